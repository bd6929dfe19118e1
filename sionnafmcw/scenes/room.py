r"""A closed rectangular room: floor, ceiling and four walls as 10 cm thick boxes.

The inner space is the axis-aligned box from ``lo`` to ``hi`` (m, world, floor at ``lo[2]``).
Materials are ITU-R P.2040 materials Sionna defines at 77 GHz (:data:`~.writer.ITU_AT_77GHZ`): walls
``concrete`` (or ``plasterboard``), floor ``floorboard``, ceiling ``plasterboard`` (or
``ceiling_board``), each with a ``scattering_coefficient`` for surface roughness. The room makes
the static clutter and the body-floor / body-wall multipath an indoor radar sees.

A wall may have openings (doors, :mod:`.furniture`): ``openings={"wall_y0": [(lo, hi, height)]}`` cuts
the wall's box, along the wall (x for the ``y`` walls, y for the ``x`` walls), from ``lo`` to ``hi`` and
from the floor to ``height``: the wall becomes the boxes left and right of the opening and the lintel
above it, whose faces (reveals) the radar sees as a real doorway's.
"""

from __future__ import annotations

import numpy as np

from . import meshes
from .registry import Parameter
from .writer import AnimationWriter, itu_material

WALL_THICKNESS = 0.1
WALL_MATERIALS = ("concrete", "plasterboard", "wood", "glass", "chipboard")
FLOOR_MATERIALS = ("floorboard", "concrete", "wood", "chipboard")
CEILING_MATERIALS = ("plasterboard", "ceiling_board", "concrete")
#: The room's builder parameters shared by every builder that puts its scene in a room (height,
#: ITU materials, diffuse scattering; passed to :func:`add_room`).
SURFACE_PARAMETERS = {
    "room_height": Parameter(3.0, float, "m", "inner height of the room", low=2.2, high=20.0),
    "wall_material": Parameter("concrete", str, "", "ITU material of the walls", choices=WALL_MATERIALS),
    "floor_material": Parameter("floorboard", str, "", "ITU material of the floor", choices=FLOOR_MATERIALS),
    "ceiling_material": Parameter("plasterboard", str, "", "ITU material of the ceiling", choices=CEILING_MATERIALS),
    "wall_scattering": Parameter(0.2, float, "", "diffuse scattering coefficient of walls, floor, ceiling",
                                 low=0.0, high=1.0),
}


def add_room(writer: AnimationWriter, lo, hi, wall: str = "concrete", floor: str = "floorboard",
             ceiling: str = "plasterboard", scattering_coefficient: float = 0.2, openings: dict | None = None) -> dict:
    """Add the six room surfaces to ``writer`` as static meshes; returns ``{name: material id}``.
    ``openings``: ``{wall: [(lo, hi, height), ...]}`` cut out of the walls (module docstring)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    if np.any(hi - lo <= 0):
        raise ValueError(f"room: empty inner space from {lo.tolist()} to {hi.tolist()}")
    t = WALL_THICKNESS
    ids = {}
    for kind, itu_type in (("wall", wall), ("floor", floor), ("ceiling", ceiling)):
        mid, mat = itu_material(itu_type, scattering_coefficient)
        writer.add_materials(mat)
        ids[kind] = mid
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    parts = {
        "floor": ((x0 - t, y0 - t, z0 - t), (x1 + t, y1 + t, z0), ids["floor"]),
        "ceiling": ((x0 - t, y0 - t, z1), (x1 + t, y1 + t, z1 + t), ids["ceiling"]),
        "wall_x0": ((x0 - t, y0, z0), (x0, y1, z1), ids["wall"]),
        "wall_x1": ((x1, y0, z0), (x1 + t, y1, z1), ids["wall"]),
        "wall_y0": ((x0 - t, y0 - t, z0), (x1 + t, y0, z1), ids["wall"]),
        "wall_y1": ((x0 - t, y1, z0), (x1 + t, y1 + t, z1), ids["wall"]),
    }
    openings = dict(openings or {})
    unknown = sorted(set(openings) - {k for k in parts if k.startswith("wall")})
    if unknown:
        raise ValueError(f"room: openings in unknown wall(s) {', '.join(unknown)}; walls: wall_x0, wall_x1, wall_y0, "
                         "wall_y1")
    out = {}
    for name, (a, b, mid) in parts.items():
        for k, (lo_box, hi_box) in enumerate(_cut(name, a, b, openings.get(name, ()))):
            v, f = meshes.box(lo_box, hi_box)
            piece = name if k == 0 else f"{name}_{k}"
            writer.static(piece, v, f, mid)
            out[piece] = mid
    return out


def _cut(name, a, b, holes):
    """The boxes of wall ``name`` (``a`` .. ``b``) with the openings ``holes`` [(lo, hi, height)] cut out."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if not holes:
        return [(a, b)]
    axis = 0 if name.startswith("wall_y") else 1
    holes = sorted((float(lo), float(hi), float(h)) for lo, hi, h in holes)
    boxes, start = [], a[axis]
    for lo, hi, h in holes:
        if not (a[axis] < lo < hi < b[axis]) or lo < start or not (a[2] < a[2] + h < b[2]):
            raise ValueError(f"room: opening {lo:.3f}..{hi:.3f} m (height {h:.3f} m) does not fit in {name} "
                             f"({a[axis]:.3f}..{b[axis]:.3f} m, {b[2] - a[2]:.3f} m high) or overlaps another")
        left_hi, lintel_lo, lintel_hi = b.copy(), a.copy(), b.copy()
        left_lo = a.copy()
        left_lo[axis], left_hi[axis] = start, lo
        boxes.append((left_lo, left_hi))
        lintel_lo[axis], lintel_hi[axis] = lo, hi
        lintel_lo[2] = a[2] + h
        boxes.append((lintel_lo, lintel_hi))
        start = hi
    last_lo = a.copy()
    last_lo[axis] = start
    boxes.append((last_lo, b.copy()))
    return [(lo_box, hi_box) for lo_box, hi_box in boxes if np.all(hi_box - lo_box > 1e-9)]


__all__ = ["CEILING_MATERIALS", "FLOOR_MATERIALS", "SURFACE_PARAMETERS", "WALL_MATERIALS", "WALL_THICKNESS", "add_room"]
