"""Point-cloud statistics (sionnafmcw.validation.point_cloud_statistics) on recordings whose figures are
known by construction, and on the real RadHAR training split against the figures its README states."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sionnafmcw.ti.formats.radhar import Recording, read_dataset
from sionnafmcw.validation.point_cloud_statistics import NEAR_RANGE, recording_statistics

RADHAR = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "radhar" / "train"


def recording(points_per_frame, velocities, ranges, z):
    frame = np.repeat(np.arange(len(points_per_frame)), points_per_frame).astype(np.int32)
    point_id = np.concatenate([np.arange(n) for n in points_per_frame]).astype(np.int32)
    n = frame.size
    r = np.asarray(ranges, np.float32)
    return Recording(frame=frame, point_id=point_id, x=r, y=np.zeros(n, np.float32), z=np.asarray(z, np.float32),
                     range=r, velocity=np.asarray(velocities, np.float32), doppler_bin=np.zeros(n, np.int32),
                     bearing=np.zeros(n, np.float32), intensity=np.linspace(20, 30, n).astype(np.float32),
                     stamp=np.zeros(n), activity="test")


def test_counts_shares_and_extent_of_a_known_recording():
    # three frames of 2, 3 and 5 points; the first point of each frame is a near (leakage) point
    counts = [2, 3, 5]
    ranges = [0.1, 2.0, 0.1, 2.0, 2.5, 0.1, 1.5, 2.0, 3.0, 3.5]
    v = [0.6, 0.0, 0.6, 0.6, 0.0, -0.6, 0.0, 0.0, 0.0, 1.2]   # near points' velocities must not count
    z = [5.0, 0.0, 5.0, 1.0, 0.5, 5.0, -0.5, 0.2, 0.4, 0.3]
    s = recording_statistics(recording(counts, v, ranges, z))
    assert s["frames"] == 3 and s["points"] == 10
    assert s["points_per_frame"]["median"] == 3 and s["points_per_frame"]["mean"] == pytest.approx(10 / 3)
    far = np.asarray(ranges) >= NEAR_RANGE
    assert s["zero_velocity_share"] == pytest.approx(np.mean(np.asarray(v)[far] == 0)) == pytest.approx(5 / 7)
    assert s["height_m"]["p95"] <= 1.0                      # near points (z = 5) are left out
    assert s["intensity_db"]["median"] == pytest.approx(25.0)


def test_pooled_recordings_are_the_concatenation():
    a = recording([2, 2], [0, 0.6, 0, 0], [1, 2, 3, 4], [0, 0, 0, 0])
    b = recording([4], [0.6, 0.6, 0, 0], [1, 2, 3, 4], [0, 0, 0, 0])
    s = recording_statistics([a, b])
    assert s["frames"] == 3 and s["points_per_frame"]["median"] == 2
    assert s["zero_velocity_share"] == pytest.approx(5 / 8)


@pytest.mark.skipif(not RADHAR.is_dir(), reason=f"no RadHAR training split at {RADHAR}")
def test_real_training_split_matches_its_readme():
    """The README's measured figures: medians 23 / 19 / 20 / 20 / 22 points per frame, zero-velocity
    shares 0.81 / 0.94 / 0.98 / 0.97 / 0.85 (range > 0.3 m), median intensity 29-30 dB."""
    by_class = {}
    for rec in read_dataset(RADHAR):
        by_class.setdefault(rec.activity, []).append(rec)
    readme = {"boxing": (23, 0.81), "jack": (19, 0.94), "jump": (20, 0.98), "squats": (20, 0.97), "walk": (22, 0.85)}
    for activity, (median, share) in readme.items():
        s = recording_statistics(by_class[activity])
        assert s["points_per_frame"]["median"] == median, activity
        assert abs(s["zero_velocity_share"] - share) < 0.005, activity   # the README's two decimals
        assert 29.0 <= s["intensity_db"]["median"] <= 30.5, activity
