r"""Sub-bin peak interpolation and local maxima.

Three-point estimators around a peak bin :math:`k` with neighbours :math:`k\pm1`; the offset
:math:`\delta \in [-\tfrac12, \tfrac12]` (bins of the FFT used) is added to :math:`k`.

``"gaussian"`` (default; parabola through the log power :math:`y = \ln|X|^2`)
    :math:`\delta = \frac{1}{2}\frac{y_{k-1} - y_{k+1}}{y_{k-1} - 2y_k + y_{k+1}}`.
    Works on power maps (non-coherent sums) and with any window. Worst-case bias for a single
    noise-free tone (measured, :math:`N = 128`): Hann 0.016 bin without zero padding, 0.003 bin
    with 2x and 0.0008 bin with 4x padding; rectangular 0.17 bin without padding, 0.004 bin with 4x.
``"parabolic"``
    The same parabola through :math:`|X|`; more biased, kept for comparison.
``"jacobsen"`` (complex spectrum, no zero padding)
    :math:`\delta = P\,\mathrm{Re}\frac{X_{k-1} - X_{k+1}}{2X_k - X_{k-1} - X_{k+1}}` with
    :math:`P = 1` for the rectangular window (Jacobsen; bias below :math:`10^{-4}` bin at
    :math:`N=128`) and :math:`P = 2` for the periodic Hann window (exact for one noise-free tone).
    Other windows or zero-padded spectra are rejected.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

_JACOBSEN_FACTOR = {None: 1.0, "boxcar": 1.0, "rect": 1.0, "rectangular": 1.0, "hann": 2.0, "hanning": 2.0}


def parabolic_offset(y_minus, y_0, y_plus):
    """Vertex of the parabola through ``(-1, y_minus), (0, y_0), (1, y_plus)``: ``(offset, value)``.

    The offset is clipped to ``[-0.5, 0.5]``; a flat triple gives 0.
    """
    ym, y0, yp = (np.asarray(v, dtype=float) for v in (y_minus, y_0, y_plus))
    den = ym - 2.0 * y0 + yp
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(den < 0, 0.5 * (ym - yp) / den, 0.0)
    delta = np.clip(np.nan_to_num(delta), -0.5, 0.5)
    return delta, y0 - 0.25 * (ym - yp) * delta


def interpolate_peak(spectrum, index, axis: int = 0, method: str = "gaussian", circular: bool = False,
                     window="hann"):
    """Fractional index of a peak along ``axis``.

    Parameters
    ----------
    spectrum : ndarray
        Power (``"gaussian"``, ``"parabolic"``: any non-negative real map, or complex, whose
        :math:`|X|^2` is used) or complex spectrum (``"jacobsen"``).
    index : tuple of int or of int arrays
        Full index of the peak cell(s) (``np.unravel_index`` / ``np.nonzero`` style).
    axis : int
        Axis to interpolate along.
    method : {"gaussian", "parabolic", "jacobsen"}
        See the module docstring.
    circular : bool
        Wrap neighbours around the axis ends (a shifted Doppler axis); otherwise a peak on the
        first or last bin is returned unchanged.
    window : str or None
        The window of ``spectrum`` (``"jacobsen"`` only).

    Returns
    -------
    float or ndarray: ``index[axis] + delta``.
    """
    s = np.asarray(spectrum)
    axis = axis % s.ndim
    idx = [np.asarray(i) for i in index]
    n = s.shape[axis]
    k = idx[axis].astype(int)
    km, kp = k - 1, k + 1
    edge = np.zeros(k.shape, bool)
    if circular:
        km, kp = km % n, kp % n
    else:
        edge = (km < 0) | (kp >= n)
        km, kp = np.clip(km, 0, n - 1), np.clip(kp, 0, n - 1)

    def take(kk):
        j = list(idx)
        j[axis] = kk
        return s[tuple(j)]

    xm, x0, xp = take(km), take(k), take(kp)
    if method == "jacobsen":
        if not np.iscomplexobj(s):
            raise ValueError("interpolate_peak: method='jacobsen' needs the complex spectrum")
        key = window.lower() if isinstance(window, str) else window
        if key not in _JACOBSEN_FACTOR:
            raise ValueError(f"interpolate_peak: no Jacobsen factor for window {window!r} (use 'hann' or None)")
        with np.errstate(divide="ignore", invalid="ignore"):
            delta = _JACOBSEN_FACTOR[key] * np.real((xm - xp) / (2 * x0 - xm - xp))
        delta = np.clip(np.nan_to_num(delta), -0.5, 0.5)
    else:
        if np.iscomplexobj(s):
            xm, x0, xp = (np.abs(v) ** 2 for v in (xm, x0, xp))
        if method == "gaussian":
            tiny = np.finfo(float).tiny
            xm, x0, xp = (np.log(np.maximum(np.asarray(v, float), tiny)) for v in (xm, x0, xp))
        elif method == "parabolic":
            xm, x0, xp = (np.sqrt(np.asarray(v, float)) for v in (xm, x0, xp))
        else:
            raise ValueError(f"interpolate_peak: unknown method {method!r}; use 'gaussian', 'parabolic' or 'jacobsen'")
        delta, _ = parabolic_offset(xm, x0, xp)
    delta = np.where(edge, 0.0, delta)
    out = k + delta
    return float(out) if out.ndim == 0 else out


def uniform_axis_value(axis_values, fractional_index):
    """Value of a uniform axis at a fractional index (linear, extrapolating past the ends)."""
    a = np.asarray(axis_values, dtype=float)
    step = a[1] - a[0] if a.size > 1 else 0.0
    return a[0] + np.asarray(fractional_index, dtype=float) * step


def local_maxima(power, size=3, modes=("wrap", "reflect")) -> np.ndarray:
    """Boolean mask of cells equal to the maximum of their ``size`` neighbourhood.

    ``modes``: boundary handling per axis (scipy.ndimage names), default wrap along Doppler
    (axis 0) and reflect along range (axis 1).
    """
    p = np.asarray(power, dtype=float)
    return p >= ndimage.maximum_filter(p, size=size, mode=list(modes))
