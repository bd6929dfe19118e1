"""The TI out-of-box demo's on-chip chain per frame against the beat synthesis of the same frame.

    PYTHONPATH=. .venv/bin/python benchmarks/ti_chain.py [--repeat 7]

Per radar, one frame of echoes like a person in a furnished room (3000 body contributions at
1.5-3 m, radial velocity N(0, 1 m/s), 0.5 m^2 in all; 4000 diffuse static contributions at
1-9 m, 0.1 m^2 in all; 8 specular wall/floor returns of 1-20 m^2 at 2-6 m), synthesised with noise
(:func:`sionnafmcw.synthesize`, the run's own settings) and run through
:func:`sionnafmcw.ti.oob.detect` with the radar's own ``.cfg`` processing:

* ``radhar``: RadHAR's IWR1443 ``.cfg`` (SDK 2.x chain; 3 Tx x 4 Rx, 16 loops, 240 samples);
* ``xwr18xx``: the SDK 3.x xWR18xx demo profile of ``tests/test_ti_cfg.py`` (16 loops, 256 samples).

The two steps are timed alternately in this process (the machine is shared: medians of
``--repeat``); printed: the medians, their ratio chain / synthesis, and the points per frame.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from sionnafmcw import Echoes, synthesize  # noqa: E402
from sionnafmcw.ti.cfg import read_ti_cfg  # noqa: E402
from sionnafmcw.ti.oob import detect  # noqa: E402
from sionnafmcw.ti.processing import processing_from_cfg  # noqa: E402

RADHAR = ROOT.parent.parent / "shared" / "realdata" / "radhar" / "1443es1_short_range_3d.cfg"


def cases():
    from test_ti_cfg import PROFILE_3D_18XX

    out = {"xwr18xx": PROFILE_3D_18XX}
    for candidate in (RADHAR, Path("/work/shared/realdata/radhar/1443es1_short_range_3d.cfg")):
        if candidate.exists():
            out["radhar"] = candidate.read_text()
            break
    return out


def room_frame(radar, rng):
    """Point-target echoes of a person in a furnished room (module docstring)."""
    n_body, n_static, n_specular = 3000, 4000, 8
    ranges = np.concatenate([rng.uniform(1.5, 3.0, n_body), rng.uniform(1.0, 9.0, n_static),
                             rng.uniform(2.0, 6.0, n_specular)])
    velocities = np.concatenate([rng.normal(0.0, 1.0, n_body), np.zeros(n_static + n_specular)])
    n = ranges.size
    azimuths = rng.uniform(-np.pi / 3, np.pi / 3, n)
    elevations = rng.uniform(-np.pi / 9, np.pi / 9, n)
    rcs = np.concatenate([np.full(n_body, 0.5 / n_body), np.full(n_static, 0.1 / n_static),
                          rng.uniform(1.0, 20.0, n_specular)])
    return Echoes.point_targets(radar, ranges=ranges, radial_velocities=velocities, azimuths=azimuths,
                                elevations=elevations, rcs=rcs)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    for name, text in cases().items():
        radar, processing = read_ti_cfg(text), processing_from_cfg(text)
        echoes = room_frame(radar, rng)
        synth, chain, points = [], [], []
        for k in range(args.repeat + 1):
            t0 = time.perf_counter()
            cube = synthesize(echoes, radar, rng=k)
            t1 = time.perf_counter()
            result = detect(cube, radar, processing, frame_number=k + 1)
            t2 = time.perf_counter()
            if k:                                    # the first pair warms caches and plans
                synth.append(t1 - t0)
                chain.append(t2 - t1)
                points.append(result.num_points)
        s, c = statistics.median(synth), statistics.median(chain)
        print(f"{name:8s} SDK {processing.sdk}.x  {radar.num_chirps} loops x {radar.num_tx} Tx x {radar.num_rx} Rx x "
              f"{radar.num_samples} samples, {echoes.a.shape[-1]} contributions: synthesis {s * 1e3:7.1f} ms, "
              f"chain {c * 1e3:6.1f} ms, chain / synthesis {c / s:.3f}, points per frame {min(points)}-{max(points)}")


if __name__ == "__main__":
    main()
