r"""Statistics of a TI point-cloud recording, the same for simulated and real ones.

A recording is a :class:`~sionnafmcw.ti.formats.radhar.Recording` (the ROS driver's published
points, as RadHAR stores them; simulated runs become one through
:func:`~sionnafmcw.ti.formats.radhar.recording_from_frames`), so that both sides pass through the
driver's own filter and quantities. Per recording, or per class over several:

* points per frame: mean, median, 5 and 95 % quantiles over the frames;
* ``zero_velocity_share``: the share of points in the zero-Doppler bin (the driver's velocity is
  the signed bin times :math:`\Delta v`, exactly 0 there) among the points beyond ``near_range``
  (0.3 m: the Tx-Rx leakage and DC points every real frame has near the sensor are left out,
  RadHAR README);
* intensity: median and 5-95 % (dB, :math:`10\log_{10}(\mathrm{peakVal}+1)` for SDK 1.x/2.x);
* the person's extent: 5-95 % of the points' height :math:`z` and forward range :math:`x`
  beyond ``near_range``;
* ``moving``: the moving points, those beyond ``near_range`` whose signed Doppler bin :math:`k`
  (:func:`signed_doppler_bins`, on the grid of all the recordings pooled: one sensor setting) is
  not 0 (the driver's ``velocity`` :math:`= k\,\Delta v \ne 0`):

  - ``points_per_frame``: their number divided by the number of frames;
  - ``frames_without``: the share of the frames in which none of them lies;
  - ``share_bin_1`` and ``share_bin_2_or_more``: the shares of the points beyond ``near_range`` at
    :math:`|k| = 1` and at :math:`|k| \ge 2`, so that with ``zero_velocity_share`` they sum to 1.

  A point at :math:`|k| = 1` is a cell whose strongest return moves at :math:`0.5` to
  :math:`1.5\,\Delta v` radially (0.31-0.92 m/s with RadHAR's ``.cfg``, :math:`\Delta v` = 0.615
  m/s); :math:`|k| \ge 2` is faster than :math:`1.5\,\Delta v`, a limb's speed.

Frames: frames with no published point do not appear in a RadHAR recording (the driver publishes
nothing for them, and its dumps carry no frame number), so every statistic counts only the frames
with at least one published point (at any range, the near ones included), for both sides. A
simulated recording numbers its frames by the run's frame index and leaves gaps for empty frames;
those gaps are not counted either. A frame whose only points are near or static counts, with no
moving point.
"""

from __future__ import annotations

import numpy as np

#: Points nearer than this (m) are the sensor's own leakage/DC detections, left out of the shares.
NEAR_RANGE = 0.3

#: Disagreement between ``velocity`` and :math:`k\,\Delta v` tolerated by :func:`signed_doppler_bins`,
#: relative to :math:`\Delta v`: float32 rounding of the velocities is below 1e-6 of it; a bin off by one
#: is off by all of it.
_GRID_RTOL = 1e-3


def doppler_grid(recordings) -> tuple[float, int]:
    r"""The Doppler grid of one recording or of several pooled: :math:`(\Delta v, b_0)`, the velocity step
    (m/s per bin) and the ``doppler_bin`` of zero velocity.

    The TI ROS driver writes, for a point of signed Doppler index :math:`k`
    (:mod:`~sionnafmcw.ti.formats.ros_driver`),

    .. math::
        \mathrm{velocity} = k\,\Delta v,\qquad \mathrm{doppler\_bin} = k + b_0,\qquad
        b_0 = \lfloor N_\text{loops}/2 \rfloor,

    so :math:`\mathrm{doppler\_bin} - \mathrm{velocity}/\Delta v = b_0` for every point. Neither
    :math:`\Delta v` nor :math:`N_\text{loops}` is stored; both follow from the lowest and the highest
    bin present, :math:`b_1 < b_2` with velocities :math:`v_1, v_2`: :math:`\Delta v = (v_2 - v_1)/(b_2 - b_1)`,
    :math:`b_0 = \mathrm{round}(b_1 - v_1/\Delta v)`. When every point is in one bin and static,
    :math:`b_0` is that bin and :math:`\Delta v` is NaN (not needed: every :math:`k` is 0).

    Raises ``ValueError`` when every point moves in one bin (the grid cannot be told) or the velocity
    does not grow with the bin.
    """
    if not isinstance(recordings, (list, tuple)):
        recordings = [recordings]
    b = np.concatenate([np.asarray(r.doppler_bin, np.int64) for r in recordings]) if recordings else np.zeros(0)
    v = np.concatenate([np.asarray(r.velocity, np.float64) for r in recordings]) if recordings else np.zeros(0)
    name = ", ".join(getattr(r, "source", "") or "recording" for r in recordings[:3])
    name += ", ..." if len(recordings) > 3 else ""
    if b.size == 0:
        return float("nan"), 0
    lo, hi = int(np.argmin(b)), int(np.argmax(b))
    if b[hi] == b[lo]:
        if np.any(v != 0):
            raise ValueError(f"{name}: every point is at doppler_bin {b[lo]} with a nonzero velocity; the "
                             "Doppler grid (step, zero bin) cannot be told from velocity and doppler_bin")
        return float("nan"), int(b[lo])
    step = (v[hi] - v[lo]) / (b[hi] - b[lo])
    if not step > 0:
        raise ValueError(f"{name}: velocity does not grow with doppler_bin ({v[lo]:.4g} m/s at bin {b[lo]}, "
                         f"{v[hi]:.4g} m/s at bin {b[hi]}); not the TI driver's Doppler fields")
    return float(step), int(np.rint(b[lo] - v[lo] / step))


def signed_doppler_bins(recording, grid: tuple[float, int] | None = None) -> np.ndarray:
    r"""The signed Doppler bin :math:`k` = ``doppler_bin`` :math:`- b_0` of every point of ``recording``
    (int64 ``[P]``), on ``grid`` (:func:`doppler_grid`; default: the recording's own).

    Every point is checked against the grid, :math:`|v - k\,\Delta v| \le 10^{-3}\,\Delta v`; a
    ``ValueError`` names the recording's ``source`` and the first point off it (``velocity`` and
    ``doppler_bin`` that are not one grid, or recordings of different sensor settings pooled).
    """
    step, zero = doppler_grid(recording) if grid is None else grid
    b = np.asarray(recording.doppler_bin, np.int64)
    v = np.asarray(recording.velocity, np.float64)
    k = b - zero
    expected = k * step if np.isfinite(step) else np.where(k == 0, 0.0, np.nan)
    bad = ~(np.abs(v - expected) <= _GRID_RTOL * (step if np.isfinite(step) else 0.0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        name = getattr(recording, "source", "") or "recording"
        raise ValueError(f"{name}: point {i} has velocity {v[i]:.6g} m/s at doppler_bin {b[i]}, off the "
                         f"Doppler grid ({step:.6g} m/s per bin, bin {zero} static)")
    return k


def recording_statistics(recordings, near_range: float = NEAR_RANGE) -> dict:
    """The statistics of one recording or a list of recordings pooled (plain floats, JSON-ready;
    module docstring)."""
    if not isinstance(recordings, (list, tuple)):
        recordings = [recordings]
    if not recordings:
        raise ValueError("recording_statistics: no recordings (an empty list); give one recording or a list of them "
                         "(a class without recordings has no statistics)")
    counts = np.concatenate([r.points_per_frame() for r in recordings])
    far = [np.asarray(r.range) >= near_range for r in recordings]
    velocity = np.concatenate([np.asarray(r.velocity)[m] for r, m in zip(recordings, far)])
    intensity = np.concatenate([np.asarray(r.intensity) for r in recordings])
    z = np.concatenate([np.asarray(r.z)[m] for r, m in zip(recordings, far)])
    x = np.concatenate([np.asarray(r.x)[m] for r, m in zip(recordings, far)])
    grid = doppler_grid(recordings)
    bins = [signed_doppler_bins(r, grid)[m] for r, m in zip(recordings, far)]
    k = np.abs(np.concatenate(bins)) if bins else np.zeros(0, np.int64)
    # frames holding a moving point: per recording, the distinct frame numbers of its moving points
    frames_moving = sum(np.unique(np.asarray(r.frame)[m][b != 0]).size for r, m, b in zip(recordings, far, bins))

    def q(a, p):
        return float(np.quantile(a, p)) if a.size else float("nan")

    def share(mask):
        return float(np.mean(mask)) if mask.size else float("nan")

    frames = int(counts.size)
    return {
        "frames": frames,
        "points": int(sum(r.num_points for r in recordings)),
        "points_per_frame": {"mean": float(counts.mean()) if counts.size else float("nan"),
                             "median": q(counts, 0.5), "p05": q(counts, 0.05), "p95": q(counts, 0.95)},
        "zero_velocity_share": share(velocity == 0),
        "intensity_db": {"median": q(intensity, 0.5), "p05": q(intensity, 0.05), "p95": q(intensity, 0.95)},
        "height_m": {"p05": q(z, 0.05), "p95": q(z, 0.95)},
        "forward_m": {"p05": q(x, 0.05), "median": q(x, 0.5), "p95": q(x, 0.95)},
        "moving": {"points_per_frame": float(np.count_nonzero(k)) / frames if frames else float("nan"),
                   "frames_without": (frames - frames_moving) / frames if frames else float("nan"),
                   "share_bin_1": share(k == 1), "share_bin_2_or_more": share(k >= 2)},
    }
