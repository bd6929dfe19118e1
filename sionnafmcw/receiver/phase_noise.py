r"""Oscillator phase noise of an FMCW radar: its PSD, the range correlation, one realisation per CPI.

The PSD. ``RadarConfig.phase_noise`` is a table ``[[offset (Hz), L (dBc/Hz)], ...]`` as data
sheets give it: the single-sideband phase noise :math:`\mathcal L(f)` of the LO at offsets
:math:`f`. Between the points :math:`\mathcal L` is interpolated linearly in
:math:`(\log f, \mathcal L)` (straight lines on the data sheet's log-frequency plot); beyond the
first and the last point the end segments continue. A single point (TI data sheets publish only
:math:`\mathcal L(1\,\mathrm{MHz})`) is extended with -20 dB/decade, the slope of a free-running
oscillator's white frequency noise (Leeson, outside the loop bandwidth) -- an assumption that
overstates the noise inside a PLL's loop bandwidth, where the data sheet's plateau is flat. In the
small-angle regime :math:`\mathcal L(f) = S_\varphi(f)/2` with :math:`S_\varphi` the one-sided
PSD of the phase :math:`\varphi(t)` (rad²/Hz), :func:`phase_psd`.

The range correlation. Tx and Rx share the oscillator (the transmitted chirp is the mixer's LO),
so a contribution with delay :math:`\tau` beats with phase

.. math:: x(t) = x_0(t)\, e^{j(\varphi(t) - \varphi(t - \tau))}

(NOTES section 2: :math:`x = s_{tx}\,\overline{s_{rx}}`). The residual
:math:`\Delta\varphi_\tau = \varphi(t) - \varphi(t-\tau)` is :math:`\varphi` through the filter
:math:`1 - e^{-j2\pi f\tau}`, so its PSD is

.. math:: S_{\Delta}(f) = |1 - e^{-j2\pi f\tau}|^2 S_\varphi(f) = 4\sin^2(\pi f\tau)\, S_\varphi(f),

and the skirt around a carrier of power :math:`P` in a range profile sits, at offset :math:`\nu`,
at :math:`P\cdot 4\sin^2(\pi\nu\tau)\,\mathcal L(|\nu|)` per Hz (two-sided; :func:`skirt_dbc`).
For :math:`\mathcal L \propto f^{-2}` and :math:`f\tau \ll 1` the skirt is flat at
:math:`(2\pi\tau)^2 \mathcal L(f_1) f_1^2`: it rises 6 dB per doubling of the range.

How it is computed (the cost of a few strength vectors, not of a synthesis per contribution).
With :math:`\Delta\varphi \ll 1` (its rms is 0.01-0.03 rad for 77 GHz radars at indoor ranges),
:math:`e^{j\Delta\varphi} \approx 1 + j\Delta\varphi`, and for :math:`\tau` short compared with
the time over which :math:`\varphi` changes within the receiver band,
:math:`\Delta\varphi_\tau(t) \approx \tau\,\dot\varphi(t)`. Then the beat sum becomes

.. math:: x(t) \approx \sum_p x_p(t) + j\,\dot\varphi(t) \sum_p \tau_p\, x_p(t) = x(t) + j\,\dot\varphi(t)\, y(t),

where :math:`y` is the beat sum with every gain multiplied by its delay: one more strength vector
of the same NUFFT plans (:func:`~sionnafmcw.synthesis.nufft.beat_nufft`, ``weights``; without Taylor
terms where every residual phase is below 0.01 rad, an error 40 dB under this term), and
:math:`\dot\varphi` (the LO's frequency noise, rad/s) one realisation per CPI shared by every
contribution and every channel, so contributions at different delays see the same, correlated
noise. Approximations and their bounds:

* first order in :math:`\tau`: the skirt PSD is :math:`(2\pi\nu\tau)^2 S_\varphi` instead of
  :math:`4\sin^2(\pi\nu\tau)S_\varphi`, too high by the factor :math:`(x/\sin x)^2 \approx 1 + x^2/3`,
  :math:`x = \pi\nu\tau`; at the band edge :math:`\nu = F_s/2` and the unambiguous range
  (:math:`\tau = F_s/\mu`), :math:`x = \pi F_s^2/(2\mu)`: 0.55 (+0.45 dB) for the TI presets,
  0.65 for walk-77ghz; 0.02 dB at offsets under 10 % of :math:`F_s` (:func:`first_order_error`);
* small angle: the dropped :math:`-\Delta\varphi^2/2` terms carry a fraction
  :math:`\sigma_{\Delta\varphi}^2/4 < 10^{-3}` of the skirt's power;
* :math:`\tau_p` is taken at the CPI centre (:math:`\tau_0 - \nu_p T_{CPI}/2`): the delay moves by
  :math:`2 v T_{CPI}/c` over a CPI, 0.8 ns of 20 ns at 4.5 m/s and 3 m (skirt 0.3 dB);
* :math:`\dot\varphi` is generated on the uniform grid :math:`n/F_s` over the CPI, so offsets up to
  :math:`F_s/2` either side of each carrier are modelled (sidebands beyond a band edge wrap around
  like any sampled signal; a board's anti-alias filter would remove those); each chirp takes the
  grid samples nearest its ADC instants (a shift below :math:`1/(2F_s)`, which changes nothing in a
  chirp and the correlation between chirps only at offsets near :math:`F_s`).

The IF chain gain of each contribution (:mod:`.if_filter`) is in its gain, so its skirt carries the
gain of its carrier: exact where :math:`H` is flat across the skirt, off by
:math:`|H(f)/H(f_p)|^2` inside the chain's transition bands.

Generation. :math:`\dot\varphi` is a stationary Gaussian process with one-sided PSD
:math:`(2\pi f)^2 S_\varphi(f)`; on :math:`N_g` grid points (the CPI at :math:`F_s`) its spectrum
is drawn bin by bin, :math:`\Phi_k = \sqrt{N_g F_s S(f_k)/2}\,(a_k + jb_k)/\sqrt2` with standard
normal :math:`a_k, b_k` (:math:`0 < k < N_g/2`, DC and Nyquist 0: a constant frequency offset
is no noise), and inverse real FFT (:func:`frequency_noise`). The draws come from the same
generator as the thermal noise, after it, so a seed gives the same cube and switching phase noise
off leaves the thermal noise of a seed unchanged.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

#: Slope (dB/decade) given to a table of one point.
SINGLE_POINT_SLOPE = -20.0


class PhaseNoiseError(ValueError):
    """A phase-noise table that cannot work; the message names the field and the fix."""


def _real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def check_table(table, where: str = "RadarConfig.phase_noise"):
    """Validate a phase-noise table; return it as a sorted list of ``[offset, dBc/Hz]`` floats (None stays None)."""
    if table is None:
        return None
    if not isinstance(table, (list, tuple, np.ndarray)) or len(table) == 0:
        raise PhaseNoiseError(f"{where} must be a non-empty list of [offset (Hz), L (dBc/Hz)] pairs, e.g. "
                              f"[[1e6, -93.0]], got {table!r}")
    rows = []
    for i, row in enumerate(table):
        if (not isinstance(row, (list, tuple, np.ndarray)) or len(row) != 2
                or not all(_real(v) for v in row)):
            raise PhaseNoiseError(f"{where}[{i}] must be a pair [offset (Hz), L (dBc/Hz)], got {row!r}")
        offset, level = float(row[0]), float(row[1])
        if not math.isfinite(offset) or offset <= 0:
            raise PhaseNoiseError(f"{where}[{i}]: the offset must be a positive frequency in Hz, got {row[0]!r}")
        if not math.isfinite(level) or level >= 0:
            raise PhaseNoiseError(f"{where}[{i}]: L must be a negative number of dBc/Hz (a data sheet's "
                                  f"phase noise, e.g. -93), got {row[1]!r}")
        rows.append([offset, level])
    rows.sort()
    offsets = [r[0] for r in rows]
    if len(set(offsets)) != len(offsets):
        raise PhaseNoiseError(f"{where}: an offset appears twice ({offsets}); give each offset once")
    return rows


def ssb_dbc(table, f) -> np.ndarray:
    r""":math:`\mathcal L(f)` (dBc/Hz) at offsets ``f`` (Hz, > 0): log-log interpolation of the table, end
    segments extended (a single point with :data:`SINGLE_POINT_SLOPE`)."""
    rows = np.asarray(table, dtype=float)
    lf = np.log10(np.asarray(f, dtype=float))
    x, y = np.log10(rows[:, 0]), rows[:, 1]
    if len(x) == 1:
        return y[0] + SINGLE_POINT_SLOPE * (lf - x[0])
    out = np.interp(lf, x, y)
    low, high = lf < x[0], lf > x[-1]
    out = np.where(low, y[0] + (y[1] - y[0]) / (x[1] - x[0]) * (lf - x[0]), out)
    out = np.where(high, y[-1] + (y[-1] - y[-2]) / (x[-1] - x[-2]) * (lf - x[-1]), out)
    return out


def phase_psd(table, f) -> np.ndarray:
    r""":math:`S_\varphi(f) = 2\cdot 10^{\mathcal L(f)/10}` (rad²/Hz, one-sided)."""
    return 2.0 * 10.0 ** (ssb_dbc(table, f) / 10.0)


def skirt_dbc(table, offset, tau) -> np.ndarray:
    r"""The closed-form skirt :math:`10\log_{10}(4\sin^2(\pi\nu\tau)) + \mathcal L(|\nu|)` (dBc/Hz, two-sided)
    around a carrier of delay ``tau`` (s) at offsets ``offset`` (Hz, nonzero)."""
    nu = np.abs(np.asarray(offset, dtype=float))
    return 10.0 * np.log10(4.0 * np.sin(np.pi * nu * tau) ** 2) + ssb_dbc(table, nu)


def first_order_error(offset, tau) -> np.ndarray:
    r"""Relative PSD error :math:`(x/\sin x)^2 - 1`, :math:`x = \pi\nu\tau`, of the first-order model."""
    x = np.pi * np.abs(np.asarray(offset, dtype=float)) * tau
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(x > 0, (x / np.sin(x)) ** 2 - 1.0, 0.0)


def grid_length(radar) -> int:
    """Samples of the generation grid: the CPI (last chirp's ADC window included) at :math:`F_s`, FFT-friendly."""
    from scipy.fft import next_fast_len

    span = radar.chirp_start_times().max() + radar.adc_start_time + radar.num_samples / radar.fs
    return next_fast_len(int(math.ceil(span * radar.fs)) + 2, real=True)


def frequency_noise(radar, rng: np.random.Generator) -> np.ndarray:
    r""":math:`\dot\varphi` (rad/s) at every ADC sample of the CPI, ``[chirp, tx, sample]`` (float64; the same
    for every receiver): one realisation (module docstring)."""
    n = grid_length(radar)
    fs = radar.fs
    k = np.arange(1, (n + 1) // 2)           # 0 < k < n/2
    f = k * fs / n
    psd = (2 * np.pi * f) ** 2 * phase_psd(radar.phase_noise, f)
    spectrum = np.zeros(n // 2 + 1, dtype=complex)
    draws = rng.standard_normal((2, k.size))
    spectrum[k] = np.sqrt(n * fs * psd / 2.0) * (draws[0] + 1j * draws[1]) / np.sqrt(2.0)
    trace = np.fft.irfft(spectrum, n)
    first = np.rint((radar.chirp_start_times() + radar.adc_start_time) * fs).astype(np.int64)   # [L, M]
    return trace[first[..., None] + np.arange(radar.num_samples)]


def delay_weights(tau, doppler, radar) -> np.ndarray:
    r""":math:`\tau_p` at the CPI centre, :math:`\tau_0 - (f_D/f_c)\,T_{CPI}/2` (s): the weights of :math:`y`."""
    return tau - doppler / radar.fc * (0.5 * radar.cpi_duration)


def term(frequency, y) -> np.ndarray:
    r"""The phase-noise term :math:`j\dot\varphi(t)\,y(t)`: ``frequency`` ``[chirp, tx, sample]`` (rad/s),
    ``y`` the delay-weighted beat cube ``[chirp, tx, rx, sample]``."""
    return 1j * frequency[:, :, None, :] * y


__all__ = ["PhaseNoiseError", "SINGLE_POINT_SLOPE", "check_table", "delay_weights", "first_order_error",
           "frequency_noise", "grid_length", "phase_psd", "skirt_dbc", "ssb_dbc", "term"]
