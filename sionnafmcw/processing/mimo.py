r"""TDM-MIMO virtual array and the TDM Doppler phase.

Virtual array. In the far field the pair (Tx :math:`m`, Rx :math:`n`) sees the delay
:math:`(2R - (\mathbf t_m + \mathbf r_n)\cdot\hat{\mathbf u})/c`, so its phase is
:math:`e^{-j2\pi(\mathbf t_m + \mathbf r_n)\cdot\hat{\mathbf u}/\lambda_{mid}}` with
:math:`\hat{\mathbf u} = [\cos\theta_e\cos\phi, \cos\theta_e\sin\phi, \sin\theta_e]`: a
virtual element at :math:`\mathbf p_{mN+n} = \mathbf t_m + \mathbf r_n` (tx-major, physical order).

TDM phase. The Tx at firing slot :math:`q_m` transmits :math:`q_m T_c` after slot 0, so a target
with range rate :math:`v` adds :math:`e^{+j4\pi v q_m T_c/\lambda_{mid}}` to all of that Tx's
channels. Compensation multiplies Doppler bin :math:`i` by the conjugate evaluated at its
velocity :math:`v_i`. It is exact only for unaliased targets (:math:`|v| < v_{max}`): an aliased
target gets the phase of its aliased velocity and its angle is biased.
"""

from __future__ import annotations

import numpy as np


def virtual_array(radar) -> np.ndarray:
    """Virtual element positions ``[M*N, 3]`` (m, radar frame), tx-major in physical order: index ``m*N + n``."""
    return (radar.tx_positions[:, None, :] + radar.rx_positions[None, :, :]).reshape(-1, 3)


def array_phase_centre(radar) -> np.ndarray:
    r"""Point ranges are measured from: :math:`\mathbf c = \frac{1}{2MN}\sum_{m,n}(\mathbf t_m + \mathbf r_n)` (m, ``[3]``).

    The beat delay of every pair is the bistatic half-sum :math:`(|\mathbf p - \mathbf t_m| +
    |\mathbf p - \mathbf r_n|)/2 \approx |\mathbf p| - \tfrac12(\mathbf t_m + \mathbf r_n)\cdot\hat{\mathbf u}`;
    summed over all channels the range peak sits at :math:`|\mathbf p - \mathbf c|` (first order).
    With the Rx row beside the Tx row this is a centimetre or two off the radar origin, a sizeable
    fraction of a range bin.
    """
    return virtual_array(radar).mean(axis=0) / 2.0


def virtual_channels(x, tx_axis: int = 1) -> np.ndarray:
    """Merge the adjacent ``tx, rx`` axes of ``x`` (at ``tx_axis``, ``tx_axis + 1``) into one virtual axis (tx-major)."""
    x = np.asarray(x)
    tx_axis = tx_axis % x.ndim
    if tx_axis + 1 >= x.ndim:
        raise ValueError(f"virtual_channels: no rx axis after tx_axis={tx_axis} in shape {x.shape}")
    shape = x.shape[:tx_axis] + (x.shape[tx_axis] * x.shape[tx_axis + 1],) + x.shape[tx_axis + 2:]
    return x.reshape(shape)


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


def tdm_phase_compensation(rd, radar, velocities, doppler_axis: int | None = 0, tx_axis: int = 1) -> np.ndarray:
    r"""Remove the TDM Doppler phase: multiply Tx :math:`m` by :math:`e^{-j4\pi v q_m T_c/\lambda_{mid}}`.

    Parameters
    ----------
    rd : array_like, complex
        Range-Doppler data, e.g. ``[doppler, tx, rx, range]`` from :func:`range_doppler`, or one
        snapshot ``[tx, rx]`` (then ``tx_axis=0`` and ``doppler_axis=None``).
    velocities : array_like
        Radial velocity (m/s, + receding) of each bin along ``doppler_axis`` (usually
        :func:`velocity_axis`), or a scalar applied to the whole array.
    doppler_axis : int or None
        Axis of ``rd`` that ``velocities`` runs along; ignored for a scalar velocity.
    tx_axis : int
        Axis of the (physical-order) transmitters.
    """
    x = np.asarray(rd)
    v = np.asarray(velocities, dtype=float)
    tx_axis = tx_axis % x.ndim
    if x.shape[tx_axis] != radar.num_tx:
        raise ValueError(f"tdm_phase_compensation: axis {tx_axis} has {x.shape[tx_axis]} entries, radar has {radar.num_tx} Tx")
    delay = radar.tx_slot() * radar.chirp_interval  # [M] s
    shape = [1] * x.ndim
    shape[tx_axis] = radar.num_tx
    if v.ndim == 0:
        phase = (-4.0 * np.pi / radar.centre_wavelength) * v * delay.reshape(shape)
    else:
        if doppler_axis is None or v.ndim != 1:
            raise ValueError("tdm_phase_compensation: velocities must be a scalar or 1-D along doppler_axis")
        doppler_axis = doppler_axis % x.ndim
        if x.shape[doppler_axis] != v.size:
            raise ValueError(f"tdm_phase_compensation: {v.size} velocities for {x.shape[doppler_axis]} Doppler bins")
        vshape = [1] * x.ndim
        vshape[doppler_axis] = v.size
        phase = (-4.0 * np.pi / radar.centre_wavelength) * v.reshape(vshape) * delay.reshape(shape)
    rot = np.exp(1j * phase).astype(np.result_type(x.dtype, np.complex64))
    return x * rot
