r"""Rigid motion of an object: its transform, the velocity of every point, and the fit that finds it.

A rigid object is stored once (its mesh in its own frame, a PLY) and placed in every frame by a
transform ``to_world`` :math:`\mathbf x = \mathbf R\,\mathbf x_L + \mathbf p` (a proper rotation
:math:`\mathbf R` and a translation :math:`\mathbf p`; the frame XML's ``<transform name="to_world">``).
Its motion in a frame is then two vectors of the manifest (:mod:`sionnafmcw.animation`):

* ``velocity`` :math:`\mathbf v_c`: the velocity of the object's area-weighted centroid
  :math:`\mathbf c = \mathbf R\,\mathbf c_L + \mathbf p` (the same point every object's velocity
  refers to, and the run store's truth position);
* ``angular_velocity`` :math:`\boldsymbol\omega` (rad/s, world frame), defined by
  :math:`\dot{\mathbf R} = [\boldsymbol\omega]_\times\mathbf R`.

Every point of the object moves at

.. math:: \mathbf v(\mathbf x) = \mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c),

exactly (differentiate :math:`\mathbf x = \mathbf R\mathbf x_L + \mathbf p`:
:math:`\dot{\mathbf x} = \dot{\mathbf R}\mathbf x_L + \dot{\mathbf p}
= \boldsymbol\omega\times(\mathbf x - \mathbf p) + \dot{\mathbf p}`, and
:math:`\mathbf v_c = \boldsymbol\omega\times(\mathbf c - \mathbf p) + \dot{\mathbf p}`). The field is
affine in :math:`\mathbf x`, so its barycentric interpolation from a triangle's corners is exact.

Writers get :math:`\boldsymbol\omega` from the rotations at :math:`t \pm h`:
:math:`\mathbf R(t+h)\mathbf R(t-h)^T = \exp(2h[\boldsymbol\omega]_\times) + O(h^3)`, so
:math:`\boldsymbol\omega = \log(\mathbf R(t+h)\mathbf R(t-h)^T)^\vee/(2h)` (:func:`angular_velocity`,
:func:`rotation_vector`), the central difference of the rotation.

numpy only (the Blender exporter imports it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Largest vertex residual (m) of :func:`rigid_fit` for a mesh to count as a rigid motion of
#: another. Vertices are float32 in PLYs and in Blender (about 1e-6 m of rounding at 10 m, a few
#: such roundings through a transform); 1e-5 m is 10 of those and moves a two-way phase at 77 GHz
#: by at most :math:`2k\cdot 10^{-5}` = 0.03 rad, far below anything the radar resolves.
RIGID_TOLERANCE = 1e-5


@dataclass(frozen=True)
class RigidMotion:
    """An object's rigid motion in one frame: ``rotation`` [3, 3], ``translation`` [3] (m) of its
    ``to_world``, ``velocity`` [3] (m/s) of its centroid ``centroid`` [3] (m, world) and
    ``angular_velocity`` [3] (rad/s, world)."""

    rotation: np.ndarray
    translation: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    centroid: np.ndarray

    def point_velocities(self, points) -> np.ndarray:
        r""":math:`\mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c)` ``[..., 3]`` (m/s) at world ``points``."""
        points = np.asarray(points, float)
        return self.velocity + np.cross(self.angular_velocity, points - self.centroid)

    def to_world(self, local_points) -> np.ndarray:
        r""":math:`\mathbf R\,\mathbf x_L + \mathbf p` of local points ``[..., 3]``."""
        return np.asarray(local_points, float) @ self.rotation.T + self.translation


def transform_matrix(rotation, translation) -> np.ndarray:
    """The 4x4 ``to_world`` of a rotation [3, 3] and a translation [3]."""
    m = np.eye(4)
    m[:3, :3] = np.asarray(rotation, float)
    m[:3, 3] = np.asarray(translation, float)
    return m


def proper_rotation(matrix, tolerance: float = 1e-6):
    """``(R, p)`` of a 4x4 transform whose 3x3 part is a proper rotation (to ``tolerance``), else None."""
    m = np.asarray(matrix, float)
    r = m[:3, :3]
    if np.max(np.abs(r @ r.T - np.eye(3))) > tolerance or np.linalg.det(r) <= 0 or np.any(m[3] != (0, 0, 0, 1)):
        return None
    return r, m[:3, 3]


def rotation_vector(rotation) -> np.ndarray:
    r"""The rotation vector :math:`\theta\hat{\mathbf a}` of a proper rotation (the matrix logarithm's
    axial vector): from the unit quaternion, stable for small and large angles up to :math:`\pi`."""
    r = np.asarray(rotation, float)
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    # Shepperd's method: the largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2 picks the stable formula
    candidates = np.array([trace, r[0, 0], r[1, 1], r[2, 2]])
    k = int(np.argmax(candidates))
    if k == 0:
        w = 0.5 * np.sqrt(max(1.0 + trace, 0.0))
        x, y, z = (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w)
    elif k == 1:
        x = 0.5 * np.sqrt(max(1.0 + 2 * r[0, 0] - trace, 0.0))
        w, y, z = (r[2, 1] - r[1, 2]) / (4 * x), (r[0, 1] + r[1, 0]) / (4 * x), (r[0, 2] + r[2, 0]) / (4 * x)
    elif k == 2:
        y = 0.5 * np.sqrt(max(1.0 + 2 * r[1, 1] - trace, 0.0))
        w, x, z = (r[0, 2] - r[2, 0]) / (4 * y), (r[0, 1] + r[1, 0]) / (4 * y), (r[1, 2] + r[2, 1]) / (4 * y)
    else:
        z = 0.5 * np.sqrt(max(1.0 + 2 * r[2, 2] - trace, 0.0))
        w, x, y = (r[1, 0] - r[0, 1]) / (4 * z), (r[0, 2] + r[2, 0]) / (4 * z), (r[1, 2] + r[2, 1]) / (4 * z)
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    s = np.sqrt(x * x + y * y + z * z)
    if s < 1e-300:
        return np.zeros(3)
    angle = 2.0 * np.arctan2(s, w)
    return np.array([x, y, z]) * (angle / s)


def angular_velocity(rotation_after, rotation_before, interval: float) -> np.ndarray:
    r""":math:`\boldsymbol\omega = \log(\mathbf R_+\mathbf R_-^T)^\vee/\Delta t` (rad/s, world) of rotations
    ``interval`` seconds apart (module docstring; the central difference when they straddle the
    instant)."""
    if not interval > 0:
        raise ValueError(f"angular_velocity: interval must be > 0 s, got {interval!r}")
    return rotation_vector(np.asarray(rotation_after, float) @ np.asarray(rotation_before, float).T) / interval


def rigid_fit(reference, vertices):
    r"""``(R, p, residual)`` with ``vertices`` :math:`\approx \mathbf R\,\mathbf x + \mathbf p` over the
    vertices :math:`\mathbf x` of ``reference`` (same count and order), by Kabsch's least squares:
    with the centred sets :math:`A` (reference) and :math:`B` and the SVD :math:`A^TB = U\Sigma V^T`,
    :math:`\mathbf R = V\,\mathrm{diag}(1, 1, d)\,U^T`, :math:`d = \mathrm{sign}\det(VU^T)`;
    ``residual`` is the largest vertex distance (m) of the fit (``inf`` for different shapes)."""
    a = np.asarray(reference, float)
    b = np.asarray(vertices, float)
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 3 or len(a) == 0:
        return np.eye(3), np.zeros(3), float("inf")
    c_a, c_b = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - c_a).T @ (b - c_b))
    d = 1.0 if np.linalg.det(vt.T @ u.T) >= 0 else -1.0
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    p = c_b - r @ c_a
    residual = float(np.max(np.linalg.norm(a @ r.T + p - b, axis=1)))
    return r, p, residual


def area_centroid(vertices, faces) -> np.ndarray:
    r"""Area-weighted centroid :math:`\sum_f A_f(\mathbf a_f + \mathbf b_f + \mathbf c_f)/3 / \sum_f A_f`
    of a triangle mesh (the vertex mean for a mesh without area)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    if len(f):
        tri = v[f]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        total = area.sum()
        if total > 0:
            return (tri.mean(axis=1) * area[:, None]).sum(axis=0) / total
    return v.mean(axis=0)


__all__ = ["RIGID_TOLERANCE", "RigidMotion", "angular_velocity", "area_centroid", "proper_rotation", "rigid_fit",
           "rotation_vector", "transform_matrix"]
