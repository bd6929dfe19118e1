r"""Motion made from keyframes on a captured skeleton: a held posture, limbs moved by inverse kinematics.

The keyframed activities (:mod:`.punches`, :mod:`.jumps`) start from one captured frame of a clip,
repeated (:func:`held_posture`), and move limbs by placing their end joints (a wrist, an ankle) on
paths given in closed form; :func:`place_limb` turns a path into the two joints' rotation channels.

Two-link inverse kinematics
---------------------------
A limb is three joints, root :math:`\mathbf s` (shoulder, hip), middle (elbow, knee) and end
:math:`\mathbf x` (wrist, ankle), with bone lengths :math:`L_1`, :math:`L_2` (the offsets of the
middle and end joints). For an end at distance :math:`d = |\mathbf x - \mathbf s|`, the middle joint
lies in the plane of :math:`\mathbf s`, :math:`\mathbf x` and a pole direction :math:`\mathbf q`
(where the elbow or the knee points), at the angle

.. math::
    \alpha = \arccos\frac{L_1^2 + d^2 - L_2^2}{2L_1d}

from :math:`\hat{\mathbf a} = (\mathbf x - \mathbf s)/d`:
:math:`\mathbf m = \mathbf s + L_1(\cos\alpha\,\hat{\mathbf a} + \sin\alpha\,\hat{\mathbf q}_\perp)`,
:math:`\hat{\mathbf q}_\perp` the pole made orthogonal to :math:`\hat{\mathbf a}`. Each bone's world
rotation is its posture's turned by the shortest rotation taking the bone onto its new direction
(Rodrigues), so the limb keeps its posture's twist; the local rotations follow as
:math:`\mathbf R_j = (\mathbf R^W_p)^T\mathbf R^W_j` and are written as ``Z Y X`` channels. A joint
below the limb (the hand, the foot) keeps its local rotation, or, with ``end_world``, the world
rotation given (a foot kept flat on the floor).

Between keyframes the clip is slerped (:mod:`.skeleton`): a straight path of the end joint becomes
arcs between keyframes; at 480 keyframes a second the speed read off the interpolated motion is
within 0.3 % of the path's (measured on a 6.3 m/s punch; the excess falls as the square of the
keyframe interval).
"""

from __future__ import annotations

import numpy as np

from .bvh import BvhClip, Joint
from .skeleton import Skeleton
from .synthetic import zyx_angles

#: Keyframes per second of the keyframed activities (module docstring).
KEYFRAME_RATE = 480.0
ZYX = ("Zrotation", "Yrotation", "Xrotation")


def minimum_jerk(s):
    r"""Minimum-jerk profile :math:`f(s) = 10s^3 - 15s^4 + 6s^5` on :math:`s \in [0, 1]` (clipped outside):
    rest to rest, peak rate :math:`f'(1/2) = 15/8` (Flash & Hogan 1985, J. Neurosci. 5(7):1688-1703)."""
    s = np.clip(np.asarray(s, float), 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def rotation_between(a, b):
    """Shortest rotations ``[N, 3, 3]`` taking unit vectors ``a`` [N, 3] onto ``b`` [N, 3] (Rodrigues)."""
    v = np.cross(a, b)
    c = np.einsum("na,na->n", a, b)
    k = np.zeros((len(a), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 0] = -v[:, 2], v[:, 1], v[:, 2]
    k[:, 1, 2], k[:, 2, 0], k[:, 2, 1] = -v[:, 0], -v[:, 1], v[:, 0]
    return np.eye(3) + k + np.einsum("nab,nbc->nac", k, k) / (1.0 + c)[:, None, None]


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


class HeldPosture:
    """Frame ``k`` of ``base`` repeated ``n`` times at ``frame_rate``: ``motion`` [n, C] (channels to edit),
    ``rest_world`` (world rotations [J, 3, 3] and origins [J, 3] of the posture, BVH axes and file units),
    ``local`` (its local rotations [J, 3, 3]) and the joint indices ``idx`` by name."""

    def __init__(self, base: BvhClip, base_time: float, n: int, frame_rate: float = KEYFRAME_RATE):
        k = int(round(base_time / base.frame_time))
        if not 0 <= k < base.num_frames:
            raise ValueError(f"posture time {base_time} s is outside the clip {base.path or ''} "
                             f"(0..{base.duration:.3f} s)")
        self.base = base
        self.frame_rate = float(frame_rate)
        self.motion = np.repeat(base.motion[k:k + 1], n, axis=0)
        sk = Skeleton(BvhClip(base.joints, 1.0 / frame_rate, base.motion[k:k + 1], base.path))
        rw, ow = sk.forward(sk.local_rotations[:1], sk.local_translations[:1])
        self.world_rotations, self.world_origins = rw[0], ow[0]
        self.local = sk.local_rotations[0]
        self.slices = base.channel_slices()
        self.idx = {j.name: i for i, j in enumerate(base.joints)}
        self.times = np.arange(n) / frame_rate

    def joint(self, name: str) -> int:
        if name not in self.idx:
            raise ValueError(f"{self.base.path or 'BVH clip'} has no joint {name!r}: a keyframed activity needs the "
                             "MotionBuilder / CMU joint names")
        j = self.idx[name]
        if tuple(self.base.joints[j].channels[-3:]) != ZYX:
            raise ValueError(f"{self.base.path or 'BVH clip'}: joint {name} needs the channels Zrotation Yrotation "
                             "Xrotation (MotionBuilder / CMU layout) to be keyframed")
        return j

    def body_axes(self):
        """``(up, left, forward)`` unit vectors of the posture (BVH axes: up +y; left from the right shoulder to
        the left one, horizontal; forward = left x up)."""
        up = np.array([0.0, 1.0, 0.0])
        left = self.world_origins[self.joint("LeftArm")] - self.world_origins[self.joint("RightArm")]
        left[1] = 0.0
        left = unit(left)
        return up, left, np.cross(left, up)

    def bone(self, name: str) -> float:
        """Length (file units) of the bone ending at joint ``name`` (its offset)."""
        return float(np.linalg.norm(self.base.joints[self.joint(name)].offset))

    def set_rotation(self, j: int, local) -> None:
        """Write local rotations ``[n, 3, 3]`` as joint ``j``'s ``Z Y X`` channels."""
        sl = self.slices[j]
        self.motion[:, slice(sl.stop - 3, sl.stop)] = zyx_angles(local)

    def clip(self, label: str) -> BvhClip:
        joints = [Joint(j.name, j.parent, j.offset, j.channels, j.end_site, j.line, list(j.children))
                  for j in self.base.joints]
        return BvhClip(joints, 1.0 / self.frame_rate, self.motion, f"{label} on {self.base.path or 'BVH clip'}")


def place_limb(pose: HeldPosture, root: str, middle: str, end: str, root_pos, target, pole,
               parent_world=None, end_world=None, extension: float = 0.0, what: str = "limb") -> np.ndarray:
    """Put joint ``end`` on ``target`` [n, 3] (module docstring) with the limb's root joint at ``root_pos``
    [n, 3] (its posture's position when the body does not move), the middle joint towards ``pole`` ([3] or
    [n, 3]); ``parent_world`` the root's parent's world rotation ([3, 3] or [n, 3, 3]; default the posture's), ``end_world`` a world
    rotation [3, 3] to hold the end joint at (default: its local rotation kept). With ``extension`` (file
    units) the point that far beyond ``end`` along the last bone goes on ``target`` instead (the tip of a
    hand held straight: :math:`L_2` becomes :math:`L_2` + ``extension``). Writes the channels of ``root``
    and ``middle`` (and ``end`` with ``end_world``); returns the middle joint's positions [n, 3]."""
    jr, jm, je = pose.joint(root), pose.joint(middle), pose.joint(end)
    l1, l2 = pose.bone(middle), pose.bone(end) + float(extension)
    s = np.broadcast_to(np.asarray(root_pos, float), np.shape(target))
    n = len(target)
    d_vec = target - s
    d = np.linalg.norm(d_vec, axis=1)
    if np.any(d > l1 + l2 + 1e-9) or np.any(d < abs(l1 - l2) - 1e-9):
        raise ValueError(f"the {what}'s path leaves the reach of {root}-{middle}-{end} "
                         f"({abs(l1 - l2):.3g}..{l1 + l2:.3g} units, asked {d.min():.3g}..{d.max():.3g})")
    a = unit(d_vec)
    q = np.broadcast_to(np.asarray(pole, float), (n, 3))
    q = unit(q - np.einsum("na,na->n", a, q)[:, None] * a)
    cos_a = np.clip((l1**2 + d**2 - l2**2) / (2 * l1 * d), -1.0, 1.0)
    mid = s + l1 * (cos_a[:, None] * a + np.sqrt(1 - cos_a**2)[:, None] * q)
    base = pose.base
    r_parent = pose.world_rotations[base.joints[jr].parent] if parent_world is None else np.asarray(parent_world)
    r_parent = np.broadcast_to(r_parent, (n, 3, 3))
    r_root0 = np.einsum("nab,bc->nac", r_parent, pose.local[jr])
    bone0 = unit(np.einsum("nab,b->na", r_root0, base.joints[jm].offset))
    r_root = np.einsum("nab,nbc->nac", rotation_between(bone0, unit(mid - s)), r_root0)
    r_mid0 = np.einsum("nab,bc->nac", r_root, pose.local[jm])
    bone1 = unit(np.einsum("nab,b->na", r_mid0, base.joints[je].offset))
    r_mid = np.einsum("nab,nbc->nac", rotation_between(bone1, unit(target - mid)), r_mid0)
    pose.set_rotation(jr, np.einsum("nba,nbc->nac", r_parent, r_root))
    pose.set_rotation(jm, np.einsum("nba,nbc->nac", r_root, r_mid))
    if end_world is not None:
        pose.set_rotation(je, np.einsum("nba,bc->nac", r_mid, np.asarray(end_world)))
    return mid


__all__ = ["HeldPosture", "KEYFRAME_RATE", "minimum_jerk", "place_limb", "rotation_between", "unit"]
