"""The SDK 1.x/2.x chain's peakVal scale against RadHAR (see sionnafmcw.validation.ti_sdk2_scale).

    python validation/ti_sdk2_scale.py --real ../shared/realdata/radhar/train [--frames 40] [--out DIR]
"""

import sys

if __name__ == "__main__":
    from sionnafmcw.validation.ti_sdk2_scale import main

    sys.exit(main())
