r"""Where a person's returns go in the xWR14xx (SDK 1.x/2.x) on-chip chain: CFAR, peak grouping, the point limit.

Evidence, not a fit: for frames of a run store (a simulated person) this follows the person's
range-Doppler cells through :mod:`sionnafmcw.ti.oob`'s steps, and for point clouds (real RadHAR
recordings and their simulated exports) it sets the moving points' share and intensity against range.

Per frame (:func:`frame_budget`), with :math:`D` the detection matrix, :math:`n` the range CFAR's
noise estimate and :math:`T` the ``cfarCfg`` threshold (all in the matrix's log2 Q9 units times
:math:`N/N'`, :math:`D = 384(\overline{\log_2|X|} + 8)` for 12 of 16 antennas):

* ``margin`` :math:`= D - (n + T)`; a cell is a CFAR detection when it is positive. Reported in
  log2 units (:math:`/ 2^9 N/N'`) and in dB (:math:`\times 20\log_{10}2 = 6.02` dB per log2 unit
  of the antenna-averaged magnitude).
* the person's cells: range bins from the nearest to the farthest joint :math:`\pm 0.1` m; static
  is Doppler bin 0, moving every other bin;
* CFAR detections at the person's moving cells before and after ``peakGrouping`` and the range
  window, and the detections of the whole frame against the point limit (100 points in the xWR14xx
  demo, 64 with an elevated transmitter): whether the room's returns use up the budget.

Why a static body takes its own neighbouring Doppler bins: the demo's Hanning window
(:math:`w_l = \tfrac12(1-\cos\tfrac{2\pi l}{L-1})`) makes a zero-Doppler tone of amplitude
:math:`A` appear at Doppler bin :math:`\pm 1` with
:math:`|\sum_l w_l e^{-j2\pi l/N_d}| / \sum_l w_l` of its peak (:func:`hanning_leakage`; 0.547,
-5.2 dB, for :math:`L = N_d = 16`), so every strong static cell has CFAR detections at
:math:`\pm 1` that ``peakGrouping``'s Doppler rule removes (the centre is greater), and a limb
moving at one bin survives only where it is stronger than the static body in its range bin.

The person's echo level (:func:`range_gated_power`, :func:`effective_rcs`): per chirp and channel
the Blackman-windowed range FFT :math:`Y_b` of :math:`N_f` points; Parseval gives
:math:`\sum_b |Y_b|^2 = N_f \sum_k |x_k w_k|^2`, so :math:`p_b = |Y_b|^2 / (N_f \sum_k w_k^2)` sums over
the bins to the power :math:`|a|^2` of a tone :math:`a e^{j\omega k}` and white noise of power
:math:`P_n = k T_0 F F_s` per sample puts :math:`P_n / N_f` in every bin. The power of the returns
from a range span is :math:`P = \sum_{b \in \text{gate}} p_b - P_n G / N_f` (:math:`G` bins: the
span and three bins each side, the Blackman main lobe), averaged over chirps and channels. With
:math:`P = P_t |a|^2` and the radar equation
:math:`|a|^2 = \lambda^2 G_t G_r \sigma / ((4\pi)^3 R^4)` (the element gains at the
direction, :func:`sionnafmcw.antenna.antenna_gain`) the effective RCS is
:math:`\sigma = P (4\pi)^3 R^4 / (P_t G_t G_r \lambda^2)`: the target's RCS as the board's beam
and IF chain see it (the high-pass corners take :math:`\prod_i f_b^2/(f_b^2+f_i^2)` off a beat
frequency :math:`f_b`; static clutter inside the gate, such as the floor under the person, counts).

Per recording set (:func:`moving_share_by_range`): points beyond ``near`` (0.3 m), their share at
non-zero Doppler (the ROS driver's velocity is the signed bin times :math:`\Delta v`), the
:math:`|{\rm bin}|` histogram, and per range band the moving share and the 5/50/95 % intensity
(:math:`10\log_{10}(\mathrm{peakVal}+1)`) of moving and static points.

    python validation/detection_budget.py --run ITEM/run.zarr [--run ...] [--frames 0,10,20]
        [--real ../shared/realdata/radhar/train] [--synthetic DIR]

prints a table per run and per point-cloud set, and the metrics JSON last.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

#: Range bands (m) of :func:`moving_share_by_range`.
RANGE_BANDS = ((0.3, 1.5), (1.5, 2.5), (2.5, 3.5), (3.5, 5.0))
#: Margin (m) added on each side of the person's joints' range span to take its range bins.
PERSON_MARGIN = 0.1
#: Range bins added on each side of a span by :func:`range_gated_power` (the Blackman main lobe).
GATE_MARGIN_BINS = 3
#: dB per log2 unit of a magnitude.
DB_PER_LOG2 = 20 * math.log10(2)


def hanning_leakage(num_chirps: int, offset: int = 1) -> float:
    r"""Magnitude at Doppler bin ``offset`` of a zero-Doppler tone relative to bin 0, through the
    demo's Q17 Hanning window and the :math:`N_d`-point FFT (:math:`N_d` the next power of two)."""
    from ..ti.oob import hanning_q17

    w = hanning_q17(num_chirps)
    size = 1 << math.ceil(math.log2(num_chirps))
    spectrum = np.abs(np.fft.fft(w, n=size))
    return float(spectrum[offset % size] / spectrum[0])


def range_gated_power(cube, radar, span_m: tuple[float, float], noise: bool = True) -> float:
    """Mean received power (W) per sample and channel of the returns from ranges ``span_m`` (module
    docstring); ``noise``: subtract the receiver noise's share of the gate."""
    from ..constants import BOLTZMANN, T0
    from ..ti.oob import blackman_q17

    cube = np.asarray(cube)
    window = blackman_q17(radar.num_samples)
    size = 1 << math.ceil(math.log2(radar.num_samples))
    step = 299792458.0 * radar.fs / (2 * radar.slope * size)
    low = max(int(math.floor(span_m[0] / step)) - GATE_MARGIN_BINS, 0)
    high = min(int(math.ceil(span_m[1] / step)) + GATE_MARGIN_BINS, size - 1)
    spectrum = np.fft.fft(cube * window, n=size, axis=-1)[..., low:high + 1]
    power = float(np.mean(np.sum(np.abs(spectrum) ** 2, axis=-1))) / (size * float(np.sum(window ** 2)))
    if noise:
        power -= BOLTZMANN * T0 * 10 ** (radar.noise_figure / 10) * radar.fs * (high - low + 1) / size
    return power


def effective_rcs(power: float, radar, distance: float, azimuth: float, elevation: float = 0.0) -> float:
    """RCS (m^2) that gives the received ``power`` (W) at ``distance`` (m) in the direction
    (``azimuth``, ``elevation``, rad, radar frame) through the radar's element pattern (module docstring)."""
    from ..antenna import antenna_gain, direction_angles
    from ..echoes import target_direction

    gain = float(np.squeeze(antenna_gain(radar.antenna_pattern, *direction_angles(target_direction(azimuth, elevation)))))
    wavelength = 299792458.0 / radar.fc
    return power * (4 * np.pi) ** 3 * distance ** 4 / (radar.tx_power * gain ** 2 * wavelength ** 2)


def frame_budget(cube, radar, processing, person_range_m: tuple[float, float]) -> dict:
    """The person's cells through CFAR and peak grouping in one frame (module docstring); SDK 2.x only.

    ``person_range_m``: the nearest and farthest range (m) of the person's body in this frame."""
    from ..ti.oob import OobError, _Array, cfar, detection_matrix, doppler_fft, peak_grouping, range_spectra
    from ..ti.processing import MAX_POINTS_ELEVATION_SDK2

    if processing.sdk != 2:
        raise OobError("the detection budget follows the SDK 1.x/2.x (xWR14xx) chain; this .cfg is SDK 3.x")
    array = _Array(radar)
    nv = array.num_virtual
    spectra = range_spectra(np.asarray(cube), radar).reshape(radar.num_chirps, nv, -1)
    if processing.clutter_removal:
        spectra = spectra - spectra.mean(axis=0, keepdims=True)
    exact = np.transpose(doppler_fft(spectra, 2, rounded=False), (2, 0, 1))          # [R, D, V]
    det = detection_matrix(exact, 2)
    n_range, n_doppler = det.shape
    range_step = 299792458.0 * radar.fs / (2 * radar.slope * n_range)
    per_log2 = 512.0 * nv / (1 << math.ceil(math.log2(nv)))
    hits, noise = cfar(det, processing.cfar_range, 2, nv)
    margin = det.astype(np.int64) - (noise + processing.cfar_range.threshold_counts(2, nv))
    low = max(int(math.floor((person_range_m[0] - PERSON_MARGIN) / range_step)), 0)
    high = min(int(math.ceil((person_range_m[1] + PERSON_MARGIN) / range_step)), n_range - 1)
    person = np.zeros(n_range, bool)
    person[low:high + 1] = True
    dopplers, ranges = np.nonzero(hits.T)                 # the HWA's order: Doppler bin by Doppler bin
    pg = processing.peak_grouping
    window = (ranges >= pg.start_range_index) & (ranges <= pg.end_range_index)
    grouped = window & peak_grouping(det, ranges, dopplers, pg.in_range, pg.in_doppler,
                                     pg.start_range_index, pg.end_range_index)
    limit = processing.max_points if not array.elevation.size else min(processing.max_points,
                                                                       MAX_POINTS_ELEVATION_SDK2)
    at_person, moving = person[ranges], dopplers != 0
    magnitude = np.abs(exact).mean(axis=-1)               # [R, D], int16 units, mean over antennas
    floor = float(np.median(magnitude[n_range // 2:, n_doppler // 4: 3 * n_doppler // 4]))
    moving_margin = margin[person][:, 1:]
    beyond = np.r_[2:n_doppler - 1]                      # |bin| >= 2: beyond the static body's Hanning leakage
    return {
        "person_bins": [low, high],
        "cfar_hits": int(hits.sum()), "after_grouping": int(grouped.sum()), "point_limit": int(limit),
        "person_static_hits": int(np.sum(at_person & ~moving)),
        "person_moving_hits": int(np.sum(at_person & moving)),
        "person_static_kept": int(np.sum(grouped & at_person & ~moving)),
        "person_moving_kept": int(np.sum(grouped & at_person & moving)),
        "moving_margin_log2": float(moving_margin.max() / per_log2),
        "static_margin_log2": float(margin[person][:, 0].max() / per_log2),
        "noise_floor": floor,
        "person_static_over_floor_db": float(20 * np.log10(magnitude[person][:, 0].max() / floor)),
        "person_moving_over_floor_db": float(20 * np.log10(magnitude[person][:, 1:].max() / floor)),
        "moving_beyond_leakage_margin_log2": float(margin[person][:, beyond].max() / per_log2),
        "person_moving_beyond_leakage_hits": int(np.sum(at_person & (np.abs(np.where(dopplers >= n_doppler // 2,
                                                                                     dopplers - n_doppler,
                                                                                     dopplers)) >= 2))),
    }


def run_budget(store, frames=None, processing=None) -> dict:
    """:func:`frame_budget` on frames of a run store with one person (default: every tenth done
    frame), and the body segments' radial speeds against half a Doppler bin."""
    from ..geometry import world_to_radar
    from ..store import RunStoreError, open_run
    from ..ti.oob import run_processing

    run = open_run(store)
    processing = run_processing(run, processing)
    radar = run.radar
    done = run.done_frames
    frames = done[::10] if frames is None else np.asarray(frames, int)
    missing = sorted(set(frames.tolist()) - set(done.tolist()))
    if missing:
        raise RunStoreError(f"{store}: frames {missing} are not done (done: {done.size} of {run.num_frames}); "
                            "give --frames among the done ones")
    joints = run.joint_positions()[:, 0]
    centre = run.phase_centre
    rows = []
    for f in frames.tolist():
        span = np.linalg.norm(joints[f] - centre, axis=-1)
        extent = (float(np.nanmin(span)), float(np.nanmax(span)))
        cube = run.cube(f)
        pose = run.pose_at(f)
        body = world_to_radar(np.nanmean(joints[f], axis=0), pose.position, pose.orientation) - radar.phase_centre
        distance = float(np.linalg.norm(body))
        azimuth, elevation = math.atan2(body[1], body[0]), math.asin(body[2] / distance)
        rcs = effective_rcs(range_gated_power(cube, radar, extent), radar, distance, azimuth, elevation)
        rows.append({"frame": f, **frame_budget(cube, radar, processing, extent),
                     "body_azimuth_deg": math.degrees(azimuth), "body_elevation_deg": math.degrees(elevation),
                     "effective_rcs_dbsm": 10 * math.log10(rcs) if rcs > 0 else float("-inf")})
    doppler_step = radar.centre_wavelength / (2 * radar.num_tx * radar.chirp_interval *
                                              (1 << math.ceil(math.log2(radar.num_chirps))))
    speed = np.abs(np.asarray(run.dataset["truth_radial_velocity"].values))[done]
    names = list(run.objects)
    moving = speed >= doppler_step / 2
    return {"store": str(store), "activity": str(run.activities()[int(done[0]), 0]) if run.people else "",
            "person_range_m": float(np.median(np.linalg.norm(joints[done] - centre, axis=-1))),
            "doppler_step": float(doppler_step),
            "segments_moving_share": {n: float(s) for n, s in zip(names, moving.mean(axis=0))},
            "segments_max_speed": {n: float(s) for n, s in zip(names, speed.max(axis=0))},
            "frames": rows}


def moving_share_by_range(recordings, doppler_step: float, near: float = 0.3) -> dict:
    """Moving share, :math:`|\\mathrm{bin}|` histogram and intensity per range band of point clouds
    (:class:`~sionnafmcw.ti.formats.radhar.Recording`, pooled; module docstring)."""
    far = [np.asarray(r.range) >= near for r in recordings]
    pick = (lambda key: np.concatenate([np.asarray(getattr(r, key))[m] for r, m in zip(recordings, far)])
            if recordings else np.zeros(0))
    rng, velocity, intensity = pick("range"), pick("velocity"), pick("intensity")
    bins = np.rint(velocity / doppler_step).astype(int)
    moving = bins != 0

    def pct(a):
        return [round(float(v), 1) for v in np.percentile(a, (5, 50, 95))] if a.size >= 5 else None

    bands = {}
    for lo, hi in RANGE_BANDS:
        s = (rng >= lo) & (rng < hi)
        bands[f"{lo:g}-{hi:g} m"] = {"points": int(s.sum()),
                                     "moving_share": float(moving[s].mean()) if s.any() else float("nan"),
                                     "moving_intensity_db": pct(intensity[s & moving]),
                                     "static_intensity_db": pct(intensity[s & ~moving])}
    return {"points": int(rng.size), "moving_share": float(moving.mean()) if rng.size else float("nan"),
            "abs_bin_share": {str(k): float(np.mean(np.abs(bins) == k)) for k in range(0, 9)} if rng.size else {},
            "bands": bands}


def _point_cloud_sets(root: Path, doppler_step: float) -> dict:
    from ..ti.formats.radhar import read_recording

    out = {}
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such folder; give a RadHAR-format folder of <class>/*.npz")
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        files = sorted(folder.glob("*.npz"))
        if files:
            out[folder.name] = moving_share_by_range([read_recording(f) for f in files], doppler_step)
    if not out:
        raise FileNotFoundError(f"{root}: no <class>/*.npz point clouds here; give a RadHAR-format folder")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", type=Path, action="append", default=[], help="a run store of one person (repeatable)")
    parser.add_argument("--frames", help="frame indices, comma-separated (default: every tenth done frame)")
    parser.add_argument("--real", type=Path, help="RadHAR's folder of <class>/*.npz recordings")
    parser.add_argument("--synthetic", type=Path, help="a RadHAR-format export of simulated runs")
    args = parser.parse_args(argv)
    try:
        frames = None if args.frames is None else [int(f) for f in args.frames.split(",")]
    except ValueError:
        print(f"error: --frames must be comma-separated integers, got {args.frames!r}", file=sys.stderr)
        return 2
    from ..store import RunStoreError
    from ..ti.oob import OobError

    metrics: dict = {"hanning_leakage_bin1": hanning_leakage(16), "runs": [], "point_clouds": {}}
    for store in args.run:
        try:
            budget = run_budget(store, frames)
        except (RunStoreError, OobError, FileNotFoundError) as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        metrics["runs"].append(budget)
        moving = sorted(((s, n) for n, s in budget["segments_moving_share"].items()), reverse=True)[:4]
        print(f"{store}: {budget['activity']} at {budget['person_range_m']:.2f} m; segments at >= half a bin "
              f"(share of frames): {', '.join(f'{n} {s:.2f}' for s, n in moving)}")
        for row in budget["frames"]:
            print(f"  frame {row['frame']:3d}: CFAR {row['cfar_hits']:3d}, grouped {row['after_grouping']:3d} "
                  f"(limit {row['point_limit']}); person static {row['person_static_hits']}->"
                  f"{row['person_static_kept']}, moving {row['person_moving_hits']}->{row['person_moving_kept']}; "
                  f"best margin static {row['static_margin_log2'] * DB_PER_LOG2:+.1f} dB, moving "
                  f"{row['moving_margin_log2'] * DB_PER_LOG2:+.1f} dB (|bin| >= 2: "
                  f"{row['moving_beyond_leakage_margin_log2'] * DB_PER_LOG2:+.1f} dB, "
                  f"{row['person_moving_beyond_leakage_hits']} hits); over floor static "
                  f"{row['person_static_over_floor_db']:.1f} dB, moving {row['person_moving_over_floor_db']:.1f} dB; "
                  f"effective RCS {row['effective_rcs_dbsm']:.1f} dBsm at {row['body_azimuth_deg']:+.0f} deg")
    step = (metrics["runs"][0]["doppler_step"] if metrics["runs"] else 0.614668667316)
    for label, root in (("real", args.real), ("synthetic", args.synthetic)):
        if root is None:
            continue
        try:
            sets = _point_cloud_sets(root, step)
        except (FileNotFoundError, KeyError) as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        metrics["point_clouds"][label] = sets
        for name, s in sets.items():
            print(f"{label} {name}: {s['points']} points beyond 0.3 m, moving {s['moving_share']:.3f}; " +
                  "; ".join(f"{band} moving {b['moving_share']:.3f} of {b['points']}"
                            for band, b in s["bands"].items()))
    print(json.dumps(metrics))
    return 0


__all__ = ["DB_PER_LOG2", "GATE_MARGIN_BINS", "PERSON_MARGIN", "RANGE_BANDS", "effective_rcs", "frame_budget",
           "hanning_leakage", "main", "moving_share_by_range", "range_gated_power", "run_budget"]
