"""Analytic point targets through synthesis and processing (see sionnafmcw.validation.point_targets).

    python validation/point_targets.py --out out/point_targets [--radar walk-77ghz]
"""

import sys

from sionnafmcw.validation.point_targets import main

if __name__ == "__main__":
    sys.exit(main())
