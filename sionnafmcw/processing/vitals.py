r"""Breathing and heart rate from the phase of the chest's range bin, one sample per frame.

A chest wall at range :math:`R(t) = R_0 + d(t)` turns the echo of its range bin by
:math:`\phi(t) = 4\pi d(t)/\lambda_{mid}` (:math:`\lambda_{mid}` at the sweep centre, NOTES
section 2): 16 rad for 5 mm of breathing at 77 GHz, so the phase is unwrapped. The estimator:

1. per frame, the range FFT (Hann) of every chirp and channel, averaged over the CPI's chirps (the
   chest hardly moves in a CPI: 5 mm/s x 27 ms = 0.1 mm): :math:`y_{n,c}(k)` for frame :math:`n`,
   channel :math:`c`, range bin :math:`k`;
2. the chest's bin :math:`k^*`: inside ``range_gate``, the bin whose frame-to-frame variation
   :math:`\sum_c\mathrm{var}_n\,y_{n,c}(k)` is largest (static clutter does not vary; the chest does);
3. the channels combined coherently, :math:`z_n = \sum_c w_c^* y_{n,c}(k^*)` with :math:`w_c` the
   principal eigenvector of the channels' covariance over the frames (the chest's array response);
4. static echoes in the same bin (the rest of a still body, a chair) add a constant vector, so
   :math:`z_n` runs on a circle not centred at 0: the circle is fitted (Kasa's algebraic least
   squares) and its centre removed before the angle is taken and unwrapped;
5. the spectrum (linear trend removed, Hann window, zero-padded 16 times) gives the breathing rate as
   the peak in ``breathing_band`` (refined by a parabola through the log-magnitudes); the breathing
   and its second and third harmonics (``harmonics``) are then fitted in time (least squares on
   :math:`\cos, \sin` of :math:`2\pi k f_b t`) and removed, and the heart rate is the residual's
   peak in ``heart_band``.

A chest wall moving alone turns the phase linearly with :math:`d(t)`: no harmonics. They come from
the other scatterers in the chest's range bin (abdomen, arms, a sitting person's thighs), whose
static or slowly swaying echoes make the phase of the sum a nonlinear function of :math:`d`; the
second and third are the strong ones (measured on the ``vital_signs`` scenario: up to the
heartbeat's level), higher ones fall off quickly. The record's frequency resolution is :math:`1/T`
(0.033 Hz for 30 s); a heart rate within about that of a removed harmonic is removed with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fast_time import range_axis, range_fft
from .rdmap import check_cube


@dataclass
class VitalSignsEstimate:
    """``breathing_rate``, ``heart_rate`` (Hz), the chest's ``range_bin`` and ``range`` (m), the unwrapped
    ``phase`` [frame] (rad), its ``frequencies`` (Hz) and ``spectrum`` (magnitude), and the
    ``heart_spectrum`` after the breathing was removed."""

    breathing_rate: float
    heart_rate: float
    range_bin: int
    range: float
    phase: np.ndarray
    frequencies: np.ndarray
    spectrum: np.ndarray
    heart_spectrum: np.ndarray


def chest_signal(frames, radar, range_gate=None):
    """``(z [frame], range bin, range m)``: steps 1-3 of the module docstring."""
    ranges = range_axis(radar, radar.num_samples)
    ys = []
    for i in range(frames.shape[0]):
        cube = check_cube(np.asarray(frames[i]), radar)
        y = range_fft(cube, window="hann", axis=-1).mean(axis=0)          # [tx, rx, bin]
        ys.append(y.reshape(-1, y.shape[-1]))
    y = np.array(ys)                                                      # [frame, channel, bin]
    variation = np.var(y, axis=0).sum(axis=0)
    if range_gate is not None:
        lo, hi = range_gate
        variation = np.where((ranges >= (lo if lo is not None else -np.inf))
                             & (ranges <= (hi if hi is not None else np.inf)), variation, -np.inf)
    k = int(np.argmax(variation))
    x = y[:, :, k]                                                        # [frame, channel]
    xc = x - x.mean(axis=0)
    _, vecs = np.linalg.eigh(xc.conj().T @ xc)
    w = vecs[:, -1]
    return x @ w.conj(), k, float(ranges[k])


def circle_centre(z) -> complex:
    """Kasa's least-squares circle through the points ``z`` (complex): its centre."""
    x, y = z.real, z.imag
    a = np.stack([x, y, np.ones_like(x)], axis=1)
    b = x * x + y * y
    (c1, c2, _), *_ = np.linalg.lstsq(a, b, rcond=None)
    return complex(c1 / 2, c2 / 2)


def _peak(freqs, mag, band):
    sel = np.flatnonzero((freqs >= band[0]) & (freqs <= band[1]))
    i = sel[int(np.argmax(mag[sel]))]
    if 0 < i < len(mag) - 1 and mag[i - 1] > 0 and mag[i + 1] > 0:
        a, b, c = np.log(mag[i - 1]), np.log(mag[i]), np.log(mag[i + 1])
        den = a - 2 * b + c
        off = 0.5 * (a - c) / den if den < 0 else 0.0
        return float(freqs[i] + off * (freqs[1] - freqs[0]))
    return float(freqs[i])


def vital_signs(frames, radar, frame_rate: float, range_gate=None, breathing_band=(0.1, 0.5),
                heart_band=(0.8, 2.0), pad: int = 16, harmonics: int = 3) -> VitalSignsEstimate:
    """Breathing and heart rate of the person in ``frames`` ``[frame, chirp, tx, rx, sample]`` taken at
    ``frame_rate`` (1/s); see the module docstring."""
    z, k, r = chest_signal(frames, radar, range_gate)
    phase = np.unwrap(np.angle(z - circle_centre(z)))
    n = phase.size
    t = np.arange(n) / frame_rate
    detrended = phase - np.polyval(np.polyfit(t, phase, 1), t)
    window = np.hanning(n)
    nfft = pad * n
    freqs = np.fft.rfftfreq(nfft, 1.0 / frame_rate)
    spectrum = np.abs(np.fft.rfft(detrended * window, nfft))
    f_b = _peak(freqs, spectrum, breathing_band)
    basis = [np.ones(n), t]
    for h in range(1, int(harmonics) + 1):
        basis += [np.cos(2 * np.pi * h * f_b * t), np.sin(2 * np.pi * h * f_b * t)]
    basis = np.stack(basis, axis=1)
    coef, *_ = np.linalg.lstsq(basis, phase, rcond=None)
    residual = phase - basis @ coef
    heart_spectrum = np.abs(np.fft.rfft(residual * window, nfft))
    f_h = _peak(freqs, heart_spectrum, heart_band)
    return VitalSignsEstimate(f_b, f_h, k, r, phase, freqs, spectrum, heart_spectrum)


__all__ = ["VitalSignsEstimate", "chest_signal", "circle_centre", "vital_signs"]
