r"""TDM-MIMO FMCW beat synthesis: :class:`~sionnafmcw.Echoes` -> IF cube.

:func:`synthesize` evaluates, for every chirp :math:`l`, Tx :math:`m`, Rx :math:`n` and sample
:math:`k` (NOTES section 2),

.. math::
    x_{lmnk} = \sqrt{P_t}\sum_p \bar a_{mnp}\,
      e^{j2\pi(f_c\tau_{mnp} + \mu\tau_{mnp} t_k - \mu\tau_{mnp}^2/2)} + w_{lmnk},
    \qquad \tau_{mnp} = \tau_{0,mnp} - \frac{f_{D,mnp}}{f_c}\,(s_{lm} + t_k)

with the exact TDM chirp start :math:`s_{lm} = (lM + q_m)T_c`, fast time
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
"""

from __future__ import annotations

import numpy as np

from .accuracy import NOISE_MARGIN_DB, SynthesisAccuracy, noise_error_budget
from .direct import beat_direct
from .noise import thermal_noise
from .nufft import beat_nufft, synthesis_accuracy

METHODS = ("nufft", "direct")


def synthesize(echoes, radar, frame_time: float = 0.0, noise: bool = True, rng=None,
               method: str = "nufft", leakage_db: float | None = None,
               noise_margin_db: float = NOISE_MARGIN_DB, max_error: float | None = None) -> np.ndarray:
    """IF cube ``[chirp, tx, rx, sample]`` (complex64, sqrt(W), tx in physical order) of one CPI.

    Parameters
    ----------
    echoes : Echoes
        Contributions at the CPI start ``frame_time``; shape must match the radar's array.
    radar : RadarConfig
    frame_time : float
        CPI start :math:`t_n` (s) to which ``echoes`` refer; the chirp timing is relative to it,
        so the cube itself depends only on the echoes.
    noise : bool
        Add receiver thermal noise :math:`k T_0 F F_s` per sample.
    rng : numpy.random.Generator or int, optional
        Noise source (a seed gives a reproducible cube).
    method : {"nufft", "direct"}
    leakage_db : float, optional
        Add direct Tx-Rx coupling of this power level (dB) to every channel
        (:meth:`Echoes.leakage`); None (default) models none.
    noise_margin_db : float
        With noise on, the fast sum's worst-case error per sample stays this far below the thermal
        noise :math:`\\sqrt{k T_0 F F_s}` (:func:`~sionnafmcw.synthesis.accuracy.noise_error_budget`).
    max_error : float, optional
        Explicit error budget per sample (sqrt(W)) for ``method="nufft"``, overriding the noise
        margin; with noise off and no ``max_error`` the tight default tolerances are used.
    """
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
    if method == "nufft":
        if max_error is None and noise:
            max_error = noise_error_budget(radar, noise_margin_db)
        cube = beat_nufft(echoes, radar, max_error=max_error)
    elif method == "direct":
        cube = beat_direct(echoes, radar)
    else:
        raise ValueError(f"synthesize: method={method!r} is unknown; choose one of {', '.join(METHODS)}")
    cube = cube.astype(np.complex64)
    if noise:
        rng = np.random.default_rng(rng)
        cube += thermal_noise(cube.shape, radar, rng)
    return cube


__all__ = ["METHODS", "NOISE_MARGIN_DB", "SynthesisAccuracy", "beat_direct", "beat_nufft", "noise_error_budget",
           "synthesis_accuracy", "synthesize", "thermal_noise"]
