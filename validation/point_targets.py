"""Analytic point targets through synthesis and processing (see sionnafmcw.validation.point_targets).

    python validation/point_targets.py --out out/point_targets [--radar walk-77ghz]
"""

import sys

if __name__ == "__main__":
    from sionnafmcw.heap import limit_arenas

    limit_arenas(1)   # before any thread: the run's threads share one glibc arena (sionnafmcw.heap)
    from sionnafmcw.validation.point_targets import main

    sys.exit(main())
