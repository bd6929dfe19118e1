"""What merging PO samples costs in accuracy and saves in contributions (the cell size of ``po_merge``).

The path engine's PO samples that fall in one cell of a fraction of the range and velocity
resolutions become one contribution per element pair (``po_render.merge_contributions``: the
channel at the carrier is kept, the beat and Doppler phase across a cell is lost). For each cell
size the script compares, on one frame, the merged echo's noise-free cube with the unmerged one:
the contributions per element pair, the cube difference (dB relative to the cube), and the largest
change of a range-Doppler cell within 40 dB of the map's peak (clutter removed). Scenes:

* ``walk``: a circle-walk frame at the engine's defaults (room, 8 mm body);
* ``plate``: a 0.2 m metal plate at 5 m turned ``--yaw`` rad (its PO integral nearly cancels).

    python benchmarks/po_merge.py [--frame 10] [--yaw 0.3] [--scene DIR]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from sionnafmcw import RadarConfig, load_animation, processing, scenes, synthesize
from sionnafmcw.engines import PathEngine
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.scenes import meshes
import sionnafmcw.engines.po_render as po_render

FRACTIONS = (1 / 16, 1 / 64, 1 / 256)


def db(x):
    return 10 * np.log10(x)


def compare(animation, radar, frame, **options):
    """Rows (fraction, contributions, cube difference dB, largest map-cell change dB) against no merge."""
    reference = PathEngine(po_merge=False, track_kernels=False, **options).echoes(animation, radar, frame)
    c0 = synthesize(reference, radar, noise=False)
    p0 = np.asarray(processing.range_doppler_map(c0, radar, clutter_removal=True).power)
    rows, default = [], po_render.MERGE_FRACTION
    try:
        for fraction in FRACTIONS:
            po_render.MERGE_FRACTION = fraction
            e = PathEngine(po_merge=True, track_kernels=False, **options).echoes(animation, radar, frame)
            c = synthesize(e, radar, noise=False)
            p = np.asarray(processing.range_doppler_map(c, radar, clutter_removal=True).power)
            strong = p0 > p0.max() * 1e-4
            rows.append((fraction, e.num_contributions, db(np.sum(np.abs(c - c0) ** 2) / np.sum(np.abs(c0) ** 2)),
                         float(np.max(np.abs(db(p[strong] / p0[strong]))))))
    finally:
        po_render.MERGE_FRACTION = default
    return reference.num_contributions, rows


def plate_scene(root: Path, yaw: float) -> Path:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from animation_helpers import write_moving_mesh_animation

    v, f = meshes.plate((0, 0, 0), (0.2, 0.2), normal=(-1, 0, 0), subdiv=2)
    v = v @ rotation_matrix((yaw, 0.0, 0.0)).T + [5.0, 0, 0]
    return write_moving_mesh_animation(root, lambda t: (v + [t, 0, 0], f), (1.0, 0, 0), num_frames=1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frame", type=int, default=10, help="circle-walk frame")
    ap.add_argument("--yaw", type=float, default=0.3, help="plate yaw (rad)")
    ap.add_argument("--scene", default=None, help="existing circle_walk animation (default: build one)")
    args = ap.parse_args()
    radar = RadarConfig.resolve("walk-77ghz")
    with tempfile.TemporaryDirectory() as tmp:
        walk = Path(args.scene) if args.scene else scenes.build("circle_walk", Path(tmp) / "walk")
        cases = (("walk", load_animation(walk), args.frame, {}),
                 ("plate", load_animation(plate_scene(Path(tmp) / "plate", args.yaw)), 0, {"diffuse": False}))
        for name, animation, frame, options in cases:
            unmerged, rows = compare(animation, radar, frame, **options)
            print(f"{name}: {unmerged} contributions per pair unmerged")
            for fraction, count, diff, cell in rows:
                print(f"  cells of 1/{round(1 / fraction)}: {count} contributions, cube difference {diff:.1f} dB, "
                      f"largest map-cell change {cell:.2f} dB")


if __name__ == "__main__":
    main()
