r"""The animation model: :class:`Animation` (frames, times, objects, meshes in world coordinates),
:class:`RadarPose`, :class:`Frame`, :class:`Mesh`. Build an :class:`Animation` with
:func:`sionnafmcw.animation.load_animation`; the directory layout is in :mod:`sionnafmcw.animation`.

Frame XMLs (:mod:`.frame_xml`) and PLYs (:mod:`.ply`) are read lazily, with small caches, so a long
animation loads quickly. Vertex velocities in a PLY are world-frame and are not transformed. A
rigid object (one PLY for every frame, placed by the frame's ``to_world``) has its motion in
:meth:`Animation.motion` (:class:`~.rigid.RigidMotion`) and, where it turns, the exact velocity
field :math:`\mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c)` as its mesh's vertex velocities.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import AnimationError
from .frame_xml import ParsedFrameXml, parse_frame_xml
from .ply import read_ply_cached
from .rigid import RigidMotion, area_centroid, proper_rotation

#: Parsed frame XMLs an :class:`Animation` keeps (the cache is emptied when it is full): a few kB
#: each, and more than the frames of one CPI sequence, so that the engines' passes over all frames
#: (loading, material check) and the per-frame updates parse every frame once.
FRAME_XML_CACHE_SIZE = 1024


#: The motion fields of a :class:`RadarPose` (world frame: m/s, rad/s, m/s^2, rad/s^2), zero by default.
RADAR_MOTION_FIELDS = ("velocity", "angular_velocity", "acceleration", "angular_acceleration")


def _zeros3():
    return np.zeros(3)


@dataclass(frozen=True)
class RadarPose:
    r"""Radar position (m, world) and orientation ``[yaw, pitch, roll]`` (rad, Sionna's convention) at a
    frame's CPI start, and the radar frame's motion there: ``velocity`` (m/s) of the radar
    origin, ``angular_velocity`` :math:`\boldsymbol\omega` (rad/s, world,
    :math:`\dot{\mathbf R} = [\boldsymbol\omega]_\times\mathbf R`), ``acceleration`` (m/s^2) and
    ``angular_acceleration`` (rad/s^2); all zero by default (a radar at rest). An element at
    radar-frame position :math:`\mathbf e` moves at :math:`\mathbf v + \boldsymbol\omega\times\mathbf R\mathbf e`
    (:func:`sionnafmcw.kinematics.element_kinematics`)."""

    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray = field(default_factory=_zeros3)
    angular_velocity: np.ndarray = field(default_factory=_zeros3)
    acceleration: np.ndarray = field(default_factory=_zeros3)
    angular_acceleration: np.ndarray = field(default_factory=_zeros3)

    def __post_init__(self):
        for name in ("position", "orientation", *RADAR_MOTION_FIELDS):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise AnimationError(f"RadarPose.{name} must be 3 finite numbers, got {getattr(self, name)!r}")
            object.__setattr__(self, name, value)

    @property
    def moving(self) -> bool:
        """True when the radar frame moves or turns at this instant (a velocity or angular velocity)."""
        return bool(np.any(self.velocity != 0) or np.any(self.angular_velocity != 0))

    def at_rest(self) -> RadarPose:
        """The same pose without motion."""
        return RadarPose(self.position, self.orientation)

    def same_place(self, other: RadarPose) -> bool:
        """True when ``other`` has the same position and orientation."""
        return bool(np.array_equal(self.position, other.position) and np.array_equal(self.orientation, other.orientation))

    def to_dict(self) -> dict:
        """``{"position", "orientation"}`` and, where non-zero, the motion fields (plain floats)."""
        out = {"position": [float(x) for x in self.position], "orientation": [float(x) for x in self.orientation]}
        for name in RADAR_MOTION_FIELDS:
            value = getattr(self, name)
            if np.any(value != 0):
                out[name] = [float(x) for x in value]
        return out


@dataclass(frozen=True)
class Frame:
    """One frame: ``index``, start ``time`` (s), ``xml`` path, ``objects`` {name: velocity [3] (m/s) of
    the object's area-weighted centroid}, ``angular_velocities`` {name: [3] (rad/s, world)} of the
    objects whose manifest entry has one, and ``transforms`` {name: 4x4 ``to_world``} of those whose
    entry repeats the frame XML's transform (checked against it when the animation is loaded)."""

    index: int
    time: float
    xml: Path
    objects: dict = field(default_factory=dict)
    angular_velocities: dict = field(default_factory=dict)
    transforms: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Mesh:
    """A mesh of one frame in world coordinates; ``vertex_velocities`` is None without vx, vy, vz."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    vertex_velocities: np.ndarray | None

    @property
    def centroid(self) -> np.ndarray:
        r"""Area-weighted centroid of the surface (vertex mean for a mesh without area):
        :math:`\sum_f A_f (\mathbf a_f + \mathbf b_f + \mathbf c_f)/3 \big/ \sum_f A_f`, with
        :math:`2A_f = |(\mathbf b_f - \mathbf a_f)\times(\mathbf c_f - \mathbf a_f)|` (computed on
        coordinate rows: the truth of every frame of a run needs it for every object)."""
        if len(self.faces):
            rows = np.ascontiguousarray(np.asarray(self.vertices, float).T)          # [3, V]
            a, b, c = (rows[:, self.faces[:, k]] for k in range(3))                  # [3, F]
            b -= a                                                                     # edges from a
            c -= a
            cross = (b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2], b[0] * c[1] - b[1] * c[0])
            twice_area = np.sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2])
            total = twice_area.sum()
            if total > 0:   # (a + b + c)/3 of the corners = a + (edge_b + edge_c)/3
                return (3 * (a @ twice_area) + b @ twice_area + c @ twice_area) / (3 * total)
        return self.vertices.mean(axis=0)


class Animation:
    """A checked animation directory; build it with :func:`~sionnafmcw.animation.load_animation`."""

    def __init__(self, path: Path, fps: float, frames: list, radar_pose: RadarPose | None, manifest: dict,
                 radar_track: list | None = None):
        self.path = Path(path)
        self.fps = float(fps)
        self.frames = frames
        self.radar_pose = radar_pose
        self.radar_track = radar_track
        self.manifest = manifest
        self._frame_xml_cache: dict = {}
        self._local_centroids: dict = {}   # PLY path -> area-weighted centroid of the PLY's own vertices

    # ------------------------------------------------------------------ basic facts
    @property
    def frame_period(self) -> float:
        """Time between frames, 1/fps (s)."""
        return 1.0 / self.fps

    @property
    def num_frames(self) -> int:
        return len(self.frames)

    @property
    def times(self) -> np.ndarray:
        """Frame start times (s)."""
        return np.array([f.time for f in self.frames], dtype=float)

    @property
    def people(self):
        """The manifest's people (:class:`~.people.People`: names, activities, keypoints per frame), or
        None when it has no ``people`` entry (checked by :func:`~sionnafmcw.animation.load_animation`)."""
        if "_people" not in self.__dict__:
            from .people import parse_people

            entry = self.manifest.get("people")
            self._people = None if entry is None else parse_people(entry, self.num_frames, str(self.path))
        return self._people

    @property
    def object_names(self) -> list[str]:
        """Names of the objects the manifest gives velocities for, in order of first appearance."""
        names: list[str] = []
        for f in self.frames:
            for n in f.objects:
                if n not in names:
                    names.append(n)
        return names

    def __len__(self) -> int:
        return self.num_frames

    # ------------------------------------------------------------------ the radar
    def radar_pose_at(self, frame_index: int) -> RadarPose | None:
        """The radar's pose and motion in a frame: the manifest's radar track (``frames[i].radar``) when it
        has one, else the default ``radar`` pose (None when the manifest has neither)."""
        if self.radar_track is not None:
            return self.radar_track[self.frame(frame_index).index]
        return self.radar_pose

    @property
    def radar_moves(self) -> bool:
        """True when the manifest's radar track moves (a pose that changes, or a non-zero velocity)."""
        track = self.radar_track
        if track is None:
            return self.radar_pose is not None and self.radar_pose.moving
        return any(p.moving or not p.same_place(track[0]) for p in track)

    def __repr__(self) -> str:
        return f"Animation({str(self.path)!r}, {self.num_frames} frames at {self.fps:g} fps, objects={self.object_names})"

    def frame(self, index: int) -> Frame:
        if not (0 <= index < self.num_frames):
            raise IndexError(f"frame index {index} out of range 0..{self.num_frames - 1}")
        return self.frames[index]

    # ------------------------------------------------------------------ geometry
    def frame_xml(self, frame_index: int) -> ParsedFrameXml:
        """The parsed XML of a frame: shapes by object name, their meshes and materials (cached)."""
        xml = self.frame(frame_index).xml
        if xml not in self._frame_xml_cache:
            if len(self._frame_xml_cache) > FRAME_XML_CACHE_SIZE:
                self._frame_xml_cache.clear()
            self._frame_xml_cache[xml] = parse_frame_xml(xml)
        return self._frame_xml_cache[xml]

    def _ply_shape(self, frame_index: int, name: str):
        shapes = self.frame_xml(frame_index).shapes
        if name not in shapes:
            raise KeyError(f"frame {frame_index} ({self.frame(frame_index).xml}) has no shape 'mesh-{name}'")
        info = shapes[name]
        if info.type != "ply":
            raise AnimationError(f"{self.frame(frame_index).xml}: shape {info.id!r} is of type {info.type!r}; "
                                 "only PLY meshes can be read")
        return info

    def _local_centroid(self, filename) -> np.ndarray:
        """Area-weighted centroid of a PLY's own vertices (cached per file)."""
        if filename not in self._local_centroids:
            ply = read_ply_cached(filename)
            self._local_centroids[filename] = area_centroid(ply.vertices, ply.faces)
        return self._local_centroids[filename]

    def mesh(self, frame_index: int, name: str) -> Mesh:
        r"""World-space mesh of object ``name`` in a frame (XML transform applied).

        Vertex velocities: the PLY's ``vx, vy, vz`` where it has them; else, for an object with a
        non-zero manifest ``angular_velocity``, the rigid field of :meth:`motion`
        (:math:`\mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c)`, exact); else None (the
        object translates with its manifest velocity)."""
        info = self._ply_shape(frame_index, name)
        ply = read_ply_cached(info.filename)
        v = ply.vertices
        if not np.allclose(info.to_world, np.eye(4)):
            v = v @ info.to_world[:3, :3].T + info.to_world[:3, 3]
        velocities = ply.vertex_velocities
        omega = self.frame(frame_index).angular_velocities.get(name)
        if velocities is None and omega is not None and np.any(omega != 0):
            motion = self.motion(frame_index, name)
            centroid = motion.centroid if motion is not None else Mesh(name, v, ply.faces, None).centroid
            velocities = self.object_velocity(frame_index, name) + np.cross(omega, v - centroid)
        return Mesh(name, v, ply.faces, velocities)

    def motion(self, frame_index: int, name: str) -> RigidMotion | None:
        """The rigid motion of ``name`` in a frame: its ``to_world`` (a proper rotation and a
        translation), its centroid's velocity, its angular velocity (zero when the manifest gives
        none) and its centroid; None when the frame's ``to_world`` scales or shears the mesh."""
        info = self._ply_shape(frame_index, name)
        rt = proper_rotation(info.to_world)
        if rt is None:
            return None
        rotation, translation = rt
        return RigidMotion(rotation, translation, self.object_velocity(frame_index, name),
                           self.angular_velocity(frame_index, name),
                           rotation @ self._local_centroid(info.filename) + translation)

    def object_positions(self, frame_index: int, names=None) -> dict:
        """``{name: area-weighted centroid [3]}`` (m, world) of the objects' meshes in a frame.

        ``names`` defaults to :attr:`object_names`.
        """
        names = self.object_names if names is None else names
        out = {}
        for n in names:
            info = self._ply_shape(frame_index, n)
            if np.array_equal(info.to_world, np.eye(4)):
                out[n] = self.mesh(frame_index, n).centroid
            else:   # the PLY's own centroid, placed: a rotation and translation keep the area weights
                m = info.to_world
                scaled = proper_rotation(m) is None
                out[n] = self.mesh(frame_index, n).centroid if scaled else \
                    m[:3, :3] @ self._local_centroid(info.filename) + m[:3, 3]
        return out

    def vertex_velocities(self, frame_index: int, name: str) -> np.ndarray | None:
        """Per-vertex velocities ``[V, 3]`` (m/s, world) of ``name`` in a frame, or None."""
        return self.mesh(frame_index, name).vertex_velocities

    def object_velocity(self, frame_index: int, name: str) -> np.ndarray:
        """Manifest velocity of ``name`` (of its area-weighted centroid) in a frame (zeros when not listed)."""
        return np.asarray(self.frame(frame_index).objects.get(name, np.zeros(3)), dtype=float)

    def angular_velocity(self, frame_index: int, name: str) -> np.ndarray:
        """Manifest angular velocity (rad/s, world) of ``name`` in a frame (zeros when not given)."""
        return np.asarray(self.frame(frame_index).angular_velocities.get(name, np.zeros(3)), dtype=float)

    # ------------------------------------------------------------------ accelerations
    def _neighbours(self, frame_index: int) -> tuple[int, int]:
        """The frames of the central difference at ``frame_index`` (one-sided at the ends; the frame
        itself twice for a single-frame animation)."""
        self.frame(frame_index)
        return max(frame_index - 1, 0), min(frame_index + 1, self.num_frames - 1)

    def _difference(self, frame_index: int, value) -> np.ndarray:
        r""":math:`(x_{n+1} - x_{n-1})/(t_{n+1} - t_{n-1})` of ``value(frame)`` (zero for one frame)."""
        before, after = self._neighbours(frame_index)
        if before == after:
            return np.zeros_like(np.asarray(value(frame_index), float))
        dt = self.frames[after].time - self.frames[before].time
        return (np.asarray(value(after), float) - np.asarray(value(before), float)) / dt

    def object_acceleration(self, frame_index: int, name: str) -> np.ndarray:
        r"""Acceleration (m/s^2, world) of ``name``'s centroid in a frame: the central difference of the
        manifest velocities, :math:`(\mathbf v_{n+1} - \mathbf v_{n-1})/(t_{n+1} - t_{n-1})` (one-sided
        at the first and last frame, zero for a single frame): second-order accurate at :math:`t_n`, so
        that the CPI of frame :math:`n` starts from its position, velocity and acceleration
        (:mod:`sionnafmcw.echoes`)."""
        return self._difference(frame_index, lambda f: self.object_velocity(f, name))

    def angular_acceleration(self, frame_index: int, name: str) -> np.ndarray:
        r"""Angular acceleration :math:`\boldsymbol\alpha` (rad/s^2, world) of ``name`` in a frame: the central
        difference of the manifest angular velocities, as :meth:`object_acceleration`."""
        return self._difference(frame_index, lambda f: self.angular_velocity(f, name))

    def vertex_accelerations(self, frame_index: int, name: str) -> np.ndarray | None:
        r"""Per-vertex accelerations ``[V, 3]`` (m/s^2, world) of ``name`` in a frame, or None where its points
        all share :meth:`object_acceleration` (an object that translates).

        * a mesh with per-vertex velocities (the PLY's ``vx, vy, vz``, a deforming mesh): the central
          difference of the vertex velocities of the neighbouring frames (a vertex is a material point);
        * a rigid object that turns (an angular velocity or an angular acceleration in the frame):
          :math:`\mathbf a_c + \boldsymbol\alpha\times\mathbf r + \boldsymbol\omega\times(\boldsymbol\omega\times\mathbf r)`,
          :math:`\mathbf r = \mathbf x - \mathbf c` (:func:`sionnafmcw.kinematics.rigid_point_kinematics`), exact
          for the rigid motion given its centroid's and its rotation's accelerations.
        """
        from ..kinematics import rigid_point_kinematics

        info = self._ply_shape(frame_index, name)
        if read_ply_cached(info.filename).vertex_velocities is not None:
            def velocities(f):
                v = self.mesh(f, name).vertex_velocities
                if v is None or v.shape != read_ply_cached(info.filename).vertex_velocities.shape:
                    raise AnimationError(f"{self.frame(f).xml}: mesh {name!r} has no per-vertex velocities of the "
                                         f"shape of frame {frame_index}'s; the vertex accelerations need them in "
                                         "the neighbouring frames")
                return v
            return self._difference(frame_index, velocities)
        omega = self.angular_velocity(frame_index, name)
        alpha = self.angular_acceleration(frame_index, name)
        if not (np.any(omega != 0) or np.any(alpha != 0)):
            return None
        mesh = self.mesh(frame_index, name)
        motion = self.motion(frame_index, name)
        centre = motion.centroid if motion is not None else mesh.centroid
        return rigid_point_kinematics(mesh.vertices, centre, self.object_velocity(frame_index, name), omega,
                                      self.object_acceleration(frame_index, name), alpha).acceleration

    def materials(self) -> dict:
        """``{material id: MaterialSpec}`` over all frames."""
        out = {}
        for i in range(self.num_frames):
            out.update(self.frame_xml(i).materials())
        return out

    def check_frequency(self, frequency: float) -> None:
        """Raise :class:`~sionnafmcw.materials.MaterialFrequencyError` if a material has no model at ``frequency``."""
        from ..materials import check_material_frequency

        seen = set()
        for i in range(self.num_frames):
            sc = self.frame_xml(i)
            for shape in sc.shapes.values():
                key = (shape.material.id, shape.material.kind, shape.material.itu_type)
                if key in seen:
                    continue
                seen.add(key)
                check_material_frequency(shape.material, frequency,
                                         where=f"{sc.xml}: shape {shape.id!r}, material {shape.material.id!r}")


__all__ = ["Animation", "FRAME_XML_CACHE_SIZE", "Frame", "Mesh", "RadarPose"]
