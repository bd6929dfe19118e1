"""Beat synthesis: today's fast sum against the noise-budgeted one, interleaved in one process.

Two cubes:

* ``bench``: walk-77ghz timing and array with 128 chirps x 256 samples (12 channels), random point
  targets (1-12 m, +-8 m/s, +-60 deg azimuth, +-20 deg elevation, 0.01-1 m^2) at 100, 1k, 10k and
  65k contributions per channel;
* ``walk``: the walk-77ghz preset itself (256 chirps x 128 samples) with a walk frame's echoes: a
  point-target frame (3000 body contributions at 3-4.5 m, radial velocity N(0, 2 m/s), 1 m^2 in
  all; 4000 diffuse static contributions at 1-11 m, 0.1 m^2 in all; 8 specular wall/floor returns
  of 1-20 m^2 at 2-6 m; 20 multipath returns beyond the unambiguous range); the same without the
  specular returns (its echo sum over the noise, ~50, is that of the engines' circle-walk
  frames); and, with
  ``--engine-frames``, the path and pixel engines' circle-walk frames of
  ``tests/data/engine_reference.npz`` (committed version; a 2-frame lap, so the body moves at
  ~230 m/s, 25x the unambiguous velocity: a stress case, slow for both methods).

Methods, timed alternately in this process (the machine is shared: medians of ``--repeat``):

* ``today``: ``sionnafmcw/synthesis/nufft.py`` as it was at ``--baseline`` (default: the commit
  before the noise budget), loaded from git: a double-precision plan per channel at tol 1e-7;
* ``new``: :func:`~sionnafmcw.synthesis.beat_nufft` with the budget ``synthesize`` uses with
  noise on (error 20 dB below the thermal noise per sample), channels sharing plans;
* ``new-tight``: the same code with noise off (tight tolerances, double precision).

For each case it prints the settings chosen (Taylor terms, finufft tolerance, precision), the
error bound and the error measured against the direct sum on ``--subset`` chirps, both relative
to the budget, and ``||fast - direct|| / ||direct||``.

    python benchmarks/synthesis.py [--sizes 100 1000 10000 65536] [--repeat 5] [--only walk|bench]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time
import types
from pathlib import Path

import numpy as np

from sionnafmcw import Echoes, RadarConfig
from sionnafmcw.synthesis import beat_direct, beat_nufft, noise_error_budget, synthesis_accuracy

ROOT = Path(__file__).resolve().parents[1]
#: The last commit with the per-channel, tol-1e-7 synthesis (before the noise budget).
BASELINE = "d40ac91"


def load_baseline(commit: str):
    """``beat_nufft`` of ``sionnafmcw/synthesis/nufft.py`` at ``commit`` (relative imports: today's package)."""
    source = subprocess.run(["git", "show", f"{commit}:sionnafmcw/synthesis/nufft.py"], cwd=ROOT,
                            capture_output=True, text=True, check=True).stdout
    module = types.ModuleType("baseline_nufft")
    module.__package__ = "sionnafmcw.synthesis"
    exec(compile(source, f"{commit}:sionnafmcw/synthesis/nufft.py", "exec"), module.__dict__)
    return module.beat_nufft


def bench_radar() -> RadarConfig:
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


def walk_frame(radar, body=3000, diffuse=4000, specular=8, seed=0) -> Echoes:
    """A walk frame's typical echoes as point targets (see the module docstring)."""
    rng = np.random.default_rng(seed)
    person = Echoes.point_targets(
        radar, rng.uniform(3.0, 4.5, body), np.clip(rng.normal(0.0, 2.0, body), -6, 6),
        np.deg2rad(rng.uniform(-6, 6, body)), np.deg2rad(rng.uniform(-20, 10, body)), np.full(body, 1.0 / body))
    clutter = Echoes.point_targets(
        radar, rng.uniform(1.0, 11.0, diffuse), 0.0, np.deg2rad(rng.uniform(-80, 80, diffuse)),
        np.deg2rad(rng.uniform(-40, 40, diffuse)), np.full(diffuse, 0.1 / diffuse))
    specular = Echoes.point_targets(
        radar, rng.uniform(2.0, 6.0, specular), 0.0, np.deg2rad(rng.uniform(-60, 60, specular)),
        np.deg2rad(rng.uniform(-40, 0, specular)), rng.uniform(1.0, 20.0, specular))
    beyond = Echoes.point_targets(
        radar, rng.uniform(1.05, 1.5, 20) * radar.max_range, rng.normal(0.0, 1.0, 20),
        np.deg2rad(rng.uniform(-60, 60, 20)), 0.0, rng.uniform(0.01, 0.5, 20))
    return Echoes.concatenate([person, clutter, specular, beyond])


def engine_frames():
    """The circle-walk frames of tests/data/engine_reference.npz (path and pixel engines), if present."""
    import io

    blob = subprocess.run(["git", "show", "HEAD:tests/data/engine_reference.npz"], cwd=ROOT, capture_output=True)
    if blob.returncode != 0:
        return {}
    data = np.load(io.BytesIO(blob.stdout))
    out = {}
    for key in ("walk/path0/f0", "walk/pixel1/f0"):
        if f"{key}/a" in data.files:
            out[f"engine {key}"] = Echoes(data[f"{key}/a"], data[f"{key}/tau"], data[f"{key}/doppler"])
    return out


def measure(name, echoes, radar, today, repeat, subset, channels_per_plan=()):
    budget = noise_error_budget(radar)
    methods = {
        "today": lambda: today(echoes, radar),
        "new": lambda: beat_nufft(echoes, radar, max_error=budget),
        "new-tight": lambda: beat_nufft(echoes, radar),
    }
    for g in channels_per_plan:
        methods[f"new cpp={g}"] = lambda g=g: beat_nufft(echoes, radar, max_error=budget, channels_per_plan=g)
    for f in methods.values():  # warm-up: finufft, thread pool, page faults
        f()
    times = {k: [] for k in methods}
    for rep in range(repeat):
        order = list(methods) if rep % 2 == 0 else list(methods)[::-1]
        for k in order:
            t0 = time.perf_counter()
            methods[k]()
            times[k].append(time.perf_counter() - t0)
    med = {k: float(np.median(v)) for k, v in times.items()}
    accuracy = synthesis_accuracy(echoes, radar, max_error=budget)
    chirps = np.linspace(0, radar.num_chirps - 1, subset).round().astype(int)
    direct = beat_direct(echoes, radar, chirps=chirps)
    errors = {}
    for k in ("today", "new", "new-tight"):
        fast = methods[k]()[chirps]
        errors[k] = {"max_over_budget": float(np.abs(fast - direct).max() / budget),
                     "rel_norm": float(np.linalg.norm(fast - direct) / np.linalg.norm(direct))}
    strength = float(np.sqrt(radar.tx_power) * np.abs(echoes.a).sum(axis=2).max())
    row = {"case": name, "paths_per_channel": int(echoes.a.shape[2]), "today_s": med["today"], "new_s": med["new"],
           "new_tight_s": med["new-tight"], "ratio": med["today"] / med["new"],
           "ratio_tight": med["today"] / med["new-tight"], "terms": [list(t) for t in accuracy.terms],
           "nufft_tol": accuracy.nufft_tol, "dtype": accuracy.dtype,
           "bound_over_budget": accuracy.error_bound / budget, "strength_over_noise": strength / np.sqrt(radar.noise_power),
           "errors": errors, "times": times}
    print(f"{name:>26} {row['paths_per_channel']:>7} {med['today'] * 1e3:>8.1f} {med['new'] * 1e3:>8.1f} "
          f"{med['new-tight'] * 1e3:>8.1f} {row['ratio']:>6.2f} {len(accuracy.terms):>5} {accuracy.nufft_tol:>8.1e} "
          f"{accuracy.dtype:>10} {row['strength_over_noise']:>9.3g} {row['bound_over_budget']:>6.2f} "
          f"{errors['new']['max_over_budget']:>7.3f} {errors['today']['rel_norm']:>9.1e} {errors['new']['rel_norm']:>9.1e}",
          flush=True)
    extra = {k: round(v * 1e3, 1) for k, v in med.items() if k.startswith("new cpp")}
    if extra:
        print(f"{'':>26} channels per plan (ms): {extra}", flush=True)
    return row


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10000, 65536])
    parser.add_argument("--repeat", type=int, default=5, help="timed runs per method (interleaved); medians")
    parser.add_argument("--subset", type=int, default=4, help="chirps of the direct sum for the error")
    parser.add_argument("--baseline", default=BASELINE, help="git commit whose nufft.py is 'today'")
    parser.add_argument("--only", choices=["walk", "bench"])
    parser.add_argument("--engine-frames", action="store_true", help="add the engine reference frames (slow)")
    parser.add_argument("--channels-per-plan", type=int, nargs="*", default=[],
                        help="also time the new method with these channels per plan")
    args = parser.parse_args(argv)

    today = load_baseline(args.baseline)
    print("times: medians (ms) of interleaved runs; errors against the direct sum on "
          f"{args.subset} chirps; budget = 20 dB below the thermal noise per sample")
    print(f"{'case':>26} {'paths':>7} {'today':>8} {'new':>8} {'tight':>8} {'ratio':>6} {'terms':>5} {'tol':>8} "
          f"{'precision':>10} {'S/sigma':>9} {'bnd/B':>6} {'err/B':>7} {'rel today':>9} {'rel new':>9}")
    rows = []
    if args.only in (None, "walk"):
        radar = RadarConfig.preset("walk-77ghz")
        cases = {"walk point targets": walk_frame(radar), "walk, no specular": walk_frame(radar, specular=0),
                 **(engine_frames() if args.engine_frames else {})}
        for name, echoes in cases.items():
            rows.append(measure(name, echoes, radar, today, args.repeat, args.subset, args.channels_per_plan))
    if args.only in (None, "bench"):
        radar = bench_radar()
        for size in args.sizes:
            rows.append(measure(f"bench {size}", random_targets(radar, size), radar, today,
                                max(1, args.repeat if size < 20000 else args.repeat // 2), min(args.subset, 2)
                                if size > 20000 else args.subset, args.channels_per_plan))
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
