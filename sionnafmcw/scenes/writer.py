r"""Writing animation directories (layout: :mod:`sionnafmcw.animation`) frame by frame, and the radio materials.

:class:`AnimationWriter` keeps the layout every builder shares: static meshes are written once
to ``meshes/<name>.ply`` and referenced by every frame; a rigid object (a body segment, a door, a
fan blade) is written once too, in its own frame, and placed per frame by its ``to_world`` with
its centroid velocity and angular velocity in the manifest (:mod:`sionnafmcw.animation.rigid`);
a deforming object gets ``meshes/<name>_<frame>.ply`` per frame (with per-vertex velocities
``vx, vy, vz`` when given) and its manifest velocity. Shapes are ``mesh-<name>`` with a radio
material declared at the top of every frame XML.

Materials (ids never start with ``mat-itu_``: Sionna would replace such a material with its
built-in one and drop the ``scattering_coefficient``):

* ``refl-metal``: ITU ``metal`` (perfectly conducting to within ITU-R P.2040 at 77 GHz);
* ``room-concrete``, ``room-plasterboard``, ``room-floorboard``, ``room-ceiling_board``: ITU
  materials valid at 77 GHz (:data:`ITU_AT_77GHZ`; ITU-R P.2040 defines the others only below
  40 GHz, see :func:`sionnafmcw.materials.check_material_frequency`), with a ``scattering_coefficient`` (rough walls);
* ``mat-skin``: a ``radio-material`` placeholder that the engines turn into Gabriel's dry skin
  (:mod:`sionnafmcw.materials`) at the scene frequency, with a ``scattering_coefficient``: a
  faceted smooth body returns few purely specular echoes (see :mod:`sionnafmcw.engines.path`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..animation import RadarPose, write_animation, write_frame_xml, write_ply
from ..animation.rigid import proper_rotation

SKIN = "mat-skin"
METAL = "refl-metal"
ITU_AT_77GHZ = ("concrete", "plasterboard", "wood", "glass", "ceiling_board", "chipboard", "floorboard", "metal")


def metal_material(scattering_coefficient: float = 0.0) -> dict:
    """ITU metal (id ``refl-metal``); a non-zero ``scattering_coefficient`` makes it a rough (diffuse) metal."""
    props = {"type": "metal"}
    if scattering_coefficient:
        props["scattering_coefficient"] = float(scattering_coefficient)
    return {METAL: ("itu-radio-material", props)}


def skin_material(scattering_coefficient: float) -> dict:
    """The skin placeholder (dry skin, Gabriel 1996) with a diffuse ``scattering_coefficient`` in [0, 1]."""
    return {SKIN: ("radio-material", {"scattering_coefficient": float(scattering_coefficient)})}


def itu_material(itu_type: str, scattering_coefficient: float = 0.0) -> tuple[str, dict]:
    """``(id, {id: definition})`` of an ITU material (id ``room-<type>``)."""
    if itu_type not in ITU_AT_77GHZ:
        raise ValueError(f"ITU material {itu_type!r} is not one of those valid at 77 GHz: {', '.join(ITU_AT_77GHZ)}")
    mid = f"room-{itu_type}"
    props = {"type": itu_type}
    if scattering_coefficient:
        props["scattering_coefficient"] = float(scattering_coefficient)
    return mid, {mid: ("itu-radio-material", props)}


class AnimationWriter:
    """Write an animation directory at ``root``: ``static(...)`` and ``rigid(...)`` once, ``frame(...)``
    per frame, ``finish(...)``."""

    def __init__(self, root, fps: float):
        self.root = Path(root)
        self.fps = float(fps)
        (self.root / "frames").mkdir(parents=True, exist_ok=True)
        (self.root / "meshes").mkdir(parents=True, exist_ok=True)
        self.materials: dict = {}
        self._static: list = []
        self._rigid: dict = {}      # name -> shape dict (ply, material, face_normals)
        self._frames: list = []
        self.static_objects: list[str] = []

    def add_materials(self, materials: dict) -> None:
        self.materials.update(materials)

    def static(self, name: str, vertices, faces, material: str, truth: bool = False) -> None:
        """A mesh that never moves (written once). ``truth=True`` lists it in every frame's manifest
        with zero velocity, so the run store carries its position as ground truth."""
        self._check_material(material)
        write_ply(self.root / "meshes" / f"{name}.ply", vertices, faces)
        self._static.append({"name": name, "ply": f"../meshes/{name}.ply", "material": material})
        if truth:
            self.static_objects.append(name)

    def rigid(self, name: str, vertices, faces, material: str, vertex_normals=None) -> None:
        """A rigid object: its mesh in its own frame (``vertices`` [V, 3] m, optional unit
        ``vertex_normals`` [V, 3]), written once to ``meshes/<name>.ply``; every :meth:`frame` must
        then place it (``rigid={name: ...}``)."""
        self._check_material(material)
        if name in self._rigid or any(s["name"] == name for s in self._static):
            raise ValueError(f"AnimationWriter: object {name!r} is declared twice")
        write_ply(self.root / "meshes" / f"{name}.ply", vertices, faces, vertex_normals=vertex_normals)
        self._rigid[name] = {"name": name, "ply": f"../meshes/{name}.ply", "material": material,
                             "face_normals": vertex_normals is None}

    def frame(self, moving: list = (), rigid: dict | None = None, radar: RadarPose | None = None) -> int:
        """Write the next frame. ``moving``: deforming objects, dicts with ``name, vertices, faces,
        material, velocity`` and optionally ``vertex_velocities`` ([V, 3], m/s, world), written per
        frame. ``rigid``: ``{name: {"to_world": 4x4, "velocity": [3], "angular_velocity": [3]}}`` for
        every object declared with :meth:`rigid` (``velocity`` of its area-weighted centroid, m/s;
        ``angular_velocity`` rad/s, world). ``radar``: the radar's pose and motion in this frame (a
        radar track: give it in every frame or in none). Returns the frame index."""
        i = len(self._frames)
        if (radar is None) != (not any(f.get("radar") is not None for f in self._frames)) and self._frames:
            raise ValueError(f"AnimationWriter.frame: frame {i} {'has no' if radar is None else 'has a'} radar pose "
                             "but the frames before it do not agree: a radar track gives every frame's pose or none")
        rigid = rigid or {}
        missing = sorted(set(self._rigid) - set(rigid))
        unknown = sorted(set(rigid) - set(self._rigid))
        if missing or unknown:
            raise ValueError(f"AnimationWriter.frame: rigid objects without a transform in frame {i}: "
                             f"{missing or 'none'}; not declared with rigid(): {unknown or 'none'}")
        shapes, objects = [], {}
        for obj in moving:
            name = obj["name"]
            self._check_material(obj["material"])
            write_ply(self.root / "meshes" / f"{name}_{i:04d}.ply", obj["vertices"], obj["faces"],
                      vertex_velocities=obj.get("vertex_velocities"))
            shapes.append({"name": name, "ply": f"../meshes/{name}_{i:04d}.ply", "material": obj["material"]})
            objects[name] = np.asarray(obj["velocity"], dtype=float)
        for name, motion in rigid.items():
            matrix = np.asarray(motion["to_world"], dtype=float)
            if matrix.shape != (4, 4) or proper_rotation(matrix) is None:
                raise ValueError(f"AnimationWriter.frame: to_world of rigid object {name!r} in frame {i} must be a "
                                 "4x4 proper rotation and translation")
            shapes.append(self._rigid[name] | {"to_world": matrix})
            objects[name] = {"velocity": motion["velocity"],
                             "angular_velocity": motion.get("angular_velocity", np.zeros(3)), "to_world": matrix}
        for name in self.static_objects:
            objects[name] = np.zeros(3)
        xml = f"frames/{i:04d}.xml"
        write_frame_xml(self.root / xml, shapes + self._static, self.materials)
        self._frames.append({"xml": xml, "objects": objects, "radar": radar})
        return i

    def finish(self, radar_position, radar_orientation, extra: dict | None = None) -> Path:
        """Write ``animation.json`` with the default radar pose (position m, orientation rad; with a radar
        track, give its frame 0) and ``extra`` top-level fields (e.g. ``"source"``; the loader ignores
        fields it does not know)."""
        if not self._frames:
            raise ValueError("AnimationWriter: no frame written")
        return write_animation(self.root, self._frames, self.fps,
                               RadarPose(np.asarray(radar_position, float), np.asarray(radar_orientation, float)),
                               extra=extra)

    def _check_material(self, material):
        if material not in self.materials:
            raise ValueError(f"material {material!r} is not declared (declared: {', '.join(self.materials) or 'none'})")


def straight_track(start, velocity, orientation, times) -> list:
    """A radar moving at a constant ``velocity`` (m/s, world) from ``start`` (m) with a fixed ``orientation``
    (yaw, pitch, roll; rad): one :class:`~sionnafmcw.animation.RadarPose` per time (s), zero acceleration."""
    start, velocity = np.asarray(start, float), np.asarray(velocity, float)
    return [RadarPose(start + velocity * t, np.asarray(orientation, float), velocity=velocity) for t in times]


def look_at_orientation(position, target) -> np.ndarray:
    """Sionna ``(yaw, pitch, roll)`` (rad) that points the radar boresight (local +x) from ``position`` at ``target``.

    Sionna's orientation turns local +x into ``(cos(pitch) cos(yaw), cos(pitch) sin(yaw), -sin(pitch))``
    (yaw about z, then pitch about the new y, which tips +x downwards for positive pitch).
    """
    d = np.asarray(target, float) - np.asarray(position, float)
    yaw = np.arctan2(d[1], d[0])
    pitch = -np.arctan2(d[2], np.hypot(d[0], d[1]))
    return np.array([yaw, pitch, 0.0])


__all__ = ["AnimationWriter", "ITU_AT_77GHZ", "METAL", "SKIN", "itu_material", "look_at_orientation",
           "metal_material", "skin_material", "straight_track"]
