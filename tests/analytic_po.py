r"""Independent reference: the near-field PO channel of every Tx/Rx element pair over an *exact*
sphere and an exact finite cylinder, integrated on their analytic parametrisations.

Written apart from :mod:`sionnafmcw.physical_optics` (it imports nothing from the package), like
``tests/po_quadrature.py``, but on the true surface instead of a mesh:

.. math::
    h_{mn} = \frac{j\Gamma}{4\pi}\int_{A_{lit}}\frac{\hat{\mathbf n}\cdot(\hat{\mathbf u}_t + \hat{\mathbf u}_r)}{2}
             \frac{e^{-jk(r_t + r_r)}}{r_t\,r_r}\,dA

(NOTES section 6; ``physical_optics``' derivation), :math:`\Gamma = -1` for metal, Tx element
:math:`m` at :math:`\mathbf t_m`, Rx element :math:`n` at :math:`\mathbf r_n`,
:math:`\hat{\mathbf u}_{t} = (\mathbf t_m - \mathbf p)/r_t`, lit where the outward normal faces
both elements (:math:`\hat{\mathbf n}\cdot\hat{\mathbf u}_t > 0` and :math:`\hat{\mathbf n}\cdot\hat{\mathbf u}_r > 0`;
convex bodies need no shadowing test). The lit indicator makes the integrand a sum of two
separable products per element pair, so all :math:`M\times N` channels are two matrix products
over the quadrature points.

Quadrature. Sphere: polar angle :math:`\theta` from the direction of the elements' centroid
(the specular region is then a polar cap and the integrand varies slowly in azimuth), composite
Gauss--Legendre in :math:`\theta` (``panels`` panels of ``order`` nodes up to the horizon of the
farthest-off element, :math:`\arccos(a/d)` plus its offset) times the trapezoidal rule in
:math:`\varphi` (periodic: spectral), :math:`dA = a^2\sin\theta\,d\theta\,d\varphi`. Cylinder (axis
:math:`\hat{\mathbf z}`, radius :math:`a`, length :math:`L`): Gauss--Legendre in azimuth over the
half facing the elements (plus margin) and in :math:`z` over :math:`[-L/2, L/2]`,
:math:`dA = a\,d\varphi\,dz`; the end caps (flat disks, Gauss--Legendre in radius and trapezoid in
azimuth) where they are lit. The two-way phase turns by at most :math:`2ka` over the sphere's
:math:`\pi/2` of :math:`\theta` (323 rad for :math:`a` = 0.1 m at 77 GHz): the default 96 panels
of 8 nodes give 2.4 nodes per radian. :func:`convergence` halves every step and reports the
change (< 0.01 dB in ``tests/test_smooth_surface.py``).

Closed forms for the sanity tests (monostatic, :math:`\sigma = (4\pi)^3 d^4|h|^2/\lambda^2`, :math:`d`
the distance to the centre / the axis): sphere, stationary phase at the specular point (range
:math:`R_s = d - a`, reflected wavefront of radius :math:`aR_s/(a + 2R_s)`),
:math:`\sigma = \pi a^2\,(d/R_s)^2` (:math:`\pi a^2` in the far field), up to PO's
:math:`1/(ka)` shadow-boundary ripple (far field: :math:`\sigma/\pi a^2 = 1 - \sin 2ka/(ka) +
\sin^2 ka/(ka)^2`); cylinder at broadside, stationary phase in azimuth and the Fresnel integral
along the axis: :math:`\sigma = \frac{2\pi a}{\lambda}\,|Z|^2\,(d/R_s)^3`,
:math:`Z = \int_{-L/2}^{L/2}e^{-jkz^2/R_s}dz` (:math:`2\pi aL^2/\lambda` in the far field).
"""

from __future__ import annotations

import numpy as np

C0 = 299_792_458.0


def _gauss_panels(lo: float, hi: float, panels: int, order: int):
    """Composite Gauss--Legendre nodes and weights on ``[lo, hi]``."""
    x, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(lo, hi, panels + 1)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    return (mid[:, None] + half[:, None] * x[None]).ravel(), (half[:, None] * w[None]).ravel()


def surface_channels(points, normals, weights, tx, rx, wavelength, reflection=-1.0) -> np.ndarray:
    r""":math:`h_{mn}` ``[M, N]`` of the PO integral over quadrature ``points [Q, 3]`` with outward unit
    ``normals [Q, 3]`` and area ``weights [Q]`` (m^2), Tx ``[M, 3]`` and Rx ``[N, 3]`` element positions."""
    k = 2 * np.pi / wavelength
    tx, rx = np.atleast_2d(np.asarray(tx, float)), np.atleast_2d(np.asarray(rx, float))
    parts = []
    for el in (tx, rx):
        d = el[:, None] - points[None]                       # [E, Q, 3] point -> element
        r = np.linalg.norm(d, axis=-1)
        cos = np.einsum("eqi,qi->eq", d, normals) / r
        lit = cos > 0
        wave = np.where(lit, np.exp(-1j * k * r) / r, 0.0)
        parts.append((cos, wave))
    (c_t, a_t), (c_r, a_r) = parts
    # sum_q w (c_t + c_r)/2 [lit_t lit_r] a_t a_r, as two matrix products
    h = 0.5 * ((weights * c_t * a_t) @ a_r.T + (weights * a_t) @ (c_r * a_r).T)
    return 1j * reflection / (4 * np.pi) * h


def sphere_quadrature(radius, centre, elements, panels: int = 96, order: int = 8, n_phi: int = 96):
    """Points, outward normals and weights over the part of the sphere any element can see."""
    centre = np.asarray(centre, float)
    elements = np.atleast_2d(np.asarray(elements, float))
    mid = elements.mean(axis=0)
    axis = mid - centre
    dist = np.linalg.norm(axis)
    axis /= dist
    offset = np.max(np.linalg.norm(elements - mid, axis=1))
    d_min = np.min(np.linalg.norm(elements - centre, axis=1))
    if d_min <= radius:
        raise ValueError("sphere_quadrature: an element lies inside the sphere")
    theta_max = min(np.pi, np.arccos(radius / d_min) + 2 * np.arcsin(min(1.0, offset / dist)) + 1e-3)
    theta, w_theta = _gauss_panels(0.0, theta_max, panels, order)
    phi = np.arange(n_phi) * 2 * np.pi / n_phi
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    st, ct = np.sin(theta)[:, None, None], np.cos(theta)[:, None, None]
    cp, sp = np.cos(phi)[None, :, None], np.sin(phi)[None, :, None]
    normal = (ct * axis + st * (cp * u + sp * v)).reshape(-1, 3)
    weight = (radius ** 2 * np.sin(theta) * w_theta)[:, None] * np.full(n_phi, 2 * np.pi / n_phi)[None]
    return centre + radius * normal, normal, weight.ravel()


def sphere_po_channels(radius, centre, tx, rx, wavelength, reflection=-1.0, panels: int = 96, order: int = 8,
                       n_phi: int = 96) -> np.ndarray:
    """``[M, N]`` PO channels of an exact sphere (module docstring)."""
    p, n, w = sphere_quadrature(radius, centre, np.concatenate([np.atleast_2d(tx), np.atleast_2d(rx)]),
                                panels, order, n_phi)
    return surface_channels(p, n, w, tx, rx, wavelength, reflection)


def cylinder_quadrature(radius, length, centre, elements, panels: int = 64, order: int = 8, z_panels: int = 32,
                        caps: bool = True, cap_panels: int = 32, n_cap_phi: int = 128):
    """Points, outward normals and weights of a cylinder along z (side facing the elements, and lit caps)."""
    centre = np.asarray(centre, float)
    elements = np.atleast_2d(np.asarray(elements, float))
    rel = elements - centre
    az = np.arctan2(rel[:, 1], rel[:, 0])
    mid = np.angle(np.mean(np.exp(1j * az)))
    spread = np.max(np.abs(np.angle(np.exp(1j * (az - mid)))))
    # half the circle facing the elements, widened by their spread (the lit part of each pair lies inside)
    half = min(np.pi, np.pi / 2 + spread + 1e-3)
    phi, w_phi = _gauss_panels(mid - half, mid + half, panels, order)
    z, w_z = _gauss_panels(-length / 2, length / 2, z_panels, order)
    pp, zz = np.meshgrid(phi, z, indexing="ij")
    normal = np.stack([np.cos(pp), np.sin(pp), np.zeros_like(pp)], -1).reshape(-1, 3)
    points = centre + radius * normal + np.stack([0 * pp, 0 * pp, zz], -1).reshape(-1, 3)
    weight = (radius * w_phi[:, None] * w_z[None]).ravel()
    pts, nrm, wts = [points], [normal], [weight]
    if caps:
        rho, w_rho = _gauss_panels(0.0, radius, cap_panels, order)
        cphi = np.arange(n_cap_phi) * 2 * np.pi / n_cap_phi
        rr, cc = np.meshgrid(rho, cphi, indexing="ij")
        disk = np.stack([rr * np.cos(cc), rr * np.sin(cc), 0 * rr], -1).reshape(-1, 3)
        dw = (rho * w_rho)[:, None] * np.full(n_cap_phi, 2 * np.pi / n_cap_phi)[None]
        for sign in (1.0, -1.0):
            if np.any(rel[:, 2] * sign > length / 2):          # some element sees this cap
                pts.append(centre + disk + [0.0, 0.0, sign * length / 2])
                nrm.append(np.tile([0.0, 0.0, sign], (len(disk), 1)))
                wts.append(dw.ravel())
    return np.concatenate(pts), np.concatenate(nrm), np.concatenate(wts)


def cylinder_po_channels(radius, length, centre, tx, rx, wavelength, reflection=-1.0, panels: int = 64,
                         order: int = 8, z_panels: int = 32, caps: bool = True) -> np.ndarray:
    """``[M, N]`` PO channels of an exact closed cylinder along z (side and lit flat end caps)."""
    p, n, w = cylinder_quadrature(radius, length, centre, np.concatenate([np.atleast_2d(tx), np.atleast_2d(rx)]),
                                  panels, order, z_panels, caps)
    return surface_channels(p, n, w, tx, rx, wavelength, reflection)


def monostatic_rcs(h, distance, wavelength) -> np.ndarray:
    r""":math:`\sigma = (4\pi)^3d^4|h|^2/\lambda^2` (m^2)."""
    return (4 * np.pi) ** 3 * distance ** 4 * np.abs(h) ** 2 / wavelength ** 2


def sphere_rcs_closed_form(radius, distance, wavelength=None) -> float:
    r"""Stationary-phase (GO) monostatic RCS of a sphere seen from ``distance`` (to its centre):
    :math:`\pi a^2(d/(d - a))^2`; with ``wavelength`` also PO's far-field shadow-boundary ripple factor
    :math:`1 - \sin 2ka/(ka) + \sin^2 ka/(ka)^2`."""
    sigma = np.pi * radius ** 2 * (distance / (distance - radius)) ** 2
    if wavelength is not None:
        ka = 2 * np.pi / wavelength * radius
        sigma *= 1 - np.sin(2 * ka) / ka + np.sin(ka) ** 2 / ka ** 2
    return float(sigma)


def cylinder_rcs_closed_form(radius, length, distance, wavelength) -> float:
    r"""Broadside monostatic RCS of a cylinder, ``distance`` to its axis: :math:`\frac{2\pi a}{\lambda}|Z|^2(d/R_s)^3`,
    :math:`Z = \int_{-L/2}^{L/2}e^{-jkz^2/R_s}dz` by Fresnel integrals (module docstring)."""
    from scipy.special import fresnel

    k = 2 * np.pi / wavelength
    r_s = distance - radius
    nu = length / 2 * np.sqrt(2 * k / (np.pi * r_s))
    s, c = fresnel(nu)
    z = 2 * np.sqrt(np.pi * r_s / (2 * k)) * (c - 1j * s)
    return float(2 * np.pi * radius / wavelength * abs(z) ** 2 * (distance / r_s) ** 3)


def convergence(channels, **grid) -> float:
    """Largest change (dB) of any pair's :math:`|h|^2` when every quadrature step of ``channels(**grid)``
    is halved (``panels``, ``z_panels`` and ``n_phi`` doubled)."""
    coarse = channels(**grid)
    fine = channels(**{k: 2 * v for k, v in grid.items()})
    return float(np.max(np.abs(10 * np.log10(np.abs(fine) ** 2 / np.abs(coarse) ** 2))))
