r"""Fast beat synthesis: a 2-D type-3 NUFFT with a Taylor-expanded residual, channels sharing plans.

Per channel (Tx :math:`m`, Rx :math:`n`) the cube is (:mod:`~sionnafmcw.synthesis.phase`)

.. math::
    x(l', k') = \sqrt{P_t}\sum_p g_p\, e^{j2\pi(A_p k' + B_p l' + C_p l'k' + K_{u,p} k'^2 + K_{l,p} l'^2)},

with :math:`g_p = \bar a_p e^{j2\pi\Phi_{0,p}}`, centred chirp index
:math:`l' = l - (L-1)/2` and centred sample index :math:`k'`. The cross term cannot go into a
type-1 transform, but it is nearly proportional to :math:`B_p`: :math:`C_p/B_p \approx
\mu/(F_s F)` for every path (it is the relative frequency step across the ADC window). With

.. math::
    \varepsilon_1 = \frac{\mu}{F_s F},\qquad \varepsilon_2 = \frac{\mu}{T_b F F_s^2},\qquad
    X = k',\qquad Y = l'(1 + \varepsilon_1 k') + \varepsilon_2 k'^2

the dominant phase is :math:`A_p X + B_p Y`, a 2-D **type-3** NUFFT from sources
:math:`2\pi(A_p, B_p)` to the fixed, warped targets :math:`(X, Y)` (a keystone grid), and the
rest is a small residual

.. math::
    R_p = \delta_p\, l'k' + \rho_p\, k'^2 + K_{l,p}\, l'^2,\qquad
    \delta_p = C_p - \varepsilon_1 B_p,\quad \rho_p = K_{u,p} - \varepsilon_2 B_p,

of order :math:`(\nu + \mu\tau/F)` relative to the main terms (1e-4 rad for indoor scenes).

:math:`e^{j2\pi R_p}` is expanded as the multinomial Taylor series

.. math::
    e^{j2\pi R_p} = \sum_{i+j+h \le Q} \frac{(j2\pi\delta_p)^i (j2\pi\rho_p)^j (j2\pi K_{l,p})^h}{i!\,j!\,h!}
    (l'k')^i (k'^2)^j (l'^2)^h

truncated at total degree :math:`Q`: each monomial is one more strength vector of the same
transform (finufft's ``n_trans``), multiplied by its basis on the output grid. :math:`Q`, the
finufft tolerance and its precision come from an error budget (:mod:`.accuracy`): the receiver
noise floor when noise is on, tight relative defaults otherwise. Nothing is dropped from the
model (no far field, no stop-and-go, no shared beat frequency): the result is the exact sum to
that budget.

Keystone fitted per plan. With the coefficients of :mod:`.phase`,
:math:`C_p/B_p = \mu(1+\nu)/(F_s(F - \mu\tau_a))`, so

.. math::
    \delta_p = C_p - \varepsilon_1 B_p = -\frac{\mu\nu T_b}{F_s}\Big(\nu + \frac{\mu\tau_a}{F}\Big)
    \approx \frac{\mu}{F^2} A_p B_p :

the cross residual grows with the beat frequency :math:`A_p` (the range) of each moving
contribution. The warp's slope need not be :math:`\varepsilon_1`: any slope :math:`\varepsilon`
gives targets :math:`Y_\varepsilon = Y + (\varepsilon - \varepsilon_1) l'k'` and residuals
:math:`\delta_p = C_p - \varepsilon B_p`, and the decomposition stays exact. Each plan takes the
slope of its own contributions, :math:`\varepsilon = \sum_p |a_p|\,\mathrm{sgn}(B_p)\,C_p / \sum_p |a_p||B_p|`
(the :math:`|a_p||B_p|`-weighted mean of :math:`C_p/B_p`, the keystone of their mean range; kept
only where it lowers :math:`\sum_p |a_p||\delta_p|`, the cross term's weight in the error bound
of :mod:`.accuracy`). A moving body spread over a few range cells then leaves a cross residual of
its range *spread* instead of its range, mostly under what the noise budget lets the Taylor
series drop: on ten frames spread over the circle walk the transforms carry 1.1 strength vectors
per channel instead of 1.7 (``benchmarks/walk_synthesis.py``, whose docstring has the figures).

Sharing across channels. The channels' sources differ (each Tx-Rx pair has its own delays and
Dopplers; a beat frequency shared across channels is off by ~0.1 range bin, 24-31 % error), but
the targets :math:`(X, Y)` are the same for all of them (up to the keystone each plan fits), and
finufft's type-3 set-up (kernel Fourier transform at every target, target sorting, the inner
type-2 plan) costs as much as a transform. So ``channels_per_plan`` channels go into **one plan
over the union of their sources**, each channel one strength vector that is zero on the other channels' sources: the
set-up is paid once per group and the result is still exact per channel (a zero strength
contributes nothing, and the tolerance is relative to each vector's own strength sum). The
groups run as single-threaded plans on a thread pool (finufft releases the GIL), which beats
finufft's own threading on these small transforms (NOTES section 4). An upsampling factor of
1.25 (instead of 2) shrinks the fine grids 2.6x for a slightly wider kernel: measured 2.5-3.5x
faster transforms at the same error on the walk-77ghz grid (used at tolerances >= 1e-6; below,
finufft chooses, as before).

Still contributions. With :math:`\nu = 0` and no Doppler rate (a static object seen by a radar at rest:
a room's static block, the static samples a moving body blocks in a frame) :math:`B, C, K_u, K_l` of
:mod:`.phase` vanish and the phase is :math:`\Phi_0 + A_pk'`: the same beat in every chirp. Those
contributions of a channel go through one 1-D type-3 transform to the :math:`N_s` sample indices
(:func:`_still_cubes`), at the plan's tolerance and precision, instead of the 2-D one: :math:`w` kernel
evaluations per source instead of :math:`w^2`.

Motion within the CPI. A Doppler rate :math:`\dot f_D` sweeps a contribution's Doppler
across the CPI: its phase gains :math:`K_s w'^2(1 + \varepsilon_1 k')` with
:math:`w' = l' + k'/(T_bF_s)` the time in TDM blocks and :math:`K_s = -\dot f_D(F - \mu\tau)T_b^2/(2f_c)`
(:mod:`.phase`), :math:`\pi\dot f_D t^2` over the CPI: a few radians for a walking torso, tens for a
swinging foot, far beyond a Taylor series. Two things keep the fast sum exact to its budget:

* **chirp blocks**: the CPI is cut into :math:`J` blocks of chirps (:func:`chirp_blocks`), each summed
  as a CPI of its own that starts later (:func:`_block`: :math:`\tau_0`, :math:`f_D` moved to the
  block's start, exactly), so the sweep about the block's centre is :math:`J^2` times smaller;
  the blocks are disjoint samples, so each may use the whole budget;
* **accelerating bases** (``_Grid(accelerating=True)``): the residual bases become
  :math:`l'k'(1 + \varepsilon_1k')`, :math:`k'^2` and :math:`w'^2(1 + \varepsilon_1k') - c` (centred on the
  grid, :math:`c` the mid-range, its constant :math:`K_sc` in each strength's phase: half the Taylor
  variable's range), the sweep seen at
  each sample's frequency :math:`F(1 + \varepsilon_1k')`, with the residual coefficients
  :math:`(\delta - 2hK_s, \rho - h^2K_s, K_s)`, :math:`h = 1/(T_bF_s)`, so that the sweep's shares of the
  cross, :math:`k'^2` and :math:`l'^2` terms are one Taylor variable; the terms no basis carries
  (:math:`E - \varepsilon_1\delta` on :math:`l'k'^2`, :math:`D - \varepsilon_1K_s` on :math:`l'^2k'`,
  the second-order range migration :math:`K_l - K_s` on :math:`l'^2`, :math:`G - \varepsilon_1h^2K_s` on
  :math:`k'^3`, the keystone fit's
  :math:`\varepsilon_1 sB_p` on :math:`l'k'^2` and the degree-3-4 terms of :mod:`.phase`) are bounded
  and charged to the Taylor share (:func:`~.accuracy.choose_accuracy`, ``fixed_phases``).

The contributions are grouped by the blocks their sweep needs (:func:`rate_classes`: the many slow
ones are not cut into the blocks of the few fast ones) and the budget is split between the groups
by their strength sums. Echoes without Doppler rates take the fast sum above unchanged.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from math import factorial

import finufft
import numpy as np

from .. import threads as run_threads_module
from .accuracy import (MAX_ORDER, NUFFT_TOL, TAYLOR_TOL, OrderError, SynthesisAccuracy, choose_accuracy,
                       taylor_order)
from .phase import PhasePolynomial

#: Channels per finufft plan (union of their sources, one set-up); measured best on 2 cores for
#: walk frames (3: 0.25 s vs 0.37 s per plan per channel under load, 7k contributions) ...
CHANNELS_PER_PLAN = 3
#: ... up to this many contributions per channel; above, spreading the other channels' zero
#: strengths costs more than the shared set-up saves (20k: 0.89 s with 1, 1.12 s with 3; 65k:
#: 1.9 s vs 3.7 s), and every channel gets its own plan.
SHARED_PLAN_MAX_SOURCES = 15_000
#: finufft fine-grid upsampling factor at tolerances >= 1e-6 (below, finufft's own choice).
UPSAMPFAC = 1.25
#: Largest residual phase bound (rad) at which a weighted sum (``beat_nufft(weights=...)``) drops its
#: Taylor terms: its relative error is then below this (-40 dB).
WEIGHTED_RESIDUAL_MAX = 0.01


@dataclass
class _Channel:
    m: int
    n: int
    x: np.ndarray          # 2 pi (A - wraps), rad per sample
    y: np.ndarray          # 2 pi B, rad per (warped) chirp
    gain: np.ndarray       # a_p of the live contributions
    phase: np.ndarray      # 2 pi Phi_0 (rad) less whole turns, with the A-wrap sign (pi where odd) folded in
    residual: tuple        # (delta, rho, K_l), cycles
    phases: np.ndarray     # [3, P]: 2 pi |r_i| max|b_i| (rad); their sum bounds 2 pi |R_p| on the grid
    amplitude: np.ndarray  # |a_p|
    weight: np.ndarray | None = None   # real per-contribution weights of a second sum (``weights``), or None
    dropped: np.ndarray | None = None  # phase (rad) of the terms the accelerating bases leave out, or None

    def select(self, keep) -> "_Channel":
        """The contributions where ``keep`` (``[P]`` bool) holds."""
        pick = (lambda a: None if a is None else a[keep])
        return _Channel(self.m, self.n, self.x[keep], self.y[keep], self.gain[keep], self.phase[keep],
                        tuple(r[keep] for r in self.residual), self.phases[:, keep], self.amplitude[keep],
                        pick(self.weight), pick(self.dropped))

    def strength(self, dtype) -> np.ndarray:
        r""":math:`g_p = \bar a_p e^{j\,\mathrm{phase}}` in the transform's precision: in complex64 the
        phase (within :math:`[-\pi, 2\pi]`) is rounded to float32 first, an error of at most
        :math:`2.4\times10^{-7}` of each strength, four orders under the smallest tolerance single
        precision is used at (:data:`~.accuracy.SINGLE_PRECISION_MIN_TOL`), and float32 cosines
        are SIMD (7x faster than float64 ones in numpy)."""
        dtype = np.dtype(dtype)
        phase = self.phase.astype(np.float32) if dtype == np.complex64 else self.phase
        out = np.empty(phase.shape, dtype=dtype)
        np.cos(phase, out=out.real)
        np.sin(phase, out=out.imag)
        out *= np.conj(self.gain)
        return out


#: Sources of zero strength at the corners of the band, (X, Y) in rad per sample / per chirp,
#: added to every finufft type-3 plan. The plan sizes its grid from the spread of the sources; the
#: error bound of :mod:`.accuracy` (the safety factor measured on sources spread over the band)
#: does not hold for a narrow spread: two targets at 1e-9 m/s and one at 0 gave 1.5x the bound in
#: single precision, and a spread of ~1e-37 (a velocity of 1e-37 m/s, met by a property-based
#: test) made every sample NaN. With the anchors every plan spans the full band.
ANCHORS = np.array([[-np.pi, -np.pi], [np.pi, np.pi]])


class _Grid:
    """The warped targets (X, Y) and the residual bases of one radar; ``accelerating``: the bases of echoes
    with Doppler rates (module docstring, "Motion within the CPI")."""

    def __init__(self, radar, accelerating: bool = False):
        L, Ns = radar.num_chirps, radar.num_samples
        self.accelerating = bool(accelerating)
        self.l0 = (L - 1) / 2.0
        lc = np.arange(L) - self.l0
        kc = np.arange(Ns) - (Ns - 1) / 2.0
        f_mid = radar.centre_frequency
        self.eps1 = radar.slope / (radar.fs * f_mid)
        self.eps2 = radar.slope / (radar.block_interval * f_mid * radar.fs**2)
        grid_l, grid_k = np.meshgrid(lc, kc, indexing="ij")  # [L, Ns]
        self.k = kc                                           # the centred sample indices k' [Ns]
        self.x = grid_k.ravel()
        self.y = (grid_l * (1 + self.eps1 * grid_k) + self.eps2 * grid_k**2).ravel()
        # the time within the block in TDM blocks, w' = l' + k'/(T_b F_s) (module docstring)
        self.time_step = 1.0 / (radar.block_interval * radar.fs)
        self.sweep_offset = 0.0
        if self.accelerating:   # the sweep and the cross term seen at each sample's frequency F(1 + eps1 k')
            key = 1 + self.eps1 * grid_k
            sweep = (grid_l + self.time_step * grid_k) ** 2 * key
            # centred on the grid (its constant part goes into each strength's phase): half the range
            self.sweep_offset = 0.5 * float(sweep.max() + sweep.min())
            self.basis = (grid_l * grid_k * key, grid_k**2, sweep - self.sweep_offset)
        else:
            self.basis = (grid_l * grid_k, grid_k**2, grid_l**2)
        self.basis_max = tuple(float(np.abs(b).max()) for b in self.basis)
        # largest |l' k'^2|, |l'^2 k'|, |l'|^2 and |k'|^3: the remainder terms of the accelerating bases
        l_max, k_max = float(np.abs(lc).max(initial=0)), float(np.abs(kc).max(initial=0))
        self.remainder_max = (l_max * k_max**2, l_max**2 * k_max, l_max**2, k_max**3)


def _channels(echoes, radar, grid: _Grid, weights=None) -> list[_Channel]:
    """The live contributions (non-zero gain) of every channel as type-3 sources, strengths and residuals;
    ``weights`` (``[M, N, P]`` real, optional) are kept per channel for the weighted second sum."""
    Ns = radar.num_samples
    slot = radar.tx_slot()
    basis_max = 2 * np.pi * np.asarray(grid.basis_max)
    out = []
    for m in range(radar.num_tx):
        for n in range(radar.num_rx):
            live = echoes.a[m, n] != 0
            if not np.any(live):
                continue
            if live.all():   # views, not copies
                live = slice(None)
            a = echoes.a[m, n, live]
            nu = echoes.doppler[m, n, live] / radar.fc
            beta = echoes.rates()[m, n, live] / radar.fc if grid.accelerating else None
            poly = PhasePolynomial.from_delay_doppler(echoes.tau[m, n, live], nu, slot[m], radar, beta)
            poly = poly.shift_chirp_origin(grid.l0)
            residual = (poly.c - grid.eps1 * poly.b, poly.k_u - grid.eps2 * poly.b, poly.k_l)
            dropped = None
            if grid.accelerating:
                # the sweep K_s w'^2 (1 + eps1 k') takes its share of the cross, k'^2 and l'^2 terms; what the
                # three bases leave (l'k'^2, l'^2k', the l'^2 of second-order range migration, k'^3) is dropped
                sweep, h = poly.sweep, grid.time_step
                cross = residual[0]
                residual = (cross - 2 * h * sweep, residual[1] - h * h * sweep, sweep)
                poly.phi0 = poly.phi0 + sweep * grid.sweep_offset   # the centred basis's constant
                dropped = 2 * np.pi * (np.abs(poly.e - grid.eps1 * cross) * grid.remainder_max[0]
                                       + np.abs(poly.d - grid.eps1 * sweep) * grid.remainder_max[1]
                                       + np.abs(poly.k_l - sweep) * grid.remainder_max[2]
                                       + np.abs(poly.g - grid.eps1 * h * h * sweep) * grid.remainder_max[3]
                                       + poly.dropped)
            phases = np.empty((3, a.size))
            for i, r in enumerate(residual):
                np.abs(r, out=phases[i])
                phases[i] *= basis_max[i]
            # shift A by whole cycles into [-1/2, 1/2): exp(j2pi*j*k') = exp(-j*pi*j*(Ns-1)) for
            # k' = k-(Ns-1)/2, i.e. (-1)^(j (Ns - 1)) for the whole number j: a phase of pi where odd
            wraps = np.round(poly.a)
            phase = poly.phi0 - np.round(poly.phi0)
            phase *= 2 * np.pi
            if (Ns - 1) % 2:
                odd = wraps.astype(np.int64) & 1   # |A| is far below 2^63 cycles
                phase += np.pi * odd
            x = poly.a - wraps
            x *= 2 * np.pi
            weight = None if weights is None else np.asarray(weights[m, n, live], dtype=float)
            out.append(_Channel(m, n, x, 2 * np.pi * poly.b, a, phase, residual, phases, np.abs(a), weight, dropped))
    return out


def _fit_keystone(group: list[_Channel], grid: _Grid) -> float:
    r"""The plan's keystone slope less the radar's, :math:`\varepsilon - \varepsilon_1` (module
    docstring), applied in place to the group's cross residuals :math:`\delta_p` and their phase
    bounds; 0 (nothing changed) where the fit would not lower :math:`\sum_p |a_p||\delta_p|`."""
    num = den = 0.0
    block_phases = [c.y / (2 * np.pi) for c in group]   # B_p, cycles per TDM block
    for c, b in zip(group, block_phases):
        num += float((c.amplitude * np.sign(b) * c.residual[0]).sum())
        den += float((c.amplitude * np.abs(b)).sum())
    if den == 0.0 or num == 0.0:
        return 0.0
    shift = num / den
    fitted = [c.residual[0] - shift * b for c, b in zip(group, block_phases)]
    before = sum(float((c.amplitude * np.abs(c.residual[0])).sum()) for c in group)
    if sum(float((c.amplitude * np.abs(d)).sum()) for c, d in zip(group, fitted)) >= before:
        return 0.0
    scale = 2 * np.pi * grid.basis_max[0]
    for c, d in zip(group, fitted):
        c.residual = (d, *c.residual[1:])
        np.abs(d, out=c.phases[0])
        c.phases[0] *= scale
    return shift


def _plans(echoes, radar, grid: _Grid, channels_per_plan: int | None, weights=None):
    """The live channels, their groups (one finufft plan each) and each group's keystone shift."""
    channels = _channels(echoes, radar, grid, weights)
    if channels_per_plan is None:
        largest = max((c.x.size for c in channels), default=0)
        channels_per_plan = CHANNELS_PER_PLAN if largest <= SHARED_PLAN_MAX_SOURCES else 1
    groups = [channels[i:i + channels_per_plan] for i in range(0, len(channels), channels_per_plan)]
    shifts = [_fit_keystone(g, grid) for g in groups]
    if grid.accelerating:
        # the fitted slope moves shift * B_p l'k' into the targets, the residual keeps its basis
        # l'k'(1 + eps1 k'): what differs, shift * B_p * eps1 * l'k'^2, joins the dropped terms
        for group, shift in zip(groups, shifts):
            if shift:
                for c in group:
                    c.dropped = c.dropped + np.abs(shift * c.y) * grid.eps1 * grid.remainder_max[0]
    return channels, groups, shifts


def synthesis_accuracy(echoes, radar, max_error: float | None = None, nufft_tol: float = NUFFT_TOL,
                       taylor_tol: float = TAYLOR_TOL, channels_per_plan: int | None = None) -> SynthesisAccuracy:
    """The settings :func:`beat_nufft` uses for these echoes and their error bound (:mod:`.accuracy`);
    ``channels_per_plan`` as there (the keystone is fitted per plan, so the groups matter). With Doppler
    rates: the settings of the chirp block with the largest bound (``chirp_blocks`` blocks)."""
    if echoes.accelerating:
        worst = None
        spans = chirp_blocks(echoes, radar, max_error, least=max(j for j, _ in rate_classes(echoes, radar)))
        for start, stop in spans:
            part, sub = _block(echoes, radar, start, stop)
            channels, _, _ = _plans(part, sub, _Grid(sub, accelerating=True), channels_per_plan)
            acc = _accuracy(channels, sub, max_error, nufft_tol, taylor_tol)
            if worst is None or acc.error_bound > worst.error_bound:
                worst = acc
        return replace(worst, chirp_blocks=len(spans))
    channels, _, _ = _plans(echoes, radar, _Grid(radar), channels_per_plan)
    return _accuracy(channels, radar, max_error, nufft_tol, taylor_tol)


def _accuracy(channels, radar, max_error, nufft_tol, taylor_tol) -> SynthesisAccuracy:
    max_b = max((float(np.abs(c.y).max()) / (2 * np.pi) for c in channels), default=0.0)
    fixed = None
    if any(c.dropped is not None for c in channels):
        fixed = [np.zeros(c.amplitude.size) if c.dropped is None else c.dropped for c in channels]
    return choose_accuracy([c.amplitude for c in channels], [c.phases for c in channels], radar.tx_power,
                           max_error, nufft_tol, taylor_tol, max_block_phase=max_b, fixed_phases=fixed)


#: Largest Doppler sweep phase (rad, about its mean) of a contribution inside one chirp block with a
#: noise budget (:func:`chirp_blocks`, :func:`rate_classes`), and without one (the tight relative
#: tolerances need order-6 Taylor terms to reach 1e-8 at 0.2 rad). Measured on three circle-walk frames
#: with cpi_motion="quadratic" (``benchmarks/cpi_motion.py``): 0.7, 1 and 2 rad within the machine's
#: noise of one another (2.0-5.2 s per frame's moving echoes on two shared cores).
BLOCK_SWEEP_PHASE = 1.0
TIGHT_BLOCK_SWEEP_PHASE = 0.12
#: Taylor degree a block's sweep should need at most with a noise budget (:func:`chirp_blocks`).
BLOCK_TAYLOR_ORDER = 4


def chirp_blocks(echoes, radar, max_error: float | None = None, least: int = 1) -> list[tuple[int, int]]:
    r"""The chirp blocks ``[(start, stop), ...]`` of the fast sum of ``echoes`` with Doppler rates.

    A contribution's Doppler sweep over a block of :math:`L_J` chirps is
    :math:`\theta_p = \tfrac{\pi}{2}|\dot f_{D,p}|(T_bL_J/2)^2(1 + \varepsilon_1 k'_{max})` about its mean
    (the :math:`K_s` term of the centred sweep basis, module docstring), :math:`J^2` times smaller
    than over the CPI. The blocks
    are the fewest :math:`J` equal ones (at most one chirp each) with every :math:`\theta_p \le`
    :data:`BLOCK_SWEEP_PHASE` and, with a budget ``max_error``, a Taylor tail at degree
    :data:`BLOCK_TAYLOR_ORDER` (:mod:`.accuracy`,
    :math:`\sqrt{P_t}\max_c\sum_p|a_p|e^{\theta_p}\theta_p^{Q+1}/(Q+1)!`) within half the Taylor
    share; without a budget every :math:`\theta_p \le` :data:`TIGHT_BLOCK_SWEEP_PHASE`; at least ``least``
    blocks."""
    from .accuracy import TAYLOR_SHARE

    L = radar.num_chirps
    rate = np.abs(echoes.rates()) * (echoes.a != 0)
    peak = float(rate.max(initial=0.0))
    if peak == 0.0:
        return [(0, L)]
    keystone = 1 + radar.slope / (radar.fs * radar.centre_frequency) * (radar.num_samples - 1) / 2
    scale = 0.5 * np.pi * (radar.block_interval * (L - 1) / 2) ** 2 * keystone   # theta over the CPI per Hz/s
    cap = BLOCK_SWEEP_PHASE if max_error is not None else TIGHT_BLOCK_SWEEP_PHASE
    count = int(min(L, max(least, np.ceil(np.sqrt(scale * peak / cap)))))
    if max_error is not None:
        m, n = radar.num_tx, radar.num_rx
        amplitude = np.abs(echoes.a).reshape(m * n, -1)
        theta_cpi = (scale * rate).reshape(m * n, -1)
        allowed = 0.5 * TAYLOR_SHARE * max_error / np.sqrt(radar.tx_power)
        q = BLOCK_TAYLOR_ORDER
        while count < L:
            theta = theta_cpi / count**2
            if float((amplitude * np.exp(theta) * theta ** (q + 1)).sum(axis=1).max()) / factorial(q + 1) <= allowed:
                break
            count += 1
    edges = np.linspace(0, L, count + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:]) if b > a]


_BLOCK_RADARS: dict = {}


def _block(echoes, radar, start: int, stop: int):
    r"""The contributions of chirps ``start .. stop - 1`` as the echoes of a CPI that starts with chirp
    ``start`` (:math:`t_s = \mathrm{start}\,T_b` later): :math:`\tau_0 - (f_Dt_s + \dot f_Dt_s^2/2)/f_c`,
    :math:`f_D + \dot f_Dt_s`, the same :math:`\dot f_D` and gains (exact), and the radar of
    ``stop - start`` chirps."""
    from ..echoes import Echoes

    key = (id(radar), stop - start)
    sub = _BLOCK_RADARS.get(key)
    if sub is None or sub[0] is not radar:
        if len(_BLOCK_RADARS) > 64:
            _BLOCK_RADARS.clear()
        sub = _BLOCK_RADARS[key] = (radar, radar.replace(num_chirps=stop - start))
    t_s = start * radar.block_interval
    rate = echoes.rates()
    if start == 0:
        part = echoes
    else:
        part = object.__new__(Echoes)   # shifted copies of checked arrays: not checked again
        part.a = echoes.a
        part.tau = echoes.tau - (echoes.doppler * t_s + 0.5 * rate * t_s**2) / radar.fc
        part.doppler = echoes.doppler + rate * t_s
        part.doppler_rate, part.labels = echoes.doppler_rate, None
        part.static_count, part.static_key = 0, None
    return part, sub[1]


def beat_nufft(echoes, radar, workers: int | None = None, nufft_tol: float = NUFFT_TOL,
               taylor_tol: float = TAYLOR_TOL, max_error: float | None = None,
               channels_per_plan: int | None = None, upsampfac: float | None = None,
               precision: str | None = None, weights: np.ndarray | None = None):
    r"""Noise-free beat cube ``[chirp, tx, rx, sample]`` by type-3 NUFFT.

    Parameters
    ----------
    max_error : float, optional
        Error budget per sample (sqrt(W)); the Taylor terms, finufft tolerance and precision are
        chosen to meet it (:func:`~sionnafmcw.synthesis.accuracy.choose_accuracy`). None keeps the
        tight relative ``nufft_tol`` / ``taylor_tol`` in double precision.
    channels_per_plan : int, optional
        Channels sharing one finufft plan (1: a plan per channel); default
        :data:`CHANNELS_PER_PLAN` up to :data:`SHARED_PLAN_MAX_SOURCES` contributions per channel, else 1.
    workers : int, optional
        Threads (default :func:`~sionnafmcw.threads.synthesis_pool`: the run's share within
        :func:`~sionnafmcw.threads.run_threads`, else the cores this process may use; at most one per plan).
    precision : {"complex64", "complex128"}, optional
        Override the precision chosen from the budget (for measurements of the error floor).
    weights : ndarray, optional
        Real weights ``[M, N, P]``, one per contribution: also return the sum with every gain
        multiplied by its weight (the delays, for phase noise:
        :mod:`sionnafmcw.receiver.phase_noise`): more strength vectors of the same plans. With the same
        Taylor terms its error bound would be the plain sum's scaled by the largest weight; where
        every contribution's residual phase bound :math:`2\pi|R_p|` on the grid (the sum of its
        ``phases``) is below :data:`WEIGHTED_RESIDUAL_MAX` the weighted sum keeps only the constant
        term, an error of at most that fraction of each weighted strength (for phase noise: a term
        40 dB below the phase-noise term itself, which is 40 dB or more below its carrier).

    Returns
    -------
    ndarray or tuple
        The cube, complex64 when the budget allows single precision, complex128 otherwise; with
        ``weights`` the pair of the cube and the weighted cube.
    """
    if channels_per_plan is not None and channels_per_plan < 1:
        raise ValueError(f"beat_nufft: channels_per_plan must be >= 1, got {channels_per_plan!r}")
    if echoes.accelerating:
        return _beat_blocks(echoes, radar, workers, nufft_tol, taylor_tol, max_error, channels_per_plan, upsampfac,
                            precision, weights)
    return _beat(echoes, radar, _Grid(radar), workers, nufft_tol, taylor_tol, max_error, channels_per_plan,
                 upsampfac, precision, weights)


def rate_classes(echoes, radar) -> list[tuple[int, np.ndarray]]:
    r"""The contributions of ``echoes`` grouped by the chirp blocks their Doppler sweep needs:
    ``[(J, mask [P]), ...]``, :math:`J` a power of two, the smallest with
    :math:`\theta_{p,CPI}/J^2 \le` :data:`BLOCK_SWEEP_PHASE` (:func:`chirp_blocks`; :math:`\theta_p` the
    largest over the element pairs), ``J = 0`` for contributions without a rate (the sum of
    :func:`beat_nufft` without Doppler rates). A walk frame's body sweeps a few radians over the CPI,
    the odd chain off a swinging limb hundreds: grouped, the many slow ones are not cut into the
    blocks the few fast ones need."""
    L = radar.num_chirps
    keystone = 1 + radar.slope / (radar.fs * radar.centre_frequency) * (radar.num_samples - 1) / 2
    scale = 0.5 * np.pi * (radar.block_interval * (L - 1) / 2) ** 2 * keystone
    rate = np.abs(echoes.rates()) * (echoes.a != 0)
    theta = scale * rate.reshape(-1, rate.shape[-1]).max(axis=0, initial=0.0)
    need = np.ceil(np.sqrt(theta / BLOCK_SWEEP_PHASE))
    level = np.where(theta > 0, 2.0 ** np.ceil(np.log2(np.maximum(need, 1.0))), 0).astype(np.int64)
    level = np.minimum(level, L)
    return [(int(j), level == j) for j in np.unique(level)]


def _beat_blocks(echoes, radar, workers, nufft_tol, taylor_tol, max_error, channels_per_plan, upsampfac, precision,
                 weights):
    r""":func:`beat_nufft` of echoes with Doppler rates: the contributions grouped by :func:`rate_classes`,
    each group's sum in its own chirp blocks (:func:`chirp_blocks`; each block its own fast sum with the
    accelerating bases, within the group's budget: the blocks are disjoint samples), the groups added;
    the budget is split between the groups in proportion to their strength sums
    :math:`\max_c\sum_p|a_p|` (the bounds of :mod:`.accuracy` grow with them)."""
    from ..echoes import Echoes

    classes = rate_classes(echoes, radar)
    if len(classes) == 1:
        return _beat_class(echoes, radar, classes[0][0], workers, nufft_tol, taylor_tol, max_error, channels_per_plan,
                           upsampfac, precision, weights)
    strength = [float(np.abs(echoes.a[..., mask]).sum(axis=-1).max()) for _, mask in classes]
    total = sum(strength) or 1.0
    out = None
    for (level, mask), part_strength in zip(classes, strength):
        if part_strength == 0.0 and out is not None:
            continue   # only padding (zero gains): nothing to add
        part = Echoes(echoes.a[..., mask], echoes.tau[..., mask], echoes.doppler[..., mask],
                      doppler_rate=echoes.rates()[..., mask] if level else None)
        budget = None if max_error is None else max_error * max(part_strength / total, 1e-12)
        cubes = _beat_class(part, radar, level, workers, nufft_tol, taylor_tol, budget, channels_per_plan, upsampfac,
                            precision, None if weights is None else weights[..., mask])
        cubes = (cubes,) if weights is None else cubes
        if out is None:
            out = [c.astype(np.complex128) for c in cubes]
        else:
            for o, c in zip(out, cubes):
                o += c
    return out[0] if weights is None else (out[0], out[1])


def _beat_class(echoes, radar, level: int, workers, nufft_tol, taylor_tol, max_error, channels_per_plan, upsampfac,
                precision, weights):
    """The fast sum of one :func:`rate_classes` group: without rates (``level`` 0) as :func:`beat_nufft` without
    them, else in at least ``level`` chirp blocks (:func:`chirp_blocks`); a block whose residual still needs
    a Taylor order above :data:`~.accuracy.MAX_ORDER` (the sweep with the other residuals and the dropped
    terms) is summed again as two halves, and a single chirp that still does by the direct sum."""
    if level == 0:
        return _beat(echoes, radar, _Grid(radar), workers, nufft_tol, taylor_tol, max_error, channels_per_plan,
                     upsampfac, precision, weights)
    L, M, N, Ns = radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples
    sums = 1 if weights is None else 2
    out = None
    pending = list(chirp_blocks(echoes, radar, max_error, least=level))
    while pending:
        start, stop = pending.pop(0)
        part, sub = _block(echoes, radar, start, stop)
        try:
            cubes = _beat(part, sub, _Grid(sub, accelerating=True), workers, nufft_tol, taylor_tol, max_error,
                          channels_per_plan, upsampfac, precision, weights)
        except OrderError:
            if stop - start == 1:   # the dropped terms alone exceed the Taylor share: this chirp exactly
                from .direct import beat_direct

                cube = beat_direct(part, sub, weights=weights)
                cubes = cube if weights is not None else cube.astype(np.complex128)
                cubes = (cubes,) if weights is None else cubes
                if out is None:
                    out = np.zeros((sums, L, M, N, Ns), dtype=np.complex128)
                out = out.astype(np.complex128, copy=False)
                for o, c in enumerate(cubes):
                    out[o, start:stop] = c
                continue
            middle = (start + stop) // 2
            pending[:0] = [(start, middle), (middle, stop)]
            continue
        cubes = (cubes,) if weights is None else cubes
        if out is None:
            out = np.zeros((sums, L, M, N, Ns), dtype=cubes[0].dtype)
        elif out.dtype != cubes[0].dtype and cubes[0].dtype == np.complex128:
            out = out.astype(np.complex128)
        for o, cube in enumerate(cubes):
            out[o, start:stop] = cube
    return out[0] if weights is None else (out[0], out[1])


def _beat(echoes, radar, grid, workers, nufft_tol, taylor_tol, max_error, channels_per_plan, upsampfac, precision,
          weights):
    """The fast sum of :func:`beat_nufft` on ``grid`` (:class:`_Grid` of ``radar``)."""
    L, M, N, Ns = radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples
    channels, groups, shifts = _plans(echoes, radar, grid, channels_per_plan, weights)
    accuracy = _accuracy(channels, radar, max_error, nufft_tol, taylor_tol)
    dtype = np.dtype(precision or accuracy.dtype)
    if upsampfac is None:  # 0: finufft's own choice (as before the noise budget)
        upsampfac = UPSAMPFAC if accuracy.nufft_tol >= 1e-6 else 0.0
    real = np.float32 if dtype == np.complex64 else np.float64
    sums = 1 if weights is None else 2          # outputs per channel: the sum, and the weighted sum
    out = np.zeros((sums, L, M, N, Ns), dtype=dtype)
    if not channels:
        return out[0] if weights is None else (out[0], out[1])
    terms = list(accuracy.terms)
    weighted_terms = 0 if weights is None else len(terms)
    largest_residual = max(float(c.phases.sum(axis=0).max(initial=0.0)) for c in channels)
    if weights is not None and largest_residual < WEIGHTED_RESIDUAL_MAX:
        weighted_terms = 1
    rows = len(terms) + weighted_terms          # strength vectors per channel
    basis_terms = []
    for term in terms:
        b = np.ones((L, Ns))
        for i, power in enumerate(term):
            if power:
                b = b * grid.basis[i] ** power
        basis_terms.append(b.astype(real))
    target_x = grid.x.astype(real)
    scale = np.sqrt(radar.tx_power)

    def run(group, shift):
        still = [_still(c) for c in group]
        cubes = _still_cubes(group, still, sums, dtype, real, scale, accuracy.nufft_tol, upsampfac, grid)
        group = [c if not s.any() else c.select(~s) for c, s in zip(group, still)]
        if not any(c.x.size for c in group):
            return cubes
        sizes = [c.x.size for c in group]
        offsets = np.concatenate([[0], np.cumsum(sizes)])
        # the last columns: two sources of zero strength at the corners of the band (ANCHORS)
        vectors = np.zeros((len(group) * rows, offsets[-1] + len(ANCHORS)), dtype=dtype)
        for j, c in enumerate(group):
            strength = c.strength(dtype)
            strength *= real(scale)
            for t, term in enumerate(terms):
                w = strength
                for i, power in enumerate(term):
                    if power:
                        w = w * ((2j * np.pi * c.residual[i]) ** power / factorial(power)).astype(dtype)
                vectors[j * rows + t, offsets[j]:offsets[j + 1]] = w
                if t < weighted_terms:
                    vectors[j * rows + len(terms) + t, offsets[j]:offsets[j + 1]] = w * c.weight.astype(real)
        plan = finufft.Plan(3, 2, n_trans=vectors.shape[0], eps=accuracy.nufft_tol, isign=1, dtype=dtype.name,
                            nthreads=1, upsampfac=upsampfac, showwarn=0)
        target_y = grid.y if shift == 0.0 else grid.y + shift * grid.basis[0].ravel()   # the plan's keystone
        plan.setpts(np.concatenate([c.x for c in group] + [ANCHORS[:, 0]]).astype(real),
                    np.concatenate([c.y for c in group] + [ANCHORS[:, 1]]).astype(real), None, target_x,
                    target_y.astype(real))
        values = plan.execute(vectors if vectors.shape[0] > 1 else vectors[0])
        values = np.reshape(values, (len(group), rows, L, Ns))
        for j, c in enumerate(group):
            for o, (first, count) in enumerate(((0, len(terms)), (len(terms), weighted_terms))[:sums]):
                cube = values[j, first].copy()  # terms[0] is the constant monomial (basis 1)
                for t in range(1, count):
                    cube += values[j, first + t] * basis_terms[t]
                cubes.append((o, c.m, c.n, cube))
        return cubes

    workers = workers or min(len(groups), run_threads_module.synthesis_pool())
    if workers > 1:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            results = list(pool.map(run, groups, shifts))
    else:
        results = [run(g, s) for g, s in zip(groups, shifts)]
    for cubes in results:
        for o, m, n, cube in cubes:
            out[o, :, m, n, :] += cube
    return out[0] if weights is None else (out[0], out[1])


def _still(c: _Channel) -> np.ndarray:
    r"""``[P]`` bool: the contributions of channel ``c`` whose phase is :math:`\Phi_0 + A_pk'` alone (no
    Doppler phase step :math:`B_p`, no residual, nothing dropped): a still target seen by a radar at rest
    (:math:`\nu = 0` zeroes :math:`B, C, K_u, K_l` of :mod:`.phase`), the same beat in every chirp."""
    still = c.y == 0.0
    for r in c.residual:
        still &= r == 0.0
    if c.dropped is not None:
        still &= c.dropped == 0.0
    return still


def _still_cubes(group, still, rows: int, dtype, real, scale, tol: float, upsampfac: float, grid: _Grid) -> list:
    r"""The cubes ``[(o, m, n, [L, N_s])]`` of the still contributions (:func:`_still`) of the channels of
    ``group``: one 1-D type-3 transform from :math:`x_p = 2\pi A_p` to the :math:`N_s` sample indices
    :math:`k'`, the same row in every chirp, with ``rows`` strength vectors per channel (the sum and, for
    phase noise, the weighted sum: the residual is zero, so the constant term is exact).

    Why it is as accurate as the 2-D sum it takes them out of: a still contribution's phase does not
    depend on the chirp, so :math:`e^{jy_pY} = 1` on every target of the 2-D transform and its value at
    :math:`(l', k')` is this transform's at :math:`k'`. The 1-D transform runs at the 2-D plan's tolerance
    and precision, whose error is the spreading kernel's truncation in each dimension (finufft), so in one
    dimension it is at most the 2-D transform's; the bound of :mod:`.accuracy`, linear in each channel's
    strength sum, then holds for the still and the moving parts together. The cost per source drops from
    :math:`w^2` kernel evaluations to :math:`w`, the targets from :math:`LN_s` to :math:`N_s`: a room's
    static block and the static samples a moving body blocks in a frame are such contributions."""
    if not any(s.any() for s in still):
        return []
    num_chirps = grid.basis[0].shape[0]
    chans = [(c.select(s), c) for c, s in zip(group, still) if s.any()]
    offsets = np.concatenate([[0], np.cumsum([part.x.size for part, _ in chans])])
    vectors = np.zeros((len(chans) * rows, offsets[-1] + len(ANCHORS)), dtype=dtype)
    for j, (part, _) in enumerate(chans):
        strength = part.strength(dtype)
        strength *= real(scale)
        vectors[j * rows, offsets[j]:offsets[j + 1]] = strength
        if rows > 1:
            vectors[j * rows + 1, offsets[j]:offsets[j + 1]] = strength * part.weight.astype(real)
    plan = finufft.Plan(3, 1, n_trans=vectors.shape[0], eps=tol, isign=1, dtype=np.dtype(dtype).name, nthreads=1,
                        upsampfac=upsampfac, showwarn=0)
    plan.setpts(np.concatenate([part.x for part, _ in chans] + [ANCHORS[:, 0]]).astype(real), None, None,
                grid.k.astype(real))
    values = plan.execute(vectors if vectors.shape[0] > 1 else vectors[0])
    values = np.reshape(values, (len(chans), rows, grid.k.size))
    return [(o, c.m, c.n, np.broadcast_to(values[j, o], (num_chirps, grid.k.size)))
            for j, (_, c) in enumerate(chans) for o in range(rows)]


__all__ = ["BLOCK_SWEEP_PHASE", "BLOCK_TAYLOR_ORDER", "CHANNELS_PER_PLAN", "TIGHT_BLOCK_SWEEP_PHASE", "SHARED_PLAN_MAX_SOURCES", "MAX_ORDER", "NUFFT_TOL", "TAYLOR_TOL",
           "UPSAMPFAC", "WEIGHTED_RESIDUAL_MAX", "beat_nufft", "chirp_blocks", "rate_classes", "synthesis_accuracy", "taylor_order"]
