"""Pixel engine against the single-bounce path engine (see sionnafmcw.validation.pixel_vs_path).

    python validation/pixel_vs_path.py --out out/pixel_vs_path
"""

import sys

if __name__ == "__main__":
    from sionnafmcw.heap import limit_arenas

    limit_arenas(1)   # before any thread: the run's threads share one glibc arena (sionnafmcw.heap)
    from sionnafmcw.validation.pixel_vs_path import main

    sys.exit(main())
