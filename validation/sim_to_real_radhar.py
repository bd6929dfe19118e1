"""Sim-to-real on RadHAR: trained on simulated point clouds only, scored on the real recordings
(see sionnafmcw.validation.sim_to_real_radhar).

    python validation/sim_to_real_radhar.py --real ../shared/realdata/radhar/train --out out/sim_to_real \
        [--synthetic DIR] [--quick] [--items N] [--ablation no_multipath,lambertian,...] [--statistics-only]
"""

import sys

if __name__ == "__main__":
    from sionnafmcw.heap import limit_arenas

    limit_arenas(1)   # before any thread: the run's threads share one glibc arena (sionnafmcw.heap)
    from sionnafmcw.validation.sim_to_real_radhar import main

    sys.exit(main())
