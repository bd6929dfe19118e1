"""``python -m sionnafmcw.cli``: the ``sionnafmcw`` command."""

import sys

from . import main

if __name__ == "__main__":
    sys.exit(main())
