r"""The SDK 1.x/2.x (xWR14xx) on-chip chain's scale against RadHAR's real IWR1443 point clouds.

Validation only: nothing here is fitted. RadHAR's ``.cfg`` (``cfarCfg 0 2 8 4 4 0 4000``) runs
through :func:`sionnafmcw.ti.oob.detect` on synthesised frames of

* point reflectors of a limb's to a person's radar cross-section (0.01 to 1 m\ :sup:`2`) at 2, 2.5 and 3 m,
  at azimuths uniform in +-30 deg and radial velocities uniform in +-2 m/s, receiver noise on, and
* receiver noise alone,

and the simulated ``peakVal`` of the points at the reflector's range, and the points per
noise-only frame, are set beside RadHAR's recordings (``peakVal = 10^{intensity/10} - 1``): all
points, the moving points at 1.5-3.2 m (where its people stand) and the near-range points
(< 0.3 m: the Tx-Rx leakage, which these frames do not model); and the recordings' points beyond
6 m (behind the room's walls, where only receiver noise can make a point) per frame.

    python validation/ti_sdk2_scale.py --real ../shared/realdata/radhar/train [--frames 40] [--out DIR]

prints a table and the metrics JSON last (also written to ``DIR/metrics.json``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

PERCENTILES = (1, 5, 25, 50, 75, 95, 99)
RCS_M2 = (0.01, 0.03, 0.1, 0.3, 1.0)
RANGES_M = (2.0, 2.5, 3.0)


def _radhar_cfg(real: Path) -> Path:
    for candidate in (real / "1443es1_short_range_3d.cfg", real.parent / "1443es1_short_range_3d.cfg"):
        if candidate.exists():
            return candidate
    raise FileNotFoundError(f"{real}: no 1443es1_short_range_3d.cfg here or one folder up; give RadHAR's folder")


def real_peak_values(real: Path) -> dict:
    """RadHAR's peakVal percentiles: all points, moving points at 1.5-3.2 m, points under 0.3 m."""
    files = sorted(real.rglob("*.npz"))
    if not files:
        raise FileNotFoundError(f"{real}: no RadHAR .npz recordings below this folder")
    intensity, distance, doppler, frames = [], [], [], 0
    for f in files:
        with np.load(f) as z:
            intensity.append(z["intensity"]), distance.append(z["range"]), doppler.append(z["doppler_bin"])
            frames += np.unique(z["frame"]).size
    peak = 10.0 ** (np.concatenate(intensity) / 10.0) - 1.0
    distance, doppler = np.concatenate(distance), np.concatenate(doppler)
    groups = {"all": np.ones(peak.shape, bool),
              "moving_1.5_3.2_m": (distance > 1.5) & (distance < 3.2) & (doppler != 8),
              "near_0.3_m": distance < 0.3}
    out = {name: {"points": int(mask.sum()),
                  "percentiles": dict(zip(map(str, PERCENTILES),
                                          np.percentile(peak[mask], PERCENTILES).round(1).tolist()))}
           for name, mask in groups.items()}
    # beyond the room's walls only receiver noise is left: its false alarms per frame
    out["frames"] = frames
    out["points_per_frame_beyond_6_m"] = float(np.count_nonzero(distance > 6.0) / max(frames, 1))
    return out


def simulated(cfg: Path, frames: int, seed: int = 0) -> dict:
    """Simulated peakVal per RCS (points within 2 range bins of the reflector) and the points of
    noise-only frames."""
    from ..echoes import Echoes
    from ..synthesis import synthesize
    from ..ti.cfg import read_ti_cfg
    from ..ti.oob import detect
    from ..ti.processing import processing_from_cfg

    text = cfg.read_text()
    radar, processing = read_ti_cfg(text), processing_from_cfg(text)
    rng = np.random.default_rng(seed)
    out = {}
    for rcs in RCS_M2:
        peaks, detected = [], 0
        for k in range(frames):
            distance = RANGES_M[k % len(RANGES_M)]
            echoes = Echoes.point_targets(radar, ranges=[distance], radial_velocities=[rng.uniform(-2, 2)],
                                          azimuths=[math.radians(rng.uniform(-30, 30))], elevations=[0.0], rcs=[rcs])
            points = detect(synthesize(echoes, radar, rng=int(rng.integers(1 << 31))), radar, processing)
            near = np.abs(points.range_index * points.range_step - distance) <= 2 * points.range_step
            detected += bool(near.any())
            peaks.extend(points.peak_value[near].astype(float).tolist())
        out[f"rcs_{rcs:g}_m2"] = {"frames": frames, "frames_detected": detected, "points": len(peaks),
                                  "percentiles": (dict(zip(map(str, PERCENTILES),
                                                           np.percentile(peaks, PERCENTILES).round(1).tolist()))
                                                  if peaks else {})}
    counts = []
    for _ in range(frames):
        echoes = Echoes.point_targets(radar, ranges=[2.0], radial_velocities=[0.0], azimuths=[0.0], rcs=[0.0])
        counts.append(detect(synthesize(echoes, radar, rng=int(rng.integers(1 << 31))), radar, processing).num_points)
    out["noise_only"] = {"frames": frames, "points_per_frame_mean": float(np.mean(counts)),
                         "points_per_frame_max": int(np.max(counts))}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--real", type=Path, required=True, help="RadHAR's folder of .npz recordings")
    parser.add_argument("--frames", type=int, default=40, help="simulated frames per case (default 40)")
    parser.add_argument("--out", type=Path, help="folder for metrics.json")
    args = parser.parse_args(argv)
    if args.frames < 1:
        print(f"error: --frames must be >= 1, got {args.frames}", file=sys.stderr)
        return 2
    try:
        real = real_peak_values(args.real)
        cfg = _radhar_cfg(args.real)
    except (FileNotFoundError, KeyError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    sim = simulated(cfg, args.frames)
    for name, row in {**{f"real {k}": v for k, v in real.items() if isinstance(v, dict)},
                      **{f"sim {k}": v for k, v in sim.items() if k != "noise_only"}}.items():
        print(f"{name:28s} {row['points']:8d} points  peakVal p{'/p'.join(map(str, PERCENTILES))}: "
              f"{' / '.join(f'{v:g}' for v in row['percentiles'].values())}")
    print(f"sim noise-only frames: {sim['noise_only']['points_per_frame_mean']:.2f} points per frame "
          f"(max {sim['noise_only']['points_per_frame_max']}); real beyond 6 m: "
          f"{real['points_per_frame_beyond_6_m']:.4f} points per frame over {real['frames']} frames")
    metrics = {"real": real, "simulated": sim}
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        temporary = args.out / "metrics.json.tmp"
        temporary.write_text(json.dumps(metrics, indent=1))
        temporary.replace(args.out / "metrics.json")
    print(json.dumps(metrics))
    return 0
