r"""Walking-person scenarios: ``circle_walk`` (the paper's walking person, measured by
:mod:`sionnafmcw.validation.circle_walk`) and ``straight_walk``.

The person is a :class:`~.body.WalkingPerson` (Boulic-Thalmann gait, :mod:`.gait`; segment
meshes and kinematic chain, :mod:`.body`), every segment a separate rigid skin object: its mesh
(with its smooth vertex normals) written once in the segment's own frame, placed per frame by its
``to_world`` with its centroid velocity and angular velocity in the manifest
(:mod:`sionnafmcw.animation.rigid`). The radar is Sionna's pose
``(yaw, pitch, roll)`` with boresight pointed at the scene's centre of interest.

``circle_walk``
    A circle of radius :math:`R` (default 3 m) about the origin, walked at the constant track
    speed :math:`V = 2\pi R\,\text{laps} / (N/\text{fps})`; with the defaults (100 frames at 24 fps,
    one lap) :math:`V = 2\pi\cdot 3/(100/24) = 4.52` m/s. The radar stands outside the circle at
    ``(-radar_distance, 0, radar_height)`` (default 5 m from the centre, 1 m high, so the far
    side of the circle is at 8 m, inside the ``walk-77ghz`` preset's 12.5 m) and looks
    horizontally at the centre. Seen from the radar the body's radial velocity follows
    :math:`\dot R = V\,d\sin\varphi / \rho(\varphi)` with :math:`\varphi` the polar angle on the
    circle and :math:`\rho` the range (for a point on the circle at the radar's height), a
    sine-like curve; 4.52 m/s exceeds the Boulic model's range (RV = 5.1 > 3 for a 1.8 m
    person), so the gait shape is frozen at RV = 3 and the cadence rises (:mod:`.gait`).
``straight_walk``
    Towards (or away from) a radar on the track, starting ``start_range`` metres in front of it
    with a ``lateral_offset`` to the side, at ``speed`` (default 1.4 m/s, a normal walk).

The body is 13 rigid segments, each written once (``meshes/<segment>.ply``, triangle edges of at most
``body_mesh_edge``, default :data:`~.body.MESH_EDGE` = 32 mm, with the exact normals of its shape) and
placed per frame by its ``to_world`` with its linear and angular velocity in the manifest
(``docs/data_contract.md``): the 100-frame circle walk is 2.4 MB. The engines render the smooth
surface those normals describe (:mod:`sionnafmcw.smooth_surface`); the body's RCS is within 0.7 dB of
its exact shapes (:mod:`.body`, *Mesh resolution*).

Both put the scene in a closed room (``room=True``, ITU concrete walls, floorboard floor,
plasterboard ceiling, valid at 77 GHz) large enough for the walk plus ``room_margin``.
"""

from __future__ import annotations

import math

import numpy as np

from ..animation.people import people_entry
from ..animation.rigid import transform_matrix
from .keypoints import KEYPOINTS, keypoint_positions, walker_anchors
from .body import MESH_EDGE, SEGMENTS, CircleTrack, LineTrack, WalkingPerson
from .gait import RV_MAX
from .registry import Parameter, register
from .room import SURFACE_PARAMETERS, add_room
from .writer import SKIN, AnimationWriter, look_at_orientation, skin_material

_PERSON = {
    "person_height": Parameter(1.8, float, "m", "standing height of the person (segment lengths scale with it)",
                               low=1.0, high=2.3),
    "phase0": Parameter(0.0, float, "", "gait phase at t = 0 in cycles (0: right heel strike)", low=0.0, high=1.0),
    "rv_max": Parameter(RV_MAX, float, "1/s", "largest relative velocity V/H_t that shapes the gait (Boulic: 3)",
                        low=0.1, high=RV_MAX),
    "skin_scattering": Parameter(0.3, float, "", "diffuse scattering coefficient of the skin", low=0.0, high=1.0),
    "body_mesh_edge": Parameter(MESH_EDGE, float, "m", "largest triangle edge of the body meshes (the engines render "
                                "their smooth surface; the default is within 0.7 dB of the exact body at 77 GHz)",
                                low=0.002, high=0.1),
}
_ROOM = {
    "room": Parameter(True, bool, "", "put the walk in a closed room (walls, floor, ceiling)"),
    "room_margin": Parameter(1.0, float, "m", "free space between the walk and the walls", low=0.1, high=20.0),
    **SURFACE_PARAMETERS,
}


def write_person(out, person: WalkingPerson, num_frames: int, fps: float, radar_position, radar_target,
                 skin_scattering: float, room_box=None, room_options=None):
    """Write the frames of ``person`` (and optionally a room) as an animation directory at ``out``."""
    w = AnimationWriter(out, fps)
    w.add_materials(skin_material(skin_scattering))
    if room_box is not None:
        opts = room_options or {}
        add_room(w, room_box[0], room_box[1], wall=opts.get("wall_material", "concrete"),
                 floor=opts.get("floor_material", "floorboard"), ceiling=opts.get("ceiling_material", "plasterboard"),
                 scattering_coefficient=opts.get("wall_scattering", 0.2))
    for k in SEGMENTS:
        w.rigid(k, person.local_meshes[k][0], person.faces(k), SKIN, vertex_normals=person.local_normals[k])
    keypoints = []
    for i in range(num_frames):
        motions = person.segment_motions(i / fps)
        w.frame(rigid={k: {"to_world": transform_matrix(m.rotation, m.translation), "velocity": m.velocity,
                           "angular_velocity": m.angular_velocity} for k, m in motions.items()})
        keypoints.append(keypoint_positions({k: (m.rotation[None], m.translation[None]) for k, m in motions.items()},
                                            walker_anchors(person))[0])
    people = people_entry(KEYPOINTS, [{"name": "person0", "prefix": "", "objects": list(SEGMENTS), "activity": "walk",
                                       "height_m": person.height, "keypoints": keypoints}])
    w.finish(radar_position, look_at_orientation(radar_position, radar_target), extra={"people": people})


def _room_options(p):
    return {k: p[k] for k in ("wall_material", "floor_material", "ceiling_material", "wall_scattering")}


def circle_person(radius=3.0, laps=1.0, num_frames=100, fps=24.0, start_angle=-math.pi / 2, clockwise=False,
                  person_height=1.8, phase0=0.0, rv_max=RV_MAX, body_mesh_edge=MESH_EDGE) -> WalkingPerson:
    """The person of ``circle_walk`` (centre at the origin): the analytic model behind the scenario."""
    speed = 2 * math.pi * radius * laps * fps / num_frames
    return WalkingPerson(height=person_height, speed=speed, phase0=phase0, rv_max=rv_max, mesh_edge=body_mesh_edge,
                         track=CircleTrack((0.0, 0.0), radius, start_angle, clockwise))


@register("circle_walk", "The paper's scenario: a person walking a circle at constant speed, radar outside the circle.", {
    "radius": Parameter(3.0, float, "m", "radius of the circle (centre at the origin)", low=0.5, high=50.0),
    "laps": Parameter(1.0, float, "", "laps walked over the animation (sets the speed)", low=0.01, high=100.0),
    "start_angle": Parameter(-math.pi / 2, float, "rad", "polar angle on the circle at t = 0 (radar at angle pi)",
                             low=-2 * math.pi, high=2 * math.pi),
    "clockwise": Parameter(False, bool, "", "walk clockwise seen from above (default anticlockwise)"),
    "radar_distance": Parameter(5.0, float, "m", "distance of the radar from the circle's centre", low=0.5, high=100.0),
    "radar_height": Parameter(1.0, float, "m", "radar height above the floor", low=0.1, high=10.0),
    **_PERSON, **_ROOM,
    "num_frames": Parameter(100, int, "", "number of frames", low=1, high=100_000),
    "fps": Parameter(24.0, float, "1/s", "frame rate", low=1e-3, high=1e4),
})
def circle_walk(out, radius, laps, start_angle, clockwise, radar_distance, radar_height, person_height, phase0,
                rv_max, skin_scattering, body_mesh_edge, room, room_margin, room_height, wall_material, floor_material,
                ceiling_material, wall_scattering, num_frames, fps):
    """Track speed :math:`V = 2\\pi R\\,laps\\,fps/N`; radar at ``(-radar_distance, 0, radar_height)`` looking at the centre."""
    if radar_distance <= radius + 0.5:
        raise ValueError(f"circle_walk: radar_distance={radar_distance} m must exceed radius + 0.5 m = {radius + 0.5} m "
                         "(the radar stands outside the circle)")
    person = circle_person(radius, laps, num_frames, fps, start_angle, clockwise, person_height, phase0, rv_max,
                           body_mesh_edge)
    radar = np.array([-radar_distance, 0.0, radar_height])
    box = None
    if room:
        half = radius + room_margin
        box = (np.array([-radar_distance - 0.5, -half, 0.0]), np.array([half, half, room_height]))
    write_person(out, person, num_frames, fps, radar, (0.0, 0.0, radar_height), skin_scattering, box,
                 _room_options(locals()))


def straight_person(start_range=6.0, lateral_offset=0.0, direction="towards", speed=1.4, person_height=1.8,
                    phase0=0.0, rv_max=RV_MAX, body_mesh_edge=MESH_EDGE) -> WalkingPerson:
    """The person of ``straight_walk`` (radar at the origin looking along +x)."""
    heading = math.pi if direction == "towards" else 0.0
    return WalkingPerson(height=person_height, speed=speed, phase0=phase0, rv_max=rv_max, mesh_edge=body_mesh_edge,
                         track=LineTrack((start_range, lateral_offset), heading))


@register("straight_walk", "A person walking straight towards or away from the radar.", {
    "start_range": Parameter(6.0, float, "m", "distance along the boresight where the walk starts", low=0.5, high=100.0),
    "lateral_offset": Parameter(0.0, float, "m", "offset of the track to the radar's left (+y)", low=-50.0, high=50.0),
    "direction": Parameter("towards", str, "", "walk towards or away from the radar", choices=("towards", "away")),
    "speed": Parameter(1.4, float, "m/s", "walking speed", low=0.05, high=10.0),
    "radar_height": Parameter(1.0, float, "m", "radar height above the floor", low=0.1, high=10.0),
    **_PERSON, **_ROOM,
    "num_frames": Parameter(48, int, "", "number of frames", low=1, high=100_000),
    "fps": Parameter(24.0, float, "1/s", "frame rate", low=1e-3, high=1e4),
})
def straight_walk(out, start_range, lateral_offset, direction, speed, radar_height, person_height, phase0, rv_max,
                  skin_scattering, body_mesh_edge, room, room_margin, room_height, wall_material, floor_material,
                  ceiling_material,
                  wall_scattering, num_frames, fps):
    """Radar at ``(0, 0, radar_height)`` looking along +x; the track runs along x at ``y = lateral_offset``."""
    duration = (num_frames - 1) / fps
    sign = -1.0 if direction == "towards" else 1.0
    end_range = start_range + sign * speed * duration
    if end_range < 0.5:
        raise ValueError(f"straight_walk: walking {direction} at {speed} m/s for {duration:.3f} s from {start_range} m "
                         f"ends at {end_range:.3f} m, closer than 0.5 m to the radar; use fewer frames or a larger "
                         "start_range")
    person = straight_person(start_range, lateral_offset, direction, speed, person_height, phase0, rv_max,
                             body_mesh_edge)
    radar = np.array([0.0, 0.0, radar_height])
    box = None
    if room:
        far = max(start_range, end_range) + room_margin
        box = (np.array([-0.5, min(-room_margin, lateral_offset - room_margin), 0.0]),
               np.array([far, max(room_margin, lateral_offset + room_margin), room_height]))
    write_person(out, person, num_frames, fps, radar, (1.0, 0.0, radar_height), skin_scattering, box,
                 _room_options(locals()))


__all__ = ["circle_person", "circle_walk", "straight_person", "straight_walk", "write_person"]


def person_for(name: str, **params) -> WalkingPerson:
    """The analytic :class:`~.body.WalkingPerson` behind scenario ``name`` (``circle_walk`` or
    ``straight_walk``) with the same parameters :func:`~sionnafmcw.scenes.build` takes (defaults filled in)."""
    from .registry import resolve

    if name not in ("circle_walk", "straight_walk"):
        raise ValueError(f"person_for: scenario {name!r} has no walking person; choose circle_walk or straight_walk")
    p = resolve(name, params)
    common = {k: p[k] for k in ("person_height", "phase0", "rv_max", "body_mesh_edge")}
    if name == "circle_walk":
        return circle_person(p["radius"], p["laps"], p["num_frames"], p["fps"], p["start_angle"], p["clockwise"],
                             **common)
    return straight_person(p["start_range"], p["lateral_offset"], p["direction"], p["speed"], **common)


def analytic_truth(name: str, times, radar_position=None, **params) -> dict:
    """Pure-numpy ground truth of the person of scenario ``name`` at ``times`` (s).

    Returns ``{segment: {"position": [T, 3], "velocity": [T, 3]}}`` (area-weighted centroids, m and
    m/s, world) and, when ``radar_position`` is given, ``"radial_velocity": [T]`` (m/s, + receding)
    seen from it. ``analytic_truth(...)["torso"]`` is the paper's reference trajectory.
    """
    from .body import radial_velocities

    person = person_for(name, **params)
    out = {}
    for seg, (pos, vel) in person.truth(times).items():
        out[seg] = {"position": pos, "velocity": vel}
        if radar_position is not None:
            out[seg]["radial_velocity"] = radial_velocities(pos, vel, radar_position)
    return out


__all__ += ["analytic_truth", "person_for"]
