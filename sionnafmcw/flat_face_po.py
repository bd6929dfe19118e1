r"""The PO echo of flat faces, exact: each chain's lit, visible aperture integrated in closed form.

A corner reflector seen off its axis has no specular point on any face: each face's physical-optics
integral is its outline's edge terms (:mod:`sionnafmcw.polygon_integral`), which a point sampling of
the face resolves only as finely as its samples resolve the outline. This module computes the echo of
flat faces without sampling any outline: the faces are clipped exactly to the part the radar lights
and sees (the first bounce) and to the exit aperture of every chain of reflections (the later bounces,
the engine's geometric-optics chains with PO on the last face), and each part is integrated with the
exact linear-phase integral. It is the reference the engine's echo of corner reflectors is measured
against (``benchmarks/po_flat_faces.py``): on its axis a trihedral's triple bounce comes out at
:math:`4\pi a^4/(3\lambda^2)` and a dihedral's double bounce at :math:`8\pi a^4/\lambda^2` in the far field
(``tests/test_flat_face_po.py``).

The lit, visible part
---------------------
Monostatic, the radar at :math:`\mathbf o` lights a point :math:`\mathbf p` of a face exactly when it
sees it: when the segment :math:`\mathbf o\mathbf p` crosses no other face first. Faces are two-sided (a
metal plate reflects on both sides, as the engine's renders do). Face :math:`B` hides from face
:math:`A` the part of :math:`A` inside the cone from :math:`\mathbf o` through :math:`B'`, the part of
:math:`B` strictly between :math:`\mathbf o` and :math:`A`'s plane (:math:`B` clipped to the slab between
the plane and the plane through :math:`\mathbf o` parallel to it); for a convex :math:`B'` that cone is
the intersection of the half-spaces :math:`\mathbf m_i\cdot(\mathbf x - \mathbf o) \ge 0` bounded by the
planes through :math:`\mathbf o` and :math:`B'`'s edges. A convex polygon minus a convex cone is the
union of the disjoint convex pieces :math:`P\cap\{\mathbf m_i\cdot(\mathbf x - \mathbf o) < 0\}\cap
\bigcap_{l<i}\{\mathbf m_l\cdot(\mathbf x - \mathbf o)\ge 0\}`, so every face's visible part is a list of
convex polygons obtained by half-space clips alone (:func:`visible_parts`; Sutherland--Hodgman on one
plane at a time, :func:`clip_half_space`). The projection is central, from the radar's point: exact
for a point radar at any range, not only in the far field.

The echo
--------
The channel of an isotropic element at :math:`\mathbf o` (transmitting and receiving; the engine's
:func:`~sionnafmcw.engines.bounce_sampling.monostatic_channels` for bounce 1) is the PO integral of
:mod:`sionnafmcw.physical_optics` with :math:`r_t = r_r = r = \|\mathbf p - \mathbf o\|`:

.. math::
    h = \frac{j\Gamma}{4\pi}\int_{A_{vis}} \frac{\cos\theta(\mathbf p)}{r^2}\,e^{-j2kr}\,dA,
    \qquad \cos\theta = |\hat{\mathbf n}\cdot\hat{\mathbf s}|,\ \hat{\mathbf s} = (\mathbf p - \mathbf o)/r.

*Far field* (:func:`monostatic_channel` with ``far_field=True``): about a reference point
:math:`\mathbf p_0` at range :math:`R_0` along :math:`\hat{\mathbf s}_0`, :math:`r \approx R_0 +
\hat{\mathbf s}_0\cdot(\mathbf p - \mathbf p_0)` in the phase and :math:`r = R_0` in the amplitude, so
:math:`h = \frac{j\Gamma}{4\pi R_0^2}e^{-j2kR_0}\sum_{parts}\cos\theta\,I_{part - \mathbf p_0}(-2k\hat{\mathbf s}_0)`
with :math:`I_{part - \mathbf p_0}` the exact integral over the part shifted by :math:`-\mathbf p_0`. Its neglected phase,
:math:`k\rho^2/R_0` across a target of radius :math:`\rho` (1.3 rad for a 0.1 m trihedral at 3 m at
77 GHz), is not small at the ranges a radar sees corner reflectors.

*Near field* (the default): each visible part is fanned into triangles and the triangles split at their
edges' midpoints until no edge exceeds ``max_edge``; on each small triangle :math:`T` about its centroid
:math:`\mathbf c` the phase is taken to first order, :math:`r \approx r_c + \hat{\mathbf s}_c\cdot
(\mathbf p - \mathbf c)`, and the triangle is integrated exactly in that phase with the amplitude at
:math:`\mathbf c`:

.. math:: h \approx \frac{j\Gamma}{4\pi}\sum_T \frac{\cos\theta_c}{r_c^2}e^{-j2kr_c}\,
    I_{T - \mathbf c}(-2k\hat{\mathbf s}_c).

The outline is exact (the triangles tile the visible part); only the phase's second-order remainder
:math:`q = k(|\mathbf x|^2 - (\hat{\mathbf s}_c\cdot\mathbf x)^2)/r_c \le k\ell^2/r_c` across a triangle of
edges :math:`\le\ell` is dropped, and its mean over each triangle is put back
(:math:`e^{-j\mu_T}`, :math:`\mu_T = k\,\operatorname{tr}[(\mathbf I - \hat{\mathbf s}_c\hat{\mathbf s}_c^T)\mathbf C_T]/r_c`,
:math:`\mathbf C_T` the triangle's second moment about its centroid), so that inside a triangle what is
left is second order in :math:`q`. Along the seams between triangles the two neighbours' phases still
differ by up to :math:`q`: a first-order error that, where the echo is a small residue of cancelling
edge terms (a trihedral 15-45 degrees off its axis: 60-70 dB below the sum of the magnitudes), is
what sets the triangles' size. The default ``max_edge`` :math:`= \sqrt{Q r_{min}/k}`,
:data:`NEAR_FIELD_PHASE` :math:`Q = 10^{-3}` rad (1.4 mm at 3 m at 77 GHz), was found by halving:
a 0.1 m trihedral at 3 m, 0-45 degrees off its axis, moves by up to 0.05 dB from 6 to 1.5 mm and by
< 0.002 dB from 1.5 to 0.5 mm (``tests/test_flat_face_po.py`` holds the default to 0.01 dB of half
of it); a 0.1 m plate at 2 m agrees with a converged Gauss-Legendre quadrature of the exact
integrand to 3e-5 of :math:`|h|` at 0-25 degrees (the test allows :math:`Q`, the seams' first-order mismatch).

Chains of reflections
---------------------
From the second bounce on the engine follows rays (geometric optics) and puts the PO current on the
last face, lit by the image source (:mod:`~sionnafmcw.engines.po_render`). The same model, with exact
outlines (:func:`chain_apertures`): a chain ending on face :math:`a` with image source :math:`\mathbf s`
lights the aperture :math:`W` of :math:`a`; after reflection its rays leave :math:`W` from
:math:`\mathbf s' = M_a(\mathbf s)`, so on the next face :math:`b` they reach the part inside the cone
from :math:`\mathbf s'` through :math:`W`, seen past the other faces, on the reflected side of
:math:`a`'s plane. Every such part is again a union of convex polygons cut by half-spaces. Its echo
(:func:`chain_channels`) is the near-field integral above with the two-way length
:math:`r_s + r_r` (from the image, back to the radar), the obliquity :math:`\hat{\mathbf n}\cdot
(\hat{\mathbf u}_s + \hat{\mathbf u}_r)/2` and :math:`\Gamma^d`; the second-order mean per triangle is
:math:`\mu_T = \frac k2\sum_{i = s, r}\operatorname{tr}[(\mathbf I - \hat{\mathbf s}_i\hat{\mathbf s}_i^T)
\mathbf C_T]/r_i`. As in the engine, the return from the last face to the radar is not tested for
blocking.
"""

from __future__ import annotations

import numpy as np

from .polygon_integral import cross, polygon_normals, polygon_phase_integral

#: Second-order phase remainder (rad) across a near-field triangle at the default ``max_edge`` (module docstring).
NEAR_FIELD_PHASE = 1e-3
#: A point lies on a plane when its signed distance is below this share of the polygon's size (m/m).
PLANE_TOLERANCE = 1e-9


class FlatFaceError(ValueError):
    """Faces or a radar point that the flat-face PO cannot use; the message names the parameter."""


def clip_half_space(polygon, normal, point) -> np.ndarray:
    r"""The convex ``polygon [V, 3]`` clipped to the closed half-space :math:`\mathbf m\cdot(\mathbf x -
    \mathbf q) \ge 0` (``normal`` :math:`\mathbf m`, ``point`` :math:`\mathbf q`): Sutherland--Hodgman on
    one plane. ``[V', 3]``, ``V' = 0`` when nothing is left."""
    poly = np.asarray(polygon, float)
    if len(poly) == 0:
        return poly
    d = (poly - point) @ normal
    spread = poly - poly.mean(axis=0)
    size = float(np.sqrt(np.max(np.sum(spread * spread, axis=1)) * (normal @ normal)))
    d = np.where(np.abs(d) <= PLANE_TOLERANCE * size, 0.0, d)
    if np.all(d >= 0):
        return poly
    if np.all(d <= 0):
        return poly[:0]
    out = []
    n = len(poly)
    for i in range(n):
        j = (i + 1) % n
        if d[i] >= 0:
            out.append(poly[i])
        if (d[i] > 0 and d[j] < 0) or (d[i] < 0 and d[j] > 0):
            t = d[i] / (d[i] - d[j])
            out.append(poly[i] + t * (poly[j] - poly[i]))
    return np.array(out) if len(out) >= 3 else poly[:0]


def _cone_planes(source, polygon):
    r"""The inward normals of the planes through ``source`` and the convex ``polygon``'s edges (None when the
    polygon is seen edge-on from ``source``): the cone from ``source`` through it is where all
    :math:`\mathbf m_i\cdot(\mathbf x - \mathbf s) \ge 0`."""
    centre = polygon.mean(axis=0)
    planes = []
    for i in range(len(polygon)):
        m = cross(polygon[i] - source, polygon[(i + 1) % len(polygon)] - source)
        if not np.any(m):
            return None
        planes.append(m if m @ (centre - source) >= 0 else -m)
    return planes


def _minus_cone(pieces, source, occluder):
    """The convex ``pieces`` minus the cone from ``source`` through the convex polygon ``occluder``."""
    planes = _cone_planes(source, occluder)
    if planes is None:
        return pieces
    out = []
    for piece in pieces:
        rest = piece
        for m in planes:
            outside = clip_half_space(rest, -m, source)
            if len(outside):
                out.append(outside)
            rest = clip_half_space(rest, m, source)
            if len(rest) == 0:
                break
    return out


def _within_cone(pieces, source, window):
    """The convex ``pieces`` inside the cone from ``source`` through the convex polygon ``window``."""
    planes = _cone_planes(source, window)
    if planes is None:
        return []
    out = []
    for piece in pieces:
        for m in planes:
            piece = clip_half_space(piece, m, source)
            if len(piece) == 0:
                break
        if len(piece):
            out.append(piece)
    return out


def _seen_from(target, source, occluders, scale: float) -> list:
    """The convex pieces of the convex polygon ``target`` that ``source`` sees past the convex ``occluders``
    (each hides the cone through its part between ``source`` and ``target``'s plane); ``[]`` edge-on."""
    normal, area = polygon_normals(target)
    if area <= PLANE_TOLERANCE * scale ** 2:
        return []
    side = normal @ (source - target[0])
    if abs(side) <= PLANE_TOLERANCE * scale:
        return []                                           # edge-on: no lit area
    towards = normal * np.sign(side)
    pieces = [target]
    for occluder in occluders:
        if not pieces:
            break
        between = clip_half_space(occluder, towards, target[0])
        between = clip_half_space(between, -towards, source)
        if len(between) < 3 or polygon_normals(between)[1] <= PLANE_TOLERANCE * scale ** 2:
            continue
        pieces = _minus_cone(pieces, source, between)
    return [p for p in pieces if polygon_normals(p)[1] > PLANE_TOLERANCE * scale ** 2]


def _faces(faces, name: str) -> np.ndarray:
    faces = np.asarray(faces, float)
    if faces.ndim != 3 or faces.shape[-1] != 3 or faces.shape[1] < 3 or not np.all(np.isfinite(faces)):
        raise FlatFaceError(f"{name}: faces must have shape [F, V >= 3, 3] and be finite, got {faces.shape}")
    return faces


def visible_parts(faces, origin) -> list:
    r"""Per face of ``faces [F, V, 3]`` (flat convex polygons, m), the list of convex polygons ``[V', 3]``
    that the radar at ``origin`` lights and sees (module docstring): faces seen edge-on give nothing;
    every other face hides the part of it inside the cone from ``origin`` through its own part between
    ``origin`` and the face's plane."""
    faces = _faces(faces, "visible_parts")
    o = np.asarray(origin, float).reshape(3)
    scale = float(np.max(np.linalg.norm(faces - faces.mean(axis=(0, 1)), axis=-1)))
    return [_seen_from(faces[a], o, [faces[b] for b in range(len(faces)) if b != a], scale)
            for a in range(len(faces))]


def mirror_point(point, face) -> np.ndarray:
    r""":math:`M(\mathbf x) = \mathbf x - 2\hat{\mathbf n}(\hat{\mathbf n}\cdot(\mathbf x - \mathbf v_0))`: the mirror
    image of ``point`` in the plane of the polygon ``face``."""
    normal = polygon_normals(face)[0]
    return point - 2 * normal * (normal @ (point - face[0]))


def chain_apertures(faces, origin, depth: int) -> list:
    r"""The exit apertures of every chain of up to ``depth`` reflections on ``faces [F, V, 3]`` (flat convex
    polygons, m) seen from ``origin``: a list of ``(chain, source, pieces)``, ``chain`` the tuple of face
    indices, ``source`` the image of ``origin`` that lights the last face (``origin`` itself for one bounce),
    ``pieces`` the convex polygons of the last face that the chain's rays reach.

    Bounce 1 is :func:`visible_parts`. A chain ending on face :math:`a` with image source
    :math:`\mathbf s` and aperture :math:`W` continues to face :math:`b \ne a`: after the reflection the
    rays leave :math:`W` from the image :math:`\mathbf s' = M_a(\mathbf s)` into the half-space of
    :math:`a`'s plane where :math:`\mathbf s` lies, so the aperture on :math:`b` is the part of :math:`b`
    in that half-space which :math:`\mathbf s'` sees past the other faces (clipped to that half-space
    too) and which lies inside the cone from :math:`\mathbf s'` through :math:`W` (its rays crossed
    :math:`a`'s plane inside :math:`W`): the geometric optics of the engine's chains
    (:func:`~sionnafmcw.engines.po_render.reflect`), with every outline exact."""
    faces = _faces(faces, "chain_apertures")
    if int(depth) < 1:
        raise FlatFaceError(f"chain_apertures: depth must be >= 1, got {depth}")
    o = np.asarray(origin, float).reshape(3)
    scale = float(np.max(np.linalg.norm(faces - faces.mean(axis=(0, 1)), axis=-1)))
    out = [((a,), o, pieces) for a, pieces in enumerate(visible_parts(faces, o)) if pieces]
    last = out
    for _ in range(1, int(depth)):
        new = []
        for chain, source, window in last:
            a = chain[-1]
            normal = polygon_normals(faces[a])[0]
            front = normal * np.sign(normal @ (source - faces[a][0]))
            image = mirror_point(source, faces[a])
            for b in range(len(faces)):
                if b == a:
                    continue
                target = clip_half_space(faces[b], front, faces[a][0])
                if len(target) < 3:
                    continue
                occluders = [clip_half_space(faces[c], front, faces[a][0]) for c in range(len(faces))
                             if c not in (a, b)]
                seen = _seen_from(target, image, [c for c in occluders if len(c) >= 3], scale)
                pieces = [p for w in window for p in _within_cone(seen, image, w)
                          if polygon_normals(p)[1] > PLANE_TOLERANCE * scale ** 2]
                if pieces:
                    new.append((chain + (b,), image, pieces))
        out.extend(new)
        last = new
    return out


def fan_triangles(polygons) -> np.ndarray:
    """``[T, 3, 3]``: the convex ``polygons`` (a list of ``[V, 3]``) fanned from their first vertex."""
    tris = [np.stack([p[0] * np.ones((len(p) - 2, 3)), p[1:-1], p[2:]], axis=1) for p in polygons if len(p) >= 3]
    return np.concatenate(tris) if tris else np.zeros((0, 3, 3))


def subdivided(triangles, max_edge: float) -> np.ndarray:
    """``[T', 3, 3]``: ``triangles [T, 3, 3]`` split at their edges' midpoints into four, again and again,
    until no edge is longer than ``max_edge`` (m); the pieces tile the triangles exactly."""
    if not max_edge > 0:
        raise FlatFaceError(f"subdivided: max_edge must be > 0 m, got {max_edge}")
    done, todo = [], np.asarray(triangles, float)
    while len(todo):
        longest = np.max(np.linalg.norm(np.roll(todo, -1, axis=1) - todo, axis=-1), axis=1)
        done.append(todo[longest <= max_edge])
        t = todo[longest > max_edge]
        m01, m12, m20 = (t[:, 0] + t[:, 1]) / 2, (t[:, 1] + t[:, 2]) / 2, (t[:, 2] + t[:, 0]) / 2
        todo = np.concatenate([np.stack(x, axis=1) for x in ((t[:, 0], m01, m20), (m01, t[:, 1], m12),
                                                             (m20, m12, t[:, 2]), (m01, m12, m20))])
    return np.concatenate(done) if done else np.zeros((0, 3, 3))


def default_max_edge(faces, origin, wavelength: float) -> float:
    r""":math:`\sqrt{Q\,r_{min}/k}` (m): the near-field triangles' largest edge at which the dropped phase
    remainder stays below :data:`NEAR_FIELD_PHASE` :math:`Q` (module docstring), :math:`r_{min}` the
    nearest vertex's range."""
    r_min = float(np.min(np.linalg.norm(np.asarray(faces, float) - np.asarray(origin, float), axis=-1)))
    return float(np.sqrt(NEAR_FIELD_PHASE * r_min * wavelength / (2 * np.pi)))


def _triangle_moment(tris, centre):
    """``[T, 3, 3]``: the second moments :math:`\\langle\\mathbf x\\mathbf x^T\\rangle` of the triangles about
    their centroids (area-weighted mean; :math:`\\frac1{12}\\sum_i \\mathbf d_i\\mathbf d_i^T` for the vertex
    offsets :math:`\\mathbf d_i` from the centroid)."""
    d = tris - centre[:, None]
    return np.einsum("tvi,tvj->tij", d, d) / 12.0


def _near_field_channel(pieces, normal, source, receiver, k: float, max_edge: float) -> complex:
    r""":math:`\frac{1}{4\pi}\int \frac{\cos\theta_s + \cos\theta_r}{2}\,
    \frac{e^{-jk(r_s + r_r)}}{r_s r_r}\,dA` over the convex ``pieces`` of a face (unit ``normal``) lit from
    ``source`` and radiating to ``receiver`` (times :math:`j\Gamma` it is the channel; module docstring):
    small triangles, each exact in the phase to first order about its centroid, the mean of the second
    order put back."""
    tris = subdivided(fan_triangles(pieces), max_edge)
    if len(tris) == 0:
        return 0j
    c = tris.mean(axis=1)
    d_s, d_r = c - source, c - receiver
    r_s, r_r = np.linalg.norm(d_s, axis=1), np.linalg.norm(d_r, axis=1)
    s_s, s_r = d_s / r_s[:, None], d_r / r_r[:, None]
    lit = normal * -np.sign(np.mean(s_s @ normal))                # the normal turned to the incident side
    obliquity = np.clip(-(s_s @ lit + s_r @ lit) / 2, 0.0, None)
    moment = _triangle_moment(tris, c)
    trace = np.einsum("tii->t", moment)
    mu = k / 2 * ((trace - np.einsum("ti,tij,tj->t", s_s, moment, s_s)) / r_s
                  + (trace - np.einsum("ti,tij,tj->t", s_r, moment, s_r)) / r_r)
    integral = polygon_phase_integral(tris - c[:, None], -k * (s_s + s_r))
    return complex(np.sum(obliquity / (r_s * r_r) * np.exp(-1j * k * (r_s + r_r) - 1j * mu) * integral)
                   / (4 * np.pi))


def part_channels(faces, origin, wavelength: float, reflection=-1.0, far_field: bool = False,
                  max_edge: float | None = None) -> np.ndarray:
    r"""``[F]`` complex: each face's share of the first-bounce channel :math:`h` of an isotropic element at
    ``origin`` (module docstring). ``faces [F, V, 3]`` flat convex polygons (m), ``reflection`` the
    faces' :math:`\Gamma` (scalar or ``[F]``; -1 for a perfect conductor), ``far_field`` about the faces'
    vertex mean, ``max_edge`` the near-field triangles' largest edge (m; :func:`default_max_edge` when None)."""
    faces = _faces(faces, "part_channels")
    o = np.asarray(origin, float).reshape(3)
    if not wavelength > 0:
        raise FlatFaceError(f"part_channels: wavelength must be > 0 m, got {wavelength}")
    k = 2 * np.pi / wavelength
    gamma = np.broadcast_to(np.asarray(reflection, complex), (len(faces),))
    parts = visible_parts(faces, o)
    normal = polygon_normals(faces)[0]
    out = np.zeros(len(faces), dtype=complex)
    if far_field:
        p0 = faces.reshape(-1, 3).mean(axis=0)
        r0 = np.linalg.norm(p0 - o)
        s0 = (p0 - o) / r0
        for f, pieces in enumerate(parts):
            if pieces:
                total = sum(polygon_phase_integral(p - p0, -2 * k * s0) for p in pieces)
                out[f] = 1j * gamma[f] / (4 * np.pi) * abs(normal[f] @ s0) * np.exp(-2j * k * r0) / r0 ** 2 * total
        return out
    if max_edge is None:
        max_edge = default_max_edge(faces, o, wavelength)
    for f, pieces in enumerate(parts):
        out[f] = 1j * gamma[f] * _near_field_channel(pieces, normal[f], o, o, k, max_edge)
    return out


def chain_channels(faces, origin, wavelength: float, depth: int, reflection=-1.0,
                   max_edge: float | None = None) -> dict:
    r"""``{chain: h}``: every chain's share (:func:`chain_apertures`) of the channel of an isotropic element at
    ``origin``, the PO of its last face lit by its image source (the engine's
    :func:`~sionnafmcw.engines.po_render.chain_po_gains`),

    .. math:: h = \frac{j\Gamma^d}{4\pi}\int_{W}\frac{\hat{\mathbf n}\cdot(\hat{\mathbf u}_s + \hat{\mathbf u}_r)}{2}\,
        \frac{e^{-jk(r_s + r_r)}}{r_s r_r}\,dA,

    :math:`r_s` from the image source, :math:`r_r` to ``origin``, over the exact aperture :math:`W`, in the
    near field (module docstring); ``reflection`` :math:`\Gamma` per bounce (scalar)."""
    faces = _faces(faces, "chain_channels")
    o = np.asarray(origin, float).reshape(3)
    if not wavelength > 0:
        raise FlatFaceError(f"chain_channels: wavelength must be > 0 m, got {wavelength}")
    k = 2 * np.pi / wavelength
    if max_edge is None:
        max_edge = default_max_edge(faces, o, wavelength)
    normal = polygon_normals(faces)[0]
    gamma = complex(reflection)
    return {chain: 1j * gamma ** len(chain) * _near_field_channel(pieces, normal[chain[-1]], source, o, k, max_edge)
            for chain, source, pieces in chain_apertures(faces, o, depth)}


def monostatic_channel(faces, origin, wavelength: float, reflection=-1.0, far_field: bool = False,
                       max_edge: float | None = None) -> complex:
    """The first-bounce channel of an isotropic element at ``origin``: the sum of :func:`part_channels`."""
    return complex(np.sum(part_channels(faces, origin, wavelength, reflection, far_field, max_edge)))


__all__ = ["FlatFaceError", "NEAR_FIELD_PHASE", "PLANE_TOLERANCE", "chain_apertures", "chain_channels",
           "clip_half_space", "default_max_edge", "fan_triangles", "mirror_point", "monostatic_channel",
           "part_channels", "subdivided", "visible_parts"]
