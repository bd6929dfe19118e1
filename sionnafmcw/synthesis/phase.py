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

Motion within the CPI. With a Doppler rate :math:`\dot f_D` the delay is
:math:`\tau(t) = \tau_0 - \nu(t - t_n) - \beta(t - t_n)^2/2`, :math:`\beta = \dot f_D/f_c`
(:class:`~sionnafmcw.echoes.Echoes`). With :math:`w = T_b l + u` the time from the centre of the
first ADC window of the Tx, :math:`t_a = qT_c + t_{mid}`, :math:`\nu_a = \nu + \beta t_a` the
rate there and :math:`\tau_a = \tau_0 - \nu t_a - \beta t_a^2/2`,
:math:`\tau = \tau_a - \nu_a w - \beta w^2/2`, and the same expansion of
:math:`\varphi = F\tau + \mu\tau u - \mu\tau^2/2` gives :math:`\Phi_0, A, B` above with
:math:`(\tau_a, \nu_a)` in place of :math:`(\tau_a, \nu)` and

.. math::
    C &= -T_b\left[\beta(F - \mu\tau_a) + \mu\nu_a(1 + \nu_a)\right]/F_s, &
    K_u &= -\left[\mu\nu_a(1 + \nu_a/2) + \tfrac{\beta}{2}(F - \mu\tau_a)\right]/F_s^2,\\
    K_l &= -\tfrac{T_b^2}{2}\left[\beta(F - \mu\tau_a) + \mu\nu_a^2\right], &
    D &= -\mu\beta T_b^2(1 + 3\nu_a)/(2F_s), &
    E &= -\mu\beta T_b(1 + 3\nu_a/2)/F_s^2, \qquad G = -\mu\beta(1 + \nu_a)/(2F_s^3)

(the terms :math:`D\,l^2k'`, :math:`E\,lk'^2` and :math:`G\,k'^3`), and terms of degree 3 and 4 in
:math:`(w, u)` that the polynomial leaves out and bounds (:attr:`PhasePolynomial.dropped`, cycles on
the grid):

.. math::
    \tfrac{|\mu\nu_a\beta|}{2}\big((L-1)T_b\big)^3 + \tfrac{|\mu|\beta^2}{8}(w_{max} + u_{max})^4,

:math:`u_{max} = (N_s-1)/(2F_s)`, :math:`w_{max} = (L-1)T_b + u_{max}`: some :math:`10^{-7}`
cycles for 150 m/s^2 over the whole CPI of ``walk-77ghz``. :math:`K_l` now
holds the Doppler sweep (:math:`\pi\dot f_D t^2`: tens of radians over a CPI for a swinging
foot) and :math:`D \approx \varepsilon_1 K_l`, :math:`\varepsilon_1 = \mu/(F_sF)`, its keystone
(the sweep seen at each sample's frequency :math:`F + \mu u`). The sweep's share of :math:`C`,
:math:`K_u`, :math:`K_l` is one term, :math:`K_s(l + k'/(T_bF_s))^2` with
:math:`K_s = -\beta(F - \mu\tau_a)T_b^2/2` (:attr:`PhasePolynomial.sweep`): the quadratic phase of
the time :math:`w/T_b` since the first ADC window's centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def exact_phase(tau0, nu, chirp_start, fast_time, radar, beta=None) -> np.ndarray:
    r"""Beat phase in cycles, :math:`f_c\tau + \mu\tau t_f - \mu\tau^2/2` with
    :math:`\tau = \tau_0 - \nu t - \beta t^2/2`, :math:`t = s + t_f`.

    All arguments broadcast; times in seconds from the CPI start (``chirp_start`` = s) and from
    the ramp start (``fast_time`` = :math:`t_f`); ``beta`` :math:`= \dot f_D/f_c` (1/s, None: 0).
    """
    t = chirp_start + fast_time
    tau = tau0 - nu * t
    if beta is not None:
        tau = tau - 0.5 * beta * t * t
    return radar.fc * tau + radar.slope * tau * fast_time - 0.5 * radar.slope * tau**2


@dataclass
class PhasePolynomial:
    """Coefficients (cycles) of :math:`\\varphi = \\Phi_0 + A k' + B l + C l k' + K_u k'^2 + K_l l^2 + D l^2k'`.

    Each attribute has the shape of the ``tau0`` / ``nu`` arrays it was built from; ``d`` (the
    :math:`l^2k'` term of a Doppler rate) and ``dropped`` (a bound, cycles, on the terms of
    degree 3-4 left out) are None without Doppler rates (module docstring).
    """

    phi0: np.ndarray
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    k_u: np.ndarray
    k_l: np.ndarray
    d: np.ndarray | None = None
    e: np.ndarray | None = None
    g: np.ndarray | None = None          # the k'^3 coefficient (a Doppler rate within the chirp)
    dropped: np.ndarray | None = None
    sweep: np.ndarray | None = None      # K_s = -beta (F - mu tau_a) T_b^2 / 2: the Doppler sweep's share of K_l

    @classmethod
    def from_delay_doppler(cls, tau0, nu, slot, radar, beta=None) -> "PhasePolynomial":
        """Coefficients for delays ``tau0`` (s), ``nu = f_D/f_c``, Tx firing slot(s) ``slot`` and, for
        motion within the CPI, ``beta`` :math:`= \\dot f_D/f_c` (1/s; module docstring)."""
        mu, fs = radar.slope, radar.fs
        t_mid = radar.adc_centre_time
        f_mid = radar.centre_frequency
        t_b = radar.block_interval
        if beta is None:
            tau_a = tau0 - nu * (np.asarray(slot) * radar.chirp_interval + t_mid)
            return cls(
                phi0=f_mid * tau_a - 0.5 * mu * tau_a**2,
                a=(mu * tau_a * (1 + nu) - f_mid * nu) / fs,
                b=-nu * t_b * (f_mid - mu * tau_a),
                c=-mu * nu * (1 + nu) * t_b / fs,
                k_u=-mu * nu * (1 + nu / 2) / fs**2,
                k_l=-mu * nu**2 * t_b**2 / 2,
            )
        t_a = np.asarray(slot) * radar.chirp_interval + t_mid
        tau_a = tau0 - nu * t_a - 0.5 * beta * t_a**2
        nu_a = nu + beta * t_a
        sweep = beta * (f_mid - mu * tau_a)
        u_max = (radar.num_samples - 1) / (2 * fs)
        w_max = (radar.num_chirps - 1) * t_b + u_max
        mb = np.abs(mu * beta)
        dropped = 0.5 * mb * np.abs(nu_a) * ((w_max - u_max) ** 3) + abs(mu) * beta**2 * (w_max + u_max) ** 4 / 8
        return cls(
            phi0=f_mid * tau_a - 0.5 * mu * tau_a**2,
            a=(mu * tau_a * (1 + nu_a) - f_mid * nu_a) / fs,
            b=-nu_a * t_b * (f_mid - mu * tau_a),
            c=-t_b * (sweep + mu * nu_a * (1 + nu_a)) / fs,
            k_u=-(mu * nu_a * (1 + nu_a / 2) + 0.5 * sweep) / fs**2,
            k_l=-0.5 * t_b**2 * (sweep + mu * nu_a**2),
            d=-mu * beta * t_b**2 * (1 + 3 * nu_a) / (2 * fs),
            e=-mu * beta * t_b * (1 + 1.5 * nu_a) / fs**2,
            g=-mu * beta * (1 + nu_a) / (2 * fs**3),
            dropped=dropped,
            sweep=-0.5 * t_b**2 * sweep,
        )

    def shift_chirp_origin(self, l0: float) -> "PhasePolynomial":
        """The same polynomial in :math:`l' = l - l_0` (exact re-expansion)."""
        if self.d is None:
            return PhasePolynomial(
                phi0=self.phi0 + self.b * l0 + self.k_l * l0**2,
                a=self.a + self.c * l0,
                b=self.b + 2 * self.k_l * l0,
                c=self.c,
                k_u=self.k_u,
                k_l=self.k_l,
                dropped=self.dropped,
            )
        return PhasePolynomial(
            phi0=self.phi0 + self.b * l0 + self.k_l * l0**2,
            a=self.a + self.c * l0 + self.d * l0**2,
            b=self.b + 2 * self.k_l * l0,
            c=self.c + 2 * self.d * l0,
            k_u=self.k_u + self.e * l0,
            k_l=self.k_l,
            d=self.d,
            e=self.e,
            g=self.g,
            dropped=self.dropped,
            sweep=self.sweep,
        )

    def evaluate(self, chirp_index, sample_index_centred) -> np.ndarray:
        """:math:`\\varphi` (cycles) at broadcastable ``l`` and ``k'`` (the dropped terms left out)."""
        l, k = chirp_index, sample_index_centred
        out = (self.phi0 + self.a * k + self.b * l + self.c * l * k
               + self.k_u * k**2 + self.k_l * l**2)
        if self.d is not None:
            out = out + self.d * l**2 * k + self.e * l * k**2 + self.g * k**3
        return out
