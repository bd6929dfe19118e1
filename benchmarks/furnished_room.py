"""The cost per frame of a furnished room with three people against the paper's circle walk.

    PYTHONPATH=. /work/main/.venv/bin/python benchmarks/furnished_room.py [--frames 24] [--scenes DIR] [--json PATH]

Two scenes, the same radar (``walk-77ghz``), the same frames (``--frames``, at 24 fps) and the same
path engine (its defaults: 1e5 rays per source, two bounces, PO, the static-scene cache):

* A: ``circle_walk`` with its defaults (one person, 4.52 m/s on the 3 m circle: the 100-frame lap, of
  which the first ``--frames`` are simulated; 8 mm body meshes, a 9.5 x 8 x 3 m room);
* B: ``people`` with three people walking (straight at 1.4 m/s, the Boulic walker, 8 mm meshes, ``seed`` 1) in its
  room (7.5 x 9.7 x 3 m) furnished with a table, a monitor on it, four chairs, a sofa, shelves, a
  metal cabinet and a door (``furniture_seed`` 1);
* C: B without its furniture (the same three people in the same bare room): B/C is what the
  furniture costs, C/A what two more people cost.

In one process, A, B and C take turns frame by frame (the order rotating each frame, so a drift of
the machine's load falls on all alike): each frame is the work of ``simulate`` without the store write -- the engine's
echoes, then the beat synthesis with thermal noise and the static block's cube cached per scene
(``synthesize(..., static_cache=...)``), timed apart, in wall and CPU seconds (user + system of the
process: all threads). The first frame of each scene (scene load, kernel compilation, the static
block traced and rendered once) is reported apart; the steady state is the mean over the other
frames. Also printed: the engine's per-frame figures (``trace_seconds``, ``adapt_seconds``,
``po_seconds``, ``geometry_seconds``, ``static_seconds``; paths, PO samples, the static block's
paths and samples) as means over the steady frames, and the scenes' sizes.

Measured
--------
``PYTHONPATH=. python benchmarks/furnished_room.py --frames 48 --scenes /tmp/bench`` on the shared
2-core machine (load average 4-6 from other work: the per-frame seconds are stretched, the ratios
interleaved)::

    A: circle_walk: 1 people, 13 moving objects (191276 triangles), 6 static objects (72 triangles)
    B: people_48: 3 people, 39 moving objects (520498 triangles), 19 static objects (660 triangles)
    C: people_48: 3 people, 39 moving objects (520498 triangles), 6 static objects (72 triangles)

          first s wall s  cpu s engine  synth  trace  adapt     po  geom.  paths po samples stat. paths stat. po
    A        3.85  0.984  0.850  0.820  0.164  0.247  0.013  0.363  0.163   7950      78717        7946   287786
    B        8.24  2.522  2.245  1.999  0.523  0.272  0.030  1.148  0.441   7793     236679        7762   225298
    C        8.09  2.560  2.229  2.011  0.548  0.255  0.029  1.142  0.443   7968     236749        7946   228376

cost per frame, furnished room with three people / circle walk (B/A): wall 2.56, CPU 2.64 (first frames
2.14); the furniture (B/C): wall 0.986, CPU 1.007; three people in a bare room against the walk (C/A):
wall 2.60, CPU 2.62. The furniture costs nothing per frame (it is in the static block, traced and
rendered once: its first frame, B against C, +0.15 s); the people cost what their bodies do: three
times the PO samples of the moving surfaces (the PO render, 0.36 -> 1.15 s), 2.7 times the moving
triangles whose acceleration structure Mitsuba rebuilds every frame (geometry 0.16 -> 0.44 s), three
moving echo sets in the synthesis (0.16 -> 0.52 s); Sionna's ray shooting barely changes (0.25 ->
0.27 s). The circle walk's single person moves at 4.52 m/s, the three walkers at 1.4 m/s.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from walk_frames import cpu_seconds  # noqa: E402

FURNITURE = dict(tables=1, monitors=1, chairs=4, sofas=1, shelves=1, cabinets=1, doors=1, furniture_seed=1)


def build(folder: Path, frames: int) -> dict:
    from sionnafmcw import scenes

    out = {}
    for label, name, params in (("A", "circle_walk", {}),                # its 100-frame lap: 4.52 m/s
                                ("B", "people", {"num_people": 3, "activity": "walk", "seed": 1, "num_frames": frames,
                                                 "fps": 24.0, **FURNITURE}),
                                ("C", "people", {"num_people": 3, "activity": "walk", "seed": 1, "num_frames": frames,
                                                 "fps": 24.0})):
        path = folder / (f"{label}_{name}" if label == "A" else f"{label}_{name}_{frames}")
        if not (path / "animation.json").is_file():
            t0 = time.perf_counter()
            scenes.build(name, path, **params)
            print(f"built {name} in {time.perf_counter() - t0:.1f} s: {path}")
        out[label] = path
    return out


def describe(label, anim) -> str:
    from sionnafmcw.animation.ply import read_ply_cached

    xml = anim.frame_xml(0)
    triangles = {"moving": 0, "static": 0}
    for name, shape in xml.shapes.items():
        kind = "moving" if name in anim.object_names else "static"
        triangles[kind] += len(read_ply_cached(shape.filename).faces)
    people = anim.people.count if anim.people is not None else 0
    return (f"{label}: {anim.path.name}: {people} people, {len(anim.object_names)} moving objects "
            f"({triangles['moving']} triangles), {len(xml.shapes) - len(anim.object_names)} static objects "
            f"({triangles['static']} triangles)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=24, help="frames per scene (default 24)")
    parser.add_argument("--scenes", default=None, help="folder of the two scenes (built there when missing)")
    parser.add_argument("--json", default=None, help="write the per-frame figures here")
    args = parser.parse_args(argv)
    if not 2 <= args.frames <= 100:
        parser.error("--frames must be within 2..100 (the first frame is reported apart; the lap has 100)")

    from sionnafmcw import PathEngine, RadarConfig, load_animation, synthesize

    folder = Path(args.scenes) if args.scenes else Path(tempfile.mkdtemp(prefix="furnished_room_"))
    paths = build(folder, args.frames)
    anims = {k: load_animation(p) for k, p in paths.items()}
    radar = RadarConfig.preset("walk-77ghz")
    engines = {k: PathEngine() for k in anims}
    caches = {k: {} for k in anims}
    for k, a in anims.items():
        print(describe(k, a))
    rows = {k: [] for k in anims}
    labels = list(anims)
    for f in range(args.frames):
        for k in labels[f % len(labels):] + labels[:f % len(labels)]:
            anim, engine = anims[k], engines[k]
            w0, c0 = time.perf_counter(), cpu_seconds()
            echoes = engine.echoes(anim, radar, f)
            w1, c1 = time.perf_counter(), cpu_seconds()
            synthesize(echoes, radar, frame_time=anim.frames[f].time, noise=True,
                       rng=np.random.default_rng([0, f]), static_cache=caches[k])
            w2, c2 = time.perf_counter(), cpu_seconds()
            stats = engine.last_stats
            rows[k].append({"frame": f, "engine_s": w1 - w0, "engine_cpu_s": c1 - c0, "synthesis_s": w2 - w1,
                            "synthesis_cpu_s": c2 - c1, "wall_s": w2 - w0, "cpu_s": c2 - c0,
                            "contributions": int(echoes.num_contributions), **{
                                n: float(v) for n, v in stats.figures.items() if isinstance(v, (int, float))}})
        last = {k: rows[k][-1] for k in labels}
        print(f"frame {f:3d}: " + "  ".join(f"{k} {r['wall_s']:6.2f} s (engine {r['engine_s']:5.2f}, synthesis "
                                            f"{r['synthesis_s']:5.2f})" for k, r in last.items()), flush=True)

    def mean(k, key, first=False):
        values = [r.get(key, math.nan) for r in rows[k][(0 if first else 1):(1 if first else None)]]
        return float(np.mean(values))

    if args.json:
        Path(args.json).write_text(json.dumps({"frames": args.frames, "rows": rows}, indent=1))
    print(f"\nwalk-77ghz, {args.frames} frames each, PathEngine() defaults; steady state = mean of frames 1..")
    keys = [("wall_s", "wall s"), ("cpu_s", "cpu s"), ("engine_s", "engine"), ("synthesis_s", "synth"),
            ("trace_seconds", "trace"), ("adapt_seconds", "adapt"), ("po_seconds", "po"),
            ("geometry_seconds", "geometry"), ("num_traced_paths", "paths"), ("po_samples", "po samples"),
            ("static_paths", "static paths"), ("static_po_samples", "static po")]
    print(f"{'':8}{'first s':>9}" + "".join(f"{h:>13}" for _, h in keys))
    for k in labels:
        print(f"{k:8}{mean(k, 'wall_s', first=True):9.2f}" + "".join(f"{mean(k, key):13.3f}" for key, _ in keys))
    ratio_wall = mean("B", "wall_s") / mean("A", "wall_s")
    ratio_cpu = mean("B", "cpu_s") / mean("A", "cpu_s")
    print(f"\ncost per frame, furnished room with three people / circle walk (B/A): wall {ratio_wall:.2f}, CPU "
          f"{ratio_cpu:.2f} (first frames: {mean('B', 'wall_s', True) / mean('A', 'wall_s', True):.2f})")
    print(f"the furniture (B/C): wall {mean('B', 'wall_s') / mean('C', 'wall_s'):.3f}, CPU "
          f"{mean('B', 'cpu_s') / mean('C', 'cpu_s'):.3f}; three people in a bare room against the walk (C/A): wall "
          f"{mean('C', 'wall_s') / mean('A', 'wall_s'):.2f}, CPU {mean('C', 'cpu_s') / mean('A', 'cpu_s'):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
