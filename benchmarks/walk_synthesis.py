"""Beat synthesis of circle-walk frames with the code of two checkouts, in turns: wall and CPU seconds.

What it measures: ``beat_nufft`` of the per-frame echoes of the path engine's circle-walk frames
(the contributions after the static block: what ``synthesize`` sums every frame) at the error
budget ``synthesize`` gives them with noise on (90 % of the budget 20 dB below the thermal noise,
``synthesis.STATIC_BUDGET_SHARE``). The echoes are computed once, here, with this checkout's
engine defaults, and written to a temporary ``.npz``; then each method runs in its own
subprocess on the same echoes, A and B in turns ``--repeats`` times:

* A: ``sionnafmcw`` of ``--tree-a`` (e.g. a ``git worktree`` of the commit before a change);
* B: ``sionnafmcw`` of ``--tree-b`` (default: this checkout).

Each run prints the settings its code chooses for the first frame (Taylor terms, finufft
tolerance, precision), the wall and CPU seconds (user + system of the process, all threads) per
frame, the median over the runs of each method and the B/A ratios; then each method's Taylor
terms of every frame (the strength vectors per channel of its transforms). The cube of the first
frame from both is compared against a tight (tolerance 1e-9) transform, relative to the budget.

    git worktree add /tmp/before HEAD~1
    python benchmarks/walk_synthesis.py --scene /tmp/cw8 --tree-a /tmp/before [--frames 2 3 4 5] [--repeats 3]

Measured
--------
The synthesis changes of the stop that added this script (``_channels`` and ``choose_accuracy``
leaner, complex64 up to twice the unambiguous Doppler) against the commit before them
(``git worktree add /tmp/before 2c9e552``), ``--scene /tmp/cw8 --tree-a /tmp/before --repeats 5``
on the 2-core AMD EPYC (frames 2-5, 9.2e4 contributions per channel in the first)::

    A: 2 terms, tol 3.27e-05, complex128, error 0.0036 of the budget
    B: 2 terms, tol 3.27e-05, complex64,  error 0.0132 of the budget
    per frame, A: 0.371 0.341 0.335 0.299 0.347 s wall, 0.552 0.488 0.494 0.445 0.514 s CPU
               B: 0.249 0.279 0.226 0.290 0.244 s wall, 0.359 0.408 0.329 0.392 0.356 s CPU
    median per frame: A 0.341 s wall, 0.494 s CPU; B 0.249 s wall, 0.359 s CPU; B/A wall 0.730, CPU 0.727

The first frame's error against a tight transform stays about a hundredth of the budget in
single precision; the bound, the same in both, fills the budget by construction.

The keystone fitted per plan (``synthesis.nufft``, "Keystone fitted per plan") and complex64
strengths from float32 phases (``_Channel.strength``) against the commit before them, on ten
frames spread over the walk (``--frames 2 12 22 32 42 52 62 72 82 92 --repeats 5``, 9.2e4
contributions per channel in the first)::

    A: Taylor terms per frame 2 1 1 1 2 2 3 2 2 1 (mean 1.70: strength vectors per channel)
    B: Taylor terms per frame 1 1 1 1 1 1 2 1 1 1 (mean 1.10)
    per frame, A: 0.326 0.408 0.313 0.442 0.375 s wall, 0.497 0.596 0.477 0.627 0.566 s CPU
               B: 0.266 0.340 0.268 0.263 0.327 s wall, 0.420 0.484 0.413 0.405 0.477 s CPU
    median per frame: A 0.375 s wall, 0.566 s CPU; B 0.268 s wall, 0.420 s CPU; B/A wall 0.715, CPU 0.741

with the first frame's error 0.0132 (A) and 0.0143 (B) of the budget. The keystone alone (an
earlier run of the same command) gave B/A wall 0.884, CPU 0.825. The frame left with two terms
keeps the :math:`l'^2` one (:math:`K_l`, quadratic in the Doppler; not fitted).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import walk_frames

REPO = Path(__file__).resolve().parents[1]


def worker(data: str, radar_name: str, reference: str | None) -> dict:
    """Time ``beat_nufft`` of the frames in ``data`` once (after a warm-up) with the ``sionnafmcw`` on the path."""
    import numpy as np

    import sionnafmcw
    from sionnafmcw import Echoes, RadarConfig
    from sionnafmcw.synthesis import STATIC_BUDGET_SHARE, beat_nufft, noise_error_budget, synthesis_accuracy

    radar = RadarConfig.resolve(radar_name)
    stored = np.load(data)
    frames = [Echoes(stored[f"a{i}"], stored[f"tau{i}"], stored[f"doppler{i}"]) for i in range(int(stored["count"]))]
    budget = (1.0 - STATIC_BUDGET_SHARE) * noise_error_budget(radar)
    accuracy = [synthesis_accuracy(echoes, radar, max_error=budget) for echoes in frames]
    first = beat_nufft(frames[0], radar, max_error=budget)          # warm-up (plans, imports)
    out = {"package": str(Path(sionnafmcw.__file__).parent), "terms": [len(a.terms) for a in accuracy],
           "tol": accuracy[0].nufft_tol, "dtype": accuracy[0].dtype}
    if reference:
        tight = np.load(reference)["cube"]
        out["error_over_budget"] = float(np.abs(first - tight).max() / budget)
    c0, t0 = walk_frames.cpu_seconds(), time.perf_counter()
    for echoes in frames:
        beat_nufft(echoes, radar, max_error=budget)
    return out | {"wall": (time.perf_counter() - t0) / len(frames),
                  "cpu": (walk_frames.cpu_seconds() - c0) / len(frames)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    walk_frames.add_arguments(p, "out/bench_walk_synthesis", [2, 3, 4, 5], 3)
    p.add_argument("--tree-a", help="checkout whose sionnafmcw runs A (required)")
    p.add_argument("--tree-b", default=str(REPO), help="checkout whose sionnafmcw runs B (default: this one)")
    p.add_argument("--worker", nargs=3, metavar=("DATA", "RADAR", "REFERENCE"), help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        data, radar_name, reference = args.worker
        print(json.dumps(worker(data, radar_name, reference or None)))
        return 0
    if not args.tree_a:
        p.error("--tree-a is required (e.g. git worktree add /tmp/before HEAD~1, then --tree-a /tmp/before)")
    for name, tree in (("a", args.tree_a), ("b", args.tree_b)):
        if not (Path(tree) / "sionnafmcw" / "__init__.py").is_file():
            p.error(f"--tree-{name} {tree}: no sionnafmcw package there (e.g. git worktree add /tmp/before HEAD~1)")

    import numpy as np

    from sionnafmcw import engines
    from sionnafmcw.synthesis import beat_nufft

    animation, radar = walk_frames.load(p, args)
    engine = engines.create("path", track_kernels=False)
    arrays = {"count": len(args.frames)}
    for i, frame in enumerate(args.frames):
        e = engine.echoes(animation, radar, frame)
        k = e.static_count
        arrays |= {f"a{i}": e.a[..., k:], f"tau{i}": e.tau[..., k:], f"doppler{i}": e.doppler[..., k:]}
    engine.close()
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "echoes.npz")
        np.savez(data, **arrays)
        from sionnafmcw import Echoes

        first = Echoes(arrays["a0"], arrays["tau0"], arrays["doppler0"])
        reference = os.path.join(tmp, "tight.npz")
        np.savez(reference, cube=beat_nufft(first, radar, nufft_tol=1e-9))
        print(f"{len(args.frames)} frames, {arrays['a0'].shape[-1]} contributions per channel in the first")
        runs = {"A": [], "B": []}
        for r in range(args.repeats):
            for method, tree in (("A", args.tree_a), ("B", args.tree_b)):
                env = os.environ | {"PYTHONPATH": str(Path(tree).resolve())}
                cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", data, args.radar,
                       reference if r == 0 else ""]
                proc = subprocess.run(cmd, env=env, cwd=REPO, capture_output=True, text=True)
                if proc.returncode != 0:
                    raise SystemExit(f"worker {method} failed:\n{proc.stderr[-3000:]}")
                result = json.loads(proc.stdout.strip().splitlines()[-1])
                runs[method].append(result)
                extra = ""
                if "error_over_budget" in result:
                    extra = f", error {result['error_over_budget']:.4f} of the budget"
                terms = result["terms"]
                print(f"{method} run {r + 1}: {terms[0]} terms, tol {result['tol']:.3g}, {result['dtype']}; "
                      f"{result['wall']:.3f} s wall, {result['cpu']:.3f} s CPU per frame{extra}  "
                      f"({result['package']})")
    median = {m: (float(np.median([x["wall"] for x in rs])), float(np.median([x["cpu"] for x in rs])))
              for m, rs in runs.items()}
    for m, rs in runs.items():   # the same in every run: the settings depend on the echoes only
        terms = rs[0]["terms"]
        print(f"{m}: Taylor terms per frame {' '.join(map(str, terms))} (mean {np.mean(terms):.2f}: strength "
              f"vectors per channel)")
    print(f"median per frame: A {median['A'][0]:.3f} s wall, {median['A'][1]:.3f} s CPU; "
          f"B {median['B'][0]:.3f} s wall, {median['B'][1]:.3f} s CPU; "
          f"B/A wall {median['B'][0] / median['A'][0]:.3f}, CPU {median['B'][1] / median['A'][1]:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
