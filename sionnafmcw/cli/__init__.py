"""The ``sionnafmcw`` command line (entry point :func:`main`), one module per subcommand.

::

    sionnafmcw presets [NAME] [--json | --config]                radar presets and their derived figures
    sionnafmcw presets --from-cfg FILE.cfg                       the radar of a TI mmWave .cfg, likewise
    sionnafmcw scene list [NAME]                                 scenarios and their parameters
    sionnafmcw scene build NAME OUT [--param k=v ...]            write an animation directory
    sionnafmcw simulate SCENE --radar PRESET|FILE --out RUN.zarr [--engine NAME] ...
    sionnafmcw plot RUN --out DIR [--kind rd|ra|doppler-time|micro-doppler|scene ...] [--frame N]
    sionnafmcw export RUN --out DIR [--format dca1000|npz] [--board B]   a TI raw capture of a run
    sionnafmcw pointcloud RUN --out PATH [--cfg FILE] [--format npz|radhar|tlv|rosbag2]   the TI board's point cloud
    sionnafmcw validate NAME [ARGS ...]                          a validation experiment
    sionnafmcw dataset SPEC --out DIR [--scheduler ADDRESS | --workers N]
    sionnafmcw check RUN.zarr                                    verify every done frame; mark unreadable ones

Modules: :mod:`.presets`, :mod:`.scene`, :mod:`.simulate`, :mod:`.plot` (figure kinds as a
table), :mod:`.export`, :mod:`.pointcloud`, :mod:`.validate`, :mod:`.dataset`, :mod:`.check`; :mod:`.common` holds the shared
parsers and loaders.
Each has ``add_parser(add)`` and the function(s) it runs.

Global options: ``--quiet`` (no progress bars), ``--version``. A user error (a missing file, an
unknown preset, scene or parameter, bad ``--frames``, bad JSON, a CPI longer than the frame
period, ...) prints one line ``sionnafmcw: error: ...`` on stderr and exits with status 2; an
interrupted run exits with 130 (143 for SIGTERM) after one line (``simulate`` and ``dataset`` then
resume where they stopped). The library's errors
speak the library's language; the command line adds which option to change or which command to
run. Heavy modules (Sionna RT, Zarr, the scene builders) are imported inside the subcommands.
"""

from __future__ import annotations

import argparse
import sys

from . import check, dataset, export, plot, pointcloud, presets, scene, simulate, validate
from .common import PROG, Parser, UserError, formatter, one_line, parse_frames, user_error_types

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130
#: Subcommand modules, in the order ``--help`` lists them.
SUBCOMMANDS = (presets, scene, simulate, plot, export, pointcloud, validate, dataset, check)
EPILOG = """\
example:
  sionnafmcw scene build moving_plate scenes/plate
  sionnafmcw simulate scenes/plate --radar walk-77ghz --out runs/plate.zarr
  sionnafmcw plot runs/plate.zarr --out figures/plate

'sionnafmcw COMMAND --help' explains each command."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``sionnafmcw`` command (one subparser per module of :data:`SUBCOMMANDS`)."""
    from .. import __version__

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS, help="no progress bars")
    parser = Parser(prog=PROG, formatter_class=formatter,
                    description="Physically grounded FMCW TDM-MIMO radar simulator on Sionna RT.", epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True

    def add(name, help_text, epilog, subparsers=sub):
        return subparsers.add_parser(name, help=help_text, description=help_text, epilog=epilog,
                                     formatter_class=formatter, parents=[common])

    for module in SUBCOMMANDS:
        module.add_parser(add)
    return parser


def main(argv=None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``); returns the exit status.

    SIGINT and SIGTERM end any command with one line on stderr and status 130 / 143
    (:mod:`sionnafmcw.interrupts`); ``simulate`` and ``dataset`` say how far they got. The process's
    threads share one glibc arena (:func:`sionnafmcw.heap.limit_arenas`).
    """
    from ..heap import limit_arenas
    from ..interrupts import handling_signals

    limit_arenas(1)   # before any thread: a run's threads share one glibc arena (sionnafmcw.heap)
    parser = build_parser()
    with handling_signals():
        try:
            try:
                args = parser.parse_args(argv)
            except SystemExit as exc:  # --help, --version
                return int(exc.code or 0) if not isinstance(exc.code, str) else 1
            if not hasattr(args, "quiet"):
                args.quiet = False
            return int(args.func(args) or 0)
        except KeyboardInterrupt as exc:
            return interrupted(exc)
        except BrokenPipeError:
            return _closed_stdout()
        except user_error_types() as err:
            print(f"{PROG}: error: {one_line(cli_message(err))}", file=sys.stderr)
            return EXIT_USER_ERROR
        except RuntimeError as exc:  # Dr.Jit wraps a KeyboardInterrupt raised inside its calls
            from ..interrupts import is_interrupt

            if is_interrupt(exc):
                return interrupted(exc)
            raise


def _closed_stdout() -> int:
    """The reader of our stdout went away (``sionnafmcw presets | head -1``): no traceback, and no
    second error when Python flushes stdout at exit; status 141 (128 + SIGPIPE) as a shell gives."""
    import os

    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return 141


def interrupted(exc: BaseException) -> int:
    """Print the one line of an interrupted command; its exit status (128 + signal number)."""
    from ..interrupts import as_interrupted

    signum = as_interrupted(exc).signum
    done, total, what = getattr(exc, "done", None), getattr(exc, "total", None), getattr(exc, "unit", "frames")
    if done is not None and total is not None:
        print(f"{PROG}: interrupted after {done} of {total} {what}; run the same command to resume", file=sys.stderr)
    else:
        print(f"{PROG}: interrupted (a simulate or dataset run resumes where it stopped when started again)",
              file=sys.stderr)
    return 128 + signum


def cli_message(err: BaseException) -> BaseException | str:
    """A library error completed with the command that fixes it (a corrupt frame: ``check``)."""
    from .common import corrupt_frame_message

    return corrupt_frame_message(err) or err


__all__ = ["EXIT_INTERRUPTED", "EXIT_USER_ERROR", "PROG", "SUBCOMMANDS", "UserError", "build_parser", "main",
           "parse_frames"]
