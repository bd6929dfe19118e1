"""The error of the animation package (its own module so that the numpy-only readers need nothing else)."""


class AnimationError(ValueError):
    """An animation directory that cannot be used; the message names the file and field."""


__all__ = ["AnimationError"]
