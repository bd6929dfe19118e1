r"""PLY meshes: reading (ASCII and binary, any elements) and writing (triangles + vertex velocities).

numpy and the standard library only: the Blender exporter (numpy < 2, no Sionna) imports it.

A mesh of an animation directory (layout in :mod:`sionnafmcw.animation`) is a PLY with a
``vertex`` element ``x, y, z`` (m, in the shape's local frame: the frame XML's ``to_world`` maps it
to the world) and a ``face`` element ``vertex_indices`` (polygons, fan-triangulated on reading as
Mitsuba does). Per-vertex velocities (m/s, world frame, not transformed by ``to_world``) are vertex
properties ``vx, vy, vz``; a separate element ``velocity`` with properties ``vx, vy, vz`` is read
as well, and must then have one entry per vertex.

Per-vertex unit normals are the standard vertex properties ``nx, ny, nz`` (local frame, turned by
``to_world`` like the positions): Mitsuba interpolates them across each triangle as the shading
normal (unless the shape sets ``face_normals``), which is the smooth surface physical optics
needs on a tessellated curved body (:mod:`sionnafmcw.physical_optics`).

What :func:`write_ply` / :func:`ply_bytes` write: ``binary_little_endian``, ``vertex`` ``x y z``
float [+ ``nx ny nz`` float] [+ ``vx vy vz`` float], ``face`` ``list uchar int vertex_indices``
(triangles).
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import AnimationError

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
            if polys.shape[1] == 3:   # triangles already
                return np.ascontiguousarray(polys, dtype=np.int64)
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

    @property
    def vertex_normals(self) -> np.ndarray | None:
        """Per-vertex normal ``[V, 3]`` (``nx, ny, nz``, local frame), or None when the file has none."""
        props = self.elements.get("vertex", {})
        if all(k in props for k in ("nx", "ny", "nz")):
            return np.stack([props["nx"], props["ny"], props["nz"]], axis=-1).astype(float)
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
                csize = np.dtype(ctp).itemsize
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
    have = [k for k in ("nx", "ny", "nz") if k in ply.elements["vertex"]]
    if have and len(have) != 3:
        raise AnimationError(f"{path}: element 'vertex' has normal properties {have}; nx, ny and nz are all needed")
    normals = ply.vertex_normals
    if normals is not None and not np.all(np.isfinite(normals)):
        bad = int(np.argmax(~np.all(np.isfinite(normals), axis=1)))
        raise AnimationError(f"{path}: non-finite vertex normal (nx, ny, nz) at vertex {bad}")
    vel = ply.vertex_velocities
    if vel is not None and not np.all(np.isfinite(vel)):
        bad = int(np.argmax(~np.all(np.isfinite(vel), axis=1)))
        raise AnimationError(f"{path}: non-finite vertex velocity (vx, vy, vz) at vertex {bad}")
    faces = ply.faces
    if faces.size and (faces.min() < 0 or faces.max() >= nv):
        raise AnimationError(f"{path}: face vertex index out of range 0..{nv - 1}")



def ply_bytes(vertices, faces, vertex_velocities=None, binary: bool = True, vertex_normals=None) -> bytes:
    """A triangle mesh (optionally with per-vertex ``nx, ny, nz`` and ``vx, vy, vz``) as the bytes of a PLY file.

    ``vertices`` ``[V, 3]``, ``vertex_normals`` ``[V, 3]`` (unit, same frame as the vertices) and
    ``vertex_velocities`` ``[V, 3]`` are written as float32, ``faces`` ``[F, 3]`` as int32; raises
    :class:`ValueError` when the normal or velocity count is not the vertex count, or a normal is
    not a finite unit vector.
    """
    v = np.asarray(vertices, dtype="<f4").reshape(-1, 3)
    f = np.asarray(faces, dtype="<i4").reshape(-1, 3)
    props = ["x", "y", "z"]
    cols = [v]
    if vertex_normals is not None:
        nrm = np.asarray(vertex_normals, dtype=float).reshape(-1, 3)
        if nrm.shape[0] != v.shape[0]:
            raise ValueError(f"PLY: {nrm.shape[0]} vertex normals for {v.shape[0]} vertices")
        length = np.linalg.norm(nrm, axis=1)
        if not np.all(np.isfinite(length)) or np.any(np.abs(length - 1.0) > 1e-3):
            raise ValueError("PLY: vertex normals must be finite unit vectors (nx, ny, nz)")
        props += ["nx", "ny", "nz"]
        cols.append(nrm.astype("<f4"))
    if vertex_velocities is not None:
        vel = np.asarray(vertex_velocities, dtype="<f4").reshape(-1, 3)
        if vel.shape[0] != v.shape[0]:
            raise ValueError(f"PLY: {vel.shape[0]} vertex velocities for {v.shape[0]} vertices")
        props += ["vx", "vy", "vz"]
        cols.append(vel)
    table = np.concatenate(cols, axis=1)
    fmt = "binary_little_endian" if binary else "ascii"
    header = ["ply", f"format {fmt} 1.0", f"element vertex {len(v)}"]
    header += [f"property float {p}" for p in props]
    header += [f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    head = ("\n".join(header) + "\n").encode("ascii")
    if binary:
        frec = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
        frec["n"] = 3
        frec["i"] = f
        return head + table.tobytes() + frec.tobytes()
    lines = [" ".join(f"{x:.9g}" for x in row) for row in table]
    lines += ["3 " + " ".join(str(int(i)) for i in tri) for tri in f]
    return head + ("\n".join(lines) + "\n").encode("ascii")


def write_ply(path, vertices, faces, vertex_velocities=None, binary: bool = True, vertex_normals=None) -> Path:
    """Write :func:`ply_bytes` to ``path`` (parent folders created); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(ply_bytes(vertices, faces, vertex_velocities, binary, vertex_normals))
    return path


@functools.lru_cache(maxsize=256)
def _read_ply_cached(path: str, mtime: float) -> PlyData:
    return read_ply(path)


def read_ply_cached(path) -> PlyData:
    """:func:`read_ply` through a cache keyed by path and modification time (256 files)."""
    return _read_ply_cached(str(path), os.path.getmtime(path))


__all__ = ["PlyData", "PlyElement", "ply_bytes", "read_ply", "read_ply_cached", "write_ply"]
