r"""Objects of a few plane faces (corner reflectors, plates) in the PO render: every exit aperture exact.

Why the sampled render is not enough here
-----------------------------------------
The render (:mod:`~sionnafmcw.engines.po_render`) samples a surface with ray tubes and integrates each
tube's footprint exactly in its linear phase. Inside an aperture the footprints tile the surface, but a
tube that the aperture's outline cuts counts whole or not at all. Where a chain has a stationary point
that error is small against the echo; a corner reflector seen 30-45 degrees off its axis has none on
any face or chain, its echo *is* the outline's edge terms
(:mod:`sionnafmcw.polygon_integral`: :math:`\int_A e^{j\mathbf w\cdot\mathbf r}dA` is a sum over the
edges, of size :math:`1/|\mathbf w_t|` per unit of length), and every cut tube adds an edge term of its
own, which does not fall until the tubes are well under :math:`1/|\mathbf w_t| = \lambda/(4\pi\sin\theta)`
(0.4 mm at 77 GHz, 45 degrees: ``benchmarks/po_flat_faces.py``). Splitting tubes along the outline
(:mod:`~sionnafmcw.engines.bounce_sampling`) converges too slowly for that.

For an object whose surface is a few convex plane faces the outlines are known exactly: the faces clipped
to what the radar lights and sees, and every chain's exit aperture clipped by the images of the faces
before it (:func:`sionnafmcw.flat_face_po.chain_apertures`, central projections from the radar's point,
exact at any range). This module integrates those apertures instead of sampling them.

The pieces and their integral
-----------------------------
Each aperture polygon is cut by a square grid of step :math:`s` in its plane (the render's first-bounce
sample size for the object, :func:`~sionnafmcw.physical_optics.render_resolution` times its range):

* a cell wholly inside is a sample with the parallelogram footprint of its edges, whose integral the PO
  kernel takes exactly in the linear phase and to second order in the quadratic
  (:func:`~sionnafmcw.physical_optics.footprint_factor`), as every render sample's;
* a cell the outline cuts is the convex polygon :math:`P` (the cell clipped to the aperture). With
  :math:`\mathbf x` about its centroid, the two-way phase :math:`k(r_t + r_r) = k(r_{t,c} + r_{r,c})
  - \mathbf w\cdot\mathbf x + q(\mathbf x) + O(x^3)`, :math:`\mathbf w = -k(\hat{\mathbf s}_t + \hat{\mathbf s}_r)`,
  :math:`q = \mathbf x^T\mathbf Q\mathbf x`, :math:`\mathbf Q = \frac k2\sum_{i=t,r}(\mathbf I
  - \hat{\mathbf s}_i\hat{\mathbf s}_i^T)/r_i`, and with :math:`\mu` the mean of :math:`q` over :math:`P`

  .. math::
      \frac1{|P|}\int_P e^{j\mathbf w\cdot\mathbf x - jq}\,dA = \frac{e^{-j\mu}}{|P|}\Bigl[(1 + j\mu)I_0
      + j\sum_{ab}Q_{ab}\,\partial_a\partial_b I_0\Bigr] + O\bigl((q - \mu)^2\bigr),
      \qquad I_0(\mathbf w) = \int_P e^{j\mathbf w\cdot\mathbf x}dA,

  since :math:`\int_P x_ax_b e^{j\mathbf w\cdot\mathbf x}dA = -\partial_a\partial_b I_0`: the same order as
  the cells' footprint factor. :math:`I_0` is exact (:func:`~sionnafmcw.polygon_integral.polygon_phase_integral`),
  its second derivatives along the plane are central differences of it (step :math:`\delta =`
  :data:`DERIVATIVE_STEP`:math:`/\rho`, :math:`\rho` the polygon's radius: truncation
  :math:`(\delta\rho)^2/12 \approx 2\times10^{-4}` of the term, rounding :math:`10^{-16}/(\delta\rho)^2`).
  :func:`outline_factor` gives this factor for every element pair; the kernel gives the rest of the
  contribution with the piece as a point sample (:func:`~.po_kernel.element_pair_po`,
  ``in_sample_phase=False``).

So every piece is exact in its linear phase and second order in its quadratic, and the pieces tile each
aperture exactly: what is left is the quadratic phase's second order, the interior's error, which the
render's rule bounds. Raising ``samples_across`` shrinks the cells, and the echo does not move beyond
that.

Rays, visibility, motion
------------------------
A piece at :math:`\mathbf p` on the last face of chain :math:`(f_1, \dots, f_d)` is reached by the ray
from the origin :math:`\mathbf o` towards :math:`M_1M_2\cdots M_{d-1}\mathbf p` (the mirror maps of the
faces before it: the chain unfolded). Those rays are cast and reflected by the render's own
:func:`~sionnafmcw.engines.po_render.render` machinery (:func:`~.po_render.reflect`), so visibility
against the other objects of the scene, the materials' reflection coefficients, velocities and
accelerations, image maps and Doppler are the engine's; a piece whose ray ends elsewhere (another
object in the way, or a hit off its face by rounding at an outline) carries nothing. Only the apertures'
outlines come from the exact geometry.

The tube render's own chains of such an object (every bounce on it) carry no PO
(:attr:`~.po_render.Render.one_object`); its chains to and from other objects (a reflector and the
ground) stay the tube render's. Which objects: a static or rigid, flat-shaded surface whose triangles lie
in at most :data:`MAX_PLANE_FACES` planes, each plane's triangles one convex polygon, and whose bounding
box is at most :data:`MAX_EXTENT` across: corner reflectors, plates, small boxes (a monitor's glass).
Large faces (a room's walls, a cabinet, a door) are left to the render: their echo is their specular
spots and the corner lines the bounce rule resolves, and their outlines would cost many cut cells.
"""

from __future__ import annotations

import numpy as np

from ..flat_face_po import chain_apertures
from ..polygon_integral import cross, polygon_normals, polygon_phase_integral

#: Most planes of an object integrated exactly (a box has six).
MAX_PLANE_FACES = 6
#: Largest bounding-box diagonal (m) of an object integrated exactly (module docstring).
MAX_EXTENT = 1.0
#: Triangles lie in one plane when their normals agree to this (rad) and their offsets to this share of
#: the object's size (a PLY's float32 vertices tilt a 2 cm triangle's normal by ~1e-5 rad); a surface is
#: flat where its shading normals agree with its triangles' planes to this too.
PLANE_TOLERANCE = 1e-4
#: :math:`\delta\rho` of the central differences of :func:`outline_factor` (module docstring).
DERIVATIVE_STEP = 0.05
#: A piece's ray must end within this share of its range from the piece (float32 casts: ~1e-7).
HIT_TOLERANCE = 1e-5


def _hull_2d(points) -> np.ndarray:
    """Indices of the convex hull of ``points [K, 2]`` in counter-clockwise order (monotone chain; a point
    within :data:`PLANE_TOLERANCE` of the size of the line through its neighbours is no corner)."""
    order = np.lexsort((points[:, 1], points[:, 0]))
    pts = points[order]
    eps = PLANE_TOLERANCE * float(np.ptp(points, axis=0).max()) ** 2

    def half(seq):
        out = []
        for i in seq:
            while len(out) >= 2:
                a, b = pts[out[-2]], pts[out[-1]]
                if (b[0] - a[0]) * (pts[i][1] - a[1]) - (b[1] - a[1]) * (pts[i][0] - a[0]) <= eps:
                    out.pop()
                else:
                    break
            out.append(i)
        return out

    lower, upper = half(range(len(pts))), half(range(len(pts) - 1, -1, -1))
    return order[np.array(lower[:-1] + upper[:-1], dtype=np.int64)]


def plane_faces(vertices, faces, max_faces: int = MAX_PLANE_FACES) -> np.ndarray | None:
    """The surface ``vertices [V, 3]``, ``faces [F, 3]`` as convex plane polygons ``[G, W, 3]`` (one per plane,
    all with the same number of corners; fanned into triangles ``[G', 3, 3]`` when their counts differ), or
    None when its triangles lie in more than ``max_faces`` planes or a plane's triangles are not one convex
    polygon (the union's area must be its hull's)."""
    v = np.asarray(vertices, float)
    tri = v[np.asarray(faces, np.int64)]
    if len(tri) == 0:
        return None
    area_normal = cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    twice = np.linalg.norm(area_normal, axis=1)
    live = twice > 0
    tri, area_normal, twice = tri[live], area_normal[live], twice[live]
    if len(tri) == 0:
        return None
    normal = area_normal / twice[:, None]
    size = float(np.max(np.linalg.norm(v - v.mean(axis=0), axis=1))) or 1.0
    groups: list[list[int]] = []
    keys: list[tuple[np.ndarray, np.ndarray]] = []
    for i, (n, p) in enumerate(zip(normal, tri)):
        for g, (m, q) in enumerate(keys):
            if abs(n @ m) >= 1 - PLANE_TOLERANCE ** 2 / 2 and np.all(np.abs((p - q) @ m) <= PLANE_TOLERANCE * size):
                groups[g].append(i)
                break
        else:
            if len(keys) == max_faces:
                return None
            keys.append((n, p[0]))
            groups.append([i])
    polygons = []
    for (n, _), members in zip(keys, groups):
        u, w = _plane_basis(n)
        corners = tri[members].reshape(-1, 3)
        flat = np.stack([corners @ u, corners @ w], axis=1)
        hull = corners[_hull_2d(flat)]
        area = polygon_normals(hull)[1]
        if abs(area - 0.5 * twice[members].sum()) > PLANE_TOLERANCE * area:
            return None
        polygons.append(hull)
    if len({len(p) for p in polygons}) == 1:
        return np.stack(polygons)
    fans = [np.stack([p[0] * np.ones((len(p) - 2, 3)), p[1:-1], p[2:]], axis=1) for p in polygons]
    return np.concatenate(fans)


def _shaded_flat(surface) -> bool:
    """True when every corner normal of ``surface`` is its triangle's normal within :data:`PLANE_TOLERANCE`
    (either side): the render reflects off the faces' planes."""
    tri = surface.vertices[surface.faces]
    n = cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1)
    live = norm > 0
    n = n[live] / norm[live, None]
    c = surface.corner_normals[live] / np.linalg.norm(surface.corner_normals[live], axis=-1, keepdims=True)
    return bool(np.all(np.abs(np.einsum("fci,fi->fc", c, n)) >= 1 - PLANE_TOLERANCE ** 2 / 2))


def exact_objects(objects) -> dict:
    """``{index: local polygons}`` of the :func:`~.po_render.scene_objects` integrated here (module docstring),
    the polygons in each surface's own frame (found once per surface and kept on it)."""
    out = {}
    for k, obj in enumerate(objects):
        surface = obj.surface
        if surface.kind == "deforming":
            continue
        faces = surface._plane_faces
        if faces is False:
            lo, hi = surface.vertices.min(axis=0), surface.vertices.max(axis=0)
            faces = plane_faces(surface.vertices, surface.faces) \
                if np.linalg.norm(hi - lo) <= MAX_EXTENT and _shaded_flat(surface) else None
            surface._plane_faces = faces
        if faces is not None:
            out[k] = faces
    return out


def _plane_basis(normal):
    u = cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return u, cross(normal, u)


def clip_convex(cells, counts, edges_from, edges_to):
    """Convex 2-D polygons ``cells [C, W, 2]`` (the first ``counts [C]`` corners of each, counter-clockwise)
    clipped to the convex polygon whose edges run ``edges_from [E, 2]`` -> ``edges_to [E, 2]``
    (counter-clockwise): Sutherland--Hodgman on every edge, all cells at once. Returns the clipped
    ``(cells [C, W', 2], counts [C])`` (count 0: nothing left)."""
    for a, b in zip(edges_from, edges_to):
        width = cells.shape[1]
        valid = np.arange(width)[None] < counts[:, None]
        # signed side (positive inside: left of a -> b)
        side = (b[0] - a[0]) * (cells[..., 1] - a[1]) - (b[1] - a[1]) * (cells[..., 0] - a[0])
        nxt = (np.arange(width)[None] + 1) % np.maximum(counts[:, None], 1)
        p_next = np.take_along_axis(cells, nxt[..., None], axis=1)
        s_next = np.take_along_axis(side, nxt, axis=1)
        keep = valid & (side >= 0)
        crossing = valid & (((side > 0) & (s_next < 0)) | ((side < 0) & (s_next > 0)))
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(crossing, side / (side - s_next), 0.0)
        point = cells + frac[..., None] * (p_next - cells)
        cand = np.stack([cells, point], axis=2).reshape(len(cells), 2 * width, 2)
        ok = np.stack([keep, crossing], axis=2).reshape(len(cells), 2 * width)
        order = np.argsort(~ok, axis=1, kind="stable")
        cells = np.take_along_axis(cand, order[..., None], axis=1)
        counts = ok.sum(axis=1)
        cells = cells[:, :max(int(counts.max(initial=0)), 1)]
        counts = np.where(counts >= 3, counts, 0)
    return cells, counts


def aperture_pieces(polygon, step: float):
    """The convex ``polygon [V, 3]`` cut by a square grid of ``step`` (m) in its plane: ``(centres [C, 3],
    edges [C, 2, 3])`` of the cells wholly inside and the list of the cut cells' polygons (each ``[V', 3]``)."""
    normal = polygon_normals(polygon)[0]
    u, w = _plane_basis(normal)
    origin = polygon[0]
    xy = np.stack([(polygon - origin) @ u, (polygon - origin) @ w], axis=1)
    if np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]) < 0:
        xy = xy[::-1]   # counter-clockwise
    i0, i1 = int(np.floor(xy[:, 0].min() / step)), int(np.ceil(xy[:, 0].max() / step))
    j0, j1 = int(np.floor(xy[:, 1].min() / step)), int(np.ceil(xy[:, 1].max() / step))
    ii, jj = np.meshgrid(np.arange(i0, i1), np.arange(j0, j1), indexing="ij")
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    cells = (np.stack([ii.ravel(), jj.ravel()], axis=1)[:, None, :] + corners[None]) * step      # [C, 4, 2]
    a, b = xy, np.roll(xy, -1, axis=0)
    side = (b[None, None, :, 0] - a[None, None, :, 0]) * (cells[..., 1:2] - a[None, None, :, 1]) \
        - (b[None, None, :, 1] - a[None, None, :, 1]) * (cells[..., 0:1] - a[None, None, :, 0])      # [C, 4, E]
    inside = np.all(side >= 0, axis=(1, 2))
    outside = np.any(np.all(side <= 0, axis=1), axis=1)
    centre = cells[inside].mean(axis=1)
    centres = origin + centre[:, :1] * u + centre[:, 1:] * w
    edges = np.broadcast_to(np.stack([step * u, step * w]), (len(centres), 2, 3)).copy()
    cut, counts = clip_convex(cells[~inside & ~outside], np.full(int(np.sum(~inside & ~outside)), 4), a, b)
    pieces = []
    for c, n in zip(cut, counts):
        if n >= 3:
            poly = origin + c[:n, :1] * u + c[:n, 1:] * w
            if polygon_normals(poly)[1] > 0:
                pieces.append(poly)
    return centres, edges, pieces


def unfolded_points(points, chain, faces) -> np.ndarray:
    r""":math:`M_{f_1}M_{f_2}\cdots M_{f_{d-1}}\mathbf p` for ``points [K, 3]`` on the last face of ``chain``: the
    points the first ray of the chain points at from the origin (module docstring)."""
    q = np.asarray(points, float)
    for f in reversed(chain[:-1]):
        normal = polygon_normals(faces[f])[0]
        q = q - 2 * np.outer((q - faces[f][0]) @ normal, normal)
    return q


def _padded(polygons) -> np.ndarray:
    """Convex polygons of different corner counts as one ``[K, W, 3]`` array, each padded by repeating its last
    corner: a zero-length edge adds nothing to the polygon's integral, area or moments."""
    width = max(len(p) for p in polygons)
    return np.stack([np.concatenate([p, np.repeat(p[-1:], width - len(p), axis=0)]) for p in polygons])


def outline_factor(outline, centre, normal, tx_images, rx, wavelength: float) -> np.ndarray:
    r"""``[M, N, K]``: the in-sample factor (module docstring) of the convex polygons ``outline [K, W, 3]``
    (world; ``centre [K, 3]`` their centroids, ``normal [K, 3]``) for the Tx elements' images ``tx_images [M, K, 3]``
    and the Rx elements ``rx [N, 3]``: the piece's integral over its area, its first phase term about the
    centroid exact, the second to first order."""
    k = 2 * np.pi / wavelength
    d_t = centre[None] - tx_images
    r_t = np.linalg.norm(d_t, axis=-1)
    s_t = d_t / r_t[..., None]                                    # [M, K, 3]
    d_r = centre[None] - rx[:, None]
    r_r = np.linalg.norm(d_r, axis=-1)
    s_r = d_r / r_r[..., None]                                    # [N, K, 3]
    rel = outline - centre[:, None]                               # [K, W, 3]
    area = polygon_normals(outline)[1]
    radius = np.max(np.linalg.norm(rel, axis=-1), axis=1)
    u = cross(normal, np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = cross(normal, u)
    w = -k * (s_t[:, None] + s_r[None])                           # [M, N, K, 3]
    delta = (DERIVATIVE_STEP / radius)[:, None]                   # [K, 1]
    du, dv = delta * u, delta * v

    def integral(shift):
        return polygon_phase_integral(rel, w + shift)

    i0 = integral(0.0)
    iu = (integral(du) - 2 * i0 + integral(-du)) / delta[:, 0] ** 2
    iv = (integral(dv) - 2 * i0 + integral(-dv)) / delta[:, 0] ** 2
    iuv = (integral(du + dv) - integral(du - dv) - integral(dv - du) + integral(-du - dv)) / (4 * delta[:, 0] ** 2)
    # Q restricted to the plane: Q_ab = k/2 sum_i (e_a.e_b - (s_i.e_a)(s_i.e_b))/r_i, e_a in {u, v}
    su_t, sv_t = np.einsum("mki,ki->mk", s_t, u), np.einsum("mki,ki->mk", s_t, v)
    su_r, sv_r = np.einsum("nki,ki->nk", s_r, u), np.einsum("nki,ki->nk", s_r, v)
    q_uu = k / 2 * ((1 - su_t ** 2) / r_t)[:, None] + k / 2 * ((1 - su_r ** 2) / r_r)[None]
    q_vv = k / 2 * ((1 - sv_t ** 2) / r_t)[:, None] + k / 2 * ((1 - sv_r ** 2) / r_r)[None]
    q_uv = -k / 2 * (su_t * sv_t / r_t)[:, None] - k / 2 * (su_r * sv_r / r_r)[None]
    # mu: the mean of q, from the polygon's second moments in the plane (fan of triangles about the centroid)
    x, y = np.einsum("kwi,ki->kw", rel, u), np.einsum("kwi,ki->kw", rel, v)
    x2, y2 = np.roll(x, -1, axis=1), np.roll(y, -1, axis=1)
    cr = x * y2 - x2 * y
    signed = np.sum(cr, axis=1) / 2
    m_xx = np.sum(cr * (x * x + x * x2 + x2 * x2), axis=1) / 12 / signed
    m_yy = np.sum(cr * (y * y + y * y2 + y2 * y2), axis=1) / 12 / signed
    m_xy = np.sum(cr * (x * y2 + 2 * x * y + 2 * x2 * y2 + x2 * y), axis=1) / 24 / signed
    mu = q_uu * m_xx + q_vv * m_yy + 2 * q_uv * m_xy
    second = q_uu * iu + q_vv * iv + 2 * q_uv * iuv
    return np.exp(-1j * mu) * ((1 + 1j * mu) * i0 + 1j * second) / area


def piece_factor(bounce, tx_positions, rx_positions, wavelength: float) -> np.ndarray:
    """``[M, N, P]``: :func:`outline_factor` of the cut pieces of a render (``bounce.outline`` set) for the Tx
    elements (through each piece's mirror map) and the Rx elements (world, m)."""
    return outline_factor(bounce.outline, bounce.samples.position, bounce.samples.normal,
                          bounce.image_of(tx_positions), np.atleast_2d(np.asarray(rx_positions, float)), wavelength)


def chain_pieces(polygons, origin, depth: int, step: float) -> list:
    """Per chain of ``polygons [F, W, 3]`` (world) seen from ``origin`` up to ``depth`` bounces
    (:func:`~sionnafmcw.flat_face_po.chain_apertures`): ``(chain, cells (centres, edges), cut polygons)``."""
    out = []
    for chain, _, pieces in chain_apertures(polygons, origin, depth):
        centres, edges, cut = [], [], []
        for piece in pieces:
            c, e, p = aperture_pieces(piece, step)
            centres.append(c)
            edges.append(e)
            cut.extend(p)
        out.append((chain, (np.concatenate(centres), np.concatenate(edges)), cut))
    return out


def _rays(directions, step: float, distance):
    """Two angular steps ``[K, 3]`` square to ``directions`` and the solid angle of a ray of a piece of size
    ``step`` (m) at ``distance`` (m): what a render sample carries (the pieces' own areas replace them)."""
    helper = np.where(np.abs(directions[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    a = cross(directions, helper)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = cross(directions, a)
    angle = step / distance
    return a * angle[:, None], b * angle[:, None], angle ** 2


def _on_face(render, polygon, shape_id: int, distance) -> np.ndarray:
    """``[P]`` bool: the samples of ``render`` on the object ``shape_id`` and in the plane of ``polygon``."""
    normal = polygon_normals(polygon)[0]
    off = np.abs((render.samples.position - polygon[0]) @ normal)
    return (render.samples.object_id == shape_id) & (off <= HIT_TOLERANCE * distance)


def exact_renders(world, objects, exact: dict, origin, rotation, wavelength: float, depth: int,
                  samples_across: int, group: str = "all", origin_motion=None) -> list:
    """The renders (:class:`~.po_render.Render`) of every chain of the objects ``exact`` (:func:`exact_objects`)
    seen from ``origin``: per object and bounce one render of the wholly-inside cells (footprint edges set)
    and one of the cut pieces (``outline`` set), each piece reached by its own cast and reflected ray
    (module docstring)."""
    from ..physical_optics import render_resolution

    origin = np.asarray(origin, float)
    out = []
    for k, local in exact.items():
        obj = objects[k]
        polygons = obj.placement.to_world(local.reshape(-1, 3)).reshape(local.shape)
        ranges = np.linalg.norm(polygons.reshape(-1, 3) - origin, axis=1)
        if ranges.min() <= 0:
            continue
        extent = float(np.linalg.norm(obj.box_vertices.max(axis=0) - obj.box_vertices.min(axis=0)))
        r_max = float(ranges.max())
        step = render_resolution(extent, r_max, wavelength, samples_across=samples_across) * r_max
        # the pieces depend on the faces' placement, the origin and the step only: kept on the surface for
        # the next frame (a radar at rest before a static or resting object finds the same ones)
        key = (origin.tobytes(), polygons.tobytes(), step, int(depth))
        cached = obj.surface._exact_pieces
        if cached is not None and cached[0] == key:
            pieces = cached[1]
        else:
            pieces = chain_pieces(polygons, origin, depth, step)
            obj.surface._exact_pieces = (key, pieces)
        if pieces:
            out.extend(_object_renders(world, objects, k, polygons, pieces, step, origin, rotation, wavelength,
                                       group, origin_motion))
    return out


def _centroid(polygon) -> np.ndarray:
    """The area centroid of the convex ``polygon [V, 3]``."""
    a = polygon[0]
    b, c = polygon[1:-1], polygon[2:]
    w = np.linalg.norm(cross(b - a, c - a), axis=1)
    return ((a + b + c) / 3 * w[:, None]).sum(axis=0) / w.sum()


def _object_renders(world, objects, k, polygons, pieces, step, origin, rotation, wavelength, group, origin_motion):
    """The renders of one object's pieces (``chain_pieces``): all its rays cast at once and reflected
    bounce by bounce, each kept where it hits the face its chain expects next; per bounce a render of the
    cells and one of the cut pieces."""
    from .po_render import _samples, first_bounce, reflect

    obj = objects[k]
    depth = max(len(chain) for chain, _, _ in pieces)
    points, chains, edges, outlines, is_cut = [], [], [], [], []
    for chain, (centres, cell_edges), cut in pieces:
        padded = chain + (-1,) * (depth - len(chain))
        for p, e, o, c in ((centres, cell_edges, None, False),
                           (np.array([_centroid(q) for q in cut]).reshape(-1, 3), None, cut, True)):
            if len(p) == 0:
                continue
            points.append(p)
            chains.append(np.repeat([padded], len(p), axis=0))
            target = unfolded_points(p, chain, polygons)
            edges.append(np.zeros((len(p), 2, 3)) if e is None else e)
            outlines.extend([None] * len(p) if o is None else o)
            is_cut.append(np.full(len(p), c))
            points[-1] = (p, target)
    if not points:
        return []
    point = np.concatenate([p for p, _ in points])
    target = np.concatenate([q for _, q in points])
    chain = np.concatenate(chains)
    edges = np.concatenate(edges)
    is_cut = np.concatenate(is_cut)
    length = np.sum(chain >= 0, axis=1)
    normals = polygon_normals(polygons)[0]
    d = target - origin
    dist = np.linalg.norm(d, axis=1)
    direction = d / dist[:, None]
    valid, t, hit_obj, prim, uv = world.cast(origin, direction, group)
    n0, f0 = normals[chain[:, 0]], polygons[chain[:, 0], 0]
    t_face = np.einsum("pi,pi->p", f0 - origin, n0) / np.einsum("pi,pi->p", direction, n0)
    rows = np.flatnonzero(valid & (hit_obj == k) & (np.abs(t - t_face) <= HIT_TOLERANCE * dist))
    if rows.size == 0:
        return []
    s_az, s_el, solid = _rays(direction[rows], step, dist[rows])
    samples, incident, acceleration = _samples(world, objects, hit_obj[rows], prim[rows], uv[rows], origin, s_az,
                                               s_el, solid, rotation, wavelength)
    bounce = first_bounce(samples, incident, s_az, s_el, origin, {obj.name: float(step / dist.max())},
                          len(point), acceleration, None if acceleration is None else origin_motion)
    out = []
    for d in range(1, depth + 1):
        if d > 1:
            bounce = reflect(world, bounce, objects, rotation, wavelength, group=group)
            rows = rows[bounce.parent]
            face = chain[rows, d - 1]
            off = np.abs(np.einsum("pi,pi->p", bounce.samples.position - polygons[face, 0], normals[face]))
            ok = (bounce.samples.object_id == obj.shape_id) & (off <= HIT_TOLERANCE * dist[rows])
            bounce, rows = bounce.select(ok), rows[ok]
        done = (length[rows] == d) & (np.linalg.norm(bounce.samples.position - point[rows], axis=1)
                                      <= HIT_TOLERANCE * dist[rows])
        for cut in (False, True):
            sel = done & (is_cut[rows] == cut)
            if not np.any(sel):
                continue
            part, picked = bounce.select(sel), rows[sel]
            s = part.samples
            if cut:
                s.area = polygon_normals(_padded([outlines[i] for i in picked]))[1]
                s.edges = None
                part.outline = _padded([outlines[i] for i in picked])
            else:
                s.area = np.full(len(picked), step * step)
                s.edges = edges[picked]
            out.append(part)
        more = length[rows] > d
        if not np.any(more):
            break
        bounce, rows = bounce.select(more), rows[more]
    return out


__all__ = ["DERIVATIVE_STEP", "HIT_TOLERANCE", "MAX_EXTENT", "MAX_PLANE_FACES", "PLANE_TOLERANCE",
           "aperture_pieces", "chain_pieces", "clip_convex", "exact_objects", "exact_renders", "outline_factor",
           "piece_factor", "plane_faces",
           "unfolded_points"]
