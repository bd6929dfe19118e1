r"""Forward kinematics of a BVH skeleton, its motion interpolated in time, in the simulator's world frame.

BVH conventions (those of the Biovision format and of Blender's importer)
--------------------------------------------------------------------------
Joint :math:`j` with parent :math:`p` is placed in its parent's frame by a translation
:math:`\mathbf t_j` and a rotation :math:`\mathbf R_j`:

.. math::
    \mathbf x_p = \mathbf t_j + \mathbf R_j\,\mathbf x_j, \qquad
    \mathbf R^W_j = \mathbf R^W_p\mathbf R_j, \qquad
    \mathbf o^W_j = \mathbf o^W_p + \mathbf R^W_p\,\mathbf t_j,

* :math:`\mathbf t_j` is the joint's ``OFFSET``; a joint with position channels (the root) takes
  its translation from them instead (an absent axis is 0, as Blender reads it);
* :math:`\mathbf R_j = \mathbf R_{a_1}(\theta_1)\mathbf R_{a_2}(\theta_2)\mathbf R_{a_3}(\theta_3)`
  for rotation channels listed in the order :math:`a_1 a_2 a_3` (degrees): the first listed
  rotation about the parent-aligned axis, each next one about the axes already turned (intrinsic),
  e.g. ``Zrotation Yrotation Xrotation`` is :math:`\mathbf R_z\mathbf R_y\mathbf R_x` (Blender's
  Euler mode ``XYZ``).

World frame
-----------
BVH files are Y-up; the simulator is Z-up (metres). A point :math:`\mathbf x_B` (file units) goes to
:math:`\mathbf x = s\,\mathbf A\,\mathbf x_B` with the unit :math:`s` (m per file unit:
:data:`CMU_UNIT` = 0.056444 for the CMU database, ``1/0.45`` inch) and
:math:`\mathbf A` = :data:`Y_UP_TO_Z_UP` :math:`(x, y, z) \mapsto (x, -z, y)` (BVH +Y up becomes +z,
BVH -Z forward becomes +y: Blender's importer default, ``axis_forward='-Z', axis_up='Y'``).
Rotations follow as :math:`\mathbf A\mathbf R\mathbf A^T`. A joint's *frame* in the world is then
:math:`(\mathbf A\mathbf R^W_j\mathbf A^T, s\mathbf A\mathbf o^W_j)`: at rest (all rotations zero) its
axes are the world axes, so a body segment can be built in world-aligned coordinates around the
joint (:mod:`.segments`).

Interpolation in time
---------------------
Frame :math:`k` is at clip time :math:`\tau_k = k\,\Delta\tau`. Between frames, with
:math:`u = \tau/\Delta\tau - k \in [0, 1)`:

* translations are linear, :math:`(1-u)\mathbf t^{(k)} + u\,\mathbf t^{(k+1)}`;
* rotations are slerped on the unit quaternions of :math:`\mathbf R_j`,
  :math:`\mathbf q(u) = \mathbf q_k\,(\mathbf q_k^{-1}\mathbf q_{k+1})^u` (the constant-rate turn
  about the fixed axis that takes one frame's rotation to the next), with the quaternions of
  successive frames in the same hemisphere (:math:`\mathbf q_k\cdot\mathbf q_{k+1} \ge 0`, the
  shorter way round).

Blender interpolates the same quaternions linearly and normalises them (``rotate_mode='QUATERNION'``,
LINEAR keyframes; :mod:`.blender_route`): "nlerp" moves along the same arc as slerp at a slightly
different rate: on the quaternions' arc of :math:`\theta = \delta/2` (a step :math:`\delta` of the
rotation between frames) it is off by :math:`\theta^3 g(u)`, :math:`g(u) = -u/6 + u^2/2 - u^3/3`
(:math:`|g| \le 0.01604`, at :math:`u` = 0.211 and 0.789; zero at 0, 1/2 and 1), so the rotation is
off by :math:`2\theta^3|g| = \delta^3|g|/4 \le 0.00401\,\delta^3` (:func:`nlerp_slerp_bound`).

numpy only.
"""

from __future__ import annotations

import math

import numpy as np

from .bvh import BvhClip

#: Metres per BVH unit of the CMU Graphics Lab Motion Capture Database (its ASF ``length 0.45``:
#: one unit is 1/0.45 inch).
CMU_UNIT = 0.0254 / 0.45
#: :math:`\mathbf A`: BVH Y-up axes to the simulator's Z-up axes, :math:`(x, y, z) \mapsto (x, -z, y)`.
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
_AXIS = {"X": 0, "Y": 1, "Z": 2}


# ============================================================================ rotations
def axis_rotation(axis: int, angle) -> np.ndarray:
    """Right-handed rotations ``[..., 3, 3]`` about coordinate ``axis`` (0, 1, 2) by ``angle`` (rad, array)."""
    angle = np.asarray(angle, float)
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(angle.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[..., axis, axis] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def quat_from_matrix(r) -> np.ndarray:
    """Unit quaternions ``[..., 4]`` (w, x, y, z) of proper rotations ``[..., 3, 3]`` (Shepperd's method)."""
    r = np.asarray(r, float)
    m00, m11, m22 = r[..., 0, 0], r[..., 1, 1], r[..., 2, 2]
    trace = m00 + m11 + m22
    cand = np.stack([trace, m00, m11, m22], axis=-1)
    k = np.argmax(cand, axis=-1)
    q = np.empty(r.shape[:-2] + (4,))
    with np.errstate(divide="ignore", invalid="ignore"):
        s0 = np.sqrt(np.maximum(1.0 + trace, 0.0)) * 2
        sx = np.sqrt(np.maximum(1.0 + m00 - m11 - m22, 0.0)) * 2
        sy = np.sqrt(np.maximum(1.0 - m00 + m11 - m22, 0.0)) * 2
        sz = np.sqrt(np.maximum(1.0 - m00 - m11 + m22, 0.0)) * 2
        q0 = np.stack([0.25 * s0, (r[..., 2, 1] - r[..., 1, 2]) / s0, (r[..., 0, 2] - r[..., 2, 0]) / s0,
                       (r[..., 1, 0] - r[..., 0, 1]) / s0], -1)
        q1 = np.stack([(r[..., 2, 1] - r[..., 1, 2]) / sx, 0.25 * sx, (r[..., 0, 1] + r[..., 1, 0]) / sx,
                       (r[..., 0, 2] + r[..., 2, 0]) / sx], -1)
        q2 = np.stack([(r[..., 0, 2] - r[..., 2, 0]) / sy, (r[..., 0, 1] + r[..., 1, 0]) / sy, 0.25 * sy,
                       (r[..., 1, 2] + r[..., 2, 1]) / sy], -1)
        q3 = np.stack([(r[..., 1, 0] - r[..., 0, 1]) / sz, (r[..., 0, 2] + r[..., 2, 0]) / sz,
                       (r[..., 1, 2] + r[..., 2, 1]) / sz, 0.25 * sz], -1)
    for idx, qk in enumerate((q0, q1, q2, q3)):
        sel = k == idx
        q[sel] = qk[sel]
    q *= np.where(q[..., :1] < 0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def matrix_from_quat(q) -> np.ndarray:
    """Rotation matrices ``[..., 3, 3]`` of quaternions ``[..., 4]`` (w, x, y, z), normalised first."""
    q = np.asarray(q, float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(q.shape[:-1] + (3, 3))
    out[..., 0, 0] = 1 - 2 * (y * y + z * z)
    out[..., 0, 1] = 2 * (x * y - w * z)
    out[..., 0, 2] = 2 * (x * z + w * y)
    out[..., 1, 0] = 2 * (x * y + w * z)
    out[..., 1, 1] = 1 - 2 * (x * x + z * z)
    out[..., 1, 2] = 2 * (y * z - w * x)
    out[..., 2, 0] = 2 * (x * z - w * y)
    out[..., 2, 1] = 2 * (y * z + w * x)
    out[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def align_hemispheres(q) -> np.ndarray:
    """Quaternions ``[F, ..., 4]`` with the signs flipped along axis 0 so that successive ones have a
    non-negative dot product (the same rotations; interpolation then takes the shorter way)."""
    q = np.array(q, float)
    for k in range(1, q.shape[0]):
        flip = np.sum(q[k] * q[k - 1], axis=-1) < 0
        q[k][flip] *= -1.0
    return q


def slerp(q0, q1, u) -> np.ndarray:
    r"""Spherical linear interpolation of unit quaternions ``[..., 4]`` at ``u`` in [0, 1]
    (broadcast): :math:`(\sin((1-u)\theta)\mathbf q_0 + \sin(u\theta)\mathbf q_1)/\sin\theta`,
    :math:`\cos\theta = \mathbf q_0\cdot\mathbf q_1`; normalised linear interpolation where
    :math:`\theta < 10^{-6}` (the two agree to :math:`\theta^2`)."""
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    u = np.asarray(u, float)[..., None]
    dot = np.clip(np.sum(q0 * q1, axis=-1, keepdims=True), -1.0, 1.0)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(dot)
    small = theta < 1e-6
    sin_t = np.where(small, 1.0, np.sin(theta))
    a = np.where(small, 1.0 - u, np.sin((1.0 - u) * theta) / sin_t)
    b = np.where(small, u, np.sin(u * theta) / sin_t)
    out = a * q0 + b * q1
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def nlerp_deviation(step_angle, u) -> np.ndarray:
    r"""Angle (rad) between the normalised linear and the spherical interpolation at fraction ``u`` of two
    rotations ``step_angle`` :math:`\delta` apart, to third order: :math:`\delta^3|g(u)|/4` (module
    docstring)."""
    u = np.asarray(u, float)
    return np.asarray(step_angle, float) ** 3 * np.abs(-u / 6 + u ** 2 / 2 - u ** 3 / 3) / 4


def nlerp_slerp_bound(step_angle) -> float:
    r"""Largest angle (rad) between the normalised linear and the spherical interpolation of two
    rotations ``step_angle`` :math:`\delta` apart: :math:`0.00401\,\delta^3` (module docstring;
    the next term is :math:`O(\delta^5)`)."""
    return 0.00401 * float(step_angle) ** 3


def rotation_angle(r) -> np.ndarray:
    """Angle (rad) of proper rotations ``[..., 3, 3]``."""
    r = np.asarray(r, float)
    return np.arccos(np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0))


# ============================================================================ the skeleton
class Skeleton:
    """The joints of a :class:`~.bvh.BvhClip` and their per-frame local transforms.

    ``local_rotations`` ``[F, J, 3, 3]`` (:math:`\\mathbf R_j`), ``local_quaternions`` ``[F, J, 4]``
    (hemisphere-aligned along the frames) and ``local_translations`` ``[F, J, 3]`` (file units),
    in BVH axes.
    """

    def __init__(self, clip: BvhClip):
        self.clip = clip
        self.names = clip.names
        self.parents = np.array([j.parent for j in clip.joints])
        num_frames, num_joints = clip.num_frames, len(clip.joints)
        rot = np.broadcast_to(np.eye(3), (num_frames, num_joints, 3, 3)).copy()
        trans = np.empty((num_frames, num_joints, 3))
        for j, (joint, sl) in enumerate(zip(clip.joints, clip.channel_slices())):
            values = clip.motion[:, sl]
            trans[:, j] = joint.offset
            has_position = any(c.endswith("position") for c in joint.channels)
            if has_position:
                trans[:, j] = 0.0
            for c, name in enumerate(joint.channels):
                axis = _AXIS[name[0]]
                if name.endswith("position"):
                    trans[:, j, axis] = values[:, c]
                else:
                    rot[:, j] = rot[:, j] @ axis_rotation(axis, np.radians(values[:, c]))
        self.local_rotations = rot
        self.local_translations = trans
        self.local_quaternions = align_hemispheres(quat_from_matrix(rot))

    @property
    def num_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        return self.clip.index(name)

    def children(self, j: int) -> list[int]:
        return list(self.clip.joints[j].children)

    def rest_positions(self) -> np.ndarray:
        """Joint origins ``[J, 3]`` (file units, BVH axes) at rest: every rotation zero, every
        translation its ``OFFSET`` (the root's too)."""
        out = np.zeros((self.num_joints, 3))
        for j, joint in enumerate(self.clip.joints):
            out[j] = joint.offset + (out[joint.parent] if joint.parent >= 0 else 0.0)
        return out

    def end_sites(self) -> dict:
        """``{joint index: end-site position [3]}`` at rest (file units, BVH axes)."""
        rest = self.rest_positions()
        return {j: rest[j] + joint.end_site for j, joint in enumerate(self.clip.joints) if joint.end_site is not None}

    def interpolated_local(self, frame_position):
        """Local ``(rotations [T, J, 3, 3], translations [T, J, 3])`` at fractional frame positions
        ``[T]`` in ``[0, F-1]`` (slerp / linear, module docstring)."""
        u = np.atleast_1d(np.asarray(frame_position, float))
        last = self.clip.num_frames - 1
        if np.any(u < -1e-9) or np.any(u > last + 1e-9):
            raise ValueError(f"frame position outside the clip's frames 0..{last}: {u.min():.6g}..{u.max():.6g}")
        u = np.clip(u, 0.0, last)
        k = np.minimum(np.floor(u).astype(int), max(last - 1, 0))
        frac = u - k
        if last == 0:
            return (np.repeat(self.local_rotations[:1], u.size, 0), np.repeat(self.local_translations[:1], u.size, 0))
        q = slerp(self.local_quaternions[k], self.local_quaternions[k + 1], frac[:, None])
        rot = matrix_from_quat(q)
        # exact matrices where u falls on a frame (no round trip through the quaternion)
        on = frac == 0.0
        rot[on] = self.local_rotations[k[on]]
        t = (1 - frac)[:, None, None] * self.local_translations[k] + frac[:, None, None] * self.local_translations[k + 1]
        return rot, t

    def forward(self, rotations, translations):
        """World ``(rotations [T, J, 3, 3], origins [T, J, 3])`` (BVH axes, file units) of local transforms."""
        rw = np.empty_like(rotations)
        ow = np.empty_like(translations)
        for j, p in enumerate(self.parents):
            if p < 0:
                rw[:, j] = rotations[:, j]
                ow[:, j] = translations[:, j]
            else:
                rw[:, j] = rw[:, p] @ rotations[:, j]
                ow[:, j] = ow[:, p] + np.einsum("tab,tb->ta", rw[:, p], translations[:, j])
        return rw, ow


class ClipMotion:
    """The clip's motion in the simulator's world: joint frames at any clip time, placed.

    ``unit`` (m per file unit), ``axes`` (:data:`Y_UP_TO_Z_UP`), ``placement`` a 4x4 world transform
    (a rotation about z and a translation, :func:`placement_matrix`) applied after the unit and the
    axes. :meth:`joint_frames` gives, at clip times :math:`\\tau` (s from the clip's frame 0), every
    joint frame's world rotation :math:`\\mathbf P\\mathbf A\\mathbf R^W_j\\mathbf A^T` and origin
    :math:`\\mathbf P(s\\mathbf A\\mathbf o^W_j)` (module docstring).
    """

    def __init__(self, clip: BvhClip, unit: float = CMU_UNIT, axes=Y_UP_TO_Z_UP, placement=None):
        if not (unit > 0 and math.isfinite(unit)):
            raise ValueError(f"ClipMotion: unit (metres per BVH unit) must be > 0, got {unit!r}")
        self.clip = clip
        self.skeleton = Skeleton(clip)
        self.unit = float(unit)
        self.axes = np.asarray(axes, float)
        self.placement = np.eye(4) if placement is None else np.asarray(placement, float)

    @property
    def frame_time(self) -> float:
        return self.clip.frame_time

    def placed(self, placement) -> "ClipMotion":
        """The same motion with another ``placement``."""
        out = ClipMotion.__new__(ClipMotion)
        out.__dict__.update(self.__dict__)
        out.placement = np.asarray(placement, float)
        return out

    def joint_frames(self, times):
        """World ``(rotations [T, J, 3, 3], origins [T, J, 3])`` (m) at clip times ``times`` (s)."""
        times = np.atleast_1d(np.asarray(times, float))
        rot, trans = self.skeleton.interpolated_local(times / self.frame_time)
        rw, ow = self.skeleton.forward(rot, trans)
        a = self.axes
        p_rot, p_t = self.placement[:3, :3], self.placement[:3, 3]
        world_rot = np.einsum("ab,tjbc,dc->tjad", p_rot @ a, rw, a)
        world_pos = np.einsum("ab,tjb->tja", p_rot @ a, self.unit * ow) + p_t
        return world_rot, world_pos

    def rest_positions(self) -> np.ndarray:
        """Joint origins ``[J, 3]`` (m) at rest in the unplaced world axes (:math:`s\\mathbf A\\mathbf o`)."""
        return self.unit * self.skeleton.rest_positions() @ self.axes.T

    def rest_end_sites(self) -> dict:
        """``{joint index: end site [3]}`` (m) at rest in the unplaced world axes."""
        return {j: self.unit * self.axes @ p for j, p in self.skeleton.end_sites().items()}


def placement_matrix(yaw: float, translation) -> np.ndarray:
    """4x4 placement: rotation by ``yaw`` (rad) about world z, then ``translation`` [3] (m)."""
    m = np.eye(4)
    m[:3, :3] = axis_rotation(2, yaw)
    m[:3, 3] = np.asarray(translation, float)
    return m


__all__ = ["CMU_UNIT", "ClipMotion", "Skeleton", "Y_UP_TO_Z_UP", "align_hemispheres", "axis_rotation",
           "matrix_from_quat", "nlerp_deviation", "nlerp_slerp_bound", "placement_matrix", "quat_from_matrix", "rotation_angle", "slerp"]
