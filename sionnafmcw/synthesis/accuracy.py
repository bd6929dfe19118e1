r"""How accurate the fast beat sum must be, and the NUFFT precision and Taylor order that deliver it.

Error model. Per channel the fast sum (:mod:`.nufft`) evaluates

.. math::
    x(l', k') = \sqrt{P_t}\sum_p g_p\, e^{j2\pi(A_p X + B_p Y)}\, e^{j2\pi R_p(l', k')},
    \qquad |g_p| = |a_p|,

with the residual phase :math:`2\pi|R_p| \le \theta_p` on the whole (chirp, sample) grid. Two
approximations are made, and both have per-sample bounds in absolute units (:math:`\sqrt{W}`):

* **Taylor truncation** of :math:`e^{j2\pi R_p}` at total degree :math:`Q`. The multinomial terms
  of degree :math:`\le Q` sum exactly to :math:`\sum_{n\le Q}(j2\pi R_p)^n/n!`, and for a real
  phase :math:`|e^{j\phi} - \sum_{n\le Q}(j\phi)^n/n!| \le |\phi|^{Q+1}/(Q+1)!`, so

  .. math:: E_T \le \sqrt{P_t}\,\max_{\rm channel}\sum_p |a_p|\,\frac{\theta_p^{Q+1}}{(Q+1)!}.

  A static contribution has :math:`\theta_p = 0` and costs nothing here.
* **NUFFT** (finufft, tolerance :math:`\epsilon`): finufft's tolerance is relative to the sum of
  the magnitudes of the strengths, so transform :math:`t` (strengths
  :math:`g_p\prod_i (j2\pi r_{i,p})^{e_i}/e_i!`, multiplied on the grid by its basis, whose
  largest value is :math:`\prod_i \max|b_i|^{e_i}`) errs by about
  :math:`\epsilon\,\|s_t\|_1\max|b_t|`. Measured against the direct sum (static, moving and
  mixed echoes, 32 x 64 and 256 x 128 grids, :math:`\epsilon = 10^{-6}\ldots10^{-3}`, both
  precisions): up to 2.5 times that with upsampling 1.25 (3.9 at :math:`10^{-7}`, hence
  finufft's own choice below :math:`10^{-6}`), 4.3 for one dominant source (Tx-Rx leakage at
  :math:`7\times10^{-7}`), and 8.1 for two all but static targets in single precision at
  :math:`3.2\times10^{-4}` (12.2 before every plan spanned the full band,
  :data:`~sionnafmcw.synthesis.nufft.ANCHORS`), so the bound takes a safety factor :math:`s = 16`
  (:data:`NUFFT_SAFETY`, twice the largest ratio measured); summed over the terms,

  .. math:: E_N \le s\,\epsilon\,\sqrt{P_t}\,\max_{\rm channel}\sum_p |a_p|\sum_{n\le Q}\frac{\theta_p^n}{n!}
            \;\le\; s\,\epsilon\,\sqrt{P_t}\,\max\sum_p |a_p|\, e^{\theta_p}.

Budget from the noise floor. With thermal noise on, the synthesis error only has to stay well
below the receiver noise :math:`\sigma = \sqrt{k T_0 F F_s}` per sample: a margin of
:math:`D` dB (default 20) sets the budget :math:`E_{\max} = \sigma\,10^{-D/20}`, i.e. the error
power is at most 1 % of the noise power and changes the noise floor by < 0.05 dB. The Taylor
part may use :math:`0.1\,E_{\max}` (:data:`TAYLOR_SHARE`): monomials are kept in order of their
weight (the largest value any of their samples can take) and the lightest dropped while the
dropped weights plus the tail beyond the candidate degree stay within that share (the series
converges absolutely, so this bounds the truncation whatever the kept set; usually only the
constant term, or it and :math:`l'^2`, survive). The NUFFT tolerance takes the rest,

.. math::
    \epsilon = \frac{E_{\max} - E_T}{s\,\sqrt{P_t}\,\max_{\rm channel}\sum_p |a_p|\sum_{t\,\rm kept} w_{t,p}},

clipped to :data:`MAX_NUFFT_TOL` (a looser kernel is not faster). For the walk-77ghz radar
(:math:`\sigma = 0.56\ \mu\sqrt{W}`, budget 56 n :math:`\sqrt{W}`) a circle-walk frame of the path
engine (PO body, its second bounces and the traced paths) has :math:`\sqrt{P_t}\sum|a| \approx
150\sigma` per channel and gets :math:`\epsilon \approx 3.5\times10^{-5}`; the point-target walk
frame of ``benchmarks/synthesis.py`` (:math:`600\sigma`: 8 specular returns of 1-20 m^2) gets
:math:`1.9\times10^{-5}`, in double precision. Single precision (complex64 finufft, 1.5-2x less
work) is used when :math:`\epsilon \ge` :data:`SINGLE_PRECISION_MIN_TOL` and every contribution
lies within twice the unambiguous Doppler (:math:`|B_p| \le`
:data:`SINGLE_PRECISION_MAX_BLOCK_PHASE` = 1 cycle per TDM block). There float32 finufft bottoms
out at :math:`0.5\text{-}1\times10^{-5}` of the strength sum (measured on the walk-77ghz and
12 x 128 x 256 grids, worst case all strengths in phase), under :math:`0.05\,s\,\epsilon` for
:math:`\epsilon \ge 2.5\times10^{-5}`, and above it the error is the same as in double precision
(measured up to 2.2 :math:`\epsilon`), so the bound holds. The floor grows with the float32
phases :math:`x_j s_k`, i.e. with :math:`|B_p|`: on the walk-77ghz grid with the strengths in
phase (``python benchmarks/single_precision.py``) the largest error at
:math:`\epsilon = 2.5\times10^{-5}` is 0.33 / 0.43 / 0.41 / 0.58 :math:`\epsilon` times the
strength sum for :math:`|B_p|` up to 0.5 / 0.75 / 1 / 2 (double precision 0.24-0.28), far under
the bound's 16. A walk frame's second bounces reach :math:`|B_p| = 0.51` (the Doppler of two
moving bounces adds), hence the limit 1 rather than the unambiguous 1/2. Far outside (170 m/s,
:math:`|B_p| \approx 9`) the float32 phases reach :math:`10^4` rad and the floor was measured 2x
over the budget, so double precision is used there.

With noise off there is no floor to hide under: the tight defaults :data:`NUFFT_TOL`,
:data:`TAYLOR_TOL` (relative, double precision) are kept unless an explicit absolute
``max_error`` is given.

Both bounds are worst cases (every contribution adding in phase at one sample); the errors
measured against the direct sum stay below them (``tests/test_synthesis.py``,
``benchmarks/synthesis.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from math import factorial

import numpy as np

#: Tight finufft tolerance (relative to the strength sum) used without a noise floor.
NUFFT_TOL = 1e-7
#: Tight bound on the largest neglected Taylor term (relative) used without a noise floor.
TAYLOR_TOL = 1e-8
#: Taylor order cap (a residual that needs more is outside the model's intended regime).
MAX_ORDER = 6
#: Default margin of the synthesis error below the thermal noise per sample (dB).
NOISE_MARGIN_DB = 20.0
#: Share of the noise budget kept for what the engines approximate before synthesis: the PO merge
#: (:mod:`sionnafmcw.engines.po_merge`); the synthesis itself gets the rest, so the two errors add
#: up to at most the budget.
UPSTREAM_SHARE = 0.1
#: Share of the error budget given to the Taylor truncation; the NUFFT gets the rest.
TAYLOR_SHARE = 0.1
#: Smallest finufft tolerance for which the single-precision (complex64) library is used.
SINGLE_PRECISION_MIN_TOL = 2.5e-5
#: Largest :math:`|B_p|` (cycles per TDM block; 1/2 is the unambiguous Doppler) for which complex64
#: is used: its floor measured under 0.6 tol x strength sum up to 2 (``benchmarks/single_precision.py``).
SINGLE_PRECISION_MAX_BLOCK_PHASE = 1.0
#: finufft's type-3 tolerance is "about": measured errors reach 8.1 tol x (strength sum) (see the
#: module docstring), so the bound uses sixteen times the tolerance requested.
NUFFT_SAFETY = 16.0
#: Loosest finufft tolerance requested (looser is no faster on these grids).
MAX_NUFFT_TOL = 1e-3


def noise_error_budget(radar, margin_db: float = NOISE_MARGIN_DB) -> float:
    """Largest error per sample of the whole echo model, :math:`\\sqrt{k T_0 F F_s}\\,10^{-D/20}`
    (sqrt(W)): the synthesis gets ``1 -`` :data:`UPSTREAM_SHARE` of it, the PO merge the rest."""
    return float(np.sqrt(radar.noise_power) * 10 ** (-margin_db / 20))


def taylor_order(theta: float, tol: float = TAYLOR_TOL) -> int:
    """Smallest Q with theta^(Q+1)/(Q+1)! <= tol (0 when theta is 0): the tight, relative rule."""
    if theta <= 0:
        return 0
    for q in range(MAX_ORDER + 1):
        if theta ** (q + 1) / factorial(q + 1) <= tol:
            return q
    raise _order_error(theta)


class OrderError(ValueError):
    """A residual phase that needs a Taylor order above :data:`MAX_ORDER` (the fast sum of Doppler rates
    then cuts its chirp block in two, :mod:`.nufft`)."""


def _order_error(theta: float) -> ValueError:
    return OrderError(
        f"beat synthesis: residual phase {theta:.3g} rad needs a Taylor order above {MAX_ORDER}; "
        "the contribution velocities are far outside the radar's design (check Echoes.doppler units: Hz)"
    )


@dataclass(frozen=True)
class SynthesisAccuracy:
    """The fast sum's settings and its worst-case error per sample (sqrt(W)).

    ``terms``: the Taylor monomials kept, exponents of :math:`(l'k', k'^2, l'^2)`; ``order``: their
    largest total degree; ``nufft_tol``: finufft tolerance; ``dtype``: finufft precision
    (``"complex64"`` or ``"complex128"``); ``taylor_bound``, ``nufft_bound``: :math:`E_T`,
    :math:`E_N` of the module docstring for the echoes at hand (:math:`E_T` includes the terms of
    degree 3-4 of Doppler rates that no basis carries, ``fixed_phases`` of :func:`choose_accuracy`);
    ``max_error``: the budget they were chosen for (None: the tight relative defaults);
    ``chirp_blocks``: the chirp blocks of a sum with Doppler rates (:func:`~.nufft.chirp_blocks`;
    the figures are then the worst block's).
    """

    terms: tuple
    nufft_tol: float
    dtype: str
    taylor_bound: float
    nufft_bound: float
    max_error: float | None
    chirp_blocks: int = 1

    @property
    def order(self) -> int:
        return max(sum(t) for t in self.terms)

    @property
    def error_bound(self) -> float:
        """:math:`E_T + E_N`, the bound on any sample's error (sqrt(W))."""
        return self.taylor_bound + self.nufft_bound


def monomials(order: int) -> list[tuple]:
    """Exponents of :math:`(l'k', k'^2, l'^2)` with total degree <= ``order``, by degree."""
    return [t for t in product(range(order + 1), repeat=3) if sum(t) <= order]


def choose_accuracy(amplitudes, residual_phases, tx_power: float, max_error: float | None = None,
                    nufft_tol: float = NUFFT_TOL, taylor_tol: float = TAYLOR_TOL,
                    max_block_phase: float = 0.0, fixed_phases=None) -> SynthesisAccuracy:
    r"""Taylor terms, finufft tolerance and precision for the live contributions of every channel.

    ``amplitudes``: one array :math:`|a_p|` per channel; ``residual_phases``: one ``[3, P]`` array
    per channel, :math:`\phi_{i,p} = 2\pi|r_{i,p}|\max|b_i|` for the residual coefficients
    :math:`(\delta, \rho, K_l)` and their bases :math:`(l'k', k'^2, l'^2)`, so that
    :math:`\theta_p = \sum_i\phi_{i,p}`.

    With ``max_error`` (sqrt(W) per sample) the settings come from that budget. The monomials are
    kept in order of their weight :math:`w_t = \sqrt{P_t}\max_c\sum_p|a_p|\prod_i\phi_{i,p}^{e_i}/e_i!`
    (the largest any of their samples can be) until the dropped ones and the tail beyond degree
    :data:`MAX_ORDER`, :math:`\sqrt{P_t}\max_c\sum_p|a_p|\,e^{\theta_p}\theta_p^{D+1}/(D+1)!`, add up to
    at most ``TAYLOR_SHARE * max_error`` (the multinomial series converges absolutely, so this bounds
    the truncation whatever the kept set); the NUFFT tolerance takes the rest of the budget over
    :math:`\sum_{t\,\rm kept} w_t`. Without it, all monomials up to the order given by the relative
    ``taylor_tol`` and the relative ``nufft_tol`` in double precision (the tight default).
    ``max_block_phase``: the largest :math:`|B_p|` (cycles per TDM block); single precision is
    used only up to :data:`SINGLE_PRECISION_MAX_BLOCK_PHASE`, where its floor was measured.
    ``fixed_phases``: one ``[P]`` array per channel, a bound (rad) on phase terms the sum leaves out
    whatever the settings (Doppler rates' terms of degree 3-4, :mod:`.phase`); since
    :math:`|e^{j\phi} - 1| \le |\phi|` they cost :math:`E_F = \sqrt{P_t}\max_c\sum_p|a_p|\phi_p`,
    taken from the Taylor share first and part of ``taylor_bound``.
    """
    root_pt = float(np.sqrt(tx_power))
    fixed = 0.0
    if fixed_phases is not None:
        fixed = root_pt * max((float((np.asarray(a, float) * np.asarray(f, float)).sum())
                               for a, f in zip(amplitudes, fixed_phases)), default=0.0)
    pairs = [(np.asarray(a, float), np.asarray(f, float).reshape(3, -1)) for a, f in zip(amplitudes, residual_phases)]
    static_sum = root_pt * max((float(a.sum()) for a, _ in pairs), default=0.0)
    # only moving contributions have a residual (theta = 0 adds exactly 0 to every weight but the
    # constant's and to every tail): take them out when they are many (a static block), keep the
    # few of a moving frame rather than copy the rest
    moving = []
    for a, f in pairs:
        theta = f.sum(axis=0)
        keep = theta > 0
        num_kept = int(np.count_nonzero(keep))
        moving.append((a, f, theta) if 2 * num_kept >= keep.size else (a[keep], f[:, keep], theta[keep]))
    theta_max = max((float(t.max()) for _, _, t in moving if t.size), default=0.0)
    powers = [{} for _ in moving]          # per channel: (i, e) -> phi_i^e / e!
    theta_powers = [{} for _ in moving]    # per channel: e -> theta^e
    growth = [None] * len(moving)          # per channel: |a| e^theta

    def power(c, i, e):
        if (i, e) not in powers[c]:
            phi = moving[c][1][i]
            powers[c][i, e] = phi / e if e == 1 else power(c, i, e - 1) * phi / e
        return powers[c][i, e]

    def theta_power(c, e):
        if e not in theta_powers[c]:
            t = moving[c][2]
            theta_powers[c][e] = t if e == 1 else theta_power(c, e - 1) * t
        return theta_powers[c][e]

    def weight(term):  # sqrt(P_t) max_c sum_p |a_p| prod_i phi_i^e_i / e_i!
        if not any(term):
            return static_sum
        best = 0.0
        for c, (a, _, _) in enumerate(moving):
            factors = [power(c, i, e) for i, e in enumerate(term) if e]
            w = factors[0] if len(factors) == 1 else np.prod(factors, axis=0)
            best = max(best, float((a * w).sum()))   # not np.dot: BLAS threads spin on the CPU
        return root_pt * best

    def tail(d, factor=True):  # sqrt(P_t) max_c sum_p |a_p| [e^theta] theta^(d+1)/(d+1)!
        best = 0.0
        for c, (a, _, t) in enumerate(moving):
            if factor and growth[c] is None:
                growth[c] = a * np.exp(t)
            best = max(best, float(((growth[c] if factor else a) * theta_power(c, d + 1)).sum()))
        return root_pt * best / factorial(d + 1)

    if max_error is None:
        order = taylor_order(theta_max, taylor_tol)
        terms = monomials(order)
        return SynthesisAccuracy(tuple(terms), float(nufft_tol), "complex128", tail(order, factor=False) + fixed,
                                 NUFFT_SAFETY * nufft_tol * sum(weight(t) for t in terms), None)
    if not (np.isfinite(max_error) and max_error > 0):
        raise ValueError(f"beat synthesis: max_error must be a positive number of sqrt(W), got {max_error!r}")
    allowed = max(TAYLOR_SHARE * max_error - fixed, 0.0)
    # the smallest candidate degree whose tail leaves half the Taylor share for dropped monomials
    degree = next((d for d in range(MAX_ORDER + 1) if tail(d) <= 0.5 * allowed), None)
    if degree is None:
        raise _order_error(theta_max)
    candidates = monomials(degree)
    weights = {t: weight(t) for t in candidates}
    candidates.sort(key=lambda t: (-weights[t], sum(t)))
    kept = len(candidates)
    dropped = tail(degree)
    while kept > 1 and dropped + weights[candidates[kept - 1]] <= allowed:  # drop the lightest first
        kept -= 1
        dropped += weights[candidates[kept]]
    terms = sorted(candidates[:kept], key=lambda t: (sum(t), t))
    if terms[0] != (0, 0, 0):
        terms = [(0, 0, 0)] + [t for t in terms if t != (0, 0, 0)]
    total = sum(weights[t] for t in terms)
    dropped += fixed
    tol = MAX_NUFFT_TOL if total == 0 else min(MAX_NUFFT_TOL, (max_error - dropped) / (NUFFT_SAFETY * total))
    # double precision cannot go much below 1e-14 relative; the bound then says so honestly
    tol = max(tol, 1e-14)
    single = tol >= SINGLE_PRECISION_MIN_TOL and max_block_phase <= SINGLE_PRECISION_MAX_BLOCK_PHASE
    dtype = "complex64" if single else "complex128"
    return SynthesisAccuracy(tuple(terms), float(tol), dtype, dropped, NUFFT_SAFETY * tol * total, float(max_error))
