r"""Radar configuration: chirp, timing, TDM-MIMO array and link budget.

Timing of one frame (coherent processing interval, CPI); the run store keeps it (:mod:`sionnafmcw.store`):

* the transmitters fire in the order ``tx_order`` (physical element indices); chirp :math:`l`
  of the transmitter at position :math:`q` of that order starts at
  :math:`t_n + (lM + q)\,T_c`, with :math:`T_c` = ``chirp_interval`` (idle + ramp);
* fast-time sample :math:`k` is taken at ``adc_start_time`` :math:`+\,k/F_s` after the chirp start.

The ADC window is centred :math:`t_{mid} = t_{adc} + (N_s - 1)/(2F_s)` into the ramp, where the
instantaneous frequency is the *sweep centre* :math:`f_{mid} = f_c + \mu t_{mid}`. Phase-based
estimates (Doppler, angle) see :math:`f_{mid}`, so velocity and angle axes use
:math:`\lambda_{mid} = c/f_{mid}`.

Derived figures (complex baseband sampling):

.. math::
    B = \mu N_s / F_s,\quad \Delta R = \frac{c}{2B},\quad R_{max} = \frac{c F_s}{2\mu},\quad
    T_b = M T_c,\quad v_{max} = \frac{\lambda_{mid}}{4 T_b},\quad
    \Delta v = \frac{\lambda_{mid}}{2 L T_b},\quad T_{CPI} = L M T_c

where :math:`M` is the number of transmitters and :math:`L` the number of chirps per transmitter.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import numbers
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from . import array
from .antenna import PATTERNS, check_pattern
from .constants import SPEED_OF_LIGHT


class RadarConfigError(ValueError):
    """A radar configuration that cannot work; the message names the field."""


def _half_wavelength(frequency: float) -> float:
    return SPEED_OF_LIGHT / frequency / 2.0


#: Gap between the last Tx and the first Rx element, in wavelengths. The boards put the Rx and
#: Tx patch rows side by side, never on the same spot; a constant Rx offset only moves the
#: virtual array's phase centre (virtual positions are tx + rx), not its shape. It also keeps
#: every Tx-Rx pair > 1 cm apart: retro-reflected paths (corners, dihedrals) pass within a
#: fraction of the Tx-Rx spacing of the corner, and exactly co-located elements make their
#: image-method path degenerate (zero-length segments through the corner).
RX_ROW_OFFSET_WAVELENGTHS = 3.0


def _rx_row(count: int, spacing: float, tx_span: float) -> np.ndarray:
    start = tx_span + RX_ROW_OFFSET_WAVELENGTHS * 2 * spacing
    return np.array([[0.0, start + n * spacing, 0.0] for n in range(count)])


def _ti_three_tx_layout(design_frequency: float):
    r"""Element layout of the TI xWR1443BOOST / xWR1843BOOST / IWR6843ISK boards.

    Source: TI mmWave SDK board geometry (``antGeometry0 0 -1 -2 -3 -2 -3 -4 -5 -4 -5 -6 -7``,
    ``antGeometry1 -1 -1 -1 -1 0 0 0 0 -1 -1 -1 -1`` in units of :math:`\lambda/2`, virtual
    antennas in the order TX0 RX0..3, TX1 RX0..3, TX2 RX0..3) and the boards' user guides
    (SWRU518, SWRU546): four receivers :math:`\lambda/2` apart, TX0 and TX2 :math:`2\lambda`
    apart in azimuth, TX1 between them and raised by :math:`\lambda/2`. We mirror TI's azimuth
    axis so that the virtual array grows along the radar's :math:`+y` and put the raised TX1 at
    :math:`+z`. The Rx row sits beside the Tx row (:data:`RX_ROW_OFFSET_WAVELENGTHS`).
    """
    d = _half_wavelength(design_frequency)
    rx = _rx_row(4, d, tx_span=4 * d)
    tx = np.array([[0.0, 0.0, 0.0], [0.0, 2 * d, d], [0.0, 4 * d, 0.0]])
    return tx, rx


@dataclass
class RadarConfig:
    r"""FMCW TDM-MIMO radar configuration, SI units.

    Parameters
    ----------
    fc : float
        Start frequency of the ramp :math:`f_c` (Hz).
    slope : float
        Chirp slope :math:`\mu` (Hz/s).
    fs : float
        Complex ADC sampling rate :math:`F_s` (Hz).
    num_samples : int
        ADC samples per chirp :math:`N_s`.
    num_chirps : int
        Chirps per transmitter per frame :math:`L`.
    chirp_interval : float
        Chirp repetition interval :math:`T_c` = idle + ramp (s).
    adc_start_time : float
        Time from the ramp start to the first ADC sample (s).
    ramp_end_time : float
        Duration of the frequency ramp (s); the ADC window must fit inside it.
    tx_positions, rx_positions : array [M,3] / [N,3]
        Element positions in the radar frame (m); boresight is local +x.
    tx_order : list of int
        Physical Tx indices in firing order within one TDM block.
    tx_power : float
        Transmit power per element :math:`P_t` (W).
    noise_figure : float
        Receiver noise figure (dB).
    antenna_pattern : str or dict
        Element pattern: a name of :data:`sionnafmcw.antenna.PATTERNS` (``"iso"``, ``"tr38901"``, the TI
        boards' ``"ti-awr1843boost"``, ...) or a measured pattern: the path of a ``.json``/``.csv`` file
        (read here, :func:`sionnafmcw.antenna.load_pattern_file`, and kept as its dict, so that a run
        store holds the pattern itself) or that dict.
    name : str
        A label (the preset name for presets).
    phase_noise : list, optional
        LO phase noise ``[[offset (Hz), L (dBc/Hz)], ...]`` (:mod:`sionnafmcw.receiver.phase_noise`);
        None: no phase noise.
    if_filter : list, optional
        IF chain, a list of filter sections (:mod:`sionnafmcw.receiver.if_filter`); None: ideal.
    adc_bits : int, optional
        ADC word length (2..16) of the ADC in the cube (:mod:`sionnafmcw.receiver.adc`); None: no
        quantisation, no clipping.
    adc_full_scale : float
        Power (W) at the ADC input of a full-scale complex tone (default 1 mW, 0 dBm).
    rx_gain : float
        Receiver gain from the antenna port to the ADC (dB; TI's ``rxGain``), default 30 dB.
    iq_imbalance : dict, optional
        ``{"gain_db": ..., "phase_deg": ...}`` (:mod:`sionnafmcw.receiver.iq_imbalance`); None: none.
    ti_processing : list of str, optional
        The processing lines (``guiMonitor``, ``cfarCfg``, ...) of the TI ``.cfg`` the radar was read
        from, as written: they change no signal, but a run store keeps them with the radar so
        that the board's own on-chip chain can be run on it (:mod:`sionnafmcw.ti.oob`); None
        for a radar that came from no such ``.cfg``.

    Notes
    -----
    The receiver fields (``phase_noise`` .. ``iq_imbalance``) are off (None) unless given: the TI
    presets state their data sheets' values, ``walk-77ghz`` and custom radars are ideal
    (:mod:`sionnafmcw.receiver`).
    """

    fc: float
    slope: float
    fs: float
    num_samples: int
    num_chirps: int
    chirp_interval: float
    adc_start_time: float
    ramp_end_time: float
    tx_positions: np.ndarray
    rx_positions: np.ndarray
    tx_order: list = None
    tx_power: float = 0.01
    noise_figure: float = 12.0
    antenna_pattern: str = "iso"
    name: str = "custom"
    phase_noise: list = None
    if_filter: list = None
    adc_bits: int = None
    adc_full_scale: float = 1e-3
    rx_gain: float = 30.0
    iq_imbalance: dict = None
    ti_processing: list = None

    def __post_init__(self):
        self.tx_positions = np.atleast_2d(np.asarray(self.tx_positions, dtype=float))
        self.rx_positions = np.atleast_2d(np.asarray(self.rx_positions, dtype=float))
        if self.tx_order is None:
            self.tx_order = list(range(self.tx_positions.shape[0]))
        self.tx_order = [int(i) for i in self.tx_order]
        self.num_samples = int(self.num_samples)
        self.num_chirps = int(self.num_chirps)
        if self.ti_processing is not None:
            _check_field_type("ti_processing", self.ti_processing)
            self.ti_processing = [str(line) for line in self.ti_processing] or None
        self._normalise_receiver()
        self.validate()

    def _normalise_receiver(self) -> None:
        """Read a measured pattern file, check and normalise the receiver fields (errors name the field)."""
        from .antenna import PATTERNS, load_pattern_file
        from .receiver import if_filter, iq_imbalance, phase_noise

        pattern = self.antenna_pattern
        if isinstance(pattern, Path) or (isinstance(pattern, str) and pattern not in PATTERNS
                                         and (pattern.lower().endswith((".json", ".csv")) or Path(pattern).is_file())):
            try:
                self.antenna_pattern = load_pattern_file(pattern)
            except ValueError as err:
                raise RadarConfigError(f"RadarConfig.antenna_pattern: {err}") from None
        try:
            self.phase_noise = phase_noise.check_table(self.phase_noise)
            self.if_filter = if_filter.check_chain(self.if_filter)
            self.iq_imbalance = iq_imbalance.check(self.iq_imbalance)
        except ValueError as err:
            raise RadarConfigError(str(err)) from None
        if self.adc_bits is not None:
            if not _is_real(self.adc_bits) or float(self.adc_bits) != int(self.adc_bits):
                raise RadarConfigError(
                    f"RadarConfig.adc_bits must be an integer (2..16) or None, got {self.adc_bits!r}")
            self.adc_bits = int(self.adc_bits)

    # ------------------------------------------------------------------ derived figures
    @property
    def num_tx(self) -> int:
        """Number of transmit elements :math:`M`."""
        return self.tx_positions.shape[0]

    @property
    def num_rx(self) -> int:
        """Number of receive elements :math:`N`."""
        return self.rx_positions.shape[0]

    @property
    def virtual_array(self) -> np.ndarray:
        """Virtual element positions ``[M*N, 3]`` (m, radar frame), tx-major: :func:`sionnafmcw.array.virtual_array`."""
        return array.virtual_array(self)

    @property
    def phase_centre(self) -> np.ndarray:
        """Phase centre of the virtual array ``[3]`` (m, radar frame): :func:`sionnafmcw.array.phase_centre`."""
        return array.phase_centre(self)

    @property
    def wavelength(self) -> float:
        """Wavelength at the ramp start frequency, :math:`c/f_c` (m)."""
        return SPEED_OF_LIGHT / self.fc

    @property
    def adc_centre_time(self) -> float:
        """:math:`t_{mid}`, time of the ADC window centre after the ramp start (s)."""
        return self.adc_start_time + (self.num_samples - 1) / (2.0 * self.fs)

    @property
    def centre_frequency(self) -> float:
        """Instantaneous frequency at the ADC window centre :math:`f_{mid}` (Hz)."""
        return self.fc + self.slope * self.adc_centre_time

    @property
    def centre_wavelength(self) -> float:
        """:math:`\\lambda_{mid} = c / f_{mid}` (m): the wavelength for velocity and angle axes."""
        return SPEED_OF_LIGHT / self.centre_frequency

    @property
    def bandwidth(self) -> float:
        """Sampled sweep bandwidth :math:`\\mu N_s / F_s` (Hz)."""
        return self.slope * self.num_samples / self.fs

    @property
    def range_resolution(self) -> float:
        """:math:`c / (2B)` (m), also the range FFT bin width without zero padding."""
        return SPEED_OF_LIGHT / (2.0 * self.bandwidth)

    @property
    def max_range(self) -> float:
        """Unambiguous range of complex sampling, :math:`c F_s / (2\\mu)` (m)."""
        return SPEED_OF_LIGHT * self.fs / (2.0 * self.slope)

    @property
    def block_interval(self) -> float:
        """TDM block duration :math:`T_b = M T_c` (s): the slow-time sampling interval."""
        return self.num_tx * self.chirp_interval

    @property
    def max_velocity(self) -> float:
        """Unambiguous radial velocity :math:`\\lambda_{mid}/(4 T_b)` (m/s), TDM-aware."""
        return self.centre_wavelength / (4.0 * self.block_interval)

    @property
    def velocity_resolution(self) -> float:
        """:math:`\\lambda_{mid} / (2 L T_b)` (m/s), the Doppler FFT bin width."""
        return self.centre_wavelength / (2.0 * self.num_chirps * self.block_interval)

    @property
    def cpi_duration(self) -> float:
        """Duration of one frame's chirps, :math:`L M T_c` (s)."""
        return self.num_chirps * self.block_interval

    @property
    def noise_power(self) -> float:
        """Receiver noise power per complex sample :math:`k T_0 F F_s` (W)."""
        from .constants import BOLTZMANN, T0

        return BOLTZMANN * T0 * 10.0 ** (self.noise_figure / 10.0) * self.fs

    def chirp_start_times(self) -> np.ndarray:
        """Start time of every chirp, ``[num_chirps, num_tx]`` in physical Tx order (s, from the CPI start)."""
        slot = np.empty(self.num_tx, dtype=float)
        slot[self.tx_order] = np.arange(self.num_tx)
        l = np.arange(self.num_chirps)[:, None]
        return (l * self.num_tx + slot[None, :]) * self.chirp_interval

    def tx_slot(self) -> np.ndarray:
        """Position of each physical Tx in the firing order, ``[num_tx]`` ints."""
        slot = np.empty(self.num_tx, dtype=int)
        slot[self.tx_order] = np.arange(self.num_tx)
        return slot

    def derived(self) -> dict:
        """The derived figures as a plain dict (SI units), for listings and stores."""
        return {
            "wavelength": self.wavelength,
            "centre_frequency": self.centre_frequency,
            "bandwidth": self.bandwidth,
            "range_resolution": self.range_resolution,
            "max_range": self.max_range,
            "velocity_resolution": self.velocity_resolution,
            "max_velocity": self.max_velocity,
            "cpi_duration": self.cpi_duration,
            "num_virtual": self.num_tx * self.num_rx,
        }

    # ------------------------------------------------------------------ checks
    def validate(self, frame_period: float | None = None) -> "RadarConfig":
        """Raise :class:`RadarConfigError` naming the field of an impossible configuration.

        ``frame_period`` (s), when given, must hold the whole CPI.
        """
        for name in ("fc", "slope", "fs", "chirp_interval", "ramp_end_time", "tx_power"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise RadarConfigError(f"RadarConfig.{name} must be a positive finite number, got {value!r}")
        for name in ("num_samples", "num_chirps"):
            if getattr(self, name) < 1:
                raise RadarConfigError(f"RadarConfig.{name} must be >= 1, got {getattr(self, name)!r}")
        if not np.isfinite(self.adc_start_time) or self.adc_start_time < 0:
            raise RadarConfigError(f"RadarConfig.adc_start_time must be >= 0, got {self.adc_start_time!r}")
        if not np.isfinite(self.noise_figure) or self.noise_figure < 0:
            raise RadarConfigError(f"RadarConfig.noise_figure must be >= 0 dB, got {self.noise_figure!r}")
        adc_end = self.adc_start_time + self.num_samples / self.fs
        if adc_end > self.ramp_end_time * (1 + 1e-9):
            raise RadarConfigError(
                f"RadarConfig: the ADC window (adc_start_time + num_samples/fs = {adc_end * 1e6:.3f} us) "
                f"is longer than the ramp (ramp_end_time = {self.ramp_end_time * 1e6:.3f} us); "
                "lower num_samples, raise fs or lengthen the ramp"
            )
        if self.ramp_end_time > self.chirp_interval * (1 + 1e-9):
            raise RadarConfigError(
                f"RadarConfig.ramp_end_time ({self.ramp_end_time * 1e6:.3f} us) exceeds chirp_interval "
                f"({self.chirp_interval * 1e6:.3f} us); the chirp interval is idle + ramp"
            )
        for name, pos in (("tx_positions", self.tx_positions), ("rx_positions", self.rx_positions)):
            if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] < 1:
                raise RadarConfigError(f"RadarConfig.{name} must have shape [count, 3], got {pos.shape}")
            if not np.all(np.isfinite(pos)):
                raise RadarConfigError(f"RadarConfig.{name} contains non-finite values")
        if sorted(self.tx_order) != list(range(self.num_tx)):
            raise RadarConfigError(
                f"RadarConfig.tx_order must be a permutation of 0..{self.num_tx - 1}, got {self.tx_order}"
            )
        if isinstance(self.antenna_pattern, dict):
            try:
                check_pattern(self.antenna_pattern)
            except ValueError as err:
                raise RadarConfigError(f"RadarConfig.{err}") from None
        elif self.antenna_pattern not in PATTERNS:
            raise RadarConfigError(
                f"RadarConfig.antenna_pattern={self.antenna_pattern!r} is unknown; choose one of "
                f"{', '.join(PATTERNS)}, "
                "or give a measured pattern file (.json or .csv: angles in degrees, gains in dBi)"
            )
        if self.adc_bits is not None and not 2 <= self.adc_bits <= 16:
            raise RadarConfigError(f"RadarConfig.adc_bits must lie in 2..16 (the ADC's word; the DCA1000 captures "
                                   f"16-bit words) or be None for no ADC in the cube, got {self.adc_bits!r}")
        if not np.isfinite(self.adc_full_scale) or self.adc_full_scale <= 0:
            raise RadarConfigError(f"RadarConfig.adc_full_scale must be a positive power in W (1e-3 = 0 dBm), "
                                   f"got {self.adc_full_scale!r}")
        if not np.isfinite(self.rx_gain):
            raise RadarConfigError(f"RadarConfig.rx_gain must be a finite gain in dB, got {self.rx_gain!r}")
        if self.if_filter:
            from .receiver.if_filter import corner

            low = [s for s in self.if_filter if s["type"] == "lowpass"]
            for section in self.if_filter:
                if corner(section, self.fs) >= 50 * self.fs:
                    raise RadarConfigError(f"RadarConfig.if_filter: the {section['type']} corner "
                                           f"{corner(section, self.fs):.4g} Hz is beyond 50 F_s; check its units (Hz)")
            if len(low) > 1:
                raise RadarConfigError("RadarConfig.if_filter: give at most one lowpass (anti-alias) section")
        if frame_period is not None and self.cpi_duration > frame_period * (1 + 1e-9):
            raise RadarConfigError(
                f"RadarConfig: the CPI (num_chirps * num_tx * chirp_interval = {self.cpi_duration * 1e3:.3f} ms) "
                f"is longer than the frame period ({frame_period * 1e3:.3f} ms); use fewer chirps or a lower frame rate"
            )
        return self

    # ------------------------------------------------------------------ (de)serialisation
    def to_dict(self) -> dict:
        """Plain, JSON-serialisable dict with the field names of this class; ``ti_processing`` only
        when set, so that a radar from no ``.cfg`` has the same dict as stored run stores and data-set
        specs hold for it."""
        out = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "ti_processing" and value is None:
                continue
            if isinstance(value, np.ndarray):
                value = value.tolist()
            elif isinstance(value, (list, dict)):
                value = copy.deepcopy(value)      # nested receiver fields: the dict never aliases the radar
            out[f.name] = value
        return out

    @classmethod
    def from_dict(cls, data: dict) -> "RadarConfig":
        """Inverse of :meth:`to_dict`; unknown or missing fields and wrong types are named in the error."""
        if not isinstance(data, dict):
            raise RadarConfigError(f"RadarConfig: expected a mapping of fields, got {type(data).__name__}")
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise RadarConfigError(f"RadarConfig: unknown field(s) {', '.join(unknown)}; known: {', '.join(sorted(names))}")
        required = {f.name for f in dataclasses.fields(cls)
                    if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING}
        missing = sorted(required - set(data))
        if missing:
            raise RadarConfigError(f"RadarConfig: missing field(s) {', '.join(missing)}")
        for name, value in data.items():
            _check_field_type(name, value)
        return cls(**data)

    def to_json(self, **kwargs) -> str:
        return json.dumps(self.to_dict(), **kwargs)

    @classmethod
    def from_json(cls, text: str) -> "RadarConfig":
        return cls.from_dict(json.loads(text))

    @classmethod
    def resolve(cls, spec) -> "RadarConfig":
        """A :class:`RadarConfig` from any of the ways a radar is named.

        ``spec`` is one of

        * a :class:`RadarConfig` (returned as is);
        * a preset name (:meth:`presets`);
        * a dict: a full configuration (:meth:`to_dict`'s fields), or a preset with changes
          ``{"preset": NAME, field: value, ...}`` (the name becomes ``NAME*`` unless ``name`` is
          one of the changes);
        * the path (``str`` or :class:`~pathlib.Path`) of a ``.json`` file holding either dict form;
        * the path of a TI mmWave SDK ``.cfg`` file, read by
          :func:`sionnafmcw.ti.cfg.read_ti_cfg`.

        Raises :class:`RadarConfigError` naming the file (when there is one) and the field:
        unknown fields against the known ones, wrong types, invalid JSON with its line and column.
        """
        if isinstance(spec, RadarConfig):
            return spec
        if isinstance(spec, dict):
            return _from_mapping(spec)
        if isinstance(spec, str) and spec in _PRESETS:
            return cls.preset(spec)
        if isinstance(spec, (str, Path)):
            path = Path(spec)
            if isinstance(spec, str) and not path.exists() and path.suffix.lower() not in (".json", ".cfg"):
                raise RadarConfigError(
                    f"radar {spec!r} is neither a preset ({', '.join(_PRESETS)}) nor an existing .json or TI .cfg file"
                )
            return _from_file(path)
        raise RadarConfigError(
            "radar must be a RadarConfig, a preset name, a dict or the path of a .json or TI .cfg file, "
            f"got {type(spec).__name__}"
        )

    def replace(self, **changes) -> "RadarConfig":
        """A copy with some fields changed (validated)."""
        return dataclasses.replace(self, **changes)

    def __eq__(self, other: Any) -> bool:
        if not isinstance(other, RadarConfig):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    # ------------------------------------------------------------------ presets
    @classmethod
    def from_ti_cfg(cls, path_or_text, board=None) -> "RadarConfig":
        """The radar of a TI mmWave SDK / demo ``.cfg`` (:func:`sionnafmcw.ti.cfg.read_ti_cfg`)."""
        return format_function(".cfg", "read")(path_or_text, board=board)

    def to_ti_cfg(self, board=None, **options) -> str:
        """This radar as a TI mmWave SDK demo ``.cfg`` (:func:`sionnafmcw.ti.cfg.write_ti_cfg`)."""
        return format_function(".cfg", "write")(self, board=board, **options)

    @staticmethod
    def presets() -> list[str]:
        """Names accepted by :meth:`preset`."""
        return list(_PRESETS)

    @classmethod
    def preset(cls, name: str) -> "RadarConfig":
        """A named configuration; see :func:`RadarConfig.presets` and the functions below."""
        if name not in _PRESETS:
            raise RadarConfigError(f"unknown radar preset {name!r}; choose one of {', '.join(_PRESETS)}")
        return _PRESETS[name]()


_FLOAT_FIELDS = ("fc", "slope", "fs", "chirp_interval", "adc_start_time", "ramp_end_time", "tx_power", "noise_figure",
                 "adc_full_scale", "rx_gain")
_INT_FIELDS = ("num_samples", "num_chirps")
_STR_FIELDS = ("name",)


def _is_real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _check_field_type(name: str, value) -> None:
    """Raise :class:`RadarConfigError` when ``value`` has the wrong type for field ``name``."""
    if name in _FLOAT_FIELDS:
        if not _is_real(value):
            raise RadarConfigError(f"RadarConfig.{name} must be a number (SI units), got {value!r}")
    elif name in _INT_FIELDS:
        if not _is_real(value) or float(value) != int(value):
            raise RadarConfigError(f"RadarConfig.{name} must be an integer, got {value!r}")
    elif name in _STR_FIELDS:
        if not isinstance(value, str):
            raise RadarConfigError(f"RadarConfig.{name} must be a string, got {value!r}")
    elif name in ("tx_positions", "rx_positions"):
        try:
            pos = np.atleast_2d(np.asarray(value, dtype=float))
        except (TypeError, ValueError):
            raise RadarConfigError(f"RadarConfig.{name} must be a list of [x, y, z] positions (m), got {value!r}") from None
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise RadarConfigError(f"RadarConfig.{name} must be a list of [x, y, z] positions (m), got shape {pos.shape}")
    elif name == "antenna_pattern":
        if not isinstance(value, (str, dict)):
            raise RadarConfigError(f"RadarConfig.antenna_pattern must be a pattern name, the path of a measured "
                                   f"pattern file or a measured pattern dict, got {value!r}")
    elif name == "adc_bits" and value is not None:
        if not _is_real(value) or float(value) != int(value):
            raise RadarConfigError(f"RadarConfig.adc_bits must be an integer (2..16) or null, got {value!r}")
    elif name in ("phase_noise", "if_filter") and value is not None:
        if not isinstance(value, (list, tuple)):
            raise RadarConfigError(f"RadarConfig.{name} must be a list or null, got {value!r}")
    elif name == "iq_imbalance" and value is not None:
        if not isinstance(value, dict):
            raise RadarConfigError(
                f"RadarConfig.iq_imbalance must be a dict {{gain_db, phase_deg}} or null, got {value!r}")
    elif name == "ti_processing" and value is not None:
        if not isinstance(value, (list, tuple)) or not all(isinstance(line, str) for line in value):
            raise RadarConfigError(f"RadarConfig.ti_processing must be a list of .cfg lines (strings) or null, "
                                   f"got {value!r}")
    elif name == "tx_order" and value is not None:
        if (not isinstance(value, (list, tuple, np.ndarray))
                or not all(_is_real(i) and float(i) == int(i) for i in value)):
            raise RadarConfigError(f"RadarConfig.tx_order must be a list of Tx indices, got {value!r}")


def _from_mapping(data: dict) -> RadarConfig:
    """A full configuration dict, or ``{"preset": NAME, field: value, ...}``."""
    if "preset" not in data:
        return RadarConfig.from_dict(data)
    base = data["preset"]
    if not isinstance(base, str) or base not in _PRESETS:
        raise RadarConfigError(f"field 'preset' is {base!r}; choose one of {', '.join(_PRESETS)}")
    changes = {k: v for k, v in data.items() if k != "preset"}
    config = RadarConfig.preset(base).to_dict()
    unknown = sorted(set(changes) - set(config))
    if unknown:
        raise RadarConfigError(f"unknown RadarConfig field(s) {', '.join(unknown)}; known: {', '.join(sorted(config))}")
    config.update(changes)
    if "name" not in changes:
        config["name"] = f"{base}*" if changes else base
    return RadarConfig.from_dict(config)


def _from_file(path: Path) -> RadarConfig:
    """A radar from a ``.json`` file (either dict form of :meth:`RadarConfig.resolve`) or a TI ``.cfg``."""
    if not path.exists():
        raise RadarConfigError(f"{path}: no such radar file")
    if path.is_dir():
        raise RadarConfigError(f"{path}: is a directory, expected a radar .json or TI .cfg file")
    if path.suffix.lower() == ".cfg":
        return _from_ti_cfg(path)
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise RadarConfigError(f"{path}: invalid JSON at line {err.lineno}, column {err.colno}: {err.msg}") from None
    except (OSError, UnicodeDecodeError) as err:
        raise RadarConfigError(f"{path}: cannot read the radar file ({getattr(err, 'strerror', None) or err})") from None
    if not isinstance(data, dict):
        raise RadarConfigError(f"{path}: the radar file must hold a JSON object with RadarConfig fields "
                               "(RadarConfig.to_dict()) or {\"preset\": NAME, field: value, ...}")
    try:
        return _from_mapping(data)
    except RadarConfigError as err:
        raise RadarConfigError(f"{path}: {err}") from None


#: Readers and writers of radar files in other formats, by file suffix: ``"module:function"``
#: imported on first use (as :mod:`sionnafmcw.engines` registers its engines), so that this module
#: imports none of them -- they import :class:`RadarConfig` (no import circle).
FORMATS = {".cfg": {"read": "sionnafmcw.ti.cfg:read_ti_cfg", "write": "sionnafmcw.ti.cfg:write_ti_cfg"}}


def format_function(suffix: str, job: str):
    """The ``job`` (``"read"`` or ``"write"``) function of the radar format ``suffix`` (:data:`FORMATS`)."""
    import importlib

    try:
        module, _, name = FORMATS[suffix][job].partition(":")
    except KeyError:
        raise RadarConfigError(f"no radar {job}er for {suffix!r} files; known formats: "
                               f"{', '.join(FORMATS) or 'none'}") from None
    return getattr(importlib.import_module(module), name)


def _from_ti_cfg(path: Path) -> RadarConfig:
    """A TI mmWave SDK ``.cfg`` file through :func:`sionnafmcw.ti.cfg.read_ti_cfg` (:data:`FORMATS`)."""
    try:
        read_ti_cfg = format_function(".cfg", "read")
    except ImportError as err:
        raise RadarConfigError(f"{path}: reading a TI mmWave .cfg file needs sionnafmcw.ti.cfg, which cannot be "
                               f"imported ({err}); give a preset or a .json radar file instead") from None
    try:
        return read_ti_cfg(path)
    except RadarConfigError as err:
        if str(path) in str(err):
            raise
        raise RadarConfigError(f"{path}: {err}") from None
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise RadarConfigError(f"{path}: {err}") from None


def _ti_profile(name, start_ghz, idle_us, adc_start_us, ramp_end_us, slope_mhz_us, num_samples,
                rate_ksps, num_loops, tx_positions, rx_positions, tx_order, tx_power_dbm, noise_figure, device):
    """A TI mmWave SDK ``profileCfg``/``frameCfg`` pair in SI units, with the device's receiver
    (:mod:`sionnafmcw.ti.devices`: HPF codes 0/0 of the profiles, the complex-1x anti-alias filter,
    16-bit ADC at 30 dB gain, the data sheet's phase noise) and the board's element pattern."""
    from .ti import devices as ti

    f_stop = start_ghz * 1e9 + slope_mhz_us * 1e12 * ramp_end_us * 1e-6
    return RadarConfig(
        fc=start_ghz * 1e9,
        slope=slope_mhz_us * 1e12,
        fs=rate_ksps * 1e3,
        num_samples=num_samples,
        num_chirps=num_loops,
        chirp_interval=(idle_us + ramp_end_us) * 1e-6,
        adc_start_time=adc_start_us * 1e-6,
        ramp_end_time=ramp_end_us * 1e-6,
        tx_positions=tx_positions,
        rx_positions=rx_positions,
        tx_order=tx_order,
        tx_power=10 ** ((tx_power_dbm - 30) / 10),
        noise_figure=noise_figure,
        antenna_pattern=name,
        name=name,
        phase_noise=ti.phase_noise_table(device, start_ghz * 1e9, f_stop),
        if_filter=ti.if_chain(0, 0),
        adc_bits=ti.ADC_BITS,
        adc_full_scale=ti.ADC_FULL_SCALE,
        rx_gain=ti.RX_GAIN_DB,
    )


def preset_ti_awr1843boost() -> RadarConfig:
    """TI AWR1843BOOST with the mmWave SDK 3.x ``profile_3d.cfg`` of the xwr18xx demo.

    ``channelCfg 15 7 0``, ``profileCfg 0 77 267 7 57.14 0 0 70 1 256 5209 0 0 30``,
    chirps 0/1/2 on TX0/TX1/TX2, ``frameCfg 0 2 16 0 100 1 0``: 77 GHz, 70 MHz/us, 256 samples
    at 5.209 Msps, 16 loops of 3 Tx. TX power 12 dBm, noise figure 15 dB (AWR1843 data sheet,
    SWRS222). Element layout: :func:`_ti_three_tx_layout` at 77 GHz; element pattern
    ``"ti-awr1843boost"`` (:data:`sionnafmcw.antenna.BOARD_PATTERNS`); receiver of the data sheet
    (:mod:`sionnafmcw.ti.devices`): -93 dBc/Hz at 1 MHz (the 77-81 GHz sweep), HPF 175 + 350 kHz,
    complex-1x anti-alias filter, 16-bit ADC.
    """
    tx, rx = _ti_three_tx_layout(77e9)
    return _ti_profile("ti-awr1843boost", 77, 267, 7, 57.14, 70, 256, 5209, 16, tx, rx, [0, 1, 2], 12.0, 15.0,
                       "AWR1843")


def preset_ti_iwr6843isk() -> RadarConfig:
    """TI IWR6843ISK with the mmWave SDK ``profile_3d_isk.cfg`` of the 68xx out-of-box demo.

    ``profileCfg 0 60 359 7 57.14 0 0 70 1 256 5209 0 0 158``, chirps on TX0/TX1/TX2,
    ``frameCfg 0 2 16 0 100 1 0``: 60 GHz, 70 MHz/us, 256 samples at 5.209 Msps, 16 loops.
    TX power 12 dBm, noise figure 12 dB (IWR6843 data sheet, SWRS219). Layout as the other TI
    boards (:func:`_ti_three_tx_layout`) at 62 GHz, the centre of the 60-64 GHz band; element
    pattern ``"ti-iwr6843isk"``; receiver of the data sheet: -93 dBc/Hz at 1 MHz, HPF 175 + 350 kHz,
    complex-1x anti-alias filter, 16-bit ADC (``rxGain`` 158 encodes 30 dB).
    """
    tx, rx = _ti_three_tx_layout(62e9)
    return _ti_profile("ti-iwr6843isk", 60, 359, 7, 57.14, 70, 256, 5209, 16, tx, rx, [0, 1, 2], 12.0, 12.0,
                       "IWR6843")


def preset_ti_iwr1443boost() -> RadarConfig:
    """TI IWR1443BOOST with the mmWave SDK ``profile_2d.cfg`` of the xwr14xx demo.

    ``channelCfg 15 5 0`` (TX0 and TX2: the two azimuth transmitters, 2 lambda apart),
    ``profileCfg 0 77 429 7 57.14 0 0 70 1 256 5209 0 0 30``, ``frameCfg 0 1 16 0 100 1 0``:
    a 2 Tx x 4 Rx TDM array with an 8-element virtual ULA. TX power 12 dBm, noise figure
    15 dB (IWR1443 data sheet, SWRS211); element pattern ``"ti-iwr1443boost"``; receiver of the
    data sheet: -93 dBc/Hz at 1 MHz, HPF 175 + 350 kHz, complex-1x anti-alias filter, 16-bit ADC.
    """
    tx, rx = _ti_three_tx_layout(77e9)
    return _ti_profile("ti-iwr1443boost", 77, 429, 7, 57.14, 70, 256, 5209, 16, tx[[0, 2]], rx, [0, 1], 12.0, 15.0,
                       "IWR1443")


def preset_walk_77ghz() -> RadarConfig:
    """3 Tx x 4 Rx, 77 GHz configuration that sees the paper's walking person.

    60 MHz/us over a 25.6 us ADC window (1.54 GHz, 9.7 cm range bins), 128 samples at 5 Msps
    (12.5 m unambiguous range), 256 chirps per Tx with T_c = 35 us (CPI 26.9 ms < 1/24 s),
    unambiguous velocity 9.2 m/s (the circle walk peaks at 4.52 m/s) and 7.1 cm/s velocity bins.
    The 12 virtual elements form a lambda/2 uniform linear array along +y; the Rx row sits
    3 lambda past the last Tx.
    """
    d = _half_wavelength(77e9)
    tx = np.array([[0.0, 4 * d * m, 0.0] for m in range(3)])
    rx = _rx_row(4, d, tx_span=8 * d)
    return RadarConfig(
        fc=77e9, slope=60e12, fs=5e6, num_samples=128, num_chirps=256,
        chirp_interval=35e-6, adc_start_time=4e-6, ramp_end_time=30e-6,
        tx_positions=tx, rx_positions=rx, tx_order=[0, 1, 2],
        tx_power=10 ** ((12.0 - 30) / 10), noise_figure=12.0,
        antenna_pattern="tr38901", name="walk-77ghz",
    )


_PRESETS = {
    "ti-awr1843boost": preset_ti_awr1843boost,
    "ti-iwr6843isk": preset_ti_iwr6843isk,
    "ti-iwr1443boost": preset_ti_iwr1443boost,
    "walk-77ghz": preset_walk_77ghz,
}
