r"""Closed triangle meshes for scene builders (outward winding, numpy only).

* :func:`box` -- axis-aligned box, 12 triangles;
* :func:`plate` -- flat square plate (open, two-sided for the ray tracer), ``2 n^2`` triangles;
* :func:`trihedral` -- triangular trihedral corner reflector: three mutually orthogonal
  isosceles right triangles of leg ``a`` meeting at the corner, open towards ``+x+y+z``
  (the boresight axis is ``(1, 1, 1)/sqrt(3)``), 3 triangles each subdivided ``n^2`` times;
  peak RCS :math:`\sigma = 4\pi a^4 / (3\lambda^2)` (Knott, *Radar Cross Section*, 2nd ed., Table 6.1);
* :func:`ellipsoid` -- UV ellipsoid with ``n_rings`` latitude rings and ``n_segments`` meridians,
  ``2 n_segments (n_rings - 1)`` triangles;
* :func:`capsule` -- cylinder with hemispherical caps between two points (a limb segment),
  ``2 n_segments (2 n_cap + n_body)`` triangles or so.

All return ``(vertices [V, 3] float64, faces [F, 3] int64)``.
"""

from __future__ import annotations

import numpy as np


def box(lo, hi):
    """Closed axis-aligned box from corner ``lo`` to corner ``hi`` (m), 12 triangles."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    f = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
         (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return v, np.array(f, dtype=np.int64)


def _grid_faces(n_u, n_v, offset=0):
    """Two triangles per cell of an ``n_u x n_v`` vertex grid (row-major)."""
    i, j = np.meshgrid(np.arange(n_u - 1), np.arange(n_v - 1), indexing="ij")
    p = (i * n_v + j).ravel() + offset
    return np.concatenate([np.stack([p, p + n_v, p + n_v + 1], 1), np.stack([p, p + n_v + 1, p + 1], 1)])


def plate(center, size, normal=(1.0, 0.0, 0.0), up=(0.0, 0.0, 1.0), subdiv: int = 1):
    """Flat rectangular plate ``size = (width, height)`` (m) centred at ``center``, facing ``normal``.

    ``height`` runs along ``up`` (made orthogonal to ``normal``), ``width`` along ``up x normal``.
    """
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    u = np.asarray(up, float)
    u = u - (u @ n) * n
    if np.linalg.norm(u) < 1e-9:
        u = np.array([0.0, 1.0, 0.0]) - n[1] * n
    u = u / np.linalg.norm(u)
    w = np.cross(u, n)
    k = subdiv + 1
    a = np.linspace(-size[0] / 2, size[0] / 2, k)
    b = np.linspace(-size[1] / 2, size[1] / 2, k)
    aa, bb = np.meshgrid(a, b, indexing="ij")
    v = np.asarray(center, float) + aa.reshape(-1, 1) * w + bb.reshape(-1, 1) * u
    f = _grid_faces(k, k)
    # winding: normal = (p1 - p0) x (p2 - p0) should point along n
    tri = v[f[0]]
    if np.cross(tri[1] - tri[0], tri[2] - tri[0]) @ n < 0:
        f = f[:, ::-1]
    return v, f


def _subdivided_triangle(p0, p1, p2, n):
    """Triangle p0 p1 p2 split into n^2 triangles (same winding)."""
    verts, index = [], {}
    for i in range(n + 1):
        for j in range(n + 1 - i):
            index[(i, j)] = len(verts)
            verts.append(p0 + (p1 - p0) * i / n + (p2 - p0) * j / n)
    faces = []
    for i in range(n):
        for j in range(n - i):
            faces.append((index[(i, j)], index[(i + 1, j)], index[(i, j + 1)]))
            if j < n - i - 1:
                faces.append((index[(i + 1, j)], index[(i + 1, j + 1)], index[(i, j + 1)]))
    return np.array(verts), np.array(faces, dtype=np.int64)


def trihedral(corner, leg: float, rotation=None, subdiv: int = 2):
    """Triangular trihedral of leg ``leg`` (m) with its corner at ``corner``.

    In its own frame the three faces lie in the planes x=0, y=0, z=0 and the aperture opens
    towards ``(1, 1, 1)``; ``rotation`` (3x3) turns that frame into the world.
    """
    e = np.eye(3) * leg
    o = np.zeros(3)
    parts = [_subdivided_triangle(o, e[1], e[2], subdiv),  # x = 0 face, normal +x
             _subdivided_triangle(o, e[2], e[0], subdiv),  # y = 0 face, normal +y
             _subdivided_triangle(o, e[0], e[1], subdiv)]  # z = 0 face, normal +z
    verts, faces, off = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + off)
        off += len(v)
    v = np.concatenate(verts)
    if rotation is not None:
        v = v @ np.asarray(rotation, float).T
    return v + np.asarray(corner, float), np.concatenate(faces)


def ellipsoid(center, radii, n_rings: int = 12, n_segments: int = 24, rotation=None):
    """Closed UV ellipsoid (semi-axes ``radii`` along the local x, y, z axes), outward winding."""
    theta = np.linspace(0.0, np.pi, n_rings + 1)[1:-1]
    phi = np.linspace(0.0, 2 * np.pi, n_segments, endpoint=False)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    unit = np.vstack([[0.0, 0.0, 1.0], ring, [0.0, 0.0, -1.0]])
    faces = _sphere_faces(n_rings - 1, n_segments)
    v = unit * np.asarray(radii, float)
    if rotation is not None:
        v = v @ np.asarray(rotation, float).T
    return v + np.asarray(center, float), faces


def _sphere_faces(n_lat, n_seg):
    """Faces of a UV sphere: north pole 0, ``n_lat`` rings of ``n_seg``, south pole last."""
    south = 1 + n_lat * n_seg
    ring = lambda i, j: 1 + i * n_seg + (j % n_seg)  # noqa: E731
    faces = []
    for j in range(n_seg):
        faces.append((0, ring(0, j), ring(0, j + 1)))
        faces.append((south, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)))
    for i in range(n_lat - 1):
        for j in range(n_seg):
            faces.append((ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)))
            faces.append((ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)))
    return np.array(faces, dtype=np.int64)


def capsule(p0, p1, radius: float, n_segments: int = 16, n_cap: int = 4, n_body: int = 4):
    """Closed capsule: a cylinder of ``radius`` (m) from ``p0`` to ``p1`` with hemispherical caps."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    axis = p1 - p0
    length = float(np.linalg.norm(axis))
    z = axis / length if length > 0 else np.array([0.0, 0.0, 1.0])
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    # latitude rings from the p1 pole (top) down to the p0 pole; elevation angle a, axial offset h
    top = [(np.pi / 2 - np.pi / 2 * k / n_cap, length) for k in range(1, n_cap + 1)]
    body = [(0.0, length * (1 - k / n_body)) for k in range(1, n_body)]
    bottom = [(-np.pi / 2 * k / n_cap, 0.0) for k in range(0, n_cap)]
    rings = top + body + bottom
    phi = np.linspace(0.0, 2 * np.pi, n_segments, endpoint=False)
    verts = [p0 + (length + radius) * z]
    for a, h in rings:
        c = radius * np.cos(a)
        off = h + radius * np.sin(a)
        verts.extend(p0 + off * z + c * (np.cos(ph) * x + np.sin(ph) * y) for ph in phi)
    verts.append(p0 - radius * z)
    faces = _sphere_faces(len(rings), n_segments)
    return np.array(verts), faces


def merge(*meshes):
    """Concatenate ``(vertices, faces)`` pairs into one mesh."""
    vs, fs, off = [], [], 0
    for v, f in meshes:
        vs.append(np.asarray(v, float))
        fs.append(np.asarray(f, np.int64) + off)
        off += len(v)
    return np.concatenate(vs), np.concatenate(fs)


def signed_volume(vertices, faces) -> float:
    """Signed volume (m^3): positive for a closed mesh with outward winding."""
    tri = np.asarray(vertices, float)[np.asarray(faces)]
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0)


__all__ = ["box", "capsule", "ellipsoid", "merge", "plate", "signed_volume", "trihedral"]
