"""RadHAR's sensor on a simulated person against the real recordings (see sionnafmcw.validation.ti_radhar).

    python validation/ti_radhar.py --real ../shared/realdata/radhar/train --out out/ti_radhar [--frames 30]
"""

import sys

if __name__ == "__main__":
    from sionnafmcw.heap import limit_arenas

    limit_arenas(1)   # before any thread: the run's threads share one glibc arena (sionnafmcw.heap)
    from sionnafmcw.validation.ti_radhar import main

    sys.exit(main())
