r"""Pixel engine: every pixel of a render from the radar is a point target (eq. (2) of the reference paper).

The reference paper is Y. Liu, M. Ahmadi, J. Fuchs, M. Alaee-Kerahroodi and M. R. Bhavani Shankar,
"A Blender-based channel simulator for FMCW radar", Interdisciplinary Centre for Security,
Reliability and Trust (SnT), University of Luxembourg (see ``docs/index.md``); its eq. (2) models the beat
signal as a sum over the pixels of a render, each pixel a point target with range, strength,
angle and velocity. "The paper" below is this one.

Each frame is "photographed" from the radar: one ray per pixel centre is cast from the virtual
array's phase centre with Mitsuba's ``ray_intersect_preliminary`` (the intersection half of
``ray_intersect``: distance, shape, triangle and barycentrics; deterministic) on the very scene
the path engine loads (:func:`~sionnafmcw.engines.loaded_scene.load_radar_scene`: same XML,
same radio materials, the same per-frame vertex updates through the Mitsuba scene parameters).
Every pixel that hits a surface is one contribution of the :class:`~sionnafmcw.echoes.Echoes`
(shape ``[num_tx, num_rx, num_hit_pixels]``, labelled with the name of the object hit) with its
range, direction, strength and velocity -- the paper's matrices :math:`R, P_r, \Theta, V`.

Pixel grid
----------
Equiangular in the radar frame (boresight local :math:`+x`, azimuth :math:`\varphi` from
:math:`+x` towards :math:`+y`, elevation :math:`\vartheta` towards :math:`+z`): with fields of
view :math:`\Phi` (azimuth) and :math:`\Theta` (elevation) and :math:`N_{az}\times N_{el}` pixels,
:math:`\Delta\varphi = \Phi/N_{az}`, :math:`\Delta\vartheta = \Theta/N_{el}`, the pixel centres are

.. math::
    \varphi_j = -\tfrac{\Phi}{2} + (j + \tfrac12)\Delta\varphi,\qquad
    \vartheta_i = -\tfrac{\Theta}{2} + (i + \tfrac12)\Delta\vartheta,\qquad
    \hat{\mathbf u}_{ij} = [\cos\vartheta_i\cos\varphi_j,\ \cos\vartheta_i\sin\varphi_j,\ \sin\vartheta_i]

and the solid angle of a pixel is the exact integral of :math:`\cos\vartheta\,d\vartheta\,d\varphi`
over it,

.. math::
    \Delta\Omega_{ij} = \Delta\varphi\,[\sin(\vartheta_i + \tfrac{\Delta\vartheta}{2})
                        - \sin(\vartheta_i - \tfrac{\Delta\vartheta}{2})]
                      = 2\,\Delta\varphi\cos\vartheta_i\sin\tfrac{\Delta\vartheta}{2},
    \qquad \sum_{ij}\Delta\Omega_{ij} = 2\,\Phi\sin\tfrac{\Theta}{2}.

Rows are ordered by increasing elevation, columns by increasing azimuth; the flat pixel index is
``i * n_az + j``. :math:`\Phi, \Theta \in (0, \pi]`.

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
by default; the cells per edge are fixed from the frame-0 mesh). The phase is fixed to the
surface point, so it moves with the body, is the same for every Tx/Rx pair (one set of
scatterers for the whole array: the MIMO phase between channels is the geometry's) and for every
chirp, and a static surface keeps it from frame to frame. Neighbouring pixels then add in power,
:math:`E|\sum_p a_p e^{j\phi_p}e^{-j2\pi f\tau_p}|^2 = \sum_p|a_p|^2`, whatever the pixel count
(4x pixels move the mean clutter-removed map power by < 0.5 dB, ``tests/test_pixel_po.py``).
``diffuse_phase="deterministic"`` is the paper's eq. (2) as published: real :math:`|a|`, so
neighbours add coherently and the map power grows with the pixel count (about 6 dB per 4x
pixels on a surface facing the radar, issue 11).

Models: physical optics for the coherent echo (default) or the paper's Lambertian eq. (2)
-----------------------------------------------------------------------------------------
Sionna's material model splits the reflected power of a surface into a coherent (specular)
share :math:`(1 - S^2)|\Gamma|^2` and a diffuse share :math:`S^2|\Gamma|^2`.

``model="physical-optics"`` (default): the coherent share is the near-field physical-optics
integral over the lit surface (:mod:`sionnafmcw.physical_optics`), the diffuse share the
random-phase Lambertian pixels above; nothing is counted twice. The PO integral is evaluated on
a second render, per object (:meth:`PixelEngine._po_samples`): an equiangular grid over the
object's angular box (:func:`angular_box`) with the step of
:func:`~sionnafmcw.physical_optics.render_resolution` for its size, its farthest range, its
curvature radius and, where the frame XML asks for facet normals (``face_normals``, as every
scene written by sionnafmcw does), a sixth of its facet size (:func:`surface_figures`,
:data:`FACET_SHARE`); all
objects' rays in one cast from the phase centre (``ray_intersect``: the hit's shading normal, the
interpolated vertex normal where the mesh has them, else the facet normal); a ray keeps its hit
only on the object it was cast for. Each hit is a :class:`~sionnafmcw.physical_optics.SurfaceSamples`
sample (area :math:`r^2\Delta\Omega/\cos\theta_i`, footprint edges for the in-sample phase,
velocity interpolated as below, the material's co-polar slab reflection coefficient
:math:`\Gamma = r_{TE}(\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2 - r_{TM}(1 - (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2)`,
:func:`copolar_reflection`, scaled by :math:`\sqrt{1 - S^2}`), and
:func:`~sionnafmcw.physical_optics.po_echoes` gives every Tx/Rx pair its exact delay, Doppler,
element gains and obliquity (near-field exact whatever ``array_model``). The PO contributions
follow the pixels' in the :class:`~sionnafmcw.echoes.Echoes`. Measured through the engine
(``tests/test_pixel_po.py``): metal plates of 0.1 and 0.2 m facing the radar at 2-20 m within
0.03 dB of the near-field Fresnel PO, a plate split in 2 or 128 triangles the same echo, a
faceted sphere :math:`\pi r^2` within 1 dB.

Why PO is the default (decision, issue 11): the Lambertian pixels alone miss the coherent share,
which is the dominant echo of every smooth surface facing the radar -- a 0.1 m metal plate at
5 m is 18.7 dBsm by PO and invisible (:math:`S = 0`) or :math:`4AS^2` = -14 dBsm to them, a
torso facet normal to the line of sight likewise -- and PO, unlike the path engine's
geometric-optics mirror, is right for finite and curved surfaces. ``model="lambertian"`` keeps
the paper's eq. (2) (every pixel a Lambertian scatterer of the diffuse share only; with
``diffuse_phase="deterministic"`` exactly as published) to reproduce the paper. In that model:

* pixel-vs-path comparisons are fair against the path engine with ``max_depth=1`` and either
  ``specular=False`` or surfaces whose mirror echo misses the radar; the diffuse parts then
  agree in absolute power (0.01-0.02 dB measured, ``tests/test_pixel_engine.py``);
* a smooth surface facing the radar is a weak diffuse reflector (a 1 m metal plate at 2 / 5 m
  with ``scattering_coefficient=1``: 6 / 13 dB below the path engine's mirror, walk-77ghz);
* a material with :math:`S = 0` (Sionna's default, every ITU material) is invisible.

Neither model has multipath (target-floor-radar) or the triple bounce of a corner reflector:
the pixel engine is single-bounce.

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

Measured
--------
Tilted rough plate (1 m at 5 m, yaw 30 deg, pitch 20 deg, :math:`\varepsilon_r` = 5,
:math:`\sigma` = 0.1 S/m, :math:`K_x` = 0.3, radar pitched 5 deg, walk-77ghz): pixel engine
(640 x 640 pixels over 26 deg) minus path engine (``max_depth=1``, 4e6 rays per Tx) = -0.016 dB
for :math:`S = 0.5` and +0.011 dB for :math:`S = 1` (Monte-Carlo 4 sigma: 8 % and 4 %), both
with ``model="lambertian"``. Circle-walk room (walls, floor, ceiling, 14-part body), 128 x 64
pixels, 3 Tx x 4 Rx, two shared CPU cores: 0.13 s per frame with ``"plane-wave"`` and 0.2-0.25 s
with ``"exact"`` in the Lambertian model, of which the ray cast is 2-8 ms and Mitsuba's scene
update of the moving meshes about 45 ms; the rest is numpy. The physical-optics model
(``benchmarks/pixel_engine.py``, the same machine shared with other jobs, so slower than above:
0.19 s per frame Lambertian): 2.3e5 PO rays and 1.45e5 samples per frame (room 9.2e4, body
5.1e4), merged to 1.0e5 contributions; 4.0 s per frame, of which the casts are 0.4 s and the
rest numpy (PO gains per element pair, the merge); synthesizing them 15 s per frame (2.6 s
Lambertian). Mitsuba's ``aov`` integrator would only replace the casts.

No recompilation
----------------
The scene is loaded once per animation and radar; each frame writes the vertex positions of the
meshes whose PLY changed through the Mitsuba scene parameters (no reload), the rays are built
from numpy arrays (the pose is data, not a kernel constant), and everything after the ray cast
is numpy. The only kernels are the ray cast (and the scene update of moving meshes, run once while
loading); :attr:`PixelEngine.stats` records launches and new kernel hashes per frame. The ray
inputs are copied into 64-byte aligned buffers: Dr.Jit compiles the alignment of numpy inputs into
the kernel, and numpy's allocations are not always aligned, which gave the same ray cast a new
kernel hash in some frames.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..animation import Animation, RadarPose
from ..antenna import antenna_gain, check_pattern, direction_angles
from ..constants import SPEED_OF_LIGHT, VACUUM_PERMITTIVITY
from ..echoes import Echoes
from ..diffuse import cells_per_edge, scatterer_phases
from ..electromagnetics import (
    copolar_fraction, dot, lambertian_pattern, reflection_power, slab_reflection_coefficients, unit,
    vertical_polarisation,
)
from ..physical_optics import SurfaceSamples, angular_grid_steps, po_echoes, render_resolution, render_samples
from ..geometry import rotation_matrix
from ..array import phase_centre
from ..sionna_rt import LambertianPattern, cast_rays, dr, mi
from .base import Engine, EngineError
from .loaded_scene import interpolate
from .po_render import MERGE_FRACTION as _PO_MERGE_FRACTION


class PixelEngineError(EngineError):
    """The pixel engine cannot run with these parameters or this animation; the message says why."""


# ---------------------------------------------------------------------------------------- pixel grid
@dataclass(frozen=True)
class PixelGrid:
    """Equiangular azimuth/elevation grid of pixel centres in the radar frame (module docstring)."""

    n_az: int
    n_el: int
    fov_az: float
    fov_el: float

    def __post_init__(self):
        for name in ("n_az", "n_el"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise PixelEngineError(f"PixelEngine: {name} must be an integer >= 1, got {value!r}")
        for name in ("fov_az", "fov_el"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                    or not np.isfinite(value) or not 0.0 < value <= np.pi:
                raise PixelEngineError(
                    f"PixelEngine: {name} must be an angle in (0, pi] rad, got {value!r} (angles are in radians)")

    @property
    def d_az(self) -> float:
        """Azimuth pixel width :math:`\\Delta\\varphi` (rad)."""
        return float(self.fov_az) / self.n_az

    @property
    def d_el(self) -> float:
        """Elevation pixel height :math:`\\Delta\\vartheta` (rad)."""
        return float(self.fov_el) / self.n_el

    @property
    def azimuths(self) -> np.ndarray:
        """Pixel-centre azimuths ``[n_az]`` (rad, increasing)."""
        return -self.fov_az / 2 + (np.arange(self.n_az) + 0.5) * self.d_az

    @property
    def elevations(self) -> np.ndarray:
        """Pixel-centre elevations ``[n_el]`` (rad, increasing)."""
        return -self.fov_el / 2 + (np.arange(self.n_el) + 0.5) * self.d_el

    @property
    def num_pixels(self) -> int:
        return self.n_az * self.n_el

    def angles(self) -> tuple[np.ndarray, np.ndarray]:
        """Azimuth and elevation of every pixel, each ``[n_el, n_az]`` (rad)."""
        el, az = np.meshgrid(self.elevations, self.azimuths, indexing="ij")
        return az, el

    def directions(self) -> np.ndarray:
        """Unit vectors ``[n_el, n_az, 3]`` through the pixel centres (radar frame)."""
        az, el = self.angles()
        return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)

    def solid_angles(self) -> np.ndarray:
        r"""Pixel solid angles ``[n_el, n_az]`` (sr):
        :math:`\Delta\Omega_{ij} = \Delta\varphi[\sin(\vartheta_i + \Delta\vartheta/2) - \sin(\vartheta_i - \Delta\vartheta/2)]`."""
        el = self.elevations
        band = np.sin(el + self.d_el / 2) - np.sin(el - self.d_el / 2)
        return np.broadcast_to((self.d_az * band)[:, None], (self.n_el, self.n_az)).copy()

    @property
    def field_of_view_solid_angle(self) -> float:
        """:math:`2\\Phi\\sin(\\Theta/2)` (sr), the sum of :meth:`solid_angles`."""
        return 2.0 * float(self.fov_az) * np.sin(float(self.fov_el) / 2)


# ---------------------------------------------------------------------------------------- results
@dataclass
class PixelRender:
    """What the radar "sees" in one frame: the hit pixels, in the order of the echoes' contributions.

    All arrays are ``[P]`` (``[P, 3]`` for vectors, world frame) over the pixels that hit a
    surface; :meth:`image` puts one of them back on the ``[n_el, n_az]`` grid. ``rcs`` is the
    monostatic pixel RCS at the phase centre :math:`\\sigma_p = 4\\pi A\\cos\\theta_i S^2\\Gamma^2\\chi f_s`
    (m^2); ``contributes`` marks the pixels with a non-zero echo (the contributions of the
    :class:`Echoes`, in this order).
    """

    frame: int
    grid: PixelGrid
    pixel: np.ndarray
    azimuth: np.ndarray
    elevation: np.ndarray
    solid_angle: np.ndarray
    range: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    velocity: np.ndarray
    radial_velocity: np.ndarray
    cos_incidence: np.ndarray
    rcs: np.ndarray
    labels: np.ndarray
    contributes: np.ndarray

    @property
    def num_hits(self) -> int:
        return int(self.pixel.size)

    def image(self, values, fill=np.nan) -> np.ndarray:
        """``values [P]`` on the pixel grid ``[n_el, n_az]`` (rows: increasing elevation), ``fill`` elsewhere."""
        values = np.asarray(values)
        out = np.full(self.grid.num_pixels, fill, dtype=np.result_type(values.dtype, np.asarray(fill).dtype))
        out[self.pixel] = values
        return out.reshape(self.grid.n_el, self.grid.n_az)


# ---------------------------------------------------------------------------------------- PO render helpers
#: Share of a faceted mesh's edge length given to ``render_resolution(facet_size=...)``, whose rule
#: is then s <= edge / 6. Measured through the engine on a 0.1 m metal sphere of 4.9 mm facets at
#: 2-20 m against the independent triangle quadrature (tests/po_quadrature.py): s = edge / 3 is
#: -0.9 to +0.3 dB off, edge / 6 within 0.05 dB, edge / 12 no closer.
FACET_SHARE = 0.5
#: Dihedral angle (rad) above which an edge is a geometric edge (a box's, a trihedral's, a slab's rim),
#: not a sampled curvature: such edges enter neither the curvature radius nor the facet size.
EDGE_ANGLE = np.deg2rad(30.0)

@dataclass(frozen=True)
class SurfaceFigures:
    r"""What the PO render and the diffuse phases need to know of one mesh (from its frame-0 geometry).

    ``cells [F]``: barycentric quantisation steps per triangle for :func:`~sionnafmcw.diffuse.scatterer_phases`
    (``ceil(longest edge / cell size)``, fixed at frame 0 so a surface cell keeps its phase while the
    mesh deforms); ``curvature_radius`` (m): the 10th percentile of :math:`\rho = \ell/\alpha` over
    the edges that sample a curved surface (length :math:`\ell`, dihedral angle
    :math:`10^{-3} < \alpha \le` :data:`EDGE_ANGLE`; sharper edges are the geometry's own, a box's or
    a slab's; ``inf`` when there are none: flat pieces); ``facet_size`` (m): the median length of
    those edges (None when there are none, or when the mesh's shading normals are interpolated, so
    samples need not stay on one facet).
    """

    cells: np.ndarray
    curvature_radius: float
    facet_size: float | None


def surface_figures(vertices, faces, cell_size: float, face_normals: bool = True) -> SurfaceFigures:
    """:class:`SurfaceFigures` of a triangle mesh (``vertices [V, 3]`` m, ``faces [F, 3]``)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces, dtype=np.int64)
    corners = v[f]                                              # [F, 3, 3]
    edge = np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=-1)   # [F, 3]
    cells = cells_per_edge(edge.max(axis=1) if len(f) else np.zeros(0), cell_size)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    norm = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, norm, out=np.zeros_like(normal), where=norm > 0)
    pairs = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    owner = np.tile(np.arange(len(f)), 3)
    key = np.sort(pairs, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, owner = key[order], owner[order]
    shared = np.nonzero(np.all(key[1:] == key[:-1], axis=1))[0]
    if shared.size:
        a, b = owner[shared], owner[shared + 1]
        angle = np.arccos(np.clip(np.abs(dot(normal[a], normal[b])), -1.0, 1.0))   # orientation-free
        length = np.linalg.norm(v[key[shared, 0]] - v[key[shared, 1]], axis=1)
        creased = (angle > 1e-3) & (angle <= EDGE_ANGLE)
    else:
        creased = np.zeros(0, dtype=bool)
    if not np.any(creased):
        return SurfaceFigures(cells, float("inf"), None)
    rho = float(np.percentile(length[creased] / angle[creased], 10))
    facet = float(np.median(length[creased])) if face_normals else None
    return SurfaceFigures(cells, rho, facet)


def angular_box(points_local, hit_azimuth=(), hit_elevation=(), pad=(0.0, 0.0)):
    """Azimuth/elevation box ``(az0, az1, el0, el1)`` (rad, radar frame) that holds an object.

    Where every vertex ``points_local [V, 3]`` (relative to the phase centre, radar frame) is in
    front (``x > 0``, the angles do not wrap), the box of the vertices, widened on a side only where
    the coarse render's hits on the object (``hit_azimuth``, ``hit_elevation``) reach beyond it
    (a big facet's outline bulges beyond its vertices' box), then by ``pad`` (one coarse pixel: the
    outline lies up to a pixel beyond the outermost hit). Otherwise the hits' box padded by ``pad``.
    None when neither exists. The vertex box is kept exact so that a grid can tile it
    (:func:`box_grid`): a rectangular facet's outline then falls on pixel edges.
    """
    p = np.asarray(points_local, float)
    hits = len(hit_azimuth) > 0
    if hits:
        h = (float(np.min(hit_azimuth)), float(np.max(hit_azimuth)),
             float(np.min(hit_elevation)), float(np.max(hit_elevation)))
    if p.size and np.all(p[:, 0] > 0):
        az = np.arctan2(p[:, 1], p[:, 0])
        el = np.arctan2(p[:, 2], np.hypot(p[:, 0], p[:, 1]))
        box = [float(az.min()), float(az.max()), float(el.min()), float(el.max())]
        if hits:
            if h[0] < box[0]:
                box[0] = h[0] - pad[0]
            if h[1] > box[1]:
                box[1] = h[1] + pad[0]
            if h[2] < box[2]:
                box[2] = h[2] - pad[1]
            if h[3] > box[3]:
                box[3] = h[3] + pad[1]
        return tuple(box)
    if hits:
        return h[0] - pad[0], h[1] + pad[0], h[2] - pad[1], h[3] + pad[1]
    return None


def box_grid(box, step: float):
    """Equiangular pixels tiling ``box = (az0, az1, el0, el1)`` (rad) with steps of at most ``step``:
    pixel-centre az, el ``[K]`` and the steps ``(d_az, d_el)`` (rad)."""
    az0, az1, el0, el1 = box
    n_az = max(1, int(np.ceil((az1 - az0) / step)))
    n_el = max(1, int(np.ceil((el1 - el0) / step)))
    d_az, d_el = (az1 - az0) / n_az, (el1 - el0) / n_el
    az = az0 + (np.arange(n_az) + 0.5) * d_az
    el = el0 + (np.arange(n_el) + 0.5) * d_el
    el, az = np.meshgrid(el, az, indexing="ij")
    return az.ravel(), el.ravel(), (d_az, d_el)


def copolar_reflection(cos_theta, eta, thickness, wavelength, k_in, normal, e_t) -> np.ndarray:
    r"""Complex co-polar reflection coefficient of the monostatic echo, :math:`\Gamma = r_{TE}
    (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2 - r_{TM}(1 - (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2)`
    (:mod:`sionnafmcw.physical_optics`, "Dielectrics"; Sionna's slab coefficients,
    :func:`~sionnafmcw.electromagnetics.slab_reflection_coefficients`; :math:`\hat{\mathbf s}` the
    TE direction :math:`\hat{\mathbf k}_{in}\times\hat{\mathbf n}`, any transverse direction at
    normal incidence). ``k_in``, ``normal``, ``e_t`` ``[P, 3]``; the others ``[P]`` or scalars.
    """
    r_te, r_tm = slab_reflection_coefficients(np.clip(cos_theta, 0.0, 1.0), eta, thickness, wavelength)
    s_hat = np.cross(k_in, normal)
    s_norm = np.linalg.norm(s_hat, axis=-1, keepdims=True)
    fallback = np.cross(k_in, np.where(np.abs(k_in[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
    s_hat = unit(np.where(s_norm > 1e-9, s_hat, fallback))
    te = dot(e_t, s_hat) ** 2
    return r_te * te - r_tm * (1.0 - te)


#: Cell size of :func:`merge_contributions` as a share of the radar's resolutions (PO mode): the
#: one value of both engines (:data:`sionnafmcw.engines.po_render.MERGE_FRACTION`).
MERGE_FRACTION = _PO_MERGE_FRACTION


def merge_contributions(echoes: Echoes, radar, directions, fraction: float = MERGE_FRACTION) -> Echoes:
    r"""Sum the contributions the radar cannot tell apart into one per cell and element pair.

    ``echoes [M, N, P]`` with ``directions [P, 3]`` (unit, radar frame, from the phase centre to
    each contribution). Contributions of one label fall in the same cell when their delay at pair
    (0, 0) lies in the same cell of :math:`\delta\tau = \epsilon/B`, their Doppler in the same cell
    of :math:`\delta f = \epsilon/T_{CPI}` (:math:`B` the sampled bandwidth, :math:`T_{CPI}` the
    frame's chirps, :math:`\epsilon` = ``fraction``) and their direction components
    :math:`u_y, u_z` in the same cell of :math:`\delta u = \epsilon c/(2BD)`, :math:`D` the largest
    element distance from the phase centre, so that every pair's delay offset
    :math:`-(\mathbf d_t + \mathbf d_r)\cdot\hat{\mathbf u}/c` varies by less than :math:`\epsilon/B`
    across a cell too. A cell becomes, per pair :math:`(m, n)`, one contribution at the mean delay
    :math:`\bar\tau_{mn}` and mean Doppler with

    .. math::
        \bar a_{mn} = \sum_{i\in\text{cell}} a_{mni}\,e^{-j2\pi f_c(\tau_{mni} - \bar\tau_{mn})}:

    the channel of every pair at the carrier is unchanged (the PO integral, the array's angle
    response), and what is lost is the beat phase across a cell within a chirp and the Doppler phase
    across the CPI, at most :math:`2\pi\epsilon` between the ends of a chirp and of the CPI. That
    bound is relative to :math:`\sum|a|`, not to the echo: a PO integral that nearly cancels (a
    plate seen off its specular direction) needs small cells. Measured on a 0.2 m metal plate at
    5 m (synthesized cube against the unmerged one): facing the radar +0.17 / +0.01 dB for
    :math:`\epsilon` = 1/16 / 1/256, turned 0.3 rad (72 dB weaker) +1.9 / +0.01 dB; hence
    :data:`MERGE_FRACTION` = 1/256. Labels are kept per cell; cells keep the order of their first
    contribution.
    """
    p = echoes.num_contributions
    if p == 0:
        return echoes
    m, n = echoes.shape[:2]
    bandwidth, cpi = float(radar.bandwidth), float(radar.cpi_duration)
    centre = phase_centre(radar)
    aperture = max(float(np.linalg.norm(np.concatenate([radar.tx_positions, radar.rx_positions]) - centre,
                                        axis=1).max()), 1e-6)
    d_tau, d_f = fraction / bandwidth, fraction / cpi
    d_u = fraction * SPEED_OF_LIGHT / (2 * bandwidth * aperture)
    labels = np.zeros(p, str) if echoes.labels is None else np.asarray(echoes.labels).reshape(-1, p)[0]
    names, lab = np.unique(labels.astype(str), return_inverse=True)
    u = np.asarray(directions, float)
    cols = [lab.reshape(-1), np.floor(echoes.tau[0, 0] / d_tau), np.floor(echoes.doppler[0, 0] / d_f),
            np.floor(u[:, 1] / d_u), np.floor(u[:, 2] / d_u)]
    keys = np.stack([np.asarray(c, dtype=np.int64) for c in cols], axis=1)
    _, first, group, counts = np.unique(keys, axis=0, return_index=True, return_inverse=True, return_counts=True)
    group = group.reshape(-1)
    # groups in the order of their first contribution
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    group, counts, first = rank[group], counts[order], first[order]
    g = counts.size
    flat_a = echoes.a.reshape(m * n, p)
    flat_tau = echoes.tau.reshape(m * n, p)
    flat_dop = echoes.doppler.reshape(m * n, p)
    out_a = np.empty((m * n, g), complex)
    out_tau, out_dop = np.empty((m * n, g)), np.empty((m * n, g))
    for k in range(m * n):
        mean_tau = np.bincount(group, flat_tau[k], g) / counts
        z = flat_a[k] * np.exp(-2j * np.pi * radar.fc * (flat_tau[k] - mean_tau[group]))
        out_a[k] = np.bincount(group, z.real, g) + 1j * np.bincount(group, z.imag, g)
        out_tau[k] = mean_tau
        out_dop[k] = np.bincount(group, flat_dop[k], g) / counts
    return Echoes(out_a.reshape(m, n, g), out_tau.reshape(m, n, g), out_dop.reshape(m, n, g),
                  names[lab.reshape(-1)[first]])


@dataclass
class _Material:
    name: str
    eta: complex
    thickness: float
    scattering_coefficient: float
    xpd_coefficient: float
    pattern: object
    lambertian: bool


@dataclass
class _State:
    """Per-scene state of the pixel engine: the objects and their materials."""

    names: list                     # object names, index = local object index
    index_by_id: dict               # Sionna object_id -> local object index
    materials: list                 # local object index -> _Material
    surfaces: dict = field(default_factory=dict)   # name -> SurfaceFigures (frame-0 mesh, filled on first use)


# ---------------------------------------------------------------------------------------- engine
class PixelEngine(Engine):
    r"""The scene rendered from the radar; each hit pixel a point target (see the module docstring).

    Parameters
    ----------
    n_az, n_el : int
        Pixels in azimuth (columns, along the radar's local y) and elevation (rows, along z).
    fov_az, fov_el : float
        Fields of view (rad), each in (0, pi].
    array_model : str
        ``"plane-wave"`` (eq. (2) of the paper, far field) or ``"exact"`` (spherical wavefronts
        per element).
    scattering_coefficient : float or None
        None: each material's own :math:`S` (consistent with the path engine); a number in
        [0, 1]: that :math:`S` for every material.
    vertex_doppler : bool
        Use per-vertex velocities from the PLYs where present (else the manifest velocity).
    model : str
        ``"physical-optics"`` (default): near-field PO for the coherent share :math:`(1 - S^2)|\Gamma|^2`
        on a per-object render plus the random-phase Lambertian pixels for the diffuse share
        :math:`S^2|\Gamma|^2`; ``"lambertian"``: the pixels only (the paper's eq. (2)).
    diffuse_phase : str
        ``"random"`` (default): each pixel's diffuse contribution carries the phase of the surface
        cell it hit (:func:`~sionnafmcw.diffuse.scatterer_phases`); ``"deterministic"``: none (the
        paper's eq. (2); the map power then grows with the pixel count).
    diffuse_cell_size : float or None
        Size (m) of the surface cells of the diffuse phases; None: :math:`\lambda/4` of the radar.
    po_samples_across : int
        Least number of PO samples across an object (:func:`~sionnafmcw.physical_optics.render_resolution`).
    po_max_rays : int
        Most PO rays per object and frame; a finer rule is coarsened to it with a warning.
    po_merge : bool
        Sum the PO samples the radar cannot tell apart (:func:`merge_contributions`, cells of
        :data:`MERGE_FRACTION` of the range, velocity and array-phase resolution) into one
        contribution per cell and pair: the same channel at the carrier, fewer contributions to
        synthesize.
    track_kernels : bool
        Record Dr.Jit kernel launches per frame in :attr:`stats`.

    Notes
    -----
    :attr:`stats` figures: ``trace_seconds`` (the ray cast), ``num_hits`` (pixels that hit a
    surface), ``num_contributions`` (hit pixels with a non-zero echo, plus the PO samples),
    ``num_po_rays`` and ``num_po_samples`` (the PO render's rays and its hits on the objects it was
    cast for; 0 in the Lambertian model), ``num_po_contributions`` (the PO samples after
    :func:`merge_contributions`).
    """

    name = "pixel"
    FIXED_SETTINGS = {"max_depth": 1}
    ARRAY_MODELS = ("plane-wave", "exact")
    MODELS = ("physical-optics", "lambertian")
    DIFFUSE_PHASES = ("random", "deterministic")

    def __init__(self, n_az: int = 128, n_el: int = 64, fov_az: float = float(np.deg2rad(120.0)),
                 fov_el: float = float(np.deg2rad(60.0)), array_model: str = "plane-wave",
                 scattering_coefficient: float | None = None, vertex_doppler: bool = True,
                 model: str = "physical-optics", diffuse_phase: str = "random",
                 diffuse_cell_size: float | None = None, po_samples_across: int = 16, po_max_rays: int = 2_000_000,
                 po_merge: bool = True, track_kernels: bool = True):
        if model not in self.MODELS:
            raise PixelEngineError(f"PixelEngine: model={model!r} is unknown; choose one of {', '.join(self.MODELS)}")
        if diffuse_phase not in self.DIFFUSE_PHASES:
            raise PixelEngineError(f"PixelEngine: diffuse_phase={diffuse_phase!r} is unknown; choose one of "
                                   f"{', '.join(self.DIFFUSE_PHASES)}")
        if diffuse_cell_size is not None and (isinstance(diffuse_cell_size, bool) or not isinstance(
                diffuse_cell_size, (int, float, np.integer, np.floating)) or not np.isfinite(diffuse_cell_size)
                or diffuse_cell_size <= 0):
            raise PixelEngineError(f"PixelEngine: diffuse_cell_size must be None or a positive length in m, "
                                   f"got {diffuse_cell_size!r}")
        for name, value in (("po_samples_across", po_samples_across), ("po_max_rays", po_max_rays)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise PixelEngineError(f"PixelEngine: {name} must be an integer >= 1, got {value!r}")
        if array_model not in self.ARRAY_MODELS:
            raise PixelEngineError(
                f"PixelEngine: array_model={array_model!r} is unknown; choose one of {', '.join(self.ARRAY_MODELS)}")
        if scattering_coefficient is not None:
            if isinstance(scattering_coefficient, bool) or not isinstance(
                    scattering_coefficient, (int, float, np.integer, np.floating)) \
                    or not 0.0 <= float(scattering_coefficient) <= 1.0:
                raise PixelEngineError(
                    f"PixelEngine: scattering_coefficient must be None or a number in [0, 1], "
                    f"got {scattering_coefficient!r}")
            scattering_coefficient = float(scattering_coefficient)
        grid = PixelGrid(n_az, n_el, fov_az, fov_el)
        super().__init__(track_kernels=track_kernels)
        self.grid = grid
        self.array_model = array_model
        self.scattering_coefficient = scattering_coefficient
        self.vertex_doppler = bool(vertex_doppler)
        self.model = model
        self.diffuse_phase = diffuse_phase
        self.diffuse_cell_size = None if diffuse_cell_size is None else float(diffuse_cell_size)
        self.po_samples_across = int(po_samples_across)
        self.po_max_rays = int(po_max_rays)
        self.po_merge = bool(po_merge)
        self.last_po_samples: SurfaceSamples | None = None
        self._directions = self.grid.directions().reshape(-1, 3)
        self._solid_angles = self.grid.solid_angles().reshape(-1)
        az, el = self.grid.angles()
        self._az, self._el = az.reshape(-1), el.reshape(-1)
        self.last_render: PixelRender | None = None

    def _settings(self) -> dict:
        return {"n_az": self.grid.n_az, "n_el": self.grid.n_el, "fov_az": float(self.grid.fov_az),
                "fov_el": float(self.grid.fov_el), "array_model": self.array_model,
                "scattering_coefficient": self.scattering_coefficient, "vertex_doppler": self.vertex_doppler,
                "model": self.model, "diffuse_phase": self.diffuse_phase,
                "diffuse_cell_size": self.diffuse_cell_size, "po_samples_across": self.po_samples_across,
                "po_max_rays": self.po_max_rays, "po_merge": self.po_merge,
                # what the model computes (constants of the model, for pixel-vs-path comparisons)
                "scattering": "diffuse" if self.model == "lambertian" else "physical-optics+diffuse",
                "specular": self.model == "physical-optics"}

    # ------------------------------------------------------------------ set-up
    def _material(self, obj_name: str, mat) -> _Material:
        needed = ("relative_permittivity", "conductivity", "thickness", "scattering_coefficient",
                  "xpd_coefficient", "scattering_pattern")
        missing = [a for a in needed if not hasattr(mat, a)]
        if missing:
            raise PixelEngineError(
                f"PixelEngine: object {obj_name!r} has radio material {getattr(mat, 'name', mat)!r} of type "
                f"{type(mat).__name__} without {', '.join(missing)}; the pixel engine needs Sionna's RadioMaterial model")
        scene = mat.scene
        omega = float(np.asarray(scene.angular_frequency).ravel()[0])
        eps_r = float(np.asarray(mat.relative_permittivity).ravel()[0])
        sigma = float(np.asarray(mat.conductivity).ravel()[0])
        s = float(np.asarray(mat.scattering_coefficient).ravel()[0])
        if self.scattering_coefficient is not None:
            s = self.scattering_coefficient
        return _Material(
            name=str(getattr(mat, "name", "")), eta=complex(eps_r, -sigma / (omega * VACUUM_PERMITTIVITY)),
            thickness=float(np.asarray(mat.thickness).ravel()[0]), scattering_coefficient=s,
            xpd_coefficient=float(np.asarray(mat.xpd_coefficient).ravel()[0]), pattern=mat.scattering_pattern,
            lambertian=isinstance(mat.scattering_pattern, LambertianPattern))

    def _load(self, scene, animation: Animation, radar) -> _State:
        """The objects and their materials; a first ray cast compiles the cast's kernel while loading."""
        names, index_by_id, materials = [], {}, []
        for name, obj in scene.objects.items():
            index_by_id[int(obj.object_id)] = len(names)
            names.append(name)
            materials.append(self._material(name, obj.radio_material))
        if self.model == "lambertian" and materials and all(m.scattering_coefficient == 0 for m in materials):
            warnings.warn(
                f"PixelEngine: every material of {animation.frames[0].xml} has scattering_coefficient 0; the pixel "
                "engine's Lambertian model sees diffuse scattering only, so it sees nothing. Give the materials a "
                "scattering_coefficient, set PixelEngine(scattering_coefficient=...) or use "
                "model='physical-optics'.", stacklevel=3)
        cast_rays(scene, np.zeros(3), np.tile([[1.0, 0.0, 0.0]], (self.grid.num_pixels, 1)))
        if self.model == "physical-optics":   # the PO cast's kernels (surface interaction), compiled while loading
            cast_rays(scene, np.zeros(3), np.tile([[1.0, 0.0, 0.0]], (7, 1)), shading_normals=True)
        return _State(names, index_by_id, materials)

    def _check_radar(self, radar) -> None:
        check_pattern(radar.antenna_pattern)

    def _geometry_changed(self) -> None:
        dr.eval()

    # ------------------------------------------------------------------ public
    def render(self, animation: Animation, radar, frame: int, radar_pose: RadarPose | None = None) -> PixelRender:
        """Cast the pixel rays of ``frame`` and return the :class:`PixelRender` (also kept as :attr:`last_render`)."""
        self.echoes(animation, radar, frame, radar_pose)
        return self.last_render

    def _frame_echoes(self, animation: Animation, radar, frame: int, pose: RadarPose):
        """Echoes ``[num_tx, num_rx, num_hit_pixels]`` of ``frame``; the render is kept as :attr:`last_render`.

        Pixels whose material gives no diffuse echo (S = 0) are left out of the echoes but kept in
        :attr:`last_render`.
        """
        rotation = rotation_matrix(pose.orientation)
        centre_local = phase_centre(radar)
        centre = pose.position + rotation @ centre_local
        directions = self._directions @ rotation.T
        t_cast = time.perf_counter()
        valid, t_hit, shape_id, prim, uv = cast_rays(self._loaded.scene, centre, directions)
        trace_seconds = time.perf_counter() - t_cast
        render, echoes = self._to_echoes(frame, animation, radar, pose, rotation, centre, valid, shape_id, prim, uv)
        self.last_render = render
        figures = {"trace_seconds": trace_seconds, "num_hits": render.num_hits, "num_po_rays": 0, "num_po_samples": 0,
                   "num_po_contributions": 0}
        self.last_po_samples = None
        if self.model == "physical-optics":
            samples, num_rays, po_seconds = self._po_samples(frame, animation, radar, rotation, centre, render)
            self.last_po_samples = samples
            figures.update(num_po_rays=num_rays, num_po_samples=samples.num_samples,
                           trace_seconds=trace_seconds + po_seconds)
            if samples.num_samples:
                po = po_echoes(samples, radar, pose.position, pose.orientation)
                if self.po_merge:
                    offset = samples.position - centre
                    po = merge_contributions(po, radar, (offset / np.linalg.norm(offset, axis=1)[:, None]) @ rotation)
                figures["num_po_contributions"] = po.num_contributions
                echoes = Echoes.concatenate([echoes, po])
        figures["num_contributions"] = echoes.num_contributions
        return echoes, figures

    def close(self) -> None:
        """Drop the loaded scene and the last render."""
        super().close()
        self.last_render = None
        self.last_po_samples = None

    # ------------------------------------------------------------------ per-object figures
    def _surface(self, animation: Animation, name: str, wavelength: float) -> SurfaceFigures:
        """:class:`SurfaceFigures` of object ``name`` (frame-0 geometry of the loaded scene, computed once)."""
        state = self._state
        if name not in state.surfaces:
            info = animation.frame_xml(0).shapes.get(name)
            if info is not None and info.type == "ply":
                # frame 0's PLY whatever frame the engine starts with (workers of a data set start
                # anywhere): the same cells, so the same phases, for every frame of the animation
                mesh = animation.mesh(0, name)
                vertices, faces, face_normals = mesh.vertices, mesh.faces, bool(info.face_normals)
            else:   # static non-PLY shape: as Mitsuba loaded it
                vertices, faces, face_normals = self._loaded.vertices[name], self._loaded.faces[name], True
            cell = self.diffuse_cell_size if self.diffuse_cell_size is not None else wavelength / 4
            state.surfaces[name] = surface_figures(vertices, faces, cell, face_normals)
        return state.surfaces[name]

    def _hit_geometry(self, animation, frame, obj, prim, uv):
        """World position (float64, from the triangle and barycentrics), facet normal and velocity of hits
        on local objects ``obj [P]``, triangles ``prim [P]``, barycentrics ``uv [P, 2]``."""
        state, loaded = self._state, self._loaded
        num = obj.size
        position, normal, velocity = np.empty((num, 3)), np.empty((num, 3)), np.zeros((num, 3))
        fr = animation.frame(frame)
        for k, name in enumerate(state.names):
            sel = np.nonzero(obj == k)[0]
            if sel.size == 0:
                continue
            tri = loaded.faces[name][prim[sel]]
            verts = loaded.vertices[name]
            b1, b2 = uv[sel, 0], uv[sel, 1]
            w = np.stack([1.0 - b1 - b2, b1, b2], axis=-1)
            v0, v1, v2 = verts[tri[:, 0]], verts[tri[:, 1]], verts[tri[:, 2]]
            position[sel] = interpolate(verts, tri, w)
            normal[sel] = unit(np.cross(v1 - v0, v2 - v0))
            vfield = loaded.vertex_velocity.get(name) if self.vertex_doppler else None
            if vfield is not None:
                velocity[sel] = interpolate(vfield, tri, w)
            else:
                velocity[sel] = np.asarray(fr.objects.get(name, np.zeros(3)), dtype=float)
        return position, normal, velocity

    def _phases(self, animation, obj, prim, uv, wavelength) -> np.ndarray:
        """Random phases of the diffuse scatterers hit (:func:`~sionnafmcw.diffuse.scatterer_phases`)."""
        names = np.array(self._state.names, dtype=object)
        cells = np.ones(obj.size, dtype=np.int64)
        for k, name in enumerate(self._state.names):
            sel = np.nonzero(obj == k)[0]
            if sel.size:
                cells[sel] = self._surface(animation, name, wavelength).cells[prim[sel]]
        return scatterer_phases(names[obj].astype(str), prim, uv, cells)

    # ------------------------------------------------------------------ physical optics
    def _po_samples(self, frame, animation, radar, rotation, centre, render):
        r"""The PO render of the frame: :class:`SurfaceSamples` of every object with a coherent share.

        Per object (material with :math:`S < 1`): an equiangular grid over its angular box
        (:func:`angular_box`: its vertices' box where it lies in front, united with the coarse
        render's hits on it padded by one pixel; clipped to the field of view) with the step
        :func:`~sionnafmcw.physical_optics.render_resolution` of its size (bounding-box diagonal), its
        farthest vertex's range (the finest step the rule asks anywhere on it), its curvature radius
        and, with facet normals, its facet size (:func:`surface_figures`). All objects' rays go in
        one cast from the phase centre; a ray keeps its hit only on the object it was cast for (the
        others have their own grid; occlusion is the cast's). Returns the samples, the ray count and
        the cast time.
        """
        state, loaded = self._state, self._loaded
        wavelength = SPEED_OF_LIGHT / radar.fc
        grid = self.grid
        half_az, half_el = grid.fov_az / 2, grid.fov_el / 2
        uniq, inverse = np.unique(np.asarray(render.labels, dtype=str), return_inverse=True)
        hit_obj = np.array([state.names.index(n) for n in uniq], dtype=np.int64)[inverse.reshape(-1)] \
            if render.num_hits else np.zeros(0, dtype=np.int64)
        dirs, owner, steps = [], [], []
        for k, name in enumerate(state.names):
            if state.materials[k].scattering_coefficient >= 1.0:
                continue
            verts = loaded.vertices[name]
            local = (verts - centre) @ rotation
            on = hit_obj == k
            box = angular_box(local, render.azimuth[on], render.elevation[on], (grid.d_az, grid.d_el))
            if box is None:
                continue
            box = (max(box[0], -half_az), min(box[1], half_az), max(box[2], -half_el), min(box[3], half_el))
            if box[0] >= box[1] or box[2] >= box[3]:
                continue
            surface = self._surface(animation, name, wavelength)
            extent = float(np.linalg.norm(np.ptp(verts, axis=0)))
            distance = float(np.linalg.norm(local, axis=1).max())
            if extent <= 0 or distance <= 0:
                continue
            facet = None if surface.facet_size is None else FACET_SHARE * surface.facet_size
            step = render_resolution(extent, distance, wavelength, curvature_radius=surface.curvature_radius,
                                     samples_across=self.po_samples_across, facet_size=facet)
            count = np.ceil((box[1] - box[0]) / step) * np.ceil((box[3] - box[2]) / step)
            if count > self.po_max_rays:
                coarse = step * np.sqrt(count / self.po_max_rays) * 1.001
                warnings.warn(f"PixelEngine: the PO render of {name!r} in frame {frame} needs {int(count)} rays "
                              f"({step * 1e3:.3g} mrad steps); coarsened to {coarse * 1e3:.3g} mrad "
                              f"(po_max_rays={self.po_max_rays}), so its PO echo is approximate", stacklevel=4)
                step = coarse
            az, el, (d_az, d_el) = box_grid(box, step)
            dirs.append(np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1))
            owner.append(np.full(az.size, k, dtype=np.int64))
            steps.append(np.tile([d_az, d_el], (az.size, 1)))
        if not dirs:
            return SurfaceSamples(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)), 0, 0.0
        local_dirs, owner, steps = np.concatenate(dirs), np.concatenate(owner), np.concatenate(steps)
        t0 = time.perf_counter()
        valid, _, shape_id, prim, uv, sh_normal = cast_rays(loaded.scene, centre, local_dirs @ rotation.T,
                                                            shading_normals=True)
        seconds = time.perf_counter() - t0
        ids = np.array(sorted(state.index_by_id), dtype=np.int64)
        local_index = np.array([state.index_by_id[i] for i in ids], dtype=np.int64)
        where = np.clip(np.searchsorted(ids, shape_id), 0, len(ids) - 1)
        keep = valid & (ids[where] == shape_id)
        keep &= local_index[where] == owner
        idx = np.nonzero(keep)[0]
        obj, prim, uv = owner[idx], prim[idx], uv[idx]
        position, _, velocity = self._hit_geometry(animation, frame, obj, prim, uv)
        normal = sh_normal[idx]
        offset = position - centre
        distance = np.linalg.norm(offset, axis=1)
        u = offset / distance[:, None]
        el = np.arcsin(np.clip(local_dirs[idx, 2], -1.0, 1.0))
        d_az, d_el = steps[idx, 0], steps[idx, 1]
        solid = d_az * (np.sin(el + d_el / 2) - np.sin(el - d_el / 2))
        step_az, step_el = angular_grid_steps(local_dirs[idx], 1.0, 1.0, rotation)
        step_az, step_el = step_az * d_az[:, None], step_el * d_el[:, None]
        mats = state.materials
        eta = np.array([m.eta for m in mats], dtype=complex)[obj]
        thick = np.array([m.thickness for m in mats])[obj]
        s_coef = np.array([m.scattering_coefficient for m in mats])[obj]
        e_t = vertical_polarisation(u, rotation)
        gamma = copolar_reflection(np.abs(dot(normal, u)), eta, thick, wavelength, u, normal, e_t)
        labels = np.array(state.names, dtype=object)[obj].astype(str)
        samples = render_samples(centre, u, distance, normal, solid, step_az, step_el, velocity=velocity,
                                 reflection=gamma, scattering_coefficient=s_coef, object_id=obj, triangle=prim,
                                 barycentric=uv, labels=labels)
        return samples.select(samples.area > 0), int(local_dirs.shape[0]), seconds

    # ------------------------------------------------------------------ hits -> Echoes
    def _to_echoes(self, frame, animation, radar, pose, rotation, centre, valid, shape_id, prim, uv):
        state = self._state
        m_tx, n_rx = radar.num_tx, radar.num_rx
        wavelength = SPEED_OF_LIGHT / radar.fc
        ids = np.array(sorted(state.index_by_id), dtype=np.int64)
        local = np.array([state.index_by_id[i] for i in ids], dtype=np.int64)
        where = np.clip(np.searchsorted(ids, shape_id), 0, max(len(ids) - 1, 0))
        known = valid & (ids[where] == shape_id) if len(ids) else np.zeros_like(valid)
        pix = np.nonzero(known)[0]
        obj = local[where[pix]]
        num = pix.size
        if num == 0:
            empty = np.zeros(0)
            render = PixelRender(frame=frame, grid=self.grid, pixel=pix, azimuth=empty, elevation=empty,
                                 solid_angle=empty, range=empty, position=np.zeros((0, 3)), normal=np.zeros((0, 3)),
                                 velocity=np.zeros((0, 3)), radial_velocity=empty, cos_incidence=empty, rcs=empty,
                                 labels=np.zeros(0, dtype=str), contributes=np.zeros(0, dtype=bool))
            echoes = Echoes.empty(m_tx, n_rx)
            echoes.labels = np.zeros((m_tx, n_rx, 0), dtype=str)
            return render, echoes

        # ---- geometry of the hits (float64): point from the triangle and barycentrics, face normal
        position, normal, velocity = self._hit_geometry(animation, frame, obj, prim[pix], uv[pix])
        offset = position - centre
        rng = np.linalg.norm(offset, axis=-1)
        # direction to the hit point (world): the pixel centre's to float32 precision of the cast
        u = offset / rng[:, None]
        cos_i = np.abs(dot(normal, u))
        mats = [state.materials[k] for k in range(len(state.names))]
        s_coef = np.array([m.scattering_coefficient for m in mats])[obj] if num else np.zeros(0)
        kx = np.array([m.xpd_coefficient for m in mats])[obj] if num else np.zeros(0)
        solid = self._solid_angles[pix]
        area = np.divide(rng ** 2 * solid, cos_i, out=np.zeros(num), where=cos_i > 1e-12)  # A = R^2 dOmega / cos(theta_i)

        # ---- element geometry (world): plane-wave -> the phase centre for every element
        tx_w = pose.position + radar.tx_positions @ rotation.T
        rx_w = pose.position + radar.rx_positions @ rotation.T
        if self.array_model == "exact":
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
        gamma2 = self._gamma_squared(obj, mats, normal, k_in, e_t, cos_in, wavelength)
        # XPD: co-polar fraction of the scattered field at each Rx element, [Ms, Ns, P]
        chi = copolar_fraction(e_t[:, None], k_in[:, None], e_r[None], k_out[None], kx)
        cos_s = np.abs(dot(normal[None], k_out))                 # [Ns, P]
        f_s = self._pattern(obj, mats, normal, k_in, k_out, cos_s)   # [Ms, Ns, P]
        # bistatic RCS sigma_mn = 4 pi A cos(theta_i,m) S^2 Gamma_m^2 chi_mn f_s,mn
        sigma = 4 * np.pi * area * cos_in[:, None, :] * s_coef ** 2 * gamma2[:, None, :] * chi * f_s
        amp = wavelength * np.sqrt(g_t[:, None, :] * g_r[None, :, :] * sigma) / (
            (4 * np.pi) ** 1.5 * r_in[:, None, :] * r_out[None, :, :])
        velocity_doppler = dot(velocity[None, None], k_out[None] - k_in[:, None]) / wavelength   # [Ms, Ns, P]

        if self.array_model == "exact":
            tau = (r_in[:, None, :] + r_out[None, :, :]) / SPEED_OF_LIGHT
        else:
            dt = (tx_w - centre) @ u.T                              # [M, P] element offsets along u
            dr_ = (rx_w - centre) @ u.T                             # [N, P]
            tau = (2 * rng[None, None, :] - dt[:, None, :] - dr_[None, :, :]) / SPEED_OF_LIGHT
        shape = (m_tx, n_rx, num)
        amp = np.broadcast_to(amp, shape)
        doppler = np.broadcast_to(velocity_doppler, shape)

        labels = np.array(state.names, dtype=object)[obj].astype(str) if num else np.zeros(0, dtype=str)
        # monostatic pixel RCS at the phase centre (plane-wave quantities) for the render
        if self.array_model == "exact":
            rcs_mono = self._monostatic_rcs(obj, mats, normal, u, centre, rotation, area, s_coef, kx, wavelength)
        else:
            rcs_mono = sigma[0, 0]
        contributes = np.any(amp > 0, axis=(0, 1)) if num else np.zeros(0, dtype=bool)
        render = PixelRender(frame=frame, grid=self.grid, pixel=pix, azimuth=self._az[pix], elevation=self._el[pix],
                             solid_angle=solid, range=rng, position=position, normal=normal, velocity=velocity,
                             radial_velocity=dot(velocity, u), cos_incidence=cos_i, rcs=rcs_mono, labels=labels,
                             contributes=contributes)
        keep = contributes
        a = amp[..., keep].astype(complex)
        if self.diffuse_phase == "random" and np.any(keep):
            # one scatterer per surface cell, the same phase for every element pair (module docstring)
            a = a * np.exp(1j * self._phases(animation, obj[keep], prim[pix][keep], uv[pix][keep], wavelength))
        echoes = Echoes(a, tau[..., keep], doppler[..., keep], labels[keep])
        return render, echoes

    def _monostatic_rcs(self, obj, mats, normal, u, centre, rotation, area, s_coef, kx, wavelength):
        cos_i = np.abs(dot(normal, u))[None]
        k_in = u[None]
        e_t = vertical_polarisation(k_in, rotation)
        gamma2 = self._gamma_squared(obj, mats, normal, k_in, e_t, cos_i, wavelength)[0]
        chi = copolar_fraction(e_t[0], k_in[0], e_t[0], -u, kx)   # back to the same element
        f_s = self._pattern(obj, mats, normal, k_in, -k_in, cos_i)[0, 0]
        return 4 * np.pi * area * cos_i[0] * s_coef ** 2 * gamma2 * chi * f_s

    @staticmethod
    def _gamma_squared(obj, mats, normal, k_in, e_t, cos_in, wavelength):
        r"""Sionna's reflection coefficient of the incident polarisation :math:`\Gamma^2`, ``[Ms, P]``
        (:func:`~sionnafmcw.electromagnetics.reflection_power` with each hit's material)."""
        eta = np.array([m.eta for m in mats], dtype=complex)[obj]
        thick = np.array([m.thickness for m in mats])[obj]
        return reflection_power(cos_in, eta[None], thick[None], wavelength, k_in, normal[None], e_t)

    @staticmethod
    def _pattern(obj, mats, normal, k_in, k_out, cos_s):
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
                    frame = mi.Frame3f(mi.Vector3f(*[mi.Float(np.ascontiguousarray(nrm[:, i], dtype=np.float32))
                                                     for i in range(3)]))
                    ki = frame.to_local(mi.Vector3f(*[mi.Float(np.ascontiguousarray(k_in[m, sel, i], dtype=np.float32))
                                                      for i in range(3)]))
                    ko = frame.to_local(mi.Vector3f(*[mi.Float(np.ascontiguousarray(k_out[n, sel, i], dtype=np.float32))
                                                      for i in range(3)]))
                    value = mat.pattern(ki, ko)
                    dr.eval(value)
                    out[m, n, sel] = np.asarray(value.numpy(), dtype=float)
        return out


__all__ = ["EDGE_ANGLE", "FACET_SHARE", "PixelEngine", "PixelEngineError", "PixelGrid", "PixelRender",
           "MERGE_FRACTION", "SurfaceFigures", "angular_box", "box_grid", "copolar_reflection", "merge_contributions",
           "surface_figures"]
