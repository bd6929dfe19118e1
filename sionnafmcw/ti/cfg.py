r"""TI mmWave SDK / demo ``.cfg`` files in and out (numpy only).

A ``.cfg`` is the list of CLI commands the mmWave SDK demo (and mmWave Studio's CLI) sends to
the device, one per line, ``%`` starting a comment. The RF part is

=============================  ==========================================================================
command                        arguments (TI's units)
=============================  ==========================================================================
``dfeDataOutputMode``          ``1`` (frame mode; 3 = advanced frame is not supported)
``channelCfg``                 ``rxChannelEn txChannelEn cascading`` (bit masks)
``adcCfg``                     ``numADCBits adcOutputFmt`` (2 = 16 bit; 1/2 = complex 1x/2x)
``adcbufCfg``                  ``[subFrameIdx] adcOutputFmt sampleSwap chanInterleave chirpThreshold``
``profileCfg``                 ``id startFreq(GHz) idleTime(us) adcStartTime(us) rampEndTime(us)
                               txOutPower txPhaseShifter freqSlope(MHz/us) txStartTime(us)
                               numAdcSamples digOutSampleRate(ksps) hpfCorner1 hpfCorner2 rxGain(dB)``
``chirpCfg``                   ``startIdx endIdx profileId startFreqVar slopeVar idleVar adcStartVar
                               txEnableMask``
``frameCfg``                   ``chirpStartIdx chirpEndIdx numLoops numFrames framePeriodicity(ms)
                               triggerSelect frameTriggerDelay(ms)``
=============================  ==========================================================================

and maps onto :class:`~sionnafmcw.radar.RadarConfig` as

.. math::
    f_c = \mathrm{startFreq}\cdot 10^9,\quad \mu = \mathrm{freqSlope}\cdot 10^{12},\quad
    F_s = \mathrm{digOutSampleRate}\cdot 10^3,\quad
    T_c = (\mathrm{idleTime} + \mathrm{rampEndTime})\cdot 10^{-6},\quad
    L = \mathrm{numLoops}

with the firing order ``tx_order`` = the transmitter of chirps ``chirpStartIdx..chirpEndIdx``
(one transmitter per chirp: TDM-MIMO) and the element positions of the enabled receivers and
transmitters taken from the board (:data:`BOARDS`, the layouts of the presets).

What the ``.cfg`` does not hold (transmit power, noise figure, element pattern, ADC full scale)
comes from the board's preset. ``txOutPower`` (a back-off code, dB) lowers the board's transmit
power. The receiver (:mod:`sionnafmcw.ti.devices`): ``hpfCornerFreq1``/``hpfCornerFreq2`` (codes
0-3) give the IF chain's two high-pass corners (with the complex-1x anti-alias filter),
``rxGain`` the receiver gain (its bits 5:0, dB; TI's 68xx profiles set the RF gain target in bits
7:6, e.g. 158 = 30 dB), ``adcCfg 2`` the 16-bit ADC, and the phase noise is the device data
sheet's for the band the chirp sweeps.

The commands that set up the out-of-box demo's detection chain (``guiMonitor``, ``cfarCfg``,
``peakGrouping``, ``multiObjBeamForming``, ... :data:`~sionnafmcw.ti.processing.CHAIN_COMMANDS`) do
not change the RF signal: they are read into :attr:`TiCfg.processing` (a
:class:`~sionnafmcw.ti.processing.TiProcessing`, SDK 1.x/2.x or 3.x syntax) and kept, as written, by
the radar (``RadarConfig.ti_processing``), so that a run store can rebuild the demo's chain.
Commands that change neither the RF signal nor the detected points (monitors, calibration
measurement, LVDS output: :data:`IGNORED_COMMANDS`) are skipped and listed in
:attr:`TiCfg.ignored`; the session commands (``sensorStop``, ``flushCfg``, ``sensorStart``) are
accepted. Any other command, or an RF set-up this simulator cannot reproduce (advanced frames,
BPM, per-chirp variations, several transmitters in one chirp, real ADC data), raises
:class:`TiCfgError` naming the line number and the command.

Without a ``board``, a ``.cfg`` in SDK 1.x/2.x processing syntax (an xWR14xx demo) runs on the
IWR1443BOOST; otherwise the start frequency decides (60-64 GHz IWR6843ISK, 76-81 GHz AWR1843BOOST).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..radar import RadarConfig, RadarConfigError, _ti_three_tx_layout
from . import devices as ti_receiver
from .cfg_text import TiCfgError, commands, text_and_source
from .processing import CHAIN_COMMANDS, NON_CHAIN_COMMANDS, parse_processing


# ---------------------------------------------------------------------------------------- boards
@dataclass(frozen=True)
class Board:
    """A TI evaluation board: its device family and its antenna layout.

    Parameters
    ----------
    name : str
        Board name (``awr1843boost``, ``iwr6843isk``, ``iwr1443boost``).
    family : str
        Device family, which fixes the DCA1000 LVDS format: ``"xWR14xx"`` (4 LVDS lanes, one per
        receiver) or ``"xWR16xx"`` (xWR16xx/18xx/68xx: 2 LVDS lanes, see
        :mod:`sionnafmcw.ti.dca1000`).
    preset : str
        The :class:`RadarConfig` preset of this board: transmit power, noise figure and element
        pattern are taken from it.
    design_frequency : float
        Frequency (Hz) the element spacings are half wavelengths of.
    device : str
        The radar device (its data sheet's receiver figures, :mod:`sionnafmcw.ti.devices`).
    """

    name: str
    family: str
    preset: str
    design_frequency: float
    device: str = ""

    def layout(self):
        """``(tx_positions [3,3], rx_positions [4,3])`` of all physical elements (m, radar frame)."""
        return _ti_three_tx_layout(self.design_frequency)


#: The boards of the presets (:func:`sionnafmcw.radar._ti_three_tx_layout`).
BOARDS = {
    "awr1843boost": Board("awr1843boost", "xWR16xx", "ti-awr1843boost", 77e9, "AWR1843"),
    "iwr6843isk": Board("iwr6843isk", "xWR16xx", "ti-iwr6843isk", 62e9, "IWR6843"),
    "iwr1443boost": Board("iwr1443boost", "xWR14xx", "ti-iwr1443boost", 77e9, "IWR1443"),
}

#: Commands of TI's demo .cfg files that change neither the RF signal nor the detected points
#: (monitoring, calibration measurement, LVDS output, power modes, lab tracker settings): skipped.
IGNORED_COMMANDS = NON_CHAIN_COMMANDS
#: Session commands: accepted, no effect on the configuration.
SESSION_COMMANDS = ("sensorStop", "flushCfg", "sensorStart", "baudRate")
#: Commands this reader understands.
RF_COMMANDS = ("dfeDataOutputMode", "channelCfg", "adcCfg", "adcbufCfg", "profileCfg", "chirpCfg", "frameCfg",
               "bpmCfg")

_BOARD_COMMENT = "sionnafmcw-board"
_NAME_COMMENT = "sionnafmcw-radar"


def board_of(spec) -> Board:
    """A :class:`Board` from a board name, a TI preset name or a :class:`Board`."""
    if isinstance(spec, Board):
        return spec
    key = str(spec).lower()
    if key.startswith("ti-"):
        key = key[3:]
    if key not in BOARDS:
        raise TiCfgError(f"unknown TI board {spec!r}; choose one of {', '.join(BOARDS)} "
                         f"(or the presets {', '.join(b.preset for b in BOARDS.values())})")
    return BOARDS[key]


def board_for_radar(radar: RadarConfig, board=None) -> Board:
    """The board of ``radar``: ``board`` when given, else the board whose preset ``radar`` was named
    after (``ti-awr1843boost``, ``ti-awr1843boost*``) or that :func:`read_ti_cfg` named it after
    (``awr1843boost-cfg``)."""
    if board is not None:
        return board_of(board)
    name = radar.name.rstrip("*")
    for candidate in BOARDS.values():
        if name in (candidate.preset, f"{candidate.name}-cfg"):
            return candidate
    raise TiCfgError(f"radar {radar.name!r} is not a TI board preset; say which board it runs on "
                     f"(board= one of {', '.join(BOARDS)})")


# ---------------------------------------------------------------------------------------- parsing
@dataclass
class TiCfg:
    """The RF content of a ``.cfg`` in TI's units, as parsed (see the module docstring)."""

    rx_mask: int = 0
    tx_mask: int = 0
    adc_bits: int = 2
    adc_format: int = 1
    adcbuf: tuple = ()
    profile: dict = field(default_factory=dict)
    chirps: dict = field(default_factory=dict)      # chirp index -> tx enable mask
    frame: dict = field(default_factory=dict)
    ignored: list = field(default_factory=list)     # (line number, command)
    processing_lines: list = field(default_factory=list)   # (line number, command, [arguments])
    processing: object = None                       # TiProcessing, or None without processing lines
    comments: dict = field(default_factory=dict)    # "% key: value" comments (our board / name tags)
    source: str = "<text>"

    @property
    def frame_period(self) -> float:
        """``framePeriodicity`` in seconds."""
        return self.frame["periodicity_ms"] * 1e-3

    @property
    def num_frames(self) -> int:
        """``numFrames`` (0 = infinite)."""
        return self.frame["num_frames"]

    @property
    def rx_gain_db(self) -> float:
        """``rxGain`` of ``profileCfg`` (dB as TI writes it)."""
        return self.profile["rx_gain"]


_PROFILE_FIELDS = ("profile_id", "start_freq_ghz", "idle_us", "adc_start_us", "ramp_end_us", "tx_out_power",
                   "tx_phase_shifter", "slope_mhz_us", "tx_start_us", "num_samples", "rate_ksps", "hpf1", "hpf2",
                   "rx_gain")
_PROFILE_INT = {"profile_id", "tx_out_power", "tx_phase_shifter", "num_samples", "hpf1", "hpf2"}


def parse_ti_cfg(path_or_text) -> TiCfg:
    """Parse a ``.cfg`` (a path, or the text itself) into a :class:`TiCfg`; see the module docstring."""
    text, source = text_and_source(path_or_text)
    cfg = TiCfg(source=source)
    seen = set()

    for number, command, args, body in commands(text):
        if command is None:
            for key in (_BOARD_COMMENT, _NAME_COMMENT):
                if body.startswith(key + ":"):
                    cfg.comments[key] = body.split(":", 1)[1].strip()
            continue
        where = f"{source}, line {number}: {command}"

        def numbers(count_options, kinds=None):
            if len(args) not in count_options:
                raise TiCfgError(f"{where} takes {' or '.join(map(str, count_options))} arguments, got {len(args)}")
            try:
                return [float(a) for a in args]
            except ValueError:
                raise TiCfgError(f"{where}: arguments must be numbers, got {' '.join(args)!r}") from None

        def unsupported(why):
            raise TiCfgError(f"{where}: {why} is not supported by this simulator (TDM-MIMO, one profile, "
                             "complex 16-bit ADC data)")

        if command in CHAIN_COMMANDS:
            cfg.processing_lines.append((number, command, args))
            continue
        if command in IGNORED_COMMANDS:
            cfg.ignored.append((number, command))
            continue
        if command in SESSION_COMMANDS:
            continue
        if command not in RF_COMMANDS:
            raise TiCfgError(f"{where}: unknown command; known RF commands: {', '.join(RF_COMMANDS)}; "
                             f"processing commands: {', '.join(CHAIN_COMMANDS)}; "
                             f"ignored commands: {', '.join(IGNORED_COMMANDS)}")

        if command == "dfeDataOutputMode":
            (mode,) = numbers((1,))
            if mode != 1:
                unsupported(f"dfeDataOutputMode {int(mode)} (only 1, frame mode)")
        elif command == "channelCfg":
            rx, tx, *_ = numbers((2, 3))
            cfg.rx_mask, cfg.tx_mask = int(rx), int(tx)
        elif command == "adcCfg":
            bits, fmt = numbers((2,))
            if bits != 2:
                unsupported(f"numADCBits {int(bits)} ({ {0: '12', 1: '14'}.get(int(bits), '?') } bit; only 2 = 16 bit)")
            if fmt == 0:
                unsupported("adcOutputFmt 0 (real ADC data; only complex 1 or 2)")
            cfg.adc_bits, cfg.adc_format = int(bits), int(fmt)
        elif command == "adcbufCfg":
            values = numbers((4, 5))
            if len(values) == 5:
                values = values[1:]
            if values[0] != 0:
                unsupported("adcbufCfg adcOutputFmt 1 (real ADC data)")
            cfg.adcbuf = tuple(int(v) for v in values)
        elif command == "profileCfg":
            values = numbers((14,))
            profile = {k: (int(v) if k in _PROFILE_INT else v) for k, v in zip(_PROFILE_FIELDS, values)}
            if cfg.profile and cfg.profile != profile:
                unsupported("a second, different profileCfg")
            cfg.profile = profile
        elif command == "chirpCfg":
            start, end, profile_id, f_var, s_var, i_var, a_var, mask = numbers((8,))
            if any((f_var, s_var, i_var, a_var)):
                unsupported("per-chirp variations (startFreqVar/slopeVar/idleVar/adcStartVar not 0)")
            mask = int(mask)
            if bin(mask).count("1") != 1:
                unsupported(f"txEnableMask {mask} (exactly one transmitter per chirp: TDM)")
            for index in range(int(start), int(end) + 1):
                cfg.chirps[index] = (mask, int(profile_id), number)
        elif command == "frameCfg":
            start, end, loops, frames, period, *rest = numbers((5, 6, 7))
            cfg.frame = {"chirp_start": int(start), "chirp_end": int(end), "num_loops": int(loops),
                         "num_frames": int(frames), "periodicity_ms": period, "line": number}
        elif command == "bpmCfg":
            values = numbers((4,))
            if values[1] != 0:
                unsupported("bpmCfg with BPM enabled")
        seen.add(command)

    for command in ("channelCfg", "profileCfg", "chirpCfg", "frameCfg"):
        if command not in seen:
            raise TiCfgError(f"{source}: no {command} command; a .cfg needs channelCfg, profileCfg, chirpCfg and frameCfg")
    cfg.processing = parse_processing(cfg.processing_lines, source)
    return cfg


# ---------------------------------------------------------------------------------------- reading
def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]


def read_ti_cfg(path_or_text, board=None) -> RadarConfig:
    """A :class:`RadarConfig` from a TI mmWave SDK / demo ``.cfg`` (path or text).

    ``board`` (a name of :data:`BOARDS` or a TI preset name) gives the antenna layout; without it,
    a ``% sionnafmcw-board: NAME`` comment (written by :func:`write_ti_cfg`) decides, else the
    start frequency: 60-64 GHz is the IWR6843ISK, 76-81 GHz the AWR1843BOOST.
    Raises :class:`TiCfgError` (a :class:`RadarConfigError`) naming the line and command.
    """
    cfg = parse_ti_cfg(path_or_text)
    return radar_from_ti_cfg(cfg, board)


def radar_from_ti_cfg(cfg: TiCfg, board=None) -> RadarConfig:
    """The :class:`RadarConfig` of a parsed :class:`TiCfg` (see :func:`read_ti_cfg`)."""
    src = cfg.source
    p = cfg.profile
    if board is None:
        if _BOARD_COMMENT in cfg.comments:
            board = cfg.comments[_BOARD_COMMENT]
        else:
            board = ("iwr6843isk" if p["start_freq_ghz"] < 70 else
                     "iwr1443boost" if cfg.processing is not None and cfg.processing.sdk == 2 else "awr1843boost")
    board = board_of(board)
    board_tx, board_rx = board.layout()
    preset = RadarConfig.preset(board.preset)

    rx_enabled = _bits(cfg.rx_mask)
    tx_enabled = _bits(cfg.tx_mask)
    if not rx_enabled or rx_enabled[-1] >= len(board_rx):
        raise TiCfgError(f"{src}: channelCfg rxChannelEn {cfg.rx_mask} does not fit the {board.name} "
                         f"({len(board_rx)} receivers: a mask of 1..{2 ** len(board_rx) - 1})")
    if not tx_enabled or tx_enabled[-1] >= len(board_tx):
        raise TiCfgError(f"{src}: channelCfg txChannelEn {cfg.tx_mask} does not fit the {board.name} "
                         f"({len(board_tx)} transmitters: a mask of 1..{2 ** len(board_tx) - 1})")

    f = cfg.frame
    line = f"{src}, line {f['line']}: frameCfg"
    order = []
    for index in range(f["chirp_start"], f["chirp_end"] + 1):
        if index not in cfg.chirps:
            raise TiCfgError(f"{line} uses chirp {index}, which no chirpCfg defines")
        mask, profile_id, chirp_line = cfg.chirps[index]
        if profile_id != p["profile_id"]:
            raise TiCfgError(f"{src}, line {chirp_line}: chirpCfg uses profile {profile_id}, "
                             f"but profileCfg defines profile {p['profile_id']}")
        if not mask & cfg.tx_mask:
            raise TiCfgError(f"{src}, line {chirp_line}: chirpCfg enables TX{_bits(mask)[0]}, "
                             f"which channelCfg txChannelEn {cfg.tx_mask} disables")
        order.append(tx_enabled.index(_bits(mask)[0]))
    if sorted(order) != list(range(len(tx_enabled))):
        raise TiCfgError(f"{line}: chirps {f['chirp_start']}..{f['chirp_end']} fire transmitter indices "
                         f"{order}; TDM-MIMO needs every enabled transmitter ({len(tx_enabled)}) exactly once per loop")
    if f["num_loops"] < 1:
        raise TiCfgError(f"{line}: numLoops must be >= 1, got {f['num_loops']}")

    tx_power = preset.tx_power * 10.0 ** (-p["tx_out_power"] / 10.0)
    name = cfg.comments.get(_NAME_COMMENT, f"{board.name}-cfg")
    try:
        chain = ti_receiver.if_chain(p["hpf1"], p["hpf2"])
    except ValueError as err:
        raise TiCfgError(f"{src}: profileCfg: {err}") from None
    f_stop = p["start_freq_ghz"] * 1e9 + p["slope_mhz_us"] * 1e12 * p["ramp_end_us"] * 1e-6
    try:
        phase_noise = ti_receiver.phase_noise_table(board.device, p["start_freq_ghz"] * 1e9, f_stop)
    except ValueError as err:
        raise TiCfgError(f"{src}: profileCfg: {err}") from None
    try:
        return RadarConfig(
            fc=p["start_freq_ghz"] * 1e9,
            slope=p["slope_mhz_us"] * 1e12,
            fs=p["rate_ksps"] * 1e3,
            num_samples=p["num_samples"],
            num_chirps=f["num_loops"],
            chirp_interval=(p["idle_us"] + p["ramp_end_us"]) * 1e-6,
            adc_start_time=p["adc_start_us"] * 1e-6,
            ramp_end_time=p["ramp_end_us"] * 1e-6,
            tx_positions=board_tx[tx_enabled],
            rx_positions=board_rx[rx_enabled],
            tx_order=order,
            tx_power=tx_power,
            noise_figure=preset.noise_figure,
            antenna_pattern=preset.antenna_pattern,
            name=name,
            phase_noise=phase_noise,
            if_filter=chain,
            adc_bits=16,
            adc_full_scale=preset.adc_full_scale,
            rx_gain=float(int(p["rx_gain"]) & 0x3F),
            ti_processing=[" ".join([c] + a) for _, c, a in cfg.processing_lines] or None,
        )
    except RadarConfigError as err:
        raise TiCfgError(f"{src}: profileCfg/frameCfg give an impossible radar: {err}") from None


# ---------------------------------------------------------------------------------------- writing
def _num(value: float, decimals: int = 6) -> str:
    """A TI-style number: rounded, no trailing ``.0``."""
    value = round(float(value), decimals)
    if value == int(value):
        return str(int(value))
    return repr(value)


def _match_rows(positions, candidates, what, board):
    index = []
    for row in positions:
        hits = np.flatnonzero(np.all(np.isclose(candidates, row, rtol=0, atol=1e-9), axis=1))
        if hits.size != 1:
            raise TiCfgError(f"{what} position {row.tolist()} m is not an element of the {board.name} "
                             "(a .cfg can only enable the board's own elements)")
        index.append(int(hits[0]))
    if index != sorted(index):
        raise TiCfgError(f"{what} positions are not in the board's element order {index}; "
                         "channelCfg can only enable elements, not reorder them")
    return index


def write_ti_cfg(radar: RadarConfig, board=None, frame_period: float = 0.1, num_frames: int = 0,
                 rx_gain_db: float | None = None, ignored=None) -> str:
    """The TI mmWave SDK demo ``.cfg`` text of ``radar`` (inverse of :func:`read_ti_cfg`).

    Parameters
    ----------
    radar : RadarConfig
        Its elements must be elements of the board (the enabled subset, in board order).
    board : str or Board, optional
        Default: the board whose preset ``radar`` is named after.
    frame_period : float
        ``framePeriodicity`` (s); must hold the CPI.
    num_frames : int
        ``numFrames`` (0 = until ``sensorStop``).
    rx_gain_db : float, optional
        ``rxGain`` of ``profileCfg`` (dB); default ``radar.rx_gain``.
    ignored : list of str, optional
        Extra (non-RF) command lines to append after the radar's own processing lines
        (``radar.ti_processing``), e.g. ``["lvdsStreamCfg -1 0 0 0"]``.

    Notes
    -----
    The chirps ``0..M-1`` fire the transmitters in ``radar.tx_order``; ``txOutPower`` is the
    back-off (dB) of ``radar.tx_power`` below the board preset's (an error unless a whole number of
    dB); ``txStartTime`` is TI's 1 us; ``hpfCornerFreq1``/``hpfCornerFreq2`` are the codes of the
    radar's two high-pass corners (0/0 without an IF chain; an error for corners TI does not offer);
    ``adcCfg 2 1`` (16 bit: a radar with another ``adc_bits`` is refused); the comments
    ``% sionnafmcw-board`` and ``% sionnafmcw-radar`` let :func:`read_ti_cfg` find the board and name again.
    """
    board = board_for_radar(radar, board)
    board_tx, board_rx = board.layout()
    tx_index = _match_rows(radar.tx_positions, board_tx, "tx", board)
    rx_index = _match_rows(radar.rx_positions, board_rx, "rx", board)
    radar.validate(frame_period)
    preset = RadarConfig.preset(board.preset)
    backoff = 10.0 * math.log10(preset.tx_power / radar.tx_power)
    backoff_code = int(round(backoff))
    if backoff < -1e-6 or abs(backoff - backoff_code) > 1e-6:
        raise TiCfgError(f"RadarConfig.tx_power ({radar.tx_power * 1e3:.4g} mW) is not the {board.name}'s "
                         f"{preset.tx_power * 1e3:.4g} mW lowered by a whole number of dB (txOutPower back-off)")

    try:
        hpf1, hpf2 = ti_receiver.hpf_codes(radar.if_filter)
    except ValueError as err:
        raise TiCfgError(f"RadarConfig.if_filter: {err}; a .cfg can only select TI's corners") from None
    if radar.adc_bits not in (None, 16):
        raise TiCfgError(f"RadarConfig.adc_bits={radar.adc_bits}: this writer emits 16-bit ADC data (adcCfg 2 1) "
                         "only; set adc_bits to 16 (or None)")
    rx_gain_db = radar.rx_gain if rx_gain_db is None else rx_gain_db
    idle_us = (radar.chirp_interval - radar.ramp_end_time) * 1e6
    lines = [
        f"% TI mmWave SDK demo configuration written by sionnafmcw for {radar.name}",
        f"% {_BOARD_COMMENT}: {board.name}",
        f"% {_NAME_COMMENT}: {radar.name}",
        "sensorStop",
        "flushCfg",
        "dfeDataOutputMode 1",
        f"channelCfg {sum(1 << i for i in rx_index)} {sum(1 << i for i in tx_index)} 0",
        "adcCfg 2 1",
        "adcbufCfg -1 0 1 1 1",
        "profileCfg 0 {} {} {} {} {} 0 {} 1 {} {} {} {} {}".format(
            _num(radar.fc / 1e9, 9), _num(idle_us, 4), _num(radar.adc_start_time * 1e6, 4),
            _num(radar.ramp_end_time * 1e6, 4), backoff_code, _num(radar.slope / 1e12, 6),
            radar.num_samples, _num(radar.fs / 1e3, 3), hpf1, hpf2, _num(rx_gain_db, 3)),
    ]
    for slot, tx in enumerate(radar.tx_order):
        lines.append(f"chirpCfg {slot} {slot} 0 0 0 0 0 {1 << tx_index[tx]}")
    lines.append(f"frameCfg 0 {radar.num_tx - 1} {radar.num_chirps} {int(num_frames)} {_num(frame_period * 1e3, 6)} 1 0")
    lines.extend(radar.ti_processing or [])
    lines.extend(ignored or [])
    lines.append("sensorStart")
    return "\n".join(lines) + "\n"


__all__ = ["BOARDS", "Board", "IGNORED_COMMANDS", "TiCfg", "TiCfgError", "board_for_radar", "board_of",
           "parse_ti_cfg", "radar_from_ti_cfg", "read_ti_cfg", "write_ti_cfg"]
