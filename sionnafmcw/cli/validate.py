"""``sionnafmcw validate``: run one of the validation experiments of :mod:`sionnafmcw.validation`."""

from __future__ import annotations

import argparse
import sys

from .common import PROG, UserError

HELP = "Run a validation experiment (writes figures and metrics.json)."
EPILOG = """\
example:
  sionnafmcw validate --list
  sionnafmcw validate point_targets --out out/point_targets
"""


def add_parser(add) -> None:
    p = add("validate", HELP, EPILOG)
    p.add_argument("name", nargs="?", metavar="NAME", help="experiment (see --list)")
    p.add_argument("args", nargs=argparse.REMAINDER, metavar="ARGS", help="the experiment's own options")
    p.add_argument("--list", action="store_true", help="list the experiments")
    p.set_defaults(func=run)


def run(args) -> int:
    from .. import validation

    if args.list or not args.name:
        for name in validation.names():
            print(f"{name}: {validation.EXPERIMENTS.get(name, '')}")
        return 0
    if args.name not in validation.names():
        raise UserError(f"unknown validation experiment {args.name!r}; choose one of {', '.join(validation.names())}")
    argv0 = sys.argv[0] if sys.argv else PROG
    if sys.argv:
        sys.argv[0] = f"{PROG} validate {args.name}"  # the experiment's usage lines name the command
    try:
        return int(validation.run(args.name, list(args.args)) or 0)
    finally:
        if sys.argv:
            sys.argv[0] = argv0
