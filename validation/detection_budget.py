"""A person's returns through the xWR14xx chain's CFAR and peak grouping, and the moving points
against range in RadHAR-format point clouds (see sionnafmcw.validation.detection_budget).

    python validation/detection_budget.py --run ITEM/run.zarr [--frames 0,10] [--real DIR] [--synthetic DIR]
"""

import sys

if __name__ == "__main__":
    from sionnafmcw.validation.detection_budget import main

    sys.exit(main())
