"""Engines: turn one animation frame into :class:`~sionnafmcw.echoes.Echoes`.

* :class:`PathEngine` -- Sionna RT's path solver, per element (:mod:`sionnafmcw.engines.path`).
"""

from .path import FrameStats, PathEngine, PathEngineError

__all__ = ["FrameStats", "PathEngine", "PathEngineError"]
