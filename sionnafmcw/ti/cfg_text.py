"""A TI ``.cfg`` as text: reading the file and splitting it into numbered commands (numpy free).

Shared by the RF reader (:mod:`sionnafmcw.ti.cfg`) and the processing reader
(:mod:`sionnafmcw.ti.processing`), so that both name the same source and line in their errors.
A ``.cfg`` is one CLI command per line; ``%`` starts a comment (to the end of the line).
"""

from __future__ import annotations

from pathlib import Path

from ..radar import RadarConfigError


class TiCfgError(RadarConfigError):
    """A ``.cfg`` that cannot be read or written; the message names the source, line and command."""


def text_and_source(path_or_text) -> tuple[str, str]:
    """``(text, source name)`` of a ``.cfg`` given as a path or as its text."""
    if isinstance(path_or_text, Path) or (isinstance(path_or_text, str) and "\n" not in path_or_text
                                          and (path_or_text.strip().lower().endswith(".cfg")
                                               or Path(path_or_text).is_file())):
        path = Path(path_or_text)
        try:
            return path.read_text(encoding="utf-8", errors="replace"), str(path)
        except OSError as err:
            raise TiCfgError(f"{path}: cannot read the TI .cfg file ({err.strerror or err})") from None
    return str(path_or_text), "<cfg text>"


def commands(text: str):
    """``(line number, command, [arguments], comment body or None)`` for every non-empty line."""
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("%"):
            yield number, None, [], line.lstrip("%").strip()
            continue
        words = line.split("%", 1)[0].split()
        if words:
            yield number, words[0], words[1:], None
