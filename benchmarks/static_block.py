r"""Cost of the static block per steady frame, and the run's peak memory: tree A against tree B.

What it measures: :func:`sionnafmcw.simulation.simulate` of a scene (``--scene``, default the
``circle_walk`` scene built with ``--frames`` frames) with radar ``walk-77ghz`` and the path
engine's defaults (the static scene cached per pose, the multi-bounce rule on), frames
``0 .. --frames - 1``, in a subprocess per run (``--worker``) that imports ``sionnafmcw`` from its
tree (``--tree-a``: a checkout, e.g. ``git archive 96945cb | tar -x -C /tmp/treeA``; ``--tree-b``
default this one), limiting glibc to one arena first as the command line does. A and B alternate
(``--rounds`` pairs, the order swapped every round) so that the machine's load hits them alike.
Per run: wall and CPU seconds (user + system, every thread) of frame 0 (scene load, the static
block rendered and its beat cube synthesised once) and per steady frame (1 ..); the engine's own
wall seconds per steady frame (median of its ``stats``) and the CPU seconds of the thread that calls
it (numpy's share of the engine; Dr.Jit's pool and the synthesis thread apart); the peak resident
size (``ru_maxrss``, MiB), the static block's PO samples; B's last beat cube against A's of the same
round (largest difference over A's largest magnitude: 0 when the echoes are bit for bit the same).

    PYTHONPATH=. python benchmarks/static_block.py --tree-a /tmp/treeA [--scene DIR] [--frames 24] [--rounds 2]

Measured
--------
2-core AMD EPYC shared with other sessions (load average 6-9: wall seconds stretched, only the
interleaved ratios and the CPU seconds compare); A = main at 96945cb (``git archive 96945cb | tar -x
-C /tmp/mb/treeA``), B = the static block held once, its constant render fields shared, the
blocking test through :class:`~sionnafmcw.engines.static_scene.RayIndex`. Every B cube equals A's
bit for bit (``B vs A cube`` 0.00e+00).

The circle walk (``scenes.build('circle_walk', '/tmp/mb/cw', num_frames=30)``), 12 frames, 2 rounds::

    PYTHONPATH=. python benchmarks/static_block.py --tree-a /tmp/mb/treeA --scene /tmp/mb/cw --frames 12 --rounds 2

    run  first wall first cpu  wall/fr  cpu/fr engine wall engine cpu peak MiB static PO  B vs A cube
    A1        16.10     11.20    1.369   0.986       0.964      0.391     2418    739508
    B1        16.22     12.91    1.363   0.939       1.038      0.383     2088    739508  0.00e+00
    A2        18.57     12.03    1.890   1.031       1.506      0.409     2414    739508
    B2        20.13     12.85    1.606   0.999       1.235      0.396     2092    739508  0.00e+00
    B/A cpu: 0.953, 0.970; engine_cpu: 0.981, 0.970; peak: 0.863, 0.866

(20 frames, 2 rounds: peak 0.865, 0.880; CPU 0.964, 1.013.) One walker of 13 parts blocks few
static segments: its blocking test was 0.03-0.06 CPU-s of a frame, and the walk's steady frames
cost what they cost (CPU 0.95-1.01 of A); the memory is the gain.

Three walkers in the furnished room (``people``, ``num_people=3, activity='walk', seed=1``, the
furniture of ``benchmarks/furnished_room.py``, 8 frames at 24 fps), 8 frames, 2 rounds::

    PYTHONPATH=. python benchmarks/static_block.py --tree-a /tmp/mb/treeA --scene /tmp/mb/room --frames 8 --rounds 2

    run  first wall first cpu  wall/fr  cpu/fr engine wall engine cpu peak MiB static PO  B vs A cube
    A1        30.70     19.75    4.331   2.545       2.845      1.225     3762    929882
    B1        30.39     19.41    3.842   2.156       3.316      1.040     3240    929882  0.00e+00
    A2        30.36     19.11    4.180   2.438       3.170      1.237     3766    929882
    B2        30.52     18.55    3.663   2.053       3.524      1.053     3220    929882  0.00e+00
    B/A first_cpu: 0.983, 0.970; wall: 0.887, 0.876; cpu: 0.847, 0.842; engine_cpu: 0.849, 0.851;
    peak: 0.861, 0.855

The engine alone, one process per tree one after the other, 5 steady frames after two
(``Spheres.meet`` and the new index timed; ``frame 0``: the engine's peak after the static block):
the blocking test 1.13 -> 0.17 s wall a frame, the engine 2.34 -> 1.47 CPU-s a frame (Dr.Jit's pool
included), its peak after frame 0 2457 -> 1919 MiB and after the frames 2759 -> 2067 MiB; the circle
walk's engine peak after frame 0 1661 -> 1398 MiB.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _cpu() -> float:
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def worker(spec: dict) -> dict:
    import sionnafmcw.heap as heap

    heap.limit_arenas(1)
    import numpy as np

    import sionnafmcw as sf
    from sionnafmcw import engines

    anim = sf.load_animation(spec["scene"])
    engine = engines.create("path")
    engine_cpu = []   # CPU seconds of the thread that runs the engine, per frame (numpy's work; Dr.Jit's pool apart)
    echoes = engine.echoes

    def timed(*a, **k):
        c = time.thread_time()
        try:
            return echoes(*a, **k)
        finally:
            engine_cpu.append(time.thread_time() - c)

    engine.echoes = timed
    store = Path(spec["out"]) / "run.zarr"
    c0, t0 = _cpu(), time.perf_counter()
    sf.simulate(anim, "walk-77ghz", engine=engine, out=store, frames=range(0, 1), progress=False)
    c1, t1 = _cpu(), time.perf_counter()
    n = spec["frames"]
    run = sf.simulate(anim, "walk-77ghz", engine=engine, out=store, frames=range(1, n), progress=False)
    c2, t2 = _cpu(), time.perf_counter()
    np.save(Path(spec["out"]) / "cube.npy", np.asarray(run.cube(n - 1)))
    figures = engine.stats[0].figures if getattr(engine, "stats", None) else {}
    return {"first_wall": t1 - t0, "first_cpu": c1 - c0, "wall": (t2 - t1) / (n - 1), "cpu": (c2 - c1) / (n - 1),
            "engine_wall": float(np.median([s.seconds for s in engine.stats[1:]])),
            "engine_cpu": float(np.median(engine_cpu[1:])),
            "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "static_po_samples": int(figures.get("static_po_samples", 0))}


def launch(tree: Path, spec: dict) -> dict:
    with tempfile.NamedTemporaryFile("r", suffix=".json", delete=False) as fh:
        result = fh.name
    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(tree), str(REPO / "benchmarks")])}
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", json.dumps(spec), "--result", result]
    proc = subprocess.run(cmd, env=env, cwd=tree, stdout=sys.stderr, stderr=sys.stderr)
    text = Path(result).read_text()
    os.unlink(result)
    if proc.returncode != 0 or not text:
        raise SystemExit(f"worker {spec['label']} failed (exit status {proc.returncode}); its output is above")
    return json.loads(text)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tree-a", help="checkout of the baseline (A), required")
    p.add_argument("--tree-b", default=str(REPO), help="checkout of the change (B, default this one)")
    p.add_argument("--scene", default=None, help="animation directory (default: circle_walk built with --frames)")
    p.add_argument("--frames", type=int, default=24)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    p.add_argument("--result", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        Path(args.result).write_text(json.dumps(worker(json.loads(args.worker))))
        return 0
    if not args.tree_a:
        p.error("--tree-a is required (a checkout of the baseline, e.g. git archive 96945cb | tar -x -C /tmp/treeA)")
    import numpy as np

    work = Path(tempfile.mkdtemp(prefix="static_block_"))
    scene = args.scene
    if scene is None:
        from sionnafmcw import scenes

        scene = str(work / "circle_walk")
        scenes.build("circle_walk", scene, num_frames=args.frames)
    trees = {"A": Path(args.tree_a).resolve(), "B": Path(args.tree_b).resolve()}
    print(f"{'run':4s} {'first wall':>10s} {'first cpu':>9s} {'wall/fr':>8s} {'cpu/fr':>7s} {'engine wall':>11s} "
          f"{'engine cpu':>10s} {'peak MiB':>8s} {'static PO':>9s}  B vs A cube")
    rows = {"A": [], "B": []}
    for r in range(args.rounds):
        cubes = {}
        for name in ("A", "B") if r % 2 == 0 else ("B", "A"):
            out = work / f"{name}{r}"
            res = launch(trees[name], {"label": f"{name}{r}", "scene": scene, "frames": args.frames, "out": str(out)})
            rows[name].append(res)
            cubes[name] = np.load(out / "cube.npy")
        for name in ("A", "B"):
            res = rows[name][-1]
            diff = ""
            if name == "B":
                diff = f"{np.abs(cubes['B'] - cubes['A']).max() / np.abs(cubes['A']).max():.2e}"
            print(f"{name}{r + 1:<3d} {res['first_wall']:10.2f} {res['first_cpu']:9.2f} {res['wall']:8.3f} "
                  f"{res['cpu']:7.3f} {res['engine_wall']:11.3f} {res['engine_cpu']:10.3f} {res['peak']:8.0f} "
                  f"{res['static_po_samples']:9d}  {diff}", flush=True)
    for key in ("first_cpu", "wall", "cpu", "engine_wall", "engine_cpu", "peak"):
        ratios = [b[key] / a[key] for a, b in zip(rows["A"], rows["B"])]
        print(f"B/A {key}: " + ", ".join(f"{x:.3f}" for x in ratios))
    return 0


if __name__ == "__main__":
    sys.exit(main())
