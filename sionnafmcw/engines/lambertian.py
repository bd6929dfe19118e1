r"""The pixel engine's diffuse echo: every hit pixel a Lambertian point target (eq. (2) of the reference paper).

Strength: Sionna RT's diffuse reflection, pixel by pixel
--------------------------------------------------------
Sionna RT (``RadioMaterial._diffuse_reflection_matrix`` and the field calculator of the path
solver) gives a path that ends with a diffuse reflection, for a ray tube of solid angle
:math:`\Delta\Omega` leaving the source (:math:`4\pi/N` for :math:`N` rays per source, divided by
the probability with which the diffuse event was sampled), the Jones matrix
:math:`S\,\Gamma\sqrt{f_s\,\Delta\Omega}\;\mathbf W_{out}\mathbf X\mathbf W_{in}` at the
interaction, and restarts the spreading there (the field after it falls as :math:`1/r_s`, the
distance from the interaction point to the receiver). Here

* :math:`S\in[0,1]` is the material's ``scattering_coefficient`` (an amplitude): a share
  :math:`S^2` of the reflected power is scattered diffusely, :math:`1 - S^2` specularly;
* :math:`\Gamma = \|\mathbf R\,\mathbf e_i\|/\|\mathbf e_i\|` is the reflection coefficient of
  the *incident polarisation*: :math:`\mathbf R` is the specular reflection matrix with the
  ITU-R P.2040 single-layer slab coefficients :math:`r_{TE}, r_{TM}` (thickness :math:`d`,
  complex permittivity :math:`\eta = \varepsilon_r - j\sigma/(\omega\varepsilon_0)`, eqs. (43),
  (44); :func:`~sionnafmcw.electromagnetics.slab_reflection_coefficients`), so

  .. math::
      \Gamma^2 = |r_{TE}(\theta_i)|^2 (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2
               + |r_{TM}(\theta_i)|^2 \bigl(1 - (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2\bigr),
      \qquad \hat{\mathbf s} = \frac{\hat{\mathbf k}_{in}\times\hat{\mathbf n}}
                                    {\|\hat{\mathbf k}_{in}\times\hat{\mathbf n}\|}

  with :math:`\hat{\mathbf e}_t` the unit polarisation of the transmitted field (the radar's
  vertically polarised elements: :math:`\hat{\boldsymbol\theta}` of the element frame) and
  :math:`\theta_i` the angle of incidence;
* :math:`f_s(\hat{\mathbf k}_{in}, \hat{\mathbf k}_{out})` is the material's scattering
  pattern, :math:`\cos\theta_s/\pi` for Sionna's default ``"lambertian"``
  (:math:`\int_{2\pi} f_s\,d\Omega_s = 1`); other registered patterns are evaluated with
  Sionna's own pattern object;
* :math:`\mathbf X = \begin{bmatrix}\sqrt{1-K_x} & -\sqrt{K_x}\\ \sqrt{K_x} & \sqrt{1-K_x}\end{bmatrix}`
  (``xpd_coefficient`` :math:`K_x`) maps the :math:`(\hat{\boldsymbol\theta}, \hat{\boldsymbol\varphi})`
  components of the incident field (world spherical basis of :math:`\hat{\mathbf k}_{in}`) to
  those of the scattered field (basis of :math:`\hat{\mathbf k}_{out}`); it keeps the power
  and rotates the polarisation, so the receive element sees the co-polar fraction
  :math:`\chi = \bigl(\hat{\mathbf e}_r\cdot\mathbf X\hat{\mathbf e}_t\bigr)^2`: exactly
  :math:`1 - K_x` for a radar pose with yaw only (its element :math:`\hat{\boldsymbol\theta}` is
  the world's), less with pitch or roll.

With Sionna's antenna fields :math:`\sqrt{G}` and receive aperture :math:`\lambda/\sqrt{4\pi}`,
one such path carries

.. math::
    |a|^2 = G_t G_r \Bigl(\frac{\lambda}{4\pi}\Bigr)^2
            \frac{S^2\,\Gamma^2\,\chi\,f_s\,\Delta\Omega}{r_s^2}.

A pixel is exactly such a ray tube, with :math:`\Delta\Omega` the pixel's solid angle. The
radar-equation reading of the same expression: the pixel illuminates the patch
:math:`A = R^2\Delta\Omega/\cos\theta_i` at range :math:`R` (the projected area
:math:`R^2\Delta\Omega` spread over the tilted surface), which intercepts
:math:`P_t G_t/(4\pi R^2)\cdot A\cos\theta_i = P_t G_t\Delta\Omega/(4\pi)` and re-radiates
:math:`S^2\Gamma^2\chi f_s` of it per steradian, i.e. the pixel RCS

.. math::
    \sigma_p = 4\pi\,A\cos\theta_i\,S^2\Gamma^2\chi\,f_s(\theta_s)
             \;\overset{\text{Lambert, monostatic}}{=}\; 4R^2\Delta\Omega\,S^2\Gamma^2\chi\cos\theta_i,
    \qquad
    |a|^2 = \frac{P_r}{P_t} = \frac{\lambda^2 G_t G_r\,\sigma_p}{(4\pi)^3 R^4}.

Summed over the pixels this is a deterministic (midpoint-rule) quadrature of the very integral
that the path engine's shoot-and-bounce estimates by Monte Carlo over its Fibonacci lattice of
rays, so both engines give the same absolute power for the same diffuse surface (measured in
``tests/test_pixel_engine.py``). The XPD basis is Sionna's (world :math:`\hat{\boldsymbol\theta},
\hat{\boldsymbol\varphi}`); a pixel hidden from the radar is not cast (first hit only, so no
extra visibility test is needed for the monostatic return).

``scattering_coefficient`` (engine option): ``None`` uses every material's own :math:`S` (the
default, consistent with the path engine; Sionna's and the ITU materials default to
:math:`S = 0`, which the Lambertian model does not see at all -- a warning says so); a number in
:math:`[0, 1]` replaces :math:`S` for every material (the paper's render, where every surface is
a Lambertian scatterer).

Diffuse phase: one random scatterer per surface cell
----------------------------------------------------
A pixel of centimetres holds many roughness cells of a wavelength (3.9 mm) with unrelated phases;
their sum is a random phasor whose *power* is the pixel's :math:`|a|^2` above. With
``diffuse_phase="random"`` (default) every pixel's contribution is :math:`|a|\,e^{j\phi}` with
:math:`\phi` the phase of the surface cell it hit (:func:`~sionnafmcw.diffuse.scatterer_phases`:
a hash of object name, triangle and barycentric cell of ``diffuse_cell_size``, :math:`\lambda/4`
by default; the cells per edge are fixed from the surface's first frame, :func:`diffuse_cells`). The phase is fixed to the
surface point, so it moves with the body, is the same for every Tx/Rx pair (one set of
scatterers for the whole array: the MIMO phase between channels is the geometry's) and for every
chirp, and a static surface keeps it from frame to frame. Neighbouring pixels then add in power,
:math:`E|\sum_p a_p e^{j\phi_p}e^{-j2\pi f\tau_p}|^2 = \sum_p|a_p|^2`, whatever the pixel count
(4x pixels move the mean clutter-removed map power by < 0.5 dB, ``tests/test_pixel_po.py``).
``diffuse_phase="deterministic"`` is the paper's eq. (2) as published: real :math:`|a|`, so
neighbours add coherently and the map power grows with the pixel count (about 6 dB per 4x
pixels on a surface facing the radar).

Array phase
-----------
``array_model="plane-wave"`` (eq. (2), far field): with :math:`\mathbf c` the phase centre and
:math:`\hat{\mathbf u}` the pixel's direction, element pair :math:`(m, n)` sees

.. math::
    \tau_{mn} = \frac{2R - (\mathbf t_m - \mathbf c + \mathbf r_n - \mathbf c)\cdot\hat{\mathbf u}}{c_0},

which for a uniform virtual row of spacing :math:`\Delta d` along the radar's :math:`y` axis
gives the paper's phase :math:`((m-1)N + n - 1)\,\Delta d\,\sin\theta/\lambda` with
:math:`\sin\theta = \cos\vartheta\sin\varphi` (with the opposite sign: the IF here is
:math:`s_{tx}\,\overline{s_{rx}}`, ``docs/conventions.md``, \"The beat signal\"). Gain and Doppler are those of the phase
centre for every pair. ``array_model="exact"``: spherical wavefronts per element,
:math:`\tau_{mn} = (\|\mathbf p - \mathbf t_m\| + \|\mathbf p - \mathbf r_n\|)/c_0` with the
element positions of the radar pose (:mod:`sionnafmcw.geometry`), element gains and
polarisations towards :math:`\mathbf p`, bistatic angles in :math:`\Gamma, f_s, \chi`, and the
bistatic radar equation :math:`|a_{mn}|^2 = \lambda^2 G_t G_r\sigma_{mn}/((4\pi)^3 r_m^2 r_n^2)`
with :math:`\sigma_{mn} = 4\pi A\cos\theta_{i,m}S^2\Gamma_m^2\chi_{mn}f_s(\theta_{s,n})`. The two
differ by the near-field term :math:`\sum_{e\in\{t_m, r_n\}}(\|\mathbf d_e\|^2 -
(\mathbf d_e\cdot\hat{\mathbf u})^2)/(2R)` (:math:`\mathbf d_e` the element offset from
:math:`\mathbf c`) to second order: 0.27 rad of carrier phase for a 1.3 cm offset at 0.5 m,
nothing at room ranges.

Velocity and Doppler
--------------------
The velocity at the hit point is the object's manifest velocity of the frame or, where the PLY
carries per-vertex velocities ``vx, vy, vz`` (and ``vertex_doppler=True``), the barycentric
interpolation :math:`\mathbf v = (1 - b_1 - b_2)\mathbf v_0 + b_1\mathbf v_1 + b_2\mathbf v_2`
with the triangle and barycentrics of the hit (the paper's :math:`V` per pixel). Doppler is the
path engine's (and Sionna's) :math:`f_D = \mathbf v\cdot(\hat{\mathbf k}_{out} - \hat{\mathbf k}_{in})/\lambda`,
:math:`\lambda = c_0/f_c`, positive approaching; plane-wave: :math:`-2\,\mathbf v\cdot\hat{\mathbf u}/\lambda`
with :math:`\hat{\mathbf u}` the direction from the phase centre to the hit point (the pixel
centre's to float32 precision).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..antenna import antenna_gain, direction_angles
from ..constants import SPEED_OF_LIGHT, VACUUM_PERMITTIVITY
from ..diffuse import cells_per_edge
from ..echoes import Echoes
from ..electromagnetics import copolar_fraction, dot, lambertian_pattern, reflection_power, vertical_polarisation
from ..sionna_rt import LambertianPattern, aligned_float, dr, mi
from .errors import PixelEngineError
from .pixel_grid import PixelRender


@dataclass
class DiffuseMaterial:
    """What the diffuse pixels need of a radio material: ``eta`` (complex relative permittivity),
    ``thickness`` (m), scattering coefficient :math:`S`, XPD coefficient :math:`K_x`, the scattering
    ``pattern`` (Sionna's) and whether it is Lambertian (evaluated in numpy)."""

    name: str
    eta: complex
    thickness: float
    scattering_coefficient: float
    xpd_coefficient: float
    pattern: object
    lambertian: bool


def diffuse_material(obj_name: str, mat, scattering_coefficient: float | None = None) -> DiffuseMaterial:
    """:class:`DiffuseMaterial` of a Sionna ``RadioMaterial`` at its scene's frequency; a
    ``scattering_coefficient`` replaces the material's own :math:`S` (the engine's option)."""
    needed = ("relative_permittivity", "conductivity", "thickness", "scattering_coefficient",
              "xpd_coefficient", "scattering_pattern")
    missing = [a for a in needed if not hasattr(mat, a)]
    if missing:
        raise PixelEngineError(
            f"PixelEngine: object {obj_name!r} has radio material {getattr(mat, 'name', mat)!r} of type "
            f"{type(mat).__name__} without {', '.join(missing)}; the pixel engine needs Sionna's RadioMaterial model")
    omega = float(np.asarray(mat.scene.angular_frequency).ravel()[0])
    eps_r = float(np.asarray(mat.relative_permittivity).ravel()[0])
    sigma = float(np.asarray(mat.conductivity).ravel()[0])
    s = float(np.asarray(mat.scattering_coefficient).ravel()[0])
    if scattering_coefficient is not None:
        s = scattering_coefficient
    return DiffuseMaterial(
        name=str(getattr(mat, "name", "")), eta=complex(eps_r, -sigma / (omega * VACUUM_PERMITTIVITY)),
        thickness=float(np.asarray(mat.thickness).ravel()[0]), scattering_coefficient=s,
        xpd_coefficient=float(np.asarray(mat.xpd_coefficient).ravel()[0]), pattern=mat.scattering_pattern,
        lambertian=isinstance(mat.scattering_pattern, LambertianPattern))


def diffuse_cells(vertices, faces, cell_size: float) -> np.ndarray:
    """Barycentric quantisation steps ``[F]`` of every triangle for
    :func:`~sionnafmcw.diffuse.scatterer_phases`: ``ceil(longest edge / cell_size)``."""
    corners = np.asarray(vertices, float)[np.asarray(faces, np.int64)]
    edge = np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=-1)
    return cells_per_edge(edge.max(axis=1) if len(edge) else np.zeros(0), cell_size)


def hit_geometry(objects, obj, triangle, bary):
    """World position (float64, from the triangle and barycentrics), facet normal and velocity of hits on
    ``objects[obj]`` (:func:`~.po_render.scene_objects`)."""
    num = len(obj)
    position, normal, velocity = np.empty((num, 3)), np.empty((num, 3)), np.zeros((num, 3))
    for k in np.unique(obj):
        sel = np.flatnonzero(obj == k)
        position[sel], _, velocity[sel], _ = objects[k].hit_geometry(triangle[sel], bary[sel])
        normal[sel] = objects[k].facet_normals(triangle[sel])
    return position, normal, velocity


def pixel_echoes(frame: int, grid, radar, pose, rotation, centre, hits, objects, materials, array_model: str,
             phases=None):
    r"""The diffuse (Lambertian) echo of every hit pixel (module docstring) and the :class:`~.pixel_grid.PixelRender`.

    ``hits``: ``(valid [K], obj [K], triangle [K], barycentric [K, 2])`` of the grid's pixel rays
    (``K = grid.num_pixels``), cast over a :class:`~.surfaces.SurfaceWorld` placed in the frame;
    ``objects``: its :func:`~.po_render.scene_objects`; ``materials``: per object a
    :class:`DiffuseMaterial`; ``array_model``: ``"plane-wave"`` or ``"exact"``; ``phases``: None (the
    paper's deterministic eq. (2)) or a function of ``(obj, triangle, barycentric)`` giving each
    contributing pixel's random phase (rad). Returns ``(render, echoes)``; pixels whose material gives
    no diffuse echo (:math:`S = 0`) are in the render but not in the echoes.
    """
    valid, hit_obj, hit_prim, hit_uv = hits
    m_tx, n_rx = radar.num_tx, radar.num_rx
    wavelength = SPEED_OF_LIGHT / radar.fc
    pix = np.nonzero(valid)[0]
    obj = hit_obj[pix]
    prim, uv = hit_prim, hit_uv
    num = pix.size
    if num == 0:
        empty = np.zeros(0)
        render = PixelRender(frame=frame, grid=grid, pixel=pix, azimuth=empty, elevation=empty,
                             solid_angle=empty, range=empty, position=np.zeros((0, 3)), normal=np.zeros((0, 3)),
                             velocity=np.zeros((0, 3)), radial_velocity=empty, cos_incidence=empty, rcs=empty,
                             labels=np.zeros(0, dtype=str), contributes=np.zeros(0, dtype=bool))
        echoes = Echoes.empty(m_tx, n_rx)
        echoes.labels = np.zeros((m_tx, n_rx, 0), dtype=str)
        return render, echoes

    # ---- geometry of the hits (float64): point from the triangle and barycentrics, face normal
    position, normal, velocity = hit_geometry(objects, obj, prim[pix], uv[pix])
    offset = position - centre
    rng = np.linalg.norm(offset, axis=-1)
    # direction to the hit point (world): the pixel centre's to float32 precision of the cast
    u = offset / rng[:, None]
    cos_i = np.abs(dot(normal, u))
    mats = list(materials)
    s_coef = np.array([m.scattering_coefficient for m in mats])[obj] if num else np.zeros(0)
    kx = np.array([m.xpd_coefficient for m in mats])[obj] if num else np.zeros(0)
    solid = grid.solid_angles().reshape(-1)[pix]
    area = np.divide(rng ** 2 * solid, cos_i, out=np.zeros(num), where=cos_i > 1e-12)  # A = R^2 dOmega / cos(theta_i)

    # ---- element geometry (world): plane-wave -> the phase centre for every element
    tx_w = pose.position + radar.tx_positions @ rotation.T
    rx_w = pose.position + radar.rx_positions @ rotation.T
    if array_model == "exact":
        src, dst = tx_w, rx_w
    else:
        src, dst = centre[None, :], centre[None, :]
    d_in = position[None, :, :] - src[:, None, :]            # [Ms, P, 3] Tx -> point
    r_in = np.linalg.norm(d_in, axis=-1)
    k_in = d_in / r_in[..., None]
    d_out = position[None, :, :] - dst[:, None, :]           # [Ns, P, 3] Rx -> point
    r_out = np.linalg.norm(d_out, axis=-1)
    k_out = -d_out / r_out[..., None]                        # point -> Rx (propagation)

    # gains towards the point, in the radar frame (the same patterns as Sionna)
    g_t = antenna_gain(radar.antenna_pattern, *direction_angles(d_in @ rotation))
    g_r = antenna_gain(radar.antenna_pattern, *direction_angles(d_out @ rotation))
    # polarisations (unit, world) and Sionna's reflection coefficient of the incident polarisation
    e_t = vertical_polarisation(k_in, rotation)             # [Ms, P, 3]
    e_r = vertical_polarisation(-k_out, rotation)           # [Ns, P, 3]
    cos_in = np.abs(dot(normal[None], k_in))                # [Ms, P]
    gamma2 = gamma_squared(obj, mats, normal, k_in, e_t, cos_in, wavelength)
    # XPD: co-polar fraction of the scattered field at each Rx element, [Ms, Ns, P]
    chi = copolar_fraction(e_t[:, None], k_in[:, None], e_r[None], k_out[None], kx)
    cos_s = np.abs(dot(normal[None], k_out))                 # [Ns, P]
    f_s = scattering_pattern(obj, mats, normal, k_in, k_out, cos_s)   # [Ms, Ns, P]
    # bistatic RCS sigma_mn = 4 pi A cos(theta_i,m) S^2 Gamma_m^2 chi_mn f_s,mn
    sigma = 4 * np.pi * area * cos_in[:, None, :] * s_coef ** 2 * gamma2[:, None, :] * chi * f_s
    amp = wavelength * np.sqrt(g_t[:, None, :] * g_r[None, :, :] * sigma) / (
        (4 * np.pi) ** 1.5 * r_in[:, None, :] * r_out[None, :, :])
    velocity_doppler = dot(velocity[None, None], k_out[None] - k_in[:, None]) / wavelength   # [Ms, Ns, P]

    if array_model == "exact":
        tau = (r_in[:, None, :] + r_out[None, :, :]) / SPEED_OF_LIGHT
    else:
        dt = (tx_w - centre) @ u.T                              # [M, P] element offsets along u
        dr_ = (rx_w - centre) @ u.T                             # [N, P]
        tau = (2 * rng[None, None, :] - dt[:, None, :] - dr_[None, :, :]) / SPEED_OF_LIGHT
    shape = (m_tx, n_rx, num)
    amp = np.broadcast_to(amp, shape)
    doppler = np.broadcast_to(velocity_doppler, shape)

    labels = np.array([o.name for o in objects], dtype=object)[obj].astype(str) if num else np.zeros(0, dtype=str)
    # monostatic pixel RCS at the phase centre (plane-wave quantities) for the render
    if array_model == "exact":
        rcs_mono = monostatic_rcs(obj, mats, normal, u, rotation, area, s_coef, kx, wavelength)
    else:
        rcs_mono = sigma[0, 0]
    contributes = np.any(amp > 0, axis=(0, 1)) if num else np.zeros(0, dtype=bool)
    az, el = (x.reshape(-1)[pix] for x in grid.angles())
    render = PixelRender(frame=frame, grid=grid, pixel=pix, azimuth=az, elevation=el,
                         solid_angle=solid, range=rng, position=position, normal=normal, velocity=velocity,
                         radial_velocity=dot(velocity, u), cos_incidence=cos_i, rcs=rcs_mono, labels=labels,
                         contributes=contributes)
    keep = contributes
    a = amp[..., keep].astype(complex)
    if phases is not None and np.any(keep):
        # one scatterer per surface cell, the same phase for every element pair (module docstring)
        a = a * np.exp(1j * phases(obj[keep], prim[pix][keep], uv[pix][keep]))
    echoes = Echoes(a, tau[..., keep], doppler[..., keep], labels[keep])
    return render, echoes


def monostatic_rcs(obj, mats, normal, u, rotation, area, s_coef, kx, wavelength):
    r"""Monostatic pixel RCS at the phase centre (m^2), :math:`4\pi A\cos\theta_i S^2\Gamma^2\chi f_s`."""
    cos_i = np.abs(dot(normal, u))[None]
    k_in = u[None]
    e_t = vertical_polarisation(k_in, rotation)
    gamma2 = gamma_squared(obj, mats, normal, k_in, e_t, cos_i, wavelength)[0]
    chi = copolar_fraction(e_t[0], k_in[0], e_t[0], -u, kx)   # back to the same element
    f_s = scattering_pattern(obj, mats, normal, k_in, -k_in, cos_i)[0, 0]
    return 4 * np.pi * area * cos_i[0] * s_coef ** 2 * gamma2 * chi * f_s


def gamma_squared(obj, mats, normal, k_in, e_t, cos_in, wavelength):
    r"""Sionna's reflection coefficient of the incident polarisation :math:`\Gamma^2`, ``[Ms, P]``
    (:func:`~sionnafmcw.electromagnetics.reflection_power` with each hit's material)."""
    eta = np.array([m.eta for m in mats], dtype=complex)[obj]
    thick = np.array([m.thickness for m in mats])[obj]
    return reflection_power(cos_in, eta[None], thick[None], wavelength, k_in, normal[None], e_t)


def scattering_pattern(obj, mats, normal, k_in, k_out, cos_s):
    """Scattering pattern :math:`f_s` ``[Ms, Ns, P]``: Lambert in numpy, other patterns through Sionna."""
    ms, ns, num = k_in.shape[0], k_out.shape[0], normal.shape[0]
    out = np.broadcast_to(lambertian_pattern(cos_s[None]), (ms, ns, num)).copy()
    for k, mat in enumerate(mats):
        if mat.lambertian:
            continue
        sel = np.nonzero(obj == k)[0]
        if sel.size == 0:
            continue
        for m in range(ms):
            for n in range(ns):
                nrm = normal[sel] * np.sign(-dot(normal[sel], k_in[m, sel]))[:, None]  # towards the incident side
                frame = mi.Frame3f(mi.Vector3f(*[aligned_float(nrm[:, i])
                                                 for i in range(3)]))
                ki = frame.to_local(mi.Vector3f(*[aligned_float(k_in[m, sel, i])
                                                  for i in range(3)]))
                ko = frame.to_local(mi.Vector3f(*[aligned_float(k_out[n, sel, i])
                                                  for i in range(3)]))
                value = mat.pattern(ki, ko)
                dr.eval(value)
                out[m, n, sel] = np.asarray(value.numpy(), dtype=float)
    return out


__all__ = ["DiffuseMaterial", "diffuse_cells", "diffuse_material", "gamma_squared", "hit_geometry",
           "monostatic_rcs", "pixel_echoes", "scattering_pattern"]
