r"""Tapering windows with coherent-gain normalisation, shared by every FFT stage.

A window :math:`w_n` (from :func:`scipy.signal.get_window`, periodic/"DFT-even" form) is scaled
to unit sum,

.. math::
    \tilde w_n = \frac{w_n}{\sum_{n'} w_{n'}},

so that a complex tone :math:`A e^{j2\pi k_0 n/N}` centred on bin :math:`k_0` gives
:math:`|X_{k_0}| = |A|` whatever the window and the zero padding. White noise of variance
:math:`\sigma^2` per sample then has variance
:math:`\sigma^2 \sum_n \tilde w_n^2 = \sigma^2\,\mathrm{ENBW}/N` per bin
(ENBW = 1 bin for the rectangular window, 1.5 bins for Hann).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import get_window


def window_weights(window, n: int) -> np.ndarray:
    """Unit-sum window of length ``n`` (float64).

    Parameters
    ----------
    window : str, tuple, array_like or None
        Anything :func:`scipy.signal.get_window` accepts (``"hann"``, ``("kaiser", 8.0)``, ...),
        an explicit array of length ``n``, or ``None``/``"boxcar"`` for no taper.
    n : int
        Window length (the number of samples along the transformed axis, before zero padding).
    """
    n = int(n)
    if n < 1:
        raise ValueError(f"window length must be >= 1, got {n}")
    if window is None:
        w = np.ones(n)
    elif isinstance(window, (str, tuple)):
        w = get_window(window, n, fftbins=True)
    else:
        w = np.asarray(window, dtype=float)
        if w.shape != (n,):
            raise ValueError(f"window array has shape {w.shape}, expected ({n},)")
    total = w.sum()
    if not np.isfinite(total) or total <= 0:
        raise ValueError("window must have a positive finite sum")
    return w / total


def apply_window(x: np.ndarray, window, axis: int) -> np.ndarray:
    """``x`` times the unit-sum window along ``axis`` (complex dtype of ``x`` kept)."""
    x = np.asarray(x)
    axis = axis % x.ndim
    w = window_weights(window, x.shape[axis])
    shape = [1] * x.ndim
    shape[axis] = -1
    dtype = np.result_type(x.dtype, np.complex64)
    return (x * w.reshape(shape).astype(np.finfo(dtype).dtype)).astype(dtype, copy=False)
