r"""The mmWave SDK out-of-box (OOB) demo's on-chip chain: a beat cube in, the device's point cloud out.

:func:`detect` runs, on one frame of the run store's ``iq``, what a TI board running the demo
computes from the ``.cfg``'s processing lines (:class:`~sionnafmcw.ti.processing.TiProcessing`),
per SDK generation; :func:`run_point_clouds` does it for every frame of a run store. The result is
a :class:`~sionnafmcw.ti.points.DetectedPoints` on the device's output grid.

What each step follows
----------------------
Read in the SDK 2.1.0.4 xWR14xx demo (``demo/xwr14xx/mmw``: ``data_path.c``,
``post_processing.c``, ``config_hwa_util.c``, ``main.c``) for ``sdk == 2`` and in the SDK 3.x
xWR18xx/68xx object detection DPC (``objdetdsp``/``objdethwa``, ``cfarcaproc*``, ``aoaproc*``,
``mss_main.c``) for ``sdk == 3`` (design notes, section 8):

1. **ADC codes.** The cube (:math:`\sqrt{\mathrm W}` at the receiver input, tx in physical order)
   becomes the device's 16-bit I/Q words with the radar's own scale,
   :math:`c = 10^{G/20}(2^{15}-1)/\sqrt{P_{FS}}` words per :math:`\sqrt{\mathrm W}`
   (:func:`sionnafmcw.receiver.adc.words_per_sqrt_watt`, the scale of the DCA1000 export:
   rounded, saturated), and the transmitters are put in firing order (``tx_order``): the device's
   virtual antenna :math:`i = q N_{rx} + n` is Rx :math:`n` of the chirp in slot :math:`q`.
2. **Range FFT** of :math:`N_r = 2^{\lceil\log_2 N_s\rceil}` points with the demo's Blackman
   window (``MmwDemo_genWindow``: :math:`w_n = 0.42 - 0.5\cos\phi n + 0.08\cos 2\phi n`,
   :math:`\phi = 2\pi/(N_s-1)`, in Q17, saturated below 1) and the HWA's scaling
   (``srcScale 8``, ``dstScale 0``, ``butterflyScaling 0x3``: the sum divided by 4), rounded and
   saturated to ``int16``. (SDK 3.x runs its range FFT on the accelerator too; its scaling was not
   read, the xWR14xx one is used.)
3. **DC range calibration** (``calibDcRangeSig``): the mean over the first ``numAvg`` chirps of
   the run of range bins ``negBin..posBin`` per virtual antenna is subtracted from every chirp
   (:func:`run_point_clouds` learns it from the run's first frames as the device does after
   ``sensorStart``; :func:`detect` alone learns it from its own frame).
4. **Static clutter removal** (``clutterRemoval 1``): per range bin and virtual antenna, the
   complex mean over the frame's chirps is subtracted.
5. **Doppler FFT** of :math:`N_d = 2^{\lceil\log_2 L\rceil}` points over the :math:`L` chirps of
   each virtual antenna with the demo's Hanning window (Q17, :math:`\phi = 2\pi/(L-1)`; SDK 3.x:
   rectangular at :math:`L \le 4`) and every butterfly stage but the first scaled
   (``(dopplerFftSize-1) >> 1``; ``srcScale 0``, ``dstScale 8``: the sum divided by
   :math:`N_d/2`), rounded, saturated.
6. **Detection matrix** (``uint16``, Doppler unshifted), :math:`N` virtual antennas,
   :math:`N' = 2^{\lceil\log_2 N\rceil}`:
   SDK 2.x (HWA, ``HWAutil_configDopplerFFT``): the Doppler paramset writes the log2-magnitude of
   its 24-bit word, :math:`v_n = \lfloor 2^{11}\log_2(2^8|X_n|)\rfloor` (Q11), and a second
   paramset sums them (a :math:`N'`-point FFT's DC bin, all stages halved, ``srcScale 2``,
   ``dstScale 8``): :math:`D = \lfloor \sum_n v_n / (4N')\rfloor
   \approx 2^9 \tfrac{N}{N'} (\overline{\log_2|X|} + 8)`, log2 in Q9 (the unit TI gives for the
   14xx ``thresholdScale``: :math:`T = 512\,T_{dB}/6`);
   SDK 3.x (DSP, ``mmwavelib_log2Abs16``): :math:`|X| \approx \max(|I|,|Q|) + \tfrac38\min(|I|,|Q|)`,
   :math:`D = \sum_n \lfloor 2^8 \log_2|X_n| \rfloor \gg \log_2 N'` (log2 Q8).
7. **CFAR** (``cfarCfg``) on :math:`D`: for the cell under test the noise sums :math:`S_L, S_R`
   of the ``noiseWin`` cells each side beyond ``guardLen`` guard cells (SDK 3.x's DSP; SDK 2.x's
   HWA is programmed with ``noiseWin >> 1`` in its noise-sample fields, ``HWAutil_configCFAR``,
   which count pairs of cells: TI's own HWA code averages :math:`N` cells by programming
   :math:`N/2` on one side and dividing by :math:`2^{\log_2 N}`, and the same ``cfarCfg`` values,
   ``noiseDivShift`` :math:`\log_2` of one side's cells for CAGO/CASO, serve both the HWA and the
   DSP devices); CA :math:`(S_L+S_R) \gg s`,
   CAGO :math:`\max(S_L,S_R) \gg s`, CASO :math:`\min(S_L,S_R) \gg s` with :math:`s` =
   ``divShift``; a detection when :math:`D > \text{noise} + T` (:meth:`CfarConfig.threshold_counts`).
   Cyclic: the windows wrap; otherwise, where a side falls off the edge, only the other side is
   used (CA: its sum doubled). SDK 2.x: range direction on every Doppler bin
   (``procDirection`` is ignored by the 14xx demo); SDK 3.x (the DSP path of the xWR68xx demo):
   Doppler CFAR on every range bin (always cyclic), then range CFAR on the Doppler bins that had a
   hit; a point passes both; a direction with threshold 0 is skipped.
8. **Peak grouping**: a detection is dropped when a neighbour in the 3x3 kernel of :math:`D`
   (only the range neighbours, or only the Doppler ones, as the flags say; Doppler cyclic, the
   range rows beyond the kept window zero) is strictly greater (``MmwDemo_peakGrouping``). SDK 2.x
   also keeps only range bins ``startRangeIdx..endRangeIdx``.
9. **FOV** (SDK 3.x ``cfarFovCfg``): range bins ``int(min/dr + 0.5)..int(max/dr + 0.5)``, signed
   Doppler bins likewise; ``aoaFovCfg``: :math:`\sin` of the azimuth and elevation limits against
   :math:`W_x, W_z`.
10. **Angle.** SDK 2.x keeps only :math:`D` of the Doppler FFT, so it recomputes the complex
    Doppler spectrum of each detected range bin with every stage scaled (the sum divided by
    :math:`N_d`, ``HWAutil_configDopplerFFTSingleRangeBin``); SDK 3.x uses the stored one.
    (SDK 2.x applies the channel coefficients first, :math:`(xc + 2^{14}) \gg 15`, then the
    Doppler rotation in float cast to int16; SDK 3.x the other way round, both rounded.)
    Doppler compensation of the TDM slots, :math:`e^{-j 2\pi q\, d_s/(M N_d)}` for
    slot :math:`q` and signed Doppler bin :math:`d_s` (``MmwDemo_dopplerCompensation``); the
    ``compRangeBiasAndRxChanPhase`` coefficients (Q15) multiply the virtual antennas; the azimuth
    row is zero-padded to 64 and transformed, :math:`k` the strongest bin, :math:`k_s` signed,
    :math:`W_x = 2k_s/64`. With an elevated transmitter,
    :math:`W_z = -\arg(E_k A_k^*)/\pi` (wrapped to :math:`[-1,1)`), :math:`E` the 64-point FFT of
    the raised row placed at its own azimuth positions (the SDK's
    :math:`\arg(A_k E_k^*)/\pi + 2W_x` for its board, whose raised row starts two elements in).
    The antennas are placed by their positions in the radar's array (the SDK assumes its boards'
    layout; for the boards' own chirp orders the two agree). :math:`R = r\,\Delta r - b`,
    :math:`x = R W_x`, :math:`z = R W_z`, :math:`y = \sqrt{R^2-x^2-z^2}` (SDK 2.x: 0 when
    negative; SDK 3.x: the point is dropped); :math:`v = d_s \Delta v`.
11. **Multi-object beamforming**: from the first peak walk down both flanks of the azimuth
    spectrum; the largest bin outside them gives a second point at the same range and Doppler when
    it exceeds ``threshold`` times the first (``MmwDemo_angleEstimationAzimElev``).
12. **Point limit** (SDK 2.x: 100, 64 with elevation; SDK 3.x: 500) and **output**: SDK 2.x
    ``int16`` x, y, z in Q\ :math:`q` with :math:`q = \lceil\log_2(16/\Delta r)\rceil`
    (``main.c``), rounded half away from zero, ``peakVal`` the azimuth FFT's magnitude at the peak
    times the HWA's gain :data:`AZIMUTH_HWA_GAIN` :math:`= 1/8` (``HWAutil_configAngleEstAzimuth``:
    ``srcScale 8``, no butterfly scaling, ``dstScale 3``), truncated, saturated at
    :data:`HWA_UNSIGNED_MAX` (``angleEstimationAzimElev``: ``objOut.peakVal = maxVal``); SDK 3.x
    float32 x, y, z, v, SNR and noise in 0.1 dB:
    noise :math:`= \lfloor 60\,\bar n/256 \rfloor`, SNR :math:`= \lfloor 60 D/256 \rfloor -` noise
    (:math:`\bar n` the range CFAR's noise estimate). For SDK 2.x the same two figures are computed
    from the log2 Q9 matrix (6 dB per unit of the mean :math:`\log_2`, the noise as the mean of the
    noise cells, in dB of the int16 Doppler spectrum), though the device sends neither.

The HWA's scaling (xWR14xx, SDK 1.x/2.x)
-----------------------------------------
The accelerator computes in 24-bit words. Its input formatter places a 16-bit sample shifted left
by :math:`8 - \mathrm{srcScale}` bits (``srcScale 0``: in the upper two bytes, as TI's HWA
support states), each halved butterfly stage divides by 2, and the output formatter writes a
16-bit word shifted right by ``dstScale`` bits, saturated. This is the only reading under which
every paramset of the demo is free of overflow and gives the documented units: range FFT
:math:`2^0 \cdot 4^{-1} \cdot 2^0` (the ADC words fill the lower 16 bits, the 256-point FFT grows
~25 times at most), Doppler FFT :math:`2^8 (N_d/2)^{-1} 2^{-8}`, the log2 sum
:math:`2^6 N'^{-1} 2^{-8}` on Q11 log2 (TI's documented log2 output) giving the Q9 matrix TI states
for the 14xx threshold, CFAR ``srcScale 8`` (the threshold added in the matrix's own units), and
the azimuth FFT :math:`2^0 \cdot 8 \cdot 2^{-3}`, ``dstScale 3`` taking back the 3 bits of the
8-element sum so a full-scale int16 input just fits the output. (Read the other way round,
:math:`2^{\mathrm{srcScale}}` in and :math:`2^{\mathrm{dstScale}-8}` out, the azimuth paramset
would overflow its 24-bit word for any input above 4096 and the matrix would be Q13.)
On the IWR1443 (errata, ES1.0-ES3.0) the output formatter saturates unsigned 16-bit words as
signed ones: ``peakVal`` and :math:`D` saturate at 32767.

The log2-magnitude unit sits in the core, before the output formatter: it takes the log2 of the
24-bit word, which for the Doppler paramset (``srcScale 0``) is :math:`2^8` times the int16
spectrum, hence the offset of 8 in :math:`D`. Its internal format is not documented (the
16-bit output is Q11); the offset cancels wherever ``divShift`` is the log2 of the cells averaged,
and decides the detection floor where it is not (RadHAR's line, below).

Sources: the SDK 2.1 xWR14xx demo's parameter sets (``config_hwa_util.c``: ``HWAutil_configRangeFFT``,
``HWAutil_configDopplerFFT``, ``HWAutil_configDopplerFFTSingleRangeBin``, ``HWAutil_configCFAR``,
``HWAutil_configAngleEstAzimuth``) and their use (``data_path.c``, ``main.c``:
``MmwDemo_processAngle``; ``post_processing.c``: ``angleEstimationAzimElev``,
``MmwDemo_dopplerComp``); TI's E2E answers "AWR6843: HWA complex multiplication - magnitude squared
mode" (``srcScale 0`` puts 16-bit data in the upper two bytes) and "IWR1443BOOST: CFAR threshold
format clarification" (14xx threshold: log2 in Q9, :math:`T = 512\,T_{dB}/6`; HWA log-mode
threshold added to the noise average); TI's visualizer writing 9 dB as ``cfarCfg ... 768`` for
RadHAR's profile (SDK 1.2, ``1443_3d_original.cfg`` of the TI ROS driver); the IWR1443 errata
(SWRZ074, output formatter saturation); TI's AWR2944 Doppler DPU averaging :math:`N` cells with
``numNoiseSamplesRight = N/2`` and ``nAvgDivFactor`` :math:`\log_2 N` (the CFAR noise fields count
pairs of cells).

The scale chain end to end
--------------------------
From watts at the receiver to ``peakVal``, for RadHAR's ``.cfg`` (:math:`N_s = 240`,
:math:`N_r = 256`, :math:`L = N_d = 16`, :math:`N = 12` virtual antennas, 8 of them in azimuth,
:math:`N' = 16`):

* A tone of amplitude :math:`a` (:math:`\sqrt{\mathrm W}`) at the receiver input becomes
  :math:`A = c\,a` ADC words, :math:`c = 10^{G/20}(2^{15}-1)/\sqrt{P_{FS}}`
  (:mod:`sionnafmcw.receiver.adc`; :math:`G` = 30 dB, :math:`P_{FS}` = 0 dBm: the receiver noise,
  -92.1 dBm at the input at 4.884 Msps and 15 dB noise figure, is :math:`\sigma` = 25.8 words rms).
* Range FFT: :math:`A \sum w_r / 4 = 25.1\,A` at the tone's bin (Blackman, :math:`\sum w_r = 100.4`);
  noise :math:`\sigma\sqrt{\sum w_r^2}/4 = 2.13\,\sigma`.
* Doppler FFT: :math:`\times \sum w_d/(N_d/2) = 0.94` (Hanning, :math:`\sum w_d = 7.5`), noise
  :math:`\times\sqrt{\sum w_d^2}/8 = 0.30`: :math:`|X| = 23.5\,A`, noise :math:`0.63\,\sigma`
  = 16.3 words rms, whose :math:`\log_2` has the mean :math:`\log_2 16.3 - \gamma/(2\ln 2) = 3.6`.
* Detection matrix: :math:`D = 384\,(\overline{\log_2|X|} + 8)` (Q9 times :math:`N/N'` = 0.75).
* CFAR (RadHAR: ``cfarCfg 0 2 8 4 4 0 4000``, CASO): the smaller sum of 8 cells a side, shifted
  right by 4, i.e. half their mean :math:`\bar D_n`: a cell is a detection when
  :math:`D > \bar D_n/2 + 4000`, i.e.
  :math:`\overline{\log_2|X|} > \overline{\log_2|X_n|}/2 + 6.42`: with the noise above,
  :math:`|X| > 2^{8.2} \approx 300` (25 dB over the noise rms; noise alone never passes).
  (The offset 8 cancels when ``divShift`` is the log2 of the cells summed, as in TI's profiles.)
* peakVal: the single-bin Doppler spectrum is :math:`X/2` (all stages scaled), the azimuth FFT
  sums the 8 azimuth antennas and :math:`\times 1/8`: :math:`\mathrm{peakVal} \approx |X|/2` for a
  reflector whose azimuth falls on an angle bin: ~150 at the threshold, :math:`11.8\,A` in general.
  RadHAR's recordings (IWR1443, this ``.cfg``) have peakVal 5th/50th/95th percentiles of
  145/463/1122 for moving points at 1.5-3.2 m and 153/922/1885 over all points
  (``validation/ti_sdk2_scale.py``): the floor where this chain puts it; and none of its 78812
  frames has a point beyond 6 m, behind the walls, where noise alone would have to make it.

Not modelled: the xWR18xx SDK 3.x demo's CFAR on the accelerator (the cyclic flag honoured; the
DSP rules above are used for every SDK 3.x device), SDK 2.x/3.x
xWR16xx syntax (8-value ``cfarCfg``), advanced frames and subframes,
``extendedMaxVelocity``, the HWA's internal 24-bit rounding inside the FFT stages (each FFT is
computed in double precision and rounded once at its output), the quantised chirp slope of the
range axis (:math:`<10^{-4}` relative), and the rangeBias added to the ``cfarFovCfg`` range minimum.
Output axes are the SDK's: :math:`x` right (sionnafmcw's :math:`-y`), :math:`y` boresight
(:math:`+x`), :math:`z` up; :math:`v > 0` receding.
"""

from __future__ import annotations

import math

import numpy as np

from ..constants import SPEED_OF_LIGHT
from ..receiver.adc import words_per_sqrt_watt
from .cfg import board_for_radar
from .cfg_text import TiCfgError
from .points import DetectedPoints
from .processing import MAX_POINTS_ELEVATION_SDK2, TiProcessing, processing_from_cfg, processing_from_lines

#: Azimuth (and elevation) FFT size of the demos.
ANGLE_FFT_SIZE = 64
#: The UART header's ``platform`` word per board device.
PLATFORMS = {"IWR1443": 0xA1443, "AWR1843": 0xA1843, "IWR6843": 0xA6843}

_Q17 = 1 << 17

# ---------------------------------------------------------------------------------------- xWR14xx HWA
#: The HWA's input formatter places a 16-bit sample in its 24-bit word shifted left by
#: :math:`8 - \mathrm{srcScale}` bits (``srcScale 0``: the upper two bytes); the output formatter
#: writes a 16-bit word shifted right by ``dstScale`` bits (module docstring, "The HWA's scaling").
HWA_WORD_BITS = 24
#: ``log2`` of the Doppler paramset's input shift (``srcScale 0``): the HWA's log2-magnitude of the
#: Doppler FFT is taken of the 24-bit word, :math:`2^8` times the int16 Doppler spectrum, so it is
#: :math:`\log_2|X| + 8` (:func:`detection_matrix`).
DOPPLER_LOG2_OFFSET = 8
#: The HWA's log2-magnitude output: unsigned 16-bit in Q11.
HWA_LOG2_Q = 11
#: SDK 2.x: the azimuth FFT's gain from the int16 Doppler samples to ``peakVal``: ``srcScale 8``
#: (no shift in), no butterfly scaling, ``dstScale 3`` (a right shift by 3 out): :math:`1/8`, the
#: bit growth of the 8-element azimuth sum taken back out.
AZIMUTH_HWA_GAIN = 1.0 / 8.0
#: Largest unsigned 16-bit HWA output on the IWR1443 (ES1.0-ES3.0 errata: the output formatter
#: saturates unsigned 16-bit words as signed ones), so ``peakVal`` saturates at 32767.
HWA_UNSIGNED_MAX = 32767


class OobError(ValueError):
    """The chain cannot run on this cube or radar; the message says what to change."""


# ---------------------------------------------------------------------------------------- windows
def blackman_q17(n: int) -> np.ndarray:
    """The demo's Blackman window of ``n`` samples in Q17 (``MmwDemo_genWindow``), as a fraction."""
    phi = 2 * np.pi / (n - 1)
    k = np.arange(n)
    w = np.floor(_Q17 * (0.42 - 0.5 * np.cos(phi * k) + 0.08 * np.cos(2 * phi * k)) + 0.5)
    return np.minimum(w, _Q17 - 1) / _Q17


def hanning_q17(n: int) -> np.ndarray:
    """The demo's Hanning window of ``n`` chirps in Q17 (``MmwDemo_genWindow``), as a fraction."""
    phi = 2 * np.pi / (n - 1)
    w = np.floor(_Q17 * 0.5 * (1 - np.cos(phi * np.arange(n))) + 0.5)
    return np.minimum(w, _Q17 - 1) / _Q17


def _next_pow2(n: int) -> int:
    return 1 << math.ceil(math.log2(max(int(n), 1)))


def _saturate16(x: np.ndarray) -> np.ndarray:
    """Round I and Q to integers and saturate them to int16 (kept complex128)."""
    re = np.clip(np.rint(x.real), -32768, 32767)
    im = np.clip(np.rint(x.imag), -32768, 32767)
    return re + 1j * im


# ---------------------------------------------------------------------------------------- geometry
class _Array:
    """The device's virtual array: slots in firing order, azimuth and elevation rows on a lambda/2 grid."""

    def __init__(self, radar):
        spacing = np.diff(np.sort(radar.rx_positions[:, 1]))
        d = float(np.min(spacing)) if spacing.size else SPEED_OF_LIGHT / radar.fc / 2
        tx = radar.tx_positions[radar.tx_order]              # firing order
        virtual = (tx[:, None, :] + radar.rx_positions[None, :, :]).reshape(-1, 3)
        column = (virtual[:, 1] - virtual[:, 1].min()) / d
        row = (virtual[:, 2] - virtual[:, 2].min()) / d
        if np.any(np.abs(column - np.rint(column)) > 1e-3) or np.any(np.abs(row - np.rint(row)) > 1e-3):
            raise OobError(f"radar {radar.name!r}: the virtual array is not on a half-wavelength grid "
                           "(the SDK's angle FFT needs the TI boards' layout)")
        column, row = np.rint(column).astype(int), np.rint(row).astype(int)
        if np.any(row > 1):
            raise OobError(f"radar {radar.name!r}: virtual elements on more than two rows; the SDK's angle "
                           "estimation has one azimuth row and one raised row")
        self.num_virtual = virtual.shape[0]
        self.azimuth = np.flatnonzero(row == 0)
        self.elevation = np.flatnonzero(row == 1)
        self.azimuth = self.azimuth[np.argsort(column[self.azimuth], kind="stable")]
        self.elevation = self.elevation[np.argsort(column[self.elevation], kind="stable")]
        start = column[self.azimuth].min()
        self.azimuth_column = column[self.azimuth] - start
        self.elevation_column = column[self.elevation] - start
        if len(set(self.azimuth_column.tolist())) != self.azimuth.size:
            raise OobError(f"radar {radar.name!r}: two azimuth virtual elements coincide")
        if self.azimuth_column.max() >= ANGLE_FFT_SIZE or (self.elevation.size and
                                                            self.elevation_column.max() >= ANGLE_FFT_SIZE):
            raise OobError(f"radar {radar.name!r}: the virtual array is wider than the "
                           f"{ANGLE_FFT_SIZE}-point angle FFT")
        self.num_tx = len(radar.tx_order)
        self.num_rx = radar.num_rx


def _platform(radar, sdk: int) -> int:
    """The UART header's platform word: the board's device; xWR14xx for SDK 1.x/2.x; else by band."""
    if sdk == 2:
        return PLATFORMS["IWR1443"]
    try:
        return PLATFORMS.get(board_for_radar(radar).device, 0)
    except TiCfgError:
        return PLATFORMS["IWR6843"] if radar.fc < 70e9 else PLATFORMS["AWR1843"]


# ---------------------------------------------------------------------------------------- 1D / 2D
def range_fft(adc: np.ndarray, rounded: bool = True) -> np.ndarray:
    """Range FFT of ADC words ``[..., sample]`` (module docstring, step 2) -> int16-valued complex
    ``[..., range bin]``; ``rounded=False``: the same spectrum before the output's rounding."""
    n = adc.shape[-1]
    spectrum = np.fft.fft(adc * blackman_q17(n), n=_next_pow2(n), axis=-1) / 4.0
    return _saturate16(spectrum) if rounded else spectrum


def doppler_fft(x: np.ndarray, sdk: int, all_stages_scaled: bool = False, rounded: bool = True) -> np.ndarray:
    """Doppler FFT over axis 0 (chirps) of ``[chirp, ...]`` (step 5) -> ``[Doppler bin, ...]``.

    The detection path scales every butterfly stage but the first (the sum divided by
    :math:`N_d/2`); ``all_stages_scaled`` scales all of them (:math:`N_d`), as the SDK 2.x
    single-range-bin Doppler FFT that feeds the angle estimation (step 10). ``rounded``: the
    int16 output; else the spectrum in the same units before the output's rounding (what the
    HWA's log2-magnitude sees, to :math:`2^{-8}` of an int16 step)."""
    n = x.shape[0]
    size = _next_pow2(n)
    window = np.ones(n) if (sdk == 3 and n <= 4) or n < 2 else hanning_q17(n)
    shape = (n,) + (1,) * (x.ndim - 1)
    divisor = size if all_stages_scaled else max(size / 2, 1)
    spectrum = np.fft.fft(x * window.reshape(shape), n=size, axis=0) / divisor
    return _saturate16(spectrum) if rounded else spectrum


def detection_matrix(spectrum: np.ndarray, sdk: int) -> np.ndarray:
    r"""Detection matrix ``[range, Doppler]`` (uint16) of the Doppler spectrum
    ``[range, Doppler, virtual]`` in int16 units (step 6): SDK 3.x the int16 words, SDK 2.x the
    spectrum before the output's rounding (:func:`doppler_fft` with ``rounded=False``).

    SDK 2.x (HWA): per antenna the Doppler paramset's log2-magnitude of its 24-bit word
    :math:`W_n = 2^8 X_n` (I and Q rounded, saturated at :math:`2^{23}`),
    :math:`v_n = \lfloor 2^{11}\log_2|W_n|\rfloor` (Q11; 0 where :math:`|W_n| < 1`), summed by a
    :math:`N'`-point FFT's DC bin with every stage halved, ``srcScale 2`` (:math:`\times 2^6`) and
    ``dstScale 8`` (:math:`\div 2^8`): :math:`D = \lfloor \sum_n v_n / (4N') \rfloor
    = 2^9\,\tfrac{N}{N'}\,(\overline{\log_2|X|} + 8)` in Q9.
    SDK 3.x (DSP): :math:`D = \sum_n \lfloor 2^8\log_2(\max + \tfrac38\min)\rfloor \gg \log_2 N'`."""
    n = spectrum.shape[-1]
    shift = math.ceil(math.log2(n)) if n > 1 else 0
    i, q = np.abs(spectrum.real), np.abs(spectrum.imag)
    if sdk == 2:
        top = float(1 << (HWA_WORD_BITS - 1))
        scale = float(1 << DOPPLER_LOG2_OFFSET)
        word = np.hypot(np.minimum(np.rint(i * scale), top), np.minimum(np.rint(q * scale), top))
        log2 = np.floor(float(1 << HWA_LOG2_Q) * np.log2(np.maximum(word, 1.0)))
        total = np.floor(log2.sum(axis=-1) / (4 * (1 << shift)))
        return np.clip(total, 0, HWA_UNSIGNED_MAX).astype(np.uint16)
    magnitude = np.maximum(i, q) + 0.375 * np.minimum(i, q)
    log2 = np.floor(256.0 * np.log2(np.maximum(magnitude, 1.0)))
    total = np.floor(log2.sum(axis=-1) / (1 << shift))
    return np.clip(total, 0, 65535).astype(np.uint16)


# ---------------------------------------------------------------------------------------- CFAR
def cfar(values: np.ndarray, config, sdk: int, num_virtual: int, cyclic: bool | None = None):
    """CA/CAGO/CASO CFAR along axis 0 of ``values`` (step 7): ``(hits, noise estimate)``, both the
    shape of ``values``: ``noiseWin`` cells on each side (SDK 3.x's DSP; SDK 2.x's HWA gets
    ``noiseWin >> 1`` in its noise-sample fields, which count pairs of cells, module docstring)."""
    x = np.asarray(values, np.int64)
    n = x.shape[0]
    win = 2 * (config.window >> 1) if sdk == 2 else config.window
    guard, shift = config.guard, config.divide_shift
    cyclic = config.cyclic if cyclic is None else cyclic
    if 2 * (win + guard) >= n:
        raise OobError(f"cfarCfg (line {config.line}): 2*(noiseWin + guardLen) = {2 * (win + guard)} must be "
                       f"less than the {n} bins of its direction")
    if win < 1:
        raise OobError(f"cfarCfg (line {config.line}): noiseWin {config.window} leaves no noise cell")
    kernel_offsets_left = np.arange(guard + 1, guard + win + 1)
    index = np.arange(n)
    if cyclic:
        left = sum(np.take(x, (index - o) % n, axis=0) for o in kernel_offsets_left)
        right = sum(np.take(x, (index + o) % n, axis=0) for o in kernel_offsets_left)
        have_left = have_right = np.ones(n, bool)
    else:
        padded = np.concatenate([np.zeros((guard + win,) + x.shape[1:], np.int64), x,
                                 np.zeros((guard + win,) + x.shape[1:], np.int64)])
        left = sum(padded[guard + win - o: guard + win - o + n] for o in kernel_offsets_left)
        right = sum(padded[guard + win + o: guard + win + o + n] for o in kernel_offsets_left)
        have_left = index - guard - win >= 0
        have_right = index + guard + win <= n - 1
    shape = (n,) + (1,) * (x.ndim - 1)
    have_left, have_right = have_left.reshape(shape), have_right.reshape(shape)
    both = have_left & have_right
    one_side = np.where(have_left, left, right)
    if config.averaging == 0:
        noise = np.where(both, left + right, 2 * one_side) >> shift
    elif config.averaging == 1:
        noise = np.where(both, np.maximum(left, right), one_side) >> shift
    else:
        noise = np.where(both, np.minimum(left, right), one_side) >> shift
    hits = x > noise + config.threshold_counts(sdk, num_virtual)
    return hits, noise


def peak_grouping(det: np.ndarray, ranges: np.ndarray, dopplers: np.ndarray, in_range: bool, in_doppler: bool,
                  min_range: int, max_range: int) -> np.ndarray:
    """Mask of the detections ``(ranges, dopplers)`` that survive the 3x3 local-maximum test (step 8)."""
    if not (in_range or in_doppler):
        return np.ones(ranges.shape, bool)
    n_doppler = det.shape[1]
    centre = det[ranges, dopplers].astype(np.int64)
    keep = np.ones(ranges.shape, bool)
    offsets = [(dr, dd) for dr in (-1, 0, 1) for dd in (-1, 0, 1) if (dr, dd) != (0, 0)
               and ((in_range and in_doppler) or (in_range and dd == 0) or (in_doppler and dr == 0))]
    for dr, dd in offsets:
        r = ranges + dr
        inside = (r >= min_range) & (r <= max_range) & (r >= 0) & (r < det.shape[0])
        value = np.where(inside, det[np.clip(r, 0, det.shape[0] - 1), (dopplers + dd) % n_doppler], 0)
        keep &= ~(value.astype(np.int64) > centre)
    return keep


# ---------------------------------------------------------------------------------------- angle
def _second_peak(magnitude: np.ndarray, first: int) -> int:
    """Index of the largest bin outside the first peak's flanks (``MmwDemo_angleEstimationAzimElev``)."""
    n = magnitude.size
    t, left, k = first, (first + 1) % n, n
    while magnitude[t] >= magnitude[left] and k > 0:
        t, left, k = (t + 1) % n, (left + 1) % n, k - 1
    t, right, k = first, (first - 1) % n, n
    while magnitude[t] >= magnitude[right] and k > 0:
        t, right, k = (t - 1) % n, (right - 1) % n, k - 1
    length = ((right - left) % n) + 1
    candidates = (left + np.arange(length)) % n
    return int(candidates[np.argmax(magnitude[candidates])])


# ---------------------------------------------------------------------------------------- the chain
def _adc_codes(cube: np.ndarray, radar, rounded: bool = True) -> np.ndarray:
    scale = words_per_sqrt_watt(radar)
    fired = np.asarray(cube)[:, radar.tx_order]          # [L, M slots, N, S]
    words = fired.astype(np.complex128) * scale
    return _saturate16(words) if rounded else words


def _phase_q15_sdk2(samples: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
    r"""SDK 2.x ``MmwDemo_rxChanPhaseBiasCompensation``: int16 samples times the Q15 coefficients,
    :math:`(x c + 2^{14}) \gg 15` per I and Q, saturated to int16."""
    product = samples * np.round(coefficients * 32768.0)
    re = np.clip(np.floor((product.real + 0x4000) / 32768.0), -32768, 32767)
    im = np.clip(np.floor((product.imag + 0x4000) / 32768.0), -32768, 32767)
    return re + 1j * im


def _rotate_sdk2(samples: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """SDK 2.x ``MmwDemo_dopplerComp``: the rotation in float, cast to int16 (truncated to zero)."""
    rotated = samples * rotation
    return np.clip(np.trunc(rotated.real), -32768, 32767) + 1j * np.clip(np.trunc(rotated.imag), -32768, 32767)


def dc_range_signature(range_spectra: np.ndarray, processing: TiProcessing) -> np.ndarray | None:
    """The DC range signature the device learns: mean over the chirps of ``range_spectra``
    ``[chirp, slot, rx, range bin]`` (the first ``numAvg`` chirps of the run, at most) of the
    calibrated bins, zero elsewhere; None when ``calibDcRangeSig`` is off."""
    dc = processing.dc_calibration
    if not dc.enabled:
        return None
    chirps = max(1, dc.num_average_chirps // range_spectra.shape[1])
    mean = range_spectra[:chirps].mean(axis=0)
    signature = np.zeros_like(mean)
    bins = list(range(0, dc.positive_bin + 1)) + list(range(mean.shape[-1] + dc.negative_bin, mean.shape[-1]))
    signature[..., bins] = mean[..., bins]
    return signature


def range_spectra(cube: np.ndarray, radar, rounded: bool = True) -> np.ndarray:
    """Range FFT of one frame in the device's units, ``[chirp, slot, rx, range bin]`` (steps 1-2);
    ``rounded=False``: the linear part alone (ADC words and range spectrum without their integer rounding
    and saturation)."""
    return range_fft(_adc_codes(cube, radar, rounded), rounded)


def detect(cube, radar, processing: TiProcessing, *, frame_number: int = 1, time: float = 0.0,
           dc_signature: np.ndarray | None = None) -> DetectedPoints:
    """The OOB demo's detected points of one frame (module docstring).

    Parameters
    ----------
    cube : complex ``[chirp, tx, rx, sample]``
        One frame of the run store's ``iq`` (:math:`\\sqrt{\\mathrm W}`, tx in physical order).
    radar : RadarConfig
        The radar that made it (array layout, ADC scale, chirp timing).
    processing : TiProcessing
        The ``.cfg``'s processing lines (:func:`sionnafmcw.ti.processing.processing_from_cfg`).
    frame_number, time
        The demo's frame counter and the CPI start (s), copied to the result.
    dc_signature : complex ``[slot, rx, range bin]``, optional
        The DC range signature learnt after ``sensorStart`` (:func:`dc_range_signature`); None
        with ``calibDcRangeSig`` on: learnt from this frame.
    """
    sdk = processing.sdk
    cube = np.asarray(cube)
    expected = (radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
    if cube.shape != expected:
        raise OobError(f"cube of shape {cube.shape} does not match the radar's [chirp, tx, rx, sample] {expected}")
    if processing.extended_max_velocity:
        raise OobError("extendedMaxVelocity 1 is not modelled; use 0")
    array = _Array(radar)
    n_virtual = array.num_virtual

    spectra = range_spectra(cube, radar)                     # [L, M, N, R]
    if processing.dc_calibration.enabled:
        signature = dc_range_signature(spectra, processing) if dc_signature is None else dc_signature
        spectra = _saturate16(spectra - signature[None])
    spectra = spectra.reshape(radar.num_chirps, n_virtual, -1)   # virtual i = slot * N + rx
    if processing.clutter_removal:
        spectra = _saturate16(spectra - spectra.mean(axis=0, keepdims=True))
    exact = doppler_fft(spectra, sdk, rounded=False)         # [D, V, R]
    cube_rdv = np.transpose(_saturate16(exact), (2, 0, 1))   # [R, D, V], the int16 spectrum
    # SDK 2.x keeps only the log2 magnitudes of the Doppler FFT; the angle estimation re-runs a
    # single-range-bin Doppler FFT with all stages scaled (``HWAutil_configDopplerFFTSingleRangeBin``)
    angle_rdv = cube_rdv if sdk != 2 else np.transpose(doppler_fft(spectra, sdk, all_stages_scaled=True), (2, 0, 1))
    det = detection_matrix(np.transpose(exact, (2, 0, 1)) if sdk == 2 else cube_rdv, sdk)   # [R, D]
    n_range, n_doppler = det.shape

    range_step = SPEED_OF_LIGHT * radar.fs / (2 * radar.slope * n_range)
    doppler_step = radar.centre_wavelength / (2 * radar.num_tx * radar.chirp_interval * n_doppler)

    # CFAR
    if sdk == 2:
        hits, noise_range = cfar(det, processing.cfar_range, sdk, n_virtual)
        passed = hits
        # the HWA lists the detections Doppler bin by Doppler bin
        dopplers, ranges = np.nonzero(passed.T)
    else:
        # the DSP skips a direction whose threshold is 0 (``cfarcaprocdsp.c``)
        if processing.cfar_doppler.threshold == 0:
            dop_hits = np.ones(det.shape, bool)
        else:
            dop_hits, _ = cfar(det.T, processing.cfar_doppler, sdk, n_virtual, cyclic=True)
            dop_hits = dop_hits.T                            # [R, D]
        columns = np.flatnonzero(dop_hits.any(axis=0))
        rng_hits = np.zeros_like(dop_hits)
        noise_range = np.zeros(det.shape, np.int64)
        if columns.size:
            hits, noise = cfar(det[:, columns], processing.cfar_range, sdk, n_virtual)
            rng_hits[:, columns] = hits if processing.cfar_range.threshold != 0 else True
            noise_range[:, columns] = noise
        passed = dop_hits & rng_hits
        ranges, dopplers = np.nonzero(passed)
    signed = np.where(dopplers >= n_doppler // 2, dopplers - n_doppler, dopplers)

    # peak grouping and the range / Doppler windows
    if sdk == 2:
        pg = processing.peak_grouping
        low, high = pg.start_range_index, pg.end_range_index
        keep = (ranges >= low) & (ranges <= high)
        keep &= peak_grouping(det, ranges, dopplers, pg.in_range, pg.in_doppler, low, high)
    else:
        keep = np.ones(ranges.shape, bool)
        if processing.cfar_range.peak_grouping or processing.cfar_doppler.peak_grouping:
            keep &= peak_grouping(det, ranges, dopplers, processing.cfar_range.peak_grouping,
                                  processing.cfar_doppler.peak_grouping, 0, n_range - 1)
        fr, fd = processing.cfar_fov_range, processing.cfar_fov_doppler
        keep &= (ranges >= int(fr.minimum / range_step + 0.5)) & (ranges <= int(fr.maximum / range_step + 0.5))
        d_low = math.copysign(int(abs(fd.minimum) / doppler_step + 0.5), fd.minimum)
        d_high = math.copysign(int(abs(fd.maximum) / doppler_step + 0.5), fd.maximum)
        keep &= (signed >= d_low) & (signed <= d_high)
    ranges, dopplers, signed = ranges[keep], dopplers[keep], signed[keep]
    limit = processing.max_points
    if sdk == 2 and array.elevation.size:
        limit = min(limit, MAX_POINTS_ELEVATION_SDK2)
    ranges, dopplers, signed = ranges[:limit], dopplers[:limit], signed[:limit]

    # angle estimation
    phase = processing.range_bias_phase.q15(n_virtual)
    slot = np.arange(n_virtual) // radar.num_rx
    bias = processing.range_bias_phase.range_bias
    first = {k: [] for k in ("x", "y", "z", "r", "d", "ds", "peak", "det", "noise")}
    second = {k: [] for k in first}
    for r, d, ds in zip(ranges.tolist(), dopplers.tolist(), signed.tolist()):
        rotation = np.exp(-2j * np.pi * slot * ds / (array.num_tx * n_doppler))
        if sdk == 2:      # channel phase first, then the TDM rotation (MmwDemo_processAngle)
            samples = _rotate_sdk2(_phase_q15_sdk2(angle_rdv[r, d], phase), rotation)
        else:
            samples = _saturate16(_saturate16(angle_rdv[r, d] * rotation) * phase)
        row = np.zeros(ANGLE_FFT_SIZE, complex)
        row[array.azimuth_column] = samples[array.azimuth]
        azimuth = np.fft.fft(row) * (AZIMUTH_HWA_GAIN if sdk == 2 else 1.0)
        magnitude = np.abs(azimuth) if sdk == 2 else np.abs(azimuth) ** 2
        if sdk == 2:
            magnitude = np.minimum(np.floor(magnitude), HWA_UNSIGNED_MAX)
        elevation = None
        if array.elevation.size:
            raised = np.zeros(ANGLE_FFT_SIZE, complex)
            raised[array.elevation_column] = samples[array.elevation]
            elevation = np.fft.fft(raised)
        peaks = [int(np.argmax(magnitude))]
        if processing.multi_object.enabled:
            other = _second_peak(magnitude, peaks[0])
            level = magnitude[peaks[0]] * processing.multi_object.threshold
            if magnitude[other] > (math.floor(level) if sdk == 2 else level):     # SDK 2.x: uint32 cast
                peaks.append(other)
        for target, k in zip((first, second), peaks):
            ks = k - ANGLE_FFT_SIZE if k > ANGLE_FFT_SIZE // 2 - 1 else k
            wx = 2.0 * ks / ANGLE_FFT_SIZE
            wz = 0.0
            if elevation is not None:
                wz = -np.angle(elevation[k] * np.conj(azimuth[k])) / np.pi
                wz = (wz + 1.0) % 2.0 - 1.0
            distance = r * range_step - bias
            x, z = distance * wx, distance * wz
            y2 = distance ** 2 - x ** 2 - z ** 2
            if sdk == 3:
                fov = processing.aoa_fov
                if (y2 <= 0 or not math.sin(math.radians(fov.min_azimuth_deg)) <= wx
                        <= math.sin(math.radians(fov.max_azimuth_deg))
                        or not math.sin(math.radians(fov.min_elevation_deg)) <= wz
                        <= math.sin(math.radians(fov.max_elevation_deg))):
                    continue
            y = math.sqrt(y2) if y2 > 0 else 0.0
            target["x"].append(x), target["y"].append(y), target["z"].append(z)
            target["r"].append(r), target["d"].append(d), target["ds"].append(ds)
            target["peak"].append(magnitude[k] if sdk == 2 else det[r, d])
            target["det"].append(int(det[r, d])), target["noise"].append(int(noise_range[r, d]))
    out = {k: first[k] + second[k] for k in first}      # the demo appends second peaks to the list
    count = len(out["x"])
    if sdk == 2:
        count = min(count, limit)                    # second peaks are appended within the limit
    for key in out:
        out[key] = np.asarray(out[key][:count])

    q = int(math.ceil(math.log2(16.0 / range_step)))
    if sdk == 2:
        grid = float(1 << q)

        def quantise(v):
            v = np.asarray(v, float)
            return (np.trunc(v * grid + np.where(v < 0, -0.5, 0.5)).astype(np.int16) / grid).astype(np.float32)
        x, y, z = quantise(out["x"]), quantise(out["y"]), quantise(out["z"])
        # side info the device does not send: the noise cells' mean (the estimate times 2^divShift
        # over the cells summed) and the cell above it, 6 dB per unit of the mean log2 magnitude
        cfg = processing.cfar_range
        cells = 2 * (cfg.window >> 1) * (2 if cfg.averaging == 0 else 1)
        noise_mean = out["noise"] * float(1 << cfg.divide_shift) / cells
        per_unit = 6.0 / (512.0 * n_virtual / (1 << math.ceil(math.log2(n_virtual))))   # dB per Q9 count
        noise_db = np.round(per_unit * noise_mean - 6.0 * DOPPLER_LOG2_OFFSET, 1).astype(np.float32)
        snr_db = np.round(per_unit * (out["det"] - noise_mean), 1).astype(np.float32)
    else:
        x, y, z = (np.asarray(out[k], np.float32) for k in ("x", "y", "z"))
        noise_tenth = np.floor(60.0 * out["noise"] / 256.0)
        snr_tenth = np.floor(60.0 * out["det"] / 256.0) - noise_tenth
        noise_db = (noise_tenth / 10.0).astype(np.float32)
        snr_db = (snr_tenth / 10.0).astype(np.float32)
    gui = processing.gui_monitor
    azimuth_map = None
    if gui.range_azimuth_heatmap:
        azimuth_map = angle_rdv[:, 0, :][:, array.azimuth].astype(np.complex64)   # SDK 2.x: the single-bin FFT
    return DetectedPoints(
        frame_number=int(frame_number), time=float(time), sdk=sdk, platform=_platform(radar, sdk),
        x=x, y=y, z=z,
        velocity=(np.asarray(out["ds"], float) * doppler_step).astype(np.float32),
        range_index=np.asarray(out["r"], np.uint16), doppler_index=np.asarray(out["ds"], np.int16),
        peak_value=np.minimum(np.asarray(out["peak"], float), 65535).astype(np.uint16),
        snr_db=snr_db, noise_db=noise_db, xyz_q_format=q if sdk == 2 else 0,
        range_step=float(range_step), doppler_step=float(doppler_step),
        range_profile=det[:, 0].copy() if gui.log_mag_range else None,
        noise_profile=det[:, n_doppler // 2].copy() if gui.noise_profile else None,
        azimuth_static_heatmap=azimuth_map,
        range_doppler_heatmap=det.copy() if gui.range_doppler_heatmap else None,
    )


# ---------------------------------------------------------------------------------------- run stores
def run_processing(run, processing=None) -> TiProcessing:
    """The processing of a run: ``processing`` (a :class:`TiProcessing`, or a ``.cfg`` path or
    text), else the processing lines of the ``.cfg`` its radar was read from."""
    if isinstance(processing, TiProcessing):
        return processing
    if processing is not None:
        return processing_from_cfg(processing)
    radar = run.radar
    found = processing_from_lines(radar.ti_processing, f"{run.path}: radar .cfg")
    if found is None:
        raise TiCfgError(f"{run.path}: the run's radar ({radar.name}) did not come from a TI .cfg with "
                         "processing lines; give the demo's .cfg (--cfg FILE)")
    return found


def run_point_clouds(store_path, processing=None, frames=None):
    """Iterator of :class:`DetectedPoints`, one per done frame of a run store (``frames``: indices,
    default all done frames), through :func:`detect`. ``processing``: a :class:`TiProcessing` or a
    ``.cfg`` (path or text); None: the run's own radar ``.cfg`` lines (:func:`run_processing`).
    The frame counter is the frame index + 1 (the demo counts from 1). With ``calibDcRangeSig``
    on, the DC signature is learnt from the run's first frames (its first ``numAvg`` chirps)."""
    from ..store import open_run

    run = open_run(store_path)
    processing = run_processing(run, processing)
    radar = run.radar
    done = run.done_frames
    frames = done if frames is None else np.asarray(frames, int).reshape(-1)
    signature = None
    if processing.dc_calibration.enabled and done.size:
        per_frame = radar.num_chirps * radar.num_tx
        needed = max(1, -(-processing.dc_calibration.num_average_chirps // per_frame))
        learnt = np.concatenate([range_spectra(run.cube(int(f)), radar) for f in done[:needed]])
        signature = dc_range_signature(learnt, processing)
    times = run.frame_times
    for f in frames.tolist():
        yield detect(run.cube(f), radar, processing, frame_number=f + 1, time=float(times[f]),
                     dc_signature=signature)


__all__ = ["ANGLE_FFT_SIZE", "OobError", "blackman_q17", "cfar", "dc_range_signature", "detect",
           "detection_matrix", "doppler_fft", "hanning_q17", "peak_grouping", "range_fft", "range_spectra",
           "run_point_clouds", "run_processing"]
