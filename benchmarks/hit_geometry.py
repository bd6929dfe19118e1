"""The geometry of a walk frame's PO samples: numpy per object (A) against the Dr.Jit kernel (B), interleaved.

What it measures: for the circle walk's PO renders of ``--frames`` at the path engine's defaults
(each frame's own renders: the body's first bounce, its reflections, the static chains that end on
the body), the time to turn every render's hits (object, triangle, barycentrics) into world
positions, shading normals, velocities and shape operators:

* A: :meth:`sionnafmcw.engines.po_render.SceneObject.hit_geometry` object by object (numpy), as
  ``po_render._samples`` did before ``engines/hit_geometry.py``;
* B: what ``_samples`` does now: the hits on refined static and rigid surfaces in one kernel
  (:func:`sionnafmcw.engines.hit_geometry.refined_hit_geometry`), the others per object,

one after the other on the same hits, ``--repeats`` times (best of), in one process, with the
largest difference between them (positions and normals absolute, shape operators relative to
their largest entry). The kernel is compiled (or read from Dr.Jit's cache) before the timing.

    python benchmarks/hit_geometry.py [--scene DIR] [--frames 1 30 60 90] [--repeats 5]

Measured
--------
The figures and the command are in :mod:`sionnafmcw.engines.hit_geometry`.
"""

from __future__ import annotations

import argparse
import sys
import time

import walk_frames


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    walk_frames.add_arguments(p, "out/bench_hit_geometry", [1, 30, 60, 90], 5)
    args = p.parse_args(argv)

    import numpy as np

    from sionnafmcw import engines
    from sionnafmcw.engines.hit_geometry import refined_hit_geometry
    from sionnafmcw.engines.po_render import scene_objects

    anim, radar = walk_frames.load(p, args)
    engine = engines.create("path", track_kernels=False)
    cases = []
    for frame in args.frames:
        engine.echoes(anim, radar, frame)
        world = engine._state.surfaces
        objects = scene_objects(engine._loaded, world, engine._state.materials)
        index = world.index
        num_static = len(engine._state.static.po.renders)
        for b in engine.last_renders[num_static:]:
            s = b.samples
            obj = np.array([index[name] for name in s.labels], dtype=np.int64)
            cases.append((frame, b.depth, objects, world, obj, s.triangle, s.barycentric))

    def per_object(objects, world, obj, tri, bary):
        out = [np.empty((len(obj), 3)), np.empty((len(obj), 3)), np.empty((len(obj), 3)), np.empty((len(obj), 3, 3))]
        for k in np.unique(obj):
            sel = np.flatnonzero(obj == k)
            for o, value in zip(out, objects[k].hit_geometry(tri[sel], bary[sel])):
                o[sel] = value
        return out

    def with_kernel(objects, world, obj, tri, bary):
        tables = world.refined_tables()
        out = [np.empty((len(obj), 3)), np.empty((len(obj), 3)), np.empty((len(obj), 3)), np.empty((len(obj), 3, 3))]
        fast = np.flatnonzero(tables.covers(obj))
        if fast.size:
            for o, value in zip(out, refined_hit_geometry(tables, objects, obj[fast], tri[fast], bary[fast])):
                o[fast] = value
        for k in np.unique(obj[~tables.covers(obj)]):
            sel = np.flatnonzero(obj == k)
            for o, value in zip(out, objects[k].hit_geometry(tri[sel], bary[sel])):
                o[sel] = value
        return out

    with_kernel(*cases[0][2:])                                   # compile (or load) the kernel
    print(f"{'frame':<7}{'render':<10}{'hits':>8}{'numpy ms':>10}{'kernel ms':>11}{'B/A':>6}"
          f"  max |dx| m  max |dn|  max |dK|/max|K|")
    total = [0.0, 0.0]
    for frame, depth, *case in cases:
        best = [np.inf, np.inf]
        for _ in range(args.repeats):
            for k, f in enumerate((per_object, with_kernel)):    # interleaved: A then B on the same hits
                t0 = time.perf_counter()
                out = f(*case)
                best[k] = min(best[k], time.perf_counter() - t0)
                if k == 0:
                    ref = out
        dx = float(np.max(np.abs(out[0] - ref[0]), initial=0.0))
        dn = float(np.max(np.abs(out[1] - ref[1]), initial=0.0))
        dk = float(np.max(np.abs(out[3] - ref[3]), initial=0.0) / max(np.max(np.abs(ref[3]), initial=0.0), 1e-300))
        total[0] += best[0]
        total[1] += best[1]
        print(f"{frame:<7}{'bounce ' + str(depth):<10}{len(case[2]):>8}{1e3 * best[0]:>10.1f}{1e3 * best[1]:>11.1f}"
              f"{best[1] / best[0]:>6.2f}  {dx:.1e}    {dn:.1e}  {dk:.1e}")
    n = len(args.frames)
    print(f"per frame: numpy {1e3 * total[0] / n:.1f} ms, kernel {1e3 * total[1] / n:.1f} ms, B/A {total[1] / total[0]:.2f}")
    engine.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
