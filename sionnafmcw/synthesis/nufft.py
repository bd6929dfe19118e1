r"""Fast beat synthesis: a 2-D type-3 NUFFT per channel with a Taylor-expanded residual.

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
transform (finufft's ``n_trans``), multiplied by its basis on the output grid. The truncation
error is below :math:`\theta^{Q+1}/(Q+1)!` with :math:`\theta = 2\pi\max_p|R_p|`; :math:`Q`
is the smallest order that brings it under ``taylor_tol`` (usually 1: four vectors).
The result is the exact model to the NUFFT tolerance (no far-field, no stop-and-go, no
dropped migration term).

Channels run as single-threaded plans spread over a thread pool (finufft releases the GIL),
which beats finufft's own threading on these small transforms (NOTES section 4).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from itertools import product
from math import factorial

import finufft
import numpy as np

from .phase import PhasePolynomial

#: finufft requested precision (relative to the sum of the strengths' magnitudes).
NUFFT_TOL = 1e-7
#: Largest neglected Taylor term of the residual phase.
TAYLOR_TOL = 1e-8
#: Taylor order cap (a residual that needs more is outside the model's intended regime).
MAX_ORDER = 6


def taylor_order(theta: float, tol: float = TAYLOR_TOL) -> int:
    """Smallest Q with theta^(Q+1)/(Q+1)! <= tol (0 when theta is 0)."""
    if theta <= 0:
        return 0
    for q in range(MAX_ORDER + 1):
        if theta ** (q + 1) / factorial(q + 1) <= tol:
            return q
    raise ValueError(
        f"beat synthesis: residual phase {theta:.3g} rad needs a Taylor order above {MAX_ORDER}; "
        "the contribution velocities are far outside the radar's design (check Echoes.doppler units: Hz)"
    )


def _channel_terms(poly: PhasePolynomial, eps1: float, eps2: float):
    delta = poly.c - eps1 * poly.b
    rho = poly.k_u - eps2 * poly.b
    return delta, rho, poly.k_l


def beat_nufft(echoes, radar, workers: int | None = None, nufft_tol: float = NUFFT_TOL,
               taylor_tol: float = TAYLOR_TOL) -> np.ndarray:
    """Noise-free beat cube ``[chirp, tx, rx, sample]`` (complex128) by type-3 NUFFT."""
    L, M, N, Ns = radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples
    l0 = (L - 1) / 2.0
    lc = np.arange(L) - l0
    kc = np.arange(Ns) - (Ns - 1) / 2.0
    f_mid = radar.centre_frequency
    eps1 = radar.slope / (radar.fs * f_mid)
    eps2 = radar.slope / (radar.block_interval * f_mid * radar.fs**2)
    grid_l, grid_k = np.meshgrid(lc, kc, indexing="ij")  # [L, Ns]
    target_x = grid_k.ravel()
    target_y = (grid_l * (1 + eps1 * grid_k) + eps2 * grid_k**2).ravel()
    basis = (grid_l * grid_k, grid_k**2, grid_l**2)
    basis_max = (np.abs(basis[0]).max(), np.abs(basis[1]).max(), np.abs(basis[2]).max())

    slot = radar.tx_slot()
    channels = []
    theta = 0.0
    for m in range(M):
        for n in range(N):
            live = echoes.a[m, n] != 0
            if not np.any(live):
                continue
            nu = echoes.doppler[m, n, live] / radar.fc
            poly = PhasePolynomial.from_delay_doppler(echoes.tau[m, n, live], nu, slot[m], radar)
            poly = poly.shift_chirp_origin(l0)
            residual = _channel_terms(poly, eps1, eps2)
            bound = sum(float(np.abs(r).max()) * bm for r, bm in zip(residual, basis_max))
            theta = max(theta, 2 * np.pi * bound)
            phi0 = poly.phi0 - np.round(poly.phi0)
            strength = np.conj(echoes.a[m, n, live]) * np.exp(2j * np.pi * phi0)
            channels.append((m, n, poly, residual, strength))

    order = taylor_order(theta, taylor_tol)
    terms = [t for t in product(range(order + 1), repeat=3) if sum(t) <= order]
    out = np.zeros((L, M, N, Ns), dtype=np.complex128)
    if not channels:
        return out
    basis_terms = []
    for term in terms:
        b = np.ones((L, Ns))
        for i, power in enumerate(term):
            if power:
                b = b * basis[i] ** power
        basis_terms.append(b)

    def run(channel):
        m, n, poly, residual, strength = channel
        vectors = np.empty((len(terms), strength.size), dtype=np.complex128)
        for t, term in enumerate(terms):
            w = strength.copy()
            for i, power in enumerate(term):
                if power:
                    w *= (2j * np.pi * residual[i]) ** power / factorial(power)
            vectors[t] = w
        # shift A by whole cycles into [-1/2, 1/2): exp(j2pi*j*k') = exp(-j*pi*j*(Ns-1)) for k' = k-(Ns-1)/2
        wraps = np.round(poly.a)
        vectors *= np.exp(-1j * np.pi * wraps * (Ns - 1))[None, :]
        plan = finufft.Plan(3, 2, n_trans=len(terms), eps=nufft_tol, isign=1, dtype="complex128",
                            nthreads=1)
        plan.setpts(2 * np.pi * (poly.a - wraps), 2 * np.pi * poly.b, None, target_x, target_y)
        values = plan.execute(vectors if len(terms) > 1 else vectors[0])
        values = np.reshape(values, (len(terms), L, Ns))
        cube = np.zeros((L, Ns), dtype=np.complex128)
        for t in range(len(terms)):
            cube += values[t] * basis_terms[t]
        return m, n, cube

    workers = workers or min(len(channels), os.cpu_count() or 1)
    if workers > 1:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            results = list(pool.map(run, channels))
    else:
        results = [run(c) for c in channels]
    for m, n, cube in results:
        out[:, m, n, :] = cube
    return np.sqrt(radar.tx_power) * out
