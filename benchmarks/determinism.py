"""What reproducibility costs in the path engine: ``deterministic=True`` (the default) against ``False``.

Scene: the circle walk (``sionnafmcw.scenes`` ``circle_walk``, the paper's scenario, room on) at the
engine's defaults (max_depth 2, 1e5 samples per source, specular + diffuse), radar walk-77ghz.

Four engines in one process, interleaved frame by frame so that load drift on a shared machine
hits both settings alike: two with ``deterministic=False`` and two with ``deterministic=True`` (the
engine's default since this benchmark showed it costs nothing per frame, while ``False`` gave
different cubes for 6 of 6 and 8 of 10 frames with the same seed), all with the same ``seed``. Per frame each engine's echoes go through the
synthesizer with the same noise generator ``default_rng([seed, frame])``, so two engines of one
setting give the same cube exactly when their echoes are the same. Printed per setting: median
seconds per frame after the first (warm-up) frame, and for how many frames the two runs'
cubes differ bit for bit, with the largest relative difference :math:`\\max|x_1 - x_2| / \\max|x_1|`.

    python benchmarks/determinism.py [--frames 6] [--samples 100000] [--start 0]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from sionnafmcw import RadarConfig, engines, load_animation, scenes
from sionnafmcw.synthesis import synthesize


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--start", type=int, default=0, help="first frame")
    ap.add_argument("--samples", type=int, default=None, help="samples_per_src (default: the engine's)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    radar = RadarConfig.resolve("walk-77ghz")
    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "walk"
        scenes.build("circle_walk", scene, num_frames=args.start + args.frames)
        animation = load_animation(scene)
        options = {} if args.samples is None else {"samples_per_src": args.samples}
        runs = {(det, k): engines.create("path", deterministic=det, seed=args.seed, **options)
                for det in (False, True) for k in (0, 1)}
        times = {key: [] for key in runs}
        cubes = {key: [] for key in runs}
        frames = list(range(args.start, args.start + args.frames))
        for f in frames:
            for key, engine in runs.items():
                t0 = time.perf_counter()
                echoes = engine.echoes(animation, radar, f)
                times[key].append(time.perf_counter() - t0)
                cubes[key].append(synthesize(echoes, radar, frame_time=animation.frames[f].time, noise=True,
                                             rng=np.random.default_rng([args.seed, f])))
            print(f"frame {f}: " + ", ".join(f"det={d} run {k}: {times[(d, k)][-1]:.2f} s"
                                             for d, k in runs), flush=True)
        print(f"\ncircle walk, walk-77ghz, path engine options {runs[(False, 0)].settings()}")
        for det in (False, True):
            steady = times[(det, 0)][1:] + times[(det, 1)][1:]
            differ = [i for i in range(len(frames)) if not np.array_equal(cubes[(det, 0)][i], cubes[(det, 1)][i])]
            rel = max((np.abs(cubes[(det, 0)][i] - cubes[(det, 1)][i]).max() / np.abs(cubes[(det, 0)][i]).max()
                       for i in range(len(frames))), default=0.0)
            print(f"deterministic={det}: median {np.median(steady):.2f} s/frame (first frame "
                  f"{np.mean([times[(det, 0)][0], times[(det, 1)][0]]):.2f} s); same seed, two runs: "
                  f"{len(differ)} of {len(frames)} frames differ (max relative difference {rel:.2e})")


if __name__ == "__main__":
    main()
