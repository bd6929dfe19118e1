"""What turning frame 0's shading normals saves the path engine's PO render.

The walking body is 13 rigid segments, each a new PLY every frame. The PO render needs smooth
shading normals and curvature radii for every mesh (``po_render.scene_objects``). Since this
change it turns frame 0's normals by the segment's rigid motion (``po_render.rigid_motion``)
instead of recomputing them from the mesh every frame.

Two path engines at their defaults, one process, interleaved frame by frame so that load drift
hits both alike: A turns the normals (today), B recomputes them (``rigid_motion`` disabled). The
script prints the median seconds per frame after the first frame, and the ratio B / A.

    python benchmarks/po_normals.py [--frames 6] [--scene DIR]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from sionnafmcw import RadarConfig, engines, load_animation, scenes
import sionnafmcw.engines.po_render as po_render


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--scene", default=None, help="existing circle_walk animation (default: build one)")
    args = ap.parse_args()
    radar = RadarConfig.resolve("walk-77ghz")
    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(args.scene) if args.scene else scenes.build("circle_walk", Path(tmp) / "walk")
        animation = load_animation(scene)
        fit = po_render.rigid_motion
        turned, recomputed = engines.create("path"), engines.create("path")
        times = {"turned": [], "recomputed": []}
        for frame in range(args.frames):
            for name, engine, motion in (("turned", turned, fit), ("recomputed", recomputed, lambda *a, **k: None)):
                po_render.rigid_motion = motion
                t0 = time.perf_counter()
                engine.echoes(animation, radar, frame)
                times[name].append(time.perf_counter() - t0)
        po_render.rigid_motion = fit
    a, b = (float(np.median(times[k][1:])) for k in ("turned", "recomputed"))
    print(f"path engine, circle walk, frames 1-{args.frames - 1}: normals turned {a:.2f} s/frame, "
          f"recomputed {b:.2f} s/frame, ratio {b / a:.2f}")


if __name__ == "__main__":
    main()
