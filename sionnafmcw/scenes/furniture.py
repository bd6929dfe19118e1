r"""Furnished rooms: tables, chairs, sofas, shelves, metal cabinets, doors and monitors, placed at random.

The pieces
----------
Every piece is made of closed boxes (:func:`.meshes.box`) in its own frame -- origin on the floor
at the centre of its footprint, :math:`u` along its length, :math:`v` along its depth (the front
towards :math:`+v`), :math:`z` up -- turned by its yaw and written as static objects (one mesh per
material), so the path engine's static-scene cache traces them once per radar pose
(:mod:`sionnafmcw.engines.static_scene`: no per-frame cost but what the people change). Sizes
(length x depth x height, m) are round values of ordinary office and living-room furniture:

===========  ==================  =================================================  ============
kind         size                parts                                              material
===========  ==================  =================================================  ============
``table``    1.2 x 0.8 x 0.75    3 cm top, four 5 cm legs                           wood
``chair``    0.44 x 0.44 x 0.9   3 cm seat at 0.46 m, four 4 cm legs, backrest      wood
``sofa``     2.0 x 0.9 x 0.85    seat block 0.42 m, back 0.2 m deep, arms 0.6 m     upholstery
``shelves``  0.8 x 0.35 x 1.8    2 cm sides, back and five boards                   chipboard
``cabinet``  0.9 x 0.45 x 1.9    closed steel box                                   metal
``door``     0.9 x 0.04 x 2.05   door leaf in an opening of a wall                  wood
``monitor``  0.54 x 0.24 x 0.44  on a table: glass screen on a metal body, stand    glass, metal
===========  ==================  =================================================  ============

Materials at the carrier
------------------------
ITU-R P.2040-3 (Table 3) through Sionna's ``itu-radio-material``, all defined from 1 GHz (wood
from 1 MHz, glass from 0.1 GHz) to 100 GHz, so valid over the 60-81 GHz radar bands
(:func:`sionnafmcw.materials.check_itu_frequency` refuses them elsewhere): ``wood`` (tables,
chairs, doors; :math:`\varepsilon' = 1.99`), ``chipboard`` (shelves; 2.58), ``metal`` (the cabinet,
the monitor's body: perfectly conducting to within P.2040), ``glass`` (the monitor's screen; 6.31).
A sofa's surface is upholstery, a woven cover over polyurethane foam: P.2040 has no textile or foam
at 77 GHz (``carpet_tile``, its only textile, is defined only to 40 GHz). It is given
``ceiling_board`` (:math:`\varepsilon' = 1.48`, a porous mineral-fibre board, P.2040 1-100 GHz), the
P.2040 material of lowest permittivity valid at the carrier, the nearest to a foam-filled fabric
(a foam is mostly air, :math:`\varepsilon'` close to 1; a dense fabric is higher): its
normal-incidence reflectivity is -20 dB against wood's -15 dB. The engines do not transmit through
surfaces, so the sofa hides what is behind it, as its wooden frame would. Wood, chipboard and
upholstery take ``furniture_scattering`` (default 0.2) as their diffuse scattering coefficient;
metal and glass are smooth (0).

Placement (:func:`place_furniture`)
-----------------------------------
Seeded (``furniture_seed``) rejection sampling, largest pieces first: doors (in a wall), sofas,
cabinets and shelves (their back against a wall, 2 cm off it, facing into the room), tables and
chairs (anywhere, any yaw), then monitors (each on its own table, facing one of its long sides).
A draw is kept when its footprint (an oriented rectangle; a door's is the quarter-circle's square
its leaf sweeps into the room) lies inside the room, at least ``furniture_clearance`` from every
piece placed before (separating-axis test, :func:`.layout.rects_clear`), from the radar (0.3 m
around it) and from every footprint disc of every person in every frame (:mod:`.layout`); with
``furniture_clear_view`` also from the straight lines between the radar and the people's footprint
centres, widened by the footprints' radii (nothing stands between the radar and a person). After
:data:`MAX_TRIES` refused draws the piece cannot be placed: :class:`ValueError` naming it and what to
change. Pieces never overlap: every accepted footprint is separated from every other one by at least
the clearance along one axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import meshes
from .layout import Rect, point_rect_distance, rects_clear, segment_rect_distance
from .registry import Parameter

#: Draws per piece before it is declared impossible.
MAX_TRIES = 400
#: Gap (m) between a piece's back and its wall.
WALL_GAP = 0.02
#: Radius (m) kept free around the radar.
RADAR_KEEP_OUT = 0.3
#: Door leaves stay this far (m) from the room's corners.
DOOR_CORNER = 0.1

#: ``{material key: (ITU type, smooth)}``: the radio materials of the pieces (module docstring).
MATERIALS = {"wood": ("wood", False), "chipboard": ("chipboard", False), "upholstery": ("ceiling_board", False),
             "metal": ("metal", True), "glass": ("glass", True)}


def _leg_boxes(hu, hv, inset, side, height):
    return [((sx * (hu - inset) - side / 2, sy * (hv - inset) - side / 2, 0.0),
             (sx * (hu - inset) + side / 2, sy * (hv - inset) + side / 2, height))
            for sx in (-1, 1) for sy in (-1, 1)]


def _table():
    hu, hv = 0.6, 0.4
    return {"wood": [((-hu, -hv, 0.72), (hu, hv, 0.75))] + _leg_boxes(hu, hv, 0.05, 0.05, 0.72)}


def _chair():
    h = 0.22
    return {"wood": [((-h, -h, 0.43), (h, h, 0.46)), ((-h, -h, 0.46), (h, -h + 0.03, 0.9))]
            + _leg_boxes(h, h, 0.03, 0.04, 0.43)}


def _sofa():
    hu, hv = 1.0, 0.45
    return {"upholstery": [((-hu + 0.2, -hv + 0.2, 0.0), (hu - 0.2, hv, 0.42)),      # seat block
                           ((-hu, -hv, 0.0), (hu, -hv + 0.2, 0.85)),                 # back
                           ((-hu, -hv + 0.2, 0.0), (-hu + 0.2, hv, 0.6)),            # arms
                           ((hu - 0.2, -hv + 0.2, 0.0), (hu, hv, 0.6))]}


def _shelves():
    hu, hv, h, t = 0.4, 0.175, 1.8, 0.02
    boxes = [((-hu, -hv, 0.0), (-hu + t, hv, h)), ((hu - t, -hv, 0.0), (hu, hv, h)),      # sides
             ((-hu + t, -hv, 0.0), (hu - t, -hv + t, h))]                                # back
    boxes += [((-hu + t, -hv + t, z), (hu - t, hv, z + t)) for z in np.linspace(0.0, h - t, 5)]
    return {"chipboard": boxes}


def _cabinet():
    return {"metal": [((-0.45, -0.225, 0.0), (0.45, 0.225, 1.9))]}


def _door():
    return {"wood": [((-0.45, -0.02, 0.0), (0.45, 0.02, 2.05))]}


def _monitor():
    return {"metal": [((-0.27, -0.04, 0.12), (0.27, 0.0, 0.44)),          # panel body
                      ((-0.03, -0.06, 0.01), (0.03, -0.04, 0.2)),         # stand
                      ((-0.12, -0.12, 0.0), (0.12, 0.06, 0.01))],         # foot
            "glass": [((-0.265, 0.0, 0.125), (0.265, 0.004, 0.435))]}    # screen


@dataclass(frozen=True)
class Kind:
    """A kind of furniture: ``name``, ``size`` (length, depth, height) m, ``placement`` (``wall``,
    ``free``, ``door`` or ``table``), ``parts()`` -> ``{material key: [(lo, hi) boxes]}`` in its frame."""

    name: str
    size: tuple
    placement: str
    parts: object
    parameter: str = field(default="")


KINDS = {k.name: k for k in (
    Kind("door", (0.9, 0.04, 2.05), "door", _door, "doors"),
    Kind("sofa", (2.0, 0.9, 0.85), "wall", _sofa, "sofas"),
    Kind("cabinet", (0.9, 0.45, 1.9), "wall", _cabinet, "cabinets"),
    Kind("shelves", (0.8, 0.35, 1.8), "wall", _shelves, "shelves"),
    Kind("table", (1.2, 0.8, 0.75), "free", _table, "tables"),
    Kind("chair", (0.44, 0.44, 0.9), "free", _chair, "chairs"),
    Kind("monitor", (0.54, 0.24, 0.44), "table", _monitor, "monitors"),
)}
#: Placement order: the largest and the most constrained first.
ORDER = ("door", "sofa", "cabinet", "shelves", "table", "chair", "monitor")

#: The room builders' furniture parameters (:mod:`sionnafmcw.scenes.activities`,
#: :mod:`sionnafmcw.scenes.people`): how many of which.
PARAMETERS = {
    "tables": Parameter(0, int, "", "tables (1.2 x 0.8 m, wood) anywhere in the room", low=0, high=4),
    "chairs": Parameter(0, int, "", "chairs (wood) anywhere in the room", low=0, high=12),
    "sofas": Parameter(0, int, "", "sofas (2 x 0.9 m, upholstery) against a wall", low=0, high=2),
    "shelves": Parameter(0, int, "", "shelf units (0.8 x 0.35 x 1.8 m, chipboard) against a wall", low=0, high=4),
    "cabinets": Parameter(0, int, "", "metal cabinets (0.9 x 0.45 x 1.9 m) against a wall", low=0, high=3),
    "doors": Parameter(0, int, "", "doors (0.9 x 2.05 m, wood) in the walls", low=0, high=4),
    "monitors": Parameter(0, int, "", "monitors (glass screen, metal body) on the tables, one per table",
                          low=0, high=4),
    "furniture_seed": Parameter(0, int, "", "seed of the furniture's placement", low=0, high=2**31 - 1),
    "furniture_clearance": Parameter(0.1, float, "m", "least gap between pieces, and between a piece and the "
                                     "people's footprints or the radar", low=0.0, high=1.0),
    "furniture_scattering": Parameter(0.2, float, "", "diffuse scattering coefficient of wood, chipboard and "
                                      "upholstery", low=0.0, high=1.0),
    "furniture_clear_view": Parameter(True, bool, "", "keep furniture off the lines of sight between the radar and "
                                      "the people"),
}


def counts_of(p: dict) -> dict:
    """``{kind: count}`` from a builder's parameters ``p`` (those of :data:`PARAMETERS`)."""
    return {k: int(p.get(KINDS[k].parameter, 0)) for k in ORDER}


def wants_furniture(p: dict) -> bool:
    return any(counts_of(p).values())


# ============================================================================ placement
@dataclass(frozen=True)
class KeepOut:
    """What furniture must stay clear of: discs (``centres [N, 2]``, ``radii [N]``) and widened
    segments (``starts [M, 2]`` -> ``ends [M, 2]``, half-widths ``widths [M]``), m."""

    centres: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    radii: np.ndarray = field(default_factory=lambda: np.zeros(0))
    starts: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    ends: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    widths: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def clear(self, rect: Rect, gap: float) -> bool:
        if len(self.radii) and np.any(point_rect_distance(rect, self.centres) < self.radii + gap):
            return False
        if len(self.widths) and np.any(segment_rect_distance(rect, self.starts, self.ends) < self.widths + gap):
            return False
        return True


def people_keep_out(footprints, radar_xy, clear_view: bool, max_lines: int = 64) -> KeepOut:
    """:class:`KeepOut` of the people's footprints ``[(centres [T, 2], radii [T]), ...]`` and the radar at
    ``radar_xy``: every footprint disc, the radar's disc, and with ``clear_view`` the lines from the radar
    to at most ``max_lines`` footprint centres per person (evenly spread over the frames)."""
    radar_xy = np.asarray(radar_xy, float)[:2]
    centres = [np.asarray(c, float) for c, _ in footprints] + [radar_xy[None]]
    radii = [np.asarray(r, float) for _, r in footprints] + [np.array([RADAR_KEEP_OUT])]
    starts, ends, widths = [np.zeros((0, 2))], [np.zeros((0, 2))], [np.zeros(0)]
    if clear_view:
        for c, r in footprints:
            pick = np.unique(np.linspace(0, len(r) - 1, min(len(r), max_lines)).round().astype(int))
            ends.append(np.asarray(c, float)[pick])
            starts.append(np.repeat(radar_xy[None], len(pick), axis=0))
            widths.append(np.asarray(r, float)[pick])
    return KeepOut(np.concatenate(centres), np.concatenate(radii), np.concatenate(starts), np.concatenate(ends),
                   np.concatenate(widths))


@dataclass(frozen=True)
class Piece:
    """A placed piece: ``name`` (``<kind><n>``), ``kind``, ``centre`` (x, y, z of its frame's origin) m,
    ``yaw`` rad, ``footprint`` (the :class:`~.layout.Rect` kept clear), the ``wall`` a wall piece or a door
    stands against or in, a door's ``opening`` (along-wall interval (lo, hi) m, height m), the ``table``
    a monitor stands on."""

    name: str
    kind: str
    centre: tuple
    yaw: float
    footprint: Rect
    wall: str = ""
    opening: tuple = ()
    table: str = ""

    def to_dict(self) -> dict:
        k = KINDS[self.kind]
        out = {"name": self.name, "kind": self.kind, "centre": [float(x) for x in self.centre], "yaw": float(self.yaw),
               "size": list(k.size), "materials": sorted(k.parts()),
               "itu_materials": [MATERIALS[m][0] for m in sorted(k.parts())],
               "footprint": self.footprint.to_dict()}
        if self.wall:
            out["wall"] = self.wall
        if self.table:
            out["table"] = self.table
        return out


def _walls(lo, hi):
    """``{wall: (inward normal [2], along-wall axis [2], point on the inner face [2], along-wall span (a, b))}``;
    the along-wall coordinate is x for the y walls and y for the x walls (the room's coordinates)."""
    (x0, y0), (x1, y1) = lo[:2], hi[:2]
    return {"wall_x0": (np.array([1.0, 0.0]), np.array([0.0, 1.0]), np.array([x0, 0.0]), (y0, y1)),
            "wall_x1": (np.array([-1.0, 0.0]), np.array([0.0, 1.0]), np.array([x1, 0.0]), (y0, y1)),
            "wall_y0": (np.array([0.0, 1.0]), np.array([1.0, 0.0]), np.array([0.0, y0]), (x0, x1)),
            "wall_y1": (np.array([0.0, -1.0]), np.array([1.0, 0.0]), np.array([0.0, y1]), (x0, x1))}


def _yaw_facing(normal) -> float:
    """Yaw whose v axis :math:`(-\\sin\\psi, \\cos\\psi)` is ``normal``."""
    return math.atan2(-normal[0], normal[1])


def _inside(rect: Rect, lo, hi, gap) -> bool:
    c = rect.corners
    return bool(np.all(c >= np.asarray(lo[:2]) + gap - 1e-12) and np.all(c <= np.asarray(hi[:2]) - gap + 1e-12))


def place_furniture(counts: dict, room_lo, room_hi, keep_out: KeepOut | None = None, seed: int = 0,
                    clearance: float = 0.1, wall_thickness: float = 0.1) -> list[Piece]:
    """Pieces for ``counts`` ``{kind: n}`` in the room with inner box ``room_lo`` .. ``room_hi`` (m), clear
    of ``keep_out`` and of each other by ``clearance`` (module docstring); reproducible from ``seed``."""
    unknown = sorted(set(counts) - set(KINDS))
    if unknown:
        raise ValueError(f"furniture: unknown kind(s) {', '.join(unknown)}; kinds: {', '.join(ORDER)}")
    for k, n in counts.items():
        if isinstance(n, bool) or int(n) != n or n < 0:
            raise ValueError(f"furniture: the count of {k!r} must be an integer >= 0, got {n!r}")
    if counts.get("monitor", 0) > counts.get("table", 0):
        raise ValueError(f"furniture: monitors={counts['monitor']} but tables={counts.get('table', 0)}; a monitor "
                         "stands on a table of its own: add tables or remove monitors")
    lo, hi = np.asarray(room_lo, float), np.asarray(room_hi, float)
    keep_out = keep_out or KeepOut()
    rng = np.random.default_rng([int(seed), 0x46])
    walls = _walls(lo, hi)
    wall_names = sorted(walls)
    placed: list[Piece] = []
    tables: list[Piece] = []
    for kind in ORDER:
        k = KINDS[kind]
        length, depth, height = k.size
        for n in range(int(counts.get(kind, 0))):
            name = f"{kind}{n}"
            piece = None
            for _ in range(MAX_TRIES):
                if k.placement == "table":
                    free = [t for t in tables if not any(p.table == t.name for p in placed)]
                    t = free[int(rng.integers(len(free)))]
                    side = 1.0 if rng.random() < 0.5 else -1.0
                    yaw = t.yaw + (0.0 if side > 0 else math.pi)
                    r = KINDS["table"].size
                    along = rng.uniform(-(r[0] - length) / 2, (r[0] - length) / 2)
                    u = np.array([math.cos(t.yaw), math.sin(t.yaw)])
                    xy = np.asarray(t.centre[:2]) + along * u
                    piece = Piece(name, kind, (xy[0], xy[1], r[2]), yaw, Rect(tuple(xy), (length / 2, depth / 2), yaw),
                                  table=t.name)
                    break
                if k.placement in ("wall", "door"):
                    w = wall_names[int(rng.integers(len(wall_names)))]
                    normal, axis, face, (a, b) = walls[w]
                    yaw = _yaw_facing(normal)
                    margin = DOOR_CORNER if k.placement == "door" else clearance
                    if b - a - 2 * margin < length:
                        continue
                    s = rng.uniform(a + margin + length / 2, b - margin - length / 2)
                    base = face + s * axis
                    if k.placement == "door":
                        xy = base - (wall_thickness / 2) * normal
                        swing = Rect(tuple(base + (length / 2) * normal), (length / 2, length / 2), yaw)
                        rect = swing
                        centre = (xy[0], xy[1], 0.0)
                        opening = ((s - length / 2, s + length / 2), height)
                    else:
                        xy = base + (WALL_GAP + depth / 2) * normal
                        rect = Rect(tuple(xy), (length / 2, depth / 2), yaw)
                        centre = (xy[0], xy[1], 0.0)
                        opening = ()
                        if not _inside(rect, lo, hi, 0.0):
                            continue
                else:
                    yaw = float(rng.uniform(0.0, 2 * math.pi))
                    xy = rng.uniform(lo[:2], hi[:2])
                    rect = Rect(tuple(xy), (length / 2, depth / 2), yaw)
                    centre = (xy[0], xy[1], 0.0)
                    opening = ()
                    if not _inside(rect, lo, hi, clearance):
                        continue
                    w = ""
                if not all(rects_clear(rect, p.footprint, clearance) for p in placed if p.kind != "monitor"):
                    continue
                if not keep_out.clear(rect, clearance):
                    continue
                piece = Piece(name, kind, centre, yaw, rect, wall=w if k.placement in ("wall", "door") else "",
                              opening=opening)
                break
            if piece is None:
                where = {"wall": ", against a wall", "door": ", in a wall"}.get(k.placement, "")
                raise ValueError(
                    f"furniture: cannot place {kind} {n + 1} of {counts[kind]} ({length} x {depth} m{where})"
                    f" in the room {hi[0] - lo[0]:.2f} x {hi[1] - lo[1]:.2f} m after {MAX_TRIES} draws, clear of "
                    f"the {len(placed)} pieces placed before, the people's tracks and the radar by "
                    f"{clearance} m: lower {k.parameter}, raise room_margin, lower furniture_clearance or set "
                    "furniture_clear_view=false")
            placed.append(piece)
            if kind == "table":
                tables.append(piece)
    return placed


def openings(pieces) -> dict:
    """``{wall: [(lo, hi, height), ...]}``: the openings the doors among ``pieces`` need (:func:`.room.add_room`)."""
    out: dict = {}
    for p in pieces:
        if p.kind == "door":
            (a, b), h = p.opening
            out.setdefault(p.wall, []).append((a, b, h))
    return out


# ============================================================================ writing
def material_id(key: str) -> str:
    return f"furniture-{key}"


def materials(scattering: float) -> dict:
    """``{id: definition}`` of the furniture's radio materials (:data:`MATERIALS`)."""
    out = {}
    for key, (itu_type, smooth) in MATERIALS.items():
        props = {"type": itu_type}
        if not smooth and scattering:
            props["scattering_coefficient"] = float(scattering)
        out[material_id(key)] = ("itu-radio-material", props)
    return out


def piece_meshes(piece: Piece) -> dict:
    """``{material key: (vertices [V, 3], faces [F, 3])}`` of a placed piece in the world (m)."""
    c, s = math.cos(piece.yaw), math.sin(piece.yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    out = {}
    for key, boxes in KINDS[piece.kind].parts().items():
        v, f = meshes.merge(*(meshes.box(a, b) for a, b in boxes))
        out[key] = (v @ rot.T + np.asarray(piece.centre, float), f)
    return out


def add_furniture(writer, pieces, scattering: float = 0.2) -> list[dict]:
    """Declare the furniture's materials on ``writer`` and write every piece as static meshes
    ``furniture_<name>_<material>``; returns the pieces' manifest entries."""
    writer.add_materials(materials(scattering))
    entries = []
    for p in pieces:
        objects = []
        for key, (v, f) in piece_meshes(p).items():
            name = f"furniture_{p.name}_{key}"
            writer.static(name, v, f, material_id(key))
            objects.append(name)
        entries.append({**p.to_dict(), "objects": objects})
    return entries


__all__ = ["KINDS", "KeepOut", "MATERIALS", "MAX_TRIES", "ORDER", "PARAMETERS", "Piece", "add_furniture",
           "counts_of", "materials", "openings", "people_keep_out", "piece_meshes", "place_furniture",
           "wants_furniture"]
