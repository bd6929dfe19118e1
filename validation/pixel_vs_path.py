"""Pixel engine against the single-bounce path engine (see sionnafmcw.validation.pixel_vs_path).

    python validation/pixel_vs_path.py --out out/pixel_vs_path
"""

import sys

from sionnafmcw.validation.pixel_vs_path import main

if __name__ == "__main__":
    sys.exit(main())
