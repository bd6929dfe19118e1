r"""The IF (beat) filter chain: high-pass and anti-alias sections as analog prototypes, their response.

A chain is a cascade of sections (``RadarConfig.if_filter``, a list of dicts); each section is
an analog prototype of :mod:`scipy.signal` (``butter``, ``cheby1``, ``cheby2``, ``ellip``,
``bessel``) of a given ``order``, ``type`` (``"highpass"`` or ``"lowpass"``) and ``corner``
(Hz, the prototype's critical frequency: -3 dB for Butterworth, the pass-band edge for
Chebyshev I and elliptic, the stop-band edge for Chebyshev II), with ``ripple`` (dB, pass band)
and ``attenuation`` (dB, stop band) where the kind needs them. ``corner_fs`` instead of
``corner`` gives the corner as a fraction of the sampling rate :math:`F_s` (a decimation filter
scales with the rate). A low-pass section may be shifted to a ``centre`` (Hz, or ``centre_fs``):

.. math:: H_{sec}(f) = P\!\left(\frac{j (f - f_0)}{f_c}\right)

with :math:`P(s)` the prototype normalised to a critical frequency of 1 rad/s. A real I/Q
receiver filters I and Q with the same real filter: :math:`f_0 = 0`, the response is conjugate
symmetric and the band is :math:`|f| < f_c`. A *complex* decimation filter (TI's complex-1x
mode) passes only the positive beat frequencies :math:`[0, 2f_c]`: :math:`f_0 = f_c`
(:mod:`sionnafmcw.ti.devices`).

What a contribution sees. Within a chirp the beat of a contribution is a tone of frequency
:math:`f_p = A_p F_s` (:mod:`sionnafmcw.synthesis.phase`, :math:`\approx \mu\tau_p - f_{D,p}`,
its *physical* frequency, which may exceed :math:`F_s` beyond the unambiguous range). An LTI
filter turns a stationary tone :math:`e^{j2\pi f_p t}` into :math:`H(f_p)e^{j2\pi f_p t}`, so the
chain is applied as the complex gain :math:`H(f_p)` of every contribution (exact in steady
state, no extra cost in the beat sum), and sampling at :math:`F_s` then aliases what the chain
let through, as on a board. Neglected: the transient of the tone switched on at the ramp start.
For an input :math:`e^{j\omega t}` from :math:`t = 0` the output is
:math:`H(j\omega)e^{j\omega t} + \sum_i R_i e^{p_i t}` with :math:`R_i` the residues of
:math:`H(s)/(s - j\omega)` at the chain's poles :math:`p_i`; at the first ADC sample
(:math:`t_{adc}`) the neglected part is at most :math:`\sum_i |R_i| e^{\mathrm{Re}(p_i) t_{adc}}`
of the input tone (:func:`transient_bound`). For TI's high-pass pair (175 and 350 kHz,
:math:`|R_1| \le 1`, :math:`|R_2| \le 2`) and a 7 us ADC start: :math:`4.5\times10^{-4}`
(-67 dB), checked against :func:`scipy.signal.lsim` in ``tests/test_receiver.py``.
The anti-alias section of the TI chain stands for a digital decimation filter (its frequency
response only; its settling is what TI's ADC start time allows for).

Receiver noise passes the same chain. Thermal noise is white at the receiver input, so after the
chain and sampling its power density at the band frequency :math:`f \in [0, F_s)` is

.. math:: S_w(f) = k T_0 F \sum_k |H(f + k F_s)|^2

(every alias of :math:`f` folds onto it; without a low-pass section only :math:`k = 0`, the ideal
anti-alias filter the :math:`k T_0 F F_s` noise model assumes): :func:`noise_gain`.
"""

from __future__ import annotations

import copy
import functools
import json
import math
import numbers

import numpy as np

KINDS = ("butter", "cheby1", "cheby2", "ellip", "bessel")
TYPES = ("highpass", "lowpass")
_NEEDS = {"butter": (), "bessel": (), "cheby1": ("ripple",), "cheby2": ("attenuation",),
          "ellip": ("ripple", "attenuation")}
_KEYS = {"type", "kind", "order", "corner", "corner_fs", "ripple", "attenuation", "centre", "centre_fs", "label"}
#: Aliases summed in :func:`noise_gain` when the chain has a low-pass section (beyond, a 4th-order
#: section is down by more than 100 dB).
NOISE_ALIASES = 4


class IFFilterError(ValueError):
    """An IF filter specification that cannot work; the message names the section and the field."""


def _real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def check_chain(spec, where: str = "RadarConfig.if_filter") -> list:
    """Validate an IF chain spec (a list of section dicts, or None); return a normalised deep copy.

    Raises :class:`IFFilterError` naming the section index, the field and the fix.
    """
    if spec is None:
        return None
    if not isinstance(spec, (list, tuple)):
        raise IFFilterError(f"{where} must be a list of filter sections (dicts with type, kind, order, corner), "
                            f"got {type(spec).__name__}")
    out = []
    for i, section in enumerate(spec):
        at = f"{where}[{i}]"
        if not isinstance(section, dict):
            raise IFFilterError(f"{at} must be a dict with type, kind, order and corner (Hz) or corner_fs, "
                                f"got {section!r}")
        unknown = sorted(set(section) - _KEYS)
        if unknown:
            raise IFFilterError(f"{at}: unknown field(s) {', '.join(unknown)}; known: {', '.join(sorted(_KEYS))}")
        s = copy.deepcopy(dict(section))
        if s.get("type") not in TYPES:
            raise IFFilterError(f"{at}.type must be one of {', '.join(TYPES)}, got {s.get('type')!r}")
        if s.get("kind") not in KINDS:
            raise IFFilterError(f"{at}.kind must be one of {', '.join(KINDS)} (scipy.signal analog prototypes), "
                                f"got {s.get('kind')!r}")
        order = s.get("order")
        if not _real(order) or float(order) != int(order) or not 1 <= int(order) <= 20:
            raise IFFilterError(f"{at}.order must be an integer in 1..20, got {order!r}")
        s["order"] = int(order)
        if ("corner" in s) == ("corner_fs" in s):
            raise IFFilterError(f"{at}: give exactly one of corner (Hz) and corner_fs (fraction of the sampling rate)")
        for key in ("corner", "corner_fs"):
            if key in s and (not _real(s[key]) or not math.isfinite(s[key]) or s[key] <= 0):
                raise IFFilterError(f"{at}.{key} must be a positive number, got {s[key]!r}")
        if "centre" in s and "centre_fs" in s:
            raise IFFilterError(f"{at}: give at most one of centre (Hz) and centre_fs")
        for key in ("centre", "centre_fs"):
            if key in s:
                if s["type"] != "lowpass":
                    raise IFFilterError(f"{at}.{key}: only a lowpass section can be shifted to a centre frequency")
                if not _real(s[key]) or not math.isfinite(s[key]):
                    raise IFFilterError(f"{at}.{key} must be a finite number, got {s[key]!r}")
        for key in ("ripple", "attenuation"):
            if key in _NEEDS[s["kind"]]:
                if key not in s:
                    raise IFFilterError(f"{at}: a {s['kind']} section needs {key} (dB)")
                if not _real(s[key]) or not math.isfinite(s[key]) or s[key] <= 0:
                    raise IFFilterError(f"{at}.{key} must be a positive number of dB, got {s[key]!r}")
            elif key in s:
                raise IFFilterError(f"{at}.{key} means nothing for a {s['kind']} section; remove it")
        if "label" in s and not isinstance(s["label"], str):
            raise IFFilterError(f"{at}.label must be a string, got {s['label']!r}")
        for key in ("corner", "corner_fs", "centre", "centre_fs", "ripple", "attenuation"):
            if key in s:
                s[key] = float(s[key])
        out.append(s)
    return out


@functools.lru_cache(maxsize=64)
def _prototype(kind: str, btype: str, order: int, ripple, attenuation):
    """Zeros, poles and gain of the analog prototype with critical frequency 1 rad/s."""
    from scipy import signal

    if kind == "butter":
        return signal.butter(order, 1.0, btype=btype, analog=True, output="zpk")
    if kind == "bessel":
        return signal.bessel(order, 1.0, btype=btype, analog=True, output="zpk", norm="mag")
    if kind == "cheby1":
        return signal.cheby1(order, ripple, 1.0, btype=btype, analog=True, output="zpk")
    if kind == "cheby2":
        return signal.cheby2(order, attenuation, 1.0, btype=btype, analog=True, output="zpk")
    return signal.ellip(order, ripple, attenuation, 1.0, btype=btype, analog=True, output="zpk")


def section_zpk(section: dict):
    """``(z, p, k)`` of a section's prototype normalised to 1 rad/s (see the module docstring)."""
    return _prototype(section["kind"], section["type"], section["order"], section.get("ripple"),
                      section.get("attenuation"))


def corner(section: dict, fs: float) -> float:
    """The section's critical frequency (Hz) at sampling rate ``fs``."""
    return section["corner"] if "corner" in section else section["corner_fs"] * fs


def centre(section: dict, fs: float) -> float:
    """The section's centre frequency (Hz): 0 unless shifted."""
    if "centre" in section:
        return section["centre"]
    return section.get("centre_fs", 0.0) * fs


def _zpk_response(z, p, k, w: np.ndarray) -> np.ndarray:
    r""":math:`k\prod(jw - z)/\prod(jw - p)` at real ``w`` (1-D), in place: what :func:`scipy.signal.freqs_zpk`
    computes (``tests/test_receiver.py`` holds the chain to :func:`scipy.signal.freqs` of the same filters),
    without its ``[roots, points]`` temporaries (a frame's 1e6 contributions)."""
    s = 1j * w
    num = np.full(w.shape, complex(k))
    den = np.ones(w.shape, dtype=complex)
    term = np.empty(w.shape, dtype=complex)
    for root in z:
        np.subtract(s, root, out=term)
        num *= term
    for root in p:
        np.subtract(s, root, out=term)
        den *= term
    num /= den
    return num


def section_response(section: dict, f, fs: float) -> np.ndarray:
    r""":math:`H_{sec}(f)` (complex) at frequencies ``f`` (Hz, any shape): the prototype's zeros, poles and
    gain (:func:`scipy.signal.butter` ... with ``output="zpk"``) at the normalised frequency :math:`(f - f_0)/f_c`."""
    f = np.asarray(f, dtype=float)
    w = (f.ravel() - centre(section, fs)) / corner(section, fs)
    z, p, k = section_zpk(section)
    return _zpk_response(z, p, k, w).reshape(f.shape)


def response(chain, f, fs: float) -> np.ndarray:
    """The chain's complex gain :math:`H(f)` at physical frequencies ``f`` (Hz): the product of its sections
    (1 for an empty or None chain), evaluated in one pass over the chain's physical zeros and poles
    (:func:`chain_zpk`)."""
    f = np.asarray(f, dtype=float)
    if not chain:
        return np.ones(f.shape, dtype=complex)
    z, p, k = chain_zpk(chain, fs)
    return _zpk_response(z, p, k, 2 * np.pi * f.ravel()).reshape(f.shape)


#: Largest error of :func:`tabulated_response` (absolute, in units of the chain's gain, whose sections are
#: prototypes of unit pass-band gain): 1e-6 is 53 dB under the steady-state model's own neglected
#: transient (:func:`transient_bound`, 4.5e-4 for TI's chain) and 120 dB under the pass band.
TABLE_TOLERANCE = 1e-6
#: :func:`tabulated_response` evaluates exactly where its table would have more than this share of
#: the points asked for (nothing to gain).
TABLE_MAX_SHARE = 0.25


def table_step(chain, fs: float, tolerance: float = TABLE_TOLERANCE) -> float | None:
    r"""The node spacing :math:`\Delta f` (Hz) at which linear interpolation of the chain's :math:`H(f)`
    errs by at most ``tolerance``; None where the bound below does not apply (repeated or undamped
    poles, more zeros than poles, no chain).

    With distinct poles :math:`p_i` and at most as many zeros as poles, the chain is
    :math:`H(s) = k_\infty + \sum_i R_i/(s - p_i)` (:math:`R_i = k\prod_j(p_i - z_j)/\prod_{l\ne i}(p_i - p_l)`,
    :math:`k_\infty = k` for as many zeros as poles, else 0). On :math:`s = j\omega`,
    :math:`d^2H/d\omega^2 = -\sum_i 2R_i/(j\omega - p_i)^3` and :math:`|j\omega - p_i| \ge |\mathrm{Re}\,p_i|`, so

    .. math:: \Bigl|\frac{d^2H}{d\omega^2}\Bigr| \le M_2 = \sum_i \frac{2|R_i|}{|\mathrm{Re}\,p_i|^3}

    on the whole axis, and linear interpolation between nodes :math:`\Delta\omega` apart errs by at most
    :math:`\Delta\omega^2 M_2/8` (the remainder of the interpolating line). Hence
    :math:`\Delta f = \sqrt{8\epsilon/M_2}/(2\pi)`. A shifted (complex) section moves its poles along
    the imaginary axis, which leaves :math:`\mathrm{Re}\,p_i` and the bound as they are. For TI's
    IWR1443 chain (two high-pass poles, a sixth-order elliptic anti-alias filter) at
    :math:`\epsilon = 10^{-6}`: :math:`\Delta f = 124` Hz, some 4e4 nodes over the band."""
    if not chain:
        return None
    z, p, k = chain_zpk(chain, fs)
    if len(z) > len(p) or len(p) == 0 or np.any(p.real == 0.0):
        return None
    gaps = np.abs(p[:, None] - p[None, :]) + np.diag(np.full(len(p), np.inf))
    if gaps.min() <= 1e-9 * np.abs(p).max():
        return None
    residues = np.array([k * np.prod(pi - z) / np.prod(pi - np.delete(p, i)) for i, pi in enumerate(p)])
    m2 = float(np.sum(2.0 * np.abs(residues) / np.abs(p.real) ** 3))
    return math.sqrt(8.0 * tolerance / m2) / (2 * np.pi)


def tabulated_response(chain, f, fs: float, tolerance: float = TABLE_TOLERANCE) -> np.ndarray:
    r""":math:`H(f)` as :func:`response`, to within ``tolerance`` (:func:`table_step`): linear interpolation
    between exact values on the nodes :math:`n\Delta f` that span ``f`` (``benchmarks/if_filter_table.py``
    times it against the exact product over the chain's roots). The nodes are whole multiples of
    :math:`\Delta f`, so a contribution's gain depends on its frequency alone, not on the others'.
    Exact (:func:`response`) where the bound does not apply, a frequency is not finite, or the table
    would not be smaller than :data:`TABLE_MAX_SHARE` of ``f``."""
    f = np.asarray(f, dtype=float)
    step = table_step(chain, fs, tolerance)
    if step is None or f.size == 0 or not (np.isfinite(f.min()) and np.isfinite(f.max())):
        return response(chain, f, fs)
    lo, hi = math.floor(float(f.min()) / step), math.ceil(float(f.max()) / step)
    count = hi - lo + 2
    if count > TABLE_MAX_SHARE * f.size:
        return response(chain, f, fs)
    nodes = response(chain, (lo + np.arange(count)) * step, fs)
    x = f.ravel() / step - lo
    index = x.astype(np.int64)
    np.minimum(index, count - 2, out=index)
    x -= index
    out = nodes[index]
    slope = nodes[index + 1]
    slope -= out
    slope *= x
    out += slope
    return out.reshape(f.shape)


def has_lowpass(chain) -> bool:
    return any(s["type"] == "lowpass" for s in chain or ())


def noise_gain(chain, f, fs: float) -> np.ndarray:
    r""":math:`\sum_k |H(f + kF_s)|^2` at band frequencies ``f`` (module docstring): the power gain of white
    noise folded onto ``f`` by sampling; :math:`|H(f)|^2` alone when the chain has no low-pass section."""
    f = np.asarray(f, dtype=float)
    aliases = range(-NOISE_ALIASES, NOISE_ALIASES + 1) if has_lowpass(chain) else (0,)
    return sum(np.abs(response(chain, f + k * fs, fs)) ** 2 for k in aliases)


def noise_bandwidth(chain, fs: float, points: int = 4096) -> float:
    r"""Equivalent noise bandwidth :math:`\int_0^{F_s} \sum_k|H(f + kF_s)|^2\,df` (Hz) of the chain:
    :math:`F_s` for no chain; thermal noise per sample is :math:`k T_0 F` times this."""
    if not chain:
        return float(fs)
    f = (np.arange(points) + 0.5) * fs / points
    return float(noise_gain(chain, f, fs).mean() * fs)


def chain_zpk(chain, fs: float):
    r"""Zeros, poles (rad/s, complex) and gain of the whole chain in the physical variable
    :math:`s = j2\pi f`: a prototype root :math:`r` maps to :math:`2\pi f_c r + j2\pi f_0`, the gain
    to :math:`k (2\pi f_c)^{n_p - n_z}`."""
    zeros, poles, gain = [], [], 1.0 + 0j
    for section in chain or ():
        z, p, k = section_zpk(section)
        wc, w0 = 2 * np.pi * corner(section, fs), 2 * np.pi * centre(section, fs)
        zeros.extend(wc * np.asarray(z) + 1j * w0)
        poles.extend(wc * np.asarray(p) + 1j * w0)
        gain *= k * wc ** (len(p) - len(z))
    return np.asarray(zeros, complex), np.asarray(poles, complex), gain


def transient_bound(chain, f: float, t: float, fs: float) -> float:
    r""":math:`\sum_i |R_i| e^{\mathrm{Re}(p_i) t}` (module docstring): the largest part of the chain's output at
    time ``t`` after a unit tone of frequency ``f`` (Hz) was switched on that the steady-state gain
    :math:`H(f)` leaves out (distinct poles)."""
    z, p, k = chain_zpk(chain, fs)
    jw = 2j * np.pi * f
    total = 0.0
    for i, pole in enumerate(p):
        others = np.delete(p, i)
        residue = k * np.prod(pole - z) / np.prod(pole - others) / (pole - jw)
        total += abs(residue) * math.exp(pole.real * t)
    return float(total)


def key(chain) -> str:
    """A hashable, canonical form of a chain (JSON with sorted keys)."""
    return json.dumps(chain, sort_keys=True)


__all__ = ["IFFilterError", "KINDS", "NOISE_ALIASES", "TABLE_MAX_SHARE", "TABLE_TOLERANCE", "TYPES", "centre",
           "chain_zpk", "check_chain", "corner", "has_lowpass", "key", "noise_bandwidth", "noise_gain", "response",
           "section_response", "section_zpk", "table_step", "tabulated_response", "transient_bound"]
