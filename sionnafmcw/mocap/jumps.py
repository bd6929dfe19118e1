r"""Jumping in place on a captured skeleton: countermovement jumps whose flight is ballistic.

No capture of a jump in place ships with the project (CMU ``75_10`` is a long jump forward), so the
jump is keyframed (:mod:`.keyframes`) on a captured standing posture: the pelvis moves vertically
through the phases of a countermovement jump, the feet stay flat on the floor while they touch it,
and the legs follow by two-link inverse kinematics (knees forward). Trunk, arms and head keep the
posture (no arm swing: an under-estimate of the arms' micro-Doppler).

Phases of one jump (pelvis height :math:`z` above its standing height :math:`z_0`)
-----------------------------------------------------------------------------------
1. countermovement: down by ``crouch`` :math:`c` on a minimum-jerk profile in :math:`T_c`;
2. push-off: constant upward acceleration :math:`a = v_0^2/(2c)` from rest at :math:`z_0 - c` to take-off
   at :math:`z_0` (legs straight, feet flat), taking :math:`2c/v_0`;
3. flight: ballistic, :math:`z(t) = z_0 + v_0t - gt^2/2`, for :math:`T_f = 2v_0/g`, with the take-off
   speed :math:`v_0 = \sqrt{2gh}` of the apex height ``jump_height`` :math:`h`; the whole body moves
   with the pelvis, the legs straight;
4. landing: touch-down at :math:`z_0` with :math:`-v_0`, constant deceleration to rest over ``crouch``
   :math:`c` (:math:`2c/v_0`);
5. recovery: back up to :math:`z_0` on a minimum-jerk profile in :math:`T_c`, then standing until the next
   jump (jumps every ``1/jump_rate`` s).

Position and velocity are continuous through every phase (the acceleration jumps at take-off and
touch-down, as the ground reaction does). :data:`JUMP_HEIGHT_RANGE`: 0.05 m (a hop) to 0.45 m (a
maximal countermovement jump of a fit adult, flight 0.6 s); the default 0.15 m is a brisk repeated jump.
"""

from __future__ import annotations

import math

import numpy as np

from .bvh import BvhClip
from .keyframes import KEYFRAME_RATE, HeldPosture, minimum_jerk, place_limb

G = 9.80665
#: Apex rise of the pelvis over its standing height (m).
JUMP_HEIGHT_RANGE = (0.05, 0.45)
#: Countermovement and landing depth of the pelvis (m).
CROUCH_RANGE = (0.05, 0.35)


def jump_profile(times, jump_height: float, crouch: float, crouch_time: float, jump_rate: float,
                 first: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """``(dz [T], airborne [T] bool)``: the pelvis's height over its standing height (m, module docstring)
    at ``times`` (s), jumps starting at ``first`` s and every ``1/jump_rate`` s."""
    v0 = math.sqrt(2 * G * jump_height)
    t_push = 2 * crouch / v0
    t_flight = 2 * v0 / G
    cycle = 2 * crouch_time + 2 * t_push + t_flight
    period = 1.0 / jump_rate
    if cycle > period:
        raise ValueError(f"jump_rate={jump_rate}/s is too fast: one jump of jump_height={jump_height} m and "
                         f"crouch={crouch} m takes {cycle:.3f} s; lower jump_rate")
    t = np.asarray(times, float) - first
    dz = np.zeros(t.shape)
    air = np.zeros(t.shape, bool)
    k = np.floor(t / period)
    u = np.where(t >= 0, t - k * period, -1.0)
    edges = np.cumsum([crouch_time, t_push, t_flight, t_push, crouch_time])
    p1 = (u >= 0) & (u < edges[0])
    dz[p1] = -crouch * minimum_jerk(u[p1] / crouch_time)
    p2 = (u >= edges[0]) & (u < edges[1])
    s = u[p2] - edges[0]
    dz[p2] = -crouch + 0.5 * (v0**2 / (2 * crouch)) * s**2
    p3 = (u >= edges[1]) & (u < edges[2])
    s = u[p3] - edges[1]
    dz[p3] = v0 * s - 0.5 * G * s**2
    air[p3] = True
    p4 = (u >= edges[2]) & (u < edges[3])
    s = u[p4] - edges[2]
    dz[p4] = -v0 * s + 0.5 * (v0**2 / (2 * crouch)) * s**2
    p5 = (u >= edges[3]) & (u < edges[4])
    dz[p5] = -crouch * (1.0 - minimum_jerk((u[p5] - edges[3]) / crouch_time))
    return dz, air


def jump_clip(base: BvhClip, base_time: float, unit: float, duration: float, jump_height: float = 0.15,
              crouch: float = 0.15, crouch_time: float = 0.25, jump_rate: float = 0.75,
              frame_rate: float = KEYFRAME_RATE) -> BvhClip:
    """Jumps in place (module docstring) on the posture of ``base`` at clip time ``base_time``; ``unit`` m per
    file unit; lengths in m, times in s. Frame 0 is a frame of the motion (no T-pose)."""
    for name, value, (lo, hi) in (("jump_height", jump_height, JUMP_HEIGHT_RANGE), ("crouch", crouch, CROUCH_RANGE)):
        if not lo <= value <= hi:
            raise ValueError(f"{name}={value} m is outside {lo}-{hi} m (sionnafmcw.mocap.jumps)")
    n = int(math.floor(duration * frame_rate + 1e-9)) + 1
    pose = HeldPosture(base, base_time, n, frame_rate)
    dz, air = jump_profile(pose.times, jump_height, crouch, crouch_time, jump_rate)
    up, left, fwd = pose.body_axes()
    root = 0
    sl = pose.slices[root]
    channels = list(base.joints[root].channels)
    if "Yposition" not in channels:
        raise ValueError(f"{base.path or 'BVH clip'}: the root needs a Yposition channel (height) to jump")
    pose.motion[:, sl.start + channels.index("Yposition")] += dz / unit
    shift = (dz / unit)[:, None] * up
    for S in ("Left", "Right"):
        hip = pose.world_origins[pose.joint(f"{S}UpLeg")] + shift
        ankle0 = pose.world_origins[pose.joint(f"{S}Foot")]
        lift = np.where(air, dz / unit, 0.0)
        ankle = ankle0 + lift[:, None] * up
        foot_world = pose.world_rotations[pose.joint(f"{S}Foot")]
        parent = pose.world_rotations[base.joints[pose.joint(f"{S}UpLeg")].parent]
        place_limb(pose, f"{S}UpLeg", f"{S}Leg", f"{S}Foot", hip, ankle, fwd, parent_world=parent,
                   end_world=foot_world, what=f"{S.lower()} foot")
    return pose.clip("jump in place")


__all__ = ["CROUCH_RANGE", "G", "JUMP_HEIGHT_RANGE", "jump_clip", "jump_profile"]
