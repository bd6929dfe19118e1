r"""The simple scenarios: ``moving_plate``, ``corner_reflectors``, ``empty_room``.

The radar sits at ``(0, 0, height)`` with boresight along world +x (orientation ``(0, 0, 0)``),
so a target at range :math:`R` and azimuth :math:`\phi` (rad, positive towards +y) in the
radar's horizontal plane is at ``(R cos(phi), R sin(phi), height)``. Everything moves along the
line of sight, so the radial velocity of a target is its speed (positive receding).

A moving radar: ``moving_plate`` and ``corner_reflectors`` take ``radar_velocity`` (m/s,
world), the radar then moving at that constant velocity from its start pose (a radar track in the
manifest, :func:`~.writer.straight_track`); ``car_park`` drives the radar down a lane between two
rows of corner reflectors (pillars), looking ahead.
"""

from __future__ import annotations

import numpy as np

from . import meshes
from .registry import Parameter, register
from .room import add_room
from .writer import METAL, AnimationWriter, metal_material

_FRAMES = Parameter(24, int, "", "number of frames", low=1, high=100_000)
_FPS = Parameter(24.0, float, "1/s", "frame rate (one CPI starts every 1/fps s)", low=1e-3, high=1e4)
_HEIGHT = Parameter(1.0, float, "m", "height of the radar and of the targets' centres", low=0.05, high=10.0)
_ROOM = Parameter(False, bool, "", "put everything inside a closed concrete room (static clutter and multipath)")
_ROUGH = Parameter(0.0, float, "", "diffuse scattering coefficient S of the metal (0: smooth, specular only; "
                   "1: fully diffuse, what the pixel engine sees)", low=0.0, high=1.0)
_RADAR_VELOCITY = Parameter((0.0, 0.0, 0.0), tuple, "m/s", "velocity of the radar (world x, y, z): it moves at "
                            "it from its start pose (0, 0, height) (a radar track); zero: a radar at rest",
                            low=-100.0, high=100.0)


def _radar_track(radar_velocity, start, num_frames, fps, builder: str):
    """The straight radar track of ``radar_velocity`` (three numbers, m/s) from ``start``, or None when it is zero."""
    from .writer import straight_track

    v = np.asarray(radar_velocity, float)
    if v.shape != (3,):
        raise ValueError(f"{builder}: radar_velocity must be three numbers (m/s, world x, y, z), got {radar_velocity!r}")
    if not np.any(v):
        return None
    return straight_track(start, v, (0.0, 0.0, 0.0), np.arange(num_frames) / fps)


def _check_clearance(track, points, builder: str, minimum: float = 0.2):
    """Every point ``[K, 3]`` at least ``minimum`` m from the radar in every frame of ``track``."""
    if track is None:
        return
    for i, pose in enumerate(track):
        d = float(np.min(np.linalg.norm(np.asarray(points, float).reshape(-1, 3) - pose.position, axis=-1)))
        if d < minimum:
            raise ValueError(f"{builder}: with radar_velocity={tuple(pose.velocity)} m/s the radar comes {d:.3f} m "
                             f"from a target in frame {i} (below {minimum} m); use fewer frames or a lower speed")


def _rotation_between(a, b) -> np.ndarray:
    """Smallest rotation taking unit vector ``a`` to unit vector ``b`` (Rodrigues)."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    if np.linalg.norm(v) < 1e-12:
        if c > 0:
            return np.eye(3)
        axis = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2 * np.outer(axis, axis) - np.eye(3)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


def _room_around(writer, points, height, margin=1.0):
    """A room enclosing the radar (at the origin) and ``points`` with ``margin`` metres to spare."""
    pts = np.vstack([np.zeros((1, 3)), np.asarray(points, float).reshape(-1, 3)])
    lo = pts.min(0) - margin
    hi = pts.max(0) + margin
    lo[2], hi[2] = 0.0, max(2.5, height + 1.0)
    add_room(writer, lo, hi)


@register("moving_plate", "A square metal plate facing the radar, moving along the line of sight.", {
    "start_range": Parameter(4.0, float, "m", "range of the plate centre at t = 0", low=0.2, high=1000.0),
    "speed": Parameter(1.0, float, "m/s", "radial speed of the plate (+ receding, - approaching)", low=-100.0, high=100.0),
    "azimuth": Parameter(0.0, float, "rad", "azimuth of the line of sight (+ towards world +y)", low=-np.pi / 2, high=np.pi / 2),
    "size": Parameter(0.5, float, "m", "edge length of the plate", low=0.01, high=10.0),
    "subdiv": Parameter(1, int, "", "cells per plate edge (2*subdiv^2 triangles)", low=1, high=200),
    "height": _HEIGHT, "room": _ROOM, "scattering_coefficient": _ROUGH, "num_frames": _FRAMES, "fps": _FPS,
    "radar_velocity": _RADAR_VELOCITY,
})
def moving_plate(out, start_range, speed, azimuth, size, subdiv, height, room, scattering_coefficient, num_frames, fps,
                 radar_velocity=(0.0, 0.0, 0.0)):
    """Plate centre at ``R(t) = start_range + speed * t`` along azimuth ``azimuth``, normal towards the radar's
    start position; the radar at rest or moving at ``radar_velocity``."""
    u = np.array([np.cos(azimuth), np.sin(azimuth), 0.0])
    t_end = (num_frames - 1) / fps
    r_end = start_range + speed * t_end
    if r_end < 0.2:
        raise ValueError(f"moving_plate: with start_range={start_range} m and speed={speed} m/s the plate reaches "
                         f"range {r_end:.3f} m at t={t_end:.3f} s (below 0.2 m, into the radar); "
                         "use fewer frames, a lower speed or a larger start_range")
    w = AnimationWriter(out, fps)
    w.add_materials(metal_material(scattering_coefficient))
    centre0 = np.array([0.0, 0.0, height])
    track = _radar_track(radar_velocity, centre0, num_frames, fps, "moving_plate")
    _check_clearance(track, [centre0 + (start_range + speed * i / fps) * u for i in range(num_frames)], "moving_plate")
    if room:
        _room_around(w, [centre0 + start_range * u, centre0 + r_end * u]
                     + ([] if track is None else [track[-1].position]), height)
    for i in range(num_frames):
        r = start_range + speed * i / fps
        v, f = meshes.plate(centre0 + r * u, (size, size), normal=-u, subdiv=subdiv)
        w.frame([{"name": "plate", "vertices": v, "faces": f, "material": METAL, "velocity": speed * u}],
                radar=None if track is None else track[i])
    w.finish(centre0, (0.0, 0.0, 0.0))


@register("corner_reflectors", "Metal trihedral corner reflectors at given ranges and azimuths, static or moving radially.", {
    "ranges": Parameter((3.0, 5.0, 7.0), tuple, "m", "range of each reflector's corner at t = 0", low=0.2, high=1000.0),
    "azimuths": Parameter((-0.3, 0.0, 0.35), tuple, "rad", "azimuth of each reflector (+ towards world +y)",
                          low=-np.pi / 2, high=np.pi / 2),
    "speeds": Parameter((0.0, 0.0, 0.0), tuple, "m/s", "radial speed of each reflector (+ receding)", low=-100.0, high=100.0),
    "leg": Parameter(0.1, float, "m", "leg length a of the triangular trihedrals (RCS 4 pi a^4 / (3 lambda^2))",
                     low=0.01, high=2.0),
    "height": _HEIGHT, "room": _ROOM, "scattering_coefficient": _ROUGH,
    "num_frames": Parameter(8, int, "", "number of frames", low=1, high=100_000), "fps": _FPS,
    "radar_velocity": _RADAR_VELOCITY,
})
def corner_reflectors(out, ranges, azimuths, speeds, leg, height, room, scattering_coefficient, num_frames, fps,
                      radar_velocity=(0.0, 0.0, 0.0)):
    """Reflector k: corner at ``(R_k + v_k t)`` along azimuth ``phi_k``, aperture axis pointing at the radar.

    Static reflectors (speed 0) are written once and listed in the manifest with zero velocity.
    A trihedral's echo is its triple bounce: simulate with the path engine's ``max_depth=3``
    (``--engine-option max_depth=3``); the default two bounces leave only its residue, tens of dB low.
    """
    if not (len(ranges) == len(azimuths) == len(speeds)) or not ranges:
        raise ValueError(f"corner_reflectors: ranges, azimuths and speeds must have the same non-zero length "
                         f"(got {len(ranges)}, {len(azimuths)}, {len(speeds)})")
    t_end = (num_frames - 1) / fps
    w = AnimationWriter(out, fps)
    w.add_materials(metal_material(scattering_coefficient))
    origin = np.array([0.0, 0.0, height])
    dirs = [np.array([np.cos(a), np.sin(a), 0.0]) for a in azimuths]
    ends = [r + s * t_end for r, s in zip(ranges, speeds)]
    if min(ends) < 0.2:
        raise ValueError(f"corner_reflectors: a reflector reaches range {min(ends):.3f} m (below 0.2 m)")
    rot = [_rotation_between(np.ones(3), -u) for u in dirs]
    track = _radar_track(radar_velocity, origin, num_frames, fps, "corner_reflectors")
    _check_clearance(track, [origin + (r + s * i / fps) * u for i in range(num_frames)
                             for r, u, s in zip(ranges, dirs, speeds)], "corner_reflectors")
    if room:
        _room_around(w, [origin + r * u for r, u in zip(ranges + tuple(ends), dirs + dirs)]
                     + ([] if track is None else [track[-1].position]), height)
    moving = []
    for k, (r, u, s, rk) in enumerate(zip(ranges, dirs, speeds, rot)):
        if s == 0.0:
            v, f = meshes.trihedral(origin + r * u, leg, rotation=rk)
            w.static(f"reflector_{k}", v, f, METAL, truth=True)
        else:
            moving.append((k, r, u, s, rk))
    for i in range(num_frames):
        t = i / fps
        objs = []
        for k, r, u, s, rk in moving:
            v, f = meshes.trihedral(origin + (r + s * t) * u, leg, rotation=rk)
            objs.append({"name": f"reflector_{k}", "vertices": v, "faces": f, "material": METAL, "velocity": s * u})
        w.frame(objs, radar=None if track is None else track[i])
    w.finish(origin, (0.0, 0.0, 0.0))


@register("car_park", "A radar driving down a lane between two rows of corner reflectors (a car park's pillars).", {
    "num_pillars": Parameter(3, int, "", "reflectors on each side of the lane", low=1, high=100),
    "spacing": Parameter(2.5, float, "m", "distance between neighbouring reflectors along the lane", low=0.2,
                         high=100.0),
    "first": Parameter(3.0, float, "m", "distance along the lane from the radar's start to the first pair",
                       low=0.2, high=1000.0),
    "lane_width": Parameter(3.0, float, "m", "distance across the lane between the two rows", low=0.4, high=100.0),
    "speed": Parameter(5.0, float, "m/s", "the radar's speed along the lane (world +x, its boresight)", low=0.0,
                       high=100.0),
    "leg": Parameter(0.1, float, "m", "leg length a of the triangular trihedrals", low=0.01, high=2.0),
    "height": _HEIGHT, "room": _ROOM, "scattering_coefficient": _ROUGH,
    "num_frames": Parameter(24, int, "", "number of frames", low=1, high=100_000), "fps": _FPS,
})
def car_park(out, num_pillars, spacing, first, lane_width, speed, leg, height, room, scattering_coefficient,
             num_frames, fps):
    """Reflector ``(k, side)``: corner at ``(first + k spacing, side lane_width/2, height)``, its aperture axis
    pointing at the radar's start ``(0, 0, height)``; the radar moves along +x at ``speed`` looking ahead
    (a radar track; every reflector is static and listed for the truth, so the run store carries its
    range and radial velocity from the moving radar).

    A trihedral's echo is its triple bounce: simulate with the path engine's ``max_depth=3``
    (``--engine-option max_depth=3``). At the default two bounces it returns only its single- and
    double-bounce residue, 35-48 dB below its echo (``benchmarks/po_bounces.py issue``)."""
    w = AnimationWriter(out, fps)
    w.add_materials(metal_material(scattering_coefficient))
    origin = np.array([0.0, 0.0, height])
    corners = [np.array([first + k * spacing, side * lane_width / 2, height])
               for k in range(num_pillars) for side in (1.0, -1.0)]
    track = _radar_track((speed, 0.0, 0.0), origin, num_frames, fps, "car_park") if speed else None
    _check_clearance(track, corners, "car_park")
    if room:
        _room_around(w, corners + ([] if track is None else [track[-1].position]), height)
    for k, corner in enumerate(corners):
        u = (corner - origin) / np.linalg.norm(corner - origin)
        v, f = meshes.trihedral(corner, leg, rotation=_rotation_between(np.ones(3), -u))
        w.static(f"pillar_{k // 2}_{'left' if k % 2 == 0 else 'right'}", v, f, METAL, truth=True)
    for i in range(num_frames):
        w.frame([], radar=None if track is None else track[i])
    w.finish(origin, (0.0, 0.0, 0.0))


@register("empty_room", "A closed room and nothing else: static clutter and the noise floor.", {
    "length": Parameter(8.0, float, "m", "inner length along x (the radar looks along +x)", low=1.0, high=100.0),
    "width": Parameter(6.0, float, "m", "inner width along y", low=1.0, high=100.0),
    "room_height": Parameter(3.0, float, "m", "inner height", low=1.5, high=20.0),
    "radar_height": Parameter(1.0, float, "m", "radar height above the floor", low=0.05, high=20.0),
    "wall_material": Parameter("concrete", str, "", "ITU material of the walls", choices=("concrete", "plasterboard", "wood", "glass", "chipboard")),
    "scattering_coefficient": Parameter(0.2, float, "", "diffuse scattering coefficient of every surface", low=0.0, high=1.0),
    "num_frames": Parameter(2, int, "", "number of frames", low=1, high=100_000), "fps": _FPS,
})
def empty_room(out, length, width, room_height, radar_height, wall_material, scattering_coefficient, num_frames, fps):
    """Inner space ``[0, length] x [-width/2, width/2] x [0, room_height]``; radar at ``(0.1, 0, radar_height)`` looking along +x."""
    if radar_height >= room_height:
        raise ValueError(f"empty_room: radar_height={radar_height} m is not below room_height={room_height} m")
    w = AnimationWriter(out, fps)
    add_room(w, (0.0, -width / 2, 0.0), (length, width / 2, room_height), wall=wall_material,
             scattering_coefficient=scattering_coefficient)
    for _ in range(num_frames):
        w.frame([])
    w.finish((0.1, 0.0, radar_height), (0.0, 0.0, 0.0))


__all__ = ["car_park", "corner_reflectors", "empty_room", "moving_plate"]
