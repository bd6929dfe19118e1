r"""A closed rectangular room: floor, ceiling and four walls as 10 cm thick boxes.

The inner space is the axis-aligned box from ``lo`` to ``hi`` (m, world, floor at ``lo[2]``).
Materials are ITU-R P.2040 materials Sionna defines at 77 GHz (:data:`~.writer.ITU_AT_77GHZ`): walls
``concrete`` (or ``plasterboard``), floor ``floorboard``, ceiling ``plasterboard`` (or
``ceiling_board``), each with a ``scattering_coefficient`` for surface roughness. The room makes
the static clutter and the body-floor / body-wall multipath an indoor radar sees.
"""

from __future__ import annotations

import numpy as np

from . import meshes
from .writer import AnimationWriter, itu_material

WALL_THICKNESS = 0.1
WALL_MATERIALS = ("concrete", "plasterboard", "wood", "glass", "chipboard")
FLOOR_MATERIALS = ("floorboard", "concrete", "wood", "chipboard")
CEILING_MATERIALS = ("plasterboard", "ceiling_board", "concrete")


def add_room(writer: AnimationWriter, lo, hi, wall: str = "concrete", floor: str = "floorboard",
             ceiling: str = "plasterboard", scattering_coefficient: float = 0.2) -> dict:
    """Add the six room surfaces to ``writer`` as static meshes; returns ``{name: material id}``."""
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
    out = {}
    for name, (a, b, mid) in parts.items():
        v, f = meshes.box(a, b)
        writer.static(name, v, f, mid)
        out[name] = mid
    return out


__all__ = ["CEILING_MATERIALS", "FLOOR_MATERIALS", "WALL_MATERIALS", "WALL_THICKNESS", "add_room"]
