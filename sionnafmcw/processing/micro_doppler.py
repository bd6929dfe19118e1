r"""Velocity over time: strongest-cell Doppler track and the micro-Doppler spectrogram.

Both take a sequence of CPIs (one per frame), frames axis first: an array
``[frame, chirp, tx, rx, sample]`` (NumPy, Zarr or xarray: frames are read one at a time) or any
iterable of ``[chirp, tx, rx, sample]`` cubes.

Doppler track (the reference paper's estimator, :mod:`sionnafmcw.validation.circle_walk`): per CPI the range-Doppler map after
static clutter removal (:func:`range_doppler_map`), optionally restricted to a range gate; the
velocity (and range) of its strongest cell, refined by log-parabolic interpolation
(:func:`interpolate_peak`, circular along Doppler).

Spectrogram: per CPI, range FFT, clutter removal, the range bins inside the gate, then a
short-time FFT over slow time (:class:`scipy.signal.ShortTimeFFT`, unit-sum window, only windows
that lie wholly inside the CPI), power summed over channels and range bins:

.. math::
    S(v_f, t_{n,p}) = \sum_{m,n}\sum_{k\in\text{gate}}
        \Big|\sum_{l} \tilde w_{l - pH}\, y_{l,m,n,k}\, e^{-j2\pi f (l-pH) T_b}\Big|^2,
    \qquad v_f = f\lambda_{mid}/2,

with column time :math:`t_{n,p} = t_n + (pH)\,T_b`, the time of the window centre
(sample :math:`\lfloor W/2\rfloor` of the window, where the periodic Hann window peaks) counted
from the first chirp of the CPI. With ``window_chirps=None`` the window is the whole CPI: one
column per frame at :math:`t_n + \lfloor L/2\rfloor T_b`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import ShortTimeFFT

from .clutter import remove_static_clutter
from .fast_time import range_axis, range_fft
from .peaks import interpolate_peak, uniform_axis_value
from .rdmap import check_cube, range_doppler_map
from .windows import window_weights


def iter_frames(frames):
    """Yield one ``[chirp, tx, rx, sample]`` ndarray per frame (arrays are read frame by frame)."""
    if hasattr(frames, "shape") and hasattr(frames, "__getitem__"):
        for i in range(frames.shape[0]):
            yield np.asarray(frames[i])
    else:
        for cube in frames:
            yield np.asarray(cube)


def _gate_mask(ranges, range_gate):
    if range_gate is None:
        return np.ones(ranges.shape, bool)
    lo, hi = range_gate
    lo = -np.inf if lo is None else lo
    hi = np.inf if hi is None else hi
    mask = (ranges >= lo) & (ranges <= hi)
    if not mask.any():
        raise ValueError(f"range gate {range_gate} m holds no range bin (bins span {ranges[0]:.3f}..{ranges[-1]:.3f} m)")
    return mask


@dataclass
class DopplerTrack:
    """Strongest cell per CPI: ``velocities`` (m/s, + receding), ``ranges`` (m), ``power`` (map units), all ``[frame]``."""

    velocities: np.ndarray
    ranges: np.ndarray
    power: np.ndarray


def doppler_time(frames, radar, clutter_removal: bool = True, interpolate: bool = True, range_gate=None,
                 window_range="hann", window_doppler="hann", n_range: int | None = None,
                 n_doppler: int | None = None) -> DopplerTrack:
    """Velocity of the strongest range-Doppler cell of every CPI (the paper's estimator).

    Parameters
    ----------
    frames : array ``[frame, chirp, tx, rx, sample]`` or iterable of cubes
    clutter_removal : bool
        Subtract the slow-time mean first (removes the static scene, and with it zero velocity).
    interpolate : bool
        Log-parabolic sub-bin refinement in velocity and range.
    range_gate : (min, max) in m, optional
        Only cells inside the gate compete (e.g. skip Tx-Rx leakage near 0 m); either end may be None.
    """
    vel, rng, pw = [], [], []
    for cube in iter_frames(frames):
        rdm = range_doppler_map(cube, radar, window_range, window_doppler, clutter_removal, n_range, n_doppler)
        p = np.where(_gate_mask(rdm.ranges, range_gate)[None, :], rdm.power, -np.inf)
        i, k = np.unravel_index(int(np.argmax(p)), p.shape)
        if interpolate:
            fi = interpolate_peak(rdm.power, (i, k), axis=0, circular=True)
            fk = interpolate_peak(rdm.power, (i, k), axis=1, circular=False)
        else:
            fi, fk = float(i), float(k)
        v = float(uniform_axis_value(rdm.velocities, fi))
        vmax = radar.centre_wavelength / (4.0 * radar.block_interval)
        vel.append((v + vmax) % (2 * vmax) - vmax)
        rng.append(float(uniform_axis_value(rdm.ranges, fk)))
        pw.append(float(rdm.power[i, k]))
    return DopplerTrack(np.asarray(vel), np.asarray(rng), np.asarray(pw))


@dataclass
class MicroDopplerSpectrogram:
    """``power[velocity, time]`` (linear), ``velocities`` (m/s, + receding, increasing), ``times`` (s, increasing)."""

    times: np.ndarray
    velocities: np.ndarray
    power: np.ndarray

    def peak_velocities(self) -> np.ndarray:
        """Velocity of the strongest bin of each column, ``[time]``."""
        return self.velocities[np.argmax(self.power, axis=0)]


def micro_doppler_spectrogram(frames, radar, frame_times, range_gate=None, window_chirps: int | None = None,
                              hop: int | None = None, window="hann", n_fft: int | None = None,
                              clutter_removal: bool = True, window_range="hann") -> MicroDopplerSpectrogram:
    """Micro-Doppler spectrogram: STFT over slow time inside every CPI (see the module docstring).

    Parameters
    ----------
    frames : array ``[frame, chirp, tx, rx, sample]`` or iterable of cubes
    frame_times : array_like ``[frame]``, s (CPI start times)
    range_gate : (min, max) in m, optional; default all range bins
    window_chirps : int, optional
        STFT window length :math:`W` in chirps (TDM blocks); default the whole CPI.
    hop : int, optional
        Hop :math:`H` in chirps; default :math:`W/2`.
    n_fft : int, optional
        FFT size (zero padding), default :math:`W`.
    """
    frame_times = np.asarray(frame_times, dtype=float).reshape(-1)
    L, Tb = radar.num_chirps, radar.block_interval
    W = L if window_chirps is None else int(window_chirps)
    if not 1 <= W <= L:
        raise ValueError(f"window_chirps={W} must be in 1..{L} (chirps per CPI)")
    H = max(1, W // 2) if hop is None else int(hop)
    M = W if n_fft is None else int(n_fft)
    if M < W:
        raise ValueError(f"n_fft={M} is shorter than window_chirps={W}")
    sft = ShortTimeFFT(window_weights(window, W), hop=H, fs=1.0 / Tb, fft_mode="centered", mfft=M)
    # slice p covers chirps [p*H - W//2, p*H - W//2 + W): keep the slices wholly inside [0, L)
    p_first = -(-(W // 2) // H)
    p_last = (L - W + W // 2) // H
    p0, p1 = p_first, p_last + 1
    slice_times = np.arange(p0, p1) * H * Tb
    ranges = range_axis(radar, radar.num_samples)
    gate = _gate_mask(ranges, range_gate)
    times, columns = [], []
    n_frames = 0
    for t_n, cube in zip(frame_times, iter_frames(frames)):
        y = range_fft(check_cube(cube, radar), window=window_range, axis=-1)[..., gate]
        if clutter_removal:
            y = remove_static_clutter(y, axis=0)
        y = y.reshape(L, -1)
        s = sft.stft(y, p0=p0, p1=p1, axis=0)  # [freq, channel*range, slice]
        columns.append(np.sum(np.abs(s) ** 2, axis=1))
        times.append(t_n + slice_times)
        n_frames += 1
    if n_frames != frame_times.size:
        raise ValueError(f"micro_doppler_spectrogram: {frame_times.size} frame times for {n_frames} frames")
    times = np.concatenate(times)
    power = np.concatenate(columns, axis=1)
    order = np.argsort(times, kind="stable")
    velocities = sft.f * radar.centre_wavelength / 2.0
    return MicroDopplerSpectrogram(times[order], velocities, power[:, order])
