r"""TDM-MIMO virtual array of a :class:`~sionnafmcw.radar.RadarConfig`: element positions, phase
centre, elevation aperture and the uniform azimuth row (all in the radar frame, m).

Virtual array. In the far field the pair (Tx :math:`m`, Rx :math:`n`) sees the delay
:math:`(2R - (\mathbf t_m + \mathbf r_n)\cdot\hat{\mathbf u})/c`, so its phase is
:math:`e^{-j2\pi(\mathbf t_m + \mathbf r_n)\cdot\hat{\mathbf u}/\lambda_{mid}}` with
:math:`\hat{\mathbf u} = [\cos\theta_e\cos\phi, \cos\theta_e\sin\phi, \sin\theta_e]`: a
virtual element at :math:`\mathbf p_{mN+n} = \mathbf t_m + \mathbf r_n` (tx-major, physical order).

The radar frame has boresight along :math:`+x`, azimuth towards :math:`+y` and elevation towards
:math:`+z` (:mod:`sionnafmcw.geometry` places it in the world). These functions need only the
radar's ``tx_positions`` and ``rx_positions``; :class:`~sionnafmcw.radar.RadarConfig` exposes
:func:`virtual_array` and :func:`phase_centre` as properties of the same names.
"""

from __future__ import annotations

import numpy as np


def virtual_array(radar) -> np.ndarray:
    """Virtual element positions ``[M*N, 3]`` (m, radar frame), tx-major in physical order: index ``m*N + n``."""
    return (radar.tx_positions[:, None, :] + radar.rx_positions[None, :, :]).reshape(-1, 3)


def phase_centre(radar) -> np.ndarray:
    r"""Point ranges are measured from: :math:`\mathbf c = \frac{1}{2MN}\sum_{m,n}(\mathbf t_m + \mathbf r_n)` (m, ``[3]``, radar frame).

    The beat delay of every pair is the bistatic half-sum :math:`(|\mathbf p - \mathbf t_m| +
    |\mathbf p - \mathbf r_n|)/2 \approx |\mathbf p| - \tfrac12(\mathbf t_m + \mathbf r_n)\cdot\hat{\mathbf u}`;
    summed over all channels the range peak sits at :math:`|\mathbf p - \mathbf c|` (first order).
    With the Rx row beside the Tx row this is a centimetre or two off the radar origin, a sizeable
    fraction of a range bin. Its world position: :func:`sionnafmcw.geometry.world_phase_centre`.
    """
    return virtual_array(radar).mean(axis=0) / 2.0


def has_elevation_aperture(radar, tol: float = 1e-9) -> bool:
    """True when the virtual elements do not all lie at one height (elevation can be measured)."""
    return bool(np.ptp(virtual_array(radar)[:, 2]) > tol)


def uniform_azimuth_row(radar, tol: float = 1e-7) -> tuple[np.ndarray, float]:
    """The longest run of virtual elements on one horizontal line with uniform spacing.

    Elements are grouped by equal ``(x, z)`` (within ``tol`` m), duplicates along ``y`` (overlapping
    virtual elements) keep their first occurrence, and in every group the longest run of
    consecutive elements spaced by the group's smallest spacing :math:`d` is found.

    Returns
    -------
    indices : ndarray of int
        Virtual element indices (into :func:`virtual_array`) ordered by increasing ``y``.
    spacing : float
        :math:`d` (m).
    """
    p = virtual_array(radar)
    keys = np.round(p[:, [0, 2]] / tol).astype(np.int64)
    best_idx, best_d = None, None
    for key in np.unique(keys, axis=0):
        members = np.flatnonzero(np.all(keys == key, axis=1))
        order = members[np.argsort(p[members, 1], kind="stable")]
        y = p[order, 1]
        keep = np.concatenate([[True], np.diff(y) > tol])
        order, y = order[keep], y[keep]
        if len(order) < 2:
            continue
        gaps = np.diff(y)
        d = gaps.min()
        on_grid = np.abs(gaps - d) <= max(tol, 1e-6 * d)
        # longest run of consecutive True in on_grid -> run of len+1 elements
        run_start, run_len, start = 0, 0, 0
        for i, ok in enumerate(np.append(on_grid, False)):
            if not ok:
                if i - start > run_len:
                    run_start, run_len = start, i - start
                start = i + 1
        idx = order[run_start:run_start + run_len + 1]
        if best_idx is None or len(idx) > len(best_idx):
            best_idx, best_d = idx, float(d)
    if best_idx is None:
        raise ValueError("uniform_azimuth_row: no two virtual elements share a horizontal line")
    return best_idx, best_d
