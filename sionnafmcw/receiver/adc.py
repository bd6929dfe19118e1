r"""The ADC in the cube: quantisation and clipping on the DCA1000 export's scale.

The cube is the IF signal in :math:`\sqrt{\mathrm W}` at the receiver input. A board's ADC sees
it through the receiver gain :math:`G` (``RadarConfig.rx_gain``, dB, TI's ``rxGain``) against
its full scale :math:`P_{FS}` (``RadarConfig.adc_full_scale``, W: the power at the ADC input of a
complex tone whose I and Q just reach full scale). The DCA1000 export maps the cube to 16-bit
words with exactly this scale (:class:`AdcScale`):

.. math:: c = 10^{G/20}\,\frac{2^{15}-1}{\sqrt{P_{FS}}}\quad\text{words per }\sqrt{\mathrm W}.

An ADC of :math:`B \le 16` bits (``RadarConfig.adc_bits``) has the same full scale and a step of
:math:`\Delta = 2^{16-B}` words (the 16-bit word's full scale kept, the resolution coarser; the
TI presets stream 16-bit words): I and Q are each rounded to the nearest step and clipped to
:math:`[-2^{B-1}, 2^{B-1}-1]` steps, then divided by :math:`c` again, so the cube stays in
:math:`\sqrt{\mathrm W}`:

.. math:: x_q = \frac{\Delta}{c}\,\mathrm{clip}\!\left(\mathrm{rint}\!\left(\frac{c\,x}{\Delta}\right),
          -2^{B-1}, 2^{B-1}-1\right) \quad\text{(I and Q)}.

With :math:`B = 16` the DCA1000 export of such a cube with the radar's own scale
(:func:`export_scale`) reproduces its words exactly and clips nothing more. Uniform quantisation
adds :math:`\Delta^2/12` per I and per Q (in words², when the signal spans many steps); the
clipped I/Q values are counted (:func:`quantise`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MAX_BITS = 16
MIN_BITS = 2
#: The largest 16-bit word (the DCA1000 export's full scale).
FULL_SCALE_COUNTS = 2 ** 15 - 1


@dataclass(frozen=True)
class AdcScale:
    """Receiver gain and ADC full scale: the scale of the ADC in the cube and of the DCA1000 export
    (:mod:`sionnafmcw.ti.dca1000`, whose module docstring derives it).

    Parameters
    ----------
    rx_gain_db : float
        Receiver gain :math:`G` from the antenna port to the ADC (dB); default 30 dB, the
        ``rxGain`` of the TI presets' ``profileCfg``.
    adc_full_scale_dbm : float
        :math:`P_{FS}` (dBm): power at the ADC input of a full-scale complex tone. Default 0 dBm:
        TI publishes no ADC full scale, but gives the IWR1443's in-band 1-dB compression at the
        receiver input as -23, -35 and -47 dBm at 24, 36 and 48 dB gain (TI E2E forum, "IWR1443
        RF questions"), i.e. +1 dBm after the gain, where the chain's swing ends: this default
        within about 1 dB. With the defaults the receiver noise of the TI presets (-92 dBm per
        sample at 5.2 Msps, 15 dB noise figure) is about 27 counts rms.
    """

    rx_gain_db: float = 30.0
    adc_full_scale_dbm: float = 0.0

    @property
    def counts_per_sqrt_watt(self) -> float:
        r""":math:`10^{G/20} (2^{15}-1) / \sqrt{P_{FS}}` (counts per :math:`\sqrt{\mathrm{W}}`)."""
        full_scale_watt = 10.0 ** ((self.adc_full_scale_dbm - 30.0) / 10.0)
        return 10.0 ** (self.rx_gain_db / 20.0) * FULL_SCALE_COUNTS / np.sqrt(full_scale_watt)

    def to_dict(self) -> dict:
        return {"rx_gain_db": self.rx_gain_db, "adc_full_scale_dbm": self.adc_full_scale_dbm,
                "counts_per_sqrt_watt": self.counts_per_sqrt_watt}


def export_scale(radar):
    """The :class:`AdcScale` of ``radar`` (its ``rx_gain`` and ``adc_full_scale``)."""
    return AdcScale(rx_gain_db=float(radar.rx_gain), adc_full_scale_dbm=10.0 * math.log10(radar.adc_full_scale / 1e-3))


def words_per_sqrt_watt(radar) -> float:
    """:math:`c`, 16-bit words per :math:`\\sqrt{\\mathrm W}` (the DCA1000 export's scale)."""
    return export_scale(radar).counts_per_sqrt_watt


def step(radar) -> float:
    """The ADC step :math:`\\Delta/c` in :math:`\\sqrt{\\mathrm W}`."""
    return 2.0 ** (MAX_BITS - radar.adc_bits) / words_per_sqrt_watt(radar)


def quantise(cube: np.ndarray, radar) -> tuple[np.ndarray, int]:
    """``(quantised cube, clipped I/Q values)`` (module docstring); the cube's dtype is kept."""
    lsb = step(radar)
    top = 2 ** (radar.adc_bits - 1)
    out = np.empty_like(cube)
    clipped = 0
    for part, target in ((cube.real, out.real), (cube.imag, out.imag)):
        codes = np.rint(part.astype(np.float64) / lsb)
        clipped += int(np.count_nonzero((codes > top - 1) | (codes < -top)))
        np.clip(codes, -top, top - 1, out=codes)
        target[...] = codes * lsb
    return out, clipped


__all__ = ["AdcScale", "FULL_SCALE_COUNTS", "MAX_BITS", "MIN_BITS", "export_scale", "quantise", "step",
           "words_per_sqrt_watt"]
