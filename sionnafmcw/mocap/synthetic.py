r"""BVH clips the project writes itself, whose motion is known in closed form (test clips, examples).

* :func:`gait_clip` -- the Boulic-Thalmann walking person of :mod:`sionnafmcw.scenes.body`
  (:class:`~sionnafmcw.scenes.body.WalkingPerson`) as a BVH clip with MotionBuilder / CMU joint
  names: its joints (hips, knees, ankles, shoulders, elbows) are those of the analytic chain, so the
  BVH route's forward kinematics can be checked against it.
* :func:`spinning_arm_clip` -- a trunk and a left arm held out horizontally, turning about the
  vertical axis through the shoulder at a constant rate :math:`\omega`: every point of the arm moves
  at :math:`\omega\hat{\mathbf z}\times(\mathbf x - \mathbf s)` (:math:`\mathbf s` the shoulder), and
  seen from a radar its Doppler is :math:`-2\hat{\mathbf r}\cdot\mathbf v/\lambda`.

Both are written in metres (``unit = 1``) and BVH's Y-up axes: a world point :math:`\mathbf x`
(Z-up) is :math:`\mathbf A^T\mathbf x` in the file and a world rotation :math:`\mathbf R` is
:math:`\mathbf A^T\mathbf R\mathbf A` (:mod:`.skeleton`); every joint has the channels
``Zrotation Yrotation Xrotation`` (the root also ``Xposition Yposition Zposition``), the local
rotation :math:`\mathbf R_p^T\mathbf R_j` of the joint's frame in its parent's, decomposed as
:math:`\mathbf R_z(a)\mathbf R_y(b)\mathbf R_x(c)`.
"""

from __future__ import annotations

import math

import numpy as np

from .bvh import BvhClip, Joint
from .skeleton import Y_UP_TO_Z_UP

_A = Y_UP_TO_Z_UP
ZYX = ("Zrotation", "Yrotation", "Xrotation")
ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition") + ZYX


def zyx_angles(r) -> np.ndarray:
    r"""Degrees ``[..., 3]`` (a, b, c) with :math:`\mathbf R = \mathbf R_z(a)\mathbf R_y(b)\mathbf R_x(c)`."""
    r = np.asarray(r, float)
    b = np.arcsin(np.clip(-r[..., 2, 0], -1.0, 1.0))
    a = np.arctan2(r[..., 1, 0], r[..., 0, 0])
    c = np.arctan2(r[..., 2, 1], r[..., 2, 2])
    return np.degrees(np.stack([a, b, c], axis=-1))


def _to_bvh_rotation(r):
    return np.einsum("ba,...bc,cd->...ad", _A, r, _A)


def _to_bvh_point(p):
    return np.asarray(p, float) @ _A   # A^T p for rows


class _Builder:
    """Joints in file order with their world frames over time ``[T, 3, 3]``, ``[T, 3]`` (Z-up, m)."""

    def __init__(self):
        self.joints = []
        self.frames = []

    def add(self, name, parent, rotations, origins, end_site=None):
        self.joints.append((name, parent, end_site))
        self.frames.append((np.asarray(rotations, float), np.asarray(origins, float)))
        return len(self.joints) - 1

    def clip(self, frame_time) -> BvhClip:
        joints, columns = [], []
        for j, (name, parent, end_site) in enumerate(self.joints):
            r, o = self.frames[j]
            if parent < 0:
                local_r, offset = r, o[0]
                columns.append(_to_bvh_point(o))
            else:
                rp, op = self.frames[parent]
                local_r = np.einsum("tba,tbc->tac", rp, r)
                rel = np.einsum("tba,tb->ta", rp, o - op)       # offset in the parent's frame
                if np.max(np.abs(rel - rel[0])) > 1e-9:
                    raise ValueError(f"joint {name!r} moves in its parent's frame: not a rigid skeleton")
                offset = rel[0]
            columns.append(zyx_angles(_to_bvh_rotation(local_r)))
            joint = Joint(name, parent, _to_bvh_point(offset) if parent >= 0 else np.zeros(3),
                          ROOT_CHANNELS if parent < 0 else ZYX,
                          None if end_site is None else _to_bvh_point(end_site))
            if parent >= 0:
                joints[parent].children.append(j)
            joints.append(joint)
        return BvhClip(joints, float(frame_time), np.concatenate(columns, axis=1))


def gait_clip(person, duration: float, frame_rate: float = 120.0) -> BvhClip:
    """:class:`~sionnafmcw.scenes.body.WalkingPerson` ``person`` over ``duration`` s sampled at
    ``frame_rate`` (module docstring); joints ``Hips`` (the spine origin, pelvis frame), ``LeftUpLeg``
    (hip), ``LeftLeg`` (knee), ``LeftFoot`` (ankle), ``LowerBack``, ``Spine``, ``Spine1``, ``Neck``,
    ``Head``, ``LeftShoulder``, ``LeftArm`` (shoulder), ``LeftForeArm`` (elbow), ``LeftHand`` (the
    end of the forearm segment) and the right side likewise."""
    times = np.arange(int(round(duration * frame_rate)) + 1) / frame_rate
    poses = [person.poses(t) for t in times]

    def seg(name):
        return np.array([p[name][0] for p in poses]), np.array([p[name][1] for p in poses])

    b = person.body
    H = person.height
    rp, op = seg("pelvis")
    ru, _ = seg("torso")
    bld = _Builder()
    hips = bld.add("Hips", -1, rp, op)
    for side, sign in (("Left", 1.0), ("Right", -1.0)):
        low = side.lower()
        rt, ot = seg(f"{low}_upper_leg")
        rs, os_ = seg(f"{low}_lower_leg")
        rf, of = seg(f"{low}_foot")
        up = bld.add(f"{side}UpLeg", hips, rt, ot)
        leg = bld.add(f"{side}Leg", up, rs, os_)
        bld.add(f"{side}Foot", leg, rf, of, end_site=np.array([b.foot_length - b.heel, 0.0, -b.ankle_height]))
    lower = bld.add("LowerBack", hips, ru, op)
    spine = bld.add("Spine", lower, ru, op + np.einsum("tab,b->ta", ru, [0.0, 0.0, 0.12 * H]))
    spine1 = bld.add("Spine1", spine, ru, op + np.einsum("tab,b->ta", ru, [0.0, 0.0, 0.24 * H]))
    neck = bld.add("Neck", spine1, ru, op + np.einsum("tab,b->ta", ru, [0.0, 0.0, b.torso]))
    bld.add("Head", neck, ru, op + np.einsum("tab,b->ta", ru, [0.0, 0.0, b.torso + 0.03 * H]),
            end_site=np.array([0.0, 0.0, 0.1 * H]))
    for side in ("Left", "Right"):
        low = side.lower()
        ra, oa = seg(f"{low}_upper_arm")
        rl, ol = seg(f"{low}_lower_arm")
        sh = bld.add(f"{side}Shoulder", spine1, ru, op + np.einsum("tab,b->ta", ru, [0.0, 0.0, 0.24 * H]))
        arm = bld.add(f"{side}Arm", sh, ra, oa)
        fore = bld.add(f"{side}ForeArm", arm, rl, ol)
        bld.add(f"{side}Hand", fore, rl, ol + np.einsum("tab,b->ta", rl, [0.0, 0.0, -b.forearm]),
                end_site=np.array([0.0, 0.0, -b.hand]))
    return bld.clip(1.0 / frame_rate)


def spinning_arm_clip(rate: float = math.pi, duration: float = 1.0, frame_rate: float = 120.0,
                      hip_height: float = 1.0, shoulder=(0.0, 0.18, 0.45), upper_arm: float = 0.3,
                      forearm: float = 0.25) -> BvhClip:
    r"""A trunk standing still (root ``Hips`` at ``hip_height`` m) and its left arm held out along the
    body's left, turning about the vertical through the shoulder at ``rate`` :math:`\omega` (rad/s,
    anticlockwise seen from above): the ``LeftArm`` joint's rotation is
    :math:`\mathbf R_z(\omega t)` (world), the elbow and wrist straight. ``shoulder`` is the shoulder
    joint relative to the root (body frame: x forward, y left, z up, m). Joints: ``Hips``,
    ``LowerBack``, ``Spine``, ``Spine1``, ``LeftShoulder``, ``LeftArm``, ``LeftForeArm``, ``LeftHand``."""
    times = np.arange(int(round(duration * frame_rate)) + 1) / frame_rate
    n = times.size
    eye = np.broadcast_to(np.eye(3), (n, 3, 3))
    root = np.broadcast_to([0.0, 0.0, hip_height], (n, 3))
    s = np.asarray(shoulder, float)
    turn = np.zeros((n, 3, 3))
    c, si = np.cos(rate * times), np.sin(rate * times)
    turn[:, 0, 0], turn[:, 0, 1], turn[:, 1, 0], turn[:, 1, 1], turn[:, 2, 2] = c, -si, si, c, 1.0
    bld = _Builder()
    hips = bld.add("Hips", -1, eye, root)
    lower = bld.add("LowerBack", hips, eye, root)
    spine = bld.add("Spine", lower, eye, root + [0.0, 0.0, 0.5 * s[2]])
    spine1 = bld.add("Spine1", spine, eye, root + [0.0, 0.0, 0.8 * s[2]])
    sh = bld.add("LeftShoulder", spine1, eye, root + [0.0, 0.0, 0.8 * s[2]])
    shoulder_w = root + s
    arm = bld.add("LeftArm", sh, turn, shoulder_w)
    elbow = shoulder_w + np.einsum("tab,b->ta", turn, [0.0, upper_arm, 0.0])
    fore = bld.add("LeftForeArm", arm, turn, elbow)
    wrist = elbow + np.einsum("tab,b->ta", turn, [0.0, forearm, 0.0])
    bld.add("LeftHand", fore, turn, wrist, end_site=np.array([0.0, 0.1, 0.0]))
    return bld.clip(1.0 / frame_rate)


__all__ = ["gait_clip", "spinning_arm_clip", "zyx_angles"]
