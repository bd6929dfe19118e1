r"""Kinematics of a path: range rates and range accelerations, the moving radar's elements, mirror images.

A contribution's path length :math:`L(t)` (Tx element, interaction points, Rx element) sets its
Doppler shift and, for motion within the CPI, its Doppler rate
(:class:`~sionnafmcw.echoes.Echoes`):

.. math:: f_D = -\frac{\dot L}{\lambda}, \qquad \dot f_D = -\frac{\ddot L}{\lambda}.

One segment. For a segment from a point :math:`\mathbf x_0(t)` to a point :math:`\mathbf x_1(t)`
with :math:`\mathbf d = \mathbf x_1 - \mathbf x_0`, :math:`R = \lVert\mathbf d\rVert`,
:math:`\hat{\mathbf s} = \mathbf d/R`, relative velocity :math:`\Delta\mathbf v = \dot{\mathbf x}_1 -
\dot{\mathbf x}_0` and relative acceleration :math:`\Delta\mathbf a`: :math:`R^2 = \mathbf d\cdot\mathbf d`
gives :math:`R\dot R = \mathbf d\cdot\Delta\mathbf v`, and once more
:math:`\dot R^2 + R\ddot R = \Delta\mathbf v\cdot\Delta\mathbf v + \mathbf d\cdot\Delta\mathbf a`, so

.. math::
    \dot R = \hat{\mathbf s}\cdot\Delta\mathbf v, \qquad
    \ddot R = \hat{\mathbf s}\cdot\Delta\mathbf a
              + \frac{\lVert\Delta\mathbf v\rVert^2 - (\hat{\mathbf s}\cdot\Delta\mathbf v)^2}{R}

(:func:`range_rate`, :func:`range_acceleration`): the radial acceleration plus the centripetal term of the velocity across the line of sight
(:math:`v_\perp^2/R`: a target passing a radar at 4.5 m/s and 3 m, 6.8 m/s^2, a Doppler sweep of
3.5 kHz/s at 77 GHz). A path's :math:`\ddot L` is the sum over its segments. A moving radar's
elements are points of it (:func:`element_kinematics`); the bistatic Doppler of element pair
:math:`(m, n)` is then relative by construction,
:math:`f_{D,mn} = -\frac{1}{\lambda}\frac{d}{dt}\big(\lVert\mathbf x - \mathbf t_m(t)\rVert
+ \lVert\mathbf x - \mathbf r_n(t)\rVert\big)`, and the radar's own motion adds to every
contribution (static clutter included) the *ego-Doppler*

.. math::
    f_{ego,mn} = \frac{\dot{\mathbf t}_m\cdot\hat{\mathbf k}_{m} - \dot{\mathbf r}_n\cdot\hat{\mathbf k}'_{n}}{\lambda}

(:func:`ego_doppler`), :math:`\hat{\mathbf k}_m` the unit vector from Tx element :math:`m` to the path's first
interaction point, :math:`\hat{\mathbf k}'_n` from its last interaction point to Rx element
:math:`n`: monostatically :math:`2v\cos\theta/\lambda` (positive, approaching) for a radar moving
at :math:`v` at an angle :math:`\theta` to the line of sight towards a static reflector.

Specular reflections. The interaction points the engines hold are material points, and a
diffuse scatterer or a PO surface sample *is* one. A specular reflection point is not: it
slides on the mirror as the geometry changes. By Fermat's principle holding it fixed leaves
:math:`\dot L` right (the length is stationary in it), but not :math:`\ddot L`: the centripetal
term of the fixed point's segments is the wrong one. The exact length of a chain over a plane
mirror is the distance from the mirror image of its start, :math:`L = \lVert\mathbf x_1 - M(\mathbf x_0)\rVert`,
with :math:`M(\mathbf x) = \mathbf x - 2\hat{\mathbf n}(\hat{\mathbf n}\cdot(\mathbf x - \mathbf q))`
for a mirror through :math:`\mathbf q` with normal :math:`\hat{\mathbf n}`; :func:`mirror_image`
moves the image with the mirror (its translation :math:`\dot{\mathbf q}, \ddot{\mathbf q}` and
rotation :math:`\boldsymbol\omega, \boldsymbol\alpha`): with :math:`\mathbf d = \mathbf x - \mathbf q`,
:math:`s = \hat{\mathbf n}\cdot\mathbf d`,

.. math::
    M = \mathbf x - 2\hat{\mathbf n}s,\quad
    \dot M = \dot{\mathbf x} - 2\dot{\hat{\mathbf n}}s - 2\hat{\mathbf n}\dot s,\quad
    \ddot M = \ddot{\mathbf x} - 2\ddot{\hat{\mathbf n}}s - 4\dot{\hat{\mathbf n}}\dot s - 2\hat{\mathbf n}\ddot s,

:math:`\dot s = \dot{\hat{\mathbf n}}\cdot\mathbf d + \hat{\mathbf n}\cdot\dot{\mathbf d}`,
:math:`\ddot s = \ddot{\hat{\mathbf n}}\cdot\mathbf d + 2\dot{\hat{\mathbf n}}\cdot\dot{\mathbf d}
+ \hat{\mathbf n}\cdot\ddot{\mathbf d}`, :math:`\dot{\hat{\mathbf n}} = \boldsymbol\omega\times\hat{\mathbf n}`,
:math:`\ddot{\hat{\mathbf n}} = \boldsymbol\alpha\times\hat{\mathbf n} + \boldsymbol\omega\times(\boldsymbol\omega\times\hat{\mathbf n})`.
A static mirror (the floor) gives :math:`\ddot L` of the unfolded segment, whose centripetal term
has the whole unfolded length in its denominator, not the last segment's.

Everything here is numpy on broadcastable ``[..., 3]`` arrays (m, m/s, m/s^2, world frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def range_rate(start, v_start, end, v_end) -> np.ndarray:
    r""":math:`\dot R = \hat{\mathbf s}\cdot\Delta\mathbf v` (m/s) of the segments ``start -> end`` (module docstring)."""
    d = np.asarray(end, float) - np.asarray(start, float)
    r = np.linalg.norm(d, axis=-1)
    return _dot(d, np.asarray(v_end, float) - np.asarray(v_start, float)) / r


def range_acceleration(start, v_start, a_start, end, v_end, a_end) -> np.ndarray:
    r""":math:`\ddot R = \hat{\mathbf s}\cdot\Delta\mathbf a + (\lVert\Delta\mathbf v\rVert^2
    - (\hat{\mathbf s}\cdot\Delta\mathbf v)^2)/R` (m/s^2) of the segments ``start -> end``
    (module docstring); every argument ``[..., 3]``, broadcast."""
    d = np.asarray(end, float) - np.asarray(start, float)
    r = np.linalg.norm(d, axis=-1)
    s = d / r[..., None]
    dv = np.asarray(v_end, float) - np.asarray(v_start, float)
    da = np.asarray(a_end, float) - np.asarray(a_start, float)
    radial = _dot(s, dv)
    return _dot(s, da) + (_dot(dv, dv) - radial * radial) / r


@dataclass(frozen=True)
class PointKinematics:
    """Position ``[..., 3]`` (m), velocity (m/s) and acceleration (m/s^2) of points, world frame."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray

    def __getitem__(self, index) -> PointKinematics:
        return PointKinematics(self.position[index], self.velocity[index], self.acceleration[index])


def rigid_point_kinematics(points, centre, velocity, angular_velocity, acceleration=None,
                           angular_acceleration=None) -> PointKinematics:
    r"""Kinematics of points ``[..., 3]`` of a rigid body whose point ``centre`` moves at ``velocity`` and
    ``acceleration`` while it turns at ``angular_velocity`` :math:`\boldsymbol\omega` with
    ``angular_acceleration`` :math:`\boldsymbol\alpha` (all world):
    :math:`\mathbf v = \mathbf v_c + \boldsymbol\omega\times\mathbf r`,
    :math:`\mathbf a = \mathbf a_c + \boldsymbol\alpha\times\mathbf r + \boldsymbol\omega\times(\boldsymbol\omega\times\mathbf r)`,
    :math:`\mathbf r = \mathbf x - \mathbf c` (differentiate :math:`\mathbf v` once more with
    :math:`\dot{\mathbf r} = \boldsymbol\omega\times\mathbf r`)."""
    x = np.asarray(points, float)
    r = x - np.asarray(centre, float)
    w = np.asarray(angular_velocity, float)
    alpha = np.zeros(3) if angular_acceleration is None else np.asarray(angular_acceleration, float)
    a_c = np.zeros(3) if acceleration is None else np.asarray(acceleration, float)
    wr = np.cross(w, r)
    v = np.asarray(velocity, float) + wr
    a = a_c + np.cross(alpha, r) + np.cross(w, wr)
    return PointKinematics(x, np.broadcast_to(v, x.shape).copy(), np.broadcast_to(a, x.shape).copy())


def element_kinematics(pose, local_positions) -> PointKinematics:
    r"""World kinematics ``[K, 3]`` of the radar's elements at radar-frame ``local_positions [K, 3]`` for a
    :class:`~sionnafmcw.animation.RadarPose` (its position is the radar origin; its velocity,
    angular velocity, acceleration and angular acceleration those of the radar frame):
    :func:`rigid_point_kinematics` about the radar origin."""
    from .geometry import rotation_matrix

    rot = rotation_matrix(pose.orientation)
    points = np.asarray(pose.position, float) + np.atleast_2d(np.asarray(local_positions, float)) @ rot.T
    return rigid_point_kinematics(points, pose.position, pose.velocity, pose.angular_velocity, pose.acceleration,
                                  pose.angular_acceleration)


def ego_doppler(tx: PointKinematics, rx: PointKinematics, first_points, last_points, wavelength: float) -> np.ndarray:
    r"""The radar's share of every element pair's Doppler ``[M, N, P]`` (Hz, positive approaching):
    :math:`(\dot{\mathbf t}_m\cdot\hat{\mathbf k}_m - \dot{\mathbf r}_n\cdot\hat{\mathbf k}'_n)/\lambda` with
    :math:`\hat{\mathbf k}_m` from Tx element :math:`m` (``tx`` ``[M]``) to the path's first interaction point
    (``first_points [P, 3]``) and :math:`\hat{\mathbf k}'_n` from its last (``last_points [P, 3]``) to Rx
    element :math:`n` (``rx`` ``[N]``) (module docstring). Paths with the same first and last points
    share the per-element terms, :math:`M + N` rows of work instead of :math:`MN`."""
    first = np.asarray(first_points, float)
    last = np.asarray(last_points, float)
    k_tx = first[None] - tx.position[:, None]                           # [M, P, 3]
    k_tx /= np.linalg.norm(k_tx, axis=-1, keepdims=True)
    k_rx = rx.position[:, None] - last[None]                            # [N, P, 3]
    k_rx /= np.linalg.norm(k_rx, axis=-1, keepdims=True)
    f_tx = np.einsum("mi,mpi->mp", tx.velocity, k_tx) / wavelength
    f_rx = -np.einsum("ni,npi->np", rx.velocity, k_rx) / wavelength
    return f_tx[:, None, :] + f_rx[None, :, :]


def mirror_image(x: PointKinematics, mirror_point: PointKinematics, normal, angular_velocity=None,
                 angular_acceleration=None) -> PointKinematics:
    r"""The image of the moving point ``x`` in a moving plane mirror (module docstring): the mirror passes
    through the material point ``mirror_point`` with unit ``normal`` and turns at ``angular_velocity``
    :math:`\boldsymbol\omega` with ``angular_acceleration`` :math:`\boldsymbol\alpha` (zero when None:
    a translating or static mirror). Arrays ``[..., 3]``, broadcast."""
    n = np.asarray(normal, float)
    zero = np.zeros(n.shape)
    w = zero if angular_velocity is None else np.broadcast_to(np.asarray(angular_velocity, float), n.shape)
    alpha = zero if angular_acceleration is None else np.broadcast_to(np.asarray(angular_acceleration, float), n.shape)
    n_dot = np.cross(w, n)
    n_ddot = np.cross(alpha, n) + np.cross(w, n_dot)
    d = x.position - mirror_point.position
    d_dot = x.velocity - mirror_point.velocity
    d_ddot = x.acceleration - mirror_point.acceleration
    s = _dot(n, d)[..., None]
    s_dot = (_dot(n_dot, d) + _dot(n, d_dot))[..., None]
    s_ddot = (_dot(n_ddot, d) + 2 * _dot(n_dot, d_dot) + _dot(n, d_ddot))[..., None]
    return PointKinematics(x.position - 2 * n * s,
                           x.velocity - 2 * n_dot * s - 2 * n * s_dot,
                           x.acceleration - 2 * n_ddot * s - 4 * n_dot * s_dot - 2 * n * s_ddot)


__all__ = ["PointKinematics", "ego_doppler", "element_kinematics", "mirror_image", "range_acceleration", "range_rate",
           "rigid_point_kinematics"]
