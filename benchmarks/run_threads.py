r"""CPU threads of a run (:mod:`sionnafmcw.threads`): the circle walk's steady frames under three settings.

What it measures: ``simulate`` of the ``circle_walk`` scene with radar ``walk-77ghz`` at the path
engine's defaults, wall and CPU seconds per frame (``ru_utime + ru_stime`` of the process, every
thread) over ``--frames`` steady frames (frames 2.., after two warm-up frames in a run of their
own: scene load and kernel compilation), under

* ``before``: what a run did before :mod:`sionnafmcw.threads` (Dr.Jit's pool at every core,
  OpenBLAS at every core): ``run_threads`` replaced by a no-op in that worker;
* ``blas1``: BLAS at one thread, Dr.Jit at every core (``threads = cores + 1``);
* ``default``: the defaults (BLAS one thread, Dr.Jit ``cores - 1``).

Each run is its own subprocess (``--worker``); the settings are interleaved round by round
(``--rounds``) so that the machine's load hits them alike; ratios are against ``before`` of the
same round. Every run's beat cubes are compared with ``before``'s of its round (largest
difference over the largest magnitude): the threads change the order of floating-point sums at
most.

    python benchmarks/run_threads.py [--scene DIR] [--frames 40] [--rounds 3]

Measured
--------
``python benchmarks/run_threads.py --scene /tmp/cw_quad --frames 60 --rounds 2`` on the 2-core
machine, nothing else running (frames 2-61 of the circle walk; every setting with the allocator's
trim after each frame, :mod:`sionnafmcw.heap`)::

    round 0 before   wall 0.426 s/frame  cpu 0.791 s/frame  dr.jit threads 2  cube diff 0.0e+00
    round 0 blas1    wall 0.386 s/frame  cpu 0.712 s/frame  dr.jit threads 2  cube diff 0.0e+00
    round 0 default  wall 0.377 s/frame  cpu 0.552 s/frame  dr.jit threads 1  cube diff 0.0e+00
    round 1 before   wall 0.429 s/frame  cpu 0.799 s/frame  dr.jit threads 2  cube diff 0.0e+00
    round 1 blas1    wall 0.384 s/frame  cpu 0.713 s/frame  dr.jit threads 2  cube diff 0.0e+00
    round 1 default  wall 0.365 s/frame  cpu 0.534 s/frame  dr.jit threads 1  cube diff 0.0e+00

    blas1    wall/before 0.907 / 0.895 (mean 0.901)  cpu/before 0.900 / 0.892 (mean 0.896)
    default  wall/before 0.887 / 0.851 (mean 0.869)  cpu/before 0.697 / 0.669 (mean 0.683)

One BLAS thread takes 10 % off the wall time and the CPU time (the OpenBLAS workers' spinning);
Dr.Jit at one worker a further 3-4 % of the wall and 20 % of the CPU (its second worker added
kernel throughput the engine barely waits for, and took the synthesis's core). The cubes are
identical bit for bit.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SETTINGS = ("before", "blas1", "default")


def worker(setting: str, scene: str, frames: int, out: str) -> dict:
    import contextlib

    import sionnafmcw as sf
    import sionnafmcw.threads as threads_module
    from sionnafmcw.threads import available_cores

    threads = None
    if setting == "before":
        threads_module.run_threads = lambda threads=None: contextlib.nullcontext(None)   # the old behaviour
    elif setting == "blas1":
        threads = available_cores() + 1
    anim = sf.load_animation(scene)
    from sionnafmcw import engines

    engine = engines.create("path")
    store = Path(out) / "run.zarr"
    sf.simulate(anim, "walk-77ghz", engine=engine, out=store, frames=range(0, 2), progress=False, threads=threads)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    c0, t0 = usage.ru_utime + usage.ru_stime, time.perf_counter()
    run = sf.simulate(anim, "walk-77ghz", engine=engine, out=store, frames=range(2, 2 + frames), progress=False,
                      threads=threads)
    wall = time.perf_counter() - t0
    usage = resource.getrusage(resource.RUSAGE_SELF)
    import drjit as dr
    import numpy as np

    from sionnafmcw.threads import engine_threads

    cube = np.asarray(run.cube(2 + frames - 1))
    np.save(Path(out) / "cube.npy", cube)
    used = dr.thread_count() if setting == "before" else engine_threads(threads or available_cores())
    return {"setting": setting, "wall": wall / frames, "cpu": (usage.ru_utime + usage.ru_stime - c0) / frames,
            "drjit_threads": used}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=None, help="circle_walk animation directory (default: build one)")
    p.add_argument("--frames", type=int, default=40, help="steady frames per run (default 40)")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=SETTINGS)
    p.add_argument("--json", default=None)
    p.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    p.add_argument("--out", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.worker, args.scene, args.frames, args.out)))
        return 0
    import numpy as np

    scene = args.scene
    tmp = Path(tempfile.mkdtemp(prefix="run_threads_"))
    if scene is None:
        from sionnafmcw import scenes

        scene = str(scenes.build("circle_walk", tmp / "scene", overwrite=True))
    rows = []
    try:
        for r in range(args.rounds):
            cubes = {}
            for setting in args.settings:
                out = tmp / f"{setting}-{r}"
                shutil.rmtree(out, ignore_errors=True)
                out.mkdir(parents=True)
                cmd = [sys.executable, __file__, "--worker", setting, "--scene", scene, "--frames", str(args.frames),
                       "--out", str(out)]
                done = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
                if done.returncode:
                    sys.stderr.write(done.stderr)
                    raise SystemExit(f"run_threads: the {setting} worker failed (exit {done.returncode})")
                row = json.loads(done.stdout.strip().splitlines()[-1])
                row["round"] = r
                cubes[setting] = np.load(out / "cube.npy")
                ref = cubes.get(args.settings[0])
                row["cube_difference"] = float(np.max(np.abs(cubes[setting] - ref)) / np.max(np.abs(ref)))
                rows.append(row)
                print(f"round {r} {setting:8s} wall {row['wall']:.3f} s/frame  cpu {row['cpu']:.3f} s/frame  "
                      f"dr.jit threads {row['drjit_threads']}  cube diff {row['cube_difference']:.1e}", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    base = args.settings[0]
    print(f"\nper frame, {args.frames} steady frames, {args.rounds} rounds; ratios against {base} of the same round")
    for setting in args.settings:
        mine = [r for r in rows if r["setting"] == setting]
        ref = {r["round"]: r for r in rows if r["setting"] == base}
        wall = [r["wall"] / ref[r["round"]]["wall"] for r in mine]
        cpu = [r["cpu"] / ref[r["round"]]["cpu"] for r in mine]
        print(f"{setting:8s} wall {np.mean([r['wall'] for r in mine]):.3f} s  cpu {np.mean([r['cpu'] for r in mine]):.3f} s"
              f"  wall/{base} {' / '.join(f'{x:.3f}' for x in wall)} (mean {np.mean(wall):.3f})"
              f"  cpu/{base} {' / '.join(f'{x:.3f}' for x in cpu)} (mean {np.mean(cpu):.3f})")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
