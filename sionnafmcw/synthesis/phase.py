r"""The beat (IF) phase of one contribution, exactly and as a polynomial in (chirp, sample).

Model (NOTES section 2). For a contribution with gain :math:`a`, delay :math:`\tau_0` and
Doppler :math:`f_D` at the CPI start :math:`t_n`, the delay evolves as
:math:`\tau(t) = \tau_0 - \nu (t - t_n)` with :math:`\nu = f_D / f_c`. The transmitted chirp is
:math:`e^{j2\pi(f_c t' + \mu t'^2/2)}` (:math:`t'` the time into the ramp) and the IF signal is
:math:`x = s_{tx}\,\overline{s_{rx}}`, which gives

.. math::
    x = \sqrt{P_t}\,\bar a\, e^{j2\pi\varphi},\qquad
    \varphi = f_c\tau + \mu\tau t_f - \tfrac{\mu}{2}\tau^2,\qquad \tau = \tau(t_n + s + t_f),

where :math:`s = (lM + q)T_c` is the start of chirp :math:`l` of the Tx at firing slot
:math:`q` and :math:`t_f = t_{adc} + k/F_s` the fast time of sample :math:`k`. This
:func:`exact_phase` is what the direct reference sum evaluates, term for term.

Polynomial form. Put :math:`t_f = t_{mid} + u`, :math:`u = k'/F_s` with the centred sample
index :math:`k' = k - (N_s - 1)/2`, let :math:`F = f_c + \mu t_{mid}` (sweep centre),
:math:`T_b = M T_c`, and :math:`\tau_a = \tau_0 - \nu(qT_c + t_{mid})` the delay at the centre
of the first ADC window of this Tx. Then :math:`\tau = \tau_a - \nu T_b l - \nu u` and
expanding :math:`\varphi = F\tau + \mu\tau u - \mu\tau^2/2` exactly:

.. math::
    \varphi = \Phi_0 + A k' + B l + C l k' + K_u k'^2 + K_l l^2

.. math::
    \Phi_0 &= F\tau_a - \mu\tau_a^2/2, &
    A &= \left[\mu\tau_a(1+\nu) - F\nu\right]/F_s, &
    B &= -\nu T_b (F - \mu\tau_a),\\
    C &= -\mu\nu(1+\nu)T_b/F_s, &
    K_u &= -\mu\nu(1+\nu/2)/F_s^2, &
    K_l &= -\mu\nu^2T_b^2/2.

:math:`A` is the beat frequency (cycles per sample), :math:`B` the Doppler phase step per TDM
block, :math:`C` range migration inside the CPI (the delay, hence the beat frequency, drifts
from chirp to chirp: about one cycle over a 27 ms CPI at 4.5 m/s, never negligible),
:math:`K_u` the Doppler-induced chirp-rate change and :math:`K_l` the second-order range
migration. Nothing is dropped: the polynomial is exact, degree 2 in :math:`(l, k')`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def exact_phase(tau0, nu, chirp_start, fast_time, radar) -> np.ndarray:
    r"""Beat phase in cycles, :math:`f_c\tau + \mu\tau t_f - \mu\tau^2/2` with :math:`\tau = \tau_0 - \nu(s + t_f)`.

    All arguments broadcast; times in seconds from the CPI start (``chirp_start`` = s) and from
    the ramp start (``fast_time`` = :math:`t_f`).
    """
    tau = tau0 - nu * (chirp_start + fast_time)
    return radar.fc * tau + radar.slope * tau * fast_time - 0.5 * radar.slope * tau**2


@dataclass
class PhasePolynomial:
    """Coefficients (cycles) of :math:`\\varphi = \\Phi_0 + A k' + B l + C l k' + K_u k'^2 + K_l l^2`.

    Each attribute has the shape of the ``tau0`` / ``nu`` arrays it was built from.
    """

    phi0: np.ndarray
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    k_u: np.ndarray
    k_l: np.ndarray

    @classmethod
    def from_delay_doppler(cls, tau0, nu, slot, radar) -> "PhasePolynomial":
        """Coefficients for delays ``tau0`` (s), ``nu = f_D/f_c`` and Tx firing slot(s) ``slot``."""
        mu, fs = radar.slope, radar.fs
        t_mid = radar.adc_centre_time
        f_mid = radar.centre_frequency
        t_b = radar.block_interval
        tau_a = tau0 - nu * (np.asarray(slot) * radar.chirp_interval + t_mid)
        return cls(
            phi0=f_mid * tau_a - 0.5 * mu * tau_a**2,
            a=(mu * tau_a * (1 + nu) - f_mid * nu) / fs,
            b=-nu * t_b * (f_mid - mu * tau_a),
            c=-mu * nu * (1 + nu) * t_b / fs,
            k_u=-mu * nu * (1 + nu / 2) / fs**2,
            k_l=-mu * nu**2 * t_b**2 / 2,
        )

    def shift_chirp_origin(self, l0: float) -> "PhasePolynomial":
        """The same polynomial in :math:`l' = l - l_0` (exact re-expansion)."""
        return PhasePolynomial(
            phi0=self.phi0 + self.b * l0 + self.k_l * l0**2,
            a=self.a + self.c * l0,
            b=self.b + 2 * self.k_l * l0,
            c=self.c,
            k_u=self.k_u,
            k_l=self.k_l,
        )

    def evaluate(self, chirp_index, sample_index_centred) -> np.ndarray:
        """:math:`\\varphi` (cycles) at broadcastable ``l`` and ``k'``."""
        l, k = chirp_index, sample_index_centred
        return (self.phi0 + self.a * k + self.b * l + self.c * l * k
                + self.k_u * k**2 + self.k_l * l**2)
