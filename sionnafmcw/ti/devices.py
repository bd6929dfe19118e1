r"""The receivers of TI's mmWave devices, from their data sheets: IF chain, ADC, phase noise.

Sources (TI data sheets, section "RF Specification", and their notes):

* AWR1843: SWRS222 (xWR1843), IWR1443: SWRS211 (xWR1443), IWR6843: SWRS219 (xWR6843).
* **IF chain.** "The analog IF stages include high-pass filtering, with two independently
  configurable first-order high-pass corner frequencies": HPF1 175, 235, 350 or 700 kHz, HPF2
  350, 700, 1400 or 2800 kHz (:data:`HPF1_CORNERS`, :data:`HPF2_CORNERS`; the codes 0-3 of
  ``profileCfg``'s ``hpfCornerFreq1``/``hpfCornerFreq2``, mmWaveLink's ``RL_RX_HPF1_175_KHz`` ...).
  "The filtering performed by the digital baseband chain is targeted to provide less than
  ±0.5 dB pass-band ripple/droop and better than 60 dB anti-aliasing attenuation for frequencies
  outside the pass-band." The pass band of the complex-1x output (the presets' ``adcCfg 2 1``) is
  taken as :math:`[0, 0.8F_s]`: the data sheets' IF bandwidth (10 MHz) is 0.8 of the highest
  complex sampling rate (12.5 Msps), and TI's demo visualiser quotes 80 % of
  :math:`cF_s/(2\mu)` as the maximum range. Anything that folds onto the pass band must be 60 dB
  down, so the stop band starts at :math:`F_s` (and, for the image band, at :math:`-0.2F_s`).
  We model this digital filter by the elliptic prototype of least order that meets it, shifted to
  the band centre: :func:`anti_alias` (order 6, 0.5 dB ripple, 60 dB, corner and centre
  :math:`0.4F_s`; :mod:`.if_filter`).
* **ADC.** The presets stream 16-bit complex samples (``adcCfg 2 1``: the words a DCA1000
  capture holds): :data:`ADC_BITS`. Receiver gain: the ``rxGain`` of the demo profiles, 30 dB; ADC
  full scale: 0 dBm (the DCA1000 export's assumption; TI publishes no single figure).
* **Phase noise** at 1 MHz offset (:data:`PHASE_NOISE_1MHZ`): AWR1843 and IWR1443 -95 dBc/Hz at
  76-77 GHz, -93 dBc/Hz at 77-81 GHz; IWR6843 -93 dBc/Hz at 60-64 GHz. Only this one point is
  published; :mod:`.phase_noise` extends it with -20 dB/decade. A chirp that sweeps several
  bands gets the worst of them (:func:`phase_noise_table`).
"""

from __future__ import annotations

#: HPF1 corners (Hz) of codes 0..3 (``hpfCornerFreq1``).
HPF1_CORNERS = (175e3, 235e3, 350e3, 700e3)
#: HPF2 corners (Hz) of codes 0..3 (``hpfCornerFreq2``).
HPF2_CORNERS = (350e3, 700e3, 1.4e6, 2.8e6)
#: Output word length of the presets' ``adcCfg 2 1`` (16 bit, complex 1x).
ADC_BITS = 16
#: ``rxGain`` of the presets' demo profiles (dB).
RX_GAIN_DB = 30.0
#: ADC full scale (W) at the ADC input: 0 dBm, the DCA1000 export's assumption.
ADC_FULL_SCALE = 1e-3
#: Pass band of the complex-1x output as a fraction of the sampling rate (module docstring).
PASSBAND_FS = 0.8
#: Phase noise at 1 MHz offset: device -> ((band start Hz, band stop Hz, dBc/Hz), ...).
PHASE_NOISE_1MHZ = {
    "AWR1843": ((76e9, 77e9, -95.0), (77e9, 81e9, -93.0)),
    "IWR1443": ((76e9, 77e9, -95.0), (77e9, 81e9, -93.0)),
    "IWR6843": ((60e9, 64e9, -93.0),),
}


def hpf_sections(hpf1_code: int = 0, hpf2_code: int = 0) -> list:
    """TI's two first-order high-pass sections for ``profileCfg`` codes ``hpfCornerFreq1``/``hpfCornerFreq2``."""
    for name, code, table in (("hpfCornerFreq1", hpf1_code, HPF1_CORNERS), ("hpfCornerFreq2", hpf2_code, HPF2_CORNERS)):
        if code not in range(len(table)):
            raise ValueError(f"{name} code {code!r} is not a TI high-pass setting; choose 0..3 "
                             f"({', '.join(f'{c / 1e3:g} kHz' for c in table)})")
    return [{"type": "highpass", "kind": "butter", "order": 1, "corner": HPF1_CORNERS[hpf1_code], "label": "HPF1"},
            {"type": "highpass", "kind": "butter", "order": 1, "corner": HPF2_CORNERS[hpf2_code], "label": "HPF2"}]


def anti_alias() -> dict:
    """The decimation filter of the complex-1x output as an elliptic section (module docstring)."""
    half = PASSBAND_FS / 2
    return {"type": "lowpass", "kind": "ellip", "order": 6, "corner_fs": half, "centre_fs": half, "ripple": 0.5,
            "attenuation": 60.0, "label": "anti-alias (complex 1x)"}


def if_chain(hpf1_code: int = 0, hpf2_code: int = 0) -> list:
    """A TI device's IF chain: the two high-pass sections and the anti-alias filter."""
    return hpf_sections(hpf1_code, hpf2_code) + [anti_alias()]


def hpf_codes(chain) -> tuple[int, int]:
    """``(hpfCornerFreq1, hpfCornerFreq2)`` of a chain holding TI's two high-pass sections (as
    :func:`hpf_sections` builds them); ``(0, 0)`` for a chain without high-pass sections. Raises
    ValueError naming the corner when a chain has other high-pass sections."""
    highs = [s for s in chain or () if s["type"] == "highpass"]
    if not highs:
        return 0, 0
    corners = [s.get("corner") for s in highs]
    ok = (len(highs) == 2 and all(s["kind"] == "butter" and s["order"] == 1 for s in highs)
          and corners[0] in HPF1_CORNERS and corners[1] in HPF2_CORNERS)
    if not ok:
        raise ValueError(f"the high-pass sections {highs} are not TI's HPF1/HPF2 pair (first-order corners "
                         f"{', '.join(f'{c / 1e3:g}' for c in HPF1_CORNERS)} kHz and "
                         f"{', '.join(f'{c / 1e3:g}' for c in HPF2_CORNERS)} kHz)")
    return HPF1_CORNERS.index(corners[0]), HPF2_CORNERS.index(corners[1])


def phase_noise_table(device: str, f_start: float, f_stop: float) -> list:
    """``[[1e6, L]]`` with the worst data-sheet value over the bands the sweep ``f_start..f_stop`` (Hz) touches."""
    bands = PHASE_NOISE_1MHZ[device]
    levels = [level for lo, hi, level in bands if f_start < hi and f_stop > lo]
    if not levels:
        raise ValueError(f"{device}: the sweep {f_start / 1e9:g}-{f_stop / 1e9:g} GHz lies outside the data sheet's "
                         f"bands {[(lo / 1e9, hi / 1e9) for lo, hi, _ in bands]} GHz")
    return [[1e6, max(levels)]]


__all__ = ["ADC_BITS", "ADC_FULL_SCALE", "HPF1_CORNERS", "HPF2_CORNERS", "PASSBAND_FS", "PHASE_NOISE_1MHZ",
           "RX_GAIN_DB", "anti_alias", "hpf_codes", "hpf_sections", "if_chain", "phase_noise_table"]
