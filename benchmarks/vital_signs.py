"""Breathing and heart rate through the whole chain: the ``vital_signs`` scenario, the path engine, the estimator.

    PYTHONPATH=. /work/main/.venv/bin/python benchmarks/vital_signs.py [--radar ti|walk] SEED [SEED ...]

Per seed: ``vital_signs`` (a sitting person, rates, amplitudes and phases drawn from the seed, 1 mm
of postural sway, body meshes of 2 cm edges), 30 s at 25 fps, 1 m in front of the radar; the path
engine (2e4 rays per source, depth 1, PO) with thermal noise; ``sionnafmcw.processing.vital_signs``.
Radars: ``ti`` = ``ti-awr1843boost`` with one Tx and two chirps (3.44 GHz, 4.4 cm range bins);
``walk`` = ``walk-77ghz`` with one Tx, one Rx, four chirps and 64 samples (0.77 GHz, 19.5 cm bins).
Prints the truth (from the manifest), the estimates and their errors (Hz). About 3.5 min per seed
on two cores.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from sionnafmcw import PathEngine, RadarConfig, load_animation, scenes, simulate
from sionnafmcw.processing import vital_signs


def radar(kind: str) -> RadarConfig:
    if kind == "ti":
        base = RadarConfig.preset("ti-awr1843boost")
        return base.replace(num_chirps=2, tx_positions=base.tx_positions[:1], tx_order=[0], name="ti-1tx-2chirps")
    base = RadarConfig.preset("walk-77ghz")
    return base.replace(num_chirps=4, num_samples=64, tx_positions=base.tx_positions[:1],
                        rx_positions=base.rx_positions[:1], tx_order=[0], name="walk-1x1-64")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("seeds", type=int, nargs="+")
    parser.add_argument("--radar", choices=("ti", "walk"), default="ti")
    args = parser.parse_args(argv)
    rad = radar(args.radar)
    fps = 25.0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            out = scenes.build("vital_signs", Path(tmp) / f"vs{seed}", seed=seed, num_frames=750, fps=fps,
                               body_mesh_edge=0.02)
            truth = json.loads((out / "animation.json").read_text())["activity"]["vital_signs"]
            t0 = time.perf_counter()
            run = simulate(load_animation(out), rad, engine=PathEngine(samples_per_src=20_000, max_depth=1),
                           out=Path(tmp) / f"vs{seed}.zarr", progress=False, noise=True)
            est = vital_signs(run.dataset.iq.values, rad, fps)
            print(f"seed {seed} ({rad.name}, {time.perf_counter() - t0:.0f} s): breathing truth "
                  f"{truth['breathing_rate']:.4f} Hz estimate {est.breathing_rate:.4f} (error "
                  f"{est.breathing_rate - truth['breathing_rate']:+.4f}), heart truth {truth['heart_rate']:.4f} "
                  f"estimate {est.heart_rate:.4f} (error {est.heart_rate - truth['heart_rate']:+.4f}); amplitudes "
                  f"{truth['breathing_amplitude'] * 1e3:.2f} mm / {truth['heart_amplitude'] * 1e3:.3f} mm; chest bin "
                  f"{est.range:.3f} m", flush=True)


if __name__ == "__main__":
    main()
