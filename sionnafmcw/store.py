r"""The run store: what :func:`~sionnafmcw.simulation.simulate` writes and every reader reads.

This module is the data contract of a run. :class:`RunStore` writes it, :func:`open_run` reads it
(as a :class:`Run`); nothing else should decode its arrays or attributes by hand.

Layout
------
A Zarr v3 group with named dimensions (so ``xarray.open_zarr(path)`` reads it too):

============================  ==================================  =========  =====================================
variable                      dimensions                          dtype      meaning (SI units)
============================  ==================================  =========  =====================================
``iq``                        frame, chirp, tx, rx, sample        complex64  beat (IF) samples; :math:`|x|^2` in W
``frame_time``                frame                               float64    CPI start :math:`t_n` (s)
``truth_position``            frame, object, xyz                  float64    area-weighted mesh centroid at :math:`t_n` (m, world)
``truth_velocity``            frame, object, xyz                  float64    the object's (manifest) velocity at :math:`t_n` (m/s, world)
``truth_radial_velocity``     frame, object                       float64    :math:`\dot R` at :math:`t_n` (m/s, + receding)
``radar_position``            frame, xyz                          float64    radar origin at :math:`t_n` (m, world)
``radar_orientation``         frame, ypr                          float64    radar (yaw, pitch, roll) at :math:`t_n` (rad)
``radar_velocity``            frame, xyz                          float64    radar origin's velocity (m/s, world)
``radar_angular_velocity``    frame, xyz                          float64    radar frame's angular velocity (rad/s, world)
``frame_done``                frame                               bool       every array of the frame is written
``object``                    object (coordinate)                 str        names of the moving objects
============================  ==================================  =========  =====================================

Scenes with people (the animation's ``people`` entry, :mod:`sionnafmcw.animation.people`) add the
per-person truth and labels:

=========================  ==================================  =========  =====================================
variable                   dimensions                          dtype      meaning (SI units)
=========================  ==================================  =========  =====================================
``joint_position``         frame, person, joint, xyz           float64    keypoints at :math:`t_n` (m, world;
                                                                          NaN where a body lacks the joint)
``person_activity``        frame, person                       str        what each person does in the frame
``person_count``           frame                               int32      people in the scene (-1: not done)
``object_person``          object                              str        an object's person ("" for none)
``person``                 person (coordinate)                 str        the people's names (``person0``, ...)
``joint``                  joint (coordinate)                  str        the keypoints' names (``KEYPOINTS``
                                                                          of :mod:`sionnafmcw.scenes.keypoints`)
=========================  ==================================  =========  =====================================

Stores written before these variables existed, and runs of scenes without people, have none of
them; :class:`Run` then reports no people.

``tx`` and ``rx`` are in *physical* element order (the rows of ``RadarConfig.tx_positions`` and
``rx_positions``), not in firing order. ``xyz`` is the world frame of the scene (z up). Frames not
done hold the fill values (0 for ``iq``, NaN for the float arrays).

Attributes
----------
``format``
    ``"sionnafmcw-run/1"`` (:data:`FORMAT`).
``radar``
    The full :class:`~sionnafmcw.radar.RadarConfig` as :meth:`~sionnafmcw.radar.RadarConfig.to_dict`
    (its own field names, SI units, element positions in the radar frame).
``radar_pose``
    ``{"position": [x, y, z], "orientation": [yaw, pitch, roll]}`` (m, rad): the radar frame in the
    world (:mod:`sionnafmcw.geometry`) in frame 0, with its ``velocity`` (m/s) and
    ``angular_velocity`` (rad/s) where non-zero. The pose of every frame is in the ``radar_*`` arrays
    (older stores have only this attribute, and :meth:`Run.pose_at` falls back to it).
``radar_track``
    None for a radar that keeps one pose in every frame, else ``{"frames", "sha256"}``, the digest of
    every frame's pose and motion (a moving radar; a resume with another track is refused).
``engine``
    The engine's settings, ``{"engine": name, option: value, ...}``.
``scene``
    Absolute path of the animation directory that was simulated.
``seed``, ``noise``, ``leakage_db``
    Frame :math:`n`'s receiver noise comes from ``numpy.random.default_rng([seed, n])`` when
    ``noise`` is true; ``leakage_db`` is the direct Tx-Rx coupling (dB) or null.
``people``
    With people: ``{person: {field: value}}``, each person's fields of the animation's ``people``
    entry besides its objects, activity and keypoints (stature, build, motion source, vital signs...).
``sionnafmcw_version``
    The version that wrote the store (not compared when resuming).

Conventions
-----------
*Timing (TDM).* Frame :math:`n`'s CPI starts at :math:`t_n` = ``frame_time[n]``. With :math:`M`
transmitters fired in the order ``radar.tx_order``, chirp :math:`l` of the Tx at position :math:`q`
of that order starts at :math:`t_n + (lM + q)T_c`, and fast-time sample :math:`k` is taken
``adc_start_time`` :math:`+ k/F_s` after the chirp start (:mod:`sionnafmcw.radar`). So ``iq[n, l, m]``
of Tx :math:`m` is :math:`q_m T_c` later than that of the first Tx to fire
(:meth:`~sionnafmcw.radar.RadarConfig.chirp_start_times`).

*Beat signal and Doppler sign.* ``iq`` is :math:`x = s_{tx}\,s_{rx}^*`: a reflector at delay
:math:`\tau` beats at the positive frequency :math:`\mu\tau`, and its slow-time phase turns as
:math:`-2\pi f_D t` with :math:`f_D = -2\dot R/\lambda`. Every velocity of the project is the range
rate :math:`v_r = \dot R`, positive when receding (:mod:`sionnafmcw.synthesis`,
:mod:`sionnafmcw.processing`).

*Phase centre.* Ranges and radial velocities are measured from the phase centre of the virtual
array, :math:`\mathbf c_w` = :func:`sionnafmcw.geometry.world_phase_centre` (radar frame:
:func:`sionnafmcw.array.phase_centre`), not from the radar origin: that is where a range peak
sits. ``truth_radial_velocity`` is :math:`(\mathbf p - \mathbf c_w)\cdot(\mathbf v - \dot{\mathbf c}_w) / \lVert\mathbf p - \mathbf c_w\rVert`
at :math:`t_n`, :math:`\dot{\mathbf c}_w` the phase centre's velocity (zero for a radar at rest): the
range rate the radar sees; :meth:`Run.truth_at_cpi_centre` moves it to the CPI centre. With a
moving radar the phase centre is that of the frame's pose (:meth:`Run.phase_centre_at`).

Resumable and never half-written: ``iq`` has one chunk per frame, and ``frame_done[f]`` is set
only after every array of frame ``f`` is written. Re-opening a store with the same settings
skips the frames marked done and rewrites any other (a frame interrupted mid-write included);
opening it with different settings is an error that says which attribute differs.

Crash safety (any instant, SIGKILL included): a new store is built in a hidden sibling
``.<name>.partial-<token>`` and renamed into place once its arrays and all its attributes (one
metadata write) are complete, so a store at its path is always whole. One writer at a time holds
``.<name>.lock`` (``{"host", "pid"}``; stale once that process is gone). Opening a store sweeps what
killed writers left -- temporary stores beside it, ``*.partial`` chunk files inside it (Zarr writes a
chunk to a temporary file and renames it) -- and never touches a frame marked done. A done frame
whose chunks cannot be read raises :class:`CorruptFrameError` naming it; :func:`check_run` reads
every done frame back and clears the done flag of the unreadable ones, so a resume recomputes them.
"""

from __future__ import annotations

import json
import warnings
from functools import cached_property
from pathlib import Path

import numpy as np
import zarr

FORMAT = "sionnafmcw-run/1"


class RunStoreError(ValueError):
    """A run store that cannot be created, resumed or read; the message names the store."""


def _json_safe(value):
    return json.loads(json.dumps(value, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))


# ===================================================================================== writer
#: Attributes every complete store has (besides ``format``); a directory without them was cut off
#: while being created by a version that did not create stores atomically.
REQUIRED_ATTRS = ("radar", "radar_pose", "engine", "seed", "noise")
#: The radar's pose per frame: array name -> the :class:`~sionnafmcw.animation.RadarPose` field.
POSE_ARRAYS = {"radar_position": "position", "radar_orientation": "orientation", "radar_velocity": "velocity",
               "radar_angular_velocity": "angular_velocity"}
#: The arrays of a frame, in the order :meth:`RunStore.write_frame` writes them (``frame_done`` last).
FRAME_ARRAYS = ("iq", "frame_time", "truth_position", "truth_velocity", "truth_radial_velocity", *POSE_ARRAYS,
                "joint_position", "person_activity", "person_count")
#: Per-person arrays (present only in runs of scenes with people).
PEOPLE_ARRAYS = ("joint_position", "person_activity", "person_count", "object_person", "person", "joint")


class RunStoreBusy(RunStoreError):
    """Another live process is writing the store (its lock is held)."""


class CorruptFrameError(RunStoreError):
    """A done frame whose chunks cannot be read (``frame``: its index, ``path``: the store)."""

    def __init__(self, path, frame: int, reason: str):
        self.path, self.frame, self.reason = Path(path), int(frame), reason
        super().__init__(f"{path}: frame {frame} is marked done but cannot be read ({reason}); "
                         "check_run(path) marks it for recomputation and simulating again with the same "
                         "settings rewrites it")


def _zarr_metadata(path: Path) -> dict | None:
    try:
        return json.loads((path / "zarr.json").read_text())
    except (OSError, ValueError):
        return None


def _creation_leftover(path: Path) -> bool:
    """True for a directory that a killed, non-atomic store creation left: a Zarr store of this
    layout (or the start of one) whose attributes are incomplete and that has no frame done."""
    if not path.is_dir():
        return False
    meta = _zarr_metadata(path)
    attrs = (meta or {}).get("attributes") or {}
    if meta is not None and attrs.get("format") == FORMAT and all(k in attrs for k in REQUIRED_ATTRS):
        return False  # complete
    if meta is not None and attrs.get("format") not in (None, FORMAT):
        return False  # some other store
    names = {p.name for p in path.iterdir()}
    if not names <= {"zarr.json", *FRAME_ARRAYS, *PEOPLE_ARRAYS, "frame_done", "object"}:
        return False  # holds something that is not ours
    try:
        done = zarr.open_array(str(path / "frame_done"), mode="r", zarr_format=3)[:]
    except Exception:  # noqa: BLE001 - not created yet: nothing done
        return True
    return not np.any(done)


def _create(path: Path, radar, num_frames: int, object_names: list[str], attrs: dict, people=None) -> None:
    """Build the store in a hidden sibling of ``path`` and rename it into place when complete
    (:func:`sionnafmcw.fs.atomic_directory`): metadata, arrays and every attribute in one write.
    ``people``: ``{"names", "joints", "object_person"}`` for the per-person arrays (module docstring)."""
    from . import _faults
    from .fs import atomic_directory

    with atomic_directory(path) as tmp:
        group = zarr.create_group(str(tmp), zarr_format=3, attributes=attrs)
        n_obj = len(object_names)
        cube = (radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
        group.create_array("iq", shape=(num_frames, *cube), chunks=(1, *cube), dtype="complex64",
                           fill_value=0, dimension_names=["frame", "chirp", "tx", "rx", "sample"])
        group.create_array("frame_time", shape=(num_frames,), dtype="float64", fill_value=np.nan,
                           dimension_names=["frame"])
        group.create_array("frame_done", shape=(num_frames,), dtype="bool", fill_value=False,
                           dimension_names=["frame"])
        for name, extra, dims in (("truth_position", (3,), ["frame", "object", "xyz"]),
                                  ("truth_velocity", (3,), ["frame", "object", "xyz"]),
                                  ("truth_radial_velocity", (), ["frame", "object"])):
            group.create_array(name, shape=(num_frames, n_obj, *extra), chunks=(1, max(n_obj, 1), *extra),
                               dtype="float64", fill_value=np.nan, dimension_names=dims)
        for name in POSE_ARRAYS:
            group.create_array(name, shape=(num_frames, 3), chunks=(1, 3), dtype="float64", fill_value=np.nan,
                               dimension_names=["frame", "ypr" if name == "radar_orientation" else "xyz"])
        objects = group.create_array("object", shape=(n_obj,), dtype=str, dimension_names=["object"])
        if n_obj:
            objects[:] = np.array(object_names, dtype=str)
        if people is not None:
            _create_people(group, num_frames, n_obj, people)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # consolidated metadata is not in the v3 spec yet
            zarr.consolidate_metadata(str(tmp))
        _faults.point("store-created", store=path)


def _create_people(group, num_frames: int, n_obj: int, people: dict) -> None:
    """The per-person arrays of a run of a scene with people (module docstring)."""
    names, joints = list(people["names"]), list(people["joints"])
    n_p, n_j = len(names), len(joints)
    group.create_array("joint_position", shape=(num_frames, n_p, n_j, 3), chunks=(1, max(n_p, 1), max(n_j, 1), 3),
                       dtype="float64", fill_value=np.nan, dimension_names=["frame", "person", "joint", "xyz"])
    group.create_array("person_activity", shape=(num_frames, n_p), chunks=(1, max(n_p, 1)), dtype=str,
                       dimension_names=["frame", "person"])
    group.create_array("person_count", shape=(num_frames,), dtype="int32", fill_value=-1, dimension_names=["frame"])
    for name, values, dim in (("person", names, "person"), ("joint", joints, "joint")):
        arr = group.create_array(name, shape=(len(values),), dtype=str, dimension_names=[dim])
        if values:
            arr[:] = np.array(values, dtype=str)
    owners = group.create_array("object_person", shape=(n_obj,), dtype=str, dimension_names=["object"])
    if n_obj:
        owners[:] = np.array(people["object_person"], dtype=str)


class RunStore:
    """Writer of one run store (see the module docstring).

    Crash safety: a new store is built beside its path and renamed into place when complete, so a
    store at its path always has all its attributes and arrays; one writer at a time holds the
    lock ``.<name>.lock`` beside it (:class:`sionnafmcw.fs.LockFile`, released by :meth:`close`,
    stale once its process is gone); opening sweeps what killed writers left (hidden temporary
    stores beside it, ``*.partial`` chunk files inside it) and never touches a frame marked done.
    """

    def __init__(self, group: zarr.Group, path: Path, lock=None):
        self.group = group
        self.path = path
        self.lock = lock
        self.created = False  # this call created the store

    # ------------------------------------------------------------------ create / resume
    @classmethod
    def open(cls, path, radar, num_frames: int, object_names: list[str], attrs: dict,
             wait: float = 0.0, hold_lock: bool = False, people: dict | None = None) -> "RunStore":
        """Create the store, or reopen it for resuming when its attributes equal ``attrs``.

        The store's lock is taken while leftovers are swept and the store is created or checked;
        ``wait`` (s): how long to wait for another live writer of the store to finish
        (:class:`RunStoreBusy` after that). ``hold_lock``: keep the lock until :meth:`close` (a
        writer of frames, as :func:`~sionnafmcw.simulate`), else release it on return. ``people``:
        ``{"names", "joints", "object_person"}`` of a scene with people (the per-person arrays).
        """
        from .fs import LockBusy, LockFile, sweep_leftovers

        path = Path(path)
        attrs = _json_safe({"format": FORMAT, **attrs})
        lock = LockFile(path, wait=wait)
        try:
            lock.acquire()
        except LockBusy as exc:
            raise RunStoreBusy(f"{exc}, writing it; wait for that process to finish (or stop it), or write "
                               "to another path") from None
        try:
            sweep_leftovers(path)  # temporary stores of killed creations
            if _creation_leftover(path):
                import shutil

                shutil.rmtree(path)
            if path.exists() and path.is_dir() and not any(path.iterdir()):
                path.rmdir()
            if not path.exists():
                _create(path, radar, num_frames, object_names, attrs, people)
                store = cls(zarr.open_group(str(path), mode="r+", zarr_format=3), path, lock)
                store.created = True
            else:
                store = cls(cls._resume(path, radar, num_frames, attrs), path, lock)
        except BaseException:
            lock.release()
            raise
        if not hold_lock:
            lock.release()
            store.lock = None
        return store

    @staticmethod
    def _resume(path: Path, radar, num_frames: int, attrs: dict) -> zarr.Group:
        from .fs import sweep_partial_files

        try:
            group = zarr.open_group(str(path), mode="r+", zarr_format=3)
        except Exception as exc:  # not a Zarr group at all
            raise RunStoreError(f"{path} exists and is not a run store ({exc}); "
                                "write the run to another path") from exc
        old = dict(group.attrs)
        if old.get("format") != FORMAT:
            raise RunStoreError(f"{path} exists and is not a sionnafmcw run store; write the run to another path")
        for key, value in attrs.items():
            if key == "sionnafmcw_version":
                continue
            if old.get(key) != value:
                raise RunStoreError(
                    f"{path} was written with a different {key!r}; resume only with the same settings, "
                    "or write to a new path (or delete the old store)"
                )
        shape = group["iq"].shape
        expected = (num_frames, radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
        if shape != expected:
            raise RunStoreError(f"{path}: iq has shape {shape}, this run needs {expected}")
        sweep_partial_files(path)  # chunk writes cut off by a kill (never a finished chunk)
        if "consolidated_metadata" not in (_zarr_metadata(path) or {}):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                zarr.consolidate_metadata(str(path))
        return group

    def close(self) -> None:
        """Release the store's lock (the store stays resumable)."""
        if self.lock is not None:
            self.lock.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ------------------------------------------------------------------ frames
    def done(self) -> np.ndarray:
        """``[frame]`` bool: which frames are complete."""
        return np.asarray(self.group["frame_done"][:], dtype=bool)

    def write_frame(self, index: int, iq: np.ndarray, time: float, positions, velocities,
                    radial_velocities, joint_positions=None, activities=None, radar_pose=None) -> None:
        """Write every array of frame ``index``, then mark it done (last). ``joint_positions`` [person,
        joint, 3] and ``activities`` [person] for a store with the per-person arrays (the person count is
        their number). ``radar_pose``: the frame's :class:`~sionnafmcw.animation.RadarPose` (the
        ``radar_*`` arrays; an older store has none and keeps its one ``radar_pose``
        attribute).

        Signals are held during the writes (:func:`sionnafmcw.interrupts.deferred`): Ctrl-C never
        cuts a chunk write in half; a SIGKILL leaves at most a ``*.partial`` file (swept by the next
        :meth:`open`) and the frame not marked done.
        """
        from . import _faults
        from .interrupts import deferred

        g = self.group
        with deferred():
            g["iq"][index] = iq.astype(np.complex64, copy=False)
            g["frame_time"][index] = time
            if g["truth_position"].shape[1]:
                g["truth_position"][index] = positions
                g["truth_velocity"][index] = velocities
                g["truth_radial_velocity"][index] = radial_velocities
            if "joint_position" in g and joint_positions is not None:
                g["joint_position"][index] = np.asarray(joint_positions, float)
                g["person_activity"][index] = np.asarray(activities, dtype=str)
                g["person_count"][index] = np.int32(len(activities))
            if radar_pose is not None:
                for name, field in POSE_ARRAYS.items():
                    if name in g:
                        g[name][index] = np.asarray(getattr(radar_pose, field), float)
            _faults.point("chunk-written", store=self.path, frame=index)
            g["frame_done"][index] = True
            _faults.point("frame-done", store=self.path, frame=index)
        if self.lock is not None:
            self.lock.refresh()

    def mark_not_done(self, frames) -> None:
        """Clear the done flag of ``frames`` (their data is rewritten by the next resume)."""
        from .interrupts import deferred

        with deferred():
            for f in frames:
                self.group["frame_done"][int(f)] = False


# ===================================================================================== checking
def check_run(path, repair: bool = True) -> dict:
    """Read every array of every done frame of the store ``path``; mark unreadable frames not done.

    Returns ``{"path", "num_frames", "done" (frames done before), "corrupt" ({frame: reason}),
    "repaired" (bool), "partial_files" (removed)}``. With ``repair`` the corrupt frames get their
    done flag cleared (holding the store's lock), so that simulating again with the same settings
    recomputes exactly them, and the ``*.partial`` files of killed writes are removed.
    """
    from .fs import LockBusy, LockFile, sweep_partial_files

    run = open_run(path)
    group = run._group
    try:
        done = run.done_frames
    except Exception as exc:  # noqa: BLE001 - frame_done itself unreadable
        raise RunStoreError(f"{run.path}: the done flags (frame_done) cannot be read ({exc}); the store cannot "
                            "be repaired: simulate into a new path") from exc
    corrupt = {}
    for f in done:
        for name in FRAME_ARRAYS:
            if name not in group:   # per-person arrays of a run without people, or a store written before
                # its array existed (the radar_* arrays)
                continue
            if name != "iq" and group[name].ndim > 1 and group[name].shape[1] == 0:
                continue
            try:
                np.asarray(group[name][int(f)])
            except Exception as exc:  # noqa: BLE001 - any decode or I/O failure
                corrupt[int(f)] = f"{name}: {type(exc).__name__}: {' '.join(str(exc).split())[:120]}"
                break
    report = {"path": run.path, "num_frames": run.num_frames, "done": done, "corrupt": corrupt,
              "repaired": False, "partial_files": []}
    if repair:
        lock = LockFile(run.path)
        try:
            lock.acquire()
        except LockBusy as exc:
            raise RunStoreBusy(f"{exc}, writing it; repair it once that process has finished") from None
        try:
            report["partial_files"] = sweep_partial_files(run.path)
            if corrupt:
                writer = RunStore(zarr.open_group(str(run.path), mode="r+", zarr_format=3), run.path)
                writer.mark_not_done(sorted(corrupt))
                report["repaired"] = True
        finally:
            lock.release()
    return report


# ===================================================================================== truth maths
def radial_velocity_at_cpi_centre(times, positions, velocities, centre, cpi_duration: float,
                                  centre_velocities=None) -> np.ndarray:
    r"""Range rate of one object at every CPI centre, from the truth sampled at the CPI starts.

    A CPI of frame :math:`n` spans :math:`[t_n, t_n + LMT_c]`; the slow-time phase of a target whose
    range rate changes during the CPI is, to first order, that of its mean range rate, which for a
    constant acceleration is the range rate at the CPI centre :math:`t_c = t_n + LMT_c/2`. The store
    holds position :math:`\mathbf p_n` and velocity :math:`\mathbf v_n` at :math:`t_n`. With the
    acceleration :math:`\mathbf a_n` from central differences of the velocities (one-sided at the
    ends; zero for a single frame), and :math:`\Delta = t_c - t_n`,

    .. math::
        \mathbf p_c = \mathbf p_n + \mathbf v_n\Delta + \tfrac12\mathbf a_n\Delta^2, \qquad
        \mathbf v_c = \mathbf v_n + \mathbf a_n\Delta, \qquad
        \dot R_c = \mathbf v_c\cdot\frac{\mathbf p_c - \mathbf c}{\lVert\mathbf p_c - \mathbf c\rVert},

    with :math:`\mathbf c` the world phase centre. The residual is of the order of the jerk:
    :math:`|\dddot{\mathbf p}|\Delta^2/2 = (v^3/r^2)\Delta^2/2 \approx 1` mm/s for the paper's circle
    walk (4.52 m/s on a 3 m circle, :math:`\Delta` = 13.4 ms), while using :math:`\dot R(t_n)` instead
    would be wrong by up to :math:`(v^2/r)\Delta \approx 0.09` m/s.

    A moving radar: ``centre`` ``[frame, 3]`` and ``centre_velocities`` ``[frame, 3]`` (the phase
    centre's, per frame) make every position and velocity relative to it first (the same formulas on
    :math:`\mathbf p - \mathbf c_n`, :math:`\mathbf v - \dot{\mathbf c}_n`, so its acceleration enters too).

    Parameters
    ----------
    times : ``[frame]`` s; positions, velocities : ``[frame, 3]`` m, m/s (world);
    centre : ``[3]`` or ``[frame, 3]`` m (world); cpi_duration : :math:`LMT_c` (s);
    centre_velocities : ``[frame, 3]`` m/s or None (a radar at rest).
    """
    t = np.asarray(times, float)
    p = np.asarray(positions, float)
    v = np.asarray(velocities, float)
    if centre_velocities is not None:
        p = p - np.asarray(centre, float)
        v = v - np.asarray(centre_velocities, float)
        centre = np.zeros(3)
    a = np.gradient(v, t, axis=0) if t.size > 1 else np.zeros_like(v)
    dt = cpi_duration / 2.0
    pc = p + v * dt + 0.5 * a * dt**2
    vc = v + a * dt
    los = pc - np.asarray(centre, float)
    return np.sum(vc * los, axis=-1) / np.linalg.norm(los, axis=-1)


# ===================================================================================== reader
class Run:
    """A run store opened for reading (:func:`open_run`): the layout of the module docstring, decoded.

    Arrays are read from the Zarr group on demand (nothing is cached but the attributes), so a
    :class:`Run` of a store that is still being written sees the frames finished since. Per-frame
    truth is NaN for frames not done. ``run[name]``, ``name in run``, ``run.sizes`` and any other
    attribute that is not the run's own go to :attr:`dataset` (the lazy ``xarray.Dataset``), so code
    written for the dataset keeps working.
    """

    def __init__(self, path: Path, group: zarr.Group):
        self.path = Path(path)
        self._group = group

    # ------------------------------------------------------------------ whole store
    @cached_property
    def dataset(self):
        """The store as a lazy ``xarray.Dataset`` (dask arrays, named dimensions)."""
        import xarray as xr

        try:
            return xr.open_zarr(str(self.path), consolidated=True)
        except Exception as exc:
            raise RunStoreError(f"{self.path} is not a readable run store: {exc}") from exc

    @cached_property
    def attrs(self) -> dict:
        """The store's attributes (see the module docstring), as plain JSON values."""
        return dict(self._group.attrs)

    def _attr(self, key: str):
        if key not in self.attrs:
            raise RunStoreError(f"{self.path}: the run store has no {key!r} attribute")
        return self.attrs[key]

    @cached_property
    def radar(self):
        """The :class:`~sionnafmcw.radar.RadarConfig` of the run."""
        from .radar import RadarConfig, RadarConfigError

        try:
            return RadarConfig.from_dict(self._attr("radar"))
        except RadarConfigError as exc:
            raise RunStoreError(f"{self.path}: attribute 'radar': {exc}") from exc

    @cached_property
    def pose(self):
        """The radar's :class:`~sionnafmcw.animation.RadarPose` in the world (frame 0's; :meth:`pose_at` per frame)."""
        from .animation import RadarPose

        pose = self._attr("radar_pose")
        try:
            motion = {k: np.asarray(pose[k], float).reshape(3) for k in ("velocity", "angular_velocity")
                      if k in pose}
            return RadarPose(np.asarray(pose["position"], float).reshape(3),
                             np.asarray(pose["orientation"], float).reshape(3), **motion)
        except (KeyError, TypeError, ValueError) as exc:
            raise RunStoreError(f"{self.path}: attribute 'radar_pose' must be {{'position': [x, y, z], "
                                f"'orientation': [yaw, pitch, roll]}}, got {pose!r}") from exc

    @cached_property
    def phase_centre(self) -> np.ndarray:
        """World position of the virtual array's phase centre ``[3]`` (m) in frame 0 (every frame for a radar
        at rest): ranges are measured from it. A moving radar's: :meth:`phase_centre_at`."""
        from .geometry import world_phase_centre

        return world_phase_centre(self.radar, self.pose.position, self.pose.orientation)

    @property
    def radar_moves(self) -> bool:
        """True when the run's radar moved (its ``radar_track`` attribute, or a velocity in its pose)."""
        return self.attrs.get("radar_track") is not None or self.pose.moving

    def pose_at(self, frame: int):
        """The radar's :class:`~sionnafmcw.animation.RadarPose` (position, orientation, velocity, angular
        velocity) in ``frame``: the per-frame ``radar_*`` arrays, or the ``radar_pose`` attribute for a
        store that has none (an older store) or a frame not written yet."""
        from .animation import RadarPose

        frame = int(frame)
        if "radar_position" not in self._group or not self.done_mask[frame]:
            return self.pose
        fields = {field: np.asarray(self._read(name, frame), float) for name, field in POSE_ARRAYS.items()
                  if name in self._group}
        if not all(np.all(np.isfinite(v)) for v in fields.values()):
            return self.pose
        return RadarPose(**fields)

    def poses(self) -> list:
        """:meth:`pose_at` of every frame ``[frame]``."""
        if "radar_position" not in self._group:
            return [self.pose] * self.num_frames
        arrays = {field: np.asarray(self._read_all(name), float) for name, field in POSE_ARRAYS.items()
                  if name in self._group}
        from .animation import RadarPose

        out = []
        for f in range(self.num_frames):
            values = {k: v[f] for k, v in arrays.items()}
            ok = self.done_mask[f] and all(np.all(np.isfinite(v)) for v in values.values())
            out.append(RadarPose(**values) if ok else self.pose)
        return out

    def phase_centre_at(self, frame: int) -> np.ndarray:
        """World position ``[3]`` (m) of the phase centre in ``frame`` (the frame's radar pose)."""
        from .geometry import world_phase_centre

        pose = self.pose_at(frame)
        return world_phase_centre(self.radar, pose.position, pose.orientation)

    def phase_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities ``[frame, 3]`` (m, m/s, world) of the phase centre in every frame."""
        from .kinematics import element_kinematics

        kin = [element_kinematics(p, self.radar.phase_centre[None]) for p in self.poses()]
        return np.array([k.position[0] for k in kin]), np.array([k.velocity[0] for k in kin])

    @property
    def engine(self) -> dict:
        """The engine's settings, ``{"engine": name, option: value, ...}``."""
        return dict(self.attrs.get("engine") or {})

    @property
    def scene(self) -> Path | None:
        """The animation directory that was simulated (None when the store does not say)."""
        scene = self.attrs.get("scene")
        return Path(scene) if scene else None

    @cached_property
    def objects(self) -> list[str]:
        """Names of the moving objects whose truth the store holds (the ``object`` axis)."""
        arr = self._group["object"]
        return [str(x) for x in np.asarray(arr[:])] if arr.shape[0] else []

    @property
    def num_frames(self) -> int:
        """Frames of the animation (done or not)."""
        return int(self._group["frame_done"].shape[0])

    # ------------------------------------------------------------------ frames
    @property
    def done_frames(self) -> np.ndarray:
        """Indices of the frames completely written, sorted (int ``[done]``)."""
        return np.flatnonzero(np.asarray(self._group["frame_done"][:], dtype=bool))

    @property
    def done_mask(self) -> np.ndarray:
        """``[frame]`` bool: which frames are completely written (``frame_done``)."""
        return np.asarray(self._group["frame_done"][:], dtype=bool)

    @property
    def frame_times(self) -> np.ndarray:
        """CPI start times :math:`t_n` ``[frame]`` (s); NaN for frames not done."""
        return np.where(self.done_mask, np.asarray(self._read_all("frame_time"), float), np.nan)

    def _check_done(self, frames) -> None:
        done = self.done_mask
        frames = np.atleast_1d(np.asarray(frames))
        bad = frames[(frames < -done.size) | (frames >= done.size)]
        if bad.size:
            raise RunStoreError(f"{self.path}: frame {int(bad[0])} is outside the run's 0..{done.size - 1}")
        missing = frames[~done[frames]]
        if missing.size:
            raise RunStoreError(f"{self.path}: frame {int(missing[0])} is not written yet "
                                f"({done.sum()} of {done.size} frames done)")

    def _read(self, name: str, frame: int) -> np.ndarray:
        """Array ``name`` of one done frame; an unreadable chunk is a :class:`CorruptFrameError`."""
        try:
            return np.asarray(self._group[name][int(frame)])
        except Exception as exc:  # noqa: BLE001 - decompression, truncated file, I/O
            raise CorruptFrameError(self.path, frame, f"{name}: {type(exc).__name__}: "
                                    f"{' '.join(str(exc).split())[:160]}") from None

    def _read_all(self, name: str) -> np.ndarray:
        """Array ``name`` over all frames; an unreadable chunk is a :class:`CorruptFrameError` naming its frame."""
        try:
            return np.asarray(self._group[name][:])
        except Exception:  # noqa: BLE001 - find the frame
            for f in range(self._group[name].shape[0]):
                self._read(name, f)
            raise

    def cube(self, frame: int) -> np.ndarray:
        """Beat cube of one frame, complex64 ``[chirp, tx, rx, sample]`` (Tx in physical order)."""
        frame = int(frame)
        self._check_done(frame)
        return self._read("iq", frame)

    def cubes(self, frames) -> np.ndarray:
        """Beat cubes ``[frame, chirp, tx, rx, sample]`` of a ``slice`` or a list of frames (all done)."""
        if isinstance(frames, slice):
            frames = np.arange(self.num_frames)[frames]
        frames = np.asarray(frames, dtype=int).reshape(-1)
        self._check_done(frames)
        return np.stack([self._read("iq", int(f)) for f in frames]) if frames.size else \
            np.zeros((0, *self._group["iq"].shape[1:]), np.complex64)

    # ------------------------------------------------------------------ truth
    def _object_index(self, obj: str) -> int:
        if obj not in self.objects:
            have = ", ".join(self.objects) if self.objects else "no moving objects"
            raise RunStoreError(f"{self.path}: object {obj!r} is not in the run's truth; it has {have}")
        return self.objects.index(obj)

    def truth(self, obj: str) -> np.ndarray:
        """Radial velocity :math:`\\dot R` of ``obj`` at the CPI starts ``[frame]`` (m/s, + receding, from the phase centre)."""
        k = self._object_index(obj)
        return np.where(self.done_mask, np.asarray(self._read_all("truth_radial_velocity")[:, k], float), np.nan)

    def object_position(self, obj: str) -> np.ndarray:
        """World position of ``obj`` at the CPI starts ``[frame, 3]`` (m); NaN for frames not done."""
        k = self._object_index(obj)
        return np.where(self.done_mask[:, None], np.asarray(self._read_all("truth_position")[:, k, :], float), np.nan)

    def object_velocity(self, obj: str) -> np.ndarray:
        """World velocity of ``obj`` at the CPI starts ``[frame, 3]`` (m/s); NaN for frames not done."""
        k = self._object_index(obj)
        return np.where(self.done_mask[:, None], np.asarray(self._read_all("truth_velocity")[:, k, :], float), np.nan)

    def object_range(self, obj: str) -> np.ndarray:
        r"""Range of ``obj`` from the phase centre at the CPI starts, :math:`\lVert\mathbf p_n - \mathbf c_w\rVert` ``[frame]``
        (m; the frame's phase centre when the radar moves)."""
        if self.radar_moves:
            return np.linalg.norm(self.object_position(obj) - self.phase_centres()[0], axis=-1)
        return np.linalg.norm(self.object_position(obj) - self.phase_centre, axis=-1)

    def truth_at_cpi_centre(self, obj: str) -> np.ndarray:
        """Radial velocity of ``obj`` at every CPI centre ``[frame]`` (m/s): :func:`radial_velocity_at_cpi_centre`
        on the done frames (the acceleration from differences between them; relative to the moving
        phase centre when the radar moves); NaN for frames not done."""
        done = self.done_frames
        out = np.full(self.num_frames, np.nan)
        if done.size:
            if self.radar_moves:
                centres, centre_velocities = self.phase_centres()
                out[done] = radial_velocity_at_cpi_centre(
                    self.frame_times[done], self.object_position(obj)[done], self.object_velocity(obj)[done],
                    centres[done], self.radar.cpi_duration, centre_velocities[done])
            else:
                out[done] = radial_velocity_at_cpi_centre(
                    self.frame_times[done], self.object_position(obj)[done], self.object_velocity(obj)[done],
                    self.phase_centre, self.radar.cpi_duration)
        return out

    def truth_in_radar_frame(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        r"""Range (m) and azimuth (rad) of every object ``[object]`` in frame ``frame``, as the radar sees them.

        The object's position at the CPI start goes to the radar frame of the frame's pose
        (:func:`sionnafmcw.geometry.world_to_radar`, :meth:`pose_at`) and is taken relative to the phase centre
        :math:`\mathbf c_r` (:func:`sionnafmcw.array.phase_centre`):
        :math:`\mathbf q = \mathbf R^T(\mathbf p - \mathbf o) - \mathbf c_r`, range :math:`\lVert\mathbf q\rVert`,
        azimuth :math:`\operatorname{atan2}(q_y, q_x)` (positive towards the radar's +y).
        Empty arrays when the run has no moving objects.
        """
        from .geometry import world_to_radar

        frame = int(frame)
        self._check_done(frame)
        if not self.objects:
            return np.zeros(0), np.zeros(0)
        positions = np.asarray(self._read("truth_position", frame), float)
        pose = self.pose_at(frame)
        local = world_to_radar(positions, pose.position, pose.orientation) - self.radar.phase_centre
        return np.linalg.norm(local, axis=-1), np.arctan2(local[:, 1], local[:, 0])

    # ------------------------------------------------------------------ people
    def _names(self, name: str) -> list[str]:
        if name not in self._group:
            return []
        arr = self._group[name]
        return [str(x) for x in np.asarray(arr[:])] if arr.shape[0] else []

    @cached_property
    def people(self) -> list[str]:
        """Names of the people in the scene (the ``person`` axis); empty for a run without people (or a store
        written before the per-person arrays existed)."""
        return self._names("person")

    @cached_property
    def joints(self) -> list[str]:
        """Keypoint names (the ``joint`` axis, :data:`sionnafmcw.scenes.keypoints.KEYPOINTS`); empty without people."""
        return self._names("joint")

    def _person_index(self, person: str) -> int:
        if person not in self.people:
            raise RunStoreError(f"{self.path}: person {person!r} is not in the run; it has "
                                f"{', '.join(self.people) or 'no people'}")
        return self.people.index(person)

    def person_objects(self, person: str) -> list[str]:
        """The objects (body segments) of ``person``."""
        self._person_index(person)
        owners = self._names("object_person")
        return [o for o, p in zip(self.objects, owners) if p == person]

    def joint_positions(self, person: str | None = None) -> np.ndarray:
        """Keypoints ``[frame, person, joint, 3]`` (m, world), or ``[frame, joint, 3]`` of one ``person``;
        NaN for frames not done and joints a body lacks."""
        if not self.people:
            raise RunStoreError(f"{self.path}: the run has no people (no joint_position)")
        arr = np.asarray(self._read_all("joint_position"), float)
        arr = np.where(self.done_mask[:, None, None, None], arr, np.nan)
        return arr if person is None else arr[:, self._person_index(person)]

    def activities(self) -> np.ndarray:
        """What each person does, ``[frame, person]`` str (``""`` for frames not done)."""
        if not self.people:
            return np.zeros((self.num_frames, 0), dtype=object)
        arr = np.asarray(self._read_all("person_activity")).astype(object)
        arr[~self.done_mask] = ""
        return arr

    def person_count(self) -> np.ndarray:
        """People in the scene per frame ``[frame]`` (int; -1 for frames not done, 0 without people)."""
        if "person_count" not in self._group:
            return np.where(self.done_mask, 0, -1)
        return np.where(self.done_mask, np.asarray(self._read_all("person_count"), int), -1)

    # ------------------------------------------------------------------ the dataset's interface
    def __getitem__(self, name):
        return self.dataset[name]

    def __contains__(self, name) -> bool:
        return name in self.dataset

    @property
    def sizes(self):
        """The dataset's dimension sizes (``frame``, ``chirp``, ``tx``, ``rx``, ``sample``, ``object``, ``xyz``)."""
        return self.dataset.sizes

    def __getattr__(self, name):
        # only reached for names that are not the run's own: the dataset's variables and methods
        if name.startswith("_") or name in ("path", "dataset"):
            raise AttributeError(name)
        return getattr(self.dataset, name)

    def __reduce__(self):
        return open_run, (str(self.path),)

    def __repr__(self) -> str:
        done = self.done_mask
        return (f"Run({str(self.path)!r}, radar={self.radar.name!r}, engine={self.engine.get('engine')!r}, "
                f"frames done {int(done.sum())}/{done.size}, objects={self.objects})")


def open_run(path) -> Run:
    """Open a run store for reading (a :class:`Run`), checking that it is one."""
    path = Path(path)
    if not path.exists():
        raise RunStoreError(f"{path}: no such run store")
    try:
        group = zarr.open_group(str(path), mode="r", zarr_format=3)
    except Exception as exc:
        raise RunStoreError(f"{path} is not a readable run store: {exc}") from exc
    if group.attrs.get("format") != FORMAT:
        raise RunStoreError(f"{path} is not a sionnafmcw run store (attribute 'format' missing)")
    return Run(path, group)
