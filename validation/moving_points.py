"""Where a point cloud's moving points come from: per frame, against the person's truth, and through the
TI chain with one part changed (see sionnafmcw.validation.moving_points).

    python validation/moving_points.py --synthetic EXPORT [--items ITEMS] [--real DIR] [--activity walk] [--chain]
        [--sources FRAMES [--source-items IDS]]
"""

import sys

if __name__ == "__main__":
    from sionnafmcw.validation.moving_points import main

    sys.exit(main())
