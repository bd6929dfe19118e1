"""Beat synthesis: fast (type-3 NUFFT) against the direct reference sum.

Cube: 3 Tx x 4 Rx = 12 channels x 128 chirps x 256 samples (a 77 GHz, 60 MHz/us chirp).
Contributions: random point targets (1-12 m, +-8 m/s, +-60 deg azimuth, +-20 deg elevation).
For each size the script times both sums in this process and prints time, ratio
(direct / fast) and the relative error ||fast - direct|| / ||direct||.

The direct sum costs O(L M N Ns P) exponentials; above ``--full-direct-max`` contributions it is
evaluated on a subset of chirps (every chirp of the subset exact) and its time scaled by
L / subset, marked "extrapolated"; the error is measured on that subset.

    python benchmarks/synthesis.py [--sizes 100 1000 10000 65536] [--subset 8]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from sionnafmcw import Echoes, RadarConfig
from sionnafmcw.synthesis import beat_direct, beat_nufft


def benchmark_radar() -> RadarConfig:
    base = RadarConfig.preset("walk-77ghz")
    return base.replace(num_chirps=128, num_samples=256, fs=10e6, name="bench-12x128x256")


def random_targets(radar, count, seed=0) -> Echoes:
    rng = np.random.default_rng(seed)
    return Echoes.point_targets(
        radar,
        ranges=rng.uniform(1.0, min(12.0, 0.9 * radar.max_range), count),
        radial_velocities=rng.uniform(-8.0, 8.0, count),
        azimuths=np.deg2rad(rng.uniform(-60, 60, count)),
        elevations=np.deg2rad(rng.uniform(-20, 20, count)),
        rcs=rng.uniform(0.01, 1.0, count),
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10000, 65536])
    parser.add_argument("--subset", type=int, default=8, help="chirps of the direct sum above --full-direct-max")
    parser.add_argument("--full-direct-max", type=int, default=1000)
    args = parser.parse_args(argv)

    radar = benchmark_radar()
    print(f"cube: {radar.num_tx * radar.num_rx} channels x {radar.num_chirps} chirps x {radar.num_samples} samples")
    print(f"{'paths':>7} {'fast s':>9} {'direct s':>10} {'ratio':>9} {'rel.error':>10}")
    rows = []
    beat_nufft(random_targets(radar, 10), radar)  # warm-up (finufft plans, thread pool)
    for size in args.sizes:
        echoes = random_targets(radar, size)
        t0 = time.perf_counter()
        fast = beat_nufft(echoes, radar)
        t_fast = time.perf_counter() - t0
        if size <= args.full_direct_max:
            chirps = np.arange(radar.num_chirps)
        else:
            chirps = np.linspace(0, radar.num_chirps - 1, args.subset).round().astype(int)
        t0 = time.perf_counter()
        direct = beat_direct(echoes, radar, chirps=chirps)
        t_direct = (time.perf_counter() - t0) * radar.num_chirps / len(chirps)
        error = np.linalg.norm(fast[chirps] - direct) / np.linalg.norm(direct)
        note = "" if len(chirps) == radar.num_chirps else f" (direct extrapolated from {len(chirps)} chirps)"
        print(f"{size:>7} {t_fast:>9.3f} {t_direct:>10.2f} {t_direct / t_fast:>9.0f} {error:>10.2e}{note}")
        rows.append({"paths": size, "fast_s": t_fast, "direct_s": t_direct, "ratio": t_direct / t_fast,
                     "rel_error": float(error), "direct_extrapolated": len(chirps) != radar.num_chirps})
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
