r"""Animations on disk (NOTES section 3a): loading, checking, and writing.

::

    <scene>/animation.json
    <scene>/frames/0000.xml, 0001.xml, ...   Mitsuba 3 scene XML, one per frame
    <scene>/meshes/*.ply                     shared by frames where a mesh does not change

``animation.json``::

    {"format": "sionnafmcw-animation/1",
     "fps": 24.0,
     "radar": {"position": [x, y, z], "orientation": [yaw, pitch, roll]},
     "frames": [{"index": 0, "time": 0.0, "xml": "frames/0000.xml",
                 "objects": {"<name>": {"velocity": [vx, vy, vz]}}}]}

Shapes are ``<shape type="ply" id="mesh-<name>">`` with a radio material; ``<name>`` is the
object name of the manifest. A PLY may carry per-vertex velocities as vertex properties
``vx, vy, vz`` (m/s, world frame); a separate element ``velocity`` with properties ``vx, vy, vz``
is read as well, and must then have one entry per vertex.

:func:`load_animation` checks everything it can without ray tracing and raises an
:class:`AnimationError` naming the file and field that is wrong. Frame XMLs and PLYs are read
lazily after that (with a small cache), so a long animation loads quickly.

Transforms inside the XML (``<transform name="to_world">`` with ``translate``, ``rotate``,
``scale``, ``matrix``, ``lookat``) are applied as Mitsuba applies them: each operation
left-multiplies the ones before it. Vertex velocities in a PLY are world-frame and are not
transformed.
"""

from __future__ import annotations

import functools
import json
import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

FORMAT = "sionnafmcw-animation/1"
TIME_TOLERANCE = 1e-6


class AnimationError(ValueError):
    """An animation directory that cannot be used; the message names the file and field."""


# =========================================================================================== PLY
_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


@dataclass
class PlyElement:
    name: str
    count: int
    properties: list  # [(name, dtype) | (name, ("list", count_dtype, item_dtype))]


@dataclass
class PlyData:
    """A PLY file: ``elements[name][property] -> array``; ``faces`` are triangles ``[F, 3]``."""

    path: Path
    header: list
    elements: dict

    @property
    def vertex_count(self) -> int:
        return len(next(iter(self.elements["vertex"].values())))

    @property
    def vertices(self) -> np.ndarray:
        v = self.elements["vertex"]
        return np.stack([v["x"], v["y"], v["z"]], axis=-1).astype(float)

    @functools.cached_property
    def faces(self) -> np.ndarray:
        """Triangles ``[F, 3]`` (polygons fan-triangulated, as Mitsuba does)."""
        face = self.elements.get("face")
        if not face:
            return np.zeros((0, 3), dtype=np.int64)
        key = "vertex_indices" if "vertex_indices" in face else ("vertex_index" if "vertex_index" in face else None)
        if key is None:
            raise AnimationError(f"{self.path}: element 'face' has no vertex_indices list")
        polys = face[key]
        if isinstance(polys, np.ndarray) and polys.ndim == 2:
            if polys.shape[1] < 3:
                raise AnimationError(f"{self.path}: faces with fewer than 3 vertices")
            fans = [polys[:, [0, k, k + 1]] for k in range(1, polys.shape[1] - 1)]
            return np.stack(fans, axis=1).reshape(-1, 3).astype(np.int64)
        tris = []
        for poly in polys:
            poly = np.asarray(poly, dtype=np.int64)
            for k in range(1, len(poly) - 1):
                tris.append((poly[0], poly[k], poly[k + 1]))
        return np.asarray(tris, dtype=np.int64).reshape(-1, 3)

    @property
    def vertex_velocities(self) -> np.ndarray | None:
        """Per-vertex velocity ``[V, 3]`` (m/s, world), or None when the file has none."""
        for element in ("vertex", "velocity"):
            props = self.elements.get(element, {})
            if all(k in props for k in ("vx", "vy", "vz")):
                return np.stack([props["vx"], props["vy"], props["vz"]], axis=-1).astype(float)
        return None


def _parse_ply_header(path: Path, data: bytes):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise AnimationError(f"{path}: not a PLY file (missing 'ply' magic or 'end_header')")
    nl = data.find(b"\n", end)
    body_start = len(data) if nl < 0 else nl + 1
    lines = data[:end].decode("ascii", errors="replace").replace("\r", "").split("\n")
    fmt = None
    elements: list[PlyElement] = []
    for raw in lines[1:]:
        words = raw.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format":
            fmt = words[1]
        elif words[0] == "element":
            elements.append(PlyElement(words[1], int(words[2]), []))
        elif words[0] == "property":
            if not elements:
                raise AnimationError(f"{path}: property before any element in the PLY header")
            if words[1] == "list":
                if words[2] not in _PLY_TYPES or words[3] not in _PLY_TYPES:
                    raise AnimationError(f"{path}: unknown PLY list type in {raw!r}")
                elements[-1].properties.append((words[4], ("list", _PLY_TYPES[words[2]], _PLY_TYPES[words[3]])))
            else:
                if words[1] not in _PLY_TYPES:
                    raise AnimationError(f"{path}: unknown PLY property type in {raw!r}")
                elements[-1].properties.append((words[2], _PLY_TYPES[words[1]]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise AnimationError(f"{path}: unsupported PLY format {fmt!r}")
    return fmt, elements, body_start


def read_ply(path) -> PlyData:
    """Read an ASCII or binary PLY (all elements and properties).

    Raises :class:`AnimationError` naming the file for a malformed or truncated file, and for
    vertex velocities (``vx, vy, vz``) that are incomplete or do not match the vertex count.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as err:
        raise AnimationError(f"{path}: cannot read PLY ({err.strerror or err})") from None
    fmt, elements, pos = _parse_ply_header(path, data)
    out: dict[str, dict[str, np.ndarray]] = {}
    if fmt == "ascii":
        tokens = data[pos:].split()
        t = 0
        for el in elements:
            cols: dict[str, list] = {name: [] for name, _ in el.properties}
            scalar_only = all(not isinstance(tp, tuple) for _, tp in el.properties)
            if scalar_only:
                n = el.count * len(el.properties)
                if t + n > len(tokens):
                    raise AnimationError(f"{path}: truncated PLY: element '{el.name}' declares {el.count} entries")
                block = np.array(tokens[t:t + n], dtype=float).reshape(el.count, len(el.properties))
                t += n
                out[el.name] = {name: block[:, k].astype(tp) for k, (name, tp) in enumerate(el.properties)}
                continue
            for _ in range(el.count):
                for name, tp in el.properties:
                    if t >= len(tokens):
                        raise AnimationError(f"{path}: truncated PLY: element '{el.name}' declares {el.count} entries")
                    if isinstance(tp, tuple):
                        k = int(tokens[t])
                        cols[name].append(np.array(tokens[t + 1:t + 1 + k], dtype=float).astype(tp[2]))
                        t += 1 + k
                    else:
                        cols[name].append(float(tokens[t]))
                        t += 1
            out[el.name] = {name: (_stack_lists(cols[name]) if isinstance(tp, tuple) else np.asarray(cols[name], dtype=tp))
                            for name, tp in el.properties}
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        for el in elements:
            scalar_only = all(not isinstance(tp, tuple) for _, tp in el.properties)
            if scalar_only:
                dtype = np.dtype([(name, order + tp) for name, tp in el.properties])
                n = el.count * dtype.itemsize
                if pos + n > len(data):
                    raise AnimationError(f"{path}: truncated PLY: element '{el.name}' declares {el.count} entries")
                arr = np.frombuffer(data, dtype=dtype, count=el.count, offset=pos)
                pos += n
                out[el.name] = {name: arr[name].astype(tp) for name, tp in el.properties}
                continue
            # lists: fast path for the common "uchar count + int indices, all triangles" face layout
            if (len(el.properties) == 1 and el.count > 0):
                name, (_, ctp, itp) = el.properties[0]
                csize, isize = np.dtype(ctp).itemsize, np.dtype(itp).itemsize
                if pos + csize <= len(data):
                    k = int(np.frombuffer(data, dtype=order + ctp, count=1, offset=pos)[0])
                    rec = np.dtype([("n", order + ctp), ("i", order + itp, (k,))])
                    n = el.count * rec.itemsize
                    if pos + n <= len(data):
                        arr = np.frombuffer(data, dtype=rec, count=el.count, offset=pos)
                        if np.all(arr["n"] == k):
                            out[el.name] = {name: arr["i"].astype(np.int64)}
                            pos += n
                            continue
            cols = {name: [] for name, _ in el.properties}
            for _ in range(el.count):
                for name, tp in el.properties:
                    if isinstance(tp, tuple):
                        _, ctp, itp = tp
                        csize = np.dtype(ctp).itemsize
                        if pos + csize > len(data):
                            raise AnimationError(f"{path}: truncated PLY in element '{el.name}'")
                        k = int(np.frombuffer(data, dtype=order + ctp, count=1, offset=pos)[0])
                        pos += csize
                        size = k * np.dtype(itp).itemsize
                        if pos + size > len(data):
                            raise AnimationError(f"{path}: truncated PLY in element '{el.name}'")
                        cols[name].append(np.frombuffer(data, dtype=order + itp, count=k, offset=pos).astype(np.int64))
                        pos += size
                    else:
                        size = np.dtype(tp).itemsize
                        if pos + size > len(data):
                            raise AnimationError(f"{path}: truncated PLY in element '{el.name}'")
                        cols[name].append(np.frombuffer(data, dtype=order + tp, count=1, offset=pos)[0])
                        pos += size
            out[el.name] = {name: (_stack_lists(col) if isinstance(dict(el.properties)[name], tuple)
                                   else np.asarray(col)) for name, col in cols.items()}
    ply = PlyData(path, elements, out)
    _check_ply(ply)
    return ply


def _stack_lists(lists):
    """A list of index arrays as a 2-D array when they all have one length, else the list."""
    if lists and all(len(x) == len(lists[0]) for x in lists):
        return np.asarray(lists, dtype=np.int64).reshape(len(lists), -1)
    return lists


def _check_ply(ply: PlyData) -> None:
    path = ply.path
    if "vertex" not in ply.elements or not all(k in ply.elements["vertex"] for k in "xyz"):
        raise AnimationError(f"{path}: PLY has no 'vertex' element with x, y, z")
    nv = ply.vertex_count
    for element in ("vertex", "velocity"):
        props = ply.elements.get(element, {})
        have = [k for k in ("vx", "vy", "vz") if k in props]
        if have and len(have) != 3:
            raise AnimationError(
                f"{path}: element '{element}' has vertex velocity properties {have}; vx, vy and vz are all needed"
            )
        if have:
            count = len(props["vx"])
            if count != nv:
                raise AnimationError(
                    f"{path}: {count} vertex velocities (element '{element}', vx/vy/vz) for {nv} vertices"
                )
    vel = ply.vertex_velocities
    if vel is not None and not np.all(np.isfinite(vel)):
        bad = int(np.argmax(~np.all(np.isfinite(vel), axis=1)))
        raise AnimationError(f"{path}: non-finite vertex velocity (vx, vy, vz) at vertex {bad}")
    faces = ply.faces
    if faces.size and (faces.min() < 0 or faces.max() >= nv):
        raise AnimationError(f"{path}: face vertex index out of range 0..{nv - 1}")


def write_ply(path, vertices, faces, vertex_velocities=None, binary: bool = True) -> Path:
    """Write a triangle mesh (optionally with per-vertex ``vx, vy, vz``) as PLY; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    v = np.asarray(vertices, dtype=np.float32).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int32).reshape(-1, 3)
    props = ["x", "y", "z"]
    cols = [v]
    if vertex_velocities is not None:
        vel = np.asarray(vertex_velocities, dtype=np.float32).reshape(-1, 3)
        if vel.shape[0] != v.shape[0]:
            raise ValueError(f"write_ply: {vel.shape[0]} vertex velocities for {v.shape[0]} vertices")
        props += ["vx", "vy", "vz"]
        cols.append(vel)
    table = np.concatenate(cols, axis=1)
    fmt = "binary_little_endian" if binary else "ascii"
    header = [f"ply", f"format {fmt} 1.0", f"element vertex {len(v)}"]
    header += [f"property float {p}" for p in props]
    header += [f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    head = ("\n".join(header) + "\n").encode("ascii")
    if binary:
        vrec = table.astype("<f4").tobytes()
        frec = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
        frec["n"] = 3
        frec["i"] = f
        path.write_bytes(head + vrec + frec.tobytes())
    else:
        lines = [" ".join(f"{x:.9g}" for x in row) for row in table]
        lines += ["3 " + " ".join(str(int(i)) for i in tri) for tri in f]
        path.write_bytes(head + ("\n".join(lines) + "\n").encode("ascii"))
    return path


# =========================================================================================== XML
def _floats(text: str, n: int | None, where: str) -> np.ndarray:
    try:
        vals = np.array([float(x) for x in re.split(r"[,\s]+", text.strip()) if x], dtype=float)
    except ValueError:
        raise AnimationError(f"{where}: cannot parse numbers from {text!r}") from None
    if n is not None and vals.size not in (n,) and not (n == 3 and vals.size == 1):
        raise AnimationError(f"{where}: expected {n} numbers, got {text!r}")
    if n == 3 and vals.size == 1:
        vals = np.repeat(vals, 3)
    return vals


def _xyz(el, where, default=0.0) -> np.ndarray:
    if "value" in el.attrib:
        return _floats(el.attrib["value"], 3, where)
    return np.array([float(el.attrib.get(k, default)) for k in "xyz"])


def _rotation(axis, angle_deg) -> np.ndarray:
    """Mitsuba's ``Transform4f.rotate``; like Mitsuba, the axis is used as given (not normalised)."""
    axis = np.asarray(axis, dtype=float)
    a = math.radians(angle_deg)
    x, y, z = axis
    c, s = math.cos(a), math.sin(a)
    C = 1 - c
    return np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                     [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                     [z * x * C - y * s, z * y * C + x * s, c + z * z * C]])


def _parse_transform(el, where) -> np.ndarray:
    """4x4 matrix of a Mitsuba ``<transform>`` element (each op left-multiplies)."""
    m = np.eye(4)
    for op in el:
        t = np.eye(4)
        w = f"{where} <{op.tag}>"
        if op.tag == "translate":
            t[:3, 3] = _xyz(op, w)
        elif op.tag == "scale":
            if "value" in op.attrib:
                t[:3, :3] = np.diag(_floats(op.attrib["value"], 3, w))
            else:
                t[:3, :3] = np.diag([float(op.attrib.get(k, 1.0)) for k in "xyz"])
        elif op.tag == "rotate":
            axis = _floats(op.attrib["value"], 3, w) if "value" in op.attrib else \
                np.array([float(op.attrib.get(k, 0.0)) for k in "xyz"])
            if "angle" not in op.attrib or not np.any(axis):
                raise AnimationError(f"{w}: rotate needs an axis and an angle")
            t[:3, :3] = _rotation(axis, float(op.attrib["angle"]))
        elif op.tag == "matrix":
            vals = _floats(op.attrib.get("value", ""), None, w)
            if vals.size == 16:
                t = vals.reshape(4, 4)
            elif vals.size == 9:
                t[:3, :3] = vals.reshape(3, 3)
            else:
                raise AnimationError(f"{w}: matrix needs 9 or 16 numbers")
        elif op.tag == "lookat":
            origin = _floats(op.attrib["origin"], 3, w)
            target = _floats(op.attrib["target"], 3, w)
            up = _floats(op.attrib.get("up", "0 0 1"), 3, w)
            d = target - origin
            d /= np.linalg.norm(d)
            left = np.cross(up, d)
            left /= np.linalg.norm(left)
            new_up = np.cross(d, left)
            t[:3, 0], t[:3, 1], t[:3, 2], t[:3, 3] = left, new_up, d, origin
        else:
            raise AnimationError(f"{w}: unsupported transform operation")
        m = t @ m
    return m


@dataclass
class ShapeInfo:
    """One ``<shape>`` of a frame XML."""

    id: str
    name: str
    type: str
    filename: Path | None
    to_world: np.ndarray
    material: object  # materials.MaterialSpec
    face_normals: bool


@dataclass
class FrameScene:
    """The parsed XML of one frame: its shapes by object name and the materials used."""

    xml: Path
    shapes: dict  # name -> ShapeInfo

    def materials(self) -> dict:
        """``{material id: MaterialSpec}`` of the shapes."""
        return {s.material.id: s.material for s in self.shapes.values()}


def _substitute_defaults(root, where):
    defaults = {d.attrib["name"]: d.attrib.get("value", "") for d in root.findall("default") if "name" in d.attrib}
    if not defaults:
        return
    pattern = re.compile(r"\$(\w+)")
    for el in root.iter():
        for k, v in list(el.attrib.items()):
            if "$" in v:
                el.attrib[k] = pattern.sub(lambda m: defaults.get(m.group(1), m.group(0)), v)


def parse_frame_xml(xml_path) -> FrameScene:
    """Parse a frame's Mitsuba XML: shapes, PLY files, transforms and radio materials (checked)."""
    from .materials import MaterialError, classify_bsdf

    xml_path = Path(xml_path)
    try:
        text = xml_path.read_text()
    except OSError as err:
        raise AnimationError(f"{xml_path}: cannot read frame XML ({err.strerror or err})") from None
    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:
        raise AnimationError(f"{xml_path}: malformed XML ({err})") from None
    if root.tag != "scene":
        raise AnimationError(f"{xml_path}: root element is <{root.tag}>, expected <scene>")
    _substitute_defaults(root, xml_path)

    def props_of(el):
        return {c.attrib["name"]: c.attrib.get("value") for c in el if "name" in c.attrib}

    bsdfs = {}
    for b in root.findall("bsdf"):
        bsdfs[b.attrib.get("id")] = b
    shapes = {}
    for s in root.iter("shape"):
        sid = s.attrib.get("id", "")
        stype = s.attrib.get("type", "")
        if stype in ("merge", "instance", "shapegroup"):
            continue
        where = f"{xml_path}: shape {sid!r}"
        bsdf_el = s.find("bsdf")
        if bsdf_el is None:
            ref = s.find("ref")
            if ref is not None:
                bsdf_el = bsdfs.get(ref.attrib.get("id"))
                if bsdf_el is None:
                    raise AnimationError(f"{where}: <ref id={ref.attrib.get('id')!r}> names no top-level <bsdf>")
        if bsdf_el is None:
            raise AnimationError(f"{where}: no radio material (<bsdf> or <ref>)")
        try:
            spec = classify_bsdf(bsdf_el.attrib.get("type"), bsdf_el.attrib.get("id"), props_of(bsdf_el))
        except MaterialError as err:
            raise AnimationError(f"{where}: {err}") from None
        props = props_of(s)
        filename = None
        if stype in ("ply", "obj"):
            if not props.get("filename"):
                raise AnimationError(f"{where}: no <string name=\"filename\">")
            filename = Path(props["filename"])
            if not filename.is_absolute():
                filename = (xml_path.parent / filename).resolve()
            if not filename.is_file():
                raise AnimationError(f"{where}: mesh file {props['filename']!r} not found (looked for {filename})")
        tr = s.find("transform[@name='to_world']")
        to_world = _parse_transform(tr, where) if tr is not None else np.eye(4)
        face_normals = str(props.get("face_normals", "false")).lower() == "true"
        name = sid[5:] if sid.startswith("mesh-") else sid
        if name in shapes:
            raise AnimationError(f"{where}: object name {name!r} is used by two shapes")
        shapes[name] = ShapeInfo(sid, name, stype, filename, to_world, spec, face_normals)
    # Sionna names objects and materials alike (ids without "mesh-" / "mat-"), in one namespace
    mat_names = {(m[4:] if m.startswith("mat-") else m) for m in (s.material.id or "" for s in shapes.values())}
    clash = sorted(mat_names & set(shapes))
    if clash:
        raise AnimationError(
            f"{xml_path}: object name(s) {clash} are also material names (material ids without 'mat-'); "
            "Sionna refuses two items with one name"
        )
    return FrameScene(xml_path, shapes)


# ===================================================================================== Animation
@dataclass(frozen=True)
class RadarPose:
    """Radar position (m, world) and orientation ``[yaw, pitch, roll]`` (rad, Sionna's convention)."""

    position: np.ndarray
    orientation: np.ndarray

    def to_dict(self) -> dict:
        return {"position": [float(x) for x in self.position], "orientation": [float(x) for x in self.orientation]}


@dataclass(frozen=True)
class Frame:
    """One frame: ``index``, start ``time`` (s), ``xml`` path and ``objects`` {name: velocity [3] (m/s)}."""

    index: int
    time: float
    xml: Path
    objects: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Mesh:
    """A mesh of one frame in world coordinates; ``vertex_velocities`` is None without vx, vy, vz."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    vertex_velocities: np.ndarray | None

    @property
    def centroid(self) -> np.ndarray:
        """Area-weighted centroid of the surface (vertex mean for a mesh without area)."""
        if len(self.faces):
            tri = self.vertices[self.faces]
            area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
            if area.sum() > 0:
                return (tri.mean(axis=1) * area[:, None]).sum(axis=0) / area.sum()
        return self.vertices.mean(axis=0)


class Animation:
    """A checked animation directory; build it with :func:`load_animation`."""

    def __init__(self, path: Path, fps: float, frames: list, radar_pose: RadarPose | None, manifest: dict):
        self.path = Path(path)
        self.fps = float(fps)
        self.frames = frames
        self.radar_pose = radar_pose
        self.manifest = manifest
        self._scene_cache: dict = {}

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

    def __repr__(self) -> str:
        return f"Animation({str(self.path)!r}, {self.num_frames} frames at {self.fps:g} fps, objects={self.object_names})"

    def frame(self, index: int) -> Frame:
        if not (0 <= index < self.num_frames):
            raise IndexError(f"frame index {index} out of range 0..{self.num_frames - 1}")
        return self.frames[index]

    # ------------------------------------------------------------------ geometry
    def scene(self, frame_index: int) -> FrameScene:
        """The parsed XML of a frame (cached)."""
        xml = self.frame(frame_index).xml
        if xml not in self._scene_cache:
            if len(self._scene_cache) > 64:
                self._scene_cache.clear()
            self._scene_cache[xml] = parse_frame_xml(xml)
        return self._scene_cache[xml]

    def mesh(self, frame_index: int, name: str) -> Mesh:
        """World-space mesh of object ``name`` in a frame (XML transform applied)."""
        shapes = self.scene(frame_index).shapes
        if name not in shapes:
            raise KeyError(f"frame {frame_index} ({self.frame(frame_index).xml}) has no shape 'mesh-{name}'")
        info = shapes[name]
        if info.type != "ply":
            raise AnimationError(f"{self.frame(frame_index).xml}: shape {info.id!r} is of type {info.type!r}; "
                                 "only PLY meshes can be read")
        ply = _read_ply_cached(str(info.filename), os.path.getmtime(info.filename))
        v = ply.vertices
        if not np.allclose(info.to_world, np.eye(4)):
            v = v @ info.to_world[:3, :3].T + info.to_world[:3, 3]
        return Mesh(name, v, ply.faces, ply.vertex_velocities)

    def object_positions(self, frame_index: int, names=None) -> dict:
        """``{name: area-weighted centroid [3]}`` (m, world) of the objects' meshes in a frame.

        ``names`` defaults to :attr:`object_names`.
        """
        names = self.object_names if names is None else names
        return {n: self.mesh(frame_index, n).centroid for n in names}

    def vertex_velocities(self, frame_index: int, name: str) -> np.ndarray | None:
        """Per-vertex velocities ``[V, 3]`` (m/s, world) of ``name`` in a frame, or None."""
        return self.mesh(frame_index, name).vertex_velocities

    def object_velocity(self, frame_index: int, name: str) -> np.ndarray:
        """Manifest velocity of ``name`` in a frame (zeros when not listed)."""
        return np.asarray(self.frame(frame_index).objects.get(name, np.zeros(3)), dtype=float)

    def materials(self) -> dict:
        """``{material id: MaterialSpec}`` over all frames."""
        out = {}
        for i in range(self.num_frames):
            out.update(self.scene(i).materials())
        return out

    def check_frequency(self, frequency: float) -> None:
        """Raise :class:`~sionnafmcw.materials.MaterialFrequencyError` if a material has no model at ``frequency``."""
        from .materials import check_material_frequency

        seen = set()
        for i in range(self.num_frames):
            sc = self.scene(i)
            for shape in sc.shapes.values():
                key = (shape.material.id, shape.material.kind, shape.material.itu_type)
                if key in seen:
                    continue
                seen.add(key)
                check_material_frequency(shape.material, frequency,
                                         where=f"{sc.xml}: shape {shape.id!r}, material {shape.material.id!r}")


@functools.lru_cache(maxsize=256)
def _read_ply_cached(path: str, mtime: float) -> PlyData:
    return read_ply(path)


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
    try:
        text = manifest_path.read_text()
    except OSError as err:
        raise AnimationError(f"{manifest_path}: cannot read the animation manifest ({err.strerror or err})") from None
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
        radar = manifest["radar"]
        if not isinstance(radar, dict):
            raise AnimationError(f"{where}: field 'radar' must be an object with position and orientation")
        position = _vector(radar.get("position"), 3, f"{where}: field 'radar.position'")
        orientation = _vector(radar.get("orientation", [0.0, 0.0, 0.0]), 3, f"{where}: field 'radar.orientation'")
        radar_pose = RadarPose(position, orientation)

    frames_raw = manifest.get("frames")
    if not isinstance(frames_raw, list) or not frames_raw:
        raise AnimationError(f"{where}: field 'frames' must be a non-empty list")
    frames = []
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
        objects_raw = fr.get("objects", {})
        if not isinstance(objects_raw, dict):
            raise AnimationError(f"{fw}.objects must be an object {{name: {{velocity: [vx, vy, vz]}}}}")
        objects = {}
        for name, spec in objects_raw.items():
            ow = f"{fw}.objects[{name!r}]"
            if not isinstance(spec, dict) or "velocity" not in spec:
                raise AnimationError(f"{ow} must be an object with a 'velocity'")
            objects[name] = _vector(spec["velocity"], 3, f"{ow}.velocity")
        frames.append(Frame(idx, float(t), xml_path, objects))

    anim = Animation(root, fps, frames, radar_pose, manifest)
    checked_plys = set()
    for fr in frames:
        scene = anim.scene(fr.index)
        for name in fr.objects:
            if name not in scene.shapes:
                raise AnimationError(
                    f"{where}: frames[{fr.index}].objects[{name!r}] has a velocity but {fr.xml} has no shape "
                    f"'mesh-{name}' (shapes: {', '.join(s.id for s in scene.shapes.values()) or 'none'})"
                )
        if check_meshes:
            for shape in scene.shapes.values():
                if shape.type == "ply" and shape.filename not in checked_plys:
                    _read_ply_cached(str(shape.filename), os.path.getmtime(shape.filename))
                    checked_plys.add(shape.filename)
    return anim


# ===================================================================================== writing
def write_animation(path, frames: list, fps: float, radar_pose=None) -> Path:
    """Write ``animation.json`` for frames already on disk.

    ``frames``: list of dicts ``{"xml": relative path, "objects": {name: velocity [3]}}`` (index
    and time are filled in). ``radar_pose``: ``(position, orientation)`` or a :class:`RadarPose`.
    """
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    manifest = {"format": FORMAT, "fps": float(fps)}
    if radar_pose is not None:
        if isinstance(radar_pose, RadarPose):
            manifest["radar"] = radar_pose.to_dict()
        else:
            manifest["radar"] = {"position": [float(x) for x in radar_pose[0]],
                                 "orientation": [float(x) for x in radar_pose[1]]}
    manifest["frames"] = [
        {"index": i, "time": i / float(fps), "xml": f["xml"],
         "objects": {n: {"velocity": [float(x) for x in v]} for n, v in f.get("objects", {}).items()}}
        for i, f in enumerate(frames)
    ]
    out = path / "animation.json"
    out.write_text(json.dumps(manifest, indent=1))
    return out


def scene_xml(shapes: list, materials: dict | None = None) -> str:
    """A Mitsuba scene XML string for ``shapes``.

    ``shapes``: list of dicts ``{"name", "ply" (path relative to the XML), "material" (id),
    optional "to_world" (list of (op, attrs) like ("translate", {"x": "1"}))}``. ``materials``:
    ``{id: (type, {prop: value})}`` written as top-level BSDFs, e.g.
    ``{"mat-itu_metal": ("itu-radio-material", {"type": "metal"})}``.
    """
    lines = ['<scene version="2.1.0">']
    for mid, (mtype, props) in (materials or {}).items():
        lines.append(f'    <bsdf type="{mtype}" id="{mid}">')
        for k, v in props.items():
            tag = "string" if isinstance(v, str) else "float"
            lines.append(f'        <{tag} name="{k}" value="{v}"/>')
        lines.append("    </bsdf>")
    for s in shapes:
        lines.append(f'    <shape type="ply" id="mesh-{s["name"]}">')
        lines.append(f'        <string name="filename" value="{s["ply"]}"/>')
        lines.append('        <boolean name="face_normals" value="true"/>')
        if s.get("to_world"):
            lines.append('        <transform name="to_world">')
            for op, attrs in s["to_world"]:
                a = " ".join(f'{k}="{v}"' for k, v in attrs.items())
                lines.append(f"            <{op} {a}/>")
            lines.append("        </transform>")
        lines.append(f'        <ref id="{s["material"]}"/>')
        lines.append("    </shape>")
    lines.append("</scene>")
    return "\n".join(lines) + "\n"


__all__ = [
    "Animation", "AnimationError", "FORMAT", "Frame", "FrameScene", "Mesh", "PlyData", "RadarPose",
    "ShapeInfo", "load_animation", "parse_frame_xml", "read_ply", "scene_xml", "write_animation", "write_ply",
]
