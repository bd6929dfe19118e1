r"""Merging PO contributions the radar cannot tell apart, within a share of the noise-floor budget.

A PO render gives one contribution per surface sample and element pair: 1e5-3e5 per frame for a
furnished room, far more than the radar resolves. The engines sum the contributions that fall in
one cell into one per element pair (:func:`merge_contributions`), both engines with this one
function. A cell holds the contributions of one label whose centre-pair delay :math:`\tau_{00}`
lies in a cell of :math:`\epsilon/B`, whose Doppler lies in a cell of :math:`\epsilon/T_{CPI}`
(:math:`B` the sampled bandwidth, :math:`T_{CPI}` the CPI), and whose first- and last-segment
directions :math:`\hat{\mathbf u}` (radar frame, from the array's phase centre to the first and the
last interaction point) have :math:`u_y, u_z` in cells of :math:`\delta u = \epsilon c/(2BD)`,
:math:`D` the largest element distance from the phase centre: element pair :math:`(m, n)` sees a
contribution at :math:`\tau_{mn} \approx \tau_{00} - (\mathbf d_m\cdot\hat{\mathbf u}_{first} +
\mathbf d_n\cdot\hat{\mathbf u}_{last})/c`, so the direction cells keep every pair's delays within
about a delay cell too. (Without them -- cells of delay and Doppler alone -- a room's range ring,
which spans a wide arc, mixes contributions whose pair delays differ by far more than the cell:
measured on a circle-walk frame, the merge error of the room's PO then stays near 2 (first bounce)
and 7-11 (second bounce) times the noise budget :math:`E_{max}` whatever the cell size.)

Per pair a cell becomes one contribution at the cell's mean delay :math:`\bar\tau` and mean Doppler
:math:`\bar f` with :math:`\bar a = \sum_i a_i'`, :math:`a_i' = a_i e^{-j2\pi f_c(\tau_i - \bar\tau)}`:
the channel at the carrier is kept exactly. What is lost is the phase
:math:`\psi_i(k, l) = 2\pi[\mu(\tau_i - \bar\tau)t_k + (f_i - \bar f)(s_l + t_k)]` across the sweep
and the CPI (:mod:`sionnafmcw.synthesis`: fast time :math:`t_k \le t_{max} = t_{adc} + (N_s - 1)/F_s`,
chirp start :math:`s_l \le s_{max}`; the :math:`\mu\tau^2/2` term moves by :math:`\mu\bar\tau\Delta\tau`,
some 1e-6 cycles, and is left out). Per sample the merged cell errs by

.. math::
    e_c = \sum_i a_i'(e^{j\psi_i} - 1) = j\sum_i a_i'\psi_i + R_c,\qquad
    |R_c| \le \tfrac12\sum_i|a_i|\psi_{i,max}^2,

and the first term is :math:`j2\pi[\mu t_k M_{\tau,c} + (s_l + t_k)M_{f,c}]` with the cell's first
moments :math:`M_{\tau,c} = \sum_i a_i'(\tau_i - \bar\tau)`, :math:`M_{f,c} = \sum_i a_i'(f_i - \bar f)`:
they cancel where the samples of a smooth surface add with turning phases, which a bound by
:math:`\sum|a|` times the cell width (the old merge's, 1000 times the noise on a walking body) cannot
see. So every sample of the cube, every pair, is off by at most

.. math::
    E_{merge} = \sqrt{P_t}\,\max_{mn}\sum_c\Bigl[2\pi\bigl(\mu t_{max}|M_{\tau,c}| + (s_{max} + t_{max})|M_{f,c}|\bigr)
                + \tfrac12\sum_{i\in c}|a_i|\psi_{i,max}^2\Bigr]
    \quad(:func:`merge_error_bound`).

:func:`merge_contributions` takes the coarsest :math:`\epsilon` of :data:`FRACTIONS` whose
:math:`E_{merge}` fits the budget it is given; the engines give it :data:`MERGE_BUDGET_SHARE` of the
noise budget :math:`E_{max}` of :func:`~sionnafmcw.synthesis.accuracy.noise_error_budget` (split
between the static block and each frame like the synthesis's), and the synthesizer keeps the rest
for its own error, so the two add up to at most :math:`E_{max}` per sample, 20 dB below the thermal
noise (:mod:`sionnafmcw.synthesis`). Measured on a circle-walk frame (``benchmarks/po_merge.py``):
the bound is 2-10 times the merge error actually measured against the unmerged cube.

Doppler rates (motion within the CPI). Contributions with Doppler rates :math:`\dot f_i`
are also keyed on the rate, in cells of :math:`\epsilon/T_{CPI}^2` (the rate that turns the phase
:math:`\pi\dot f t^2` by :math:`\pi\epsilon` over the CPI), and a cell takes the mean rate
:math:`\bar{\dot f}`; the phase lost gains the term :math:`\pi(\dot f_i - \bar{\dot f})(s_l + t_k)^2`,
so the bound gains :math:`\pi(s_{max} + t_{max})^2|M_{\dot f,c}|` with the cell's moment
:math:`M_{\dot f,c} = \sum_i a_i'(\dot f_i - \bar{\dot f})` and that term in :math:`\psi_{i,max}`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import SPEED_OF_LIGHT
from ..synthesis.accuracy import NOISE_MARGIN_DB, UPSTREAM_SHARE, noise_error_budget

#: Share of the noise error budget :math:`E_{max}` that the PO merge may use (module docstring): what
#: the synthesizer leaves to the engines (:data:`sionnafmcw.synthesis.accuracy.UPSTREAM_SHARE`).
MERGE_BUDGET_SHARE = UPSTREAM_SHARE
#: The cell sizes :func:`merge_contributions` tries, coarsest first, as a share :math:`\epsilon` of the
#: radar's resolutions; beyond the finest nothing is merged.
FRACTIONS = tuple(2.0 ** -k for k in range(4, 14))
#: A merge is made only where it removes at least this share of the contributions: below it the
#: synthesis (whose cost per channel hardly depends on the count, :mod:`sionnafmcw.synthesis`) gains
#: nothing and the merge's share of the error budget is spent for nothing. A walking body's own PO
#: samples, spread over directions the array tells apart, merge by 7 % even in the coarsest cells
#: (measured on a circle-walk frame); a room's, seen once per radar pose, by 60-90 %.
MIN_SAVING = 0.2


@dataclass
class Merged:
    """What :func:`merge_contributions` returns: ``a, tau, doppler`` ``[M, N, G]``, ``labels [G]``, the
    cell of every input contribution ``cell [P]`` (index into ``G``), the cell ``fraction``
    :math:`\\epsilon` taken (None: nothing merged), its error ``bound`` (sqrt(W) per sample) and the
    cells' mean ``doppler_rate [M, N, G]`` (None for contributions without rates)."""

    a: np.ndarray
    tau: np.ndarray
    doppler: np.ndarray
    labels: np.ndarray
    cell: np.ndarray
    fraction: float | None
    bound: float
    doppler_rate: np.ndarray | None = None


def label_codes(labels) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(labels, return_inverse=True)`` for ``[P]`` string labels, read run by run (the
    labels of a render come in runs of one object, so only the runs' labels are sorted)."""
    labels = np.asarray(labels).astype(str, copy=False).reshape(-1)
    if labels.size == 0:
        return np.zeros(0, dtype=labels.dtype), np.zeros(0, dtype=np.int64)
    start = np.flatnonzero(np.concatenate([[True], labels[1:] != labels[:-1]]))
    names, run_code = np.unique(labels[start], return_inverse=True)
    return names, np.repeat(run_code.reshape(-1), np.diff(np.append(start, labels.size)))


def aperture(radar) -> float:
    """:math:`D`: the largest distance (m) of a Tx or Rx element from the array's phase centre."""
    from ..array import phase_centre

    elements = np.concatenate([radar.tx_positions, radar.rx_positions])
    return max(float(np.linalg.norm(elements - phase_centre(radar), axis=1).max()), 1e-6)


def cell_keys(tau00, doppler00, directions, label_code, radar, fraction: float, rate00=None) -> np.ndarray:
    """The cell of every contribution as one int64 key ``[P]`` (or a row of keys ``[P, K]`` where one
    would overflow) for cells of ``fraction`` :math:`\\epsilon` of the resolutions (module docstring).
    ``directions``: ``[P, 3]`` or a pair ``(first, last)`` of them, unit vectors in the radar frame;
    ``rate00``: the Doppler rates ``[P]`` (Hz/s) or None."""
    first, last = directions if isinstance(directions, tuple) else (directions, directions)
    d_tau = fraction / radar.bandwidth
    d_f = fraction / radar.cpi_duration
    d_u = fraction * SPEED_OF_LIGHT / (2 * radar.bandwidth * aperture(radar))
    columns = [np.asarray(label_code, np.int64), np.floor(np.asarray(tau00) / d_tau),
               np.floor(np.asarray(doppler00) / d_f), np.floor(first[:, 1] / d_u), np.floor(first[:, 2] / d_u)]
    if last is not first:
        columns += [np.floor(last[:, 1] / d_u), np.floor(last[:, 2] / d_u)]
    if rate00 is not None:
        columns.append(np.floor(np.asarray(rate00) / (fraction / radar.cpi_duration**2)))
    # each column from 0 (column by column: a strided reduction over [P, K] is several times slower)
    columns = [np.asarray(c, dtype=np.int64) for c in columns]
    lows = [int(c.min()) if c.size else 0 for c in columns]
    span = np.array([int(c.max()) - low + 1 if c.size else 1 for c, low in zip(columns, lows)], dtype=np.int64)
    if np.sum(np.log2(span.astype(float))) >= 62:
        return np.stack([c - low for c, low in zip(columns, lows)], axis=1)
    flat = columns[0] - lows[0]
    for c, low, size in zip(columns[1:], lows[1:], span[1:]):
        flat = flat * int(size) + (c - low)
    return flat


def count_cells(keys) -> int:
    """The number of distinct cells among :func:`cell_keys` (a sort, no inverse)."""
    if keys.ndim == 2:
        return len(np.unique(keys, axis=0))
    if keys.size == 0:
        return 0
    ordered = np.sort(keys)
    return int(np.count_nonzero(ordered[1:] != ordered[:-1])) + 1


def cells_of_keys(keys) -> tuple[np.ndarray, np.ndarray]:
    """Cell of every contribution ``[P]`` and the first contribution of every cell ``[G]`` (cells
    numbered in the order of their first contribution) from :func:`cell_keys`."""
    if keys.ndim == 2:
        _, first_index, cell = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    else:
        _, first_index, cell = np.unique(keys, return_index=True, return_inverse=True)
    order = np.argsort(first_index, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank[np.asarray(cell).reshape(-1)], first_index[order]


def merge_cells(tau00, doppler00, directions, label_code, radar, fraction: float, rate00=None):
    """Cell of every contribution ``[P]`` and the first contribution of every cell ``[G]`` (cells numbered
    in the order of their first contribution) for cells of ``fraction`` :math:`\\epsilon` of the
    resolutions (module docstring). ``directions``: ``[P, 3]`` or a pair ``(first, last)`` of them,
    unit vectors in the radar frame; ``rate00``: the Doppler rates ``[P]`` (Hz/s) or None."""
    return cells_of_keys(cell_keys(tau00, doppler00, directions, label_code, radar, fraction, rate00))


def _cell_sums(values, cell, num_cells):
    """Per pair row ``k`` and cell ``c``: the sum of ``values [K, P]`` over the cell, ``[K, G]`` (one bincount)."""
    rows = values.shape[0]
    index = (np.arange(rows)[:, None] * num_cells + cell[None]).ravel()
    if np.iscomplexobj(values):
        re = np.bincount(index, values.real.ravel(), rows * num_cells)
        im = np.bincount(index, values.imag.ravel(), rows * num_cells)
        return (re + 1j * im).reshape(rows, num_cells)
    return np.bincount(index, values.ravel(), rows * num_cells).reshape(rows, num_cells)


def _merge(a, tau, doppler, cell, num_cells, frequency, rate=None):
    """Per pair: the cells' mean delay and Doppler and :math:`\\bar a = \\sum a_i e^{-j2\\pi f_c(\\tau_i - \\bar\\tau)}`,
    and the carrier-corrected contributions and their deviations from the cell means; with ``rate``
    also the cells' mean Doppler rate and the deviations from it (else None, None)."""
    count = np.bincount(cell, minlength=num_cells).astype(float)
    mean_tau = _cell_sums(tau, cell, num_cells) / count
    mean_f = _cell_sums(doppler, cell, num_cells) / count
    d_tau = tau - mean_tau[:, cell]
    d_f = doppler - mean_f[:, cell]
    a_c = a * np.exp(-2j * np.pi * frequency * d_tau)
    mean_r = d_r = None
    if rate is not None:
        mean_r = _cell_sums(rate, cell, num_cells) / count
        d_r = rate - mean_r[:, cell]
    return _cell_sums(a_c, cell, num_cells), mean_tau, mean_f, a_c, d_tau, d_f, mean_r, d_r


def _bound(a, a_c, d_tau, d_f, cell, num_cells, radar, d_r=None) -> float:
    """:math:`E_{merge}` of the module docstring (sqrt(W) per sample)."""
    t_max = radar.adc_start_time + (radar.num_samples - 1) / radar.fs
    s_max = (radar.num_chirps * radar.num_tx - 1) * radar.chirp_interval
    m_tau = np.abs(_cell_sums(a_c * d_tau, cell, num_cells)).sum(axis=1)
    m_f = np.abs(_cell_sums(a_c * d_f, cell, num_cells)).sum(axis=1)
    psi = 2 * np.pi * (radar.slope * t_max * np.abs(d_tau) + (s_max + t_max) * np.abs(d_f))
    first = 2 * np.pi * (radar.slope * t_max * m_tau + (s_max + t_max) * m_f)
    if d_r is not None:
        span2 = (s_max + t_max) ** 2
        psi = psi + np.pi * span2 * np.abs(d_r)
        first = first + np.pi * span2 * np.abs(_cell_sums(a_c * d_r, cell, num_cells)).sum(axis=1)
    second = 0.5 * (np.abs(a) * psi * psi).sum(axis=1)
    return float(np.sqrt(radar.tx_power) * np.max(first + second))


def merge_error_bound(a, tau, doppler, cell, radar, doppler_rate=None) -> float:
    """:math:`E_{merge}` (sqrt(W) per cube sample, every pair) of merging ``a, tau, doppler`` (and
    ``doppler_rate``) ``[M, N, P]`` into the cells ``cell [P]`` (module docstring)."""
    m, n, p = np.shape(a)
    if p == 0:
        return 0.0
    num_cells = int(cell.max()) + 1
    flat = (np.reshape(a, (m * n, p)), np.reshape(tau, (m * n, p)), np.reshape(doppler, (m * n, p)))
    rate = None if doppler_rate is None else np.reshape(doppler_rate, (m * n, p))
    _, _, _, a_c, d_tau, d_f, _, d_r = _merge(*flat, cell, num_cells, radar.fc, rate)
    return _bound(flat[0], a_c, d_tau, d_f, cell, num_cells, radar, d_r)


def merge_contributions(a, tau, doppler, labels, directions, radar, budget: float, doppler_rate=None) -> Merged:
    """The contributions ``a, tau, doppler`` ``[M, N, P]`` (``labels [P]``; ``directions`` as
    :func:`merge_cells`; ``doppler_rate`` ``[M, N, P]`` or None) merged in the coarsest cells of
    :data:`FRACTIONS` whose :func:`merge_error_bound` is at most ``budget`` (sqrt(W) per sample);
    unmerged when none is.

    The sizes worth merging (removing at least :data:`MIN_SAVING` of the contributions) are found
    first, coarsest first; within them the cell size by bisection over :data:`FRACTIONS` (the bound
    shrinks with the cells) with the bound of the first and the last element pair, the two farthest
    apart, checked with every pair at the size found (one size finer while that fails). Nothing is
    merged where no size worth it fits. It depends on the contributions alone, so a frame's echoes
    do not depend on the frames before. Cells keep the order of their first contribution; a contribution alone in its
    cell comes back unchanged."""
    a = np.asarray(a)
    m, n, p = a.shape
    labels = np.asarray(labels).astype(str, copy=False)
    unmerged = Merged(a, np.asarray(tau), np.asarray(doppler), labels, np.arange(p), None, 0.0,
                      None if doppler_rate is None else np.asarray(doppler_rate))
    if p == 0:
        return unmerged
    names, codes = label_codes(labels)
    flat_a, flat_tau, flat_f = a.reshape(m * n, p), np.asarray(tau).reshape(m * n, p), \
        np.asarray(doppler).reshape(m * n, p)
    flat_r = None if doppler_rate is None else np.asarray(doppler_rate).reshape(m * n, p)
    # the bound is a maximum over pairs: the first pair alone failing settles it for both ends
    ends = [0, m * n - 1] if m * n > 1 else [0]
    keys, cache = {}, {}

    def key(k):
        if k not in keys:
            keys[k] = cell_keys(flat_tau[0], flat_f[0], directions, codes, radar, FRACTIONS[k],
                                None if flat_r is None else flat_r[0])
        return keys[k]

    def cells(k):
        if k not in cache:
            cache[k] = cells_of_keys(key(k))
        return cache[k]

    def rows_of(x, rows):
        return None if x is None else x[rows]

    def fits(k, rows):
        cell, first = cells(k)
        if first.size == p:
            return True   # nothing merged: exact
        _, _, _, a_c, d_tau, d_f, _, d_r = _merge(flat_a[rows], flat_tau[rows], flat_f[rows], cell, first.size,
                                                  radar.fc, rows_of(flat_r, rows))
        return _bound(flat_a[rows], a_c, d_tau, d_f, cell, first.size, radar, d_r) <= budget

    def worth(k):
        return count_cells(key(k)) <= (1.0 - MIN_SAVING) * p

    hi = -1                                  # the finest size still worth merging (worth is monotone)
    while hi + 1 < len(FRACTIONS) and worth(hi + 1):
        hi += 1
    if hi < 0 or not fits(hi, ends[:1]) or (len(ends) > 1 and not fits(hi, ends)):
        return unmerged
    lo = 0                                   # the coarsest size that fits on the two pairs, by bisection
    while lo < hi:
        mid = (lo + hi) // 2
        if fits(mid, ends):
            hi = mid
        else:
            lo = mid + 1
    for k in range(lo, len(FRACTIONS)):
        cell, first = cells(k)
        g = first.size
        if not worth(k):
            return unmerged
        merged, mean_tau, mean_f, a_c, d_tau, d_f, mean_r, d_r = _merge(flat_a, flat_tau, flat_f, cell, g, radar.fc,
                                                                        flat_r)
        bound = _bound(flat_a, a_c, d_tau, d_f, cell, g, radar, d_r)
        if bound <= budget:
            return Merged(merged.reshape(m, n, g), mean_tau.reshape(m, n, g), mean_f.reshape(m, n, g),
                          names[codes[first]], cell, FRACTIONS[k], bound,
                          None if mean_r is None else mean_r.reshape(m, n, g))
    return unmerged


def take_out_of_cells(a, tau, cell, cell_tau, cell_doppler, cell_labels, frequency: float):
    r"""Contributions that remove ``a, tau`` ``[M, N, K]`` (merged earlier into cells ``cell [K]``) from
    their cells: one contribution per cell touched, at the cell's delay :math:`\bar\tau` and Doppler,

    .. math:: -\sum_{i \in \text{cell}} a_i\,e^{-j2\pi f_c(\tau_i - \bar\tau)},

    so that the merged cell plus it is exactly the merge of the contributions left in it about the
    cell's means :math:`\bar\tau`, :math:`\bar f`, whose error is bounded as any merge's (module
    docstring, with the moments of what is left; a frame blocks a few per cent of the static
    samples). ``cell_tau``, ``cell_doppler`` ``[M, N, G]`` and ``cell_labels [G]`` are the merged
    output. Returns ``(a, tau, doppler, labels)``.
    """
    m, n, k = a.shape
    cells, inverse = np.unique(cell, return_inverse=True)
    g = cells.size
    z = -a * np.exp(-2j * np.pi * frequency * (tau - cell_tau[:, :, cell]))
    out = _cell_sums(z.reshape(m * n, k), inverse.reshape(-1), g)
    return out.reshape(m, n, g), cell_tau[:, :, cells], cell_doppler[:, :, cells], np.asarray(cell_labels)[cells]


def merge_budget(radar, share: float = 1.0) -> float:
    """``share`` of :data:`MERGE_BUDGET_SHARE` of the noise error budget
    (:func:`~sionnafmcw.synthesis.accuracy.noise_error_budget`, sqrt(W) per sample)."""
    return share * MERGE_BUDGET_SHARE * noise_error_budget(radar, NOISE_MARGIN_DB)


__all__ = ["FRACTIONS", "MERGE_BUDGET_SHARE", "MIN_SAVING", "Merged", "aperture", "cell_keys", "cells_of_keys",
           "count_cells", "label_codes", "merge_budget", "merge_cells", "merge_contributions", "merge_error_bound",
           "take_out_of_cells"]
