r"""Independent reference: the near-field physical-optics integral by plain quadrature over a mesh.

Written apart from :mod:`sionnafmcw.physical_optics` (it imports nothing from it): every lit
triangle is split into :math:`s^2` congruent sub-triangles of edge at most ``max_edge``
(default :math:`\lambda/6`), each integrated with the 7-point degree-5 Gauss rule
(Dunavant 1985, Table 1, n = 5), of

.. math::
    h = \frac{j\Gamma}{4\pi}\int_{A_{lit}}\frac{\hat{\mathbf n}\cdot(\hat{\mathbf u}_t+\hat{\mathbf u}_r)}{2}
        \frac{e^{-jk(r_t + r_r)}}{r_t\,r_r}\,dA,
    \qquad \sigma = \frac{(4\pi)^3R^4|h|^2}{\lambda^2}\ \text{(monostatic)},

which is NOTES section 6's :math:`\sigma = \frac{4\pi}{\lambda^2}|\int(\hat{\mathbf n}\cdot\hat{\mathbf r})
(R/r)^2e^{-j2k(r-R)}dA|^2` when Tx = Rx. Lit: a triangle whose normal (outward for closed
meshes; either side for open ones, ``two_sided=True``) faces both the Tx and the Rx point.
No shadowing test: use it on convex targets and plates.
"""

from __future__ import annotations

import numpy as np

C0 = 299_792_458.0

# Dunavant degree-5, 7 points: barycentric (l1, l2, l3) and weights (sum 1)
_A1, _B1 = 0.059715871789770, 0.470142064105115
_A2, _B2 = 0.797426985353087, 0.101286507323456
_GAUSS = np.array([
    [1 / 3, 1 / 3, 1 / 3],
    [_A1, _B1, _B1], [_B1, _A1, _B1], [_B1, _B1, _A1],
    [_A2, _B2, _B2], [_B2, _A2, _B2], [_B2, _B2, _A2],
])
_WEIGHTS = np.array([0.225] + [0.132394152788506] * 3 + [0.125939180544827] * 3)


def _sub_triangles(s):
    """Corner coefficients ``[s^2, 3, 2]`` (multiples of e1 = (p1-p0)/s, e2 = (p2-p0)/s) of the
    s^2 congruent sub-triangles of a triangle."""
    out = []
    for i in range(s):
        for j in range(s - i):
            out.append([[i, j], [i + 1, j], [i, j + 1]])
            if j < s - i - 1:
                out.append([[i + 1, j], [i + 1, j + 1], [i, j + 1]])
    return np.array(out, dtype=float)


def quadrature_points(vertices, faces, max_edge):
    """Gauss points ``[Q, 3]``, weights (m^2) ``[Q]`` and unit normals ``[Q, 3]`` over the mesh."""
    tri = np.asarray(vertices, float)[np.asarray(faces)]
    p0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    cross = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    longest = np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2), axis=1)
    splits = np.maximum(1, np.ceil(longest / max_edge)).astype(int)
    pts, wts, nrm = [], [], []
    for s in np.unique(splits[area > 0]):
        sel = np.nonzero((splits == s) & (area > 0))[0]
        coef = _sub_triangles(s)                                    # [T, 3, 2]
        gauss = np.einsum("qk,tkc->tqc", _GAUSS, coef).reshape(-1, 2) / s   # [T*7, 2] in units of e1, e2
        x = (p0[sel, None] + gauss[None, :, :1] * e1[sel, None] + gauss[None, :, 1:] * e2[sel, None])
        pts.append(x.reshape(-1, 3))
        wts.append((np.tile(_WEIGHTS, coef.shape[0])[None] * (area[sel] / s ** 2)[:, None]).ravel())
        nrm.append(np.repeat(cross[sel] / (2 * area[sel])[:, None], gauss.shape[0], axis=0))
    return np.concatenate(pts), np.concatenate(wts), np.concatenate(nrm)


def po_channel(vertices, faces, tx, rx, wavelength, reflection=-1.0, two_sided=False, max_edge=None):
    """Complex PO channel ``h`` (no carrier phase removed: it contains e^{-jk(r_t + r_r)}) from ``tx`` to ``rx``."""
    max_edge = wavelength / 6 if max_edge is None else max_edge
    x, w, n = quadrature_points(vertices, faces, max_edge)
    tx, rx = np.asarray(tx, float), np.asarray(rx, float)
    d_t, d_r = tx - x, rx - x
    r_t, r_r = np.linalg.norm(d_t, axis=1), np.linalg.norm(d_r, axis=1)
    c_t = np.sum(n * d_t, axis=1) / r_t
    c_r = np.sum(n * d_r, axis=1) / r_r
    if two_sided:
        flip = np.sign(c_t)
        c_t, c_r = c_t * flip, c_r * flip
    lit = (c_t > 0) & (c_r > 0)
    k = 2 * np.pi / wavelength
    integrand = (c_t + c_r) / 2 * np.exp(-1j * k * (r_t + r_r)) / (r_t * r_r)
    return 1j * reflection / (4 * np.pi) * np.sum(w[lit] * integrand[lit])


def monostatic_rcs(vertices, faces, radar, reference, wavelength, two_sided=False, max_edge=None):
    """sigma_PO (m^2) seen from ``radar``; R = |reference - radar|."""
    h = po_channel(vertices, faces, radar, radar, wavelength, two_sided=two_sided, max_edge=max_edge)
    r = np.linalg.norm(np.asarray(reference, float) - np.asarray(radar, float))
    return float((4 * np.pi) ** 3 * r ** 4 * abs(h) ** 2 / wavelength ** 2)


def square_plate_rcs_fresnel(side, distance, wavelength):
    r"""Closed form of the near-field PO of a square plate facing the radar on its axis (paraxial):
    :math:`\sigma = \frac{4\pi}{\lambda^2}\bigl|\int_{-a/2}^{a/2}e^{-jkx^2/R}dx\bigr|^4`, the 1-D
    integrals by Fresnel integrals :math:`\int_0^{a/2}e^{-jkx^2/R}dx = \sqrt{\pi R/(2k)}\,(C(\nu) - jS(\nu))`,
    :math:`\nu = \frac a2\sqrt{2k/(\pi R)}`."""
    from scipy.special import fresnel

    k = 2 * np.pi / wavelength
    nu = side / 2 * np.sqrt(2 * k / (np.pi * distance))
    s, c = fresnel(nu)
    one_d = 2 * np.sqrt(np.pi * distance / (2 * k)) * (c - 1j * s)
    return float(4 * np.pi / wavelength ** 2 * abs(one_d) ** 4)


def cylinder(radius, length, n_segments, n_length, center=(0.0, 0.0, 0.0)):
    """Open cylinder surface along z (outward normals), ``2 n_segments n_length`` triangles."""
    phi = np.linspace(0, 2 * np.pi, n_segments, endpoint=False)
    z = np.linspace(-length / 2, length / 2, n_length + 1)
    zz, pp = np.meshgrid(z, phi, indexing="ij")
    v = np.stack([radius * np.cos(pp), radius * np.sin(pp), zz], -1).reshape(-1, 3) + np.asarray(center, float)
    faces = []
    for i in range(n_length):
        for j in range(n_segments):
            a, b = i * n_segments + j, i * n_segments + (j + 1) % n_segments
            c, d = a + n_segments, b + n_segments
            faces += [(a, b, d), (a, d, c)]
    return v, np.array(faces, dtype=np.int64)
