r"""The animation manifest ``animation.json``: :func:`load_animation` (read and check a whole
animation directory) and :func:`write_animation` (write the manifest of frames already on disk).

The layout and the manifest's fields are in :mod:`sionnafmcw.animation`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .errors import AnimationError, read_text
from .model import RADAR_MOTION_FIELDS, Animation, Frame, RadarPose
from .ply import read_ply_cached

#: The manifest's ``format`` field.
FORMAT = "sionnafmcw-animation/1"
#: Largest difference (s) between a frame's ``time`` and ``index / fps``.
TIME_TOLERANCE = 1e-6
#: Largest difference between an object's manifest ``to_world`` and its frame XML's (the writers
#: write both from the same float64 numbers with ``repr``, so they agree exactly; a hand-written
#: manifest may round): 1 nm in the translation, 1e-9 in the rotation.
TRANSFORM_TOLERANCE = 1e-9


def _vector(value, n, where) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise AnimationError(f"{where} must be {n} numbers, got {value!r}") from None
    if arr.shape != (n,):
        raise AnimationError(f"{where} must be {n} numbers, got {value!r}")
    if not np.all(np.isfinite(arr)):
        raise AnimationError(f"{where} contains non-finite values: {value!r}")
    return arr


def load_animation(path, check_meshes: bool = True) -> Animation:
    """Load and check an animation directory (or its ``animation.json``).

    Checks: the manifest's ``format``, ``fps``, ``radar`` and ``frames`` (indices 0, 1, 2...
    in order, ``time`` = index/fps within 1e-6 s, finite object velocities), every frame XML
    (readable, shapes with radio materials Sionna knows, mesh files present, a ``mesh-<name>``
    shape for every object with a velocity) and, with ``check_meshes``, every PLY it refers to
    (readable, vertex velocities complete, one per vertex, finite).
    """
    path = Path(path)
    manifest_path = path / "animation.json" if path.is_dir() else path
    root = manifest_path.parent
    text = read_text(manifest_path, "the animation manifest")
    try:
        manifest = json.loads(text)
    except json.JSONDecodeError as err:
        raise AnimationError(f"{manifest_path}: invalid JSON ({err})") from None
    if not isinstance(manifest, dict):
        raise AnimationError(f"{manifest_path}: the manifest must be a JSON object")
    where = str(manifest_path)
    if manifest.get("format") != FORMAT:
        raise AnimationError(f"{where}: field 'format' is {manifest.get('format')!r}, expected {FORMAT!r}")
    fps = manifest.get("fps")
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not math.isfinite(fps) or fps <= 0:
        raise AnimationError(f"{where}: field 'fps' must be a positive number, got {fps!r}")
    fps = float(fps)

    radar_pose = None
    if "radar" in manifest:
        radar_pose = _radar_pose(manifest["radar"], where, "radar", per_frame=False)

    frames_raw = manifest.get("frames")
    if not isinstance(frames_raw, list) or not frames_raw:
        raise AnimationError(f"{where}: field 'frames' must be a non-empty list")
    frames, track = [], []
    for i, fr in enumerate(frames_raw):
        fw = f"{where}: frames[{i}]"
        if not isinstance(fr, dict):
            raise AnimationError(f"{fw} must be an object")
        idx = fr.get("index")
        if isinstance(idx, bool) or not isinstance(idx, int):
            raise AnimationError(f"{fw}.index must be an integer, got {idx!r}")
        if idx != i:
            raise AnimationError(f"{fw}.index is {idx}, expected {i}: frames must be listed in order 0, 1, 2, ...")
        t = fr.get("time")
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise AnimationError(f"{fw}.time must be a number, got {t!r}")
        if abs(t - idx / fps) > TIME_TOLERANCE:
            raise AnimationError(
                f"{fw}.time is {t!r} s but index/fps = {idx / fps!r} s (tolerance {TIME_TOLERANCE} s)"
            )
        xml = fr.get("xml")
        if not isinstance(xml, str) or not xml:
            raise AnimationError(f"{fw}.xml must be a path string, got {xml!r}")
        xml_path = (root / xml).resolve()
        if not xml_path.is_file():
            raise AnimationError(f"{fw}.xml: frame XML {xml!r} not found (looked for {xml_path})")
        if "radar" in fr:
            track.append(_radar_pose(fr["radar"], where, f"frames[{i}].radar", per_frame=True))
        objects_raw = fr.get("objects", {})
        if not isinstance(objects_raw, dict):
            raise AnimationError(f"{fw}.objects must be an object {{name: {{velocity: [vx, vy, vz]}}}}")
        objects, spins, transforms = {}, {}, {}
        for name, spec in objects_raw.items():
            ow = f"{fw}.objects[{name!r}]"
            if not isinstance(spec, dict) or "velocity" not in spec:
                raise AnimationError(f"{ow} must be an object with a 'velocity'")
            unknown = sorted(set(spec) - {"velocity", "angular_velocity", "to_world"})
            if unknown:
                raise AnimationError(f"{ow} has unknown field(s) {', '.join(unknown)}; known: velocity, "
                                     "angular_velocity, to_world")
            objects[name] = _vector(spec["velocity"], 3, f"{ow}.velocity")
            if "angular_velocity" in spec:
                spins[name] = _vector(spec["angular_velocity"], 3, f"{ow}.angular_velocity")
            if "to_world" in spec:
                transforms[name] = _vector(spec["to_world"], 16, f"{ow}.to_world").reshape(4, 4)
        frames.append(Frame(idx, float(t), xml_path, objects, spins, transforms))

    radar_track = None
    if track:
        if len(track) != len(frames):
            missing = next(i for i, fr in enumerate(frames_raw) if "radar" not in fr)
            raise AnimationError(f"{where}: frames[{missing}] has no field 'radar' but {len(track)} other frames do: "
                                 "a radar track gives the radar's pose in every frame (or in none)")
        radar_track = complete_track(track, [f.time for f in frames], given=[set(fr["radar"]) for fr in frames_raw])
        if radar_pose is None:
            radar_pose = radar_track[0].at_rest()
    anim = Animation(root, fps, frames, radar_pose, manifest, radar_track)
    people = anim.people      # the optional 'people' entry, checked (sionnafmcw.animation.people)
    if people is not None:       # a person's objects are shapes of the scene (moving, or still in every frame)
        known = set(anim.object_names) | set(anim.frame_xml(0).shapes)
        for name, objs in people.objects.items():
            missing = [o for o in objs if o not in known]
            if missing:
                raise AnimationError(f"{where}: field 'people': person {name!r} lists objects that are not shapes of "
                                     f"the scene: {', '.join(missing[:5])}")
    checked_plys = set()
    for fr in frames:
        parsed = anim.frame_xml(fr.index)
        for name in fr.objects:
            if name not in parsed.shapes:
                raise AnimationError(
                    f"{where}: frames[{fr.index}].objects[{name!r}] has a velocity but {fr.xml} has no shape "
                    f"'mesh-{name}' (shapes: {', '.join(s.id for s in parsed.shapes.values()) or 'none'})"
                )
        for name, matrix in fr.transforms.items():
            shape = parsed.shapes[name]
            if not np.allclose(matrix, shape.to_world, rtol=0.0, atol=TRANSFORM_TOLERANCE):
                raise AnimationError(
                    f"{where}: frames[{fr.index}].objects[{name!r}].to_world differs from the to_world of shape "
                    f"{shape.id!r} in {fr.xml} (largest difference {np.max(np.abs(matrix - shape.to_world)):.3g}); "
                    "write the same transform in both, or leave it out of the manifest")
        if check_meshes:
            for shape in parsed.shapes.values():
                if shape.type == "ply" and shape.filename not in checked_plys:
                    read_ply_cached(shape.filename)
                    checked_plys.add(shape.filename)
            for name in fr.angular_velocities:
                shape = parsed.shapes[name]
                if shape.type == "ply" and read_ply_cached(shape.filename).vertex_velocities is not None:
                    raise AnimationError(
                        f"{where}: frames[{fr.index}].objects[{name!r}] has an angular_velocity and its mesh "
                        f"{shape.filename} carries per-vertex velocities vx, vy, vz: give one or the other (a rigid "
                        "object's velocity field is its velocity and angular velocity)")
    return anim


#: Fields of a manifest's radar pose (top level or per frame): position, orientation and the motion.
RADAR_FIELDS = ("position", "orientation", *RADAR_MOTION_FIELDS)


def _radar_pose(value, where: str, name: str, per_frame: bool) -> RadarPose:
    """A :class:`RadarPose` from a manifest's ``radar`` object; the error names the field. Per frame,
    ``position``, ``orientation`` and ``velocity`` are required (the track's motion); at the top level
    only ``position`` (a radar at rest unless it gives its motion)."""
    if not isinstance(value, dict):
        raise AnimationError(f"{where}: field '{name}' must be an object with position and orientation")
    unknown = sorted(set(value) - set(RADAR_FIELDS))
    if unknown and per_frame:   # (the top-level pose ignores unknown fields)
        raise AnimationError(f"{where}: field '{name}' has unknown field(s) {', '.join(unknown)}; known: "
                             f"{', '.join(RADAR_FIELDS)}")
    required = ("position", "orientation", "velocity") if per_frame else ("position",)
    for key in required:
        if key not in value:
            raise AnimationError(f"{where}: field '{name}.{key}' is missing" + (
                " (a radar track states the radar's velocity in every frame, m/s, world)" if key == "velocity" else ""))
    fields = {"position": _vector(value["position"], 3, f"{where}: field '{name}.position'"),
              "orientation": _vector(value.get("orientation", [0.0, 0.0, 0.0]), 3,
                                     f"{where}: field '{name}.orientation'")}
    for key in RADAR_MOTION_FIELDS:
        if key in value:
            fields[key] = _vector(value[key], 3, f"{where}: field '{name}.{key}'")
    return RadarPose(**fields)


def complete_track(poses: list, times, given=None) -> list:
    r"""The radar track ``poses`` (one :class:`RadarPose` per frame, at ``times`` (s)) with the
    accelerations filled in where ``given`` (per frame, the set of fields the manifest states; None:
    none) lacks them: the central differences of the velocities and angular velocities,
    :math:`\mathbf a_n = (\mathbf v_{n+1} - \mathbf v_{n-1})/(t_{n+1} - t_{n-1})` (one-sided at the
    ends, zero for a single frame), as :meth:`~sionnafmcw.animation.Animation.object_acceleration`
    does for the objects."""
    from dataclasses import replace

    t = np.asarray(times, float)
    given = [set() for _ in poses] if given is None else given
    out = []
    for name, source in (("acceleration", "velocity"), ("angular_acceleration", "angular_velocity")):
        values = np.array([getattr(p, source) for p in poses])
        derived = np.gradient(values, t, axis=0) if len(poses) > 1 else np.zeros_like(values)
        out.append(derived)
    return [replace(p, **{name: d[i] for name, d in zip(("acceleration", "angular_acceleration"), out)
                          if name not in given[i]}) for i, p in enumerate(poses)]


def write_animation(path, frames: list, fps: float, radar_pose=None, extra: dict | None = None) -> Path:
    """Write ``animation.json`` for frames already on disk; returns its path.

    ``frames``: list of dicts ``{"xml": relative path, "objects": {name: velocity [3]}}`` (index
    and time ``index / fps`` are filled in); an object's entry may also be a dict ``{"velocity",
    "angular_velocity", "to_world"}`` (a rigid object: :mod:`.rigid`; ``to_world`` a 4x4 that must
    equal the frame XML's); a frame's ``"radar"`` (a :class:`RadarPose` or its dict) is the radar's
    pose and motion in that frame (a radar track: every frame or none). ``radar_pose``: a
    :class:`RadarPose`, a dict ``{"position", "orientation"}`` or ``(position, orientation)``: the
    default pose (with a track, write its frame 0). ``extra``: further top-level fields (e.g.
    ``"source"``, ``"scenario"``; the loader ignores fields it does not know).
    """
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    manifest = {"format": FORMAT, "fps": float(fps)}
    if radar_pose is not None:
        if isinstance(radar_pose, RadarPose):
            manifest["radar"] = radar_pose.to_dict()
        elif isinstance(radar_pose, dict):
            manifest["radar"] = {"position": [float(x) for x in radar_pose["position"]],
                                 "orientation": [float(x) for x in radar_pose["orientation"]]}
        else:
            manifest["radar"] = {"position": [float(x) for x in radar_pose[0]],
                                 "orientation": [float(x) for x in radar_pose[1]]}
    manifest["frames"] = []
    for i, f in enumerate(frames):
        entry = {"index": i, "time": i / float(fps), "xml": f["xml"],
                 "objects": {n: _object_entry(v) for n, v in f.get("objects", {}).items()}}
        if f.get("radar") is not None:
            entry["radar"] = _radar_entry(f["radar"])
        manifest["frames"].append(entry)
    manifest.update(extra or {})
    out = path / "animation.json"
    out.write_text(json.dumps(manifest, indent=1))
    return out


def _radar_entry(value) -> dict:
    """A frame's ``radar`` entry: position, orientation and velocity always, the other motion fields where
    non-zero."""
    pose = value if isinstance(value, RadarPose) else RadarPose(**{k: np.asarray(v, float) for k, v in value.items()})
    entry = pose.to_dict()
    entry.setdefault("velocity", [0.0, 0.0, 0.0])
    return entry


def _object_entry(value) -> dict:
    """The manifest entry of one object: a velocity [3], or a dict of velocity, angular velocity, to_world."""
    if not isinstance(value, dict):
        return {"velocity": [float(x) for x in np.asarray(value, float).reshape(3)]}
    entry = {"velocity": [float(x) for x in np.asarray(value["velocity"], float).reshape(3)]}
    if value.get("angular_velocity") is not None:
        entry["angular_velocity"] = [float(x) for x in np.asarray(value["angular_velocity"], float).reshape(3)]
    if value.get("to_world") is not None:
        entry["to_world"] = [float(x) for x in np.asarray(value["to_world"], float).reshape(16)]
    return entry


__all__ = ["FORMAT", "RADAR_FIELDS", "TIME_TOLERANCE", "TRANSFORM_TOLERANCE", "complete_track", "load_animation",
           "write_animation"]
