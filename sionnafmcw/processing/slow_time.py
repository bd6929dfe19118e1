r"""Slow-time processing: Doppler FFT and the radial-velocity axis.

The TDM block interval :math:`T_b = M T_c` is the slow-time sampling interval of every channel.
A target with range rate :math:`v_r` (positive receding) rotates the phase of chirp :math:`l` by
:math:`-2\pi f_D' l T_b` with :math:`f_D' = -2 v_r/\lambda_{mid}` (sweep-centre wavelength,
:mod:`sionnafmcw.radar`), i.e. a slow-time tone at :math:`f = 2v_r/\lambda_{mid}`. After the forward FFT
of size :math:`L` and ``fftshift``, bin :math:`i` holds

.. math::
    f_i = \frac{i - \lfloor L/2 \rfloor}{L T_b}, \qquad
    v_i = f_i\,\frac{\lambda_{mid}}{2} \in [-v_{max}, v_{max}),\quad v_{max} = \frac{\lambda_{mid}}{4T_b}.

Velocities beyond :math:`\pm v_{max}` alias (wrap around).
"""

from __future__ import annotations

import numpy as np
import scipy.fft

from .windows import apply_window


def doppler_fft(x, window="hann", n_fft: int | None = None, axis: int = 0) -> np.ndarray:
    r"""Windowed forward FFT along slow time, ``fftshift``-ed: bin :math:`i` is :math:`v_i`.

    Parameters
    ----------
    x : array_like, complex
        Slow time along ``axis`` (chirp index).
    window : str, tuple, array or None
        Unit-sum taper (:mod:`.windows`).
    n_fft : int, optional
        FFT size :math:`L' \ge L`; default the number of chirps.
    axis : int
        Slow-time axis.
    """
    x = np.asarray(x)
    n = x.shape[axis]
    n_fft = n if n_fft is None else int(n_fft)
    if n_fft < n:
        raise ValueError(f"doppler_fft: n_fft={n_fft} is shorter than the {n} chirps (no truncation)")
    spec = scipy.fft.fft(apply_window(x, window, axis), n=n_fft, axis=axis)
    return scipy.fft.fftshift(spec, axes=axis)


def velocity_axis(radar, n_fft: int | None = None) -> np.ndarray:
    r"""Radial velocity of every shifted Doppler bin, :math:`v_i = (i - \lfloor L/2\rfloor)\lambda_{mid}/(2 L T_b)` (m/s, + receding)."""
    n_fft = radar.num_chirps if n_fft is None else int(n_fft)
    i = np.arange(n_fft) - n_fft // 2
    return i / (n_fft * radar.block_interval) * radar.centre_wavelength / 2.0
