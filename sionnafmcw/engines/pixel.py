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
:math:`S = 0`, which the pixel engine does not see at all -- a warning says so); a number in
:math:`[0, 1]` replaces :math:`S` for every material (the paper's render, where every surface is
a Lambertian scatterer).

Specular reflection: not modelled (decision)
--------------------------------------------
The pixel engine models only the diffuse share :math:`S^2` of the reflected power, the paper's
(Lambertian) pixel model. The specular share :math:`1 - S^2` is a mirror reflection: it returns
to the radar only from points whose surface normal points back at the radar, a set of measure
zero on the pixel grid, and its strength comes from the coherent sum over the whole facet, which
pixels of centimetres cannot resolve at a wavelength of 3.9 mm. The path engine computes it with
the image method: a metal plate facing the radar at range :math:`R` returns like a target of
:math:`\sigma = \pi R^2` (geometric optics; 19 dBsm at 5 m, capped at the physical-optics
:math:`4\pi A^2/\lambda^2` = 59 dBsm for :math:`A` = 1 m\ :sup:`2` in the far field), while the
same plate as a Lambertian surface has :math:`\sum_p\sigma_p \approx 4AS^2\Gamma^2` = 6 dBsm
for :math:`S = \Gamma = 1`. Measured (walk-77ghz, 1 m metal plate facing the radar, sum over the
12 channels): path engine (specular) -55.4 dB at 2 m and -63.4 dB at 5 m; pixel engine with
``scattering_coefficient=1``: -61.6 dB and -76.5 dB, i.e. 6 and 13 dB less, growing with range.
Consequences for pixel-vs-path comparisons:

* they are fair against the path engine with ``max_depth=1`` and either ``specular=False`` or
  surfaces whose mirror echo misses the radar (tilted plates, curved or rough bodies); the
  diffuse parts then agree in absolute power (0.01-0.02 dB measured, ``tests/test_pixel_engine.py``);
* a smooth surface facing the radar (a wall straight ahead, a flat metal plate, a torso facet
  normal to the line of sight) is a strong specular reflector in the path engine and a weak
  diffuse one here; scenes dominated by glints (walls, corner reflectors, whose triple bounce
  is absent too) differ by tens of dB, and multipath (target-floor-radar) is absent altogether;
* a material with :math:`S = 0` (Sionna's default, every ITU material) is invisible here.

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
for :math:`S = 0.5` and +0.011 dB for :math:`S = 1` (Monte-Carlo 4 sigma: 8 % and 4 %). Circle-walk
room (walls, floor, ceiling, 14-part body), 128 x 64 pixels, 3 Tx x 4 Rx, two shared CPU cores:
0.13 s per frame with ``"plane-wave"`` and 0.2-0.25 s with ``"exact"``, of which the ray cast is
2-8 ms and Mitsuba's scene update of the moving meshes about 45 ms; the rest is numpy.
Mitsuba's ``aov`` integrator would only replace the 2-8 ms cast.

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
from dataclasses import dataclass

import numpy as np

from ..animation import Animation, RadarPose
from ..antenna import antenna_gain, check_pattern, direction_angles
from ..constants import SPEED_OF_LIGHT, VACUUM_PERMITTIVITY
from ..echoes import Echoes
from ..electromagnetics import (
    copolar_fraction, dot, lambertian_pattern, reflection_power, unit,
    vertical_polarisation,
)
from ..geometry import rotation_matrix
from ..array import phase_centre
from ..sionna_rt import LambertianPattern, dr, mi
from .base import Engine, EngineError
from .loaded_scene import interpolate


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


# ---------------------------------------------------------------------------------------- Dr.Jit inputs
def _jit_float(values) -> "mi.Float":
    """``values`` as a Dr.Jit Float from a 64-byte aligned buffer.

    Dr.Jit reads numpy memory as it is and compiles the alignment of each input into the
    kernel (``align 1`` vs ``align 64``): inputs with varying alignment would give the same
    ray cast a new kernel hash (a recompilation) from frame to frame.
    """
    values = np.asarray(values, dtype=np.float32).ravel()
    buffer = np.empty(values.size + 16, dtype=np.float32)
    start = (-buffer.ctypes.data % 64) // buffer.itemsize
    aligned = buffer[start:start + values.size]
    aligned[:] = values
    return mi.Float(aligned)


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


# ---------------------------------------------------------------------------------------- engine
class PixelEngine(Engine):
    """The scene rendered from the radar; each hit pixel a point target (see the module docstring).

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
    track_kernels : bool
        Record Dr.Jit kernel launches per frame in :attr:`stats`.

    Notes
    -----
    :attr:`stats` figures: ``trace_seconds`` (the ray cast), ``num_hits`` (pixels that hit a
    surface), ``num_contributions`` (hit pixels with a non-zero echo).
    """

    name = "pixel"
    FIXED_SETTINGS = {"scattering": "diffuse", "specular": False, "max_depth": 1}
    ARRAY_MODELS = ("plane-wave", "exact")

    def __init__(self, n_az: int = 128, n_el: int = 64, fov_az: float = float(np.deg2rad(120.0)),
                 fov_el: float = float(np.deg2rad(60.0)), array_model: str = "plane-wave",
                 scattering_coefficient: float | None = None, vertex_doppler: bool = True,
                 track_kernels: bool = True):
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
        self._directions = self.grid.directions().reshape(-1, 3)
        self._solid_angles = self.grid.solid_angles().reshape(-1)
        az, el = self.grid.angles()
        self._az, self._el = az.reshape(-1), el.reshape(-1)
        self.last_render: PixelRender | None = None

    def _settings(self) -> dict:
        return {"n_az": self.grid.n_az, "n_el": self.grid.n_el, "fov_az": float(self.grid.fov_az),
                "fov_el": float(self.grid.fov_el), "array_model": self.array_model,
                "scattering_coefficient": self.scattering_coefficient, "vertex_doppler": self.vertex_doppler}

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
        if materials and all(m.scattering_coefficient == 0 for m in materials):
            warnings.warn(
                f"PixelEngine: every material of {animation.frames[0].xml} has scattering_coefficient 0; the pixel "
                "engine models diffuse scattering only, so it sees nothing. Give the materials a "
                "scattering_coefficient or set PixelEngine(scattering_coefficient=...).", stacklevel=3)
        self._cast(scene, np.zeros(3), np.tile([[1.0, 0.0, 0.0]], (self.grid.num_pixels, 1)))
        return _State(names, index_by_id, materials)

    def _check_radar(self, radar) -> None:
        check_pattern(radar.antenna_pattern)

    def _geometry_changed(self) -> None:
        dr.eval()

    # ------------------------------------------------------------------ ray casting
    @staticmethod
    def _cast(scene, origin, directions):
        """First hits of rays from ``origin`` along ``directions [K, 3]`` (world): t, object id, triangle, barycentrics."""
        k = directions.shape[0]
        o = mi.Point3f(*[_jit_float(np.full(k, origin[i])) for i in range(3)])
        ray = mi.Ray3f(o, mi.Vector3f(*[_jit_float(directions[:, i]) for i in range(3)]))
        pi = scene.mi_scene.ray_intersect_preliminary(ray, coherent=True)
        valid = pi.is_valid()
        shape_id = dr.reinterpret_array(mi.UInt32, pi.shape)
        dr.eval(pi.t, pi.prim_index, pi.prim_uv, shape_id, valid)
        uv = np.stack([np.asarray(pi.prim_uv.x.numpy(), dtype=np.float64),
                       np.asarray(pi.prim_uv.y.numpy(), dtype=np.float64)], axis=-1)
        return (np.asarray(valid.numpy(), dtype=bool), np.asarray(pi.t.numpy(), dtype=np.float64),
                np.asarray(shape_id.numpy(), dtype=np.int64), np.asarray(pi.prim_index.numpy(), dtype=np.int64),
                uv)

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
        valid, t_hit, shape_id, prim, uv = self._cast(self._loaded.scene, centre, directions)
        trace_seconds = time.perf_counter() - t_cast
        render, echoes = self._to_echoes(frame, animation, radar, pose, rotation, centre, valid, shape_id, prim, uv)
        self.last_render = render
        return echoes, {"trace_seconds": trace_seconds, "num_hits": render.num_hits,
                        "num_contributions": echoes.num_contributions}

    def close(self) -> None:
        """Drop the loaded scene and the last render."""
        super().close()
        self.last_render = None

    # ------------------------------------------------------------------ hits -> Echoes
    def _to_echoes(self, frame, animation, radar, pose, rotation, centre, valid, shape_id, prim, uv):
        state, loaded = self._state, self._loaded
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
        position = np.empty((num, 3))
        normal = np.empty((num, 3))
        velocity = np.zeros((num, 3))
        fr = animation.frame(frame)
        for k, name in enumerate(state.names):
            sel = np.nonzero(obj == k)[0]
            if sel.size == 0:
                continue
            tri = loaded.faces[name][prim[pix[sel]]]
            verts = loaded.vertices[name]
            b1, b2 = uv[pix[sel], 0], uv[pix[sel], 1]
            w = np.stack([1.0 - b1 - b2, b1, b2], axis=-1)
            v0, v1, v2 = verts[tri[:, 0]], verts[tri[:, 1]], verts[tri[:, 2]]
            position[sel] = interpolate(verts, tri, w)
            normal[sel] = unit(np.cross(v1 - v0, v2 - v0))
            field = loaded.vertex_velocity.get(name) if self.vertex_doppler else None
            if field is not None:
                velocity[sel] = interpolate(field, tri, w)
            else:
                velocity[sel] = np.asarray(fr.objects.get(name, np.zeros(3)), dtype=float)
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
        echoes = Echoes(amp[..., keep].astype(complex), tau[..., keep], doppler[..., keep], labels[keep])
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


__all__ = ["PixelEngine", "PixelEngineError", "PixelGrid", "PixelRender"]
