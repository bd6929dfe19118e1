r"""Antenna element power patterns: one gain function for Sionna, the PO kernel, the pixel engine and point targets.

Every element of the radar (Tx and Rx) carries the same pattern, with boresight along the
radar's local :math:`+x` axis. Directions are given in the radar frame as zenith angle
:math:`\theta` (from local :math:`+z`) and azimuth :math:`\varphi` (from local :math:`+x`
towards :math:`+y`), as in Sionna RT; elevation is :math:`90^\circ - \theta`.

``RadarConfig.antenna_pattern`` is a name of :data:`PATTERNS` or a measured pattern (a dict read
from a file, :func:`load_pattern_file`). Each pattern is written once, as a formula on an array
namespace (:class:`ElementPattern`): NumPy evaluates it here (:func:`antenna_gain`, used by
:meth:`sionnafmcw.Echoes.point_targets`, the pixel engine, :func:`sionnafmcw.physical_optics.element_gains`
and the path engine's per-element ratio), Dr.Jit evaluates the same formula in the PO kernel and in
the pattern registered with Sionna RT's antenna-pattern registry
(:func:`sionnafmcw.sionna_rt.sionna_antenna_pattern`), so both engines and the analytic point
targets apply one and the same gain.

``"iso"``
    :math:`G = 1`.
``"tr38901"``
    3GPP TR 38.901 Table 7.3-1 element (Sionna RT's own ``"tr38901"``):

    .. math::
        A_V = -\min\left(12\left(\tfrac{\theta - 90^\circ}{\theta_{3dB}}\right)^2, A_m\right),\quad
        A_H = -\min\left(12\left(\tfrac{\varphi}{\varphi_{3dB}}\right)^2, A_m\right),\quad
        G_{dB} = G_0 - \min(-(A_V + A_H), A_m)

    with :math:`G_0 = 8` dBi, :math:`\theta_{3dB} = \varphi_{3dB} = 65^\circ`, :math:`A_m = 30` dB
    (:class:`ParabolicPattern`).
``"ti-awr1843boost"``, ``"ti-iwr1443boost"``, ``"ti-iwr6843isk"``
    The same form with the boards' own peak gain and half-power beamwidths in azimuth and elevation
    (:data:`BOARD_PATTERNS`, with their sources), 30 dB beyond the main lobe (TR 38.901's floor: the
    boards' user guides plot the main lobe only).

A measured pattern gives two principal cuts, azimuth (:math:`\theta = 90^\circ`) and elevation
(:math:`\varphi = 0`), in dBi on angle grids in degrees; off the cuts the gain is their sum in dB
less the boresight gain, the separable form TR 38.901 uses:

.. math:: G_{dB}(\varphi, \epsilon) = G_{az}(\varphi) + G_{el}(\epsilon) - G_0,\qquad
          G_0 = \tfrac12\,(G_{az}(0) + G_{el}(0)),

linearly interpolated in dB, each cut's end values beyond its grid (:class:`MeasuredPattern`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math

import numpy as np

# ---------------------------------------------------------------------------------------- array namespace
class NumpyOps:
    """The few array operations the pattern formulas need, for NumPy (Dr.Jit's: :mod:`sionnafmcw.sionna_rt`)."""

    minimum = staticmethod(np.minimum)
    maximum = staticmethod(np.maximum)
    floor = staticmethod(np.floor)

    @staticmethod
    def clip(x, lo, hi):
        return np.clip(x, lo, hi)

    @staticmethod
    def gather(table: np.ndarray, index):
        return table[np.asarray(index, dtype=np.int64)]


NUMPY = NumpyOps()


def _wrap(phi, ops):
    """Azimuth wrapped to :math:`[-\\pi, \\pi)`."""
    return phi - 2 * np.pi * ops.floor((phi + np.pi) / (2 * np.pi))


# ---------------------------------------------------------------------------------------- patterns
class ElementPattern:
    """An element power pattern: :meth:`gain_db` on any array namespace; ``name`` for listings,
    ``registry_name`` for Sionna RT's antenna-pattern registry."""

    name: str = ""
    registry_name: str = ""

    def gain_db(self, theta, phi, ops=NUMPY):
        """Gain (dBi) towards zenith ``theta`` and azimuth ``phi`` (rad)."""
        raise NotImplementedError

    def power_gain(self, theta, phi) -> np.ndarray:
        """Linear power gain (NumPy)."""
        theta = np.asarray(theta, dtype=float)
        phi = np.asarray(phi, dtype=float)
        shape = np.broadcast(theta, phi).shape
        return np.broadcast_to(10.0 ** (np.asarray(self.gain_db(theta, phi)) / 10.0), shape).copy()

    def peak_gain_db(self) -> float:
        """Boresight gain (dBi)."""
        return float(self.gain_db(np.array(np.pi / 2), np.array(0.0)))


class IsotropicPattern(ElementPattern):
    name = registry_name = "iso"

    def gain_db(self, theta, phi, ops=NUMPY):
        return 0.0 * theta + 0.0 * phi


class ParabolicPattern(ElementPattern):
    r"""TR 38.901's element form with peak gain ``gain_dbi``, half-power beamwidths ``azimuth_beamwidth``
    and ``elevation_beamwidth`` (degrees) and ``max_attenuation`` (dB) beyond the main lobe."""

    def __init__(self, name, gain_dbi, azimuth_beamwidth, elevation_beamwidth, max_attenuation=30.0,
                 registry_name=None, source=""):
        self.name = name
        self.registry_name = registry_name or f"sionnafmcw-{name}"
        self.gain_dbi = float(gain_dbi)
        self.azimuth_beamwidth = float(azimuth_beamwidth)
        self.elevation_beamwidth = float(elevation_beamwidth)
        self.max_attenuation = float(max_attenuation)
        self.source = source

    def gain_db(self, theta, phi, ops=NUMPY):
        a_m = self.max_attenuation
        phi = _wrap(phi, ops)
        a_v = -ops.minimum(12.0 * ((theta - np.pi / 2) / math.radians(self.elevation_beamwidth)) ** 2, a_m)
        a_h = -ops.minimum(12.0 * (phi / math.radians(self.azimuth_beamwidth)) ** 2, a_m)
        return self.gain_dbi - ops.minimum(-(a_v + a_h), a_m)


#: Resolution (degrees) of the uniform grids measured cuts are resampled onto (linear in dB).
CUT_STEP_DEG = 0.05


class MeasuredPattern(ElementPattern):
    """Two measured principal cuts (module docstring); ``spec`` as :func:`check_measured` returns it."""

    def __init__(self, spec: dict):
        self.spec = spec
        digest = hashlib.sha1(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]
        self.name = spec.get("name") or f"measured-{digest}"
        self.registry_name = f"sionnafmcw-measured-{digest}"
        self.cuts = []
        for axis in ("azimuth", "elevation"):
            angles = np.asarray(spec[f"{axis}_deg"], dtype=float)
            gains = np.asarray(spec[f"{axis}_dbi"], dtype=float)
            count = int(round((angles[-1] - angles[0]) / CUT_STEP_DEG)) + 1
            grid = angles[0] + CUT_STEP_DEG * np.arange(count)
            self.cuts.append((float(angles[0]), np.interp(grid, angles, gains)))
        self.boresight = 0.5 * (self._cut(0, np.array(0.0), NUMPY) + self._cut(1, np.array(0.0), NUMPY))

    def _cut(self, which: int, angle_deg, ops):
        start, table = self.cuts[which]
        index = ops.clip((angle_deg - start) / CUT_STEP_DEG, 0.0, float(len(table) - 1))
        lower = ops.minimum(ops.floor(index), float(len(table) - 2)) if len(table) > 1 else 0.0 * index
        frac = index - lower
        if len(table) == 1:
            return ops.gather(table, lower)
        return ops.gather(table, lower) * (1.0 - frac) + ops.gather(table, lower + 1.0) * frac

    def gain_db(self, theta, phi, ops=NUMPY):
        azimuth = _wrap(phi, ops) * (180.0 / np.pi)
        elevation = 90.0 - theta * (180.0 / np.pi)
        return self._cut(0, azimuth, ops) + self._cut(1, elevation, ops) - float(self.boresight)


# ---------------------------------------------------------------------------------------- the boards
#: The TI boards' elements: peak gain (dBi) and half-power beamwidths (degrees), with their sources.
#: Peak gains from the user guides' text; beamwidths read off their H-plane (azimuth) and E-plane
#: (elevation) pattern figures. A board's own measurement can replace them (a measured pattern file).
BOARD_PATTERNS = {
    "ti-awr1843boost": dict(gain_dbi=10.5, azimuth_beamwidth=56.0, elevation_beamwidth=28.0,
                            source="TI SPRUIM4B (xWR1843BOOST user's guide), section Antenna: peak gain > 10.5 dBi "
                                   "over 76-81 GHz; H-/E-plane patterns 3 dB down at about +-28 and +-14 degrees"),
    "ti-iwr1443boost": dict(gain_dbi=9.0, azimuth_beamwidth=56.0, elevation_beamwidth=28.0,
                            source="TI SWRU518 (xWR1443BOOST user's guide), section Antenna: peak gain > 9 dBi "
                                   "over 76-81 GHz; the same series-fed patch columns as the xWR1843BOOST"),
    "ti-iwr6843isk": dict(gain_dbi=7.0, azimuth_beamwidth=120.0, elevation_beamwidth=30.0,
                          source="TI SWRU546 (IWR6843ISK / MMWAVEICBOOST user's guide), antenna section: the "
                                 "ISK's wide-field patch array, +-60 degrees in azimuth and +-15 degrees in elevation "
                                 "at 3 dB, about 7 dBi"),
}

_NAMED = {
    "iso": IsotropicPattern(),
    "tr38901": ParabolicPattern("tr38901", 8.0, 65.0, 65.0, 30.0, registry_name="tr38901",
                                source="3GPP TR 38.901 Table 7.3-1"),
    **{name: ParabolicPattern(name, **data) for name, data in BOARD_PATTERNS.items()},
}
#: The names ``RadarConfig.antenna_pattern`` accepts (besides a measured pattern).
PATTERNS = tuple(_NAMED)


# ---------------------------------------------------------------------------------------- measured patterns
_MEASURED_KEYS = ("azimuth_deg", "azimuth_dbi", "elevation_deg", "elevation_dbi")


def check_measured(spec: dict, where: str = "antenna pattern") -> dict:
    """Validate a measured pattern dict; return a normalised copy (lists of floats, ``name``/``source`` strings).

    Raises ValueError naming ``where`` (the file, or the field) and the key at fault."""
    if not isinstance(spec, dict):
        raise ValueError(f"{where}: a measured pattern is a dict with {', '.join(_MEASURED_KEYS)}, got {spec!r}")
    allowed = set(_MEASURED_KEYS) | {"name", "source"}
    unknown = sorted(set(spec) - allowed)
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {', '.join(unknown)}; a measured pattern has "
                         f"{', '.join(_MEASURED_KEYS)} and optionally name, source")
    missing = [k for k in _MEASURED_KEYS if k not in spec]
    if missing:
        raise ValueError(f"{where}: missing {', '.join(missing)} (two principal cuts: angles in degrees, gains in dBi)")
    out = {k: str(spec[k]) for k in ("name", "source") if k in spec}
    for axis, limit in (("azimuth", 180.0), ("elevation", 90.0)):
        try:
            angles = np.asarray(spec[f"{axis}_deg"], dtype=float)
            gains = np.asarray(spec[f"{axis}_dbi"], dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{where}: {axis}_deg and {axis}_dbi must be lists of numbers") from None
        if angles.ndim != 1 or gains.shape != angles.shape or angles.size < 2:
            raise ValueError(f"{where}: {axis}_deg and {axis}_dbi must be equally long lists of at least 2 numbers, "
                             f"got {angles.shape} and {gains.shape}")
        if not (np.all(np.isfinite(angles)) and np.all(np.isfinite(gains))):
            raise ValueError(f"{where}: {axis}_deg and {axis}_dbi must be finite numbers")
        if np.any(np.diff(angles) <= 0):
            raise ValueError(f"{where}: {axis}_deg must increase strictly (degrees)")
        if angles[0] > 0 or angles[-1] < 0 or angles[0] < -limit or angles[-1] > limit:
            raise ValueError(f"{where}: {axis}_deg must span boresight (0) within [-{limit:g}, {limit:g}] degrees, "
                             f"got {angles[0]:g}..{angles[-1]:g}")
        out[f"{axis}_deg"] = angles.tolist()
        out[f"{axis}_dbi"] = gains.tolist()
    az0 = float(np.interp(0.0, out["azimuth_deg"], out["azimuth_dbi"]))
    el0 = float(np.interp(0.0, out["elevation_deg"], out["elevation_dbi"]))
    if abs(az0 - el0) > 1.0:
        raise ValueError(f"{where}: the azimuth and elevation cuts disagree at boresight ({az0:.2f} vs {el0:.2f} dBi); "
                         "both cuts pass through boresight, so they must agree there (within 1 dB)")
    return out


def load_pattern_file(path) -> dict:
    """A measured pattern from a file: JSON with ``azimuth_deg``, ``azimuth_dbi``, ``elevation_deg``,
    ``elevation_dbi`` (optionally ``name``, ``source``), or CSV with the header
    ``angle_deg,azimuth_dbi,elevation_dbi`` (both cuts on one angle grid). The errors name the file
    and the field."""
    from pathlib import Path

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such antenna pattern file (JSON or CSV with angles in degrees, gains in dBi)")
    text = path.read_text()
    if path.suffix.lower() == ".csv":
        lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
        header = [h.strip() for h in lines[0].split(",")] if lines else []
        if header != ["angle_deg", "azimuth_dbi", "elevation_dbi"]:
            raise ValueError(f"{path}: the first line must be the header angle_deg,azimuth_dbi,elevation_dbi, "
                             f"got {lines[0] if lines else 'nothing'!r}")
        rows = []
        for number, line in enumerate(lines[1:], start=2):
            try:
                rows.append([float(v) for v in line.split(",")])
            except ValueError:
                raise ValueError(f"{path}, data line {number}: expected three numbers, got {line!r}") from None
            if len(rows[-1]) != 3:
                raise ValueError(f"{path}, data line {number}: expected three numbers, got {line!r}")
        table = np.asarray(rows, dtype=float).reshape(-1, 3)
        spec = {"azimuth_deg": table[:, 0], "azimuth_dbi": table[:, 1], "elevation_deg": table[:, 0],
                "elevation_dbi": table[:, 2], "name": path.stem, "source": path.name}
    else:
        try:
            spec = json.loads(text)
        except json.JSONDecodeError as err:
            raise ValueError(f"{path}: invalid JSON at line {err.lineno}, column {err.colno}: {err.msg}") from None
        if isinstance(spec, dict):
            spec = {"name": path.stem, "source": path.name, **spec}
    return check_measured(spec, where=str(path))


# ---------------------------------------------------------------------------------------- the gain API
@functools.lru_cache(maxsize=32)
def _measured(canonical: str) -> MeasuredPattern:
    return MeasuredPattern(json.loads(canonical))


def element_pattern(spec) -> ElementPattern:
    """The :class:`ElementPattern` of a ``RadarConfig.antenna_pattern`` value (a name or a measured dict)."""
    if isinstance(spec, ElementPattern):
        return spec
    if isinstance(spec, dict):
        return _measured(json.dumps(check_measured(spec), sort_keys=True))
    check_pattern(spec)
    return _NAMED[spec]


def check_pattern(spec):
    """Return ``spec`` if it is a known pattern name or a valid measured pattern, else raise a ValueError
    listing the choices."""
    if isinstance(spec, dict):
        check_measured(spec, where="antenna_pattern")
        return spec
    if isinstance(spec, ElementPattern):
        return spec
    if not isinstance(spec, str) or spec not in _NAMED:
        raise ValueError(
            f"antenna_pattern={spec!r} is not supported; choose one of {', '.join(PATTERNS)} or give a measured "
            "pattern file (.json or .csv: angles in degrees, gains in dBi)"
        )
    return spec


def antenna_gain(pattern, theta, phi) -> np.ndarray:
    """Linear power gain of one element towards zenith ``theta`` and azimuth ``phi`` (rad)."""
    return element_pattern(pattern).power_gain(theta, phi)


def direction_angles(direction) -> tuple[np.ndarray, np.ndarray]:
    """Zenith and azimuth angles (rad) of direction vectors ``[..., 3]`` in the radar frame."""
    d = np.asarray(direction, dtype=float)
    norm = np.linalg.norm(d, axis=-1)
    theta = np.arccos(np.clip(d[..., 2] / norm, -1.0, 1.0))
    phi = np.arctan2(d[..., 1], d[..., 0])
    return theta, phi


__all__ = ["BOARD_PATTERNS", "CUT_STEP_DEG", "ElementPattern", "IsotropicPattern", "MeasuredPattern", "NUMPY",
           "NumpyOps", "PATTERNS", "ParabolicPattern", "antenna_gain", "check_measured", "check_pattern",
           "direction_angles", "element_pattern", "load_pattern_file"]
