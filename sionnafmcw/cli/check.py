"""``sionnafmcw check``: read every done frame of a run store back; mark unreadable frames for recomputation."""

from __future__ import annotations

from pathlib import Path

from .common import PROG, open_run_or_error, ranges_text

HELP = "Verify a run store: every done frame readable (unreadable ones are marked for recomputation)."
EPILOG = """\
Reads every array of every frame marked done. A frame that cannot be read (a damaged
chunk) loses its done flag, so that the same 'sionnafmcw simulate' command recomputes
exactly those frames; leftovers of killed writes (*.partial files) are removed.
Exit status 0: every done frame is readable; 1: some frames were marked for recomputation.

example:
  sionnafmcw check runs/plate.zarr
"""


def add_parser(add) -> None:
    p = add("check", HELP, EPILOG)
    p.add_argument("run", metavar="RUN.zarr", help="run store to verify")
    p.add_argument("--dry-run", action="store_true", help="only report; change nothing")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..store import check_run

    open_run_or_error(args.run)  # a one-line error when it is not a store
    report = check_run(Path(args.run), repair=not args.dry_run)
    done, corrupt = report["done"], report["corrupt"]
    if not corrupt:
        print(f"{args.run}: {done.size} of {report['num_frames']} frames done, all readable")
        return 0
    action = "would be marked" if args.dry_run else "marked"
    print(f"{args.run}: {len(corrupt)} of {done.size} done frames unreadable (frames {ranges_text(corrupt)}), "
          f"{action} for recomputation; run the same 'sionnafmcw simulate' command to recompute them")
    for frame, reason in sorted(corrupt.items()):
        print(f"  frame {frame}: {reason}")
    return 1


__all__ = ["add_parser", "run", "PROG"]
