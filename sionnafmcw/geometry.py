r"""Radar pose: frames, rotations and the ground truth seen from the radar.

The radar frame has boresight along local :math:`+x`, azimuth towards :math:`+y`, elevation
towards :math:`+z`. Its orientation in the world is Sionna RT's :math:`(\alpha, \beta, \gamma)` =
(yaw, pitch, roll) rotation about :math:`(z, y, x)`:

.. math:: \mathbf R = \mathbf R_z(\alpha)\,\mathbf R_y(\beta)\,\mathbf R_x(\gamma)

(3GPP TR 38.901 eq. 7.1-4, Sionna's ``rotation_matrix``), so a point :math:`\mathbf p_r` of the
radar frame is at :math:`\mathbf p_w = \mathbf c + \mathbf R\,\mathbf p_r` in the world.
"""

from __future__ import annotations

import numpy as np

from . import array


def rotation_matrix(orientation) -> np.ndarray:
    """:math:`R_z(yaw) R_y(pitch) R_x(roll)` for ``orientation = [yaw, pitch, roll]`` (rad)."""
    a, b, c = (float(x) for x in orientation)
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    return np.array([
        [ca * cb, ca * sb * sc - sa * cc, ca * sb * cc + sa * sc],
        [sa * cb, sa * sb * sc + ca * cc, sa * sb * cc - ca * sc],
        [-sb, cb * sc, cb * cc],
    ])


def radar_to_world(points, position, orientation) -> np.ndarray:
    """Radar-frame points ``[..., 3]`` to world coordinates."""
    return np.asarray(points, float) @ rotation_matrix(orientation).T + np.asarray(position, float)


def world_to_radar(points, position, orientation) -> np.ndarray:
    """World points ``[..., 3]`` to the radar frame."""
    return (np.asarray(points, float) - np.asarray(position, float)) @ rotation_matrix(orientation)


def world_phase_centre(radar, position, orientation) -> np.ndarray:
    r"""World position of the virtual array's phase centre, :math:`\mathbf c_w = \mathbf c + \mathbf R\,\mathbf c_r` (m, ``[3]``).

    :math:`\mathbf c_r` is :func:`sionnafmcw.array.phase_centre` (radar frame), ``position`` the
    radar origin :math:`\mathbf c` and ``orientation`` its (yaw, pitch, roll) in the world.
    """
    return radar_to_world(array.phase_centre(radar), position, orientation)


def radial_velocity(positions, velocities, origin) -> np.ndarray:
    r"""Range rate :math:`\dot R = (\mathbf p - \mathbf o)\cdot\mathbf v / \|\mathbf p - \mathbf o\|` (m/s, positive receding)."""
    d = np.asarray(positions, float) - np.asarray(origin, float)
    return np.einsum("...i,...i->...", d, np.asarray(velocities, float)) / np.linalg.norm(d, axis=-1)
