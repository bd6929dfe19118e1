"""``simulate``: an animation through an engine and the beat synthesizer into a run store.

For every frame :math:`n` (CPI start :math:`t_n` = the frame time): the engine gives the
:class:`~sionnafmcw.Echoes` at :math:`t_n`, :func:`~sionnafmcw.synthesize` turns them into the
IF cube with noise from a generator seeded by ``(seed, n)`` (so a resumed run, or a run of a
frame subset, gives the same cube for the same frame; the noise-free cube of the engine's static
echo block, the same every frame, is synthesised once per block and reused: ``static_cache``),
and the store receives the cube, the radar's pose of the frame and the ground truth of every
moving object: position (area-weighted centroid of its mesh), velocity (the manifest's) and radial
velocity :math:`\\dot R` from the radar's phase centre (the centroid of the virtual array, positive
receding; relative to the phase centre's own motion when the radar moves,
:func:`relative_radial_velocity`), and for a scene with people (the manifest's ``people`` entry)
every person's keypoints and activity (:mod:`sionnafmcw.store`). The synthesis and the store write
of frame :math:`n` run on one worker thread while
the engine computes the next frames, up to :data:`PENDING_FRAMES` frames ahead; frames are written
in order, each once its cube is complete (a signal stops the main thread; the write under way
finishes first, the frames queued behind it are left to a resume). Memory is bounded by the echoes
of the frames queued and one frame's synthesis; the synthesis is checked against the memory
available before anything is written. The run is crash-safe: killed or interrupted at any instant, the store is
valid and the same call resumes it (see :func:`simulate`).
"""

from __future__ import annotations

import threading
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from . import __version__, engines
from .engines import Engine
from .geometry import radial_velocity, world_phase_centre
from .radar import RadarConfig
from .interrupts import Interrupted, as_interrupted, deferred, handling_signals, is_interrupt, received
from .store import RunStore, check_run, open_run
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


class SimulationError(ValueError):
    """A :func:`simulate` call refused before anything is written (bad argument, radar that cannot
    see the scene, too little memory); the message names the parameter and what would fix it."""


class SimulationInterrupted(Interrupted):
    """:func:`simulate` stopped by SIGINT / SIGTERM; the store is valid and resumes.

    ``done``: frames of the selection done in the store, ``total``: frames selected, ``path``: the store.
    """

    def __init__(self, signum: int, done: int, total: int, path):
        super().__init__(signum, f"interrupted after {done} of {total} frames; simulate again with the same "
                                 "arguments to resume")
        self.done, self.total, self.path = int(done), int(total), Path(path)


def _frame_indices(frames, num_frames: int) -> list[int]:
    span = f"the animation's frames 0..{num_frames - 1}"
    if frames is None:
        return list(range(num_frames))
    if isinstance(frames, slice):
        indices = list(range(num_frames))[frames]
        if not indices:
            raise SimulationError(f"simulate: frames={frames!r} selects no frame of {span}; choose a slice inside it")
        return indices
    try:
        indices = [int(f) for f in frames]
    except (TypeError, ValueError):
        raise SimulationError(f"simulate: frames={frames!r} must be a slice or integer frame indices") from None
    if not indices:
        raise SimulationError(f"simulate: frames={frames!r} selects no frame; give at least one of {span}")
    bad = [f for f in indices if not 0 <= f < num_frames]
    if bad:
        raise SimulationError(f"simulate: frames {bad} are outside {span}")
    return indices


def _done_count(out: Path, indices) -> int:
    """Frames of ``indices`` done in the store ``out`` (0 when there is no readable store)."""
    try:
        done = open_run(out).done_mask
    except Exception:  # noqa: BLE001 - no store (yet)
        return 0
    return int(sum(done[f] for f in indices if f < done.size))


def _check_arguments(seed, noise, leakage_db) -> None:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SimulationError(f"simulate: seed={seed!r} must be an integer >= 0 (numpy's SeedSequence takes no "
                              "negative entropy)")
    if not isinstance(noise, (bool, np.bool_)):
        raise SimulationError(f"simulate: noise={noise!r} must be True or False")
    if leakage_db is not None:
        try:
            value = float(leakage_db)
        except (TypeError, ValueError):
            raise SimulationError(f"simulate: leakage_db={leakage_db!r} must be a number (dB) or None") from None
        if not np.isfinite(value):
            raise SimulationError(f"simulate: leakage_db={leakage_db!r} must be a finite level in dB (or None for "
                                  "no leakage)")


def _check_ranges(animation, radar, poses, indices, names) -> dict:
    r"""Truth positions ``{frame: [object, 3]}`` of the selected frames, after checking that every moving
    object lies inside the radar's unambiguous range :math:`R_{max} = cF_s/(2\mu)` from the phase centre
    of the frame's radar pose ``poses[frame]`` (beyond it the beat frequency exceeds the sample rate and
    the echo aliases to a wrong range)."""
    positions = {}
    if not names:
        return positions
    worst = (0.0, None, None)
    for f in indices:
        centre = world_phase_centre(radar, poses[f].position, poses[f].orientation)
        by_name = animation.object_positions(f, names)
        positions[f] = np.array([by_name[n] for n in names])
        ranges = np.linalg.norm(positions[f] - centre, axis=-1)
        k = int(np.argmax(ranges))
        if ranges[k] > worst[0]:
            worst = (float(ranges[k]), names[k], f)
    if worst[0] > radar.max_range:
        r, name, f = worst
        raise SimulationError(
            f"simulate: moving object {name!r} is {r:.2f} m from the radar in frame {f}, beyond radar "
            f"{radar.name!r}'s maximum range {radar.max_range:.2f} m (c fs / (2 slope)); its echo would alias to a "
            f"wrong range: raise the radar's sample rate fs or lower its slope (or move the radar closer)")
    return positions


#: Frames whose echoes may wait for the synthesis stage while the engine computes the next one. The
#: stages take about as long as each other on the walk, and a frame's synthesis varies (2.6-2.9 times
#: the CPU for a frame of the lap's second half, :mod:`sionnafmcw.threads`), so with one frame queued
#: the engine waited whenever a frame's synthesis ran long (3.7-4.8 s of "synth+st" in a 100-frame
#: run, ``benchmarks/circle_walk.py``); with two, a short one catches up and the synthesis can tell
#: that it is behind (:func:`~sionnafmcw.threads.synthesis_catching_up`).
#: ``benchmarks/run_resources.py --settings arena1 queue1``: one place makes the run 1.04 times as
#: long; each queued frame holds its echoes (tens of MB for the walk).
PENDING_FRAMES = 2

#: Bytes per cube sample while one frame is synthesised and written: the complex128 sum (16), the
#: complex128 noise (16), the complex64 cube (8) and Zarr's encoded copy of it (8).
SYNTHESIS_BYTES_PER_SAMPLE = 48
#: Bytes per cube sample kept across frames: the noise-free complex128 cube of the engine's static
#: echo block (``synthesize(..., static_cache=...)``).
STATIC_CUBE_BYTES_PER_SAMPLE = 16
#: The static block's cube of the last run, where the process keeps static blocks
#: (:func:`~sionnafmcw.engines.path.keep_static_blocks`): a run whose engine reuses the block reuses it too.
_KEPT_STATIC_CUBE: dict = {}


def _keeps_static_blocks() -> bool:
    """Whether the process keeps static blocks; the kept cube is dropped where it does not."""
    from .engines import path

    if not path.static_blocks_kept():
        _KEPT_STATIC_CUBE.clear()
        return False
    return True


def available_memory() -> int:
    """Bytes of memory this process can still use: the system's available memory, capped by the
    cgroup (container) limit minus its usage when there is one."""
    import psutil

    avail = int(psutil.virtual_memory().available)
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = int(Path("/sys/fs/cgroup/memory.current").read_text().strip())
        if limit != "max":
            avail = min(avail, int(limit) - used)
    except (OSError, ValueError):
        pass
    return max(avail, 0)


def frame_memory(radar, engine_obj=None) -> dict:
    r"""Estimated peak memory (bytes) of one frame: ``{"cube", "synthesis", "static", "engine", "total"}``.

    The cube holds :math:`N = L M N_{rx} N_s` samples; synthesis and the store write need about
    :data:`SYNTHESIS_BYTES_PER_SAMPLE` bytes per sample (of which 8 are the complex64 cube itself),
    the static block's cube :data:`STATIC_CUBE_BYTES_PER_SAMPLE` more, kept across frames, for an
    engine with a ``static_scene`` (the path engine's default).
    ``engine``: the engine's own estimate, ``engine.memory_estimate(radar)`` when it has one, else 0.
    The engine's frame :math:`n + 1` runs while frame :math:`n` is synthesised, so the total is
    their sum.
    """
    n = int(radar.num_chirps) * int(radar.num_tx) * int(radar.num_rx) * int(radar.num_samples)
    estimate = getattr(engine_obj, "memory_estimate", None)
    engine_bytes = int(estimate(radar)) if callable(estimate) else 0
    synthesis = SYNTHESIS_BYTES_PER_SAMPLE * n
    static = STATIC_CUBE_BYTES_PER_SAMPLE * n if getattr(engine_obj, "static_scene", False) else 0
    return {"samples": n, "cube": 8 * n, "synthesis": synthesis, "static": static, "engine": engine_bytes,
            "total": synthesis + static + engine_bytes}


def _check_memory(radar, engine_obj) -> None:
    need = frame_memory(radar, engine_obj)
    have = available_memory()
    if need["total"] > have:
        gib = 2.0 ** 30
        engine_part = f", engine {need['engine'] / gib:.2f} GiB" if need["engine"] else ""
        raise SimulationError(
            f"simulate: one frame needs about {need['total'] / gib:.2f} GiB (cube of {need['samples']:.3g} samples = "
            f"{radar.num_chirps} chirps x {radar.num_tx} Tx x {radar.num_rx} Rx x {radar.num_samples} samples, "
            f"{need['cube'] / gib:.2f} GiB as complex64; synthesis {need['synthesis'] / gib:.2f} GiB, the static "
            f"block's cube {need['static'] / gib:.2f} GiB{engine_part}) "
            f"but {have / gib:.2f} GiB of memory is available; lower the radar's num_samples or num_chirps")


def radar_poses(animation, radar_pose=None) -> list:
    """The radar's :class:`~sionnafmcw.animation.RadarPose` in every frame of ``animation``: ``radar_pose`` (one
    pose for every frame, or a radar track, :func:`sionnafmcw.engines.base.resolve_pose`), else the
    animation's (its radar track, else its pose). Raises :class:`SimulationError` naming what is missing
    or wrong."""
    from .engines.base import resolve_pose
    from .engines.errors import EngineError

    if radar_pose is None and animation.radar_pose is None and animation.radar_track is None:
        raise SimulationError(f"simulate: {animation.path} has no radar pose in animation.json; pass radar_pose=")
    try:
        return [resolve_pose(animation, radar_pose, f) for f in range(animation.num_frames)]
    except EngineError as err:
        raise SimulationError(f"simulate: {err}") from None


def track_attribute(poses) -> dict | None:
    """The store's ``radar_track`` attribute: None for a radar that keeps one pose (and motion) in every
    frame, else ``{"frames", "sha256"}``: the digest of every frame's pose and motion (a resume with
    another track is refused; the poses themselves are the store's per-frame arrays)."""
    import hashlib

    first = poses[0].to_dict()
    if all(p.to_dict() == first for p in poses):
        return None
    digest = hashlib.sha256()
    for p in poses:
        for name in ("position", "orientation", "velocity", "angular_velocity", "acceleration", "angular_acceleration"):
            digest.update(np.asarray(getattr(p, name), dtype="<f8").tobytes())
    return {"frames": len(poses), "sha256": digest.hexdigest()}


def relative_radial_velocity(positions, velocities, centre, centre_velocity) -> np.ndarray:
    r"""Range rate from a moving phase centre, :math:`\dot R = (\mathbf p - \mathbf c)\cdot(\mathbf v - \dot{\mathbf c})
    / \lVert\mathbf p - \mathbf c\rVert` (m/s, positive receding): what the radar measures of a target
    whatever the radar's own motion (:func:`sionnafmcw.geometry.radial_velocity` for a radar at rest)."""
    return radial_velocity(positions, np.asarray(velocities, float) - np.asarray(centre_velocity, float), centre)


def simulate(animation, radar, engine="path", out="run.zarr", frames=None, progress=True,
             radar_pose=None, seed: int = 0, noise: bool = True, engine_options: dict | None = None,
             leakage_db: float | None = None, repair: bool = False, wait: float = 0.0, threads: int | None = None):
    """Simulate ``frames`` of ``animation`` and write the run store ``out``; returns it as a :class:`~sionnafmcw.store.Run`.

    Parameters
    ----------
    animation : Animation or path of an animation directory
    radar : anything :meth:`RadarConfig.resolve` takes (a RadarConfig, a preset name, a dict, a .json or TI .cfg path)
    engine : a registered engine name (:func:`sionnafmcw.engines.names`: ``"path"``, ``"pixel"``, ...) or an
        :class:`~sionnafmcw.engines.Engine` instance
    out : path of the Zarr store; an existing store with the same settings is resumed
    frames : iterable of frame indices or a slice (default: all); the store always spans all frames
    radar_pose : RadarPose (every frame), or a radar track (a list of one RadarPose per animation frame, with
        its velocities), overriding the animation's pose or track
    seed : noise seed (integer >= 0); frame ``n`` uses ``numpy.random.default_rng([seed, n])``
    noise : add receiver thermal noise
    engine_options : keyword options of the engine when ``engine`` is a name (:func:`sionnafmcw.engines.options`)
    leakage_db : direct Tx-Rx coupling (dB) added to every frame (:meth:`Echoes.leakage`); None: none
    repair : before resuming, read every done frame of an existing store back and mark the unreadable
        ones for recomputation (:func:`sionnafmcw.store.check_run`)
    wait : seconds to wait for another live process writing ``out`` to finish (then resume what it left)
    threads : CPU threads of the run (default: the cores this process may use); the engine's Dr.Jit pool
        gets ``threads - 1`` of them and BLAS one while the frames run (:mod:`sionnafmcw.threads`)

    Notes
    -----
    Crash safety. Everything is checked before anything is written: the arguments, the frame
    selection, the materials at the carrier, every moving object inside the radar's maximum range
    (:class:`SimulationError` otherwise) and the memory of one frame (:func:`frame_memory`) against
    :func:`available_memory`. The store appears at ``out`` only once complete
    (:class:`~sionnafmcw.store.RunStore`), frames are marked done after their data, and SIGINT /
    SIGTERM (in the main thread) stop the run between writes with :class:`SimulationInterrupted`.
    """
    with handling_signals():
        return _simulate(animation, radar, engine, out, frames, progress, radar_pose, seed, noise,
                         engine_options, leakage_db, repair, wait, threads)


def _simulate(animation, radar, engine, out, frames, progress, radar_pose, seed, noise, engine_options,
              leakage_db, repair, wait, threads):
    from .animation import Animation, load_animation
    from .threads import check_threads, run_threads, synthesis_catching_up

    _check_arguments(seed, noise, leakage_db)
    threads = check_threads(threads, "simulate", SimulationError)
    if not isinstance(animation, Animation):
        animation = load_animation(animation)
    radar = RadarConfig.resolve(radar)
    radar.validate(frame_period=animation.frame_period)
    poses = radar_poses(animation, radar_pose)
    pose = poses[0]
    indices = _frame_indices(frames, animation.num_frames)
    engine_obj = _engine(engine, engine_options)
    settings = engine_obj.settings()
    _check_memory(radar, engine_obj)
    animation.check_frequency(radar.fc)
    names = animation.object_names
    positions_at = _check_ranges(animation, radar, poses, indices, names)
    people = animation.people
    people_arrays = None if people is None else {
        "names": people.names, "joints": people.keypoint_names, "object_person": people.object_person(names)}

    out = Path(out)
    if repair and out.exists():
        check_run(out, repair=True)
    store, bar = None, None
    try:
        with deferred():  # a signal during creation: the store is finished (or removed), then the interrupt
            store = RunStore.open(
                out, radar, animation.num_frames, names,
                attrs={"radar": radar.to_dict(), "radar_pose": pose.to_dict(), "radar_track": track_attribute(poses),
                       "engine": settings,
                       "scene": str(Path(animation.path).resolve()), "seed": int(seed), "noise": bool(noise),
                       "leakage_db": leakage_db,
                       **({"people": {n: people.info[n] for n in people.names}} if people is not None else {}),
                       "sionnafmcw_version": __version__},
                wait=wait, hold_lock=True, people=people_arrays,
            )
        with deferred():
            done = store.done()
        todo = [f for f in indices if not done[f]]
        if progress and todo:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(todo), desc=f"simulate {out.name}", unit="frame")
        # the beat cube of the engine's static echo block, computed once per block: kept across runs with the
        # block itself where the process keeps static blocks (the entry names its block and radar)
        static_cache = _KEPT_STATIC_CUBE if _keeps_static_blocks() else {}

        def synthesise(f, echoes):
            rng = np.random.default_rng([int(seed), int(f)])
            return synthesize(echoes, radar, frame_time=animation.frames[f].time, noise=noise, rng=rng,
                              leakage_db=leakage_db, static_cache=static_cache)

        def write(f, cube):
            if names:
                from .kinematics import element_kinematics

                positions = positions_at[f]
                velocities = np.array([animation.object_velocity(f, n) for n in names])
                centre = element_kinematics(poses[f], radar.phase_centre[None])
                radial = relative_radial_velocity(positions, velocities, centre.position[0], centre.velocity[0])
            else:
                positions = velocities = radial = None
            joints = activities = None
            if people is not None:
                joints, activities = people.keypoints[f], people.activities[f]
            store.write_frame(f, cube, animation.frames[f].time, positions, velocities, radial, joints, activities,
                              radar_pose=poses[f])
            if bar is not None:
                bar.update(1)

        # frame n is synthesised and written on a worker thread while the engine computes the next
        # frames (numpy, finufft and the store release the GIL). One worker: frames are written in
        # order, each once its cube is complete, so the store and its crash safety are as without
        # the overlap; at most PENDING_FRAMES frames wait (memory). When the engine fails, every
        # frame it computed is still written; an interrupt finishes the frame being synthesised.
        # A frame whose synthesis starts while the echoes of a later frame are ready (queued, or in
        # the engine's hands waiting for a place in the queue) is synthesised on all the run's
        # threads: the synthesis is behind the engine (sionnafmcw.threads).
        ready = [0]
        queue_lock = threading.Lock()

        def finish(f, echoes):
            with queue_lock:
                ready[0] -= 1
                behind = ready[0] > 0
            with synthesis_catching_up(behind):
                cube = synthesise(f, echoes)
            write(f, cube)

        with run_threads(threads), \
                ThreadPoolExecutor(max_workers=1, thread_name_prefix="sionnafmcw-synthesis") as pool:
            pending = deque()
            try:
                for f in todo:
                    echoes = engine_obj.echoes(animation, radar, f, radar_pose=poses[f])
                    with queue_lock:
                        ready[0] += 1
                    while len(pending) >= PENDING_FRAMES:
                        pending.popleft().result()
                    pending.append(pool.submit(finish, f, echoes))
                    del echoes
                while pending:
                    pending.popleft().result()
            except BaseException as exc:
                # an engine error: every frame whose echoes were computed is still written. An
                # interrupt: the frame being synthesised is finished and written, the ones queued
                # behind it are dropped (not started: a resume computes them), so that what it leaves
                # does not depend on how far the engine had run ahead
                if is_interrupt(exc) or received() is not None:
                    for future in pending:
                        future.cancel()
                while pending:
                    try:
                        pending.popleft().result()
                    except BaseException:  # noqa: BLE001  (the first failure is the one to report; a cancelled frame)
                        pass
                raise
    except BaseException as exc:
        if is_interrupt(exc) or received() is not None:
            signum = as_interrupted(exc).signum
            done_count = _done_count(out, indices) if store is None else \
                int(sum(store.done()[f] for f in indices))
            raise SimulationInterrupted(signum, done_count, len(indices), out) from None
        raise
    finally:
        if bar is not None:
            bar.close()
        if store is not None:
            store.close()
    with deferred():
        return open_run(out)

