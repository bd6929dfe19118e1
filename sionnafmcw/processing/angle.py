r"""Angle estimation on the virtual array.

Steering vector of virtual element :math:`v` at :math:`\mathbf p_v` (:func:`sionnafmcw.array.virtual_array`):

.. math::
    a_v(\phi, \theta_e) = e^{-j2\pi\,\mathbf p_v\cdot\hat{\mathbf u}(\phi,\theta_e)/\lambda_{mid}},\qquad
    \hat{\mathbf u} = [\cos\theta_e\cos\phi,\ \cos\theta_e\sin\phi,\ \sin\theta_e],

azimuth :math:`\phi` positive towards :math:`+y`, elevation :math:`\theta_e` towards :math:`+z`.

Angle FFT (uniform row, :func:`sionnafmcw.array.uniform_azimuth_row`: elements :math:`y_i = y_0 + i d`). The
beamformer matched to :math:`a` is an inverse-sign DFT over the row,

.. math::
    S(u_q) = \sum_{i=0}^{N_a-1} \tilde w_i\, x_i\, e^{+j2\pi i q/Q},\qquad
    u_q = \frac{q - \lfloor Q/2\rfloor}{Q}\,\frac{\lambda_{mid}}{d} = \cos\theta_e\sin\phi,

(``fftshift``-ed, zero-padded to :math:`Q`); :math:`\phi = \arcsin u` where :math:`|u| \le 1`
(for :math:`d > \lambda_{mid}/2` grating lobes fold back inside the visible region). With a
unit-sum window a unit plane wave gives :math:`|S| = 1` at its angle.

Bartlett (conventional) beamformer, exact positions, any layout (also the raised Tx of TI boards):

.. math::
    P(\phi, \theta_e) = \left|\frac{\mathbf a^H(\phi,\theta_e)\,\mathbf x}{V}\right|^2,

per snapshot :math:`\mathbf x` (``V`` virtual channels); a unit plane wave gives 1 at its angle.
Averaging :math:`P` over snapshots gives the classical :math:`\mathbf a^H\hat{\mathbf R}\mathbf a/V^2`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft
from scipy import optimize

from ..echoes import target_direction
from .fast_time import range_axis
from ..array import has_elevation_aperture, uniform_azimuth_row, virtual_array
from .mimo import tdm_phase_compensation, virtual_channels
from .rdmap import range_doppler
from .slow_time import velocity_axis
from .windows import window_weights


def steering_vectors(radar, azimuths, elevations=0.0) -> np.ndarray:
    """:math:`a_v(\\phi, \\theta_e)`, shape ``broadcast(azimuths, elevations).shape + [V]`` (complex128)."""
    u = target_direction(*np.broadcast_arrays(np.asarray(azimuths, float), np.asarray(elevations, float)))
    return np.exp(-2j * np.pi / radar.centre_wavelength * (u @ virtual_array(radar).T))


@dataclass
class AngleSpectrum:
    """Output of :func:`angle_fft`.

    Attributes
    ----------
    spectrum : ndarray, complex
        Beamformer output, the angle axis where the ``tx, rx`` axes were.
    sin_azimuth : ndarray ``[Q]``
        :math:`u_q = \\cos\\theta_e\\sin\\phi` of each bin (uniform).
    azimuths : ndarray ``[Q]``, rad
        :math:`\\arcsin u_q`, NaN outside the visible region :math:`|u| > 1`.
    elements : ndarray of int
        Virtual elements of the row used; ``spacing`` (m) their pitch :math:`d`.
    """

    spectrum: np.ndarray
    sin_azimuth: np.ndarray
    azimuths: np.ndarray
    elements: np.ndarray
    spacing: float

    @property
    def visible(self) -> np.ndarray:
        return np.abs(self.sin_azimuth) <= 1.0


def angle_fft(x, radar, n_fft: int = 256, window=None, tx_axis: int = 1) -> AngleSpectrum:
    """Zero-padded FFT beamformer over the uniform azimuth row of the virtual array.

    Parameters
    ----------
    x : array_like, complex
        Data with the ``tx, rx`` axes at ``tx_axis, tx_axis+1`` (``[doppler, tx, rx, range]`` or
        ``[chirp, tx, rx, range]``: ``tx_axis=1``; one snapshot ``[tx, rx]``: ``tx_axis=0``).
        Compensate the TDM phase first (:func:`tdm_phase_compensation`) for moving targets.
    n_fft : int
        :math:`Q`, number of angle bins (zero padding), at least the row length.
    window : str, tuple, array or None
        Taper across the row (unit sum); ``None`` = rectangular (narrowest beam).
    """
    xv = virtual_channels(x, tx_axis)
    axis = tx_axis % np.asarray(x).ndim
    elements, d = uniform_azimuth_row(radar)
    if n_fft < len(elements):
        raise ValueError(f"angle_fft: n_fft={n_fft} is smaller than the {len(elements)}-element row")
    row = np.take(xv, elements, axis=axis)
    w = window_weights(window, len(elements))
    shape = [1] * row.ndim
    shape[axis] = -1
    row = row * w.reshape(shape)
    spec = scipy.fft.fftshift(scipy.fft.ifft(row, n=n_fft, axis=axis) * n_fft, axes=axis)
    u = (np.arange(n_fft) - n_fft // 2) / n_fft * radar.centre_wavelength / d
    with np.errstate(invalid="ignore"):
        az = np.where(np.abs(u) <= 1.0, np.arcsin(np.clip(u, -1, 1)), np.nan)
    return AngleSpectrum(spec, u, az, elements, d)


def bartlett_spectrum(snapshots, radar, azimuths, elevations=None, channel_axis: int = -1) -> np.ndarray:
    """Bartlett power :math:`|a^H x / V|^2` on an angle grid, per snapshot.

    Parameters
    ----------
    snapshots : array_like, complex
        Virtual-channel vectors (tx-major, :func:`virtual_channels`) along ``channel_axis``.
    azimuths : array_like ``[A]``, rad
    elevations : array_like ``[E]``, rad, optional
        If given, a 2-D grid; otherwise elevation 0.

    Returns
    -------
    ndarray: ``snapshots`` without the channel axis, followed by ``[A]`` or ``[E, A]``.
    """
    x = np.moveaxis(np.asarray(snapshots), channel_axis, -1)
    nv = radar.num_tx * radar.num_rx
    if x.shape[-1] != nv:
        raise ValueError(f"bartlett_spectrum: {x.shape[-1]} channels, expected {nv} virtual channels")
    az = np.atleast_1d(np.asarray(azimuths, float))
    if elevations is None:
        a = steering_vectors(radar, az, 0.0)  # [A, V]
        grid = az.shape
    else:
        el = np.atleast_1d(np.asarray(elevations, float))
        a = steering_vectors(radar, az[None, :], el[:, None])  # [E, A, V]
        grid = a.shape[:2]
    a = a.reshape(-1, nv).astype(np.result_type(x.dtype, np.complex64))
    y = x @ a.conj().T / nv
    return (np.abs(y) ** 2).reshape(x.shape[:-1] + grid)


def estimate_direction(snapshot, radar, elevation: bool | None = None, grid_step: float = np.deg2rad(1.0),
                       max_elevation: float = np.deg2rad(60.0)) -> tuple[float, float | None, float]:
    """Direction of the strongest plane wave in one virtual snapshot ``[V]`` (Bartlett maximum).

    Grid search (``grid_step``; elevation within ``±max_elevation`` when estimated) refined by
    Nelder-Mead on :math:`-|a^H x|^2` with exact element positions.

    Returns ``(azimuth, elevation or None, bartlett_power)``; elevation is estimated when
    ``elevation`` is true (default: when the layout has an elevation aperture) and is ``None``
    otherwise (azimuth then assumes elevation 0: it measures :math:`\\arcsin(\\cos\\theta_e\\sin\\phi)`).
    """
    x = np.asarray(snapshot).reshape(-1)
    if elevation is None:
        elevation = has_elevation_aperture(radar)
    az = np.arange(-np.pi / 2, np.pi / 2 + 1e-12, grid_step)
    if elevation:
        el = np.arange(-max_elevation, max_elevation + 1e-12, grid_step)
        p = bartlett_spectrum(x, radar, az, el)
        ie, ia = np.unravel_index(np.argmax(p), p.shape)
        start = np.array([az[ia], el[ie]])

        def cost(t):
            return -bartlett_spectrum(x, radar, t[0], t[1:2])[0, 0]
    else:
        p = bartlett_spectrum(x, radar, az)
        start = np.array([az[np.argmax(p)]])

        def cost(t):
            return -bartlett_spectrum(x, radar, t[0])[0]
    simplex = np.vstack([start, start + np.diag(np.full(start.size, grid_step / 2))])
    res = optimize.minimize(cost, start, method="Nelder-Mead",
                            options={"xatol": 1e-5, "fatol": 1e-12, "initial_simplex": simplex, "maxiter": 400})
    t = res.x if res.fun <= cost(start) else start
    return float(t[0]), (float(t[1]) if elevation else None), float(-cost(t))


@dataclass
class RangeAzimuthMap:
    """Range-azimuth power map (summed non-coherently over Doppler bins).

    Attributes
    ----------
    power : ndarray ``[range, azimuth]``
    ranges : ndarray ``[range]``, m
    azimuths : ndarray ``[azimuth]``, rad (increasing)
    """

    power: np.ndarray
    ranges: np.ndarray
    azimuths: np.ndarray


def range_azimuth_map(cube, radar, method: str = "fft", azimuths=None, n_angle: int = 256, window_angle=None,
                      window_range="hann", window_doppler="hann", clutter_removal: bool = True,
                      tdm_compensation: bool = True, n_range: int | None = None,
                      n_doppler: int | None = None, chunk: int = 32) -> RangeAzimuthMap:
    """Range-azimuth map of one CPI.

    :func:`range_doppler` (with optional clutter removal), TDM phase compensation per Doppler bin,
    beamforming per (Doppler, range) cell, and power summed over Doppler.

    ``method="fft"``: :func:`angle_fft` over the uniform row with ``n_angle`` bins; only the visible
    bins are kept (azimuth axis :math:`\\arcsin u`, non-uniform). ``method="bartlett"``:
    :func:`bartlett_spectrum` at elevation 0 on ``azimuths`` (default 181 points over ±90°).
    """
    rd = range_doppler(cube, radar, window_range, window_doppler, clutter_removal, n_range, n_doppler)
    if tdm_compensation:
        rd = tdm_phase_compensation(rd, radar, velocity_axis(radar, rd.shape[0]))
    ranges = range_axis(radar, rd.shape[-1])
    if method == "fft":
        spec = angle_fft(rd[:1], radar, n_fft=n_angle, window=window_angle)
        keep = spec.visible
        power = np.zeros((rd.shape[-1], int(keep.sum())))
        for i in range(0, rd.shape[0], chunk):
            s = angle_fft(rd[i:i + chunk], radar, n_fft=n_angle, window=window_angle).spectrum  # [d, Q, R]
            power += np.sum(np.abs(s[:, keep, :]) ** 2, axis=0).T
        return RangeAzimuthMap(power, ranges, spec.azimuths[keep])
    if method == "bartlett":
        az = np.linspace(-np.pi / 2, np.pi / 2, 181) if azimuths is None else np.asarray(azimuths, float)
        power = np.zeros((rd.shape[-1], az.size))
        for i in range(0, rd.shape[0], chunk):
            snaps = np.moveaxis(virtual_channels(rd[i:i + chunk], 1), 1, -1)  # [d, R, V]
            power += bartlett_spectrum(snaps, radar, az).sum(axis=0)
        return RangeAzimuthMap(power, ranges, az)
    raise ValueError(f"range_azimuth_map: unknown method {method!r}; use 'fft' or 'bartlett'")
