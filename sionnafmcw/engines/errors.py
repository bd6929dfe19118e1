"""The engines' errors: every one an :class:`EngineError` (a ``ValueError``) whose message says what is
wrong and what would fix it. Kept apart from the engines so that every module of the family
(the template in :mod:`.base`, the loaded scene, the engines) imports them without importing one
another."""

from __future__ import annotations


class EngineError(ValueError):
    """An engine cannot run this animation / radar / option combination; the message says why."""


class SceneGeometryError(EngineError):
    """A frame's geometry cannot be written into the loaded scene (the message names the file)."""


class SceneLoadError(EngineError):
    """Sionna could not load a frame's scene XML (the message names the file)."""


class PathEngineError(EngineError):
    """The path engine cannot run this animation / radar combination; the message says why."""


class PixelEngineError(EngineError):
    """The pixel engine cannot run with these parameters or this animation; the message says why."""


class ProxyResolutionWarning(UserWarning):
    """A mesh is coarser than the rule of the traced proxy (:data:`~.path.PROXY_SAGITTA_FRACTION`); the
    message names the object, by how much, and the edge length that would meet it."""


__all__ = ["EngineError", "ProxyResolutionWarning", "PathEngineError", "PixelEngineError", "SceneGeometryError", "SceneLoadError"]
