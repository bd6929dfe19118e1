"""Point-cloud statistics (sionnafmcw.validation.point_cloud_statistics) on recordings whose figures are
known by construction, on the real RadHAR training split against the figures its README states, and the
moving-point figures of a real recording against an independent count."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sionnafmcw.ti.formats.radhar import Recording, read_dataset
from sionnafmcw.validation.point_cloud_statistics import NEAR_RANGE, recording_statistics, signed_doppler_bins

RADHAR = next((p / "shared" / "realdata" / "radhar" / "train" for p in Path(__file__).resolve().parents
               if (p / "shared" / "realdata" / "radhar" / "train").is_dir()), Path("shared/realdata/radhar/train"))


#: The Doppler grid of the hand-made recordings: 0.6 m/s per bin, 16 loops (the driver's doppler_bin = k + 8).
STEP, OFFSET = 0.6, 8


def recording(points_per_frame, velocities, ranges, z, frames=None):
    """A recording of the driver's fields; ``frames`` numbers the frames (default 0, 1, ...), gaps allowed."""
    frames = np.arange(len(points_per_frame)) if frames is None else np.asarray(frames)
    frame = np.repeat(frames, points_per_frame).astype(np.int32)
    point_id = np.concatenate([np.arange(n) for n in points_per_frame]).astype(np.int32)
    n = frame.size
    r = np.asarray(ranges, np.float32)
    v = np.asarray(velocities, np.float32)
    return Recording(frame=frame, point_id=point_id, x=r, y=np.zeros(n, np.float32), z=np.asarray(z, np.float32),
                     range=r, velocity=v, doppler_bin=(np.rint(v / STEP) + OFFSET).astype(np.int32),
                     bearing=np.zeros(n, np.float32), intensity=np.linspace(20, 30, n).astype(np.float32),
                     stamp=np.zeros(n), activity="test", source="hand-made")


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


def test_no_recordings_is_a_clear_error():
    with pytest.raises(ValueError, match="no recordings"):
        recording_statistics([])


def test_pooled_recordings_are_the_concatenation():
    a = recording([2, 2], [0, 0.6, 0, 0], [1, 2, 3, 4], [0, 0, 0, 0])
    b = recording([4], [0.6, 0.6, 0, 0], [1, 2, 3, 4], [0, 0, 0, 0])
    s = recording_statistics([a, b])
    assert s["frames"] == 3 and s["points_per_frame"]["median"] == 2
    assert s["zero_velocity_share"] == pytest.approx(5 / 8)


def test_moving_points_of_a_known_recording():
    """Frames 0, 1, 3 and 4 have points (frame 2 none: not counted, as a RadHAR recording cannot show it).
    Beyond 0.3 m: frame 0 one point at bin +1 and one at -2; frame 1 only static; frame 3 a static point and a
    near one at bin +3 (left out); frame 4 bins +1, +1, -1 and 0."""
    counts = [3, 2, 2, 4]
    v = [0.6, -1.2, 0.0, 0.0, 0.0, 0.0, 1.8, 0.6, 0.6, -0.6, 0.0]
    ranges = [2.0, 2.5, 0.1, 1.0, 1.5, 2.0, 0.2, 1.0, 1.1, 1.2, 3.0]
    rec = recording(counts, v, ranges, np.zeros(11), frames=[0, 1, 3, 4])
    assert signed_doppler_bins(rec).tolist() == [1, -2, 0, 0, 0, 0, 3, 1, 1, -1, 0]
    s = recording_statistics(rec)
    assert s["frames"] == 4
    m = s["moving"]
    assert m["points_per_frame"] == 5 / 4                       # 2 in frame 0, 3 in frame 4
    assert m["frames_without"] == 2 / 4                         # frames 1 and 3
    assert m["share_bin_1"] == 4 / 9 and m["share_bin_2_or_more"] == 1 / 9   # of the 9 points beyond 0.3 m
    assert s["zero_velocity_share"] == 4 / 9
    # pooled with a recording of one frame with one moving point: the sums, not the mean of the figures
    other = recording([1], [1.2], [2.0], [0.0])
    p = recording_statistics([rec, other])["moving"]
    assert p["points_per_frame"] == 6 / 5 and p["frames_without"] == 2 / 5
    assert p["share_bin_1"] == 4 / 10 and p["share_bin_2_or_more"] == 2 / 10


def test_signed_bins_from_the_fields_alone():
    # no static point: the grid (0.6147 m/s, bin 8 static) from the lowest and highest bins
    v = np.float32(0.6147) * np.array([-3, 1, 2], np.float32)
    rec = Recording(**{**recording([3], [0, 0, 0], [1, 1, 1], [0, 0, 0]).arrays(), "activity": "test",
                       "source": "hand-made"} | {"velocity": v, "doppler_bin": np.array([5, 9, 10], np.int32)})
    assert signed_doppler_bins(rec).tolist() == [-3, 1, 2]
    # all static in one bin: k = 0; all moving in one bin: the grid cannot be told
    assert signed_doppler_bins(recording([2], [0, 0], [1, 1], [0, 0])).tolist() == [0, 0]
    with pytest.raises(ValueError, match="hand-made: every point is at doppler_bin 9"):
        signed_doppler_bins(recording([2], [0.6, 0.6], [1, 1], [0, 0]))
    # a velocity off the others' grid: named, with its bin
    bad = recording([3], [0.0, 0.6, 1.2], [1, 1, 1], [0, 0, 0])
    bad = Recording(**{**bad.arrays(), "activity": "test", "source": "hand-made"}
                    | {"velocity": np.array([0.0, 0.9, 1.2], np.float32)})
    with pytest.raises(ValueError, match="hand-made: point 1 has velocity 0.9 m/s at doppler_bin 9"):
        recording_statistics(bad)


@pytest.mark.skipif(not RADHAR.is_dir(), reason=f"no RadHAR training split at {RADHAR}")
def test_moving_points_of_a_real_recording_against_an_independent_count():
    """RadHAR's .cfg has 16 loops: the driver's doppler_bin 8 is the zero-Doppler bin. Frames are counted
    here from the dump's point_id restarts, moving points from doppler_bin != 8, directly."""
    from sionnafmcw.ti.formats.radhar import read_recording

    path = sorted((RADHAR / "boxing").glob("*.npz"))[0]
    rec = read_recording(path)
    with np.load(path) as data:
        pid, dbin, rng = data["point_id"], data["doppler_bin"].astype(int), data["range"]
    frame = np.cumsum(np.concatenate([[0], np.diff(pid) <= 0]))
    far = rng >= 0.3
    moving = far & (dbin != 8)
    frames = frame[-1] + 1
    m = recording_statistics(rec)["moving"]
    assert m["points_per_frame"] == pytest.approx(moving.sum() / frames, rel=1e-12)
    assert m["frames_without"] == pytest.approx(1 - np.unique(frame[moving]).size / frames, rel=1e-12)
    assert m["share_bin_1"] == pytest.approx(np.sum(far & (np.abs(dbin - 8) == 1)) / far.sum(), rel=1e-12)
    assert m["share_bin_2_or_more"] == pytest.approx(np.sum(far & (np.abs(dbin - 8) >= 2)) / far.sum(), rel=1e-12)
    assert moving.sum() > 100 and 0 < m["frames_without"] < 1    # a recording with something to count


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
