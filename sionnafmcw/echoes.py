r"""Echoes: what both engines hand to the beat synthesizer.

An :class:`Echoes` holds, for every transmit element :math:`m`, receive element :math:`n` and
contribution :math:`p` (a propagation path, or a pixel), at the start of the CPI:

* ``a[m, n, p]``: complex baseband gain, Sionna RT's convention (no carrier phase
  :math:`e^{-j2\pi f_c\tau}`), so that :math:`P_r = P_t |a|^2`;
* ``tau[m, n, p]``: delay (s);
* ``doppler[m, n, p]``: Doppler shift (Hz), positive for an approaching reflector, so that the
  delay evolves as :math:`\tau(t) = \tau_0 - (f_D/f_c)(t - t_n)`.

Tx is in physical element order. Zero-gain entries are padding (Sionna pads per-link path
lists to a common length).

Ideal point targets (:meth:`Echoes.point_targets`) use spherical wavefronts per element and the
bistatic radar equation

.. math::
    a_{mnp} = \frac{\lambda \sqrt{G_t G_r \sigma_p}}{(4\pi)^{3/2} R^{t}_{mp} R^{r}_{np}},
    \qquad \tau_{mnp} = \frac{R^t_{mp} + R^r_{np}}{c},
    \qquad f_{D,mnp} = -\frac{\mathbf v_p\cdot(\hat{\mathbf u}^t_{mp} + \hat{\mathbf u}^r_{np})}{\lambda},

with :math:`\lambda = c/f_c`, :math:`R^t_{mp} = \|\mathbf p_p - \mathbf t_m\|`,
:math:`\hat{\mathbf u}^t_{mp}` the unit vector from Tx element :math:`m` to the target (likewise
for Rx) and :math:`G_t, G_r` the element pattern gains towards the target. The target moves
radially: :math:`\mathbf v_p = \dot R_p\,\hat{\mathbf u}_p` with :math:`\dot R_p` positive receding.
Monostatically this gives :math:`P_r = P_t G^2\lambda^2\sigma/((4\pi)^3R^4)` and
:math:`f_D = -2\dot R/\lambda`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .antenna import antenna_gain, direction_angles
from .constants import SPEED_OF_LIGHT


def target_direction(azimuth, elevation) -> np.ndarray:
    """Unit vectors ``[..., 3]`` in the radar frame; azimuth from +x towards +y, elevation towards +z (rad)."""
    az = np.asarray(azimuth, dtype=float)
    el = np.asarray(elevation, dtype=float)
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)


@dataclass
class Echoes:
    """Per-element contributions ``[num_tx, num_rx, num_contributions]`` at the CPI start."""

    a: np.ndarray
    tau: np.ndarray
    doppler: np.ndarray
    labels: np.ndarray | None = None

    def __post_init__(self):
        self.a = np.asarray(self.a, dtype=np.complex128)
        self.tau = np.asarray(self.tau, dtype=np.float64)
        self.doppler = np.asarray(self.doppler, dtype=np.float64)
        if self.a.ndim != 3:
            raise ValueError(f"Echoes.a must have shape [num_tx, num_rx, num_contributions], got {self.a.shape}")
        for name in ("tau", "doppler"):
            if getattr(self, name).shape != self.a.shape:
                raise ValueError(
                    f"Echoes.{name} has shape {getattr(self, name).shape}, expected {self.a.shape} like Echoes.a"
                )
        for name in ("a", "tau", "doppler"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"Echoes.{name} contains non-finite values")
        if np.any(self.tau[self.a != 0] < 0):
            raise ValueError("Echoes.tau must be >= 0 for every contribution with non-zero gain")
        if self.labels is not None:
            labels = np.asarray(self.labels)
            if labels.shape == (self.a.shape[2],):
                labels = np.broadcast_to(labels, self.a.shape)
            if labels.shape != self.a.shape:
                raise ValueError(
                    f"Echoes.labels must have shape [num_contributions] or {self.a.shape}, got {labels.shape}"
                )
            self.labels = labels

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.a.shape

    @property
    def num_tx(self) -> int:
        return self.a.shape[0]

    @property
    def num_rx(self) -> int:
        return self.a.shape[1]

    @property
    def num_contributions(self) -> int:
        return self.a.shape[2]

    @classmethod
    def empty(cls, num_tx: int, num_rx: int) -> "Echoes":
        z = np.zeros((num_tx, num_rx, 0))
        return cls(z.astype(complex), z, z)

    @classmethod
    def concatenate(cls, parts: list["Echoes"]) -> "Echoes":
        """All contributions of ``parts`` side by side (labels kept where every part has them)."""
        labels = None
        if parts and all(p.labels is not None for p in parts):
            labels = np.concatenate([np.asarray(p.labels) for p in parts], axis=2)
        return cls(
            np.concatenate([p.a for p in parts], axis=2),
            np.concatenate([p.tau for p in parts], axis=2),
            np.concatenate([p.doppler for p in parts], axis=2),
            labels,
        )

    def select(self, mask) -> "Echoes":
        """Keep the contributions where ``mask`` ([num_contributions] bool) is true."""
        mask = np.asarray(mask, dtype=bool)
        labels = None if self.labels is None else np.asarray(self.labels)[..., mask]
        return Echoes(self.a[..., mask], self.tau[..., mask], self.doppler[..., mask], labels)

    def received_power(self, tx_power: float) -> np.ndarray:
        """:math:`P_t |a|^2` per element pair and contribution (W)."""
        return tx_power * np.abs(self.a) ** 2

    @classmethod
    def leakage(cls, radar, coupling_db: float) -> "Echoes":
        r"""Direct Tx-to-Rx coupling (leakage) of every element pair, as explicit contributions.

        The path engine does not model it (Sionna drops segments shorter than 1 cm and the radar
        runs with ``los=False``). Each pair :math:`(m, n)` gets one contribution with
        :math:`|a| = 10^{C/20}` (``coupling_db`` = :math:`C`, the power coupling, e.g. -30 dB on
        TI boards), delay :math:`\|\mathbf t_m - \mathbf r_n\|/c` and zero Doppler: a static
        tone near range zero, removed by static clutter removal. Label ``"leakage"``.
        """
        if not np.isfinite(coupling_db):
            raise ValueError(f"Echoes.leakage: coupling_db must be finite, got {coupling_db!r}")
        d = np.linalg.norm(radar.tx_positions[:, None, :] - radar.rx_positions[None, :, :], axis=-1)
        shape = (radar.num_tx, radar.num_rx, 1)
        a = np.full(shape, 10 ** (coupling_db / 20), dtype=complex)
        return cls(a, (d / SPEED_OF_LIGHT)[..., None], np.zeros(shape), np.full(shape, "leakage"))

    @classmethod
    def point_targets(cls, radar, ranges, radial_velocities, azimuths, elevations=0.0, rcs=1.0,
                      labels=None) -> "Echoes":
        """Ideal point targets in the radar frame (see the module docstring for the model).

        Parameters
        ----------
        radar : RadarConfig
        ranges : array_like, m, from the radar frame origin at the CPI start
        radial_velocities : array_like, m/s, range rate (positive receding)
        azimuths, elevations : array_like, rad (azimuth positive towards +y)
        rcs : array_like, m^2
        """
        ranges, velocities, az, el, rcs = np.broadcast_arrays(
            *(np.atleast_1d(np.asarray(x, dtype=float)) for x in (ranges, radial_velocities, azimuths, elevations, rcs))
        )
        if np.any(ranges <= 0):
            raise ValueError("point_targets: ranges must be > 0 m")
        if np.any(rcs < 0):
            raise ValueError("point_targets: rcs must be >= 0 m^2")
        u = target_direction(az, el)  # [P,3]
        position = ranges[:, None] * u
        velocity = velocities[:, None] * u
        wavelength = SPEED_OF_LIGHT / radar.fc

        d_t = position[None, :, :] - radar.tx_positions[:, None, :]  # [M,P,3]
        d_r = position[None, :, :] - radar.rx_positions[:, None, :]  # [N,P,3]
        r_t = np.linalg.norm(d_t, axis=-1)
        r_r = np.linalg.norm(d_r, axis=-1)
        g_t = antenna_gain(radar.antenna_pattern, *direction_angles(d_t))
        g_r = antenna_gain(radar.antenna_pattern, *direction_angles(d_r))
        rate_t = np.einsum("mpi,pi->mp", d_t, velocity) / r_t  # dR_t/dt
        rate_r = np.einsum("npi,pi->np", d_r, velocity) / r_r

        amplitude = wavelength * np.sqrt(g_t[:, None, :] * g_r[None, :, :] * rcs) / (
            (4 * np.pi) ** 1.5 * r_t[:, None, :] * r_r[None, :, :]
        )
        tau = (r_t[:, None, :] + r_r[None, :, :]) / SPEED_OF_LIGHT
        doppler = -(rate_t[:, None, :] + rate_r[None, :, :]) / wavelength
        return cls(amplitude.astype(complex), tau, doppler, labels)
