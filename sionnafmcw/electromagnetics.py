r"""Electromagnetics of a diffuse reflection, as Sionna RT computes it (numpy only).

What the pixel engine (:mod:`sionnafmcw.engines.pixel`) needs to give every hit pixel the
strength of Sionna RT's diffuse reflection: the ITU-R P.2040 slab reflection coefficients, the
reflection coefficient of the incident polarisation, the spherical basis in which Sionna writes
fields, the field of a vertically polarised element and the co-polar fraction after Sionna's
cross-polarisation (XPD) rotation. All directions are unit vectors in the world frame, arrays
broadcast over leading axes (``[..., 3]`` for vectors); lengths in metres, angles in radians.

Conventions (Sionna RT's): :math:`\hat{\mathbf k}_{in}` is the propagation direction of the
incident wave (source -> interaction point), :math:`\hat{\mathbf k}_{out}` that of the scattered
wave (interaction point -> receiver); the complex relative permittivity is
:math:`\eta = \varepsilon_r - j\sigma/(\omega\varepsilon_0)`.
"""

from __future__ import annotations

import numpy as np


def dot(a, b) -> np.ndarray:
    """Scalar products over the last axis: ``[..., 3] x [..., 3] -> [...]``."""
    return np.einsum("...i,...i->...", a, b)


def unit(v, axis: int = -1) -> np.ndarray:
    """``v`` divided by its norm along ``axis`` (zero vectors stay zero)."""
    norm = np.linalg.norm(v, axis=axis, keepdims=True)
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0)


def slab_reflection_coefficients(cos_theta, eta, thickness, wavelength) -> tuple[np.ndarray, np.ndarray]:
    r"""ITU-R P.2040 single-layer slab reflection coefficients :math:`(r_{TE}, r_{TM})` (complex).

    The same formulas as Sionna's ``itu_coefficients_single_layer_slab`` (ITU-R P.2040 eqs.
    (43a), (44)):

    .. math::
        r'_{TE} = \frac{\cos\theta - \sqrt{\eta - \sin^2\theta}}{\cos\theta + \sqrt{\eta - \sin^2\theta}},\quad
        r'_{TM} = \frac{\eta\cos\theta - \sqrt{\eta - \sin^2\theta}}{\eta\cos\theta + \sqrt{\eta - \sin^2\theta}},\quad
        q = \frac{2\pi d}{\lambda}\sqrt{\eta - \sin^2\theta},\quad
        r = r'\,\frac{1 - e^{-j2q}}{1 - r'^2 e^{-j2q}}

    ``cos_theta``: cosine of the angle of incidence; ``eta``: complex relative permittivity
    :math:`\varepsilon_r - j\sigma/(\omega\varepsilon_0)`; ``thickness`` :math:`d` and
    ``wavelength`` :math:`\lambda` in metres.
    """
    cos_theta = np.asarray(cos_theta, dtype=float)
    eta = np.asarray(eta, dtype=complex)
    sin2 = 1.0 - cos_theta ** 2
    root = np.sqrt(eta - sin2)
    r_te_p = (cos_theta - root) / (cos_theta + root)
    r_tm_p = (eta * cos_theta - root) / (eta * cos_theta + root)
    q = 2 * np.pi * np.asarray(thickness, dtype=float) / wavelength * root
    e2q = np.exp(-2j * q)
    r_te = r_te_p * (1 - e2q) / (1 - r_te_p ** 2 * e2q)
    r_tm = r_tm_p * (1 - e2q) / (1 - r_tm_p ** 2 * e2q)
    return r_te, r_tm


def reflection_power(cos_theta, eta, thickness, wavelength, k_in, normal, e_t) -> np.ndarray:
    r"""Power reflection coefficient of the incident polarisation, :math:`\Gamma^2 = \|\mathbf R\mathbf e_i\|^2/\|\mathbf e_i\|^2`.

    With :math:`\mathbf R` Sionna's specular reflection matrix (slab coefficients
    :func:`slab_reflection_coefficients` at the angle of incidence :math:`\theta_i`) and
    :math:`\hat{\mathbf e}_t` the unit polarisation of the incident field,

    .. math::
        \Gamma^2 = |r_{TE}(\theta_i)|^2 (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2
                 + |r_{TM}(\theta_i)|^2 \bigl(1 - (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2\bigr),
        \qquad \hat{\mathbf s} = \frac{\hat{\mathbf k}_{in}\times\hat{\mathbf n}}
                                      {\|\hat{\mathbf k}_{in}\times\hat{\mathbf n}\|}

    (:math:`\hat{\mathbf s}` the TE direction, normal to the plane of incidence; at normal
    incidence any transverse direction, where :math:`|r_{TE}| = |r_{TM}|`). ``cos_theta`` is
    clipped to [0, 1]; ``k_in``, ``normal`` and ``e_t`` are ``[..., 3]``, the others broadcast
    with ``[...]``.
    """
    r_te, r_tm = slab_reflection_coefficients(np.clip(cos_theta, 0.0, 1.0), eta, thickness, wavelength)
    s_hat = np.cross(k_in, normal)
    s_norm = np.linalg.norm(s_hat, axis=-1, keepdims=True)
    # normal incidence: any transverse direction (|r_TE| = |r_TM| there)
    fallback = np.cross(k_in, np.where(np.abs(k_in[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
    s_hat = np.where(s_norm > 1e-9, s_hat, fallback)
    s_hat = unit(s_hat)
    te = dot(e_t, s_hat) ** 2
    return np.abs(r_te) ** 2 * te + np.abs(r_tm) ** 2 * (1.0 - te)


def spherical_basis(k) -> tuple[np.ndarray, np.ndarray]:
    r"""The spherical unit vectors :math:`(\hat{\boldsymbol\theta}, \hat{\boldsymbol\varphi})` of unit directions ``k [..., 3]``.

    With :math:`\theta = \arccos k_z` (from the :math:`+z` axis) and :math:`\varphi = \operatorname{atan2}(k_y, k_x)`,

    .. math::
        \hat{\boldsymbol\theta} = [\cos\theta\cos\varphi,\ \cos\theta\sin\varphi,\ -\sin\theta],\qquad
        \hat{\boldsymbol\varphi} = [-\sin\varphi,\ \cos\varphi,\ 0],

    the basis in which Sionna RT writes the transverse field travelling along :math:`\hat{\mathbf k}`.
    """
    # the cosines and sines without the angles: cos(theta) = k_z, sin(theta) = sqrt(1 - k_z^2),
    # (cos, sin)(phi) = (k_x, k_y)/rho with rho = |(k_x, k_y)|; on the z axis (rho = 0) atan2's phi
    # (0, or pi for k_x = -0) from the angle itself
    ct = np.clip(k[..., 2], -1.0, 1.0)
    st = np.sqrt(1.0 - ct * ct)
    rho = np.hypot(k[..., 0], k[..., 1])
    axis = rho == 0
    with np.errstate(invalid="ignore", divide="ignore"):
        cp, sp = np.asarray(k[..., 0] / rho), np.asarray(k[..., 1] / rho)
    if np.any(axis):
        phi = np.arctan2(k[..., 1][axis], k[..., 0][axis])
        cp[axis], sp[axis] = np.cos(phi), np.sin(phi)
    theta_hat = np.stack([ct * cp, ct * sp, -st], axis=-1)
    phi_hat = np.stack([-sp, cp, np.zeros_like(sp)], axis=-1)
    return theta_hat, phi_hat


def vertical_polarisation(k_world, rotation) -> np.ndarray:
    r"""Unit field vector (world) radiated towards ``k_world [..., 3]`` by a vertically polarised element.

    An element of a device with rotation :math:`\mathbf R` (radar frame -> world) and Sionna's
    ``"V"`` polarisation (slant angle 0) radiates along the :math:`\hat{\boldsymbol\theta}` of its
    own frame: :math:`\mathbf R\,\hat{\boldsymbol\theta}(\mathbf R^T\hat{\mathbf k})`.
    """
    local = k_world @ rotation
    theta_hat, _ = spherical_basis(local)
    return theta_hat @ rotation.T


def copolar_fraction(e_t, k_in, e_r, k_out, xpd_coefficient) -> np.ndarray:
    r"""Share :math:`\chi` of the scattered power a receive element of polarisation ``e_r`` sees.

    Sionna's diffuse reflection rotates the polarisation with

    .. math::
        \mathbf X = \begin{bmatrix}\sqrt{1-K_x} & -\sqrt{K_x}\\ \sqrt{K_x} & \sqrt{1-K_x}\end{bmatrix},

    (``xpd_coefficient`` :math:`K_x`) acting on the :math:`(\hat{\boldsymbol\theta},
    \hat{\boldsymbol\varphi})` components of the incident field ``e_t`` in the basis of
    ``k_in`` and giving those of the scattered field in the basis of ``k_out``
    (:func:`spherical_basis`); :math:`\mathbf X` keeps the power, so

    .. math::
        \chi = \bigl(\hat{\mathbf e}_r\cdot\mathbf X\hat{\mathbf e}_t\bigr)^2 \in [0, 1],

    exactly :math:`1 - K_x` when both elements are vertically polarised in the world's basis (a
    radar pose with yaw only), less with pitch or roll. ``e_t``, ``k_in`` (the incident side) and
    ``e_r``, ``k_out`` (the scattered side) are ``[..., 3]`` and broadcast against each other;
    ``xpd_coefficient`` broadcasts with the incident side's ``[...]``.
    """
    th_i, ph_i = spherical_basis(k_in)
    a1, b1 = dot(e_t, th_i), dot(e_t, ph_i)
    ca, sa = np.sqrt(1.0 - xpd_coefficient), np.sqrt(xpd_coefficient)
    a2 = ca * a1 - sa * b1
    b2 = sa * a1 + ca * b1
    th_o, ph_o = spherical_basis(k_out)
    e_s = a2[..., None] * th_o + b2[..., None] * ph_o
    return dot(e_r, e_s) ** 2


def lambertian_pattern(cos_s) -> np.ndarray:
    r"""Sionna's ``"lambertian"`` scattering pattern :math:`f_s = \cos\theta_s/\pi` (:math:`\int_{2\pi} f_s\,d\Omega_s = 1`)."""
    return cos_s / np.pi


__all__ = ["copolar_fraction", "dot", "lambertian_pattern", "reflection_power", "slab_reflection_coefficients",
           "spherical_basis", "unit", "vertical_polarisation"]
