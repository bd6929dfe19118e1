r"""Direct reference sum of the beat signal: every sample of every contribution, term for term.

.. math::
    x_{lmnk} = \sqrt{P_t}\sum_p \bar a_{mnp}\, e^{j2\pi\varphi_{mnp}(s_{lm}, t_k)}

with :math:`\varphi` from :func:`~sionnafmcw.synthesis.phase.exact_phase`. Cost
:math:`O(L M N N_s P)` complex exponentials: the yardstick for the fast sum, small inputs only.
"""

from __future__ import annotations

import numpy as np

from .phase import exact_phase

#: Largest [chirps x samples x contributions] block evaluated at once (complex128 elements).
BLOCK_ELEMENTS = 4_000_000


def beat_direct(echoes, radar, chirps=None, weights=None):
    """Noise-free beat cube ``[chirp, tx, rx, sample]`` (complex128) by direct summation.

    ``chirps`` (optional index array) restricts the output to those chirps, for spot checks of
    large inputs. ``weights`` (``[M, N, P]`` real, optional): also return the sum with every gain
    multiplied by its weight, as the pair ``(cube, weighted cube)``.
    """
    chirps = np.arange(radar.num_chirps) if chirps is None else np.asarray(chirps)
    starts = radar.chirp_start_times()[chirps]  # [L', M]
    fast_time = radar.adc_start_time + np.arange(radar.num_samples) / radar.fs
    sums = 1 if weights is None else 2
    out = np.zeros((len(chirps), radar.num_tx, radar.num_rx, radar.num_samples, sums), dtype=np.complex128)
    amplitude = np.sqrt(radar.tx_power)
    for m in range(radar.num_tx):
        for n in range(radar.num_rx):
            live = echoes.a[m, n] != 0
            gain = np.conj(echoes.a[m, n, live])
            if weights is not None:
                gain = np.stack([gain, gain * weights[m, n, live]], axis=-1)   # [P, 2]
            tau0 = echoes.tau[m, n, live]
            nu = echoes.doppler[m, n, live] / radar.fc
            beta = None if echoes.doppler_rate is None else echoes.doppler_rate[m, n, live][None, None, :] / radar.fc
            if gain.size == 0:
                continue
            per_chirp = max(1, BLOCK_ELEMENTS // (radar.num_samples * len(gain)))
            for start in range(0, len(chirps), per_chirp):
                s = starts[start:start + per_chirp, m][:, None, None]
                phase = exact_phase(tau0[None, None, :], nu[None, None, :], s, fast_time[None, :, None], radar, beta)
                # phase is O(1e4) cycles; keep only its fractional part before scaling by 2*pi
                phase -= np.round(phase)
                out[start:start + per_chirp, m, n, :] = (np.exp(2j * np.pi * phase) @ gain).reshape(
                    phase.shape[:2] + (sums,))
    out *= amplitude
    return out[..., 0] if weights is None else (out[..., 0], out[..., 1])
