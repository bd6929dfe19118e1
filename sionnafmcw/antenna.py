r"""Antenna element power patterns, identical to Sionna RT's vertically polarised ones.

Every element of the radar (Tx and Rx) carries the same pattern, with boresight along the
radar's local :math:`+x` axis. Directions are given in the radar frame as zenith angle
:math:`\theta` (from local :math:`+z`) and azimuth :math:`\varphi` (from local :math:`+x`
towards :math:`+y`), as in Sionna RT.

``"iso"``
    :math:`G(\theta, \varphi) = 1`.
``"tr38901"``
    3GPP TR 38.901 Table 7.3-1 element (the pattern Sionna RT registers as ``"tr38901"``):

    .. math::
        A_V = -\min\left(12\left(\tfrac{\theta - 90^\circ}{65^\circ}\right)^2, 30\right),\quad
        A_H = -\min\left(12\left(\tfrac{\varphi}{65^\circ}\right)^2, 30\right)

        G_{dB} = 8 - \min(-(A_V + A_H), 30)

    i.e. 8 dBi at boresight, 65 degree half-power beamwidth, 30 dB front-to-back ratio; a fair
    stand-in for the patch elements of 77 GHz radar boards.

The path engine hands the same name to Sionna's antenna-pattern registry (its elements form a
custom ``AntennaArray``, :mod:`sionnafmcw.engines.path`), so that both engines and the analytic
point targets apply one and the same gain.
"""

from __future__ import annotations

import numpy as np

PATTERNS = ("iso", "tr38901")


def check_pattern(name: str) -> str:
    """Return ``name`` if it is a known pattern, else raise a ValueError listing the choices."""
    if name not in PATTERNS:
        raise ValueError(
            f"antenna_pattern={name!r} is not supported; choose one of {', '.join(PATTERNS)}"
        )
    return name


def antenna_gain(pattern: str, theta, phi) -> np.ndarray:
    """Linear power gain of one element towards zenith ``theta`` and azimuth ``phi`` (rad)."""
    check_pattern(pattern)
    theta = np.asarray(theta, dtype=float)
    phi = np.asarray(phi, dtype=float)
    if pattern == "iso":
        return np.ones(np.broadcast(theta, phi).shape)
    phi = np.mod(phi + np.pi, 2 * np.pi) - np.pi
    half_power = np.deg2rad(65.0)
    a_v = -np.minimum(12.0 * ((theta - np.pi / 2) / half_power) ** 2, 30.0)
    a_h = -np.minimum(12.0 * (phi / half_power) ** 2, 30.0)
    a_db = -np.minimum(-(a_v + a_h), 30.0) + 8.0
    return 10.0 ** (a_db / 10.0)


def direction_angles(direction) -> tuple[np.ndarray, np.ndarray]:
    """Zenith and azimuth angles (rad) of direction vectors ``[..., 3]`` in the radar frame."""
    d = np.asarray(direction, dtype=float)
    norm = np.linalg.norm(d, axis=-1)
    theta = np.arccos(np.clip(d[..., 2] / norm, -1.0, 1.0))
    phi = np.arctan2(d[..., 1], d[..., 0])
    return theta, phi
