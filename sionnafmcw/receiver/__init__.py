r"""The receiver between the antenna port and the ADC samples: what a board does to the beat signal.

:func:`~sionnafmcw.synthesis.synthesize` applies, in this order, what ``RadarConfig`` states
(each effect off when its field is None; all off for ``walk-77ghz`` and any custom radar, on for
the TI presets with their data sheets' values, :mod:`.ti`):

1. **IF chain** (``if_filter``, :mod:`.if_filter`): the complex gain :math:`H(f_p)` of every
   contribution at its beat frequency (:func:`filter_echoes`), before the beat sum; then sampling
   aliases what the chain lets through, attenuated as on the board.
2. the beat sum (:mod:`sionnafmcw.synthesis`).
3. **Phase noise** (``phase_noise``, :mod:`.phase_noise`): :math:`j\dot\varphi(t)\,y(t)`, the LO's
   frequency noise times the delay-weighted beat sum (range correlation), one realisation per CPI.
4. **Thermal noise** :math:`k T_0 F` per Hz, through the IF chain: coloured by
   :math:`\sum_k|H(f + kF_s)|^2` along fast time (:func:`shape_noise`).
5. **I/Q imbalance** (``iq_imbalance``, :mod:`.iq_imbalance`): :math:`\mu x + \nu\bar x`.
6. **ADC** (``adc_bits``, ``adc_full_scale``, ``rx_gain``, :mod:`.adc`): quantisation and clipping
   on the DCA1000 export's scale; the clipped I/Q values are counted.
"""

from __future__ import annotations

import copy

import numpy as np

from . import adc, if_filter, iq_imbalance, phase_noise
from ..ti import devices as ti


def beat_frequency(echoes, radar) -> np.ndarray:
    r"""The physical beat frequency of every contribution, ``[M, N, P]`` (Hz): :math:`A_pF_s` of
    :mod:`sionnafmcw.synthesis.phase` (the tone within the first ADC window of its Tx,
    :math:`\mu\tau_a(1+\nu) - F\nu`), not wrapped into the band."""
    nu = echoes.doppler / radar.fc
    slot = radar.tx_slot()[:, None, None]
    tau_a = echoes.tau - nu * (slot * radar.chirp_interval + radar.adc_centre_time)
    return radar.slope * tau_a * (1 + nu) - radar.centre_frequency * nu


def filter_echoes(echoes, radar):
    """``echoes`` with every gain multiplied by :math:`\\overline{H(f_p)}` (the beat carries
    :math:`\\bar a`): the IF chain in steady state (:mod:`.if_filter`), its gain interpolated in a table
    of exact values to within :data:`~.if_filter.TABLE_TOLERANCE` (:func:`~.if_filter.tabulated_response`).
    The same object when the radar has no IF chain; labels and the static block are kept (the static
    block stays bit for bit the same from frame to frame, as the chain's gain depends on nothing else)."""
    if not radar.if_filter or echoes.num_contributions == 0:
        return echoes
    return echoes.map_parts(lambda part: _filtered(part, radar))


def _filtered(echoes, radar):
    """:func:`filter_echoes` of an :class:`~sionnafmcw.Echoes` that is not joined (or one part)."""
    if echoes.num_contributions == 0:
        return echoes
    h = if_filter.tabulated_response(radar.if_filter, beat_frequency(echoes, radar), radar.fs)
    out = copy.copy(echoes)
    out.a = echoes.a * np.conj(h)
    return out


def band_frequencies(radar) -> np.ndarray:
    """The fast-time FFT bins as band frequencies ``k F_s / N_s`` in :math:`[0, F_s)` (Hz): the range axis."""
    return np.arange(radar.num_samples) * radar.fs / radar.num_samples


def shape_noise(noise: np.ndarray, radar) -> np.ndarray:
    r"""White noise ``[..., sample]`` coloured by the IF chain: per chirp, its fast-time spectrum times
    :math:`\sqrt{\sum_k |H(f + kF_s)|^2}` (:func:`.if_filter.noise_gain`), circular in each chirp (the
    same second-order statistics per range bin as a stationary filtered noise). Unchanged without a chain."""
    if not radar.if_filter:
        return noise
    from scipy import fft

    gain = np.sqrt(if_filter.noise_gain(radar.if_filter, band_frequencies(radar), radar.fs))
    spectrum = fft.fft(noise, axis=-1, workers=-1)
    spectrum *= gain.astype(spectrum.real.dtype)
    return fft.ifft(spectrum, axis=-1, workers=-1).astype(noise.dtype)


def noise_power(radar) -> float:
    r"""Thermal noise per complex sample after the IF chain, :math:`k T_0 F B_n` (W), with
    :math:`B_n` the chain's noise bandwidth (:func:`.if_filter.noise_bandwidth`; :math:`F_s` without a chain)."""
    return radar.noise_power * if_filter.noise_bandwidth(radar.if_filter, radar.fs) / radar.fs


def summary(radar) -> dict:
    """The receiver effects of ``radar`` as plain figures (SI units; None where off), for listings."""
    chain = radar.if_filter or []
    highs = [if_filter.corner(s, radar.fs) for s in chain if s["type"] == "highpass"]
    lows = [s for s in chain if s["type"] == "lowpass"]
    return {
        "phase_noise_1mhz_dbc_hz": (None if radar.phase_noise is None
                                    else float(phase_noise.ssb_dbc(radar.phase_noise, 1e6))),
        "highpass_corners_hz": highs or None,
        "lowpass_passband_hz": ([if_filter.centre(s, radar.fs) - if_filter.corner(s, radar.fs) for s in lows][:1]
                                + [if_filter.centre(s, radar.fs) + if_filter.corner(s, radar.fs) for s in lows][:1])
                               or None,
        "adc_bits": radar.adc_bits,
        "iq_imbalance": radar.iq_imbalance,
        "antenna_pattern": radar.antenna_pattern if isinstance(radar.antenna_pattern, str)
        else radar.antenna_pattern.get("name", "measured"),
    }


__all__ = ["adc", "band_frequencies", "beat_frequency", "filter_echoes", "if_filter", "iq_imbalance", "noise_power",
           "phase_noise", "shape_noise", "summary", "ti"]
