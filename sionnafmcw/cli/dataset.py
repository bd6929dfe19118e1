"""``sionnafmcw dataset``: generate (or resume) a data set from a specification file on Dask."""

from __future__ import annotations

import collections
import sys
import warnings
from pathlib import Path

from .common import PROG, UserError

HELP = "Generate a data set from a specification file."
EPILOG = """\
A finished run with the same SPEC and DIR resumes: complete items are skipped. Exit status 1
when some items failed (they are listed in DIR's index with their error). Killed or
interrupted at any moment (Ctrl-C: status 130), the same command resumes: no item is lost
or computed twice. On a cluster: one 'dask scheduler', N 'dask worker ADDRESS --nthreads 1'
processes, DIR on a file system every worker sees at the same path (see the README).

example:
  sionnafmcw dataset specs/walkers.yaml --out data/walkers --workers 2
  sionnafmcw dataset specs/walkers.yaml --out data/walkers --scheduler tcp://10.0.0.5:8786
"""


def add_parser(add) -> None:
    p = add("dataset", HELP, EPILOG)
    p.add_argument("spec", metavar="SPEC", help="data-set specification (YAML or JSON)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://host:8786")
    group.add_argument("--workers", type=int, default=None, metavar="N", help="start a local Dask cluster of N workers")
    p.set_defaults(func=run)


def run(args) -> int:
    from .. import dataset
    from ..dataset.spec import SpecError

    spec_path = Path(args.spec)
    if not spec_path.is_file():
        raise UserError(f"{args.spec}: no such data-set specification file")
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers {args.workers}: must be >= 1")
    try:
        spec = dataset.load_spec(spec_path)
    except SpecError as err:
        message = str(err)
        raise UserError(message if str(spec_path) in message else f"{args.spec}: {message}") from None
    # A failed item is reported once, one line naming the item and its error: in the summary that
    # generate prints, or (--quiet, no summary) here; not again as a Python warning with a source line.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", dataset.DatasetWarning)
        index = dataset.generate(spec, Path(args.out), scheduler=args.scheduler, workers=args.workers,
                                 progress=not args.quiet)
    for w in caught:
        if not issubclass(w.category, dataset.DatasetWarning):
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        elif args.quiet:
            print(f"{PROG}: {w.message}", file=sys.stderr)
    counts = collections.Counter(str(s) for s in index["status"].values)
    summary = ", ".join(f"{n} {status}" for status, n in sorted(counts.items()))
    print(f"wrote data set {spec.name} to {args.out}: {summary}")
    return 1 if counts.get("failed") else 0
