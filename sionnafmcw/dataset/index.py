r"""The data-set layout on disk, per-item labels from the run stores, and the index.

Layout of a data set folder ``out``::

    out/spec.json                  {"format", "spec" (canonical, see DatasetSpec.to_dict), "sionnafmcw_version"}
    out/index.zarr                 the index (below), rewritten as items finish
    out/items/<id>/scene/          the animation directory (sionnafmcw.scenes.build)
    out/items/<id>/scene.json      written after the scene is complete: {"scenario", "parameters"}
    out/items/<id>/run.zarr        the run store (sionnafmcw.store); the item is complete when every
                                   frame the spec asks for is marked done in it
    out/items/<id>/item.json       the item's record: parameters, status, error and traceback,
                                   attempts, wall time, worker, labels

Labels of an item (from its run store, never from the spec): the *label object* is the spec's
``label_object``, else ``torso`` when the scene has one, else the first person's torso
(``person0_torso``), else the first moving object. Per frame
:math:`n`: ``frame_time`` :math:`t_n` (s), ``radial_velocity`` :math:`\dot R_n` of the label
object (m/s, positive receding, the store's ``truth_radial_velocity``) and ``range``
:math:`R_n = \|\mathbf p_n - \mathbf c\|` (m) from the radar's phase centre :math:`\mathbf c`
(the virtual array's centroid, as the store's radial velocity) to the object's centroid
:math:`\mathbf p_n`. Frames not simulated are NaN. A scene with people
(:mod:`sionnafmcw.animation.people`) adds, per frame, ``person_count`` (-1 not simulated),
``activity`` of every person and ``joint_position``, every person's keypoints
(:data:`sionnafmcw.scenes.keypoints.KEYPOINTS`, m, world; the pose-estimation label), and per person
its ``breathing_rate`` and ``heart_rate`` (Hz, the vital signs the scene drew; NaN for people without).

The index (``xarray.Dataset``, dimensions ``item`` and ``frame``, ``frame`` padded with NaN to the
longest item): ``status`` (complete / failed / pending), ``error``, ``ran`` (run by the last
``generate`` call), ``attempts``, ``seconds`` (wall time of the last attempt), ``cpu_seconds``
(CPU time of the worker process meanwhile), ``worker``,
``scenario``, ``radar``, ``noise_seed``, ``param_<name>`` for every scenario parameter (the
builder's defaults filled in; tuples as JSON text), ``label_object``, ``num_frames``,
``frames_done``, and the per-frame labels ``frame_time``, ``radial_velocity``, ``range``,
``frame_done``; when some item has people also ``num_people`` (item), ``person_count`` (item,
frame; int32, -1 where not simulated), ``activity`` (item, frame, person; ``""`` where none),
``joint_position`` (item, frame, person, joint, xyz; float32 m, NaN where none), ``breathing_rate`` and
``heart_rate`` (item, person; Hz), the ``person`` axis padded to the most people of an item
(``person0``, ``person1``, ...) and the ``joint`` axis named by the keypoints. Attributes:
``format``, ``name``, ``scenario``, ``spec`` (JSON), ``summary``,
``sionnafmcw_version``.
"""

from __future__ import annotations

import json
import os
import shutil
import uuid
import warnings
from pathlib import Path

import numpy as np

INDEX_FORMAT = "sionnafmcw-dataset/1"
SPEC_FILE = "spec.json"
INDEX_DIR = "index.zarr"


class DatasetError(RuntimeError):
    """A data set folder that cannot be generated into or read; the message names it and the fix."""


def item_dir(out, item_id: str) -> Path:
    return Path(out) / "items" / item_id


def write_json_atomic(path: Path, data) -> None:
    """Write JSON to ``path`` through a temporary sibling and a rename (never half-written)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True, default=_json_default))
    os.replace(tmp, path)


def _json_default(o):
    if hasattr(o, "tolist"):
        return o.tolist()
    return str(o)


def read_json(path: Path):
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None


# ===================================================================================== stores
def store_state(store, frames=None) -> dict:
    """``{"exists", "num_frames", "frame_done" [frame] bool, "complete"}`` of a run store.

    ``complete``: every frame in ``frames`` (default all) is marked done. Missing or unreadable
    store: not complete.
    """
    from ..store import open_run

    store = Path(store)
    if not store.exists():
        return {"exists": False, "num_frames": 0, "frame_done": np.zeros(0, bool), "complete": False}
    try:
        done = open_run(store).done_mask
    except Exception:
        return {"exists": True, "num_frames": 0, "frame_done": np.zeros(0, bool), "complete": False}
    wanted = range(done.size) if frames is None else [f for f in frames]
    complete = bool(done.size) and all(0 <= f < done.size and done[f] for f in wanted)
    return {"exists": True, "num_frames": int(done.size), "frame_done": done, "complete": complete}


def choose_label_object(objects, requested: str | None) -> str:
    """The label object among ``objects`` (see the module docstring); ``""`` when there is none."""
    objects = list(objects)
    if requested is not None:
        if requested not in objects:
            raise DatasetError(f"label_object {requested!r} is not an object of this scene; its objects: "
                               f"{', '.join(objects) or 'none'} (fix label_object in the spec)")
        return requested
    if "torso" in objects:
        return "torso"
    torsos = [o for o in objects if o.endswith("_torso")]
    if torsos:
        return torsos[0]
    return objects[0] if objects else ""


def store_labels(store, label_object: str | None = None) -> dict:
    """Per-frame labels of one run store (see the module docstring), as plain lists.

    Returns ``{"label_object", "objects", "num_frames", "frame_done", "frame_time",
    "radial_velocity", "range"}`` and, for a run with people, ``"people"``, ``"joints"``, ``"person_count"``,
    ``"activity"`` ([frame][person]), ``"joint_position"`` ([frame][person][joint][3], m to 10 um, None
    where NaN), ``"breathing_rate"`` and ``"heart_rate"`` ([person], Hz or None).
    """
    from ..store import open_run

    run = open_run(store)
    done = run.done_mask
    n = done.size
    objects = run.objects
    obj = choose_label_object(objects, label_object)
    times = run.frame_times
    radial = run.truth(obj) if obj else np.full(n, np.nan)  # NaN for frames not done
    ranges = run.object_range(obj) if obj else np.full(n, np.nan)
    labels = {"label_object": obj, "objects": objects, "num_frames": int(n), "frame_done": done.tolist(),
              "frame_time": times.tolist(), "radial_velocity": radial.tolist(), "range": ranges.tolist()}
    if run.people:
        joints = np.round(run.joint_positions(), 5)
        info = run.attrs.get("people") or {}

        def rate(person, key):
            value = (info.get(person, {}).get("vital_signs") or {}).get(key)
            return None if value is None else float(value)

        labels.update(people=run.people, joints=run.joints, person_count=run.person_count().tolist(),
                      activity=run.activities().tolist(),
                      joint_position=np.where(np.isfinite(joints), joints, None).tolist(),
                      breathing_rate=[rate(p, "breathing_rate") for p in run.people],
                      heart_rate=[rate(p, "heart_rate") for p in run.people])
    return labels


# ===================================================================================== the index
def _param_column(values: list):
    """One ``param_<name>`` column: numbers stay numbers, tuples/mixed become JSON text."""
    if all(isinstance(v, bool) for v in values):
        return np.array(values, dtype=bool)
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.int64)
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.float64)
    if all(isinstance(v, str) for v in values):
        return np.array(values, dtype=object)
    return np.array([json.dumps(v) for v in values], dtype=object)


def build_index(spec, records: list, summary: str = ""):
    """The index as an ``xarray.Dataset`` from the item records (see the module docstring)."""
    import xarray as xr

    from .. import __version__, scenes
    from ..scenes.registry import resolve

    declared = scenes.parameters(spec.scenario)
    n_items = len(records)
    n_frames = max([r["num_frames"] for r in records] + [1])

    def per_frame(key, fill=np.nan, dtype=float):
        arr = np.full((n_items, n_frames), fill, dtype=dtype)
        for i, r in enumerate(records):
            values = (r.get("labels") or {}).get(key)
            if values:
                arr[i, :len(values)] = np.asarray(values, dtype=dtype)
        return arr

    data = {
        "index": ("item", np.array([r["index"] for r in records], dtype=np.int64)),
        "status": ("item", np.array([r["status"] for r in records], dtype=object)),
        "error": ("item", np.array([r.get("error") or "" for r in records], dtype=object)),
        "ran": ("item", np.array([bool(r.get("ran")) for r in records], dtype=bool)),
        "attempts": ("item", np.array([int(r.get("attempts", 0)) for r in records], dtype=np.int64)),
        "seconds": ("item", np.array([np.nan if r.get("seconds") is None else r["seconds"] for r in records], float)),
        "cpu_seconds": ("item", np.array([np.nan if r.get("cpu_seconds") is None else r["cpu_seconds"]
                                          for r in records], float)),
        "worker": ("item", np.array([r.get("worker") or "" for r in records], dtype=object)),
        "scenario": ("item", np.array([spec.scenario] * n_items, dtype=object)),
        "radar": ("item", np.array([r["radar_name"] for r in records], dtype=object)),
        "noise_seed": ("item", np.array([r["noise_seed"] for r in records], dtype=np.int64)),
        "label_object": ("item", np.array([(r.get("labels") or {}).get("label_object", "") for r in records],
                                          dtype=object)),
        "num_frames": ("item", np.array([r["num_frames"] for r in records], dtype=np.int64)),
        "frames_done": ("item", np.array([int(r.get("frames_done", 0)) for r in records], dtype=np.int64)),
        "frame_time": (("item", "frame"), per_frame("frame_time")),
        "radial_velocity": (("item", "frame"), per_frame("radial_velocity")),
        "range": (("item", "frame"), per_frame("range")),
        "frame_done": (("item", "frame"), per_frame("frame_done", False, bool)),
    }
    data.update(_people_labels(records, n_frames))
    resolved = [resolve(spec.scenario, r["parameters"]) for r in records]
    for name, p in declared.items():
        data[f"param_{name}"] = ("item", _param_column([_plain_param(v[name]) for v in resolved]))
    coords = {"item": np.array([r["id"] for r in records], dtype=object)}
    if "person_count" in data:
        n_people = data["activity"][1].shape[2]
        joints = next(r["labels"]["joints"] for r in records if (r.get("labels") or {}).get("people"))
        coords.update(person=np.array([f"person{k}" for k in range(n_people)], dtype=object),
                      joint=np.array(joints, dtype=object))
    ds = xr.Dataset(data, coords=coords)
    for name, p in declared.items():
        ds[f"param_{name}"].attrs.update({"units": p.unit, "description": p.doc,
                                          "drawn": name in spec.parameters and spec.parameters[name].kind != "value"})
    ds["frame_time"].attrs["units"] = "s"
    ds["radial_velocity"].attrs.update({"units": "m/s", "description": "truth dR/dt of label_object, + receding"})
    ds["range"].attrs.update({"units": "m", "description": "truth range of label_object from the radar phase centre"})
    if "joint_position" in ds:
        ds["joint_position"].attrs.update({"units": "m", "description": "keypoints of every person, world frame"})
        ds["breathing_rate"].attrs["units"] = ds["heart_rate"].attrs["units"] = "Hz"
    ds["seconds"].attrs["units"] = "s"
    ds["cpu_seconds"].attrs.update({"units": "s", "description": "CPU time of the worker process during the item "
                                    "(all its threads; with several items per process at once, theirs too)"})
    ds.attrs.update({"format": INDEX_FORMAT, "name": spec.name, "scenario": spec.scenario, "spec": spec.to_json(),
                     "summary": summary, "sionnafmcw_version": __version__})
    return ds


def _people_labels(records: list, n_frames: int) -> dict:
    """The per-person index variables (module docstring) from the records' labels; ``{}`` when no item has people."""
    with_people = [(i, r["labels"]) for i, r in enumerate(records) if (r.get("labels") or {}).get("people")]
    if not with_people:
        return {}
    n_items = len(records)
    n_people = max(len(lab["people"]) for _, lab in with_people)
    n_joints = max(len(lab["joints"]) for _, lab in with_people)
    count = np.full((n_items, n_frames), -1, np.int32)
    activity = np.full((n_items, n_frames, n_people), "", dtype=object)
    joints = np.full((n_items, n_frames, n_people, n_joints, 3), np.nan, np.float32)
    breathing = np.full((n_items, n_people), np.nan)
    heart = np.full((n_items, n_people), np.nan)
    people = np.zeros(n_items, np.int64)
    for i, lab in with_people:
        p = len(lab["people"])
        people[i] = p
        c = np.asarray(lab["person_count"], np.int32)
        count[i, :c.size] = c
        act = np.asarray(lab["activity"], dtype=object).reshape(-1, p)
        activity[i, :act.shape[0], :p] = act
        jp = np.array(lab["joint_position"], dtype=float)   # None -> nan
        joints[i, :jp.shape[0], :p, :jp.shape[2]] = jp
        breathing[i, :p] = [np.nan if v is None else v for v in lab["breathing_rate"]]
        heart[i, :p] = [np.nan if v is None else v for v in lab["heart_rate"]]
    return {"num_people": ("item", people), "person_count": (("item", "frame"), count),
            "activity": (("item", "frame", "person"), activity),
            "joint_position": (("item", "frame", "person", "joint", "xyz"), joints),
            "breathing_rate": (("item", "person"), breathing), "heart_rate": (("item", "person"), heart)}


def _plain_param(v):
    return list(v) if isinstance(v, tuple) else v


def write_index(out, ds) -> Path:
    """Write the index to ``out/index.zarr``, replacing the old one only once the new one is whole."""
    out = Path(out)
    target = out / INDEX_DIR
    tmp = out / f".{INDEX_DIR}.{uuid.uuid4().hex[:8]}.tmp"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # consolidated metadata is not in the Zarr v3 spec yet
        ds.to_zarr(str(tmp), mode="w", zarr_format=3, consolidated=True)
    old = None
    if target.exists():
        old = out / f".{INDEX_DIR}.{uuid.uuid4().hex[:8]}.old"
        os.rename(target, old)
    os.rename(tmp, target)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    return target


def open_index(path):
    """The index of the data set folder ``path`` (or of ``path/index.zarr``) as an in-memory ``xarray.Dataset``."""
    import xarray as xr

    path = Path(path)
    target = path if path.name == INDEX_DIR else path / INDEX_DIR
    if not target.exists():
        raise DatasetError(f"{path} has no {INDEX_DIR}: it is not a generated data set (run "
                           "sionnafmcw.dataset.generate(spec, out) first)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = xr.open_zarr(str(target), consolidated=True).load()
    if ds.attrs.get("format") != INDEX_FORMAT:
        raise DatasetError(f"{target} is not a sionnafmcw data-set index (attribute 'format' is "
                           f"{ds.attrs.get('format')!r}, expected {INDEX_FORMAT!r})")
    return ds


__all__ = ["DatasetError", "build_index", "choose_label_object", "item_dir", "open_index", "store_labels",
           "store_state", "write_index"]
