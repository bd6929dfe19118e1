"""The single-precision (complex64) finufft floor of the beat synthesis against the Doppler span.

``beat_nufft`` uses complex64 only where its rounding floor was measured to stay under the
error bound's allowance (:mod:`sionnafmcw.synthesis.accuracy`): the floor grows with the float32
phases :math:`x_j s_k`, i.e. with the largest :math:`|B_p|` (cycles per TDM block; the unambiguous
Doppler is :math:`|B_p| \\le 1/2`). This measures that floor on the walk-77ghz grid (256 chirps x
128 samples, 12 channels) for Doppler spans ``--spans`` (largest :math:`|B_p|`):
``--sources`` contributions per channel at 1-11 m, :math:`B_p` uniform in the span (the largest
at its edge), their strengths **in phase at one sample** (the worst case of the bound: the signal
there is the strength sum). Reference: ``beat_nufft`` in double precision at ``--reference-tol``.
For each span and finufft tolerance ``--tols`` it prints the largest error over the cube of the
complex128 and complex64 transforms, relative to :math:`\\epsilon\\sqrt{P_t}\\sum_p|a_p|` (the
NUFFT bound is :math:`s = 16` times that, ``accuracy.NUFFT_SAFETY``; the float32 floor must stay
under :math:`0.05\\,s` of it, the margin of the module docstring).

    python benchmarks/single_precision.py [--spans 0.5 0.75 1 2] [--tols 2.5e-5 1e-4 1e-3]

Measured
--------
``python benchmarks/single_precision.py`` on the 2-core AMD EPYC (23 s)::

     span |B|      tol  complex128  complex64   (max error / (tol sqrt(Pt) sum|a|))
         0.50  2.5e-05       0.249      0.330   (peak/sum 1.000)
         0.50  1.0e-04       0.253      0.255   (peak/sum 1.000)
         0.50  1.0e-03       0.350      0.350   (peak/sum 1.000)
         0.75  2.5e-05       0.277      0.425   (peak/sum 1.000)
         0.75  1.0e-04       0.325      0.335   (peak/sum 1.000)
         0.75  1.0e-03       0.407      0.406   (peak/sum 1.000)
         1.00  2.5e-05       0.260      0.407   (peak/sum 1.000)
         1.00  1.0e-04       0.257      0.252   (peak/sum 1.000)
         1.00  1.0e-03       0.323      0.323   (peak/sum 1.000)
         2.00  2.5e-05       0.242      0.575   (peak/sum 1.000)
         2.00  1.0e-04       0.310      0.353   (peak/sum 1.000)
         2.00  1.0e-03       0.374      0.369   (peak/sum 1.000)

The float32 floor shows at the smallest tolerance and grows with the span, but stays under
0.6 tol x strength sum up to |B| = 2, against the bound's 16 (``accuracy.NUFFT_SAFETY``), hence
``accuracy.SINGLE_PRECISION_MAX_BLOCK_PHASE`` = 1 (twice the unambiguous Doppler).
"""

from __future__ import annotations

import argparse

import numpy as np

from sionnafmcw import Echoes, RadarConfig
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.synthesis import beat_nufft
from sionnafmcw.synthesis.phase import PhasePolynomial


def in_phase_echoes(radar, num: int, span: float, rng) -> Echoes:
    """``num`` contributions per channel at 1-11 m with :math:`B_p` uniform in ``[-span, span]`` (two at
    the edges), strengths in phase at sample (chirp L/2, sample Ns/2) of every channel."""
    m_tx, n_rx = radar.num_tx, radar.num_rx
    distance = rng.uniform(1.0, 11.0, num)
    block = rng.uniform(-span, span, num)
    block[:2] = (-span, span)
    # B = -nu t_b (f_mid - mu tau_a) ~ -f_D t_b f_mid / f_c: the Doppler that gives B
    doppler = -block / radar.block_interval * radar.fc / radar.centre_frequency
    tau = np.broadcast_to(2 * distance / SPEED_OF_LIGHT, (m_tx, n_rx, num)).copy()
    fd = np.broadcast_to(doppler, (m_tx, n_rx, num)).copy()
    magnitude = rng.uniform(0.5, 1.0, num) * 1e-6
    slot = radar.tx_slot()
    l_mid, k_mid = radar.num_chirps // 2, radar.num_samples // 2 - (radar.num_samples - 1) / 2.0
    a = np.empty((m_tx, n_rx, num), complex)
    for m in range(m_tx):
        poly = PhasePolynomial.from_delay_doppler(tau[m, 0], fd[m, 0] / radar.fc, slot[m], radar)
        phase = poly.evaluate(l_mid, k_mid)                     # cycles at the chosen sample
        a[m] = magnitude * np.exp(2j * np.pi * phase)           # conj(a) e^{j 2 pi phase} = |a|
    return Echoes(a, tau, fd)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--spans", type=float, nargs="+", default=[0.5, 0.75, 1.0, 2.0])
    p.add_argument("--tols", type=float, nargs="+", default=[2.5e-5, 1e-4, 1e-3])
    p.add_argument("--sources", type=int, default=2000)
    p.add_argument("--reference-tol", type=float, default=1e-11)
    p.add_argument("--radar", default="walk-77ghz")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    radar = RadarConfig.resolve(args.radar)
    rng = np.random.default_rng(args.seed)
    scale = np.sqrt(radar.tx_power)
    print(f"{'span |B|':>9} {'tol':>8} {'complex128':>11} {'complex64':>10}   (max error / (tol sqrt(Pt) sum|a|))")
    for span in args.spans:
        echoes = in_phase_echoes(radar, args.sources, span, rng)
        reference = beat_nufft(echoes, radar, nufft_tol=args.reference_tol)
        strength_sum = scale * np.abs(echoes.a).sum(axis=-1)           # [M, N]
        peak = np.abs(reference).max(axis=(0, 3)) / strength_sum
        for tol in args.tols:
            ratios = []
            for precision in ("complex128", "complex64"):
                cube = beat_nufft(echoes, radar, nufft_tol=tol, precision=precision)
                error = np.abs(cube - reference).max(axis=(0, 3)) / strength_sum   # [M, N]
                ratios.append(float((error / tol).max()))
            print(f"{span:9.2f} {tol:8.1e} {ratios[0]:11.3f} {ratios[1]:10.3f}   (peak/sum {peak.min():.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
