"""Engines: turn one animation frame into :class:`~sionnafmcw.echoes.Echoes`.

* :class:`PathEngine` -- Sionna RT's path solver, per element (:mod:`sionnafmcw.engines.path`).
* :class:`PixelEngine` -- a render from the radar, every hit pixel a point target (:mod:`sionnafmcw.engines.pixel`).

Both load the scene with :mod:`sionnafmcw.engines.scene_loading` and share the per-frame scene
state of :mod:`sionnafmcw.engines.frame_scene` (geometry updates, radar pose, kernel tracking,
barycentric interpolation).
"""

from .path import FrameStats, PathEngine, PathEngineError
from .pixel import PixelEngine, PixelEngineError, PixelFrameStats, PixelGrid, PixelRender

__all__ = ["FrameStats", "PathEngine", "PathEngineError", "PixelEngine", "PixelEngineError", "PixelFrameStats",
           "PixelGrid", "PixelRender"]
