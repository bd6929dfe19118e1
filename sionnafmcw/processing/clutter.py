r"""Static clutter removal: subtract the slow-time mean.

.. math::
    y_{l,\dots} = x_{l,\dots} - \frac{1}{L}\sum_{l'=0}^{L-1} x_{l',\dots}

per channel and per fast-time sample (or range bin; the range FFT is linear, so the order does
not matter). It removes every echo whose complex amplitude is constant over the CPI (walls,
furniture, Tx-Rx leakage), i.e. the zero-Doppler component of the *unwindowed* slow-time
spectrum; a mover slower than about one velocity bin loses part of its power too.
"""

from __future__ import annotations

import numpy as np


def remove_static_clutter(cube, axis: int = 0) -> np.ndarray:
    """``cube`` minus its mean along slow time ``axis`` (``chirp`` is axis 0 of the raw cube)."""
    x = np.asarray(cube)
    return x - x.mean(axis=axis, keepdims=True)
