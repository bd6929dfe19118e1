r"""Range-Doppler processing of one CPI.

.. math::
    Y_{i,m,n,k} = \sum_{l} \tilde v_l\, e^{-j2\pi il/L'}
        \sum_{s} \tilde w_s\, x_{l,m,n,s}\, e^{-j2\pi ks/K}
    \quad (\text{Doppler axis fftshift-ed}),
    \qquad P_{i,k} = \sum_{m,n} |Y_{i,m,n,k}|^2 .

With unit-sum windows a point target of amplitude :math:`A` (per channel) gives
:math:`|Y| = A` in its cell and :math:`P = MN A^2` in the non-coherent map; complex white noise
of variance :math:`\sigma^2` gives :math:`E[P] = MN\sigma^2 \sum\tilde w^2 \sum \tilde v^2`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .clutter import remove_static_clutter
from .fast_time import range_axis, range_fft
from .slow_time import doppler_fft, velocity_axis


def check_cube(cube, radar) -> np.ndarray:
    """The cube as an array, after checking it is ``[chirp, tx, rx, sample]`` for ``radar``."""
    x = np.asarray(cube)
    expected = (radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
    if x.shape != expected:
        raise ValueError(
            f"cube has shape {x.shape}; expected [chirp, tx, rx, sample] = {expected} for this RadarConfig"
        )
    return x


def range_doppler(cube, radar, window_range="hann", window_doppler="hann", clutter_removal: bool = False,
                  n_range: int | None = None, n_doppler: int | None = None) -> np.ndarray:
    r"""Complex range-Doppler cube ``[doppler, tx, rx, range]`` of one CPI.

    Range FFT along samples (:func:`range_fft`), optional static clutter removal
    (:func:`remove_static_clutter`, slow-time mean per channel and range bin), Doppler FFT along
    chirps with ``fftshift`` (:func:`doppler_fft`). Axes: :func:`velocity_axis` ``(radar, n_doppler)``
    and :func:`range_axis` ``(radar, n_range)``. Tx stays in physical order; the TDM phase is not
    compensated here (:func:`tdm_phase_compensation`).
    """
    x = check_cube(cube, radar)
    r = range_fft(x, window=window_range, n_fft=n_range, axis=-1)
    if clutter_removal:
        r = remove_static_clutter(r, axis=0)
    return doppler_fft(r, window=window_doppler, n_fft=n_doppler, axis=0)


@dataclass
class RangeDopplerMap:
    """Non-coherent range-Doppler power map of one CPI.

    Attributes
    ----------
    power : ndarray ``[doppler, range]``
        :math:`\\sum_{m,n}|Y|^2` (W, linear; see the module docstring for the scaling).
    ranges : ndarray ``[range]``, m
    velocities : ndarray ``[doppler]``, m/s, radial velocity, positive receding
    """

    power: np.ndarray
    ranges: np.ndarray
    velocities: np.ndarray

    def peak(self) -> tuple[int, int]:
        """``(doppler_index, range_index)`` of the strongest cell."""
        return np.unravel_index(int(np.argmax(self.power)), self.power.shape)


def range_doppler_map(cube, radar, window_range="hann", window_doppler="hann", clutter_removal: bool = False,
                      n_range: int | None = None, n_doppler: int | None = None) -> RangeDopplerMap:
    """:func:`range_doppler`, then power summed over all Tx-Rx channels, with its axes."""
    rd = range_doppler(cube, radar, window_range, window_doppler, clutter_removal, n_range, n_doppler)
    power = np.sum(rd.real.astype(np.float64) ** 2 + rd.imag.astype(np.float64) ** 2, axis=(1, 2))
    return RangeDopplerMap(power, range_axis(radar, rd.shape[-1]), velocity_axis(radar, rd.shape[0]))
