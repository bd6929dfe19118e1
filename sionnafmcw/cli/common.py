"""What the subcommands share: the one-line :class:`UserError`, the argument parser class, text
parsers for ``--frames``, ``MIN:MAX``, ``key=value`` options, and the loaders that turn a library
error into a command-line message (which option to change, which command to run).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

PROG = "sionnafmcw"


class UserError(Exception):
    """A mistake on the command line or in an input file: printed as one line, no traceback."""


class Parser(argparse.ArgumentParser):
    """Argument parser whose errors are one line (:class:`UserError`) instead of usage + exit."""

    def error(self, message):
        raise UserError(f"{message} (see '{self.prog} --help')")


def formatter(prog):
    return argparse.RawDescriptionHelpFormatter(prog, max_help_position=32, width=100)


# ============================================================================ text parsers
def parse_frames(text: str, num_frames: int) -> list[int]:
    """Frame indices from ``--frames``: ``a:b`` (a..b-1), ``a:``, ``:b``, ``a:b:step``, ``n`` or ``i,j,k``.

    Indices are 0-based and must lie in ``0..num_frames-1``; raises :class:`UserError` naming the problem.
    """
    text = str(text).strip()
    where = f"--frames {text!r}"
    span = f"the scene has {num_frames} frame{'s' if num_frames != 1 else ''} (0..{num_frames - 1})"

    def integer(s, what):
        try:
            value = int(s)
        except ValueError:
            raise UserError(f"{where}: {what} {s!r} is not an integer; write a:b, a:b:step, n or i,j,k") from None
        return value

    if not text:
        raise UserError(f"{where} is empty; write a:b (frames a..b-1), a:, :b, n or i,j,k")
    if ":" in text:
        parts = text.split(":")
        if len(parts) > 3:
            raise UserError(f"{where}: too many ':'; write a:b or a:b:step")
        start = integer(parts[0], "start") if parts[0].strip() else 0
        stop = integer(parts[1], "stop") if parts[1].strip() else num_frames
        step = integer(parts[2], "step") if len(parts) == 3 and parts[2].strip() else 1
        if step < 1:
            raise UserError(f"{where}: step must be >= 1")
        if start < 0 or stop < 0:
            raise UserError(f"{where}: negative frame numbers are not allowed; {span}")
        if stop > num_frames:
            raise UserError(f"{where}: stop {stop} is past the end; {span}")
        if start >= stop:
            raise UserError(f"{where} selects no frame (start {start} >= stop {stop}); {span}")
        return list(range(start, stop, step))
    indices = [integer(p.strip(), "frame") for p in text.split(",") if p.strip()]
    bad = [i for i in indices if not 0 <= i < num_frames]
    if bad:
        raise UserError(f"{where}: frame(s) {', '.join(map(str, bad))} out of range; {span}")
    if len(set(indices)) != len(indices):
        raise UserError(f"{where} lists a frame twice")
    return indices


def parse_interval(text: str, option: str) -> tuple:
    """``MIN:MAX`` (either side may be empty) as floats."""
    parts = str(text).split(":")
    if len(parts) != 2:
        raise UserError(f"{option} {text!r}: write MIN:MAX in metres, e.g. 0.5:8 (either side may be empty)")
    try:
        lo, hi = (float(p) if p.strip() else None for p in parts)
    except ValueError:
        raise UserError(f"{option} {text!r}: MIN and MAX must be numbers (metres)") from None
    if lo is not None and hi is not None and lo >= hi:
        raise UserError(f"{option} {text!r}: MIN must be below MAX")
    return lo, hi


def key_values(items, option: str) -> list[tuple[str, str]]:
    """``["k=v", ...]`` of a repeatable option as ``[(k, v), ...]`` (each key once)."""
    out = []
    for item in items or []:
        if "=" not in item or not item.split("=", 1)[0].strip():
            raise UserError(f"{option} {item!r}: write key=value")
        key, value = item.split("=", 1)
        out.append((key.strip(), value.strip()))
    keys = [k for k, _ in out]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise UserError(f"{option}: {', '.join(dup)} given twice")
    return out


_TRUE = ("1", "true", "yes", "on")
_FALSE = ("0", "false", "no", "off")


def coerce(text: str, like, where: str):
    """Command-line text as a value of the type of ``like`` (a default value; None: guess)."""
    low = text.lower()
    if isinstance(like, bool):
        if low in _TRUE:
            return True
        if low in _FALSE:
            return False
        raise UserError(f"{where}={text!r} is not a boolean; write true or false")
    if isinstance(like, int):
        try:
            value = float(text)
        except ValueError:
            raise UserError(f"{where}={text!r} is not an integer") from None
        if not value.is_integer():
            raise UserError(f"{where}={text!r} is not an integer")
        return int(value)
    if isinstance(like, float):
        try:
            return float(text)
        except ValueError:
            raise UserError(f"{where}={text!r} is not a number") from None
    if isinstance(like, str):
        return text
    if low in _TRUE[1:] or low in _FALSE[1:]:
        return low in _TRUE
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def ranges_text(indices) -> str:
    """``[0, 1, 2, 5]`` -> ``"0-2, 5"``."""
    indices = sorted(int(i) for i in indices)
    parts, start = [], None
    for k, i in enumerate(indices):
        if start is None:
            start = i
        if k + 1 == len(indices) or indices[k + 1] != i + 1:
            parts.append(str(start) if start == i else f"{start}-{i}")
            start = None
    return ", ".join(parts)


# ============================================================================ loaders
def load_radar(spec: str, option: str = "--radar"):
    """:meth:`RadarConfig.resolve` of a preset name, ``.json`` or TI ``.cfg`` file given as ``option``;
    its :class:`~sionnafmcw.radar.RadarConfigError` becomes a :class:`UserError` naming ``option``."""
    from ..radar import RadarConfig, RadarConfigError

    try:
        return RadarConfig.resolve(spec)
    except RadarConfigError as err:
        raise UserError(f"{option}: {err}") from None


def load_scene(path: str, option: str = "SCENE"):
    """The checked :class:`~sionnafmcw.animation.Animation` at ``path`` (``option`` names it in errors)."""
    from ..animation import AnimationError, load_animation

    p = Path(path)
    if not p.exists():
        raise UserError(f"{option} {path}: no such directory; build one with 'sionnafmcw scene build NAME {path}'")
    if p.is_dir() and not (p / "animation.json").is_file():
        raise UserError(f"{option} {path}: no animation.json in this directory; "
                        "build a scene with 'sionnafmcw scene build NAME DIR'")
    try:
        return load_animation(p)
    except AnimationError as err:
        raise UserError(str(err)) from None


def open_run_or_error(path):
    """:func:`sionnafmcw.store.open_run`, its error completed with the command that writes a store."""
    from ..store import RunStoreError, open_run

    try:
        return open_run(Path(path))
    except RunStoreError as err:
        raise UserError(f"{err}; write one with 'sionnafmcw simulate SCENE --radar PRESET --out {path}'") from None


def progress(iterable, quiet: bool, **kwargs):
    """``tqdm`` progress bar over ``iterable`` (none with ``--quiet``)."""
    from tqdm.auto import tqdm

    return tqdm(iterable, disable=quiet, **kwargs)


# ============================================================================ errors
#: The library's error classes that mean bad input, as (module, class): only those of modules
#: already imported can have been raised, so nothing is imported to catch them.
LIBRARY_USER_ERRORS = (
    ("sionnafmcw.radar", "RadarConfigError"), ("sionnafmcw.animation.errors", "AnimationError"),
    ("sionnafmcw.store", "RunStoreError"), ("sionnafmcw.materials", "MaterialError"),
    ("sionnafmcw.simulation", "SimulationError"),
    ("sionnafmcw.engines.base", "EngineError"),  # every engine's errors, scene loading included
    ("sionnafmcw.dataset.spec", "SpecError"), ("sionnafmcw.dataset.index", "DatasetError"),
    ("sionnafmcw.ti.dca1000", "CaptureError"),
    ("sionnafmcw.ti.oob", "OobError"), ("sionnafmcw.ti.formats.tlv", "TlvError"), ("sionnafmcw.ti.formats.radhar", "RadharFormatError"),
)


def user_error_types() -> tuple:
    """:class:`UserError`, the file-system errors of a wrong path and the loaded :data:`LIBRARY_USER_ERRORS`."""
    types = [UserError, FileNotFoundError, FileExistsError, NotADirectoryError, IsADirectoryError, PermissionError]
    for module, name in LIBRARY_USER_ERRORS:
        mod = sys.modules.get(module)
        if mod is not None and isinstance(getattr(mod, name, None), type):
            types.append(getattr(mod, name))
    return tuple(types)


def corrupt_frame_message(err: BaseException) -> str | None:
    """The command-line message of a :class:`~sionnafmcw.store.CorruptFrameError` (None for other errors)."""
    store = sys.modules.get("sionnafmcw.store")
    if store is None or not isinstance(err, store.CorruptFrameError):
        return None
    return (f"{err.path}: frame {err.frame} cannot be read ({err.reason}); run 'sionnafmcw check {err.path}' to "
            "mark it for recomputation, then the same 'sionnafmcw simulate' command to recompute it")


def one_line(err) -> str:
    """The error's message on one line (an ``OSError`` as ``file: reason``)."""
    if isinstance(err, str):
        return " ".join(err.split())
    if isinstance(err, OSError) and err.strerror and err.filename:
        return f"{err.filename}: {err.strerror}"
    return " ".join(str(err).split()) or type(err).__name__


__all__ = ["PROG", "Parser", "UserError", "coerce", "corrupt_frame_message", "formatter", "key_values", "load_radar", "load_scene",
           "one_line", "open_run_or_error", "parse_frames", "parse_interval", "progress", "ranges_text",
           "user_error_types"]
