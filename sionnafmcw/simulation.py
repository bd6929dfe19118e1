"""``simulate``: an animation through an engine and the beat synthesizer into a run store.

For every frame :math:`n` (CPI start :math:`t_n` = the frame time): the engine gives the
:class:`~sionnafmcw.Echoes` at :math:`t_n`, :func:`~sionnafmcw.synthesize` turns them into the
IF cube with noise from a generator seeded by ``(seed, n)`` (so a resumed run, or a run of a
frame subset, gives the same cube for the same frame), and the store receives the cube and the
ground truth of every moving object: position (area-weighted centroid of its mesh), velocity
(the manifest's) and radial velocity :math:`\\dot R` from the radar's phase centre (the centroid
of the virtual array, positive receding). Memory is bounded by one frame.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import __version__, engines
from .engines import Engine
from .geometry import radial_velocity, world_phase_centre
from .radar import RadarConfig
from .store import RunStore, open_run
from .synthesis import synthesize


def _engine(engine, engine_options: dict | None) -> Engine:
    """The engine of a :func:`simulate` call: a registry name (:mod:`sionnafmcw.engines`) or an :class:`Engine`."""
    if isinstance(engine, str):
        return engines.create(engine, **(engine_options or {}))
    if not isinstance(engine, Engine):
        raise TypeError(f"simulate: engine must be a registered engine name ({', '.join(engines.names())}) or a "
                        f"sionnafmcw.engines.Engine, got {type(engine).__name__}")
    if engine_options:
        raise TypeError(f"simulate: engine_options ({', '.join(engine_options)}) apply to an engine given by name; "
                        f"{type(engine).__name__} is already built")
    return engine


def _frame_indices(frames, num_frames: int) -> list[int]:
    if frames is None:
        return list(range(num_frames))
    if isinstance(frames, slice):
        return list(range(num_frames))[frames]
    indices = [int(f) for f in frames]
    bad = [f for f in indices if not 0 <= f < num_frames]
    if bad:
        raise ValueError(f"simulate: frames {bad} are outside the animation's 0..{num_frames - 1}")
    return indices


def simulate(animation, radar, engine="path", out="run.zarr", frames=None, progress=True,
             radar_pose=None, seed: int = 0, noise: bool = True, engine_options: dict | None = None,
             leakage_db: float | None = None):
    """Simulate ``frames`` of ``animation`` and write the run store ``out``; returns it as a :class:`~sionnafmcw.store.Run`.

    Parameters
    ----------
    animation : Animation or path of an animation directory
    radar : anything :meth:`RadarConfig.resolve` takes (a RadarConfig, a preset name, a dict, a .json or TI .cfg path)
    engine : a registered engine name (:func:`sionnafmcw.engines.names`: ``"path"``, ``"pixel"``, ...) or an
        :class:`~sionnafmcw.engines.Engine` instance
    out : path of the Zarr store; an existing store with the same settings is resumed
    frames : iterable of frame indices or a slice (default: all); the store always spans all frames
    radar_pose : RadarPose overriding the animation's
    seed : noise seed; frame ``n`` uses ``numpy.random.default_rng([seed, n])``
    noise : add receiver thermal noise
    engine_options : keyword options of the engine when ``engine`` is a name (:func:`sionnafmcw.engines.options`)
    leakage_db : direct Tx-Rx coupling (dB) added to every frame (:meth:`Echoes.leakage`); None: none
    """
    from .animation import Animation, load_animation

    if not isinstance(animation, Animation):
        animation = load_animation(animation)
    radar = RadarConfig.resolve(radar)
    radar.validate(frame_period=animation.frame_period)
    pose = radar_pose if radar_pose is not None else animation.radar_pose
    if pose is None:
        raise ValueError(f"simulate: {animation.path} has no radar pose in animation.json; pass radar_pose=")
    engine_obj = _engine(engine, engine_options)
    settings = engine_obj.settings()
    indices = _frame_indices(frames, animation.num_frames)

    names = animation.object_names
    store = RunStore.open(
        out, radar, animation.num_frames, names,
        attrs={"radar": radar.to_dict(), "radar_pose": pose.to_dict(), "engine": settings,
               "scene": str(Path(animation.path).resolve()), "seed": int(seed), "noise": bool(noise),
               "leakage_db": leakage_db,
               "sionnafmcw_version": __version__},
    )
    done = store.done()
    todo = [f for f in indices if not done[f]]
    centre = world_phase_centre(radar, pose.position, pose.orientation)

    iterator = todo
    if progress and todo:
        from tqdm.auto import tqdm

        iterator = tqdm(todo, desc=f"simulate {Path(out).name}", unit="frame")
    for f in iterator:
        echoes = engine_obj.echoes(animation, radar, f, radar_pose=pose)
        rng = np.random.default_rng([int(seed), int(f)])
        cube = synthesize(echoes, radar, frame_time=animation.frames[f].time, noise=noise, rng=rng,
                          leakage_db=leakage_db)
        if names:
            positions_by_name = animation.object_positions(f, names)
            positions = np.array([positions_by_name[n] for n in names])
            velocities = np.array([animation.object_velocity(f, n) for n in names])
            radial = radial_velocity(positions, velocities, centre)
        else:
            positions = velocities = radial = None
        store.write_frame(f, cube, animation.frames[f].time, positions, velocities, radial)
    return open_run(out)


def __getattr__(name):
    # ENGINES: the registered engine names, for callers written before the registry (issue 10)
    if name == "ENGINES":
        return tuple(engines.names())
    raise AttributeError(f"module 'sionnafmcw.simulation' has no attribute {name!r}")
