r"""TDM-MIMO FMCW beat synthesis: :class:`~sionnafmcw.Echoes` -> IF cube.

:func:`synthesize` evaluates, for every chirp :math:`l`, Tx :math:`m`, Rx :math:`n` and sample
:math:`k` (NOTES section 2),

.. math::
    x_{lmnk} = \sqrt{P_t}\sum_p \bar a_{mnp}\,
      e^{j2\pi(f_c\tau_{mnp} + \mu\tau_{mnp} t_k - \mu\tau_{mnp}^2/2)} + w_{lmnk},
    \qquad \tau_{mnp} = \tau_{0,mnp} - \frac{f_{D,mnp}}{f_c}\,(s_{lm} + t_k)

(plus :math:`-\tfrac12(\dot f_{D,mnp}/f_c)(s_{lm} + t_k)^2` for contributions with a Doppler rate:
motion within the CPI, :class:`~sionnafmcw.Echoes`), with the exact TDM chirp start
:math:`s_{lm} = (lM + q_m)T_c`, fast time
:math:`t_k = t_{adc} + k/F_s`, carrier phase, beat frequency, Doppler, range migration inside
the CPI, radar-equation power :math:`P_r = P_t|a|^2` and thermal noise :math:`w`
(:mod:`~sionnafmcw.synthesis.noise`). Compared with eq. (1) of the reference paper this adds
the transmit-time offset :math:`q_m T_c` of each Tx inside a TDM block and the carrier phase
:math:`f_c\tau`.

Two implementations: ``method="direct"`` (:mod:`.direct`, the reference sum) and
``method="nufft"`` (:mod:`.nufft`, type-3 NUFFT, used everywhere). The fast sum is as accurate
as the noise needs (:mod:`.accuracy`): with noise on, its error per sample stays
``noise_margin_db`` (20 dB) below the thermal noise :math:`\sqrt{k T_0 F F_s}` for the echoes at
hand, which usually allows single precision; with noise off it keeps tight relative tolerances
(1e-7) unless ``max_error`` is given. Gains are frozen at the
CPI start: over a CPI :math:`T` a reflector at range :math:`R` changes :math:`|a|` by about
:math:`2\dot R T/R` (8 % at 3 m, 4.5 m/s, 27 ms), which only affects Doppler sidelobes.

Static block. The beat sum is linear in the contributions: with the static block :math:`S`
(contributions ``[..., :static_count]`` of :class:`~sionnafmcw.Echoes`, the same in every frame
with the same ``static_key``) and the rest :math:`D`,

.. math:: x_{lmnk} = \sqrt{P_t}\sum_{p\in S}(\ldots) + \sqrt{P_t}\sum_{p\in D}(\ldots) + w_{lmnk}.

The cube depends only on the echoes (the chirp timing is relative to the CPI start, not on the
frame time), so the first sum of one frame is the first sum of every frame with the same key:
:func:`synthesize` computes it once (``static_cache``) and reuses it exactly. The noise
:math:`w` is drawn per frame after the two sums are added.
"""

from __future__ import annotations

import warnings

import numpy as np

from .accuracy import NOISE_MARGIN_DB, UPSTREAM_SHARE, SynthesisAccuracy, noise_error_budget
from .direct import beat_direct
from .noise import thermal_noise
from .nufft import beat_nufft, synthesis_accuracy

METHODS = ("nufft", "direct")


class AdcClippingWarning(UserWarning):
    """The ADC in the cube clipped I/Q values (``RadarConfig.adc_bits``): the echoes exceed its full scale."""


def synthesize(echoes, radar, frame_time: float = 0.0, noise: bool = True, rng=None,
               method: str = "nufft", leakage_db: float | None = None,
               noise_margin_db: float = NOISE_MARGIN_DB, max_error: float | None = None,
               static_cache: dict | None = None, phase_noise: bool | None = None,
               stats: dict | None = None) -> np.ndarray:
    r"""IF cube ``[chirp, tx, rx, sample]`` (complex64, sqrt(W), tx in physical order) of one CPI.

    Parameters
    ----------
    echoes : Echoes
        Contributions at the CPI start ``frame_time``; shape must match the radar's array.
    radar : RadarConfig
    frame_time : float
        CPI start :math:`t_n` (s) to which ``echoes`` refer; the chirp timing is relative to it,
        so the cube itself depends only on the echoes.
    noise : bool
        Add receiver thermal noise :math:`k T_0 F F_s` per sample (coloured by the radar's IF chain,
        :func:`sionnafmcw.receiver.shape_noise`).
    rng : numpy.random.Generator or int, optional
        Noise source (a seed gives a reproducible cube); thermal noise first, then phase noise.
    method : {"nufft", "direct"}
    leakage_db : float, optional
        Add direct Tx-Rx coupling of this power level (dB) to every channel
        (:meth:`Echoes.leakage`); None (default) models none. It is appended after the echoes,
        so it is part of the per-frame sum, never of the static block.
    noise_margin_db : float
        With noise on, the fast sum's worst-case error per sample plus what the engines' PO merge may
        err (:data:`~sionnafmcw.synthesis.accuracy.UPSTREAM_SHARE` of it) stays this far below the
        thermal noise :math:`\sqrt{k T_0 F F_s}` (:func:`~sionnafmcw.synthesis.accuracy.noise_error_budget`).
    max_error : float, optional
        Explicit error budget per sample (sqrt(W)) for ``method="nufft"``, overriding the noise
        margin; with noise off and no ``max_error`` the tight default tolerances are used.
    static_cache : dict, optional
        Reuse the noise-free cube of the echoes' static block (``echoes.static_key`` not None,
        ``static_count`` > 0, ``method="nufft"``) across calls: ``static_cache[static_key]`` holds
        ``(radar, budget, cube, weighted cube or None)`` (the static sum's budget, below; the
        delay-weighted cube when phase noise needs it) and is reused when the radar and the budget
        are the same (and the weighted cube is there when needed), else computed with
        :func:`beat_nufft` and stored; the dict keeps one entry (a new key replaces
        the old one), so it costs one cube of memory. Ignored for ``method="direct"`` (exact
        anyway) and for echoes without a static block.
    phase_noise : bool, optional
        Apply the radar's phase noise (``radar.phase_noise``; nothing when it is None). Default: as
        ``noise`` (a noise-free cube is free of every random effect).
    stats : dict, optional
        Filled with ``adc_clipped`` (I/Q values the ADC clipped, 0 without an ADC) and
        ``adc_values`` (I/Q values in the cube). Clipping also raises an :class:`AdcClippingWarning`.

    Notes
    -----
    With a static block the cube is :math:`x_S + x_D` (linearity, see the module docstring),
    each sum by its own :func:`beat_nufft`. The bound :math:`E_{\max}` per sample must hold for
    the sum, so when there is a budget (the noise budget with noise on, or ``max_error``) the
    static sum gets :math:`\epsilon_S E_{\max}` and the per-frame sum the rest,
    :math:`|e_S + e_D| \le \epsilon_S E_{\max} + (1 - \epsilon_S)E_{\max}`, with
    :data:`STATIC_BUDGET_SHARE` :math:`\epsilon_S = 0.1`: the static cube is computed once per
    block, so its tighter tolerance costs once, and the sum computed every frame gets 90 % (on the
    circle walk one Taylor term fewer and 10 % less time per frame than with half each:
    ``benchmarks/synthesis_split.py``). Without a
    budget (noise off) each sum keeps the tight relative defaults; those bounds are proportional
    to a channel's strength sum :math:`\sqrt{P_t}\sum_p|a_p|` (times terms in the residual
    phases, which are 0 for the static block), and the strength sums of :math:`S` and :math:`D`
    add up to the whole's, so every channel keeps the bound of the whole echoes.
    """
    from .. import receiver

    if echoes.num_tx != radar.num_tx or echoes.num_rx != radar.num_rx:
        raise ValueError(
            f"synthesize: echoes are for {echoes.num_tx} Tx x {echoes.num_rx} Rx elements but the radar "
            f"{radar.name!r} has {radar.num_tx} x {radar.num_rx}"
        )
    if leakage_db is not None:
        from ..echoes import Echoes

        echoes = Echoes.concatenate([echoes, Echoes.leakage(radar, leakage_db)])
    if not np.isfinite(frame_time):
        raise ValueError(f"synthesize: frame_time must be finite, got {frame_time!r}")
    with_phase_noise = radar.phase_noise is not None and (noise if phase_noise is None else bool(phase_noise))
    split = method == "nufft" and static_cache is not None and echoes.static_key is not None \
        and echoes.static_count > 0
    if not split:   # split: each part through the IF chain by _static_and_dynamic (the static one once)
        echoes = receiver.filter_echoes(echoes, radar)
    weighted = None
    if method == "nufft":
        if max_error is None and noise:
            max_error = (1.0 - UPSTREAM_SHARE) * noise_error_budget(radar, noise_margin_db)
        if split:
            cube, weighted = _static_and_dynamic(echoes, radar, max_error, static_cache, with_phase_noise)
        elif with_phase_noise:
            cube, weighted = beat_nufft(echoes, radar, max_error=max_error, weights=_delay_weights(echoes, radar))
        else:
            cube = beat_nufft(echoes, radar, max_error=max_error)
    elif method == "direct":
        if with_phase_noise:
            cube, weighted = beat_direct(echoes, radar, weights=_delay_weights(echoes, radar))
        else:
            cube = beat_direct(echoes, radar)
    else:
        raise ValueError(f"synthesize: method={method!r} is unknown; choose one of {', '.join(METHODS)}")
    cube = cube.astype(np.complex64)  # a copy: the cached static cube is never changed
    if noise or with_phase_noise:
        rng = np.random.default_rng(rng)
    if noise:
        cube += receiver.shape_noise(thermal_noise(cube.shape, radar, rng), radar)
    if with_phase_noise:
        frequency = receiver.phase_noise.frequency_noise(radar, rng)
        cube += receiver.phase_noise.term(frequency, weighted).astype(np.complex64)
    if radar.iq_imbalance is not None:
        cube = receiver.iq_imbalance.apply(cube, radar.iq_imbalance)
    clipped = 0
    if radar.adc_bits is not None:
        cube, clipped = receiver.adc.quantise(cube, radar)
        if clipped:
            warnings.warn(f"synthesize: the {radar.adc_bits}-bit ADC of radar {radar.name!r} clipped {clipped} of "
                          f"{2 * cube.size} I/Q values ({100 * clipped / (2 * cube.size):.3g} %): the echoes exceed "
                          f"its full scale ({radar.adc_full_scale:.3g} W at {radar.rx_gain:g} dB gain); lower "
                          "rx_gain or raise adc_full_scale", AdcClippingWarning, stacklevel=2)
    if stats is not None:
        stats["adc_clipped"] = int(clipped)
        stats["adc_values"] = int(2 * cube.size)
    return cube


def _delay_weights(echoes, radar) -> np.ndarray:
    """The phase-noise weights of ``echoes``: their delays at the CPI centre
    (:mod:`sionnafmcw.receiver.phase_noise`)."""
    from ..receiver.phase_noise import delay_weights

    return delay_weights(echoes.tau, echoes.doppler, radar)


def _contributions(echoes, start: int, stop: int | None = None):
    """Contributions ``[..., start:stop]`` of ``echoes`` (views; no labels, no static block)."""
    return echoes.contributions(start, stop)


#: Share of the error budget given to the static block's sum (computed once per block); the
#: sum computed every frame gets the rest (:func:`synthesize`, Notes).
STATIC_BUDGET_SHARE = 0.1


#: Most contributions of the static block summed by one :func:`beat_nufft` call (:func:`static_block_cube`):
#: a furnished room's 452k in 4 chunks took the first frame's peak memory to 0.71x and the static NUFFT
#: from 1.9 to 1.5 CPU-s, the walk's 747k in 6 to 0.69x and 2.6 to 2.5 (``benchmarks/first_frame.py``).
STATIC_CHUNK = 131_072


def static_block_cube(echoes, radar, max_error: float | None, weighted: bool = False, chunk: int | None = None):
    r"""Noise-free cube of the static block of ``echoes`` (contributions ``[..., :static_count]``, before
    the IF chain) and its delay-weighted cube when ``weighted`` (else None), summed in chunks of at most
    ``chunk`` contributions (default :data:`STATIC_CHUNK`): each chunk through the IF chain and
    :func:`beat_nufft`, the cubes added.

    The beat sum is linear in the contributions and the IF chain's gain of a contribution depends on
    that contribution alone, so the chunks' cubes add up to the whole's. Error: with the budget
    :math:`E` (``max_error``, per sample) chunk :math:`c` gets
    :math:`E_c = E\,s_c/\sum_{c'} s_{c'}`, :math:`s_c = \max_{m,n}\sum_{p\in c}|a_{mnp}|` (the bounds of
    :mod:`.accuracy` grow with these strength sums, as :func:`beat_nufft` splits its rate classes), so
    by the triangle inequality the sum's error is at most :math:`\sum_c E_c = E`, the whole's budget.
    Without a budget each chunk keeps the tight relative tolerances. What it buys: the type-3 plans'
    source arrays, the strength vectors of the Taylor terms and the filtered gains are a chunk's, not
    the whole block's (a room's 450-750k contributions): ``benchmarks/first_frame.py`` measures the
    peak memory and CPU of both."""
    from .. import receiver

    total = echoes.static_count
    chunk = STATIC_CHUNK if chunk is None else int(chunk)
    if chunk < 1:
        raise ValueError(f"static_block_cube: chunk must be >= 1 contribution, got {chunk!r}")
    edges = np.linspace(0, total, max(1, -(-total // chunk)) + 1).round().astype(np.int64)
    chunks = [_contributions(echoes, int(a), int(b)) for a, b in zip(edges[:-1], edges[1:]) if b > a]
    strength = [float(np.abs(c.a).sum(axis=-1).max(initial=0.0)) for c in chunks]
    whole = sum(strength) or 1.0
    cube = cube_w = None
    for contributions, s in zip(chunks, strength):
        part = receiver.filter_echoes(contributions, radar)
        budget = None if max_error is None else max_error * max(s / whole, 1e-12)
        if weighted:
            c, c_w = beat_nufft(part, radar, max_error=budget, weights=_delay_weights(part, radar))
        else:
            c, c_w = beat_nufft(part, radar, max_error=budget), None
        if len(chunks) == 1:
            return c, c_w
        cube = c.astype(np.complex128) if cube is None else cube + c
        if weighted:
            cube_w = c_w.astype(np.complex128) if cube_w is None else cube_w + c_w
    return cube, cube_w


def _static_and_dynamic(echoes, radar, max_error: float | None, static_cache: dict, weighted: bool = False):
    """Noise-free cube :math:`x_S + x_D` (and the delay-weighted cube when ``weighted``, else None) of
    ``echoes`` before the IF chain: the static block's from ``static_cache`` (or computed and stored),
    the rest by :func:`beat_nufft`, the budget split by :data:`STATIC_BUDGET_SHARE` (see
    :func:`synthesize`). Each part goes through the IF chain (:func:`sionnafmcw.receiver.filter_echoes`,
    a gain per contribution that depends on that contribution alone) only when its cube is computed:
    the static block's once per block, not every frame."""
    from .. import receiver

    static_error = None if max_error is None else STATIC_BUDGET_SHARE * max_error
    dynamic_error = None if max_error is None else (1.0 - STATIC_BUDGET_SHARE) * max_error
    entry = static_cache.get(echoes.static_key)
    if (entry is None or entry[1] != static_error or (entry[0] is not radar and entry[0] != radar)
            or (weighted and entry[3] is None)):
        static_cache.clear()  # one cube of memory
        cube, cube_w = static_block_cube(echoes, radar, static_error, weighted)
        entry = static_cache[echoes.static_key] = (radar, static_error, cube, cube_w)
    static, static_w = entry[2], entry[3]
    if echoes.static_count == echoes.num_contributions:
        return static, (static_w if weighted else None)
    part = receiver.filter_echoes(_contributions(echoes, echoes.static_count), radar)
    if weighted:
        dynamic, dynamic_w = beat_nufft(part, radar, max_error=dynamic_error, weights=_delay_weights(part, radar))
        return static + dynamic, static_w + dynamic_w
    return static + beat_nufft(part, radar, max_error=dynamic_error), None


__all__ = ["AdcClippingWarning", "METHODS", "NOISE_MARGIN_DB", "STATIC_BUDGET_SHARE", "UPSTREAM_SHARE",
           "STATIC_CHUNK", "SynthesisAccuracy", "beat_direct", "beat_nufft", "noise_error_budget", "static_block_cube",
           "synthesis_accuracy", "synthesize", "thermal_noise"]
