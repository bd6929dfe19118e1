"""The IF chain's gain per contribution: the exact product over the chain's roots (A) against the table
(B, :func:`sionnafmcw.receiver.if_filter.tabulated_response`), interleaved in one process.

Beat frequencies drawn uniformly over ``[0.02, 0.5] F_s`` (a room's ranges), ``--contributions`` of them
shaped ``[3, 4, P]`` as a frame's element pairs, the chain of a TI board's ``.cfg`` (RadHAR's IWR1443 by
default: two high-pass poles, a sixth-order elliptic anti-alias filter). Prints the node spacing, the median
seconds of each over ``--repeats`` alternated runs, their ratio and the largest difference (which the
table's bound keeps under :data:`~sionnafmcw.receiver.if_filter.TABLE_TOLERANCE`).

    python benchmarks/if_filter_table.py [--contributions 1000000] [--repeats 7] [--cfg FILE]

Measured
--------
2-core AMD EPYC with AVX-512, quiet::

    python benchmarks/if_filter_table.py --repeats 11
    999996 gains, node spacing 123.8 Hz: exact 0.0459 s, table 0.0128 s (B/A 0.280); largest difference
    1.02e-07 (tolerance 1e-06)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

RADHAR_CFG = Path("/work/shared/realdata/radhar/1443es1_short_range_3d.cfg")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--contributions", type=int, default=1_000_000, help="gains per run (all element pairs)")
    p.add_argument("--repeats", type=int, default=7)
    p.add_argument("--cfg", type=Path, default=RADHAR_CFG, help="TI .cfg whose IF chain is timed")
    args = p.parse_args(argv)
    if args.contributions < 12 or args.repeats < 1:
        p.error("--contributions must be >= 12 and --repeats >= 1")
    if not args.cfg.is_file():
        p.error(f"--cfg {args.cfg}: no such file")
    import numpy as np

    from sionnafmcw.radar import RadarConfig
    from sionnafmcw.receiver import if_filter

    radar = RadarConfig.resolve(str(args.cfg))
    chain, fs = radar.if_filter, radar.fs
    if not chain:
        p.error(f"--cfg {args.cfg}: its radar has no IF chain")
    f = np.random.default_rng(0).uniform(0.02 * fs, 0.5 * fs, (3, 4, args.contributions // 12))
    seconds = {"A": [], "B": []}
    for _ in range(args.repeats):
        for label, evaluate in (("A", if_filter.response), ("B", if_filter.tabulated_response)):
            t0 = time.perf_counter()
            h = evaluate(chain, f, fs)
            seconds[label].append(time.perf_counter() - t0)
            if label == "A":
                exact = h
    error = float(np.abs(h - exact).max())
    a, b = float(np.median(seconds["A"])), float(np.median(seconds["B"]))
    print(f"{f.size} gains, node spacing {if_filter.table_step(chain, fs):.1f} Hz: exact {a:.4f} s, table {b:.4f} s "
          f"(B/A {b / a:.3f}); largest difference {error:.2e} (tolerance {if_filter.TABLE_TOLERANCE:g})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
