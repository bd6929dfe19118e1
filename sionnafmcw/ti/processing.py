r"""The processing commands of a TI ``.cfg``: what the out-of-box (OOB) demo does with the cube.

:class:`TiProcessing` is the typed, frozen form of the lines that configure the demo's on-chip
chain (:mod:`sionnafmcw.ti.oob`); :func:`processing_from_cfg` reads it from a ``.cfg`` (path or
text), and :func:`sionnafmcw.ti.cfg.parse_ti_cfg` exposes it as ``.processing`` next to the RF
part.

Two generations of syntax
-------------------------
The mmWave SDK changed the commands between generations:

========================  ====================================  =============================================
command                   SDK 1.x/2.x (xWR14xx demo)            SDK 3.x (xWR18xx/68xx demo, per subframe)
========================  ====================================  =============================================
``guiMonitor``            6 values: ``detObj logMagRange        7: ``subFrame detObj logMagRange noiseProf
                          noiseProf rangeAzimuth rangeDoppler   rangeAzimuth rangeDoppler stats``
                          stats``
``cfarCfg``               7: ``procDir mode noiseWin guardLen   9: ``subFrame procDir mode noiseWin guardLen
                          divShift cyclic thresholdScale``      divShift cyclic thresholdDb peakGrouping``
                          (range direction only; threshold in
                          the detection matrix's log2 Q9)
``peakGrouping``          5: ``scheme rangeEn dopplerEn         (last value of each ``cfarCfg``)
                          startRangeIdx endRangeIdx``
``multiObjBeamForming``   2: ``enabled threshold``              3: ``subFrame enabled threshold``
``clutterRemoval``        1: ``enabled``                        2: ``subFrame enabled``
``calibDcRangeSig``       4: ``enabled negBin posBin numAvg``   5: ``subFrame enabled negBin posBin numAvg``
``aoaFovCfg``             (none)                                5: ``subFrame minAz maxAz minEl maxEl`` (deg)
``cfarFovCfg``            (none)                                4: ``subFrame procDir min max`` (m, m/s)
``extendedMaxVelocity``   (none)                                2: ``subFrame enabled``
``compRangeBias...``      ``rangeBias`` (m), then Re Im pairs    the same
                          of the virtual antennas' phase
                          coefficients, Tx-major
========================  ====================================  =============================================

The generation is decided from the syntax: the first processing line whose argument count (or
whose very existence: ``peakGrouping`` is SDK 1.x/2.x only, ``aoaFovCfg``, ``cfarFovCfg`` and
``extendedMaxVelocity`` SDK 3.x only) belongs to one generation fixes it, and every later line
must agree; a line of the other generation is an error naming both lines. Subframe indices must
be ``-1`` (legacy frame: ``dfeDataOutputMode 1``, the only frame mode the simulator has).
The argument counts are those of the demos' CLI handlers (SDK 2.1.0.4 ``demo/xwr14xx/mmw/mmw_cli.c``
and SDK 3.x ``demo/xwr18xx/mmw/mss/mmw_cli.c``, which reject any other count).

Lines that configure monitoring, calibration measurement, low power or the LVDS output
(:data:`NON_CHAIN_COMMANDS`) do not change the detected points and are only listed.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .cfg_text import TiCfgError, commands, text_and_source
from .points import GuiMonitor

#: Commands that configure the OOB demo's detection chain (read into :class:`TiProcessing`).
CHAIN_COMMANDS = ("guiMonitor", "cfarCfg", "peakGrouping", "multiObjBeamForming", "clutterRemoval",
                  "calibDcRangeSig", "aoaFovCfg", "cfarFovCfg", "extendedMaxVelocity",
                  "compRangeBiasAndRxChanPhase")
#: Commands of TI's .cfg files that neither change the RF signal nor the detected points (monitors,
#: calibration measurement, LVDS streaming, power modes, tracker/people-counting lab settings).
NON_CHAIN_COMMANDS = (
    "lvdsStreamCfg", "measureRangeBiasAndRxChanPhase", "CQRxSatMonitor", "CQSigImgMonitor", "analogMonitor",
    "calibData", "nearFieldCfg", "rangeLimitCfg", "lowPower", "idlePowerCycle", "staticBoundaryBox",
    "boundaryBox", "sensorPosition", "gatingParam", "stateParam", "allocationParam", "maxAcceleration",
    "trackingCfg", "presenceBoundaryBox", "fovCfg", "compressionCfg", "dbscanCfg", "clusterCfg",
)

#: Argument counts per generation (2: SDK 1.x/2.x xWR14xx; 3: SDK 3.x).
_COUNTS = {
    "guiMonitor": {2: 6, 3: 7},
    "cfarCfg": {2: 7, 3: 9},
    "peakGrouping": {2: 5},
    "multiObjBeamForming": {2: 2, 3: 3},
    "clutterRemoval": {2: 1, 3: 2},
    "calibDcRangeSig": {2: 4, 3: 5},
    "aoaFovCfg": {3: 5},
    "cfarFovCfg": {3: 4},
    "extendedMaxVelocity": {3: 2},
}
_SDK_NAME = {2: "SDK 1.x/2.x (xWR14xx)", 3: "SDK 3.x (xWR18xx/68xx)"}

#: The demos' point limits: SDK 2.x xWR14xx ``MMW_MAX_OBJ_OUT`` (100; 64 when an elevation Tx is
#: used, ``MMW_MAX_OBJ_ELEVATION`` of ``post_processing.c``), SDK 3.x ``DPIF`` 500.
MAX_POINTS = {2: 100, 3: 500}
MAX_POINTS_ELEVATION_SDK2 = 64


@dataclass(frozen=True)
class CfarConfig:
    r"""One ``cfarCfg`` line: cell-averaging CFAR along one direction of the detection matrix.

    ``direction`` 0 range, 1 Doppler; ``averaging`` 0 CA, 1 CAGO (greater of the two sides),
    2 CASO (smaller); ``window`` noise cells and ``guard`` guard cells on each side;
    ``divide_shift`` the right shift of the noise sum; ``cyclic`` wrap at the edges;
    ``threshold``: SDK 3.x dB, SDK 1.x/2.x the raw value in the detection matrix's units (log2 in
    Q9 of the antennas' mean times :math:`N/N'`, :func:`sionnafmcw.ti.oob.detection_matrix`);
    ``peak_grouping`` (SDK 3.x) keep only local maxima in this direction.
    """

    direction: int
    averaging: int
    window: int
    guard: int
    divide_shift: int
    cyclic: bool
    threshold: float
    peak_grouping: bool = False
    line: int = 0

    def threshold_counts(self, sdk: int, num_virtual: int) -> int:
        r"""The threshold in detection-matrix units.

        SDK 3.x (``mss_main.c``): :math:`T = T_{dB}\,\frac{256}{6}\,\frac{N}{N'}` with :math:`N`
        virtual antennas and :math:`N' = 2^{\lceil\log_2 N\rceil}` (the matrix is
        :math:`\sum_n \log_2|X_n|` in Q8 shifted right by :math:`\log_2 N'`, and
        :math:`20\log_{10} 2 \approx 6` dB per unit of :math:`\log_2`), truncated to an integer.
        SDK 1.x/2.x: the ``.cfg``'s raw value, added by the accelerator's CFAR in the matrix's
        own units (log2 Q9; TI: :math:`T = 512\,T_{dB}/6`, the visualizer's 768 for 9 dB).
        """
        if sdk == 2:
            return int(self.threshold)
        n_pad = 1 << math.ceil(math.log2(num_virtual))
        return int(self.threshold * 256.0 / 6.0 * num_virtual / n_pad)


@dataclass(frozen=True)
class PeakGrouping:
    """SDK 1.x/2.x ``peakGrouping``: ``scheme`` (1: detection-matrix local maximum), grouping
    along range / Doppler, and the range-bin window ``[start_range_index, end_range_index]`` of
    the detections kept (applied even without grouping, ``post_processing.c``)."""

    scheme: int = 1
    in_range: bool = True
    in_doppler: bool = True
    start_range_index: int = 1
    end_range_index: int = 65535
    line: int = 0


@dataclass(frozen=True)
class MultiObjBeamForming:
    """``multiObjBeamForming``: a second point at the same range and Doppler when the second
    azimuth peak exceeds ``threshold`` times the first."""

    enabled: bool = False
    threshold: float = 0.5
    line: int = 0


@dataclass(frozen=True)
class DcRangeCalibration:
    """``calibDcRangeSig``: during the first ``num_average_chirps`` chirps of the run the demo
    averages the range FFT of bins ``negative_bin..positive_bin`` (negative bins counted from the
    end) per virtual antenna and subtracts that mean from then on."""

    enabled: bool = False
    negative_bin: int = -5
    positive_bin: int = 8
    num_average_chirps: int = 256
    line: int = 0


@dataclass(frozen=True)
class AoaFov:
    """SDK 3.x ``aoaFovCfg``: azimuth and elevation limits (degrees) of the points kept."""

    min_azimuth_deg: float = -90.0
    max_azimuth_deg: float = 90.0
    min_elevation_deg: float = -90.0
    max_elevation_deg: float = 90.0
    line: int = 0


@dataclass(frozen=True)
class CfarFov:
    """SDK 3.x ``cfarFovCfg``: the detections kept along one direction (range m, Doppler m/s)."""

    direction: int
    minimum: float
    maximum: float
    line: int = 0


@dataclass(frozen=True)
class RangeBiasAndPhase:
    r"""``compRangeBiasAndRxChanPhase``: ``range_bias`` (m) subtracted from every range and the
    per-virtual-antenna phase coefficients (Tx-major, in chirp order), which the demo stores as
    Q15 ``int16`` pairs (:math:`\mathrm{round}(v\,2^{15})`, saturated to 32767)."""

    range_bias: float = 0.0
    coefficients: tuple = ()
    line: int = 0

    def q15(self, count: int) -> np.ndarray:
        """The coefficients of ``count`` virtual antennas as complex numbers on the Q15 grid
        (1 for antennas the line does not cover)."""
        out = np.ones(count, complex)
        values = np.asarray(self.coefficients, float).reshape(-1, 2)[:count]
        q = np.clip(np.round(values * 32768.0), -32768, 32767) / 32768.0
        out[:q.shape[0]] = q[:, 0] + 1j * q[:, 1]
        return out


@dataclass(frozen=True)
class TiProcessing:
    """The OOB demo's processing configuration of one ``.cfg`` (see the module docstring).

    ``sdk`` is the generation of the syntax (2 for SDK 1.x/2.x, 3 for SDK 3.x), which fixes the
    chain that :func:`sionnafmcw.ti.oob.detect` runs. ``cfar_range`` / ``cfar_doppler`` are the
    ``cfarCfg`` lines (SDK 1.x/2.x has the range one only); ``peak_grouping`` is SDK 1.x/2.x's
    line (SDK 3.x: the flags of the ``cfarCfg`` lines); ``cfar_fov_*`` and ``aoa_fov`` are SDK
    3.x's; ``max_points`` the demo's point limit; ``lines`` the processing lines as written
    (kept by the radar read from the ``.cfg`` so that a run store can rebuild this).
    """

    sdk: int
    gui_monitor: GuiMonitor
    cfar_range: CfarConfig
    cfar_doppler: CfarConfig | None = None
    peak_grouping: PeakGrouping | None = None
    multi_object: MultiObjBeamForming = MultiObjBeamForming()
    clutter_removal: bool = False
    dc_calibration: DcRangeCalibration = DcRangeCalibration()
    aoa_fov: AoaFov = AoaFov()
    cfar_fov_range: CfarFov | None = None
    cfar_fov_doppler: CfarFov | None = None
    range_bias_phase: RangeBiasAndPhase = RangeBiasAndPhase()
    extended_max_velocity: bool = False
    max_points: int = 500
    lines: tuple = field(default=(), compare=False)
    source: str = field(default="<cfg text>", compare=False)

    def replace(self, **changes) -> "TiProcessing":
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)


# ---------------------------------------------------------------------------------------- parsing
def _flag(value: float, where: str, name: str) -> bool:
    if value not in (0, 1):
        raise TiCfgError(f"{where}: {name} must be 0 or 1, got {value:g}")
    return bool(value)


def processing_lines(text: str):
    """``[(line number, command, [arguments])]`` of the chain commands in ``text``."""
    return [(n, c, a) for n, c, a, _ in commands(text) if c in CHAIN_COMMANDS]


def parse_processing(lines, source: str = "<cfg text>") -> TiProcessing | None:
    """A :class:`TiProcessing` from ``[(line number, command, [arguments])]`` (the chain commands
    of one ``.cfg``); None when there are none. Raises :class:`TiCfgError` naming the line."""
    lines = list(lines)
    if not lines:
        return None
    sdk = None
    sdk_line = None
    values = {}
    for number, command, args in lines:
        where = f"{source}, line {number}: {command}"
        counts = _COUNTS.get(command)
        if counts is not None:
            generation = [g for g, n in counts.items() if n == len(args)]
            if not generation:
                expected = " or ".join(f"{n} ({_SDK_NAME[g]})" for g, n in counts.items())
                raise TiCfgError(f"{where} takes {expected} arguments, got {len(args)}")
            if sdk is None:
                sdk, sdk_line = generation[0], (number, command)
            elif generation[0] != sdk:
                raise TiCfgError(f"{where} is {_SDK_NAME[generation[0]]} syntax, but line {sdk_line[0]} "
                                 f"({sdk_line[1]}) is {_SDK_NAME[sdk]} syntax; write every processing "
                                 f"line in one generation's syntax")
        try:
            numbers = [float(a) for a in args]
        except ValueError:
            raise TiCfgError(f"{where}: arguments must be numbers, got {' '.join(args)!r}") from None
        if sdk == 3 and counts is not None and 3 in counts:
            if numbers[0] != -1:
                raise TiCfgError(f"{where}: subframe {numbers[0]:g} is for advanced frames; the simulator runs "
                                 "legacy frames (dfeDataOutputMode 1): use -1")
            numbers = numbers[1:]
        values.setdefault(command, []).append((number, where, numbers))
    if sdk is None:
        number = lines[0][0]
        raise TiCfgError(f"{source}, line {number}: compRangeBiasAndRxChanPhase alone does not say the SDK "
                         "generation; add the demo's guiMonitor and cfarCfg lines")

    def one(command, required=True):
        entries = values.get(command, [])
        if not entries:
            if required:
                example = {2: {"guiMonitor": "guiMonitor 1 0 0 0 0 0", "cfarCfg": "cfarCfg 0 2 8 4 3 0 1280",
                               "peakGrouping": "peakGrouping 1 1 1 1 229"},
                           3: {"guiMonitor": "guiMonitor -1 1 1 0 0 0 1",
                               "cfarCfg": "cfarCfg -1 0 2 8 4 3 0 15 1",
                               "aoaFovCfg": "aoaFovCfg -1 -90 90 -90 90",
                               "cfarFovCfg": "cfarFovCfg -1 0 0 8.92"}}[sdk].get(command, command)
                raise TiCfgError(f"{source}: no {command} line; the {_SDK_NAME[sdk]} demo needs one "
                                 f"(e.g. '{example}')")
            return None
        if len(entries) > 1 and command not in ("cfarCfg", "cfarFovCfg"):
            raise TiCfgError(f"{entries[1][1]}: a second {command} line (line {entries[0][0]} is the first); keep one")
        return entries[0]

    number, where, v = one("guiMonitor")
    for i, name in enumerate(("detected objects", "log magnitude range", "noise profile", "range azimuth heat map",
                              "range Doppler heat map", "stats")):
        if i and v[i] not in (0, 1):
            raise TiCfgError(f"{where}: {name} must be 0 or 1, got {v[i]:g}")
    if v[0] not in ((0, 1) if sdk == 2 else (0, 1, 2)):
        raise TiCfgError(f"{where}: detected objects must be {'0 or 1' if sdk == 2 else '0, 1 or 2'}, got {v[0]:g}")
    gui = GuiMonitor(int(v[0]), *(bool(x) for x in v[1:6]))

    cfar = {}
    for number, where, v in values.get("cfarCfg", []):
        if sdk == 2:
            direction, (mode, win, guard, shift, cyclic, threshold), grouping = 0, v[1:], False
        else:
            direction, (mode, win, guard, shift, cyclic, threshold, grouping) = v[0], v[1:]
        if direction not in (0, 1):
            raise TiCfgError(f"{where}: procDirection must be 0 (range) or 1 (Doppler), got {direction:g}")
        if mode not in (0, 1, 2):
            raise TiCfgError(f"{where}: averageMode must be 0 (CA), 1 (CAGO) or 2 (CASO), got {mode:g}")
        for name, value in (("noiseWin", win), ("guardLen", guard), ("divShift", shift)):
            if value < 0 or value != int(value) or value > 255:
                raise TiCfgError(f"{where}: {name} must be an integer 0..255, got {value:g}")
        if win < 1:
            raise TiCfgError(f"{where}: noiseWin must be >= 1, got {win:g}")
        if sdk == 3 and not 0 <= threshold <= 100:
            raise TiCfgError(f"{where}: threshold must be 0..100 dB, got {threshold:g}")
        if sdk == 2 and not 0 <= threshold <= 65535:
            raise TiCfgError(f"{where}: thresholdScale must be 0..65535 (log2 Q9), got {threshold:g}")
        key = int(direction)
        if key in cfar:
            raise TiCfgError(f"{where}: a second cfarCfg for the {('range', 'Doppler')[key]} direction "
                             f"(line {cfar[key].line} is the first)")
        cfar[key] = CfarConfig(key, int(mode), int(win), int(guard), int(shift),
                               _flag(cyclic, where, "cyclicMode"), float(threshold),
                               _flag(grouping, where, "peakGrouping") if sdk == 3 else False, number)
    if 0 not in cfar:
        example = "cfarCfg 0 2 8 4 3 0 1280" if sdk == 2 else "cfarCfg -1 0 2 8 4 3 0 15 1"
        raise TiCfgError(f"{source}: no cfarCfg for the range direction; add one (e.g. '{example}')")
    if sdk == 3 and 1 not in cfar:
        raise TiCfgError(f"{source}: no cfarCfg for the Doppler direction; the SDK 3.x demo needs both "
                         "(e.g. 'cfarCfg -1 1 0 4 2 3 1 15 1')")

    grouping = None
    if sdk == 2:
        number, where, v = one("peakGrouping")
        scheme, in_range, in_doppler, start, end = v
        if scheme not in (1, 2):
            raise TiCfgError(f"{where}: scheme must be 1 (detection matrix) or 2 (CFAR peaks), got {scheme:g}")
        if scheme == 2:
            raise TiCfgError(f"{where}: scheme 2 (CFAR-peak based) is not modelled; the xWR14xx demo supports 1")
        grouping = PeakGrouping(int(scheme), _flag(in_range, where, "rangeDirEn"),
                                _flag(in_doppler, where, "dopplerDirEn"), int(start), int(end), number)

    entry = one("multiObjBeamForming", required=False)
    multi = MultiObjBeamForming()
    if entry:
        number, where, (enabled, threshold) = entry
        if not 0 <= threshold <= 1:
            raise TiCfgError(f"{where}: threshold must be 0..1 (a fraction of the first peak), got {threshold:g}")
        multi = MultiObjBeamForming(_flag(enabled, where, "enabled"), float(threshold), number)

    entry = one("clutterRemoval", required=False)
    clutter = bool(entry and _flag(entry[2][0], entry[1], "enabled"))

    entry = one("calibDcRangeSig", required=False)
    dc = DcRangeCalibration()
    if entry:
        number, where, (enabled, negative, positive, average) = entry
        if negative > 0 or positive < 0:
            raise TiCfgError(f"{where}: negativeBinIdx must be <= 0 and positiveBinIdx >= 0, "
                             f"got {negative:g} {positive:g}")
        if average < 1 or average != int(average) or (int(average) & (int(average) - 1)):
            raise TiCfgError(f"{where}: numAvg must be a power of two, got {average:g}")
        dc = DcRangeCalibration(_flag(enabled, where, "enabled"), int(negative), int(positive), int(average), number)

    aoa = AoaFov()
    fov = {}
    extended = False
    if sdk == 3:
        number, where, v = one("aoaFovCfg")
        if not (-90 <= v[0] < v[1] <= 90 and -90 <= v[2] < v[3] <= 90):
            raise TiCfgError(f"{where}: need -90 <= min < max <= 90 degrees for azimuth and elevation, "
                             f"got {' '.join(f'{x:g}' for x in v)}")
        aoa = AoaFov(*v, line=number)
        for number, where, (direction, low, high) in values.get("cfarFovCfg", []):
            if direction not in (0, 1):
                raise TiCfgError(f"{where}: procDirection must be 0 (range) or 1 (Doppler), got {direction:g}")
            if int(direction) in fov:
                raise TiCfgError(f"{where}: a second cfarFovCfg for the {('range', 'Doppler')[int(direction)]} "
                                 f"direction (line {fov[int(direction)].line} is the first)")
            fov[int(direction)] = CfarFov(int(direction), float(low), float(high), number)
        for direction, example in ((0, "cfarFovCfg -1 0 0 8.92"), (1, "cfarFovCfg -1 1 -1 1.00")):
            if direction not in fov:
                raise TiCfgError(f"{source}: no cfarFovCfg for the {('range', 'Doppler')[direction]} direction; "
                                 f"the SDK 3.x demo needs both (e.g. '{example}')")
        entry = one("extendedMaxVelocity", required=False)
        if entry:
            extended = _flag(entry[2][0], entry[1], "enabled")
            if extended:
                raise TiCfgError(f"{entry[1]}: extended maximum velocity (1) is not modelled by the simulated "
                                 "chain; use 0")

    entry = one("compRangeBiasAndRxChanPhase", required=False)
    bias = RangeBiasAndPhase()
    if entry:
        number, where, v = entry
        if len(v) < 3 or len(v) % 2 == 0:
            raise TiCfgError(f"{where}: takes rangeBias then Re Im pairs (one per virtual antenna), got {len(v)} "
                             "values")
        bias = RangeBiasAndPhase(float(v[0]), tuple(v[1:]), number)

    return TiProcessing(sdk=sdk, gui_monitor=gui, cfar_range=cfar[0], cfar_doppler=cfar.get(1),
                        peak_grouping=grouping, multi_object=multi, clutter_removal=clutter, dc_calibration=dc,
                        aoa_fov=aoa, cfar_fov_range=fov.get(0), cfar_fov_doppler=fov.get(1),
                        range_bias_phase=bias, extended_max_velocity=extended, max_points=MAX_POINTS[sdk],
                        lines=tuple(" ".join([c] + a) for _, c, a in lines), source=source)


def processing_from_cfg(source) -> TiProcessing:
    """The :class:`TiProcessing` of a ``.cfg`` (a path or its text); the RF lines are not read.
    Raises :class:`TiCfgError` naming the line, or when the ``.cfg`` has no processing lines."""
    text, name = text_and_source(source)
    processing = parse_processing(processing_lines(text), name)
    if processing is None:
        raise TiCfgError(f"{name}: no processing lines (guiMonitor, cfarCfg, ...); the out-of-box demo "
                         "chain needs them: use the demo's .cfg")
    return processing


def processing_from_lines(lines, source: str = "<radar>") -> TiProcessing | None:
    """The :class:`TiProcessing` of the processing lines a radar keeps (``RadarConfig.ti_processing``)."""
    if not lines:
        return None
    return parse_processing(processing_lines("\n".join(lines)), source)


__all__ = ["AoaFov", "CHAIN_COMMANDS", "CfarConfig", "CfarFov", "DcRangeCalibration", "MAX_POINTS",
           "MultiObjBeamForming", "NON_CHAIN_COMMANDS", "PeakGrouping", "RangeBiasAndPhase", "TiProcessing",
           "parse_processing", "processing_from_cfg", "processing_from_lines", "processing_lines"]
