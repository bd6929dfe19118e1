'''Engines: turn one animation frame into :class:`~sionnafmcw.echoes.Echoes`, and their registry.

* ``"path"``: :class:`PathEngine` -- one Sionna RT trace for the whole array (Tx centre to Rx
  centre; every element pair's delay, gain and Doppler from the interaction points), the direct
  echo by near-field physical optics on a render from the phase centre (and ray-tube PO for
  multi-bounce chains), Sionna's paths with a diffuse interaction with a random phase fixed to
  every scatterer (:mod:`sionnafmcw.engines.path`, :mod:`sionnafmcw.engines.po_render`).
* ``"pixel"``: :class:`PixelEngine` -- a render from the radar, every hit pixel a point target
  (:mod:`sionnafmcw.engines.pixel`).

Every engine is an :class:`~sionnafmcw.engines.base.Engine`: the base class owns the per-frame
template (radar pose, radar validation, scene (re)loading at the carrier, per-frame geometry,
kernel tracking, :class:`~sionnafmcw.engines.base.FrameStats`) and each engine writes only its
hooks (:mod:`sionnafmcw.engines.base`). The shared scene state is
:mod:`sionnafmcw.engines.loaded_scene`, the PO render of the lit surface (for either engine)
:mod:`sionnafmcw.engines.po_render`; everything Sionna-specific goes through
:mod:`sionnafmcw.sionna_rt`.

The registry is what :func:`~sionnafmcw.simulation.simulate`, the command line and data-set
specs use: :func:`names`, :func:`engine_class`, :func:`create` and :func:`options`. Targets
are imported lazily, so listing the engines does not load Sionna.

Adding an engine
----------------
One new file with the engine, and one :func:`register` line. For example an engine that returns
the ideal point-target echo of every moving object's centroid (``tests/test_engines.py`` runs it
through ``simulate``)::

    # mypackage/centroid.py
    import numpy as np
    from sionnafmcw import Echoes
    from sionnafmcw.engines import Engine
    from sionnafmcw.geometry import rotation_matrix, world_to_radar

    class CentroidEngine(Engine):
        """Every moving object is an ideal point target of RCS ``rcs`` (m^2) at its mesh centroid."""

        name = "centroid"

        def __init__(self, rcs: float = 1.0, track_kernels: bool = False):
            super().__init__(track_kernels=track_kernels)
            self.rcs = float(rcs)

        def _settings(self):
            return {"rcs": self.rcs}

        def _load(self, scene, animation, radar):
            return None  # nothing beyond the loaded scene

        def _frame_echoes(self, animation, radar, frame, pose):
            names = animation.object_names
            centroids = animation.object_positions(frame, names)
            p = world_to_radar(np.array([centroids[n] for n in names]), pose.position, pose.orientation)
            v = np.array([animation.object_velocity(frame, n) for n in names]) @ rotation_matrix(pose.orientation)
            ranges = np.linalg.norm(p, axis=-1)
            radial = np.einsum("ij,ij->i", v, p) / ranges  # positive receding
            echoes = Echoes.point_targets(radar, ranges, radial, np.arctan2(p[:, 1], p[:, 0]),
                                          np.arcsin(p[:, 2] / ranges), rcs=self.rcs, labels=names)
            return echoes, {"num_targets": len(names)}   # the figures land in engine.stats

    # where the package registers its engines (e.g. its __init__.py)
    from sionnafmcw import engines
    engines.register("centroid", "mypackage.centroid:CentroidEngine")

after which ``simulate(animation, radar, engine="centroid")`` and
``engines.create("centroid", rcs=2.0)`` work, and ``engines.options("centroid")`` lists
``rcs`` and ``track_kernels``.
'''

from __future__ import annotations

import importlib
import inspect

from .base import Engine, FrameStats
from .errors import (EngineError, PathEngineError, PixelEngineError, ProxyResolutionWarning, SceneGeometryError,
                     SceneLoadError)

_REGISTRY: dict[str, object] = {}  # name -> engine class or "module:Class" (imported on first use)


def register(name: str, target) -> None:
    """Register the engine ``target`` under ``name``.

    ``target`` is an :class:`~sionnafmcw.engines.base.Engine` subclass or a ``"module:Class"``
    string imported on first use (so registering costs nothing). The class's ``name`` attribute
    must equal ``name`` (it is what ``settings()["engine"]`` and the run stores record).
    Registering a name again with another target replaces it.
    """
    if not isinstance(name, str) or not name.strip() or name != name.strip():
        raise EngineError(f"engines.register: the engine name must be a non-empty string without surrounding "
                     f"spaces, got {name!r}")
    if isinstance(target, str):
        module, sep, attribute = target.partition(":")
        if not sep or not module or not attribute:
            raise EngineError(f"engines.register({name!r}): target {target!r} must be 'module:Class' or a class")
    elif not inspect.isclass(target):
        raise EngineError(f"engines.register({name!r}): target must be an Engine subclass or 'module:Class', "
                     f"got {type(target).__name__}")
    _REGISTRY[name] = target


def names() -> list[str]:
    """The registered engine names, in registration order."""
    return list(_REGISTRY)


def engine_class(name: str) -> type:
    """The engine class registered as ``name`` (imported now if registered as ``"module:Class"``).

    Raises :class:`~sionnafmcw.engines.base.EngineError` naming an unknown engine and the known
    ones, or a target that is not an :class:`~sionnafmcw.engines.base.Engine` with this name.
    """
    if name not in _REGISTRY:
        raise EngineError(f"engine {name!r} is unknown; choose one of {', '.join(_REGISTRY) or 'none (none registered)'}")
    target = _REGISTRY[name]
    if isinstance(target, str):
        module, _, attribute = target.partition(":")
        try:
            target = getattr(importlib.import_module(module), attribute)
        except (ImportError, AttributeError) as err:
            raise EngineError(f"engine {name!r}: cannot import its target {_REGISTRY[name]!r}: {err}") from err
    if not (inspect.isclass(target) and issubclass(target, Engine)):
        raise EngineError(f"engine {name!r}: {target!r} is not a subclass of sionnafmcw.engines.Engine")
    if target.name != name:
        raise EngineError(f"engine {name!r}: class {target.__name__} has name = {target.name!r}; set "
                     f"{target.__name__}.name = {name!r} (it is the name run stores record)")
    _REGISTRY[name] = target
    return target


def options(name: str) -> dict:
    """The keyword options of engine ``name`` and their defaults (``inspect.Parameter.empty`` if required)."""
    signature = inspect.signature(engine_class(name).__init__)
    return {p.name: p.default for p in list(signature.parameters.values())[1:]
            if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)}


def create(name: str, **engine_options):
    """A new engine ``name`` with ``engine_options``.

    Raises :class:`~sionnafmcw.engines.base.EngineError` naming an unknown engine (and the known
    ones) or an unknown option (and the valid ones); the engine's own errors for bad values.
    """
    valid = options(name)
    unknown = [k for k in engine_options if k not in valid]
    if unknown:
        raise EngineError(f"engine {name!r} has no option {', '.join(map(repr, unknown))}; "
                     f"valid options: {', '.join(valid) or 'none'}")
    return engine_class(name)(**engine_options)


register("path", "sionnafmcw.engines.path:PathEngine")
register("pixel", "sionnafmcw.engines.pixel:PixelEngine")

_LAZY = {
    "LoadedScene": "loaded_scene",
    "PathEngine": "path",
    "PixelEngine": "pixel", "PixelGrid": "pixel_grid", "PixelRender": "pixel_grid",
}


def __getattr__(name):
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'sionnafmcw.engines' has no attribute {name!r}")


__all__ = ["Engine", "EngineError", "FrameStats", "PathEngineError", "PixelEngineError", "ProxyResolutionWarning",
           "SceneGeometryError", "SceneLoadError", "create", "engine_class", "names", "options", "register", *_LAZY]
