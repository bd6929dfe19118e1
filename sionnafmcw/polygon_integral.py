r"""The exact integral of a linear phase over a flat polygon: the PO of a flat face in closed form.

In the far field of a flat face (and on every small piece of it in the near field) the physical-optics
integral is the Fourier transform of the face's outline,

.. math:: I(\mathbf w) = \int_A e^{j\mathbf w\cdot\mathbf r}\,dA,

with :math:`\mathbf w = -2k\hat{\mathbf s}` for a monostatic radar looking along :math:`\hat{\mathbf s}`
(:math:`e^{-jk(r_t + r_r)}`, NOTES section 2). Gordon (W. B. Gordon, "Far-field approximations to the
Kirchhoff-Helmholtz representations of scattered fields", IEEE Trans. Antennas Propag. 23(4), 1975)
turns it into a sum over the polygon's edges, exact for any simple polygon, which this module evaluates
vectorised over polygons (:func:`polygon_phase_integral`).

Derivation
----------
Let the polygon have vertices :math:`\mathbf v_0 \dots \mathbf v_{V-1}` in one plane, counter-clockwise
about the unit normal :math:`\hat{\mathbf n}` (Newell's normal
:math:`\hat{\mathbf n} \propto \sum_k \mathbf v_k\times\mathbf v_{k+1}`, which is how the order defines it),
edges :math:`\mathbf e_k = \mathbf v_{k+1} - \mathbf v_k`, midpoints :math:`\mathbf c_k`. Split
:math:`\mathbf w = w_n\hat{\mathbf n} + \mathbf w_t`. On the plane :math:`\nabla_t e^{j\mathbf w\cdot\mathbf r}
= j\mathbf w_t e^{j\mathbf w\cdot\mathbf r}`, so the in-plane field
:math:`\mathbf F = \mathbf w_t e^{j\mathbf w\cdot\mathbf r}/(j|\mathbf w_t|^2)` has
:math:`\nabla_t\cdot\mathbf F = e^{j\mathbf w\cdot\mathbf r}` and the divergence theorem in the plane gives
the integral as the flux of :math:`\mathbf F` through the outline. The outward edge normal times the
edge's length is :math:`\mathbf e_k\times\hat{\mathbf n}`, and along the edge
:math:`\int_0^1 e^{j\mathbf w\cdot(\mathbf v_k + t\mathbf e_k)}dt = e^{j\mathbf w\cdot\mathbf c_k}
\operatorname{sinc}(\mathbf w\cdot\mathbf e_k/2)`, :math:`\operatorname{sinc}x = \sin x/x`:

.. math::
    I(\mathbf w) = \frac{1}{j|\mathbf w_t|^2}\sum_{k} \bigl[\mathbf w\cdot(\mathbf e_k\times\hat{\mathbf n})\bigr]\,
        e^{j\mathbf w\cdot\mathbf c_k}\,\operatorname{sinc}\frac{\mathbf w\cdot\mathbf e_k}{2}.

Gordon's own vertex form, :math:`\sum_k \hat{\mathbf n}\cdot(\mathbf e_{k-1}\times\mathbf e_k)
e^{j\mathbf w\cdot\mathbf v_k}/((\mathbf w\cdot\mathbf e_{k-1})(\mathbf w\cdot\mathbf e_k))` up to sign, is
the same sum with every sinc written as a difference of two vertex exponentials; it is singular when
:math:`\mathbf w_t` is perpendicular to an edge (:math:`\mathbf w\cdot\mathbf e_k = 0`), where the
edge-sum form is smooth: its sinc is 1 there, and an edge parallel to :math:`\mathbf w_t` simply has a
zero weight. Both forms divide by :math:`|\mathbf w_t|^2`: the terms, each of size
:math:`|\mathbf e_k|/|\mathbf w_t|`, cancel to the area :math:`A` as :math:`\mathbf w_t\to 0`, losing
:math:`\log_{10}(1/(|\mathbf w_t|\rho))` digits (:math:`\rho` the polygon's radius).

*The small-:math:`\mathbf w_t` form.* Where :math:`|\mathbf w_t|\rho` is below
:data:`SERIES_RADIUS` the integral is summed as a series instead. Fan the polygon from its vertex mean
:math:`\mathbf c` into the triangles :math:`(\mathbf c, \mathbf v_k, \mathbf v_{k+1})` with signed areas
:math:`A_k = \frac12\hat{\mathbf n}\cdot(\mathbf v_k - \mathbf c)\times(\mathbf v_{k+1} - \mathbf c)`
(Green's theorem: exact for any simple polygon, convex or not). On a triangle with vertex phases
:math:`a_i = \mathbf w\cdot(\mathbf p_i - \mathbf c)` the Hermite--Genocchi formula gives
:math:`\int_T e^{j\mathbf w\cdot(\mathbf r - \mathbf c)}dA = 2A_T\,\exp[ja_0, ja_1, ja_2]`, the second divided
difference of the exponential, whose Taylor series is

.. math::
    \int_T e^{j\mathbf w\cdot(\mathbf r - \mathbf c)}\,dA = 2A_T\sum_{m\ge 0}\frac{j^m\,h_m(a_0, a_1, a_2)}{(m + 2)!},

:math:`h_m` the complete homogeneous symmetric polynomial of degree :math:`m`
(:math:`h_m(x_1..x_n) = h_m(x_1..x_{n-1}) + x_n h_{m-1}(x_1..x_n)`). With :math:`|a_i| \le x =
|\mathbf w_t|\rho` the :math:`m`-th term is at most :math:`x^m/(2\,m!)`, so :data:`SERIES_TERMS` terms
leave :math:`< 10^{-19}A` at :math:`x \le 1`, and no term cancels another by more than the sum's own size.
At :math:`x \ge 1` the edge sum loses at most one digit. The two forms meet at :math:`x = 1`, and the
value is continuous there to rounding (``tests/test_polygon_integral.py``); at :math:`\mathbf w_t = 0`
the series is the area exactly, times :math:`e^{j\mathbf w\cdot\mathbf c}`.
"""

from __future__ import annotations

import math

import numpy as np

#: :math:`|\mathbf w_t|\rho` below which :func:`polygon_phase_integral` sums the Taylor series (module docstring).
SERIES_RADIUS = 1.0
#: Terms of that series: the last one below :math:`10^{-19}` of the area at :data:`SERIES_RADIUS`.
SERIES_TERMS = 22


class PolygonError(ValueError):
    """Polygons or wave vectors of the wrong shape; the message names the parameter."""


def cross(a, b) -> np.ndarray:
    r""":math:`\mathbf a\times\mathbf b` over the last axis (length 3), broadcast: numpy's ``cross`` without its
    axis handling, which dominates on the small arrays the polygon clipping works on."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def polygon_normals(vertices) -> tuple[np.ndarray, np.ndarray]:
    r"""``(normal [..., 3], area [...])``: Newell's unit normal of the polygons ``vertices [..., V, 3]``
    (counter-clockwise about it) and their area; a degenerate polygon gets area 0 and normal 0."""
    v = np.asarray(vertices, float)
    twice = np.sum(cross(v, np.roll(v, -1, axis=-2)), axis=-2)
    norm = np.sqrt(np.sum(twice * twice, axis=-1))
    normal = np.divide(twice, norm[..., None], out=np.zeros_like(twice), where=norm[..., None] > 0)
    return normal, norm / 2


def _sinc(x):
    """sin(x)/x, 1 at 0 (numpy's sinc is the normalised one)."""
    return np.sinc(np.asarray(x) / np.pi)


def _series(v, w, normal, centre):
    r"""The Taylor form (module docstring) of :math:`\int e^{j\mathbf w\cdot(\mathbf r - \mathbf c)}dA` for
    polygons ``v [P, V, 3]``, ``w [P, 3]``, fanned from ``centre [P, 3]``."""
    p = v - centre[:, None]
    q = np.roll(p, -1, axis=1)
    area = 0.5 * np.einsum("pvi,pi->pv", cross(p, q), normal)          # [P, V] signed fan triangles
    a1 = np.einsum("pvi,pi->pv", p, w)
    a2 = np.einsum("pvi,pi->pv", q, w)
    # h_m over the variables (0, a1, a2): the fan's apex has phase 0, so h_m(0, a1, a2) = h_m(a1, a2)
    h2 = np.ones_like(a1)                                               # h_0(a1, a2)
    power = np.ones_like(a1)                                            # a1^m = h_m(a1)
    total = h2 / 2.0                                                    # m = 0: h_0 / 2!
    jm = 1.0 + 0j
    for m in range(1, SERIES_TERMS):
        power = power * a1
        h2 = power + a2 * h2
        jm *= 1j
        total = total + jm * h2 / math.factorial(m + 2)
    return np.sum(2 * area * total, axis=1)


def polygon_phase_integral(vertices, w) -> np.ndarray:
    r""":math:`I(\mathbf w) = \int_A e^{j\mathbf w\cdot\mathbf r}\,dA` (m^2, complex) over flat polygons.

    ``vertices [..., V, 3]`` (m): every polygon's vertices in order around it (simple, convex or not, in
    one plane; the sense of the order does not matter: the normal is taken from it); ``w [..., 3]`` (rad/m),
    broadcast against the polygons. Exact (module docstring): the edge sum where
    :math:`|\mathbf w_t|\rho \ge` :data:`SERIES_RADIUS`, the Taylor series below; a degenerate polygon
    integrates to 0.
    """
    v = np.asarray(vertices, float)
    w = np.asarray(w, float)
    if v.ndim < 2 or v.shape[-1] != 3 or v.shape[-2] < 3:
        raise PolygonError(f"polygon_phase_integral: vertices must have shape [..., V >= 3, 3], got {v.shape}")
    if w.shape[-1:] != (3,):
        raise PolygonError(f"polygon_phase_integral: w must have shape [..., 3], got {w.shape}")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(w))):
        raise PolygonError("polygon_phase_integral: vertices and w must be finite")
    shape = np.broadcast_shapes(v.shape[:-2], w.shape[:-1])
    nv = v.shape[-2]
    v = np.broadcast_to(v, shape + (nv, 3)).reshape(-1, nv, 3)
    w = np.broadcast_to(w, shape + (3,)).reshape(-1, 3)
    normal, area = polygon_normals(v)
    centre = v.mean(axis=1)
    w_t = w - np.einsum("pi,pi->p", w, normal)[:, None] * normal
    wt2 = np.einsum("pi,pi->p", w_t, w_t)
    radius = np.max(np.linalg.norm(v - centre[:, None], axis=-1), axis=1)
    small = np.sqrt(wt2) * radius < SERIES_RADIUS
    out = np.zeros(v.shape[0], dtype=complex)
    live = area > 0
    s = np.flatnonzero(small & live)
    if s.size:
        out[s] = np.exp(1j * np.einsum("pi,pi->p", w[s], centre[s])) * _series(v[s], w[s], normal[s], centre[s])
    e = np.flatnonzero(~small & live)
    if e.size:
        ve, we, ne = v[e], w[e], normal[e]
        edges = np.roll(ve, -1, axis=1) - ve
        mids = ve + edges / 2
        weight = np.einsum("pi,pvi->pv", we, cross(edges, ne[:, None]))
        along = np.einsum("pi,pvi->pv", we, edges)
        # phases relative to the vertex mean, so that the sum's terms carry no large common phase
        phase = np.einsum("pi,pvi->pv", we, mids - centre[e][:, None])
        terms = weight * np.exp(1j * phase) * _sinc(along / 2)
        out[e] = np.exp(1j * np.einsum("pi,pi->p", we, centre[e])) * np.sum(terms, axis=1) / (1j * wt2[e])
    return out.reshape(shape)


__all__ = ["PolygonError", "SERIES_RADIUS", "SERIES_TERMS", "cross", "polygon_normals", "polygon_phase_integral"]
