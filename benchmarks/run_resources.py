r"""CPU threads, C heap and frame queue of a run (:mod:`sionnafmcw.threads`, :mod:`sionnafmcw.heap`,
:data:`sionnafmcw.simulation.PENDING_FRAMES`): steady frames under eight settings.

What it measures: ``simulate`` of a scene (default: the ``circle_walk`` scene, built when
``--scene`` is not given) with radar ``walk-77ghz`` and engine ``--engine`` (default ``path``,
options ``--engine-options``), over ``--frames`` steady frames (frames 2.., after two warm-up
frames in a run of their own: scene load and kernel compilation):

* wall and CPU seconds per frame (``ru_utime + ru_stime`` of the process, every thread);
* the resident size (``/proc/self/statm``) after the warm-up and after the last frame, its growth
  between them (MiB), and the peak (``ru_maxrss``);
* with ``trimmed``, the seconds of the trim per frame;

under the settings

* ``before``: a run before :mod:`sionnafmcw.threads` (Dr.Jit's pool at every core, OpenBLAS at
  every core): ``run_threads`` replaced by a no-op in that worker;
* ``blas1``: BLAS at one thread, Dr.Jit at every core (``threads = cores + 1``);
* ``default``: the defaults of ``simulate`` (BLAS one thread, Dr.Jit ``cores - 1``; glibc's arena
  per thread);
* ``arena1``: the defaults in a process that limits glibc to one arena first thing
  (:func:`sionnafmcw.heap.limit_arenas`, as the command line does);
* ``trimmed``: the defaults with the free pages handed back to the OS after every frame is
  written (glibc ``malloc_trim(0)``), the alternative measured and not used;
* ``synthesis2``: ``arena1`` with the synthesis's finufft pool at every core within the run (as
  before :func:`sionnafmcw.threads.synthesis_threads`: ``threads // 2``);
* ``queue1``: ``arena1`` with one frame's echoes waiting for the synthesis stage at most (as before
  :data:`sionnafmcw.simulation.PENDING_FRAMES` = 2);
* ``nocatchup``: ``arena1`` with the synthesis at ``threads // 2`` even while it is behind the
  engine (:func:`sionnafmcw.threads.synthesis_catching_up` a no-op).

Each run is its own subprocess (``--worker``); the settings are interleaved round by round
(``--rounds``) so that the machine's load hits them alike; ratios are against the first setting of
the same round. Every run's last beat cube is compared with the first setting's of its round
(largest difference over the largest magnitude): threads and the heap change nothing but the
order of floating-point sums at most.

    python benchmarks/run_resources.py [--scene DIR] [--frames 40] [--rounds 3] [--settings ...]
        [--engine path] [--engine-options '{"static_scene": false}']

Measured
--------
On the 2-core machine, nothing else running: the figures and their commands are in the
docstrings of :mod:`sionnafmcw.threads` and :mod:`sionnafmcw.heap`.
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

SETTINGS = ("before", "blas1", "default", "arena1", "trimmed", "synthesis2", "queue1", "nocatchup")


def _resident_mib() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def worker(setting: str, scene: str, frames: int, out: str, engine_name: str, engine_options: dict) -> dict:
    import contextlib
    import ctypes

    import sionnafmcw.heap as heap_module

    if setting in ("arena1", "synthesis2", "queue1", "nocatchup"):
        heap_module.limit_arenas(1)     # as the command line does, before any thread of the run
    import sionnafmcw as sf
    import sionnafmcw.threads as threads_module
    from sionnafmcw import engines
    from sionnafmcw.store import RunStore
    from sionnafmcw.threads import available_cores, engine_threads

    threads = None
    if setting == "before":
        threads_module.run_threads = lambda threads=None: contextlib.nullcontext(None)   # the old behaviour
    elif setting == "blas1":
        threads = available_cores() + 1
    elif setting == "synthesis2":
        threads_module.synthesis_threads = lambda threads: available_cores()
    elif setting == "queue1":
        import sionnafmcw.simulation as simulation_module

        simulation_module.PENDING_FRAMES = 1
    elif setting == "nocatchup":
        threads_module.synthesis_catching_up = lambda active=True: contextlib.nullcontext()
    trim = [0.0, 0]
    if setting == "trimmed":
        malloc_trim = ctypes.CDLL("libc.so.6").malloc_trim
        write_frame = RunStore.write_frame

        def write_and_trim(*a, **k):
            written = write_frame(*a, **k)
            t0 = time.perf_counter()
            malloc_trim(0)
            trim[0] += time.perf_counter() - t0
            trim[1] += 1
            return written

        RunStore.write_frame = write_and_trim
    anim = sf.load_animation(scene)
    engine = engines.create(engine_name, **engine_options)
    store = Path(out) / "run.zarr"
    sf.simulate(anim, "walk-77ghz", engine=engine, out=store, frames=range(0, 2), progress=False, threads=threads)
    trim[:] = [0.0, 0]
    resident0 = _resident_mib()
    usage = resource.getrusage(resource.RUSAGE_SELF)
    c0, t0 = usage.ru_utime + usage.ru_stime, time.perf_counter()
    run = sf.simulate(anim, "walk-77ghz", engine=engine, out=store, frames=range(2, 2 + frames), progress=False,
                      threads=threads)
    wall = time.perf_counter() - t0
    usage = resource.getrusage(resource.RUSAGE_SELF)
    resident1 = _resident_mib()
    import drjit as dr
    import numpy as np

    cube = np.asarray(run.cube(2 + frames - 1))
    np.save(Path(out) / "cube.npy", cube)
    used = dr.thread_count() if setting == "before" else engine_threads(threads or available_cores())
    return {"setting": setting, "wall": wall / frames, "cpu": (usage.ru_utime + usage.ru_stime - c0) / frames,
            "drjit_threads": used, "resident_start": resident0, "resident_end": resident1,
            "peak": usage.ru_maxrss / 1024, "trim_ms": 1e3 * trim[0] / max(trim[1], 1)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=None, help="animation directory (default: build circle_walk)")
    p.add_argument("--frames", type=int, default=40, help="steady frames per run (default 40)")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=SETTINGS)
    p.add_argument("--engine", default="path")
    p.add_argument("--engine-options", type=json.loads, default={}, help="engine options as JSON")
    p.add_argument("--json", default=None)
    p.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    p.add_argument("--out", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.worker, args.scene, args.frames, args.out, args.engine, args.engine_options)))
        return 0
    import numpy as np

    scene = args.scene
    tmp = Path(tempfile.mkdtemp(prefix="run_resources_"))
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
                       "--out", str(out), "--engine", args.engine, "--engine-options", json.dumps(args.engine_options)]
                done = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
                if done.returncode:
                    sys.stderr.write(done.stderr)
                    raise SystemExit(f"run_resources: the {setting} worker failed (exit {done.returncode})")
                row = json.loads(done.stdout.strip().splitlines()[-1])
                row["round"] = r
                cubes[setting] = np.load(out / "cube.npy")
                ref = cubes[args.settings[0]]
                row["cube_difference"] = float(np.max(np.abs(cubes[setting] - ref)) / np.max(np.abs(ref)))
                rows.append(row)
                print(f"round {r} {setting:9s} wall {row['wall']:.3f} s/frame  cpu {row['cpu']:.3f} s/frame  "
                      f"dr.jit threads {row['drjit_threads']}  resident {row['resident_start']:.0f} -> "
                      f"{row['resident_end']:.0f} MiB (+{row['resident_end'] - row['resident_start']:.0f}), peak "
                      f"{row['peak']:.0f} MiB  trim {row['trim_ms']:.1f} ms/frame  cube diff "
                      f"{row['cube_difference']:.1e}", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    base = args.settings[0]
    print(f"\n{args.engine} {json.dumps(args.engine_options)}, per frame over {args.frames} steady frames, "
          f"{args.rounds} round(s); ratios against {base} of the same round")
    ref = {r["round"]: r for r in rows if r["setting"] == base}
    for setting in args.settings:
        mine = [r for r in rows if r["setting"] == setting]
        wall = [r["wall"] / ref[r["round"]]["wall"] for r in mine]
        cpu = [r["cpu"] / ref[r["round"]]["cpu"] for r in mine]
        growth = [r["resident_end"] - r["resident_start"] for r in mine]
        print(f"{setting:9s} wall {np.mean([r['wall'] for r in mine]):.3f} s  cpu {np.mean([r['cpu'] for r in mine]):.3f} s"
              f"  wall/{base} {' / '.join(f'{x:.3f}' for x in wall)} (mean {np.mean(wall):.3f})"
              f"  cpu/{base} {' / '.join(f'{x:.3f}' for x in cpu)} (mean {np.mean(cpu):.3f})"
              f"  resident growth {' / '.join(f'{x:+.0f}' for x in growth)} MiB")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
