"""The paper's walking person on a 3 m circle (see sionnafmcw.validation.circle_walk).

    python validation/circle_walk.py --engine path|pixel|both --out out/circle_walk
"""

import sys

if __name__ == "__main__":
    from sionnafmcw.heap import limit_arenas

    limit_arenas(1)   # before any thread: the run's threads share one glibc arena (sionnafmcw.heap)
    from sionnafmcw.validation.circle_walk import main

    sys.exit(main())
