"""The paper's walking person on a 3 m circle (see sionnafmcw.validation.circle_walk).

    python validation/circle_walk.py --engine path|pixel|both --out out/circle_walk
"""

import sys

from sionnafmcw.validation.circle_walk import main

if __name__ == "__main__":
    sys.exit(main())
