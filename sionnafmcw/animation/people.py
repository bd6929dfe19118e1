r"""The people of an animation: who is in it, what each does, and where each one's joints are.

The scene builders that write people (:func:`sionnafmcw.mocap.scene.write_people`,
:mod:`sionnafmcw.scenes.walking`) add a top-level ``people`` entry to ``animation.json``::

    "people": {"keypoints": ["pelvis", "neck", ...],                 # K names
               "persons": [{"name": "person0", "prefix": "person0_",
                            "objects": ["person0_pelvis", ...],      # the person's objects
                            "activity": "walk",                      # or one label per frame
                            "keypoints": [[[x, y, z], ...], ...]}]}  # [frame][keypoint] m, world

* ``name``: the person's name (the run store's ``person`` coordinate); ``prefix``: the prefix of its
  object names (empty for a scene of one person); ``objects``: its objects (body segments), each also
  in the frames' ``objects``;
* ``activity``: what the person does, one string for the whole animation or a list with one per
  frame;
* ``keypoints``: the world positions (m) of the keypoints :math:`[F][K][3]` at the frame times (the
  CPI starts), ``null`` where the body has no such joint (:mod:`sionnafmcw.scenes.keypoints`).

The entry is optional (scenes without people, and scenes written before it, have none); the loader
checks it when it is there (:func:`parse_people`) and the run store carries it per frame
(:mod:`sionnafmcw.store`). numpy only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import AnimationError


@dataclass(frozen=True)
class People:
    """The ``people`` entry of a manifest, checked: ``names`` [P], ``prefixes`` [P], ``objects`` {name:
    [object names]}, ``keypoint_names`` [K], ``activities`` [F, P] (str), ``keypoints`` [F, P, K, 3] (m,
    NaN where a body has no such joint), ``info`` {name: the person's other manifest fields}."""

    names: list
    prefixes: list
    objects: dict
    keypoint_names: list
    activities: np.ndarray
    keypoints: np.ndarray
    info: dict

    @property
    def count(self) -> int:
        return len(self.names)

    def object_person(self, object_names) -> list[str]:
        """The person of each of ``object_names`` (``""`` for objects of no person)."""
        owner = {o: n for n, objs in self.objects.items() for o in objs}
        return [owner.get(o, "") for o in object_names]


def parse_people(entry, num_frames: int, where: str) -> People:
    """Check the manifest's ``people`` ``entry`` (module docstring) for an animation of ``num_frames``
    frames; :class:`~.errors.AnimationError` naming the field otherwise."""
    w = f"{where}: field 'people'"
    if not isinstance(entry, dict):
        raise AnimationError(f"{w} must be an object with 'keypoints' and 'persons'")
    kp_names = entry.get("keypoints")
    if not isinstance(kp_names, list) or not all(isinstance(k, str) for k in kp_names):
        raise AnimationError(f"{w}.keypoints must be a list of keypoint names")
    persons = entry.get("persons")
    if not isinstance(persons, list):
        raise AnimationError(f"{w}.persons must be a list of persons")
    names, prefixes, objects, info = [], [], {}, {}
    activities = np.empty((num_frames, len(persons)), dtype=object)
    keypoints = np.full((num_frames, len(persons), len(kp_names), 3), np.nan)
    for p, person in enumerate(persons):
        pw = f"{w}.persons[{p}]"
        if not isinstance(person, dict):
            raise AnimationError(f"{pw} must be an object")
        name = person.get("name")
        if not isinstance(name, str) or not name or name in names:
            raise AnimationError(f"{pw}.name must be a non-empty string of its own, got {name!r}")
        prefix = person.get("prefix", "")
        objs = person.get("objects", [])
        if not isinstance(prefix, str) or not isinstance(objs, list) or not all(isinstance(o, str) for o in objs):
            raise AnimationError(f"{pw}: 'prefix' must be a string and 'objects' a list of object names")
        act = person.get("activity", "")
        if isinstance(act, str):
            activities[:, p] = act
        elif isinstance(act, list) and len(act) == num_frames and all(isinstance(a, str) for a in act):
            activities[:, p] = act
        else:
            raise AnimationError(f"{pw}.activity must be a string or a list of {num_frames} strings (one per frame)")
        kp = person.get("keypoints")
        try:
            arr = np.array([[[np.nan] * 3 if q is None else q for q in frame] for frame in kp], dtype=float)
        except (TypeError, ValueError):
            raise AnimationError(f"{pw}.keypoints must be [{num_frames}][{len(kp_names)}][3] numbers (or null)") \
                from None
        if arr.shape != (num_frames, len(kp_names), 3):
            raise AnimationError(f"{pw}.keypoints has shape {arr.shape}, expected ({num_frames}, {len(kp_names)}, 3): "
                                 "one [x, y, z] per keypoint per frame")
        keypoints[:, p] = arr
        names.append(name)
        prefixes.append(prefix)
        objects[name] = list(objs)
        info[name] = {k: v for k, v in person.items() if k not in ("name", "prefix", "objects", "activity",
                                                                  "keypoints")}
    return People(names, prefixes, objects, list(kp_names), activities, keypoints, info)


def people_entry(keypoint_names, persons) -> dict:
    """The manifest's ``people`` entry from ``persons``: dicts with ``name``, ``prefix``, ``objects``,
    ``activity`` (str or [F] str), ``keypoints`` [F, K, 3] (m; NaN -> null, rounded to 1 um) and any
    further JSON fields."""
    out = []
    for person in persons:
        kp = np.asarray(person["keypoints"], float)
        rows = [[None if not np.all(np.isfinite(q)) else [round(float(x), 6) for x in q] for q in frame]
                for frame in kp]
        out.append({**{k: v for k, v in person.items() if k != "keypoints"}, "keypoints": rows})
    return {"keypoints": list(keypoint_names), "persons": out}


__all__ = ["People", "parse_people", "people_entry"]
