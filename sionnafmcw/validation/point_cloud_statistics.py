r"""Statistics of a TI point-cloud recording, the same for simulated and real ones.

A recording is a :class:`~sionnafmcw.ti.formats.radhar.Recording` (the ROS driver's published
points, as RadHAR stores them; simulated runs become one through
:func:`~sionnafmcw.ti.formats.radhar.recording_from_frames`), so that both sides pass through the
driver's own filter and quantities. Per recording, or per class over several:

* points per frame: mean, median, 5 and 95 % quantiles over the frames;
* ``zero_velocity_share``: the share of points in the zero-Doppler bin (the driver's velocity is
  the signed bin times :math:`\Delta v`, exactly 0 there) among the points beyond ``near_range`` (0.3 m: the Tx-Rx leakage and DC points every real frame
  has near the sensor are left out, RadHAR README);
* intensity: median and 5-95 % (dB, :math:`10\log_{10}(\mathrm{peakVal}+1)` for SDK 1.x/2.x);
* the person's extent: 5-95 % of the points' height :math:`z` and forward range :math:`x`
  beyond ``near_range``.

Frames with no published point do not appear in a RadHAR recording (the driver publishes
nothing for them), so the statistics count only frames with at least one point, for both sides.
"""

from __future__ import annotations

import numpy as np

#: Points nearer than this (m) are the sensor's own leakage/DC detections, left out of the shares.
NEAR_RANGE = 0.3


def recording_statistics(recordings, near_range: float = NEAR_RANGE) -> dict:
    """The statistics of one recording or a list of recordings pooled (plain floats, JSON-ready)."""
    if not isinstance(recordings, (list, tuple)):
        recordings = [recordings]
    counts = np.concatenate([r.points_per_frame() for r in recordings]) if recordings else np.zeros(0)
    far = [np.asarray(r.range) >= near_range for r in recordings]
    velocity = np.concatenate([np.asarray(r.velocity)[m] for r, m in zip(recordings, far)])
    intensity = np.concatenate([np.asarray(r.intensity) for r in recordings])
    z = np.concatenate([np.asarray(r.z)[m] for r, m in zip(recordings, far)])
    x = np.concatenate([np.asarray(r.x)[m] for r, m in zip(recordings, far)])

    def q(a, p):
        return float(np.quantile(a, p)) if a.size else float("nan")

    return {
        "frames": int(counts.size),
        "points": int(sum(r.num_points for r in recordings)),
        "points_per_frame": {"mean": float(counts.mean()) if counts.size else float("nan"),
                             "median": q(counts, 0.5), "p05": q(counts, 0.05), "p95": q(counts, 0.95)},
        "zero_velocity_share": float(np.mean(velocity == 0)) if velocity.size else float("nan"),
        "intensity_db": {"median": q(intensity, 0.5), "p05": q(intensity, 0.05), "p95": q(intensity, 0.95)},
        "height_m": {"p05": q(z, 0.05), "p95": q(z, 0.95)},
        "forward_m": {"p05": q(x, 0.05), "median": q(x, 0.5), "p95": q(x, 0.95)},
    }

