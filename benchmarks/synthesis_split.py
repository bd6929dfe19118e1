"""The per-frame beat sum of a walk frame with half the error budget (A) against 90 % of it (B), interleaved.

With the engine's static block, ``synthesize`` computes two sums: the static block's once per
block, and the rest every frame; the noise budget :math:`E_{max}` is split between them
(``synthesis.STATIC_BUDGET_SHARE``). This measures what the split costs per frame: for the
path engine's circle-walk frames (defaults), the per-frame part (contributions after
``static_count``) through ``beat_nufft`` with ``max_error`` = A: :math:`E_{max}/2` (the split
before), B: :math:`0.9\\,E_{max}` (now), in turns, ``--repeats`` times; it prints the settings
each chooses (Taylor terms, finufft tolerance, precision) and the mean seconds per frame.

    python benchmarks/synthesis_split.py [--scene DIR] [--frames 2 3 4 5] [--repeats 3]

Measured
--------
``python benchmarks/synthesis_split.py --scene /tmp/cw8`` (the 100-frame circle walk, 8 mm body,
about 9e4 per-frame contributions per element pair; 2-core AMD EPYC)::

    A share 0.5: 3 terms, tol 1.94e-05, complex128
    B share 0.9: 2 terms, tol 3.29e-05, complex128
    seconds per frame, A: 0.356 0.317 0.326   B: 0.322 0.288 0.291   (B/A 0.90)
"""

from __future__ import annotations

import argparse
import sys
import time

import walk_frames


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    walk_frames.add_arguments(p, "out/bench_synthesis_split", [2, 3, 4, 5], 3)
    args = p.parse_args(argv)

    from sionnafmcw import engines
    from sionnafmcw.echoes import Echoes
    from sionnafmcw.synthesis import beat_nufft, noise_error_budget, synthesis_accuracy

    anim, radar = walk_frames.load(p, args)
    engine = engines.create("path", track_kernels=False)
    dynamic = []
    for frame in args.frames:
        e = engine.echoes(anim, radar, frame)
        k = e.static_count
        dynamic.append(Echoes(e.a[..., k:], e.tau[..., k:], e.doppler[..., k:]))
    engine.close()
    budget = noise_error_budget(radar)
    shares = {"A": 0.5, "B": 0.9}
    for name, share in shares.items():
        acc = synthesis_accuracy(dynamic[0], radar, max_error=share * budget)
        print(f"{name} share {share}: {len(acc.terms)} terms, tol {acc.nufft_tol:.3g}, {acc.dtype}")
    seconds = {name: [] for name in shares}
    for _ in range(args.repeats):
        for name, share in shares.items():
            t0 = time.perf_counter()
            for d in dynamic:
                beat_nufft(d, radar, max_error=share * budget)
            seconds[name].append((time.perf_counter() - t0) / len(dynamic))
    a, b = (sum(seconds[n]) / len(seconds[n]) for n in ("A", "B"))
    print(f"seconds per frame, A: {' '.join(f'{s:.3f}' for s in seconds['A'])}   "
          f"B: {' '.join(f'{s:.3f}' for s in seconds['B'])}   (B/A {b / a:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
