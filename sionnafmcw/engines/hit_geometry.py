r"""Position, shading normal, shape operator and velocity of ray hits on refined rigid surfaces, in one Dr.Jit kernel.

The PO render (:mod:`~sionnafmcw.engines.po_render`) turns every kept ray hit -- an object, a
triangle of its surface and barycentrics :math:`(b_1, b_2)` -- into a sample
(:meth:`~.po_render.SceneObject.hit_geometry`, numpy, per object). On a refined surface
(:mod:`sionnafmcw.smooth_surface`) that is, per hit:

* the hit's parameters in the parent (input) triangle,
  :math:`(\beta_1, \beta_2) = \sum_c w_c\,\boldsymbol\beta_c` (:math:`w = (1 - b_1 - b_2, b_1, b_2)`,
  :math:`\boldsymbol\beta_c` the sub-triangle's corners in the parent,
  :meth:`~sionnafmcw.smooth_surface.RefinedSurface.to_parent`);
* the point of the parent's cubic Bezier patch there, :math:`\mathbf b_{300} + \sum_{i\ne 300}
  B_i(\omega)(\mathbf b_i - \mathbf b_{300})` (:math:`\omega = (1 - \beta_1 - \beta_2, \beta_1, \beta_2)`;
  a flat parent: the plane, :math:`\sum_c\omega_c\mathbf p_c`), and the unit normal of its quadratic
  normal patch (:meth:`~sionnafmcw.smooth_surface.PNTriangles.position`, ``.normal``);
* the sub-facet's interpolated normal's shape operator
  :math:`\mathbf K = (\mathbf I - \hat{\mathbf m}\hat{\mathbf m}^T)\mathbf T/|\mathbf m|`,
  :math:`\mathbf m = \mathbf n_0 + b_1(\mathbf n_1 - \mathbf n_0) + b_2(\mathbf n_2 - \mathbf n_0)`
  (:func:`~sionnafmcw.physical_optics.shape_operator`, :math:`\mathbf T` per sub-triangle);
* placed with the object's rotation and translation, :math:`\mathbf x = \mathbf R\mathbf x_L + \mathbf p`,
  :math:`\hat{\mathbf n} = \mathbf R\hat{\mathbf n}_L`, :math:`\mathbf K = \mathbf R\mathbf K_L\mathbf R^T`,
  and moving with :math:`\mathbf v = \mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c)`
  (a turning rigid object; :math:`\boldsymbol\omega = 0`, :math:`\mathbf v_c` the uniform velocity
  otherwise).

Some sixty numpy passes over ``[K, 3]`` and ``[K, 3, 3]`` arrays with their temporaries, per object
and render: on the walk the largest numpy cost of a frame's PO. :class:`RefinedTables` gathers,
once per :class:`~.surfaces.SurfaceWorld`, the per-triangle data of every refined static and rigid
surface (they do not change from frame to frame in their own frames) into Dr.Jit arrays (mapped
from aligned numpy buffers of which the surfaces' own arrays become views: one copy);
:func:`refined_hit_geometry` evaluates every hit on them in one kernel (one lane per hit, gathers
only: no scatter or reduction, so the numbers do not depend on the thread count). It computes the
same expressions as the numpy path, in another order: they agree to rounding
(``tests/test_surfaces.py``). Hits on other surfaces (flat, unrefined or deforming) keep the numpy
path, which is cheap for them.

Measured (``python benchmarks/hit_geometry.py --scene <walk> --frames 1 30 60 90``, 2-core AMD EPYC,
best of 5, interleaved): a frame's hits take 13.1 ms instead of 32.4 (B/A 0.40; the body's first
bounce 0.26-0.27, its reflections, mostly on the flat walls, 0.68-0.75), positions within 4.4e-16 m,
normals 3.3e-16 and shape operators 2.6e-16 of their largest entry of the numpy path's.
"""

from __future__ import annotations

import numpy as np

from ..sionna_rt import aligned_copy, aligned_float64, array_backend, dr, drjit_array

#: Per-triangle and per-parent columns of :class:`RefinedTables` (flattened, row-major).
ROW_COLUMNS = (("parent_params", 6), ("corner_normals", 9), ("gradients", 9))
PARENT_COLUMNS = (("control", 30), ("normal_control", 18), ("flat", 1))


class RefinedTables:
    """The refined static and rigid surfaces of a world, concatenated (module docstring):
    ``offset [O]`` (each object's first row, -1 where its hits take the numpy path), ``parent``
    (UInt32 per row), and the columns of :data:`ROW_COLUMNS` / :data:`PARENT_COLUMNS` as flat
    Dr.Jit ``Float64`` arrays."""

    def __init__(self, surfaces):
        b = array_backend()
        num = len(surfaces)
        self.offset = np.full(num, -1, dtype=np.int64)
        rows, parents = {name: [] for name, _ in ROW_COLUMNS}, {name: [] for name, _ in PARENT_COLUMNS}
        parent_index, parent_starts = [], []
        row = prow = 0
        for k, s in enumerate(surfaces):
            if s.kind == "deforming" or s.refined is None or s.flat:
                continue
            pn = s.refined.surface
            self.offset[k] = row
            parent_index.append(s.refined.parent + prow)
            rows["parent_params"].append(s.refined.barycentric.reshape(-1, 6))
            rows["corner_normals"].append(s.corner_normals.reshape(-1, 9))
            rows["gradients"].append(s.normal_gradients().reshape(-1, 9))
            parents["control"].append(pn.control.reshape(-1, 30))
            parents["normal_control"].append(pn.normal_control.reshape(-1, 18))
            parents["flat"].append(pn.flat.astype(float).reshape(-1, 1))
            parent_starts.append(prow)
            row += len(s.faces)
            prow += len(pn.control)
        self.num_rows = row
        self.parent = drjit_array(b.UInt32, np.concatenate(parent_index), np.uint32) if parent_index else None
        # Dr.Jit maps the aligned numpy buffers (LLVM: no copy); the surfaces' own arrays become views
        # of the same buffers, so the tables cost only the normal gradients, which numpy never kept
        buffers = {name: aligned_copy(np.concatenate(v).ravel(), np.float64)
                   for name, v in (*rows.items(), *parents.items()) if v}
        self.columns = {name: b.Float64(buffer) for name, buffer in buffers.items()}
        for k in np.flatnonzero(self.offset >= 0):
            s, start = surfaces[k], int(self.offset[k])
            n = len(s.faces)
            view = {name: buffers[name][start * width:(start + n) * width] for name, width in ROW_COLUMNS}
            s.corner_normals = s.refined.corner_normals = view["corner_normals"].reshape(n, 3, 3)
            s.refined.barycentric = view["parent_params"].reshape(n, 3, 2)
            s._gradients = view["gradients"].reshape(n, 3, 3)
        for k, first in zip(np.flatnonzero(self.offset >= 0), parent_starts):
            pn = surfaces[k].refined.surface
            g = len(pn.control)
            pn.control = buffers["control"][first * 30:(first + g) * 30].reshape(g, 10, 3)
            pn.normal_control = buffers["normal_control"][first * 18:(first + g) * 18].reshape(g, 6, 3)

    def covers(self, obj) -> np.ndarray:
        """``[K]`` bool: the hits ``obj`` whose object is in the tables."""
        return self.offset[np.asarray(obj, dtype=np.int64)] >= 0


def _placements(objects, b):
    """Per object (Dr.Jit ``Float64`` columns, length O): rotation (9), translation (3), velocity at the
    centre (3), angular velocity (3), centre (3) of :meth:`~.po_render.SceneObject.hit_geometry`'s
    velocity field (zero angular velocity: the uniform velocity)."""
    values = np.zeros((len(objects), 21))
    for k, ob in enumerate(objects):
        place = ob.placement
        values[k, :9] = np.asarray(place.rotation, float).ravel()
        values[k, 9:12] = place.translation
        if ob.vertex_doppler and place.motion is not None:
            values[k, 12:15] = place.motion.velocity
            values[k, 15:18] = place.motion.angular_velocity
            values[k, 18:21] = place.motion.centroid
        else:
            values[k, 12:15] = place.velocity
    return [aligned_float64(values[:, c], b) for c in range(21)]


def refined_hit_geometry(tables: RefinedTables, objects, obj, triangle, bary):
    """Position, shading normal, velocity ``[K, 3]`` (world) and shape operator ``[K, 3, 3]`` of hits
    on the surfaces of ``tables`` (every ``obj`` covered: :meth:`RefinedTables.covers`): what
    :meth:`~.po_render.SceneObject.hit_geometry` gives, in one kernel (module docstring)."""
    b = array_backend()
    Float, UInt32 = b.Float64, b.UInt32
    obj = np.asarray(obj, dtype=np.int64)
    num = len(obj)
    if num == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3, 3))
    row = drjit_array(UInt32, tables.offset[obj] + np.asarray(triangle, dtype=np.int64), np.uint32)
    o = drjit_array(UInt32, obj, np.uint32)
    b1, b2 = aligned_float64(bary[:, 0], b), aligned_float64(bary[:, 1], b)
    col = tables.columns

    def gather(name, width, index, j):
        return dr.gather(Float, col[name], index * width + j)

    parent = dr.gather(UInt32, tables.parent, row)
    w0 = 1.0 - b1 - b2
    beta = [w0 * gather("parent_params", 6, row, j) + b1 * gather("parent_params", 6, row, 2 + j)
            + b2 * gather("parent_params", 6, row, 4 + j) for j in range(2)]
    u1, u2 = beta
    u0 = 1.0 - u1 - u2
    # the cubic patch: b300 + sum over the other nine control points of B_i (b_i - b300)
    sq0, sq1, sq2 = u0 * u0, u1 * u1, u2 * u2
    cubic = [sq1 * u1, sq2 * u2, 3 * sq0 * u1, 3 * u0 * sq1, 3 * sq1 * u2, 3 * u1 * sq2, 3 * u0 * sq2,
             3 * sq0 * u2, 6 * u0 * u1 * u2]            # control points 1..9 (b030 ... b111)
    first = [gather("control", 30, parent, c) for c in range(3)]
    curved = [first[c] + sum(cubic[i] * (gather("control", 30, parent, 3 * (i + 1) + c) - first[c])
                             for i in range(9)) for c in range(3)]
    plane = [u0 * first[c] + u1 * gather("control", 30, parent, 3 + c) + u2 * gather("control", 30, parent, 6 + c)
             for c in range(3)]
    is_flat = gather("flat", 1, parent, 0) > 0.5
    local = [dr.select(is_flat, plane[c], curved[c]) for c in range(3)]
    quad = [sq0, sq1, sq2, 2 * u0 * u1, 2 * u1 * u2, 2 * u0 * u2]
    n_pn = [sum(quad[i] * gather("normal_control", 18, parent, 3 * i + c) for i in range(6)) for c in range(3)]
    inv = 1.0 / dr.maximum(dr.sqrt(n_pn[0] * n_pn[0] + n_pn[1] * n_pn[1] + n_pn[2] * n_pn[2]), 1e-300)
    n_local = [x * inv for x in n_pn]
    # the sub-facet's shape operator (I - m m^T) T / |m|
    cn = [gather("corner_normals", 9, row, j) for j in range(9)]
    m = [cn[c] + b1 * (cn[3 + c] - cn[c]) + b2 * (cn[6 + c] - cn[c]) for c in range(3)]
    length = dr.sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2])
    mh = [x / length for x in m]
    t = [gather("gradients", 9, row, j) for j in range(9)]
    mt = [mh[0] * t[j] + mh[1] * t[3 + j] + mh[2] * t[6 + j] for j in range(3)]          # m^T T
    k_local = [(t[3 * i + j] - mh[i] * mt[j]) / length for i in range(3) for j in range(3)]
    # placed: x = R x_L + p, n = R n_L, K = R K_L R^T; v = v_c + w x (x - c)
    place = [dr.gather(Float, column, o) for column in _placements(objects, b)]
    rot = place[:9]
    position = [rot[3 * i] * local[0] + rot[3 * i + 1] * local[1] + rot[3 * i + 2] * local[2] + place[9 + i]
                for i in range(3)]
    normal = [rot[3 * i] * n_local[0] + rot[3 * i + 1] * n_local[1] + rot[3 * i + 2] * n_local[2] for i in range(3)]
    k_rot = [sum(rot[3 * i + a] * k_local[3 * a + j] for a in range(3)) for i in range(3) for j in range(3)]  # R K
    curvature = [sum(k_rot[3 * i + a] * rot[3 * j + a] for a in range(3)) for i in range(3) for j in range(3)]
    v, w, c = place[12:15], place[15:18], place[18:21]
    r = [position[i] - c[i] for i in range(3)]
    velocity = [v[0] + w[1] * r[2] - w[2] * r[1], v[1] + w[2] * r[0] - w[0] * r[2], v[2] + w[0] * r[1] - w[1] * r[0]]
    outputs = [*position, *normal, *velocity, *curvature]
    dr.eval(*outputs)
    values = np.stack([np.asarray(x.numpy()) for x in outputs], axis=-1)
    return (values[:, 0:3], values[:, 3:6], values[:, 6:9], values[:, 9:18].reshape(num, 3, 3))


__all__ = ["PARENT_COLUMNS", "ROW_COLUMNS", "RefinedTables", "refined_hit_geometry"]
