r"""A render from the radar in numpy, for the physical-optics tests and benchmark.

What the pixel engine does with Mitsuba's ``ray_intersect_preliminary`` (first hit per pixel:
distance, triangle, barycentrics), done here with the Moeller-Trumbore test on an equiangular
azimuth/elevation grid around a direction, so the tests need no scene files. Each triangle is
tested only against the pixels inside its angular bounding box (padded by one pixel).
"""

from __future__ import annotations

import numpy as np

from sionnafmcw.physical_optics import angular_grid_steps, interpolated_normals, render_samples


def grid(centre_az, centre_el, half_width, step):
    """Equiangular pixel centres covering ``centre +- half_width`` (rad) with ``step``: az, el ``[n_el, n_az]``."""
    n = int(np.ceil(2 * half_width / step))
    offs = (np.arange(n) - (n - 1) / 2) * step
    el, az = np.meshgrid(centre_el + offs, centre_az + offs, indexing="ij")
    return az, el, step


def cast(vertices, faces, origin, az, el):
    """First hits of the rays through ``az, el`` (``[n_el, n_az]`` equiangular, radar frame = world) from ``origin``.

    Returns ``hit [K] bool, t [K], triangle [K], barycentric [K, 2]``.
    """
    v = np.asarray(vertices, float) - np.asarray(origin, float)
    f = np.asarray(faces)
    n_el, n_az = az.shape
    step_az = (az[0, -1] - az[0, 0]) / max(n_az - 1, 1) if n_az > 1 else 1.0
    step_el = (el[-1, 0] - el[0, 0]) / max(n_el - 1, 1) if n_el > 1 else 1.0
    az, el = az.ravel(), el.ravel()
    k = az.size
    d = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], -1)
    az0, el0 = az.min(), el.min()
    # pixel index = i_el * n_az + i_az (az varies fastest, as in grid())
    tri = v[f]                                                   # [F, 3, 3]
    t_az = np.arctan2(tri[..., 1], tri[..., 0])
    t_el = np.arctan2(tri[..., 2], np.hypot(tri[..., 0], tri[..., 1]))
    lo_a = np.clip(np.floor((t_az.min(1) - az0) / step_az) - 1, 0, n_az - 1).astype(int)
    hi_a = np.clip(np.ceil((t_az.max(1) - az0) / step_az) + 1, 0, n_az - 1).astype(int)
    lo_e = np.clip(np.floor((t_el.min(1) - el0) / step_el) - 1, 0, n_el - 1).astype(int)
    hi_e = np.clip(np.ceil((t_el.max(1) - el0) / step_el) + 1, 0, n_el - 1).astype(int)
    front = np.all(tri @ d.mean(axis=0) > 0, axis=1)   # in front of the radar
    na, ne = hi_a - lo_a + 1, hi_e - lo_e + 1
    count = np.where(front, na * ne, 0)
    tri_idx = np.repeat(np.arange(len(f)), count)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    ia = lo_a[tri_idx] + local % na[tri_idx]
    ie = lo_e[tri_idx] + local // na[tri_idx]
    pix = ie * n_az + ia
    # Moeller-Trumbore
    p0, p1, p2 = tri[tri_idx, 0], tri[tri_idx, 1], tri[tri_idx, 2]
    e1, e2 = p1 - p0, p2 - p0
    dd = d[pix]
    pv = np.cross(dd, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-18
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = -p0
    b1 = np.einsum("ij,ij->i", tv, pv) * inv
    qv = np.cross(tv, e1)
    b2 = np.einsum("ij,ij->i", dd, qv) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    good = ok & (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1) & (t > 0)
    t_best = np.full(k, np.inf)
    np.minimum.at(t_best, pix[good], t[good])
    winner = good & (t == t_best[pix])
    hit = np.isfinite(t_best)
    triangle = np.full(k, -1)
    bary = np.zeros((k, 2))
    triangle[pix[winner]] = tri_idx[winner]
    bary[pix[winner]] = np.stack([b1[winner], b2[winner]], -1)
    return hit, t_best, triangle, bary, d


def solid_angles(el, step):
    """Exact solid angle of each equiangular pixel (sr)."""
    return step * (np.sin(el + step / 2) - np.sin(el - step / 2))


def vertex_normals(vertices, faces):
    """Area-weighted vertex normals ``[V, 3]`` (what a mesh exporter writes for a smooth surface)."""
    v, f = np.asarray(vertices, float), np.asarray(faces)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    out = np.zeros_like(v)
    for i in range(3):
        np.add.at(out, f[:, i], cross)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def render(vertices, faces, origin, target, half_width, step, smooth_normals=False, **fields):
    """:class:`SurfaceSamples` of the mesh seen from ``origin`` on a grid of ``step`` (rad) around ``target``.

    ``fields`` (per-triangle arrays ``[F]`` or per-mesh scalars) go to the samples: ``velocity``,
    ``reflection``, ``scattering_coefficient``, ``object_id``. ``smooth_normals``: the
    barycentric interpolation of :func:`vertex_normals` (Mitsuba's shading normal) instead of the
    facet normal, with its shape operator (``curvature``, :func:`~sionnafmcw.physical_optics.interpolated_normals`).
    """
    origin = np.asarray(origin, float)
    dirn = np.asarray(target, float) - origin
    az0 = np.arctan2(dirn[1], dirn[0])
    el0 = np.arctan2(dirn[2], np.hypot(dirn[0], dirn[1]))
    az, el, step = grid(az0, el0, half_width, step)
    hit, t, tri, bary, d = cast(vertices, faces, origin, az, el)
    v = np.asarray(vertices, float)
    f = np.asarray(faces)[tri[hit]]
    normal = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    if smooth_normals:
        vn = vertex_normals(v, faces)
        normal, curvature = interpolated_normals(v[f], vn[f], bary[hit])
    dirs = d[hit]
    step_az, step_el = angular_grid_steps(dirs, step, step)
    extra = {}
    for name, value in fields.items():
        value = np.asarray(value)
        extra[name] = value[tri[hit]] if value.ndim >= 1 and value.shape[0] == len(faces) else value
    if smooth_normals:
        extra["curvature"] = curvature
    return render_samples(origin, dirs, t[hit], normal, solid_angles(el.ravel()[hit], step), step_az, step_el,
                          triangle=tri[hit], barycentric=bary[hit], **extra)
