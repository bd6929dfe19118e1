r"""TDM-MIMO processing: virtual channels and the TDM Doppler phase.

Virtual channels. The ``tx, rx`` axes of a cube merge into one virtual axis, tx-major: channel
:math:`mN + n` is the virtual element :math:`\mathbf t_m + \mathbf r_n` of
:func:`sionnafmcw.array.virtual_array` (the array geometry lives in :mod:`sionnafmcw.array`).

TDM phase. The Tx at firing slot :math:`q_m` transmits :math:`q_m T_c` after slot 0, so a target
with range rate :math:`v` adds :math:`e^{+j4\pi v q_m T_c/\lambda_{mid}}` to all of that Tx's
channels. Compensation multiplies Doppler bin :math:`i` by the conjugate evaluated at its
velocity :math:`v_i`. It is exact only for unaliased targets (:math:`|v| < v_{max}`): an aliased
target gets the phase of its aliased velocity and its angle is biased.
"""

from __future__ import annotations

import numpy as np


def virtual_channels(x, tx_axis: int = 1) -> np.ndarray:
    """Merge the adjacent ``tx, rx`` axes of ``x`` (at ``tx_axis``, ``tx_axis + 1``) into one virtual axis (tx-major)."""
    x = np.asarray(x)
    tx_axis = tx_axis % x.ndim
    if tx_axis + 1 >= x.ndim:
        raise ValueError(f"virtual_channels: no rx axis after tx_axis={tx_axis} in shape {x.shape}")
    shape = x.shape[:tx_axis] + (x.shape[tx_axis] * x.shape[tx_axis + 1],) + x.shape[tx_axis + 2:]
    return x.reshape(shape)


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
