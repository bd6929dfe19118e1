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

Resolution. :func:`ellipsoid_grid` and :func:`capsule_divisions` choose the rings and
meridians from a largest triangle edge :math:`e`: a UV cell of sides :math:`h_u, h_v`
splits into two triangles whose longest edge is the diagonal :math:`\sqrt{h_u^2 + h_v^2}`, so
both sides are kept below :math:`e/\sqrt2` (arcs of equal length along the equator and
the longest meridian; sheared ellipsoid cells are refined until their diagonal fits).
The chord of an arc of radius :math:`\rho` and length :math:`h` departs from the arc by the
sagitta :math:`h^2/(8\rho)` (:func:`sagitta`). :func:`vertex_normals` gives the smooth
(area-weighted) normals a renderer interpolates across the facets; :func:`edge_lengths` the
edges of a mesh.
"""

from __future__ import annotations

import numpy as np

#: Largest turn (rad) of the surface normal over one grid step of a curved body mesh (the walker's
#: segments, the motion-capture body): where the radius of curvature :math:`\rho` is small (a foot's
#: toe and heel, 9 mm) the steps are kept to :math:`\psi_{max}\rho` whatever the edge length, so the
#: smooth surface the engines rebuild from the normals (:mod:`sionnafmcw.smooth_surface`) follows the
#: shape: a 32 mm foot whose toe turned its normal by 91 degrees over one edge missed it by 1.2 mm and
#: its echo by up to 1.8 dB.
MAX_NORMAL_TURN = 0.6
#: Default largest triangle edge (m) of the human body meshes (the walker's segments and the
#: motion-capture body): the engines render the smooth surface of their exact normals, within 0.7 dB
#: of the exact shapes at 77 GHz (:mod:`sionnafmcw.scenes.body`, *Mesh resolution*).
BODY_MESH_EDGE = 0.032


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


def ellipsoid(center, radii, n_rings: int = 12, n_segments: int = 24, rotation=None, theta=None, phi=None):
    """Closed UV ellipsoid (semi-axes ``radii`` along the local x, y, z axes), outward winding.

    Rings at the polar angles ``theta`` (rad, strictly between 0 and pi, increasing; default
    ``n_rings - 1`` equal steps) and meridians at the azimuths ``phi`` (rad in [0, 2 pi), increasing;
    default ``n_segments`` equal steps): :func:`ellipsoid_grid` spaces them by arc length.
    """
    theta = np.linspace(0.0, np.pi, n_rings + 1)[1:-1] if theta is None else np.asarray(theta, float)
    phi = np.linspace(0.0, 2 * np.pi, n_segments, endpoint=False) if phi is None else np.asarray(phi, float)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    unit = np.vstack([[0.0, 0.0, 1.0], ring, [0.0, 0.0, -1.0]])
    faces = _sphere_faces(len(theta), len(phi))
    v = unit * np.asarray(radii, float)
    if rotation is not None:
        v = v @ np.asarray(rotation, float).T
    return v + np.asarray(center, float), faces


def _sphere_faces(n_lat, n_seg):
    """Faces of a UV sphere: north pole 0, ``n_lat`` rings of ``n_seg``, south pole last (the caps'
    fans around each meridian, then two triangles per cell of every pair of rings)."""
    south = 1 + n_lat * n_seg
    j = np.arange(n_seg)
    jn = (j + 1) % n_seg
    caps = np.empty((2 * n_seg, 3), dtype=np.int64)
    caps[0::2] = np.stack([np.zeros(n_seg, np.int64), 1 + j, 1 + jn], -1)
    last = 1 + (n_lat - 1) * n_seg
    caps[1::2] = np.stack([np.full(n_seg, south), last + jn, last + j], -1)
    i = np.arange(n_lat - 1)[:, None]
    a, b = 1 + i * n_seg + j, 1 + (i + 1) * n_seg + j           # ring i and ring i + 1, meridian j
    an, bn = 1 + i * n_seg + jn, 1 + (i + 1) * n_seg + jn
    cells = np.stack([np.stack([a, b, bn], -1), np.stack([a, bn, an], -1)], axis=2).reshape(-1, 3)
    return np.concatenate([caps, cells]).astype(np.int64)


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
    a, h = np.array(rings).T
    c = radius * np.cos(a)[:, None, None]
    off = (h + radius * np.sin(a))[:, None, None]
    around = np.cos(phi)[None, :, None] * x + np.sin(phi)[None, :, None] * y          # [1, S, 3]
    ring_verts = (p0 + off * z + c * around).reshape(-1, 3)
    verts = np.concatenate([(p0 + (length + radius) * z)[None], ring_verts, (p0 - radius * z)[None]])
    faces = _sphere_faces(len(rings), n_segments)
    return verts, faces


def ellipse_perimeter(a: float, b: float) -> float:
    r"""Perimeter (m) of an ellipse of semi-axes ``a, b`` (Ramanujan's second formula,
    :math:`\pi(a+b)(1 + 3h/(10 + \sqrt{4 - 3h}))`, :math:`h = (a-b)^2/(a+b)^2`, relative error < 1e-9
    for the body's axis ratios)."""
    a, b = float(a), float(b)
    h = (a - b) ** 2 / (a + b) ** 2
    return float(np.pi * (a + b) * (1 + 3 * h / (10 + np.sqrt(4 - 3 * h))))


def _count(length: float, spacing: float, minimum: int) -> int:
    return max(minimum, int(np.ceil(length / spacing - 1e-9)))


def _equal_arc_angles(a: float, b: float, start: float, stop: float, spacing: float, minimum: int,
                      max_turn: float | None = None) -> np.ndarray:
    r"""Parameters ``t_0 = start < ... < t_n = stop`` of the curve ``(a cos t, b sin t)`` cutting it into
    ``n >= minimum`` arcs, each at most ``spacing`` (m) long and, with ``max_turn`` (rad), turning its
    normal by at most that much: equal steps of
    :math:`\int\max(|\dot{\mathbf x}|/h,\ \dot\psi/\psi_{max})\,dt` with the speed
    :math:`|\dot{\mathbf x}| = \sqrt{a^2\sin^2t + b^2\cos^2t}` and the normal's turn rate
    :math:`\dot\psi = ab/|\dot{\mathbf x}|^2` (curvature times speed): equal arcs where the curve is
    gentle, steps of :math:`\psi_{max}
ho` where its radius of curvature :math:`
ho` is small (a
    foot's toe)."""
    t = np.linspace(start, stop, 4097)
    speed = np.hypot(a * np.sin(t), b * np.cos(t))
    rate = speed / spacing
    if max_turn is not None:
        rate = np.maximum(rate, a * b / np.maximum(speed, 1e-300) ** 2 / max_turn)
    arc = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])
    n = _count(arc[-1], 1.0, minimum)
    return np.interp(np.linspace(0.0, arc[-1], n + 1), arc, t)


def ellipsoid_grid(radii, max_edge: float, max_turn: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    r"""Ring polar angles ``theta`` and meridian azimuths ``phi`` (rad) of an :func:`ellipsoid` whose
    triangle edges stay below ``max_edge`` (m) and, with ``max_turn`` (rad), whose grid steps turn the
    normal by at most ``max_turn`` along the equator and the sharpest meridian (steps of
    :func:`_equal_arc_angles`).

    Azimuths cut the equator :math:`(a\cos\varphi, b\sin\varphi)` into equal arcs of at most
    :math:`h = e/\sqrt2` (every other ring is the equator scaled by :math:`\sin\vartheta`, its arcs
    shorter); polar angles cut the meridian :math:`(R\sin\vartheta, c\cos\vartheta)`,
    :math:`R = \max(a, b)`, into equal arcs of at most :math:`h`: every meridian moves at most as
    fast in :math:`\vartheta` as this one, so every cell side is at most :math:`h`. Where the
    ellipsoid is not one of revolution its cells are sheared and their diagonal can exceed
    :math:`\sqrt2 h`: :math:`h` is then shrunk until the longest edge of the mesh is at most :math:`e`.
    """
    if not max_edge > 0:
        raise ValueError(f"ellipsoid_grid: max_edge must be > 0 m, got {max_edge!r}")
    a, b, c = (float(r) for r in radii)
    h = max_edge / np.sqrt(2.0)
    for _ in range(8):
        phi = _equal_arc_angles(a, b, 0.0, 2 * np.pi, h, 8, max_turn)[:-1]
        # meridian (R sin th, c cos th) = (c cos th, R sin th) mirrored: speed sqrt(R^2 cos^2 + c^2 sin^2)
        theta = _equal_arc_angles(c, max(a, b), 0.0, np.pi, h, 4, max_turn)[1:-1]
        longest = float(edge_lengths(*ellipsoid((0, 0, 0), (a, b, c), theta=theta, phi=phi)).max())
        if longest <= max_edge:
            break
        h *= 0.99 * max_edge / longest
    return theta, phi


def ellipsoid_divisions(radii, max_edge: float) -> tuple[int, int]:
    """``(n_rings, n_segments)`` of :func:`ellipsoid_grid` (ring intervals pole to pole, meridians)."""
    theta, phi = ellipsoid_grid(radii, max_edge)
    return len(theta) + 1, len(phi)


def capsule_divisions(length: float, radius: float, max_edge: float,
                      max_turn: float | None = None) -> tuple[int, int, int]:
    """``(n_segments, n_cap, n_body)`` of :func:`capsule` whose triangle edges stay below ``max_edge`` (m):
    circumference, quarter-circle cap meridian and cylinder length divided into steps of at most
    ``max_edge / sqrt(2)`` and, with ``max_turn`` (rad), of at most ``max_turn`` of the normal
    (``max_turn * radius`` of arc)."""
    if not max_edge > 0:
        raise ValueError(f"capsule_divisions: max_edge must be > 0 m, got {max_edge!r}")
    h = max_edge / np.sqrt(2.0)
    if max_turn is not None:
        h_arc = min(h, float(max_turn) * radius)
    else:
        h_arc = h
    return (_count(2 * np.pi * radius, h_arc, 8), _count(0.5 * np.pi * radius, h_arc, 2), _count(length, h, 1))


def sagitta(edge: float, curvature_radius: float) -> float:
    r"""Largest distance (m) between a chord of length ``edge`` and its arc of radius ``curvature_radius``:
    :math:`\rho - \sqrt{\rho^2 - e^2/4} \approx e^2/(8\rho)`."""
    return float(curvature_radius - np.sqrt(max(curvature_radius ** 2 - 0.25 * edge ** 2, 0.0)))


def edge_lengths(vertices, faces) -> np.ndarray:
    """Lengths ``[F, 3]`` (m) of every triangle's three edges."""
    tri = np.asarray(vertices, float)[np.asarray(faces)]
    return np.linalg.norm(tri - np.roll(tri, -1, axis=1), axis=-1)


def vertex_normals(vertices, faces) -> np.ndarray:
    """Smooth unit normals ``[V, 3]``: the area-weighted mean of the outward normals of the triangles
    around each vertex (what a renderer interpolates as shading normals; a vertex in no triangle
    gets ``(0, 0, 1)``)."""
    v, f = np.asarray(vertices, float), np.asarray(faces)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    out = np.zeros_like(v)
    for i in range(3):
        np.add.at(out, f[:, i], cross)
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    out = np.divide(out, norm, out=np.zeros_like(out), where=norm > 0)
    out[norm[:, 0] == 0] = (0.0, 0.0, 1.0)
    return out


def ellipsoid_normals(vertices, center, radii, rotation=None) -> np.ndarray:
    r"""Exact unit normals ``[V, 3]`` of the ellipsoid (:func:`ellipsoid`'s ``center``, ``radii``,
    ``rotation``) at ``vertices`` on it: the gradient of :math:`\sum_i (x_i/r_i)^2`,
    :math:`\hat{\mathbf n} \propto \mathbf R\,\mathrm{diag}(r)^{-2}\mathbf R^T(\mathbf x - \mathbf c)`."""
    rot = np.eye(3) if rotation is None else np.asarray(rotation, float)
    local = (np.asarray(vertices, float) - np.asarray(center, float)) @ rot
    n = (local / np.asarray(radii, float) ** 2) @ rot.T
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def capsule_normals(vertices, p0, p1) -> np.ndarray:
    """Exact unit normals ``[V, 3]`` of the capsule (:func:`capsule`) between ``p0`` and ``p1`` at
    ``vertices`` on it: from the nearest point of the axis segment to the vertex (radial on the
    cylinder, from the cap's centre on the caps)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    v = np.asarray(vertices, float)
    axis = p1 - p0
    t = np.clip((v - p0) @ axis / max(float(axis @ axis), 1e-300), 0.0, 1.0)
    n = v - (p0 + t[:, None] * axis)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


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


__all__ = ["BODY_MESH_EDGE", "MAX_NORMAL_TURN", "box", "capsule", "capsule_divisions", "capsule_normals",
           "edge_lengths", "ellipse_perimeter", "ellipsoid", "ellipsoid_divisions", "ellipsoid_grid",
           "ellipsoid_normals", "merge", "plate", "sagitta", "signed_volume", "trihedral", "vertex_normals"]
