r"""The smooth surface a mesh's vertex normals describe, rebuilt as curved PN triangles and tessellated
finely enough for physical optics.

Why. The PO render puts its samples on the flat facets of a mesh (positions interpolated between the
corners) while the shading normals say the surface is curved. A facet of edge :math:`e` on a
surface of curvature radius :math:`\rho` departs from it by the sagitta :math:`e^2/(8\rho)`, and at
77 GHz (:math:`\lambda` = 3.9 mm) 1 mm of sagitta is 3 rad of two-way phase: a 320-face icosphere
of 0.1 m returns 10-13 dB too little, a 24-sided cylinder 8 dB (``benchmarks/smooth_surface.py po``).
:func:`pn_refine` rebuilds the smooth surface from the corner positions and normals and tessellates
it on a uniform grid of ``level`` steps per edge; :func:`refinement_level` picks the level. The
refinement is made once per rigid object in its own frame, so its cost is not per frame.

Curved PN triangles
-------------------
Vlachos, Peters, Boyd and Mitchell, "Curved PN triangles", I3D 2001. Over every triangle with corners
:math:`\mathbf p_0, \mathbf p_1, \mathbf p_2` and unit corner normals :math:`\hat{\mathbf n}_i`, a cubic
Bezier triangle in the barycentrics :math:`\mathbf w = (w_0, w_1, w_2)`,

.. math::
    \mathbf b(\mathbf w) = \sum_{i+j+k=3}\frac{3!}{i!\,j!\,k!}\,w_0^iw_1^jw_2^k\,\mathbf b_{ijk},

with the corners :math:`\mathbf b_{300} = \mathbf p_0` (etc.), two control points on every edge
(:math:`\mathbf b_{210}` next to :math:`\mathbf p_0` on the edge to :math:`\mathbf p_1`:
:math:`\mathbf b_{210} = \mathbf p_0 + s\,\mathbf d_{01}/3`, :math:`\mathbf d_{01} = \mathbf c -
(\mathbf c\cdot\hat{\mathbf n}_0)\hat{\mathbf n}_0` the chord :math:`\mathbf c = \mathbf p_1 - \mathbf p_0`
projected on the tangent plane at :math:`\mathbf p_0`; PN's :math:`s = 1`, see *Edge handles*) and
the centre :math:`\mathbf b_{111} = \mathbf E + (\mathbf E - \mathbf V)/2` (:math:`\mathbf E` the mean of
the six edge points, :math:`\mathbf V` of the corners; the patch then passes through :math:`\mathbf E`
at its centroid and reproduces quadrics whose edges it reproduces). The normal is PN's quadratic
patch :math:`\hat{\mathbf n}(\mathbf w) \propto \sum_{i+j+k=2}\frac{2!}{i!\,j!\,k!}w_0^iw_1^jw_2^k\mathbf n_{ijk}`,
:math:`\mathbf n_{200} = \hat{\mathbf n}_0` (etc.) and :math:`\mathbf n_{110}` the sum
:math:`\hat{\mathbf n}_0 + \hat{\mathbf n}_1` reflected in the plane normal to the chord, normalised:
along an edge it depends on that edge's ends only, so two triangles that share a smooth edge share
its normals, and PN's normals (not those of the cubic, which is only :math:`C^0` across edges) are
the ones returned. A sub-vertex of the tessellation is :math:`\mathbf b(\mathbf w)` on the grid
:math:`\mathbf w = (n - i - j, i, j)/n`; the ``level`` :math:`n` gives :math:`n^2` sub-triangles per
triangle, same winding.

Edge handles
------------
An edge whose end normals and chord lie in one plane is best made a circular arc. With the normals
turning by :math:`\alpha` over an arc of radius :math:`R`, the chord is :math:`2R\sin(\alpha/2)` and meets
each end's tangent at :math:`\alpha/2`, so PN's handle :math:`|\mathbf d|/3` is
:math:`|\mathbf c|\cos(\alpha/2)/3`. The cubic whose midpoint lies on the arc has handles
:math:`\frac43R\tan(\alpha/4)` (midpoint :math:`(\mathbf p_0 + 3\mathbf b_1 + 3\mathbf b_2 + \mathbf p_1)/8`
at height :math:`R\cos(\alpha/2) + \frac34 L\sin(\alpha/2) = R` for :math:`L = \frac{4R(1-\cos(\alpha/2))}
{3\sin(\alpha/2)} = \frac43R\tan\frac\alpha4`), i.e. :math:`|\mathbf c|/(3\cos^2(\alpha/4))`, and
bulges out of the arc by at most :math:`\frac{2}{27}R\sin^6(\alpha/4)/\cos^2(\alpha/4)` (Goldapp,
CAGD 8, 1991: 0.1 um on a 0.1 m sphere at :math:`\alpha` = 36 degrees). ``handles="circular"`` (the default)
scales PN's projected handle by

.. math::
    s(\alpha) = \frac{1}{\cos(\alpha/2)\cos^2(\alpha/4)}

(:func:`handle_scale`), :math:`\alpha` the angle between the edge's end normals (clipped at
:data:`MAX_HANDLE_ANGLE`). The
normal angle, not the angle between the two projected chords, is what a helix on a cylinder (the
diagonal of a side quad) needs: its normals turn by the azimuth step :math:`\Delta\varphi`, and
:math:`s(\Delta\varphi)` gives its projection on the cross-section exactly the circular handle.
Where PN's handle vanishes (chord in both tangent planes: a straight line) so does this one.

Which is better, at the centroid of an equilateral spherical triangle (corners at angular radius
:math:`\beta` about the pole, :math:`\sin\beta = \frac{2}{\sqrt3}\sin\frac\alpha2`): the patch passes
through :math:`\mathbf E`, whose height is :math:`\cos\beta\,(1 + \frac{2s}{3}\sin^2\frac\alpha2)` (every
edge point sits at :math:`\cos\beta + s\,\mathbf d_z/3`, :math:`\mathbf d_z = 2\sin^2(\alpha/2)\cos\beta`),
so the surface lies inside the sphere by

.. math::
    R\Bigl[1 - \sqrt{1 - \tfrac43\sin^2\tfrac\alpha2}\,\bigl(1 + \tfrac{2s}{3}\sin^2\tfrac\alpha2\bigr)\Bigr]
    \approx \frac{R\alpha^4}{24}\ (s = 1),\qquad \frac{R\alpha^4}{96}\ (s = s(\alpha)),

the largest error of the patch (``tests/test_smooth_surface.py`` finds the icospheres' largest
triangles attain it to 1e-6). Circular handles are four times closer: 12 um instead of 47 um on the
320-face icosphere of 0.1 m, at most 61 um instead of 323 um on the walker's 32 mm segments with exact
normals, feet aside (``benchmarks/smooth_surface.py geometry``). With them the normal field errs by
:math:`\alpha^3t(1 - t^2)/64` along an edge (:math:`t = 2u - 1`; at most :math:`\alpha^3/(96\sqrt3)`,
series of both fields to :math:`\alpha^3`), 0.0064 :math:`\alpha^3` inside an equilateral patch.

Smooth edges and creases
------------------------
Vertices are welded by position (a mesh's split vertices become one), and every edge is computed
once: its ``level - 1`` inner points are one set of vertices shared by all its triangles, so no ray
passes between patches (zero boundary edges on a closed input). An edge is *smooth* when all its
triangles give its two ends the same normal (up to a common sign) within :data:`NORMAL_TOLERANCE`
= 1e-4 rad: far above the rounding of float32 PLY normals (6e-8) and far below any intended crease
(Blender's and :data:`~sionnafmcw.engines.po_render.CREASE_ANGLE`'s 30 degrees); treating normals that
differ by :math:`\delta` as one moves the edge curve by at most :math:`\frac49\cdot\frac{e\delta}{3}`
(0.5 um on a 3 cm edge). Its curve comes from the first triangle's normals, and its sub-vertices
get one normal. Any other edge is a *crease* (a box edge, a cylinder's rim): each side keeps its own
normals (``corner_normals`` per side, ``crease`` on the vertex), and both sides share one curve:

* ``creases="curved"`` (default): each end's handle lies along the line common to both sides'
  tangent planes, :math:`\hat{\mathbf t} = \hat{\mathbf n}_f\times\hat{\mathbf n}_g`, of length the
  chord's projection on it times :math:`s` of the angle between the two end tangents -- a box edge
  stays straight, a cylinder's rim becomes the circle, and a flat cap with a curved rim stays in its
  plane. Where the sides' normals differ by less than :data:`CREASE_TANGENT_ANGLE` the cross
  product is ill-conditioned and the tangent plane of their mean is used;
* ``creases="straight"``: the chord, on both sides (the rim stays a polygon).

Measured on the 24-sided cylinder at broadside, 10 m, where the Fresnel zone along the axis covers
the whole 0.3 m (``benchmarks/smooth_surface.py po``): straight rims leave the side a polygon near
its ends and the echo 3.4 dB low at every level; curved rims bring it within 0.03 dB. Hence the
default. Edges of three or more triangles that disagree are straight.

A *flat* triangle -- its three edges straight (handles along the chord within the normal
tolerance) and its corner normals one -- maps linearly: its sub-vertices are its linear
subdivision, its normals bitwise its own (still flat shaded), and points are evaluated as offsets
from the first corner, so an axis-aligned wall keeps its coordinate exactly.

Level
-----
A flat sub-facet departs from the smooth surface by the quadric interpolation error: for corners
:math:`\mathbf p_i` of a surface of shape operator :math:`\mathbf K`, the plane through them is off
at :math:`\mathbf w` by :math:`d(\mathbf w) = \sum_{i<j}w_iw_jc_{ij}` with
:math:`c_{ij} = \frac12\mathbf e_{ij}^T\mathbf K\mathbf e_{ij}`, and the normals give
:math:`\mathbf K\mathbf e_{ij} \approx \hat{\mathbf n}_j - \hat{\mathbf n}_i`, so

.. math::
    c_{ij} = \tfrac12(\mathbf p_j - \mathbf p_i)\cdot(\hat{\mathbf n}_j - \hat{\mathbf n}_i),\qquad
    d_{max} = \max_{\mathbf w}\Bigl|\sum_{i<j}w_iw_jc_{ij}\Bigr|

(:func:`facet_sagitta`; an edge's own sagitta is :math:`c/4`, the centroid of an equilateral facet
on a sphere :math:`c/3`). For a circular arc :math:`c = |\mathbf e|\sin(\alpha/2) = |\mathbf e|^2/(2R)`
exactly. It uses the normal curvature along the edge, :math:`(\hat{\mathbf n}_j - \hat{\mathbf n}_i)\cdot
\hat{\mathbf e}`, not the turning angle over the edge length (:func:`~sionnafmcw.engines.po_render.curvature_radius`):
on a cylinder the diagonal of a side quad turns its normal by the azimuth step but bends at half
the curvature, and the angle would ask for :math:`\sqrt2` times its level. A level-:math:`n`
sub-facet has edges :math:`\mathbf e/n`, so :math:`d_{max}/n^2`, and :func:`refinement_level` is
:math:`n = \lceil\sqrt{d_{max}/h}\rceil` (1 on a flat mesh; measured sub-facets stay below
:math:`h`, one level less exceeds it: ``tests/test_smooth_surface.py``). :data:`MAX_REFINED_TRIANGLES`
caps the result (about 200 bytes a triangle); a level above it raises, naming the facet.

The rule :math:`h = \lambda/25` (:data:`SAGITTA_FRACTION`): a sample at height :math:`h` off the
surface carries the two-way phase error :math:`2kh = 4\pi/25` = 0.5 rad at the worst point of a
facet, and it is where the walker's PO converges -- the 8 mm body, :math:`\lambda/35` on the
forearm, is within 0.9 dB of the 4 mm one (:mod:`sionnafmcw.scenes.body`, *Mesh resolution*), the
12 mm body (:math:`\lambda/16`) 2.8 dB off.

Samples on the smooth surface
-----------------------------
That rule is not enough for samples left on the flat sub-facets: the facets form a lattice of
period :math:`p \approx` their size, whose sagitta ripple :math:`d(\mathbf x)` is a phase grating.
Its first harmonics (amplitude about :math:`0.2\,d_{max}`) scatter back from the points of the
surface tilted by :math:`\sin\theta = \lambda/(2p)` (16 degrees for 7 mm facets): on a sphere, as many
specular points as grating directions (six on a triangle lattice), each of relative amplitude
:math:`2k\cdot0.2\,d_{max}`, beating with the true one, :math:`\sqrt6\cdot0.4\,kd_{max} \approx
kd_{max}` rms. At :math:`\lambda/25` that is 25 % of the field; measured, the refined 320- and
1280-face icospheres are 1.2-1.4 dB low at 3 m and 10 m with flat samples (the 5120-face icosphere,
:math:`\lambda/49`, 1.2 dB), within 0.3 dB from :math:`\lambda/55` on (level sweep of the 320-face
icosphere in ``benchmarks/smooth_surface.py po``). So:

* the engine should put every sample where it belongs, on the smooth surface:
  :meth:`RefinedSurface.smooth_points` maps a hit (sub-triangle, barycentrics) to the point and PN
  normal of the parent patch at the same parameters. The sagitta rule then only bounds how far a
  sample moves off its ray (:math:`\le h`) and the distortion of the pixel tiling (order
  :math:`\sqrt{2h/\rho}`); measured within 0.15 dB of the exact spheres and 0.03 dB of the exact
  cylinder at :math:`\lambda/25` (0.3 dB even at level 1);
* samples left on the facets need :math:`kd_{max} \le` 6 % (0.5 dB, half of a 1 dB error budget, the other
  half to the render's pixel sampling): :math:`d_{max} \le \lambda/105`, :data:`FLAT_SAGITTA_FRACTION`
  = 1/100, twice the level and four times the triangles.

The PN surface must itself be close: it is where every edge sees a nearly constant curvature, and
where the normals are the surface's. On the walker (``benchmarks/smooth_surface.py walker``: PO RCS
at the convergence table's ten looks against the body with every sample on the exact ellipsoids
and capsules) the 32 mm mesh refined with the shapes' exact normals and samples on the smooth
surface is within 1.8 dB (today's 8 mm mesh: 1.1 dB; the 32 mm facets: 18 dB); the rest is the
feet, whose toe and heel turn the normal by 91 degrees over one 32 mm edge -- no curve through the
ends recovers that (the PN foot is 1.2 mm off), and with exact feet the refined 32 mm body is within
0.7 dB. The 16 mm mesh refined is within 0.45 dB. With the coarse mesh's own area-weighted vertex
normals instead, the PN normals are 1.4-6.7 degrees off (pelvis to forearm, 32 mm), the PN surface
0.06-0.46 mm and the echo up to 3.4 dB: a scene that knows its shapes should write their exact normals.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Largest angle (rad) between two corner normals that are taken as one normal (module docstring,
#: *Smooth edges and creases*).
NORMAL_TOLERANCE = 1e-4
#: Smallest angle (rad) between the two sides' normals at a crease end for the crease tangent
#: :math:`\hat{\mathbf n}_f\times\hat{\mathbf n}_g` to be used (below it, the tangent plane of their mean).
CREASE_TANGENT_ANGLE = 0.1
#: Largest normal turning angle (rad) the circular handle rule is applied at (module docstring).
MAX_HANDLE_ANGLE = 2 * np.pi / 3
#: The refinement rule's largest facet sagitta, as a share of the wavelength, for PO samples moved onto
#: the smooth surface (module docstring, *Level*).
SAGITTA_FRACTION = 1 / 25
#: The same for PO samples left on the flat sub-facets (module docstring, *Samples on the smooth surface*).
FLAT_SAGITTA_FRACTION = 1 / 100
#: Most triangles a refinement may make (memory guard: about 200 bytes per refined triangle).
MAX_REFINED_TRIANGLES = 2_000_000


class SmoothSurfaceError(ValueError):
    """A mesh or parameter the smooth-surface refinement cannot use; the message names it."""


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _unit(x, eps=1e-300):
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    return x / np.maximum(norm, eps), norm[..., 0]


def _check_mesh(vertices, faces, corner_normals, where: str):
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 2 or v.shape[1] != 3 or not np.all(np.isfinite(v)):
        raise SmoothSurfaceError(f"{where}: vertices must be finite [V, 3] positions (m), got shape {v.shape}")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
        raise SmoothSurfaceError(f"{where}: faces must be integer [F, 3] vertex indices, got shape {f.shape} "
                                 f"dtype {f.dtype}")
    f = f.astype(np.int64)
    if len(f) == 0:
        raise SmoothSurfaceError(f"{where}: faces is empty (a mesh needs at least one triangle)")
    if f.min() < 0 or f.max() >= len(v):
        raise SmoothSurfaceError(f"{where}: faces index vertices {f.min()}..{f.max()}, outside 0..{len(v) - 1}")
    n = np.asarray(corner_normals, dtype=float)
    if n.shape != (len(f), 3, 3):
        raise SmoothSurfaceError(f"{where}: corner_normals must have shape [F, 3, 3] = {(len(f), 3, 3)} "
                                 f"(a normal per triangle corner), got {n.shape}")
    if not np.all(np.isfinite(n)):
        raise SmoothSurfaceError(f"{where}: corner_normals contains non-finite values")
    norm = np.linalg.norm(n, axis=-1)
    if norm.size and np.max(np.abs(norm - 1.0)) > 1e-3:
        k = np.unravel_index(np.argmax(np.abs(norm - 1.0)), norm.shape)
        raise SmoothSurfaceError(f"{where}: corner_normals must be unit vectors (within 1e-3); face {k[0]} corner "
                                 f"{k[1]} has length {norm[k]:.6g}")
    # normals within rounding of unit length are kept bitwise (flat-shaded walls stay flat shaded)
    return v, f, np.where(np.abs(norm - 1.0)[..., None] > 1e-12, n / norm[..., None], n)


def handle_scale(angle) -> np.ndarray:
    r"""Factor :math:`s(\alpha) = 1/(\cos(\alpha/2)\cos^2(\alpha/4))` that turns a PN handle
    (the chord projected on the tangent plane, over 3) into the circular-arc handle of the module
    docstring; :math:`\alpha` is clipped to :data:`MAX_HANDLE_ANGLE`."""
    a = np.clip(np.asarray(angle, float), 0.0, MAX_HANDLE_ANGLE)
    return 1.0 / (np.cos(a / 2) * np.cos(a / 4) ** 2)


# ---------------------------------------------------------------------------------------- edges
@dataclass
class _Edges:
    """The unique edges of a welded mesh and their curves (canonical direction lo -> hi)."""

    lo: np.ndarray             # [E] welded vertex ids
    hi: np.ndarray             # [E]
    face_edge: np.ndarray      # [F, 3] edge id of each face's edge k (corner k -> corner k+1)
    forward: np.ndarray        # [F, 3] bool: the face's edge k runs lo -> hi
    side_sign: np.ndarray      # [F, 3] +-1: the face's normals against the edge's reference side
    smooth: np.ndarray         # [E] bool: every side agrees on the normals at both ends
    straight: np.ndarray       # [E] bool: the curve is the chord (linear)
    handle_lo: np.ndarray      # [E, 3] control point next to lo
    handle_hi: np.ndarray      # [E, 3] control point next to hi
    normal_lo: np.ndarray      # [E, 3] reference side's normal at lo
    normal_hi: np.ndarray      # [E, 3]
    normal_mid: np.ndarray     # [E, 3] PN's middle normal coefficient of the reference side


def _pn_mid_normal(p_a, p_b, n_a, n_b):
    r"""PN's quadratic middle normal :math:`\mathbf n_{110}`: :math:`\mathbf n_a + \mathbf n_b` reflected
    in the plane normal to the chord, normalised (the mean normal where that degenerates)."""
    c = p_b - p_a
    cc = _dot(c, c)
    v = np.divide(2 * _dot(c, n_a + n_b), cc, out=np.zeros_like(cc), where=cc > 0)
    h, length = _unit(n_a + n_b - v[..., None] * c)
    fallback, flen = _unit(n_a + n_b)
    bad = length < 1e-6
    if np.any(bad):
        h[bad] = np.where(flen[bad, None] > 1e-6, fallback[bad], n_a[bad])
    return h


def _edges(points, fw, normals, handles: str, creases: str, tolerance: float) -> _Edges:
    num_f = len(fw)
    start = fw.reshape(-1)                                 # corner k of face f -> corner k+1
    end = np.roll(fw, -1, axis=1).reshape(-1)
    n_start = normals.reshape(-1, 3)
    n_end = np.roll(normals, -1, axis=1).reshape(-1, 3)
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    key = lo * (int(fw.max(initial=0)) + 1) + hi
    uniq, first, edge_of_side = np.unique(key, return_index=True, return_inverse=True)
    edge_of_side = edge_of_side.reshape(-1)
    num_e = uniq.size
    forward = start == lo
    side_lo = np.where(forward[:, None], n_start, n_end)   # each side's normals at the edge's lo / hi
    side_hi = np.where(forward[:, None], n_end, n_start)
    ref = first                                            # reference side: the first (lowest face)
    ref_lo, ref_hi = side_lo[ref][edge_of_side], side_hi[ref][edge_of_side]
    sign = np.where(_dot(side_lo, ref_lo) + _dot(side_hi, ref_hi) < 0, -1.0, 1.0)
    gap_lo = np.linalg.norm(sign[:, None] * side_lo - ref_lo, axis=-1)
    gap_hi = np.linalg.norm(sign[:, None] * side_hi - ref_hi, axis=-1)
    # chord of an angle: 2 sin(a / 2) <= tolerance angle
    chord_tol = 2 * np.sin(tolerance / 2)
    agree_lo = np.bincount(edge_of_side, gap_lo > chord_tol, num_e) == 0
    agree_hi = np.bincount(edge_of_side, gap_hi > chord_tol, num_e) == 0
    num_sides = np.bincount(edge_of_side, minlength=num_e)
    smooth = agree_lo & agree_hi
    p_lo, p_hi = points[lo[first]], points[hi[first]]
    n_lo, n_hi = side_lo[first], side_hi[first]
    chord = p_hi - p_lo
    chord_len = np.linalg.norm(chord, axis=-1)
    c_hat = np.divide(chord, chord_len[:, None], out=np.zeros_like(chord), where=chord_len[:, None] > 0)

    # the other side of two-sided edges (its normals turned to the reference's sign)
    other = np.full(num_e, -1)
    sides = np.arange(len(key))
    not_ref = sides != ref[edge_of_side]
    other[edge_of_side[not_ref]] = sides[not_ref]
    two = (num_sides == 2) & (other >= 0)
    o = np.where(two, other, ref)
    o_lo, o_hi = sign[o, None] * side_lo[o], sign[o, None] * side_hi[o]

    def tangent(end_normal, other_normal, agree, towards):
        """Direction of the curve's end handle (length = the projection of the chord on it)."""
        # smooth end: the chord projected on the tangent plane (PN)
        d = towards - _dot(towards, end_normal)[:, None] * end_normal
        crease = ~agree & two
        if creases == "curved" and np.any(crease):
            mean, _ = _unit(end_normal + other_normal)
            d_mean = towards - _dot(towards, mean)[:, None] * mean
            cross, sin = _unit(np.cross(end_normal, other_normal))
            d_cross = _dot(towards, cross)[:, None] * cross
            use_cross = crease & (sin >= np.sin(CREASE_TANGENT_ANGLE))
            d = np.where(use_cross[:, None], d_cross, np.where(crease[:, None], d_mean, d))
        return d

    d_lo = tangent(n_lo, o_lo, agree_lo, chord)
    d_hi = tangent(n_hi, o_hi, agree_hi, -chord)
    straight = (chord_len == 0) | ((~smooth) & ((creases == "straight") | (num_sides > 2)))
    # ends whose handle is along the chord to within the normal tolerance: a straight edge
    along_lo = np.linalg.norm(np.cross(d_lo, c_hat), axis=-1) <= tolerance * chord_len
    along_hi = np.linalg.norm(np.cross(d_hi, c_hat), axis=-1) <= tolerance * chord_len
    straight |= along_lo & along_hi
    if handles == "circular":
        turn_normals = np.arccos(np.clip(_dot(n_lo, n_hi), -1.0, 1.0))
        t_lo, _ = _unit(d_lo)
        t_hi, _ = _unit(-d_hi)
        turn_tangents = np.arccos(np.clip(_dot(t_lo, t_hi), -1.0, 1.0))
        scale = handle_scale(np.where(smooth, turn_normals, turn_tangents))[:, None]
    else:
        scale = 1.0
    h_lo = p_lo + scale * d_lo / 3
    h_hi = p_hi + scale * d_hi / 3
    h_lo[straight] = p_lo[straight] + chord[straight] / 3
    h_hi[straight] = p_hi[straight] - chord[straight] / 3
    face_edge = edge_of_side.reshape(num_f, 3)
    return _Edges(lo[first], hi[first], face_edge, forward.reshape(num_f, 3), sign.reshape(num_f, 3), smooth,
                  straight, h_lo, h_hi, n_lo, n_hi, _pn_mid_normal(p_lo, p_hi, n_lo, n_hi))


# ---------------------------------------------------------------------------------------- patches
#: Control points of a cubic Bezier triangle in the order used here: b300, b030, b003 (corners),
#: b210, b120 (edge 0 -> 1), b021, b012 (edge 1 -> 2), b102, b201 (edge 2 -> 0), b111.
_CUBIC = np.array([[3, 0, 0], [0, 3, 0], [0, 0, 3], [2, 1, 0], [1, 2, 0], [0, 2, 1], [0, 1, 2], [1, 0, 2],
                   [2, 0, 1], [1, 1, 1]])
_CUBIC_COEF = np.array([1, 1, 1, 3, 3, 3, 3, 3, 3, 6], float)
#: Quadratic normal coefficients: n200, n020, n002, n110, n011, n101.
_QUAD = np.array([[2, 0, 0], [0, 2, 0], [0, 0, 2], [1, 1, 0], [0, 1, 1], [1, 0, 1]])
_QUAD_COEF = np.array([1, 1, 1, 2, 2, 2], float)


def _basis(weights, powers, coef):
    """Bernstein basis ``[K, C]`` of the monomials ``powers [C, 3]`` at ``weights [K, 3]`` (written out for
    the cubic and quadratic patches: they are evaluated at every PO sample)."""
    w = np.asarray(weights, float)
    w0, w1, w2 = w[:, 0], w[:, 1], w[:, 2]
    if powers is _CUBIC:
        a, b, c = w0 * w0, w1 * w1, w2 * w2
        return np.stack([a * w0, b * w1, c * w2, 3 * a * w1, 3 * w0 * b, 3 * b * w2, 3 * w1 * c, 3 * w0 * c,
                         3 * a * w2, 6 * w0 * w1 * w2], axis=-1)
    if powers is _QUAD:
        return np.stack([w0 * w0, w1 * w1, w2 * w2, 2 * w0 * w1, 2 * w1 * w2, 2 * w0 * w2], axis=-1)
    return coef * np.prod(w[:, None, :] ** powers[None], axis=-1)


@dataclass
class PNTriangles:
    r"""The smooth surface of a mesh: one cubic Bezier triangle (positions) and one quadratic
    normal patch per face (module docstring), welded and classified edges.

    ``points [U, 3]``: the distinct positions of the vertices the faces use; ``faces [F, 3]``: the
    faces on them (``vertex_of_input [V]`` maps input vertices to ``points``, -1 where unused);
    ``control [F, 10, 3]``: the cubic control points (b300, b030, b003, b210, b120, b021, b012,
    b102, b201, b111); ``normal_control [F, 6, 3]``: n200, n020, n002, n110, n011, n101;
    ``flat [F]``: faces mapped linearly (their plane, exactly).
    """

    points: np.ndarray
    faces: np.ndarray
    control: np.ndarray
    normal_control: np.ndarray
    flat: np.ndarray
    edges: _Edges
    vertex_of_input: np.ndarray
    _offsets: np.ndarray | None = field(default=None, repr=False)   # control[:, 1:] - control[:, :1], once

    def position(self, face, weights) -> np.ndarray:
        """Points ``[K, 3]`` of the surface at barycentric ``weights [K, 3]`` (w0, w1, w2) of ``face [K]``."""
        face = np.asarray(face, np.int64)
        w = np.asarray(weights, float)
        b = _basis(w, _CUBIC, _CUBIC_COEF)
        # offsets from the first corner: a plane's points keep its coordinate exactly (axis-aligned walls)
        if self._offsets is None:
            self._offsets = self.control[:, 1:] - self.control[:, :1]
        out = self.control[face, 0] + np.einsum("kc,kci->ki", b[:, 1:], self._offsets[face])
        flat = self.flat[face]
        if np.any(flat):
            tri = self.points[self.faces[face[flat]]]
            out[flat] = np.einsum("kc,kci->ki", w[flat], tri)
        return out

    def normal(self, face, weights) -> np.ndarray:
        """Unit PN normals ``[K, 3]`` at ``weights [K, 3]`` of ``face [K]`` (quadratic patch, normalised)."""
        face = np.asarray(face, np.int64)
        b = _basis(weights, _QUAD, _QUAD_COEF)
        return _unit(np.einsum("kc,kci->ki", b, self.normal_control[face]))[0]


def pn_triangles(vertices, faces, corner_normals, handles: str = "circular", creases: str = "curved",
                 normal_tolerance: float = NORMAL_TOLERANCE) -> PNTriangles:
    """The :class:`PNTriangles` of a mesh (module docstring); arguments as :func:`pn_refine`."""
    v, f, n = _check_mesh(vertices, faces, corner_normals, "pn_triangles")
    if handles not in ("circular", "pn"):
        raise SmoothSurfaceError(f"pn_triangles: handles must be 'circular' or 'pn', got {handles!r}")
    if creases not in ("curved", "straight"):
        raise SmoothSurfaceError(f"pn_triangles: creases must be 'curved' or 'straight', got {creases!r}")
    if not 0 < normal_tolerance < 0.1:
        raise SmoothSurfaceError(f"pn_triangles: normal_tolerance must lie in (0, 0.1) rad, got {normal_tolerance!r}")
    # weld the vertices the faces use by position (+ 0.0 turns -0.0 into 0.0); unused vertices map to -1
    used = np.unique(f)
    points, welded = np.unique(v[used] + 0.0, axis=0, return_inverse=True)
    vertex_of_input = np.full(len(v), -1, dtype=np.int64)
    vertex_of_input[used] = welded.reshape(-1)
    fw = vertex_of_input[f]
    e = _edges(points, fw, n, handles, creases, normal_tolerance)
    num_f = len(f)
    control = np.empty((num_f, 10, 3))
    control[:, :3] = points[fw]
    slots = ((3, 4), (5, 6), (7, 8))          # (next to corner k, next to corner k+1) of edge k
    for k, (a, b) in enumerate(slots):
        eid, fwd = e.face_edge[:, k], e.forward[:, k]
        control[:, a] = np.where(fwd[:, None], e.handle_lo[eid], e.handle_hi[eid])
        control[:, b] = np.where(fwd[:, None], e.handle_hi[eid], e.handle_lo[eid])
    # b111 = E + (E - V) / 2 (E the mean of the edge control points, V of the corners), from the first corner
    mean_edge = (control[:, 3:9] - control[:, :1]).mean(axis=1)
    centre = (control[:, :3] - control[:, :1]).mean(axis=1)
    control[:, 9] = control[:, 0] + (mean_edge + (mean_edge - centre) / 2)
    # quadratic normals: corners as given; middle coefficients from the edge table where smooth
    normal_control = np.empty((num_f, 6, 3))
    normal_control[:, :3] = n
    for k in range(3):
        eid = e.face_edge[:, k]
        own = _pn_mid_normal(control[:, k], control[:, (k + 1) % 3], n[:, k], n[:, (k + 1) % 3])
        shared = e.side_sign[:, k, None] * e.normal_mid[eid]
        normal_control[:, 3 + k] = np.where(e.smooth[eid][:, None], shared, own)
    straight_faces = np.all(e.straight[e.face_edge], axis=1)
    same = np.all(np.linalg.norm(n - n[:, :1], axis=-1) <= 2 * np.sin(normal_tolerance / 2), axis=1)
    flat = straight_faces & same
    return PNTriangles(points, fw, control, normal_control, flat, e, vertex_of_input)


# ---------------------------------------------------------------------------------------- refinement
@dataclass
class RefinedSurface:
    r"""A mesh rebuilt as its smooth surface and tessellated ``level`` times per edge.

    ``vertices [V', 3]`` (m): the input's distinct positions first, then ``level - 1`` points per
    edge, then the faces' inner points; ``faces [F', 3]``: ``level^2`` sub-triangles per input
    triangle, same winding; ``normals [V', 3]``: the PN normal at every vertex (on a crease, that of
    the lowest-numbered face at it: use ``corner_normals`` there); ``crease [V']``: vertices whose
    faces disagree on the normal; ``corner_normals [F', 3, 3]``: the normal of every sub-triangle
    corner, one per vertex on smooth edges and per side on creases (what the renderer interpolates);
    ``parent [F']``: the input triangle of every sub-triangle; ``barycentric [F', 3, 2]``: the
    parameters :math:`(b_1, b_2)` of its corners in the parent (the point
    :math:`(1 - b_1 - b_2)\mathbf p_0 + b_1\mathbf p_1 + b_2\mathbf p_2` of the parent's parameter
    plane; :meth:`to_parent`); ``level``; ``num_creases``: input edges treated as creases;
    ``surface``: the :class:`PNTriangles` it samples.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    crease: np.ndarray
    corner_normals: np.ndarray
    parent: np.ndarray
    barycentric: np.ndarray
    level: int
    num_creases: int
    surface: PNTriangles

    def to_parent(self, triangle, barycentric) -> tuple[np.ndarray, np.ndarray]:
        """Input triangle ``[K]`` and its barycentric ``(b1, b2)`` ``[K, 2]`` of points given on the
        refined mesh as sub-triangle ``triangle [K]`` and barycentric ``barycentric [K, 2]`` (the
        surface-fixed coordinates, e.g. for :mod:`sionnafmcw.diffuse`'s phases)."""
        t = np.asarray(triangle, np.int64)
        b = np.asarray(barycentric, float)
        w = np.stack([1.0 - b[:, 0] - b[:, 1], b[:, 0], b[:, 1]], axis=-1)
        return self.parent[t], np.einsum("kc,kci->ki", w, self.barycentric[t])

    def smooth_points(self, triangle, barycentric) -> tuple[np.ndarray, np.ndarray]:
        """Points ``[K, 3]`` and unit PN normals ``[K, 3]`` on the smooth surface at the hits ``triangle [K]``,
        ``barycentric [K, 2]`` of the refined mesh (the same parameters in the parent: :meth:`to_parent`):
        where the PO samples belong (module docstring, *Samples on the smooth surface*)."""
        parent, b = self.to_parent(triangle, barycentric)
        w = np.stack([1.0 - b[:, 0] - b[:, 1], b[:, 0], b[:, 1]], axis=-1)
        return self.surface.position(parent, w), self.surface.normal(parent, w)


def _grid(level: int):
    """Barycentric grid of ``level`` steps per edge: integer ``(i, j)`` ``[G, 2]`` (w1 = i/n, w2 = j/n) and the
    sub-triangles ``[level^2, 3]`` as indices into it, same winding as (p0, p1, p2)."""
    n = level
    ij = [(i, j) for i in range(n + 1) for j in range(n + 1 - i)]
    index = {p: k for k, p in enumerate(ij)}
    tris = []
    for i in range(n):
        for j in range(n - i):
            tris.append((index[(i, j)], index[(i + 1, j)], index[(i, j + 1)]))
            if j < n - i - 1:
                tris.append((index[(i + 1, j)], index[(i + 1, j + 1)], index[(i, j + 1)]))
    return np.array(ij, dtype=np.int64), np.array(tris, dtype=np.int64)


def pn_refine(vertices, faces, corner_normals, level: int, handles: str = "circular", creases: str = "curved",
              normal_tolerance: float = NORMAL_TOLERANCE,
              max_triangles: int = MAX_REFINED_TRIANGLES) -> RefinedSurface:
    r"""The mesh ``(vertices [V, 3], faces [F, 3])`` with ``corner_normals [F, 3, 3]`` (unit, a
    normal per triangle corner, :func:`sionnafmcw.engines.po_render.shading_normals`) rebuilt as
    curved PN triangles and tessellated on a uniform barycentric grid of ``level`` steps per edge
    (:class:`RefinedSurface`, ``level^2`` sub-triangles per triangle).

    ``handles``: ``"circular"`` (default; edge curves that follow circular arcs, module docstring)
    or ``"pn"`` (Vlachos et al.'s chord projection); ``creases``: ``"curved"`` (default; a crease
    follows the intersection of its two sides' tangent planes) or ``"straight"`` (the chord);
    ``normal_tolerance`` (rad): corner normals closer than this are one normal;
    ``max_triangles``: memory guard.
    """
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or level < 1:
        raise SmoothSurfaceError(f"pn_refine: level must be an integer >= 1, got {level!r}")
    level = int(level)
    num_f = int(np.shape(faces)[0]) if np.ndim(faces) == 2 else 0
    if num_f * level ** 2 > max_triangles:
        raise SmoothSurfaceError(f"pn_refine: level {level} makes {num_f} x {level}^2 = {num_f * level ** 2} "
                                 f"triangles, more than max_triangles={max_triangles}")
    pn = pn_triangles(vertices, faces, corner_normals, handles, creases, normal_tolerance)
    e = pn.edges
    fw = pn.faces
    num_u, num_e = len(pn.points), len(e.lo)
    n = level
    ij, tris = _grid(n)
    g = len(ij)
    i, j = ij[:, 0], ij[:, 1]
    weights = np.stack([n - i - j, i, j], axis=-1) / n                       # [G, 3]
    # vertices: distinct corners, then n - 1 per edge (canonical lo -> hi), then the faces' inner points
    t = np.arange(1, n) / n
    if n > 1:
        straight = e.straight[:, None, None]
        u = t[None, :, None]
        p_lo, p_hi = pn.points[e.lo][:, None], pn.points[e.hi][:, None]
        cubic = p_lo + (3 * (1 - u) ** 2 * u * (e.handle_lo[:, None] - p_lo)
                        + 3 * (1 - u) * u ** 2 * (e.handle_hi[:, None] - p_lo) + u ** 3 * (p_hi - p_lo))
        edge_points = np.where(straight, (1 - u) * p_lo + u * p_hi, cubic).reshape(-1, 3)
        quad = ((1 - u) ** 2 * e.normal_lo[:, None] + 2 * (1 - u) * u * e.normal_mid[:, None]
                + u ** 2 * e.normal_hi[:, None])
        edge_normals = _unit(quad)[0]
        same_ends = np.all(e.normal_lo == e.normal_hi, axis=-1) & e.straight
        edge_normals = np.where(same_ends[:, None, None], e.normal_lo[:, None], edge_normals.reshape(num_e, n - 1, 3))
        edge_normals = edge_normals.reshape(-1, 3)
    else:
        edge_points = edge_normals = np.zeros((0, 3))
    inner = (i > 0) & (j > 0) & (i + j < n)
    num_inner = int(inner.sum())
    # global index of every grid point of every face
    index = np.empty((num_f, g), dtype=np.int64)
    corner = {0: (i == 0) & (j == 0), 1: (i == n) & (j == 0), 2: (i == 0) & (j == n)}
    for k, mask in corner.items():
        index[:, np.flatnonzero(mask)] = fw[:, k:k + 1]
    # edge k of a face runs corner k -> corner k+1; u * n its step from corner k
    on_edge = {0: ((j == 0) & (i > 0) & (i < n), i), 1: ((i + j == n) & (j > 0) & (j < n), j),
               2: ((i == 0) & (j > 0) & (j < n), n - j)}
    base = num_u
    for k, (mask, step) in on_edge.items():
        cols = np.flatnonzero(mask)
        s = step[cols][None, :]
        fwd = e.forward[:, k:k + 1]
        canon = np.where(fwd, s, n - s)
        index[:, cols] = base + e.face_edge[:, k:k + 1] * (n - 1) + (canon - 1)
    inner_cols = np.flatnonzero(inner)
    base_inner = num_u + num_e * (n - 1)
    index[:, inner_cols] = base_inner + np.arange(num_f)[:, None] * num_inner + np.arange(num_inner)[None, :]
    # every face's own evaluation at its grid points (positions of inner points; normals of corners)
    faces_rep = np.repeat(np.arange(num_f), g)
    w_rep = np.tile(weights, (num_f, 1))
    own_normal = pn.normal(faces_rep, w_rep).reshape(num_f, g, 3)
    for k, mask in corner.items():
        own_normal[:, np.flatnonzero(mask)] = pn.normal_control[:, k:k + 1]
    # on smooth edges every side takes the edge's own normals (one value per vertex)
    for k, (mask, _) in on_edge.items():
        cols = np.flatnonzero(mask)
        if cols.size == 0:
            continue
        eid = e.face_edge[:, k]
        smooth = e.smooth[eid]
        shared = edge_normals[index[:, cols] - base] * e.side_sign[:, k, None, None]
        own_normal[:, cols] = np.where(smooth[:, None, None], shared, own_normal[:, cols])
    # a flat face whose corners carry one normal keeps it bitwise at every point (still flat shaded)
    flat_same = pn.flat & np.all(pn.normal_control[:, :3] == pn.normal_control[:, :1], axis=(1, 2))
    own_normal[flat_same] = pn.normal_control[flat_same, :1]
    if num_inner:
        f_in = np.repeat(np.arange(num_f), num_inner)
        inner_points = pn.position(f_in, np.tile(weights[inner_cols], (num_f, 1)))
    else:
        inner_points = np.zeros((0, 3))
    vertices_out = np.concatenate([pn.points, edge_points, inner_points])
    num_v = len(vertices_out)
    # one normal per vertex: that of the lowest-numbered face at it; crease where faces disagree
    flat_index = index.reshape(-1)
    flat_normal = own_normal.reshape(-1, 3)
    _, first = np.unique(flat_index, return_index=True)          # every vertex is a grid point of a face
    normals = flat_normal[first]
    aligned = np.abs(_dot(flat_normal, normals[flat_index]))
    gap = np.sqrt(np.maximum(0.0, 2.0 - 2.0 * aligned))
    crease = np.bincount(flat_index, gap > 2 * np.sin(normal_tolerance / 2), num_v) > 0
    faces_out = index[:, tris].reshape(-1, 3)
    corner_normals_out = own_normal[:, tris].reshape(-1, 3, 3)
    parent = np.repeat(np.arange(num_f), len(tris))
    bary = np.tile((ij[tris] / n)[None], (num_f, 1, 1, 1)).reshape(-1, 3, 2)
    return RefinedSurface(vertices_out, faces_out, normals, crease, corner_normals_out, parent, bary, n,
                          int(np.sum(~e.smooth)), pn)


# ---------------------------------------------------------------------------------------- level
def _simplex_grid(steps: int = 12) -> np.ndarray:
    ij = np.array([(a, b) for a in range(steps + 1) for b in range(steps + 1 - a)], float)
    return np.stack([steps - ij[:, 0] - ij[:, 1], ij[:, 0], ij[:, 1]], axis=-1) / steps


def facet_sagitta(vertices, faces, corner_normals) -> np.ndarray:
    r"""Largest distance ``[F]`` (m) between every flat triangle and the smooth surface its corner
    normals describe (module docstring, *Level*): :math:`\max_{\mathbf w}|\sum_{i<j}w_iw_jc_{ij}|`,
    :math:`c_{ij} = \frac12(\mathbf p_j - \mathbf p_i)\cdot(\hat{\mathbf n}_j - \hat{\mathbf n}_i)`,
    over a barycentric grid of step 1/12 (the centroid and the edge midpoints on it)."""
    v, f, n = _check_mesh(vertices, faces, corner_normals, "facet_sagitta")
    tri = v[f]
    c = np.stack([0.5 * _dot(tri[:, b] - tri[:, a], n[:, b] - n[:, a]) for a, b in ((0, 1), (1, 2), (2, 0))], -1)
    w = _simplex_grid()
    pair = np.stack([w[:, 0] * w[:, 1], w[:, 1] * w[:, 2], w[:, 2] * w[:, 0]], -1)     # [G, 3]
    return np.abs(c @ pair.T).max(axis=1)


def refinement_level(vertices, faces, corner_normals, wavelength: float, max_sagitta: float | None = None,
                     max_triangles: int = MAX_REFINED_TRIANGLES) -> int:
    r"""Smallest uniform :func:`pn_refine` level whose sub-facets all stay within ``max_sagitta`` (m;
    default :data:`SAGITTA_FRACTION` x ``wavelength``) of the smooth surface: a level-:math:`n`
    sub-facet of a facet of sagitta :math:`d` (:func:`facet_sagitta`) has :math:`d/n^2`, so
    :math:`n = \lceil\sqrt{d_{max}/h_{max}}\rceil` (1 for a flat mesh). Raises
    :class:`SmoothSurfaceError`, naming the facet and the parameters, when the level would make more
    than ``max_triangles`` triangles."""
    if not np.isfinite(wavelength) or wavelength <= 0:
        raise SmoothSurfaceError(f"refinement_level: wavelength must be a positive length in m, got {wavelength!r}")
    h = SAGITTA_FRACTION * wavelength if max_sagitta is None else max_sagitta
    if not np.isfinite(h) or h <= 0:
        raise SmoothSurfaceError(f"refinement_level: max_sagitta must be a positive length in m, got {max_sagitta!r}")
    d = facet_sagitta(vertices, faces, corner_normals)
    worst = int(np.argmax(d))
    level = max(1, int(np.ceil(np.sqrt(d[worst] / h) - 1e-9)))
    if len(d) * level ** 2 > max_triangles:
        raise SmoothSurfaceError(
            f"refinement_level: facet {worst} departs {d[worst] * 1e3:.3g} mm from the smooth surface of its corner "
            f"normals, so max_sagitta={h * 1e3:.3g} mm needs level {level}: {len(d)} x {level}^2 = "
            f"{len(d) * level ** 2} triangles, more than max_triangles={max_triangles} (a degenerate or "
            f"very coarse mesh: check its normals, remesh it, or raise max_sagitta / max_triangles)")
    return level


__all__ = ["CREASE_TANGENT_ANGLE", "FLAT_SAGITTA_FRACTION", "MAX_HANDLE_ANGLE", "MAX_REFINED_TRIANGLES",
           "NORMAL_TOLERANCE", "PNTriangles", "RefinedSurface", "SAGITTA_FRACTION", "SmoothSurfaceError",
           "facet_sagitta", "handle_scale", "pn_refine", "pn_triangles", "refinement_level"]
