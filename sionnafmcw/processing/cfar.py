r"""Constant false-alarm rate (CFAR) detection on 2-D power maps ``[doppler, range]`` (linear power).

The training cells of a cell under test (CUT) are a ``(2(g_0+t_0)+1) x (2(g_1+t_1)+1)`` rectangle
minus the central ``(2g_0+1) x (2g_1+1)`` guard block (which includes the CUT): :math:`N` cells.
For complex Gaussian noise the power is exponential (square-law detector).

CA-CFAR: noise estimate :math:`\hat\sigma^2 = \frac1N\sum_{i} P_i`, threshold
:math:`T = \alpha\hat\sigma^2` with

.. math::
    P_{fa} = \left(1 + \frac{\alpha}{N}\right)^{-N}
    \;\Leftrightarrow\; \alpha = N\left(P_{fa}^{-1/N} - 1\right).

OS-CFAR (Rohling): :math:`T = \alpha P_{(k)}`, the :math:`k`-th smallest training power, with

.. math::
    P_{fa} = \prod_{i=0}^{k-1} \frac{N - i}{N - i + \alpha}

solved for :math:`\alpha` with :func:`scipy.optimize.brentq`; the reported noise is
:math:`P_{(k)} / \sum_{i=N-k+1}^{N} 1/i` (unbiased for exponential noise). Default
:math:`k = \lfloor 3N/4 \rceil`.

Both are exact for independent exponential training cells. A windowed FFT correlates neighbouring
bins (Hann: adjacent-bin power correlation 0.44), which lowers the effective :math:`N` a little; the
guard cells also keep a target's own main lobe out of its estimate.

Edges: the map is extended with ``wrap`` along Doppler (axis 0: the shifted Doppler axis is
circular) and ``reflect`` (half-sample symmetric) along range (axis 1); other scipy.ndimage modes
(``nearest``, ``mirror``, ``wrap``) may be chosen per axis. Filtering uses
:func:`scipy.ndimage.correlate` (CA) and :func:`scipy.ndimage.rank_filter` (OS) with the
training footprint: no loop over cells.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize

_NP_PAD = {"wrap": "wrap", "reflect": "symmetric", "mirror": "reflect", "nearest": "edge"}


@dataclass
class CFARResult:
    """CFAR output, every array shaped like the power map.

    Attributes
    ----------
    detections : bool ndarray, power > threshold
    threshold : ndarray, :math:`\\alpha \\times` statistic
    noise : ndarray, local noise-power estimate
    factor : float, :math:`\\alpha`
    num_train : int, :math:`N`
    """

    detections: np.ndarray
    threshold: np.ndarray
    noise: np.ndarray
    factor: float
    num_train: int

    def indices(self) -> tuple[np.ndarray, ...]:
        """``np.nonzero(detections)``."""
        return np.nonzero(self.detections)


def _pair(v, name) -> tuple[int, int]:
    t = tuple(int(x) for x in np.broadcast_to(np.asarray(v), (2,)))
    if min(t) < 0:
        raise ValueError(f"CFAR {name} must be >= 0, got {v!r}")
    return t


def cfar_footprint(guard=(2, 2), train=(8, 8)) -> np.ndarray:
    """Boolean training footprint: outer rectangle minus the guard block (CUT included)."""
    g, t = _pair(guard, "guard"), _pair(train, "train")
    h = (g[0] + t[0], g[1] + t[1])
    fp = np.ones((2 * h[0] + 1, 2 * h[1] + 1), dtype=bool)
    fp[h[0] - g[0]:h[0] + g[0] + 1, h[1] - g[1]:h[1] + g[1] + 1] = False
    if not fp.any():
        raise ValueError("CFAR footprint has no training cells; raise train")
    return fp


def ca_cfar_factor(num_train: int, pfa: float) -> float:
    r""":math:`\alpha = N(P_{fa}^{-1/N} - 1)`."""
    _check_pfa(pfa)
    return float(num_train * (pfa ** (-1.0 / num_train) - 1.0))


def os_cfar_factor(num_train: int, rank: int, pfa: float) -> float:
    r""":math:`\alpha` solving :math:`P_{fa} = \prod_{i=0}^{k-1} (N-i)/(N-i+\alpha)`; ``rank`` = :math:`k` (1-based)."""
    _check_pfa(pfa)
    n, k = int(num_train), int(rank)
    if not 1 <= k <= n:
        raise ValueError(f"OS-CFAR rank must be in 1..{n}, got {k}")
    i = np.arange(k)

    def f(alpha):
        return np.sum(np.log(n - i) - np.log(n - i + alpha)) - np.log(pfa)

    hi = 1.0
    while f(hi) > 0:
        hi *= 2.0
    return float(optimize.brentq(f, 0.0, hi, xtol=1e-12, rtol=1e-12))


def _check_pfa(pfa):
    if not 0.0 < pfa < 1.0:
        raise ValueError(f"CFAR pfa must be in (0, 1), got {pfa!r}")


def _padded(power, half, modes):
    if np.iscomplexobj(power):
        raise ValueError("CFAR needs a real power map (use |x|**2)")
    p = np.asarray(power, dtype=float)
    if p.ndim != 2:
        raise ValueError(f"CFAR works on 2-D power maps [doppler, range], got shape {p.shape}")
    for ax, (h, mode) in enumerate(zip(half, modes)):
        if mode not in _NP_PAD:
            raise ValueError(f"CFAR edge mode {mode!r} unknown; use one of {', '.join(_NP_PAD)}")
        width = [(0, 0), (0, 0)]
        width[ax] = (h, h)
        p = np.pad(p, width, mode=_NP_PAD[mode])
    return p


def _crop(x, half, shape):
    return x[half[0]:half[0] + shape[0], half[1]:half[1] + shape[1]]


def ca_cfar_2d(power, guard=(2, 2), train=(8, 8), pfa: float = 1e-4, modes=("wrap", "reflect")) -> CFARResult:
    """Cell-averaging CFAR (see the module docstring); ``guard``/``train`` are half-widths (doppler, range)."""
    fp = cfar_footprint(guard, train)
    n = int(fp.sum())
    half = (fp.shape[0] // 2, fp.shape[1] // 2)
    p = np.asarray(power, dtype=float)
    padded = _padded(p, half, modes)
    noise = _crop(ndimage.correlate(padded, fp / n, mode="constant"), half, p.shape)
    alpha = ca_cfar_factor(n, pfa)
    threshold = alpha * noise
    return CFARResult(p > threshold, threshold, noise, alpha, n)


def os_cfar_2d(power, guard=(2, 2), train=(8, 8), pfa: float = 1e-4, rank: int | None = None,
               modes=("wrap", "reflect")) -> CFARResult:
    """Ordered-statistic CFAR; ``rank`` = :math:`k` (1-based, default :math:`\\lfloor 3N/4\\rceil`)."""
    fp = cfar_footprint(guard, train)
    n = int(fp.sum())
    k = int(round(0.75 * n)) if rank is None else int(rank)
    alpha = os_cfar_factor(n, k, pfa)
    half = (fp.shape[0] // 2, fp.shape[1] // 2)
    p = np.asarray(power, dtype=float)
    padded = _padded(p, half, modes)
    stat = _crop(ndimage.rank_filter(padded, k - 1, footprint=fp, mode="constant"), half, p.shape)
    mean_kth = np.sum(1.0 / np.arange(n - k + 1, n + 1))  # E[P_(k)] / sigma^2
    threshold = alpha * stat
    return CFARResult(p > threshold, threshold, stat / mean_kth, alpha, n)
