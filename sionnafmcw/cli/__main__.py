"""``python -m sionnafmcw.cli``: the ``sionnafmcw`` command."""

import sys

from . import main

sys.exit(main())
