"""The engine contract: :class:`Engine` owns the per-frame template, each engine writes its hooks.

An engine turns one frame of an :class:`~sionnafmcw.animation.Animation`, seen by a
:class:`~sionnafmcw.radar.RadarConfig` at a radar pose, into the
:class:`~sionnafmcw.echoes.Echoes` that the beat synthesizer turns into the IF cube. Every engine
runs the same steps per frame, written once here in :meth:`Engine.echoes` (the template method):

1. the radar pose of the call (the argument, else the animation's; :func:`resolve_pose`);
2. ``radar.validate`` against the frame period, then :meth:`Engine._check_radar` (hook);
3. the scene, loaded once per (animation, radar): on a new key the animation's carrier check,
   :func:`~sionnafmcw.engines.loaded_scene.load_radar_scene` (scene XML of frame 0 at the
   carrier), :meth:`Engine._load` (hook: devices, materials, the engine's own per-scene state)
   and :meth:`LoadedScene.load <sionnafmcw.engines.loaded_scene.LoadedScene.load>` (per-object
   geometry of frame 0);
4. the geometry of the frame (the meshes whose PLY changed) and, when it changed,
   :meth:`Engine._geometry_changed` (hook: what the engine's kernels need after a geometry update);
5. :meth:`Engine._frame_echoes` (hook: the engine's physics), which returns the echoes and its
   own per-frame figures;
6. a :class:`FrameStats` (time, Dr.Jit kernels launched / compiled / new, reload, the engine's
   figures) appended to :attr:`Engine.stats`.

Steps 3-5 run under :func:`~sionnafmcw.sionna_rt.track_kernels`. Besides the hooks an engine
declares its registry :attr:`~Engine.name`, its constructor options (keyword arguments with
defaults, which :func:`sionnafmcw.engines.options` reads) and :meth:`Engine._settings`;
:meth:`Engine.settings`, ``repr``, ``__call__``, :meth:`Engine.close`, :attr:`Engine.last_stats`
and :attr:`Engine.scene` come from the base.
"""

from __future__ import annotations

import abc
import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..animation import Animation, RadarPose
from .errors import EngineError


@dataclass
class FrameStats:
    """What one :meth:`Engine.echoes` call did.

    ``seconds``: wall time of the call; ``kernels_launched``: Dr.Jit JIT kernels run;
    ``kernels_compiled``: those found neither in Dr.Jit's in-memory nor on-disk cache (so compiled
    by LLVM); ``new_kernel_hashes``: kernels this engine had not launched before (independent of
    the caches: the measure of recompilation); ``reloaded``: the scene was (re)loaded in this call.
    ``figures`` holds ``geometry_seconds`` (writing the frame's meshes into the scene: Mitsuba's
    parameter update, which rebuilds the ray-tracing acceleration structure) and the engine's own
    figures (the path engine's ``num_paths``, ``num_traced_paths`` and ``num_duplicates``, the
    pixel engine's ``trace_seconds``, ``num_hits``, ``num_contributions``), also readable as
    attributes (``stats.num_paths``).
    """

    frame: int
    seconds: float
    kernels_launched: int
    kernels_compiled: int
    new_kernel_hashes: int
    reloaded: bool
    figures: dict = field(default_factory=dict)

    def __getattr__(self, name):
        if name.startswith("__") or name == "figures":
            raise AttributeError(name)
        try:
            return self.figures[name]
        except KeyError:
            raise AttributeError(f"FrameStats has no field or figure {name!r} (figures: "
                                 f"{', '.join(self.figures) or 'none'})") from None


def resolve_pose(animation: Animation, radar_pose, frame: int | None = None) -> RadarPose:
    """The radar pose of ``frame``: from ``radar_pose`` (a :class:`RadarPose`, a ``(position, orientation)``
    pair, or a radar track: a sequence of one :class:`RadarPose` per animation frame), else the
    animation's (:meth:`~sionnafmcw.animation.Animation.radar_pose_at`; its default pose when
    ``frame`` is None).

    Raises :class:`EngineError` naming the animation when neither is given, and naming ``radar_pose``
    when it is not one of these.
    """
    if radar_pose is None:
        pose = animation.radar_pose if frame is None else animation.radar_pose_at(frame)
        if pose is None:
            raise EngineError(f"{animation.path}: animation.json has no 'radar' pose; pass radar_pose=")
        return pose
    if isinstance(radar_pose, RadarPose):
        return radar_pose
    if isinstance(radar_pose, (list, tuple)) and radar_pose and isinstance(radar_pose[0], RadarPose):
        if len(radar_pose) != animation.num_frames:
            raise EngineError(f"radar_pose: a radar track has one RadarPose per frame of the animation "
                              f"({animation.num_frames}), got {len(radar_pose)}")
        bad = [i for i, p in enumerate(radar_pose) if not isinstance(p, RadarPose)]
        if bad:
            raise EngineError(f"radar_pose[{bad[0]}]: a radar track holds RadarPose objects, got "
                              f"{type(radar_pose[bad[0]]).__name__}")
        return radar_pose[0 if frame is None else frame]
    try:
        position, orientation = radar_pose
        return RadarPose(np.asarray(position, dtype=float), np.asarray(orientation, dtype=float))
    except (TypeError, ValueError) as err:
        raise EngineError(f"radar_pose must be a RadarPose, a (position, orientation) pair or a list of one "
                          f"RadarPose per frame, got {radar_pose!r} ({err})") from None


class Engine(abc.ABC):
    """Base of every engine: the per-frame template :meth:`echoes` and what all engines share.

    Subclasses set :attr:`name` (their registry name), take their options as keyword arguments
    with defaults (ending with ``track_kernels=True``, passed on to ``super().__init__``) and
    implement :meth:`_settings`, :meth:`_load` and :meth:`_frame_echoes`; :meth:`_check_radar`
    and :meth:`_geometry_changed` are optional hooks. See the module docstring for the order.
    """

    #: Registry name (``settings()["engine"]``); :func:`sionnafmcw.engines.register` checks it.
    name: ClassVar[str] = ""
    #: Constant descriptions of the engine's model, added to :meth:`settings` (not options).
    FIXED_SETTINGS: ClassVar[dict] = {}

    def __init__(self, track_kernels: bool = True):
        self.track_kernels = bool(track_kernels)
        self.stats: list[FrameStats] = []
        self._seen_hashes: set = set()
        self._key: tuple | None = None
        self._loaded = None   # LoadedScene: the Sionna scene and the geometry of the current frame
        self._state = None    # the engine's own per-scene state (what _load returned)

    # ------------------------------------------------------------------ hooks
    @abc.abstractmethod
    def _settings(self) -> dict:
        """The engine's options as a plain dict (JSON types), in constructor order."""

    @abc.abstractmethod
    def _load(self, scene, animation: Animation, radar):
        """Prepare the freshly loaded Sionna ``scene`` (devices, materials) and return the per-scene state.

        Runs before the per-object geometry of frame 0 is read (``scene.mi_scene_params``), so
        whatever adds scene parameters (devices, velocities) belongs here. The loaded scene is
        :attr:`_loaded` from then on; the returned object is :attr:`_state`.
        """

    @abc.abstractmethod
    def _frame_echoes(self, animation: Animation, radar, frame: int, pose: RadarPose):
        """The echoes of ``frame`` at ``pose`` and the engine's figures: ``(Echoes, dict)``.

        The geometry of ``frame`` is already in :attr:`_loaded` (faces, world vertices and vertex
        velocities per object) and in the Sionna scene.
        """

    def _check_radar(self, radar) -> None:
        """Reject a radar this engine cannot model (after ``radar.validate``); default: accept all."""

    def _geometry_changed(self) -> None:
        """Called after the frame's meshes were written into the scene (and only then); default: nothing."""

    # ------------------------------------------------------------------ template
    def echoes(self, animation: Animation, radar, frame: int, radar_pose: RadarPose | None = None):
        """Echoes ``[num_tx, num_rx, P]`` of ``frame`` (Tx in physical element order).

        ``radar_pose`` overrides the animation's pose of the frame (a :class:`RadarPose`, a
        ``(position, orientation)`` pair or a radar track, :func:`resolve_pose`). The scene is loaded
        on the first call and again when the animation or the radar changes; a :class:`FrameStats`
        is appended to :attr:`stats`.
        """
        # the scene state imports Dr.Jit / Mitsuba / Sionna (sionnafmcw.sionna_rt): loaded when an
        # engine first runs, so that the registry and the error classes stay light to import
        from ..sionna_rt import track_kernels
        from .loaded_scene import LoadedScene, load_radar_scene

        t0 = time.perf_counter()
        pose = resolve_pose(animation, radar_pose, frame)
        radar.validate(frame_period=animation.frame_period)
        self._check_radar(radar)
        key = (id(animation), str(animation.path), radar.to_json())
        reloaded = False
        with track_kernels(self.track_kernels, self._seen_hashes) as kernels:
            if self._loaded is None or self._key != key:
                self.close()
                animation.check_frequency(radar.fc)
                scene = load_radar_scene(animation.frames[0].xml, radar.fc)
                state = self._load(scene, animation, radar)
                self._loaded = LoadedScene.load(scene, animation)
                self._state, self._key = state, key
                reloaded = True
            t_geometry = time.perf_counter()
            if self._loaded.update_geometry(animation, frame):
                self._geometry_changed()
            t_geometry = time.perf_counter() - t_geometry
            echoes, figures = self._frame_echoes(animation, radar, frame, pose)
        figures = {"geometry_seconds": t_geometry} | dict(figures)
        self.stats.append(FrameStats(frame, time.perf_counter() - t0, kernels.launched, kernels.compiled,
                                     kernels.new, reloaded, figures))
        return echoes

    def __call__(self, animation: Animation, radar, frame: int, radar_pose=None):
        return self.echoes(animation, radar, frame, radar_pose)

    def close(self) -> None:
        """Drop the loaded scene (the next call loads it again)."""
        self._loaded = self._state = self._key = None

    # ------------------------------------------------------------------ description
    def settings(self) -> dict:
        """The engine settings as a plain dict (for run stores): ``"engine"`` (the registry name),
        the options (:meth:`_settings`) and the model's constants (:attr:`FIXED_SETTINGS`)."""
        return {"engine": self.name, **self._settings(), **self.FIXED_SETTINGS}

    def __repr__(self) -> str:
        return f"{type(self).__name__}(" + ", ".join(f"{k}={v!r}" for k, v in self._settings().items()) + ")"

    @property
    def last_stats(self) -> FrameStats | None:
        """The :class:`FrameStats` of the last call (None before the first)."""
        return self.stats[-1] if self.stats else None

    @property
    def scene(self):
        """The Sionna scene currently loaded (None before the first frame)."""
        return None if self._loaded is None else self._loaded.scene


__all__ = ["Engine", "FrameStats", "resolve_pose"]
