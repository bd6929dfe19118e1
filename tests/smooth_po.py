r"""PO on a (refined) mesh the way the engine's render evaluates it, and the meshes of the comparisons.

Shared by ``tests/test_smooth_surface.py`` and ``benchmarks/smooth_surface.py``.

:func:`mesh_po_channels` puts the PO samples where the engine's render puts them: on the flat
facets of the mesh it is given (positions by barycentric interpolation of the corners), with the
interpolated corner normals (:func:`sionnafmcw.physical_optics.interpolated_normals`, Mitsuba's
shading normal), on the facets that face the elements' centroid (what a render from the phase
centre hits on a convex body), and sums them with :func:`sionnafmcw.physical_optics.po_gains`
(point samples, ``in_sample_phase=False``). Unlike the render it samples the facets with a
quadrature (every facet split into :math:`s^2` congruent cells of edge at most ``max_cell``, the
7-point degree-5 Gauss rule in each, as ``tests/po_quadrature.py``), so what it measures is the
*geometry* a mesh gives the PO integral, free of the render's pixel sampling. Applied to the
input mesh it shows today's error; applied to :func:`sionnafmcw.smooth_surface.pn_refine`'s mesh,
what the refinement leaves -- with the samples on its flat sub-facets (``samples="flat"``) or moved
onto the smooth surface at their parameters (``samples="surface"``, :func:`refined_po_channels`).

Meshes: :func:`icosphere` and :func:`cylinder` (24-sided prism with flat caps: radial normals on
the side, axial on the caps, a crease at each rim). The walking body: its segments refined in
their own frames (:func:`refined_segments`, with the normals of the analytic segment shapes,
:func:`analytic_segment_normals`, or the coarse mesh's area-weighted vertex normals), posed and
rendered exactly as ``tests/body_po.py`` does (:func:`body_rcs`), the hits optionally moved onto
the refined smooth surfaces (:func:`refined_surface`) or onto the exact shapes
(:func:`analytic_surface`: the reference body). Radar: ``walk-77ghz``'s element positions with the
radar at :math:`(-d, 0, 0)` looking along +x at the target centred on the origin
(:func:`walk_elements`).
"""

from __future__ import annotations

import numpy as np

from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.physical_optics import SurfaceSamples, interpolated_normals, po_gains
from sionnafmcw.radar import RadarConfig
from sionnafmcw.scenes import meshes
from sionnafmcw.scenes.body import SEGMENTS, segment_shapes
from sionnafmcw.smooth_surface import pn_refine, refinement_level

RADAR = RadarConfig.preset("walk-77ghz")
WAVELENGTH = RADAR.wavelength

# Dunavant degree-5, 7 points: barycentric (l0, l1, l2) and weights (sum 1)
_A1, _B1 = 0.059715871789770, 0.470142064105115
_A2, _B2 = 0.797426985353087, 0.101286507323456
_GAUSS = np.array([[1 / 3, 1 / 3, 1 / 3], [_A1, _B1, _B1], [_B1, _A1, _B1], [_B1, _B1, _A1],
                   [_A2, _B2, _B2], [_B2, _A2, _B2], [_B2, _B2, _A2]])
_WEIGHTS = np.array([0.225] + [0.132394152788506] * 3 + [0.125939180544827] * 3)


def walk_elements(distance: float, height: float = 0.0):
    """World Tx ``[3, 3]`` and Rx ``[4, 3]`` positions of ``walk-77ghz`` at ``(-distance, 0, height)``, yaw 0
    (boresight +x, the array along +y): the radar looks at the origin."""
    pos = np.array([-distance, 0.0, height])
    return RADAR.tx_positions + pos, RADAR.rx_positions + pos


def icosphere(radius: float, subdivisions: int):
    """Icosahedron split ``subdivisions`` times (every triangle into 4, new vertices pushed onto the sphere):
    ``20 * 4**subdivisions`` faces, outward winding, vertices on the sphere of ``radius`` about the origin."""
    t = (1 + 5 ** 0.5) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        mid = v[uniq[:, 0]] + v[uniq[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(v) + inv.reshape(3, -1).T                           # [F, 3]: mid of edges 01, 12, 20
        f = np.concatenate([np.stack([f[:, 0], m[:, 0], m[:, 2]], 1), np.stack([f[:, 1], m[:, 1], m[:, 0]], 1),
                            np.stack([f[:, 2], m[:, 2], m[:, 1]], 1), m])
        v = np.concatenate([v, mid])
    return v * radius, f


def cylinder(radius: float, length: float, n_sides: int = 24):
    """Closed ``n_sides`` prism along z centred on the origin, vertices on the cylinder: one ring of side quads
    (two triangles each, the full length) and a triangle fan on each cap about its centre. Returns
    ``(vertices, faces, corner_normals)`` with the exact normals: radial on the side, +-z on the caps
    (a crease at each rim)."""
    phi = np.arange(n_sides) * 2 * np.pi / n_sides
    ring = np.stack([radius * np.cos(phi), radius * np.sin(phi), np.zeros(n_sides)], -1)
    bottom, top = ring - [0, 0, length / 2], ring + [0, 0, length / 2]
    v = np.concatenate([bottom, top, [[0, 0, -length / 2], [0, 0, length / 2]]])
    j = np.arange(n_sides)
    jn = (j + 1) % n_sides
    side = np.concatenate([np.stack([j, jn, n_sides + jn], 1), np.stack([j, n_sides + jn, n_sides + j], 1)])
    c_bot, c_top = 2 * n_sides, 2 * n_sides + 1
    cap_bot = np.stack([np.full(n_sides, c_bot), jn, j], 1)
    cap_top = np.stack([np.full(n_sides, c_top), n_sides + j, n_sides + jn], 1)
    f = np.concatenate([side, cap_bot, cap_top]).astype(np.int64)
    radial = v.copy()
    radial[:, 2] = 0
    radial = radial / np.maximum(np.linalg.norm(radial, axis=1, keepdims=True), 1e-300)
    normals = np.concatenate([radial[side], np.tile([0.0, 0.0, -1.0], (n_sides, 3, 1)),
                              np.tile([0.0, 0.0, 1.0], (n_sides, 3, 1))])
    return v, f, normals


def _cells(s: int) -> np.ndarray:
    """Barycentric (b1, b2) corners ``[s^2, 3, 2]`` of the s^2 congruent cells of a triangle."""
    out = []
    for i in range(s):
        for j in range(s - i):
            out.append([[i, j], [i + 1, j], [i, j + 1]])
            if j < s - i - 1:
                out.append([[i + 1, j], [i + 1, j + 1], [i, j + 1]])
    return np.array(out, float) / s


def facet_quadrature(vertices, faces, max_cell: float):
    """Gauss points of every facet: ``(facet [Q], barycentric [Q, 2], area weight [Q])``."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces)
    tri = v[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    splits = np.maximum(1, np.ceil(longest / max_cell)).astype(int)
    facet, bary, weight = [], [], []
    for s in np.unique(splits):
        sel = np.flatnonzero((splits == s) & (area > 0))
        if sel.size == 0:
            continue
        cells = _cells(s)                                              # [C, 3, 2]
        local = np.einsum("gk,ckb->cgb", _GAUSS, cells).reshape(-1, 2)   # [C*7, 2]
        w = np.tile(_WEIGHTS, len(cells)) / len(cells)
        facet.append(np.repeat(sel, len(local)))
        bary.append(np.tile(local, (sel.size, 1)))
        weight.append((area[sel, None] * w[None]).ravel())
    return np.concatenate(facet), np.concatenate(bary), np.concatenate(weight)


def mesh_po_channels(vertices, faces, corner_normals, tx, rx, wavelength: float = WAVELENGTH,
                     reflection: float = -1.0, max_cell: float | None = None, chunk: int = 200_000) -> np.ndarray:
    """``[M, N]`` PO channels of a mesh with shading normals, samples on its flat facets (module docstring).

    ``corner_normals [F, 3, 3]``; facets are kept when their (winding) normal faces the elements'
    centroid; ``max_cell`` (default lambda / 4) is the quadrature cell edge.
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces)
    tx, rx = np.atleast_2d(tx), np.atleast_2d(rx)
    centre = np.concatenate([tx, rx]).mean(axis=0)
    tri = v[f]
    facet_normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    facing = np.einsum("fi,fi->f", facet_normal, centre - tri.mean(axis=1)) > 0
    keep = np.flatnonzero(facing)
    facet, bary, weight = facet_quadrature(v, f[keep], wavelength / 4 if max_cell is None else max_cell)
    facet = keep[facet]
    h = np.zeros((len(tx), len(rx)), complex)
    frequency = SPEED_OF_LIGHT / wavelength
    for start in range(0, len(facet), chunk):
        sl = slice(start, start + chunk)
        corners = tri[facet[sl]]
        b = bary[sl]
        position = (corners[:, 0] + b[:, :1] * (corners[:, 1] - corners[:, 0])
                    + b[:, 1:] * (corners[:, 2] - corners[:, 0]))
        normal, _ = interpolated_normals(corners, np.asarray(corner_normals, float)[facet[sl]], b)
        samples = SurfaceSamples(position, normal, weight[sl], reflection=reflection)
        a, tau, _ = po_gains(samples, tx, rx, wavelength, in_sample_phase=False)
        h += np.einsum("mnp,mnp->mn", a, np.exp(-2j * np.pi * frequency * tau))
    return h


def refined_po_channels(refined, tx, rx, wavelength: float = WAVELENGTH, samples: str = "flat",
                        reflection: float = -1.0, max_cell: float | None = None, chunk: int = 200_000) -> np.ndarray:
    """``[M, N]`` PO channels of a :class:`~sionnafmcw.smooth_surface.RefinedSurface`: ``samples="flat"``, on its
    flat sub-facets with interpolated corner normals (:func:`mesh_po_channels`); ``"surface"``, the same
    quadrature points moved onto the smooth surface at their parameters, with its PN normals
    (:meth:`~sionnafmcw.smooth_surface.RefinedSurface.smooth_points`), area weights of the sub-facets."""
    if samples == "flat":
        return mesh_po_channels(refined.vertices, refined.faces, refined.corner_normals, tx, rx, wavelength,
                                reflection, max_cell, chunk)
    if samples != "surface":
        raise ValueError(f"refined_po_channels: samples must be 'flat' or 'surface', got {samples!r}")
    tx, rx = np.atleast_2d(tx), np.atleast_2d(rx)
    centre = np.concatenate([tx, rx]).mean(axis=0)
    tri = refined.vertices[refined.faces]
    facet_normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    keep = np.flatnonzero(np.einsum("fi,fi->f", facet_normal, centre - tri.mean(axis=1)) > 0)
    facet, bary, weight = facet_quadrature(refined.vertices, refined.faces[keep],
                                           wavelength / 4 if max_cell is None else max_cell)
    facet = keep[facet]
    h = np.zeros((len(tx), len(rx)), complex)
    frequency = SPEED_OF_LIGHT / wavelength
    for start in range(0, len(facet), chunk):
        sl = slice(start, start + chunk)
        position, normal = refined.smooth_points(facet[sl], bary[sl])
        a, tau, _ = po_gains(SurfaceSamples(position, normal, weight[sl], reflection=reflection), tx, rx,
                             wavelength, in_sample_phase=False)
        h += np.einsum("mnp,mnp->mn", a, np.exp(-2j * np.pi * frequency * tau))
    return h


def db_error(h, reference) -> tuple[np.ndarray, float]:
    """Per-pair :math:`10\\lg(|h|^2/|h_{ref}|^2)` ``[M, N]`` and the same of the coherent sum over all pairs (dB)."""
    per_pair = 10 * np.log10(np.abs(h) ** 2 / np.abs(reference) ** 2)
    total = 10 * np.log10(np.abs(np.sum(h)) ** 2 / np.abs(np.sum(reference)) ** 2)
    return per_pair, float(total)


# ---------------------------------------------------------------------------------------- the walker
def analytic_segment_normals(shape, vertices) -> np.ndarray:
    """Exact outward unit normals ``[V, 3]`` at points on a segment shape of
    :func:`sionnafmcw.scenes.body.segment_shapes` (ellipsoid: the gradient
    :math:`(\\mathbf x - \\mathbf c)/\\mathbf r^2`; capsule: from the nearest point of its axis)."""
    x = np.asarray(vertices, float)
    if shape[0] == "ellipsoid":
        g = (x - np.asarray(shape[1], float)) / np.asarray(shape[2], float) ** 2
    else:
        p0, p1 = np.asarray(shape[1], float), np.asarray(shape[2], float)
        axis = p1 - p0
        t = np.clip((x - p0) @ axis / (axis @ axis), 0.0, 1.0)
        g = x - (p0 + t[:, None] * axis)
    return g / np.linalg.norm(g, axis=1, keepdims=True)


def refined_segments(person, normals: str = "analytic", wavelength: float = WAVELENGTH, level: int | None = None):
    """``{segment: RefinedSurface}`` of ``person``'s local meshes refined in their own frames at
    :func:`~sionnafmcw.smooth_surface.refinement_level` (or ``level``), corner normals from the analytic
    shapes (``normals="analytic"``) or the coarse mesh's vertex normals (``"mesh"``)."""
    shapes = segment_shapes(person.body)
    out = {}
    for name in SEGMENTS:
        v, f = person.local_meshes[name]
        if normals == "analytic":
            vn = analytic_segment_normals(shapes[name], v)
        elif normals == "mesh":
            vn = meshes.vertex_normals(v, f)
        else:
            raise ValueError(f"refined_segments: normals must be 'analytic' or 'mesh', got {normals!r}")
        n = level if level is not None else refinement_level(v, f, vn[f], wavelength)
        out[name] = pn_refine(v, f, vn[f], n)
    return out


def _turn(aspect_deg: float) -> np.ndarray:
    """``body_po.body_look``'s turn of the body frame: the radar at ``aspect_deg`` goes to -x."""
    a = np.radians(aspect_deg) + np.pi
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def project_to_shape(shape, points) -> tuple[np.ndarray, np.ndarray]:
    """Points ``[K, 3]`` near a segment shape moved onto it (ellipsoid: scaled from its centre; capsule: from
    the nearest point of its axis) and the exact normals there (:func:`analytic_segment_normals`)."""
    x = np.asarray(points, float)
    if shape[0] == "ellipsoid":
        c, radii = np.asarray(shape[1], float), np.asarray(shape[2], float)
        rel = x - c
        p = c + rel / np.linalg.norm(rel / radii, axis=1, keepdims=True)
    else:
        p0, p1, radius = np.asarray(shape[1], float), np.asarray(shape[2], float), float(shape[3])
        axis = p1 - p0
        t = np.clip((x - p0) @ axis / (axis @ axis), 0.0, 1.0)
        q = p0 + t[:, None] * axis
        p = q + radius * (x - q) / np.linalg.norm(x - q, axis=1, keepdims=True)
    return p, analytic_segment_normals(shape, p)


def body_rcs(person, segments: dict, phase: float, aspect_deg: float, distance: float, surface=None,
             step: float | None = None, radar_height: float = 1.0, return_samples: bool = False):
    """``body_po.BodyRCS`` of ``person`` at gait ``phase`` built from ``segments`` (``{segment: (vertices,
    faces, vertex_normals)}`` in the segments' own frames), posed, seen and rendered exactly as
    ``body_po.body_rcs`` does (radar at ``distance``, ``aspect_deg``, ``radar_height``; pixel ``step``,
    default ``body_po.pixel_step``; skin). ``surface``: None puts the samples on the flat facets the rays
    hit (``body_po``'s render); else a callable ``surface(segment, triangle, barycentric, points)`` (local
    frame; ``points`` the flat hits) returning the samples' points and unit normals on a smooth surface,
    where the area, footprint and PO are then taken (the shape operator stays that of the facet's
    interpolated normals). ``return_samples``: also the samples and the segment index of each (into
    ``SEGMENTS``)."""
    import body_po as bp
    import mesh_render
    from sionnafmcw.diffuse import lambertian_gains
    from sionnafmcw.physical_optics import angular_grid_steps, footprint_edges, monostatic_rcs

    poses = person.local_poses(phase)
    lift = np.array([0.0, 0.0, person.hip_height + float(person.gait.vertical(phase))])
    turn = _turn(aspect_deg)
    vs, fs, ns, start, off = [], [], [], [0], 0
    for k in SEGMENTS:
        r, o = poses[k]
        v, f, n = segments[k]
        vs.append((v @ r.T + o + lift) @ turn.T)
        ns.append(n @ r.T @ turn.T)
        fs.append(f + off)
        off += len(v)
        start.append(start[-1] + len(f))
    v, f, n = np.concatenate(vs), np.concatenate(fs), np.concatenate(ns)
    radar = np.array([-distance, 0.0, radar_height])
    step = bp.pixel_step(person, distance) if step is None else step
    rel = v - radar
    az = np.arctan2(rel[:, 1], rel[:, 0])
    el = np.arctan2(rel[:, 2], np.hypot(rel[:, 0], rel[:, 1]))
    az_grid = np.arange(az.min() - 2 * step, az.max() + 2 * step, step)
    el_grid = np.arange(el.min() - 2 * step, el.max() + 2 * step, step)
    elg, azg = np.meshgrid(el_grid, az_grid, indexing="ij")
    hit, t, tri, bary, d = bp.cast_chunked(v, f, radar, azg, elg)
    tri, bary, dirs, t = tri[hit], bary[hit], d[hit], t[hit]
    normal, curvature = interpolated_normals(v[f[tri]], n[f[tri]], bary)
    position = radar + t[:, None] * dirs
    if surface is not None:
        for i, k in enumerate(SEGMENTS):
            sel = np.flatnonzero((tri >= start[i]) & (tri < start[i + 1]))
            if sel.size:
                r, o = poses[k]
                local = (position[sel] @ turn - o - lift) @ r
                p_loc, n_loc = surface(k, tri[sel] - start[i], bary[sel], local)
                position[sel] = (p_loc @ r.T + o + lift) @ turn.T
                normal[sel] = n_loc @ r.T @ turn.T
    rng = np.linalg.norm(position - radar, axis=1)
    cos = np.abs(np.einsum("pi,pi->p", normal, (position - radar) / rng[:, None]))
    solid = mesh_render.solid_angles(elg.ravel()[hit], step)
    area = np.divide(rng ** 2 * solid, cos, out=np.zeros_like(rng), where=cos > 1e-6)
    step_az, step_el = angular_grid_steps(dirs, step, step)
    s = SurfaceSamples(position, normal, area, edges=footprint_edges(position, normal, radar, step_az, step_el),
                       reflection=bp.skin_reflection(),
                       scattering_coefficient=bp.scattering_coefficient(bp.SKIN_RMS_ROUGHNESS),
                       triangle=tri, barycentric=bary, curvature=curvature)
    reference = np.array([0.0, 0.0, radar_height])
    po = monostatic_rcs(s, radar, bp.WAVELENGTH, reference)
    amp, _, _ = lambertian_gains(s, radar[None], radar[None], bp.WAVELENGTH)
    diffuse = float((4 * np.pi) ** 3 * np.linalg.norm(radar - reference) ** 4 * np.sum(amp ** 2) / bp.WAVELENGTH ** 2)
    out = bp.BodyRCS(po, diffuse, s.num_samples, step)
    if return_samples:
        return out, s, np.searchsorted(np.asarray(start), tri, side="right") - 1, radar
    return out


def coarse_segments(person) -> dict:
    """``{segment: (vertices, faces, vertex_normals)}`` of ``person``'s own meshes (what ``body_po`` renders)."""
    return {k: (*person.local_meshes[k], person.local_normals[k]) for k in SEGMENTS}


def refined_segment_meshes(refined: dict) -> dict:
    """``{segment: (vertices, faces, vertex_normals)}`` of :func:`refined_segments` (no creases on the body)."""
    out = {}
    for k, s in refined.items():
        if np.any(s.crease):
            raise ValueError(f"refined_segment_meshes: segment {k} has creases; per-vertex normals cannot carry them")
        out[k] = (s.vertices, s.faces, s.normals)
    return out


def refined_surface(refined: dict):
    """``surface`` callable of :func:`body_rcs`: the hits moved onto the refined segments' smooth surfaces."""
    return lambda k, tri, bary, points: refined[k].smooth_points(tri, bary)


def analytic_surface(person):
    """``surface`` callable of :func:`body_rcs`: the hits moved onto the exact segment shapes."""
    shapes = segment_shapes(person.body)
    return lambda k, tri, bary, points: project_to_shape(shapes[k], points)
