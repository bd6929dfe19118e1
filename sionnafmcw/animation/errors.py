"""The error of the animation package (its own module so that the numpy-only readers need nothing else)."""

from pathlib import Path


class AnimationError(ValueError):
    """An animation directory that cannot be used; the message names the file and field."""


def read_text(path: Path, what: str) -> str:
    """The text of ``path``, or :class:`AnimationError` "``path``: cannot read ``what`` (reason)"."""
    try:
        return Path(path).read_text()
    except OSError as err:
        raise AnimationError(f"{path}: cannot read {what} ({err.strerror or err})") from None


__all__ = ["AnimationError", "read_text"]
