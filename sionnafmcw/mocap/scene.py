r"""People on a floor, a radar looking at them: animation directories from BVH clips.

:func:`write_people` writes any number of people (:class:`~.person.MocapPerson`,
:class:`~.person.PosedPerson`), each under its own object-name prefix, with an optional room,
through :class:`~sionnafmcw.scenes.writer.AnimationWriter`: every segment is a rigid skin object
(one PLY with its smooth vertex normals, a ``to_world`` per frame). :func:`bvh_to_animation` is
the whole route from a BVH file, by numpy (:mod:`.person`) or by Blender
(:mod:`.blender_route`); ``sionnafmcw scene from-bvh`` is its command line.

Radar pose
----------
:func:`radar_in_front` puts the radar ``distance`` metres in front of the person's start position
(along the start heading), ``height`` metres above the floor, its boresight horizontal and pointed
back at the person (Sionna's orientation from :func:`~sionnafmcw.scenes.writer.look_at_orientation`);
an explicit pose (position, yaw, pitch, roll) may be given instead.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..scenes import meshes
from .bvh import read_bvh
from .person import MocapPerson, add_person
from .skeleton import CMU_UNIT

ROUTES = ("numpy", "blender")


def radar_in_front(position, heading: float, distance: float, height: float):
    """``(radar position [3], look-at target [3])``: ``distance`` m ahead of ``position`` (x, y) along
    ``heading`` (rad), ``height`` m up, looking horizontally back at the start position."""
    if not distance > 0:
        raise ValueError(f"radar distance must be > 0 m, got {distance!r}")
    x, y = (float(v) for v in position)
    radar = np.array([x + distance * math.cos(heading), y + distance * math.sin(heading), float(height)])
    return radar, np.array([x, y, float(height)])


def radar_orientation(radar_position, target=None, orientation=None) -> np.ndarray:
    """Sionna ``(yaw, pitch, roll)`` (rad): ``orientation`` when given, else looking at ``target``."""
    from ..scenes.writer import look_at_orientation

    if orientation is not None:
        return np.asarray(orientation, float)
    return look_at_orientation(radar_position, target)


def write_people(out, people, radar_position, radar_orientation, skin_scattering: float = 0.3, room_box=None,
                 room_options=None, extra: dict | None = None, activities=None, furniture=None,
                 person_info=None) -> Path:
    """Write ``people`` (``[(person, prefix), ...]``, same ``fps`` and ``num_frames``) as an animation
    directory at ``out`` with the radar pose (position m, orientation rad) and an optional room
    (``room_box = (lo, hi)``, :func:`sionnafmcw.scenes.room.add_room` with ``room_options``);
    ``extra`` is added to ``animation.json``.

    The manifest's ``people`` entry (:mod:`sionnafmcw.animation.people`) names person :math:`i`
    ``person<i>`` and gives its objects, its activity (``activities[i]``: a string or one per frame;
    default ``""``), its keypoints in every frame (:meth:`~.person.MocapPerson.keypoints`) and the
    fields of ``person_info[i]``. ``furniture``: placed pieces (:func:`sionnafmcw.scenes.furniture.place_furniture`),
    written as static objects (doors cut their openings in the room's walls), listed under ``furniture``.
    """
    from ..animation.people import people_entry
    from ..scenes import furniture as furniture_mod
    from ..scenes.keypoints import KEYPOINTS
    from ..scenes.room import add_room
    from ..scenes.writer import AnimationWriter, skin_material

    if not people:
        raise ValueError("write_people: no person")
    fps, n = people[0][0].fps, people[0][0].num_frames
    for person, prefix in people:
        if person.fps != fps or person.num_frames != n:
            raise ValueError(f"write_people: person {prefix!r} has {person.num_frames} frames at {person.fps:g} fps, "
                             f"the first {n} at {fps:g} fps; every person needs the same frames")
    prefixes = [p for _, p in people]
    if len(set(prefixes)) != len(prefixes):
        raise ValueError(f"write_people: prefixes {prefixes} repeat; give every person its own")
    activities = list(activities) if activities is not None else [""] * len(people)
    person_info = list(person_info) if person_info is not None else [{}] * len(people)
    if len(activities) != len(people) or len(person_info) != len(people):
        raise ValueError(f"write_people: {len(people)} people but {len(activities)} activities and "
                         f"{len(person_info)} person_info entries; give one per person")
    pieces = list(furniture or [])
    if pieces and room_box is None and any(p.kind == "door" for p in pieces):
        raise ValueError("write_people: doors need a room (room_box) to stand in")
    w = AnimationWriter(out, fps)
    w.add_materials(skin_material(skin_scattering))
    opts = room_options or {}
    if room_box is not None:
        add_room(w, room_box[0], room_box[1], wall=opts.get("wall_material", "concrete"),
                 floor=opts.get("floor_material", "floorboard"), ceiling=opts.get("ceiling_material", "plasterboard"),
                 scattering_coefficient=opts.get("wall_scattering", 0.2), openings=furniture_mod.openings(pieces))
    extra = dict(extra or {})
    if pieces:
        extra["furniture"] = furniture_mod.add_furniture(w, pieces, opts.get("furniture_scattering", 0.2))
    frames = [add_person(w, person, prefix) for person, prefix in people]
    for i in range(n):
        rigid = {}
        for rigid_at in frames:
            rigid.update(rigid_at(i))
        w.frame(rigid=rigid)
    persons = [{"name": f"person{i}", "prefix": prefix, "objects": [prefix + k for k in person.segment_names],
                "activity": act, **info, "keypoints": person.keypoints()}
               for i, ((person, prefix), act, info) in enumerate(zip(people, activities, person_info))]
    extra["people"] = people_entry(KEYPOINTS, persons)
    return w.finish(radar_position, radar_orientation, extra=extra)


def room_around(points, margin: float, height: float):
    """``(lo, hi)`` of a room enclosing ``points [N, 3]`` with ``margin`` metres on every side, floor at 0."""
    pts = np.asarray(points, float).reshape(-1, 3)
    lo = pts.min(0) - margin
    hi = pts.max(0) + margin
    lo[2], hi[2] = 0.0, max(float(height), float(pts[:, 2].max()) + 0.3)
    return lo, hi


def bvh_to_animation(bvh, out, route: str = "numpy", fps: float = 30.0, num_frames: int | None = None,
                     start: float | None = None, unit: float = CMU_UNIT, position=(0.0, 0.0), heading: float = 0.0,
                     radar_distance: float = 3.0, radar_height: float = 1.0, radar_pose=None,
                     height: float | None = None, build: str = "male", mesh_edge: float = meshes.BODY_MESH_EDGE,
                     skin_scattering: float = 0.3, room: bool = False, room_margin: float = 1.0,
                     velocity_step: float = 0.5, python=None, timeout: float | None = None) -> Path:
    """A BVH file as an animation directory at ``out`` (one person, :class:`~.person.MocapPerson`'s
    parameters); ``route`` ``"numpy"`` (this process) or ``"blender"`` (Blender's BVH importer drives
    the armature, the segments are parented to its bones, the exporter writes the frames:
    :func:`~.blender_route.export_with_blender`). The radar stands ``radar_distance`` m in front of
    the start position at ``radar_height`` (:func:`radar_in_front`), or at ``radar_pose``
    ``(position [3], orientation [3] rad)``. Returns ``out``."""
    from ..fs import atomic_directory

    if route not in ROUTES:
        raise ValueError(f"route {route!r} is unknown; choose one of {', '.join(ROUTES)}")
    clip = read_bvh(bvh)
    person = MocapPerson(clip, unit=unit, fps=fps, num_frames=num_frames, start=start, position=position,
                         heading=heading, height=height, build=build, mesh_edge=mesh_edge, velocity_step=velocity_step)
    if radar_pose is not None:
        radar_position = np.asarray(radar_pose[0], float)
        orientation = np.asarray(radar_pose[1], float)
    else:
        radar_position, target = radar_in_front(position, heading, radar_distance, radar_height)
        orientation = radar_orientation(radar_position, target)
    box = None
    if room:
        pts = np.concatenate([np.concatenate(list(person.world_vertices(i).values()))[::97]
                              for i in range(0, person.num_frames, max(1, person.num_frames // 8))])
        box = room_around(np.vstack([pts, radar_position[None]]), room_margin, 3.0)
    source = {"bvh": str(Path(bvh).resolve()), "route": route, "start_s": person.start, "unit_m": unit,
              "stature_m": person.body.height, "build": build}   # the Blender route writes the same "mocap" entry
    out = Path(out)
    if route == "blender":
        from .blender_route import export_with_blender

        return export_with_blender(person, Path(bvh), out, radar_position, orientation,
                                   skin_scattering=skin_scattering, room_box=box, python=python, timeout=timeout)
    with atomic_directory(out, replace=True) as tmp:
        from .library import clip_label

        write_people(tmp, [(person, "")], radar_position, orientation, skin_scattering, room_box=box,
                     extra={"mocap": source}, activities=[clip_label(str(bvh))],
                     person_info=[{"height_m": person.body.height, "build": build}])
    return out


__all__ = ["ROUTES", "bvh_to_animation", "radar_in_front", "radar_orientation", "room_around", "write_people"]
