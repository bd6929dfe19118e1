r"""Near-field physical optics (PO) for the single-bounce echo, on samples of the lit surface.

The engines give this module the surface the radar sees as *samples*: for every hit of a render
from the array's phase centre, a point :math:`\mathbf p_i` (world, m), its unit normal
:math:`\hat{\mathbf n}_i`, the area :math:`\Delta A_i` of the surface the sample stands for, the
two edge vectors of that footprint, its velocity :math:`\mathbf v_i`, its material's reflection
coefficient :math:`\Gamma_i` and scattering coefficient :math:`S_i` (:class:`SurfaceSamples`).
Every sample becomes one contribution of an :class:`~sionnafmcw.echoes.Echoes` per Tx element
:math:`m` and Rx element :math:`n` (:func:`po_gains`, :func:`po_echoes`); the beat synthesizer's
coherent sum of these contributions *is* the PO integral.

Derivation
----------
Conventions (NOTES section 2): time dependence :math:`e^{j\omega t}`, so a wave travelling a
distance :math:`r` picks up :math:`e^{-jkr}`, :math:`k = 2\pi/\lambda`, :math:`\lambda = c/f_c`.
Sionna's gain :math:`a` carries no carrier phase; the channel of a contribution is
:math:`a\,e^{-j2\pi f_c\tau}` and :math:`P_r = P_t|a|^2`. An element of power gain :math:`G` at
distance :math:`d` in free space gives :math:`a = \sqrt{G_tG_r}\,\lambda/(4\pi d)`: a unit field
:math:`\sqrt{G_t}\,e^{-jkd}/d` received through the aperture factor :math:`\lambda\sqrt{G_r}/(4\pi)`.

*Incident field.* Tx element :math:`m` at :math:`\mathbf t_m` illuminates the surface point
:math:`\mathbf p` with :math:`E_i = \sqrt{G_t}\,e^{-jkr_t}/r_t`, :math:`r_t = \|\mathbf p - \mathbf t_m\|`.

*PO current and scattered field.* On the lit side the PO surface current of a perfect conductor
is :math:`\mathbf J = 2\hat{\mathbf n}\times\mathbf H_i`. Its radiation towards Rx element
:math:`n` at :math:`\mathbf r_n` (each surface element is in its own far field, the surface as a
whole need not be: every distance below is exact), projected on the receive polarisation, is the
scalar Kirchhoff--PO integral

.. math::
    E_s(\mathbf r_n) = \frac{jk}{2\pi}\,\Gamma\int_{A_{lit}} \frac{\hat{\mathbf n}\cdot(\hat{\mathbf u}_t
        + \hat{\mathbf u}_r)}{2}\,E_i(\mathbf p)\,\frac{e^{-jkr_r}}{r_r}\,dA,
    \qquad \hat{\mathbf u}_t = \frac{\mathbf t_m - \mathbf p}{r_t},\ \hat{\mathbf u}_r = \frac{\mathbf r_n - \mathbf p}{r_r},

with :math:`\Gamma = -1` for a perfect conductor in Sionna's (ITU-R P.2040) convention of the
reflected tangential field. Monostatically the obliquity :math:`\hat{\mathbf n}\cdot(\hat{\mathbf u}_t
+ \hat{\mathbf u}_r)/2` is :math:`\cos\theta_i`, the PO of a PEC is polarisation independent, and
the prefactor is the one that makes an infinite plate at distance :math:`R` return exactly its
mirror image (stationary phase: :math:`\frac{jk}{2\pi}\int e^{-jk\rho^2/R}\,2\pi\rho\,d\rho/R^2 =
1/(2R)`, the image source at :math:`2R` times :math:`\Gamma`), i.e. Sionna's own specular path.

*Through the receive aperture*, :math:`h_{mn} = \frac{\lambda\sqrt{G_r}}{4\pi}E_s`, and with
:math:`k\lambda/(2\pi) = 1`:

.. math::
    h_{mn} = \sum_i a_{mni}\,e^{-jk(r_{t,mi} + r_{r,ni})},\qquad
    a_{mni} = \frac{j\,\Gamma_i\sqrt{1 - S_i^2}}{4\pi}\,\sqrt{G_{t,mi}G_{r,ni}}\;
              \frac{\hat{\mathbf n}_i\cdot(\hat{\mathbf u}_{t,mi} + \hat{\mathbf u}_{r,ni})}{2}\;
              \frac{\Delta A_i\,F_{mni}}{r_{t,mi}\,r_{r,ni}},

.. math::
    \tau_{mni} = \frac{r_{t,mi} + r_{r,ni}}{c},\qquad
    f_{D,mni} = \frac{\mathbf v_i\cdot(\hat{\mathbf k}_{out} - \hat{\mathbf k}_{in})}{\lambda}
              = -\frac{\mathbf v_i\cdot(\hat{\mathbf s}_{t,mi} + \hat{\mathbf s}_{r,ni})}{\lambda}

(:math:`\hat{\mathbf s} = -\hat{\mathbf u}`, pointing from the element to the sample; Doppler
positive approaching, Sionna's sign). This is near-field exact: every element pair has its own
distances, directions and gains; nothing is a plane wave. Only the samples' positions come from
one render (from the phase centre): one set of scatterers for the whole array.

*Radar-equation reading.* Monostatic, isotropic elements, reference range :math:`R`:
:math:`|h|^2 = \lambda^2\sigma/((4\pi)^3R^4)` gives

.. math::
    \sigma_{PO} = \frac{4\pi}{\lambda^2}\Bigl|\int_{A_{lit}} (\hat{\mathbf n}\cdot\hat{\mathbf r})
                  \Bigl(\frac{R}{r}\Bigr)^2 e^{-j2k(r - R)}\,dA\Bigr|^2 |\Gamma|^2(1 - S^2),

NOTES section 6, tending to :math:`4\pi A^2/\lambda^2` for a plate, :math:`\pi a^2` for a sphere,
:math:`2\pi aL^2/\lambda` for a cylinder at broadside in the far field (:func:`monostatic_rcs`).

*In-sample phase.* At 3.9 mm wavelength a sample of centimetres is not a point: the phase
:math:`-k(r_t + r_r)` changes across its footprint, the parallelogram
:math:`\mathbf x = \alpha\mathbf e_1 + \beta\mathbf e_2`, :math:`|\alpha|,|\beta|\le\frac12` (the
pixel's angular cell projected along the ray onto the tangent plane, :func:`footprint_edges`).
The surface itself leaves the tangent plane by its sag: with :math:`\hat{\mathbf n}` turned to
the incident side and :math:`\mathbf K = \partial\hat{\mathbf n}/\partial\mathbf x` its shape
operator (positive for a surface that curves away from the radar),
:math:`\mathbf p(\mathbf x) = \mathbf p_i + \mathbf x - \frac12(\mathbf x^T\mathbf K\mathbf x)\hat{\mathbf n}`.
To second order the two-way length is

.. math::
    r_t + r_r = r_{t} + r_{r} + \mathbf g\cdot\mathbf x + \tfrac12\mathbf x^T\mathbf H\mathbf x,\qquad
    \mathbf g = \hat{\mathbf s}_t + \hat{\mathbf s}_r,\qquad
    \mathbf H = \frac{\mathbf I - \hat{\mathbf s}_t\hat{\mathbf s}_t^T}{r_t}
              + \frac{\mathbf I - \hat{\mathbf s}_r\hat{\mathbf s}_r^T}{r_r}
              + (\cos\theta_t + \cos\theta_r)\,\mathbf K

(range curvature of the two spherical waves, then the sag seen along both rays,
:math:`\cos\theta = \hat{\mathbf n}\cdot\hat{\mathbf u}`). In the footprint's coordinates the
phase is :math:`a\alpha + b\beta + q(\alpha,\beta)` with :math:`a = k\,\mathbf g\cdot\mathbf e_1`,
:math:`b = k\,\mathbf g\cdot\mathbf e_2`, :math:`q = \frac k2(h_{11}\alpha^2 + h_{22}\beta^2 + 2h_{12}\alpha\beta)`,
:math:`h_{ij} = \mathbf e_i^T\mathbf H\mathbf e_j`. The footprint factor is the mean of
:math:`e^{-j(a\alpha + b\beta + q)}` over the footprint. Expanding :math:`e^{-j(q - \mu)}` about the
mean :math:`\mu = \langle q\rangle = k(h_{11} + h_{22})/24` to first order, with the moments
:math:`\int_{-1/2}^{1/2}\alpha^l e^{-ja\alpha}d\alpha` = :math:`S(y)`, :math:`jS'(y)/2`,
:math:`-S''(y)/4` for :math:`l = 0, 1, 2` (:math:`S(y) = \sin y/y`, :math:`y = a/2`,
:math:`z = b/2`), gives the closed form

.. math::
    F_{mni} = e^{-j\mu}\Bigl[(1 + j\mu)S(y)S(z) + \frac{jk}{8}\bigl(h_{11}S''(y)S(z)
              + h_{22}S(y)S''(z) + 2h_{12}S'(y)S'(z)\bigr)\Bigr]

(:func:`footprint_factor`; :math:`F = \operatorname{sinc}\operatorname{sinc}` when :math:`\mathbf H = 0`,
:math:`F = e^{-j\mu}` at the specular point :math:`a = b = 0`). Since
:math:`|e^{-jx} - 1 + jx| \le x^2/2`, its error is at most
:math:`\frac12\operatorname{Var}q = \frac{k^2}{8}\bigl(\frac{h_{11}^2 + h_{22}^2}{180} + \frac{h_{12}^2}{36}\bigr)`,
whatever the linear phase. Where that bound reaches 1 (a quadratic phase of radians: footprints
stretched at grazing incidence, the large samples of a far second-bounce surface) it says nothing
that :math:`|F_{exact}| \le 1` does not, and :math:`F` is the linear factor :math:`S(y)S(z)`,
which never exceeds 1 either (its error :math:`\langle|q|\rangle \le \sqrt{\mu^2 + \operatorname{Var}q}`).

With the edge phase :math:`Q = kh/8` of an isotropic
:math:`h_{11} = h_{22} = h = 2s^2/\rho_{eff}` (sample size :math:`s`,
:math:`\rho_{eff} = \min(R, \rho)`, :math:`\rho` the surface's radius of curvature) this is
:math:`0.089\,Q^2`, where the linear-phase factor :math:`\operatorname{sinc}\operatorname{sinc}`
alone errs by :math:`\mu = 2Q/3`.

*Sample size.* The resolution rule of :func:`render_resolution` keeps :math:`Q` below
:data:`MAX_QUADRATIC_PHASE` :math:`= \pi/32` at the sample's edge (:math:`x = s/2`):

.. math::
    s \le 2\sqrt{Q_{max}\min(R, \rho)/k} = \tfrac14\sqrt{\lambda\min(R, \rho)},\qquad s \le D/N_{across},

(2.2 cm at 2 m for a flat plate, 5 mm on a 0.1 m sphere), the second bound keeping a target of
size :math:`D` at least :math:`N_{across}` samples wide so its outline is resolved. At that bound
the in-sample error is :math:`8.6\cdot10^{-4}` per sample (6.5 % with the linear factor). What
the bound now holds back is the *tiling*: on a curved surface the footprints lie on each
sample's own tangent plane, so neighbouring footprints neither meet at their seams nor share a
phase there, an error that grows with :math:`s/\rho` and that no per-sample factor removes (the
exact patch of a pixel, parametrised by its ray angles, carries a quadratic phase
:math:`k\,\mathbf g\cdot\partial^2\mathbf p/\partial\alpha^2` that is large wherever the
linear phase is). ``benchmarks/po_sample_size.py`` measures both: on a 0.1 m sphere of 1.2 mm
facets the second-order factor cuts the error of the complex channel against the quadrature
from 0.096 to 0.025 at 2 m and from 0.047 to 0.019 at 10 m (rms over grid offsets) at the
rule's samples, but on the walking body (8 mm facets) samples 2x larger than the rule's
(Q = pi/8) miss the body's RCS by 1.13 dB rms (3.5 dB at worst) against 0.4 dB at the rule,
second order or not. The rule therefore stays. Samples without a shape operator (``curvature`` None: facet normals, flat within a facet) get
the range terms only.

*Energy split, as Sionna's material model.* A material with scattering coefficient :math:`S`
reflects the power share :math:`(1 - S^2)|\Gamma|^2` specularly and :math:`S^2|\Gamma|^2`
diffusely. PO carries the coherent share (the factor :math:`\sqrt{1 - S^2}\,\Gamma` above); the
diffuse share goes to the random-phase Lambertian scatterers of :mod:`sionnafmcw.diffuse` on the
same samples. Sionna's first-order specular paths must then be dropped (PO replaces them), so
nothing is counted twice.

*Dielectrics.* :math:`\Gamma_i` is the complex co-polar reflection coefficient of the sample's
material at its angle of incidence. For a half-space at normal incidence
:math:`\Gamma = (1 - \sqrt\eta)/(1 + \sqrt\eta)` (:func:`normal_incidence_reflection`,
:math:`\eta = \varepsilon_r - j\sigma/(\omega\varepsilon_0)`); the engine, which knows the
polarisation, passes :math:`\Gamma = r_{TE}(\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2
- r_{TM}(1 - (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2)` with Sionna's slab coefficients
(:math:`\hat{\mathbf s}` the TE direction; the minus sign because the TM basis vector flips on
reflection, so that :math:`\Gamma = r_{TE}` at normal incidence and :math:`-1` for a PEC at
every angle). PO with a local :math:`\Gamma` is the usual impedance-surface approximation; it is
exact for PEC and good near normal incidence, where the echo is.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .antenna import antenna_gain, direction_angles
from .constants import SPEED_OF_LIGHT

#: Largest in-sample quadratic phase (rad) the resolution rule allows at the sample's edge (module
#: docstring, "Sample size": the tiling of curved surfaces, not the in-sample phase, sets it).
MAX_QUADRATIC_PHASE = np.pi / 32


class PhysicalOpticsError(ValueError):
    """Samples or element positions that the PO integral cannot use; the message names the field."""


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _array(name, value, shape_tail, dtype=float):
    value = np.asarray(value, dtype=dtype)
    if value.ndim != 1 + len(shape_tail) or tuple(value.shape[1:]) != tuple(shape_tail):
        tail = "".join(f", {s}" for s in shape_tail)
        raise PhysicalOpticsError(f"SurfaceSamples.{name} must have shape [P{tail}], got {value.shape}")
    if np.issubdtype(value.dtype, np.number) and not np.all(np.isfinite(value)):
        raise PhysicalOpticsError(f"SurfaceSamples.{name} contains non-finite values")
    return value


@dataclass
class SurfaceSamples:
    """Samples of the lit surface (world frame), one per render hit.

    Attributes
    ----------
    position : ``[P, 3]`` m
    normal : ``[P, 3]`` unit surface normal (either side; it is turned towards the radar)
    area : ``[P]`` m^2, the surface area each sample stands for
    edges : ``[P, 2, 3]`` m, the two edge vectors of the sample's parallelogram footprint on the
        tangent plane (:func:`footprint_edges`); None treats samples as points (no in-sample phase)
    velocity : ``[P, 3]`` m/s (default 0)
    reflection : ``[P]`` complex co-polar reflection coefficient :math:`\\Gamma` (default -1, PEC)
    scattering_coefficient : ``[P]`` Sionna's :math:`S \\in [0, 1]` (default 0: all specular)
    curvature : ``[P, 3, 3]`` 1/m, the shape operator :math:`\\partial\\hat{\\mathbf n}/\\partial\\mathbf x`
        of the surface at the sample, for ``normal`` as given (:func:`interpolated_normals`); None:
        flat (facet normals), the in-sample phase then has the range curvature only
    object_id : ``[P]`` int (default 0); triangle : ``[P]`` int (default -1);
    barycentric : ``[P, 2]`` (default 0): where on which triangle, for :mod:`sionnafmcw.diffuse`
    labels : ``[P]`` str object names (default None)
    """

    position: np.ndarray
    normal: np.ndarray
    area: np.ndarray
    edges: np.ndarray | None = None
    velocity: np.ndarray | None = None
    reflection: np.ndarray | None = None
    scattering_coefficient: np.ndarray | None = None
    object_id: np.ndarray | None = None
    triangle: np.ndarray | None = None
    barycentric: np.ndarray | None = None
    labels: np.ndarray | None = field(default=None)
    curvature: np.ndarray | None = None

    def __post_init__(self):
        self.position = _array("position", self.position, (3,))
        p = self.position.shape[0]
        self.normal = _array("normal", self.normal, (3,))
        norm = np.linalg.norm(self.normal, axis=-1)
        if self.normal.shape[0] != p or np.any(np.abs(norm - 1.0) > 1e-3):
            raise PhysicalOpticsError(
                f"SurfaceSamples.normal must be [{p}, 3] unit vectors (got shape {self.normal.shape}, "
                f"norms in [{norm.min() if norm.size else 0:.3g}, {norm.max() if norm.size else 0:.3g}])")
        self.normal = self.normal / norm[:, None] if p else self.normal
        self.area = _array("area", self.area, ())
        if np.any(self.area < 0):
            raise PhysicalOpticsError("SurfaceSamples.area must be >= 0 m^2")
        defaults = {"velocity": (np.zeros((p, 3)), (3,), float),
                    "reflection": (np.full(p, -1.0 + 0j), (), complex),
                    "scattering_coefficient": (np.zeros(p), (), float),
                    "object_id": (np.zeros(p, dtype=np.int64), (), np.int64),
                    "triangle": (np.full(p, -1, dtype=np.int64), (), np.int64),
                    "barycentric": (np.zeros((p, 2)), (2,), float)}
        for name, (default, tail, dtype) in defaults.items():
            value = getattr(self, name)
            value = default if value is None else _array(name, np.broadcast_to(value, (p,) + tail), tail, dtype)
            setattr(self, name, np.array(value))
        if self.edges is not None:
            self.edges = _array("edges", self.edges, (2, 3))
        if self.curvature is not None:
            self.curvature = _array("curvature", self.curvature, (3, 3))
        s = self.scattering_coefficient
        if np.any((s < 0) | (s > 1)):
            raise PhysicalOpticsError("SurfaceSamples.scattering_coefficient must lie in [0, 1]")
        if self.labels is not None:
            self.labels = np.asarray(self.labels).astype(str)
        for name in ("area", "edges", "labels", "curvature"):
            value = getattr(self, name)
            if value is not None and value.shape[0] != p:
                raise PhysicalOpticsError(f"SurfaceSamples.{name} has {value.shape[0]} samples, position has {p}")

    @property
    def num_samples(self) -> int:
        return int(self.position.shape[0])

    def select(self, mask) -> "SurfaceSamples":
        """The samples where ``mask`` (``[P]`` bool or indices) holds."""
        mask = np.asarray(mask)
        if mask.dtype == bool and mask.shape == (self.num_samples,):   # else numpy names the mismatch
            mask = np.flatnonzero(mask)   # one pass over the mask; then each field gathers its rows only
        kw = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            kw[name] = None if value is None else value[mask]
        return SurfaceSamples(**kw)


# ---------------------------------------------------------------------------------------- sampling
def angular_grid_steps(directions, d_az: float, d_el: float, rotation=None) -> tuple[np.ndarray, np.ndarray]:
    r"""Direction increments across one pixel of an equiangular azimuth/elevation grid.

    For :math:`\hat{\mathbf u} = [\cos\vartheta\cos\varphi, \cos\vartheta\sin\varphi, \sin\vartheta]`
    (radar frame, ``directions [K, 3]``) returns :math:`\partial_\varphi\hat{\mathbf u}\,\Delta\varphi
    = \cos\vartheta[-\sin\varphi, \cos\varphi, 0]\Delta\varphi` and :math:`\partial_\vartheta
    \hat{\mathbf u}\,\Delta\vartheta = [-\sin\vartheta\cos\varphi, -\sin\vartheta\sin\varphi,
    \cos\vartheta]\Delta\vartheta`, both ``[K, 3]``, turned into the world by ``rotation`` (3x3).
    """
    u = np.asarray(directions, float)
    el = np.arcsin(np.clip(u[:, 2], -1.0, 1.0))
    az = np.arctan2(u[:, 1], u[:, 0])
    ce, se, ca, sa = np.cos(el), np.sin(el), np.cos(az), np.sin(az)
    step_az = np.stack([-ce * sa, ce * ca, np.zeros_like(ce)], -1) * d_az
    step_el = np.stack([-se * ca, -se * sa, ce], -1) * d_el
    if rotation is not None:
        rotation = np.asarray(rotation, float)
        step_az, step_el = step_az @ rotation.T, step_el @ rotation.T
    return step_az, step_el


def footprint_edges(position, normal, origin, step_u, step_v) -> np.ndarray:
    r"""Edge vectors ``[P, 2, 3]`` of each sample's footprint on its tangent plane.

    A ray from ``origin`` through ``position`` (distance :math:`r`, direction :math:`\hat{\mathbf u}`)
    whose direction changes by ``step_u``, ``step_v`` (``[P, 3]``, e.g. :func:`angular_grid_steps`)
    across the pixel sweeps :math:`r\,\Delta\hat{\mathbf u}` at the hit; projected along the ray onto
    the plane :math:`\hat{\mathbf n}\cdot\mathbf x = 0`:
    :math:`\mathbf e = r\Delta\hat{\mathbf u} - \frac{\hat{\mathbf n}\cdot r\Delta\hat{\mathbf u}}
    {\hat{\mathbf n}\cdot\hat{\mathbf u}}\hat{\mathbf u}`.
    """
    p = np.asarray(position, float)
    n = np.asarray(normal, float)
    d = p - np.asarray(origin, float)
    r = np.linalg.norm(d, axis=-1, keepdims=True)
    u = d / r
    cos = _dot(n, u)[:, None]
    cos = np.where(np.abs(cos) < 1e-9, 1e-9, cos)
    out = []
    for step in (step_u, step_v):
        e = r * np.asarray(step, float)
        out.append(e - (_dot(n, e)[:, None] / cos) * u)
    return np.stack(out, axis=1)


def render_samples(origin, directions, distance, normal, solid_angle, step_az=None, step_el=None,
                   **fields) -> SurfaceSamples:
    r""":class:`SurfaceSamples` from the hits of a render from ``origin`` (world).

    ``directions [P, 3]`` (unit, world) and ``distance [P]`` (m) of the rays that hit, ``normal``
    ``[P, 3]`` at the hits, ``solid_angle [P]`` (sr) of their pixels. The area a pixel stands for
    is :math:`\Delta A = r^2\Delta\Omega/|\cos\theta_i|` (the pixel engine's); ``step_az``,
    ``step_el`` (:func:`angular_grid_steps`) give the footprint edges for the in-sample phase.
    Grazing hits (:math:`|\cos\theta_i| < 10^{-6}`) get zero area. ``fields`` go to
    :class:`SurfaceSamples` (velocity, reflection, scattering_coefficient, object_id, triangle,
    barycentric, labels).
    """
    u = np.asarray(directions, float)
    t = np.asarray(distance, float)
    pos = np.asarray(origin, float) + t[:, None] * u
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    cos = np.abs(_dot(n, u))
    area = np.divide(t ** 2 * np.asarray(solid_angle, float), cos, out=np.zeros_like(t), where=cos > 1e-6)
    edges = None
    if step_az is not None and step_el is not None:
        edges = footprint_edges(pos, n, origin, step_az, step_el)
    return SurfaceSamples(pos, n, area, edges=edges, **fields)


def render_resolution(extent: float, distance: float, wavelength: float, curvature_radius: float = np.inf,
                      samples_across: int = 16, facet_size: float | None = None,
                      max_quadratic_phase: float = MAX_QUADRATIC_PHASE) -> float:
    r"""Largest angular pixel step (rad) for PO on a target of size ``extent`` at ``distance``.

    Sample size :math:`s = \min(2\sqrt{Q_{max}\min(R, \rho)/k},\ D/N_{across})` (module
    docstring: in-sample quadratic phase :math:`\le Q_{max}` = ``max_quadratic_phase`` at the
    sample's edge, :data:`MAX_QUADRATIC_PHASE` unless a convergence study asks otherwise; outline
    resolved), step :math:`s/R`.
    ``curvature_radius`` :math:`\rho`: the smallest radius of curvature of the lit surface (m;
    ``inf`` for flat facets). ``facet_size``: the mesh edge length of a faceted curved surface
    whose samples carry *facet* normals; a sample's footprint is taken in the plane of the facet
    it hit, so it must not straddle facets: :math:`s \le` ``facet_size``/3 (measured on a 0.1 m
    sphere of 4.9 mm facets: 0.3-0.8 dB from the quadrature at s = edge/3, 1.4 dB at edge/1.6,
    +2.5 dB at 2 edges). With interpolated (shading) normals leave it None: the tangent plane
    then follows the smooth surface and the curvature bound alone holds (within 1 dB of the
    quadrature at 16 samples across the same sphere).
    """
    for name, value in (("extent", extent), ("distance", distance), ("wavelength", wavelength)):
        if not np.isfinite(value) or value <= 0:
            raise PhysicalOpticsError(f"render_resolution: {name} must be a positive length in m, got {value!r}")
    if not curvature_radius > 0:
        raise PhysicalOpticsError(f"render_resolution: curvature_radius must be > 0 m, got {curvature_radius!r}")
    if int(samples_across) < 1:
        raise PhysicalOpticsError(f"render_resolution: samples_across must be >= 1, got {samples_across!r}")
    if not 0 < max_quadratic_phase <= np.pi:
        raise PhysicalOpticsError(f"render_resolution: max_quadratic_phase must lie in (0, pi] rad, got "
                                  f"{max_quadratic_phase!r}")
    # k x^2 / rho_eff <= Q at x = s/2 with rho_eff = min(R, rho): s = 2 sqrt(Q rho_eff / k)
    k = 2 * np.pi / wavelength
    s = min(2.0 * np.sqrt(max_quadratic_phase * min(distance, curvature_radius) / k), extent / int(samples_across))
    if facet_size is not None:
        if not facet_size > 0:
            raise PhysicalOpticsError(f"render_resolution: facet_size must be > 0 m, got {facet_size!r}")
        s = min(s, facet_size / 3)
    return float(s / distance)


# ---------------------------------------------------------------------------------------- materials
def normal_incidence_reflection(eta) -> np.ndarray:
    r""":math:`\Gamma = (1 - \sqrt\eta)/(1 + \sqrt\eta)` of a half-space of complex relative
    permittivity :math:`\eta` at normal incidence (Sionna's :math:`r_{TE}`; -1 for a PEC)."""
    root = np.sqrt(np.asarray(eta, dtype=complex))
    return (1 - root) / (1 + root)


def coherent_reflection(reflection, scattering_coefficient) -> np.ndarray:
    r"""PO's share of the reflected field: :math:`\sqrt{1 - S^2}\,\Gamma` (Sionna's specular share)."""
    s = np.asarray(scattering_coefficient, float)
    return np.sqrt(np.clip(1.0 - s ** 2, 0.0, 1.0)) * np.asarray(reflection, complex)


# ---------------------------------------------------------------------------------------- geometry per element
@dataclass
class ElementGeometry:
    """Per element and sample: distances ``r_t [M, P]``, ``r_r [N, P]`` and unit vectors from the
    elements to the samples ``s_t [M, P, 3]``, ``s_r [N, P, 3]`` (world)."""

    r_t: np.ndarray
    r_r: np.ndarray
    s_t: np.ndarray
    s_r: np.ndarray

    @classmethod
    def of(cls, samples: SurfaceSamples, tx_positions, rx_positions) -> "ElementGeometry":
        tx = np.atleast_2d(np.asarray(tx_positions, float))
        rx = np.atleast_2d(np.asarray(rx_positions, float))
        for name, value in (("tx_positions", tx), ("rx_positions", rx)):
            if value.ndim != 2 or value.shape[1] != 3 or not np.all(np.isfinite(value)):
                raise PhysicalOpticsError(f"{name} must be finite [num_elements, 3] world positions (m), got {value.shape}")
        d_t = samples.position[None] - tx[:, None]
        d_r = samples.position[None] - rx[:, None]
        r_t = np.linalg.norm(d_t, axis=-1)
        r_r = np.linalg.norm(d_r, axis=-1)
        if np.any(r_t <= 0) or np.any(r_r <= 0):
            raise PhysicalOpticsError("a surface sample coincides with an antenna element (zero distance)")
        return cls(r_t, r_r, d_t / r_t[..., None], d_r / r_r[..., None])

    def delays(self) -> np.ndarray:
        """:math:`(r_t + r_r)/c` ``[M, N, P]`` (s)."""
        return (self.r_t[:, None] + self.r_r[None]) / SPEED_OF_LIGHT

    def dopplers(self, velocity, wavelength: float) -> np.ndarray:
        r""":math:`f_D = -\mathbf v\cdot(\hat{\mathbf s}_t + \hat{\mathbf s}_r)/\lambda` ``[M, N, P]`` (Hz, positive approaching)."""
        rate_t = _dot(self.s_t, velocity[None])
        rate_r = _dot(self.s_r, velocity[None])
        return -(rate_t[:, None] + rate_r[None]) / wavelength


def _gains(gain, shape, name):
    if gain is None:
        return np.ones(shape)
    gain = np.asarray(gain, float)
    if gain.shape != shape:
        raise PhysicalOpticsError(f"{name} must have shape {shape} (elements x samples), got {gain.shape}")
    return gain


def oriented_normals(samples: SurfaceSamples, towards, return_side: bool = False):
    """Sample normals turned to the side of the point ``towards`` (the phase centre); with
    ``return_side`` also the sign ``[P]`` (+-1) they were multiplied by."""
    side = np.sign(_dot(samples.normal, np.asarray(towards, float) - samples.position))
    side[side == 0] = 1.0
    return (samples.normal * side[:, None], side) if return_side else samples.normal * side[:, None]


def sinc_and_derivatives(y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r""":math:`S(y) = \sin y/y` and its first two derivatives :math:`S' = (\cos y - S)/y`,
    :math:`S'' = -S - 2S'/y`, with their Taylor series (to :math:`y^8`, :math:`y^7`, :math:`y^6`)
    below :math:`|y| = 0.05`, where the closed forms cancel."""
    shape = np.shape(y)
    y = np.atleast_1d(np.asarray(y, float))
    small = np.abs(y) < 0.05
    safe = np.where(small, 1.0, y)
    s0 = np.sin(safe)
    s0 /= safe
    s1 = np.cos(safe)
    s1 -= s0
    s1 /= safe
    s2 = s1 / safe
    s2 *= -2.0
    s2 -= s0
    if np.any(small):
        x = y[small]
        x2 = x * x
        s0[small] = 1 - x2 / 6 * (1 - x2 / 20 * (1 - x2 / 42 * (1 - x2 / 72)))
        s1[small] = -x / 3 * (1 - x2 / 10 * (1 - x2 / 28 * (1 - x2 / 54)))
        s2[small] = -1 / 3 + x2 / 10 * (1 - x2 * 5 / 84 * (1 - x2 * 14 / 540))
    return s0.reshape(shape), s1.reshape(shape), s2.reshape(shape)


def footprint_factor(k: float, a, b, h11, h22, h12) -> np.ndarray:
    r"""The in-sample phase factor :math:`F` of the module docstring (complex, broadcast shape).

    ``a``, ``b``: the linear phase across the footprint's edges, :math:`k\,\mathbf g\cdot\mathbf e_{1,2}`
    (rad); ``h11``, ``h22``, ``h12``: :math:`\mathbf e_i^T\mathbf H\mathbf e_j` (m); ``k`` (rad/m).
    :math:`F = e^{-j\mu}[(1 + j\mu)S(y)S(z) + \frac{jk}8(h_{11}S''(y)S(z) + h_{22}S(y)S''(z)
    + 2h_{12}S'(y)S'(z))]`, :math:`\mu = k(h_{11} + h_{22})/24`, where its error bound
    :math:`\frac12\operatorname{Var}q` is below 1; else (a quadratic phase of radians: footprints
    stretched at grazing incidence, far second-bounce surfaces; nothing is known of :math:`F` there
    but :math:`|F| \le 1`) the linear factor :math:`S(y)S(z)`, which keeps that bound
    (:func:`footprint_error_bound`)."""
    sy, sy1, sy2 = sinc_and_derivatives(0.5 * np.asarray(a, float))
    sz, sz1, sz2 = sinc_and_derivatives(0.5 * np.asarray(b, float))
    mu = k * (np.asarray(h11) + h22) / 24
    base = sy * sz
    im = h11 * sy2 * sz
    im += h22 * sy * sz2
    im += 2 * h12 * sy1 * sz1
    im *= k / 8
    im += mu * base
    cos, sin = np.cos(mu), np.sin(mu)
    second = np.empty(np.broadcast(base, im).shape, complex)
    second.real = cos * base + sin * im
    second.imag = cos * im - sin * base
    return np.where(_quadratic_variance(k, h11, h22, h12) < 2.0, second, base)


def _quadratic_variance(k: float, h11, h22, h12):
    r""":math:`\operatorname{Var}q = \frac{k^2}4\bigl(\frac{h_{11}^2 + h_{22}^2}{180} + \frac{h_{12}^2}{36}\bigr)`
    over the footprint (:math:`\operatorname{Var}\alpha^2 = 1/180`, :math:`\langle\alpha^2\beta^2\rangle = 1/144`)."""
    return k * k / 4 * ((np.asarray(h11) ** 2 + np.asarray(h22) ** 2) / 180 + np.asarray(h12) ** 2 / 36)


def footprint_error_bound(k: float, h11, h22, h12) -> np.ndarray:
    r"""Bound on :math:`|F - F_{exact}|` of :func:`footprint_factor`: :math:`\frac12\operatorname{Var}q`
    (second order, :math:`|e^{-jx} - 1 + jx| \le x^2/2`) where that is below 1, else
    :math:`\sqrt{\mu^2 + \operatorname{Var}q} \ge \langle|q|\rangle` (linear, :math:`|e^{-jx} - 1| \le |x|`;
    at least 1 there)."""
    var = _quadratic_variance(k, h11, h22, h12)
    mu = k * (np.asarray(h11) + h22) / 24
    return np.where(var < 2.0, 0.5 * var, np.sqrt(mu * mu + var))


def in_sample_factor(k: float, edges, s_t, r_t, cos_t, s_r, r_r, cos_r, curvature=None) -> np.ndarray:
    r""":func:`footprint_factor` ``[M, N, P]`` of every element pair and sample.

    ``edges [P, 2, 3]``; per Tx element (or its image) ``s_t [M, P, 3]`` (unit, element -> sample),
    ``r_t [M, P]``, ``cos_t [M, P]`` (:math:`\hat{\mathbf n}\cdot\hat{\mathbf u}_t`, normal on
    the incident side); the same per Rx element; ``curvature [P, 3, 3]`` the shape operator of that
    turned normal (None: flat). :math:`h_{ij} = (\mathbf e_i\cdot\mathbf e_j - (\hat{\mathbf s}_t\cdot\mathbf e_i)
    (\hat{\mathbf s}_t\cdot\mathbf e_j))/r_t + (\dots)/r_r
    + (\cos\theta_t + \cos\theta_r)\,\mathbf e_i^T\mathbf K\mathbf e_j`.
    """
    e1, e2 = edges[:, 0], edges[:, 1]
    pt = np.stack([_dot(s_t, e1[None]), _dot(s_t, e2[None])], axis=-1)     # [M, P, 2]
    pr = np.stack([_dot(s_r, e1[None]), _dot(s_r, e2[None])], axis=-1)     # [N, P, 2]
    gram = (_dot(e1, e1), _dot(e2, e2), _dot(e1, e2))
    pairs = ((0, 0), (1, 1), (0, 1))
    if curvature is not None:
        k_e = [np.einsum("pij,pj->pi", curvature, e) for e in (e1, e2)]
        kappa = (_dot(e1, k_e[0]), _dot(e2, k_e[1]), 0.5 * (_dot(e1, k_e[1]) + _dot(e2, k_e[0])))
        cos_sum = cos_t[:, None] + cos_r[None]
    h = []
    for n, ((i, j), ee) in enumerate(zip(pairs, gram)):
        ht = (ee[None] - pt[..., i] * pt[..., j]) / r_t
        hr = (ee[None] - pr[..., i] * pr[..., j]) / r_r
        hij = ht[:, None] + hr[None]
        if curvature is not None:
            hij += cos_sum * kappa[n]
        h.append(hij)
    a = k * (pt[:, None, :, 0] + pr[None, :, :, 0])
    b = k * (pt[:, None, :, 1] + pr[None, :, :, 1])
    return footprint_factor(k, a, b, *h)


def normal_gradient_tensors(corners, corner_normals) -> np.ndarray:
    r"""Per triangle the tensor :math:`\mathbf T = \mathbf N(\mathbf E^T\mathbf E)^{-1}\mathbf E^T
    = \Delta\mathbf n_1\mathbf f_1^T + \Delta\mathbf n_2\mathbf f_2^T` (``[F, 3, 3]``) of
    :func:`interpolated_normals`: ``corners [F, 3, 3]`` (vertices), ``corner_normals [F, 3, 3]``,
    :math:`\Delta\mathbf n_a` the corner-normal differences, :math:`\mathbf f_a` the dual basis of the
    triangle's plane (:math:`\mathbf f_a\cdot\mathbf e_b = \delta_{ab}`, :math:`\mathbf e_a = \mathbf v_a - \mathbf v_0`);
    zero for a degenerate triangle. It depends on the triangle alone, so a surface computes it once
    (:meth:`~sionnafmcw.engines.surfaces.Surface.normal_gradients`) and every hit on the triangle takes
    its shape operator from it (:func:`shape_operator`)."""
    v = np.asarray(corners, float)
    nc = np.asarray(corner_normals, float)
    e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    g11, g22, g12 = _dot(e1, e1), _dot(e2, e2), _dot(e1, e2)
    det = g11 * g22 - g12 * g12
    det = np.where(det > 0, det, np.inf)                              # degenerate triangle: K = 0
    # the rows of (E^T E)^-1 E^T: the dual basis f_a of the triangle's plane, f_a . e_b = delta_ab
    f1 = (g22[:, None] * e1 - g12[:, None] * e2) / det[:, None]
    f2 = (g11[:, None] * e2 - g12[:, None] * e1) / det[:, None]
    return (nc[:, 1] - nc[:, 0])[:, :, None] * f1[:, None, :] + (nc[:, 2] - nc[:, 0])[:, :, None] * f2[:, None, :]


def shape_operator(corner_normals, tensors, barycentric) -> tuple[np.ndarray, np.ndarray]:
    r"""The interpolated normal :math:`\hat{\mathbf n} = \mathbf m/|\mathbf m|` and its shape operator
    :math:`\mathbf K = (\mathbf I - \hat{\mathbf n}\hat{\mathbf n}^T)\mathbf T/|\mathbf m|` at hits
    (:func:`interpolated_normals`), from each hit's triangle's ``corner_normals [P, 3, 3]`` and
    :func:`normal_gradient_tensors` ``tensors [P, 3, 3]``, ``barycentric [P, 2]``.
    Returns ``(normal [P, 3], curvature [P, 3, 3])``."""
    nc = np.asarray(corner_normals, float)
    t = np.asarray(tensors, float)
    b = np.asarray(barycentric, float)
    m = nc[:, 0] + b[:, :1] * (nc[:, 1] - nc[:, 0]) + b[:, 1:] * (nc[:, 2] - nc[:, 0])
    length = np.linalg.norm(m, axis=-1)
    normal = m / length[:, None]
    projected = t - normal[:, :, None] * np.einsum("pi,pij->pj", normal, t)[:, None, :]
    return normal, projected / length[:, None, None]


def interpolated_normals(corners, corner_normals, barycentric) -> tuple[np.ndarray, np.ndarray]:
    r"""Shading normal and its shape operator at points of triangles (Mitsuba's interpolated normal).

    ``corners [P, 3, 3]`` (the triangles' vertices), ``corner_normals [P, 3, 3]``, ``barycentric
    [P, 2]`` (:math:`b_1, b_2`). The normal is :math:`\hat{\mathbf n} = \mathbf m/|\mathbf m|`,
    :math:`\mathbf m = \mathbf n_0 + b_1(\mathbf n_1 - \mathbf n_0) + b_2(\mathbf n_2 - \mathbf n_0)`;
    with :math:`\mathbf E = [\mathbf v_1 - \mathbf v_0, \mathbf v_2 - \mathbf v_0]` and
    :math:`\mathbf N` likewise of the corner normals, a step :math:`d\mathbf x` in the triangle's
    plane moves the barycentrics by :math:`(\mathbf E^T\mathbf E)^{-1}\mathbf E^Td\mathbf x`, so
    :math:`\mathbf K = \partial\hat{\mathbf n}/\partial\mathbf x = (\mathbf I - \hat{\mathbf n}\hat{\mathbf n}^T)
    \mathbf N(\mathbf E^T\mathbf E)^{-1}\mathbf E^T/|\mathbf m|` (``[P, 3, 3]``; :math:`\mathbf I/\rho`
    on the tangent plane of a sphere of radius :math:`\rho` with outward normals): the triangle's
    :func:`normal_gradient_tensors` through :func:`shape_operator`.
    Returns ``(normal [P, 3], curvature [P, 3, 3])``."""
    return shape_operator(corner_normals, normal_gradient_tensors(corners, corner_normals), barycentric)


def po_gains(samples: SurfaceSamples, tx_positions, rx_positions, wavelength: float, tx_gain=None, rx_gain=None,
             in_sample_phase: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""PO contributions ``(a, tau, doppler)``, each ``[M, N, P]``, of the samples (module docstring).

    ``tx_positions [M, 3]``, ``rx_positions [N, 3]``: element positions in the world (m);
    ``tx_gain [M, P]``, ``rx_gain [N, P]``: element power gains towards each sample (default 1,
    isotropic). ``in_sample_phase=False`` drops the footprint factor :math:`F` (point samples).
    Normals are turned towards the elements' centroid; a sample seen from behind by an element
    pair (negative obliquity) contributes nothing.
    """
    if not np.isfinite(wavelength) or wavelength <= 0:
        raise PhysicalOpticsError(f"po_gains: wavelength must be a positive length in m, got {wavelength!r}")
    geo = ElementGeometry.of(samples, tx_positions, rx_positions)
    m, n, p = geo.r_t.shape[0], geo.r_r.shape[0], samples.num_samples
    g_t = _gains(tx_gain, (m, p), "tx_gain")
    g_r = _gains(rx_gain, (n, p), "rx_gain")
    centre = np.concatenate([np.atleast_2d(tx_positions), np.atleast_2d(rx_positions)]).mean(axis=0)
    normal, side = oriented_normals(samples, centre, return_side=True)
    cos_t = -_dot(normal[None], geo.s_t)                      # n . u_t  [M, P]
    cos_r = -_dot(normal[None], geo.s_r)                      # n . u_r  [N, P]
    obliquity = np.clip((cos_t[:, None] + cos_r[None]) / 2, 0.0, None)
    gamma = coherent_reflection(samples.reflection, samples.scattering_coefficient)
    k = 2 * np.pi / wavelength
    footprint = 1.0
    if in_sample_phase and samples.edges is not None:
        curvature = None if samples.curvature is None else samples.curvature * side[:, None, None]
        footprint = in_sample_factor(k, samples.edges, geo.s_t, geo.r_t, cos_t, geo.s_r, geo.r_r, cos_r, curvature)
    a = (1j * gamma / (4 * np.pi)) * np.sqrt(g_t[:, None] * g_r[None]) * obliquity * samples.area * footprint / (
        geo.r_t[:, None] * geo.r_r[None])
    return a, geo.delays(), geo.dopplers(samples.velocity, wavelength)


def element_positions(radar, position, orientation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World Tx ``[M, 3]`` and Rx ``[N, 3]`` element positions and the rotation (radar -> world)."""
    from .geometry import rotation_matrix

    rotation = rotation_matrix(orientation)
    position = np.asarray(position, float)
    return position + radar.tx_positions @ rotation.T, position + radar.rx_positions @ rotation.T, rotation


def element_gains(radar, samples: SurfaceSamples, tx_w, rx_w, rotation) -> tuple[np.ndarray, np.ndarray]:
    """The radar's element pattern gains towards every sample: ``[M, P]`` and ``[N, P]``."""
    d_t = (samples.position[None] - tx_w[:, None]) @ rotation
    d_r = (samples.position[None] - rx_w[:, None]) @ rotation
    return (antenna_gain(radar.antenna_pattern, *direction_angles(d_t)),
            antenna_gain(radar.antenna_pattern, *direction_angles(d_r)))


def po_echoes(samples: SurfaceSamples, radar, position=(0.0, 0.0, 0.0), orientation=(0.0, 0.0, 0.0),
              label: str = "po"):
    """:class:`~sionnafmcw.echoes.Echoes` ``[num_tx, num_rx, P]`` of the PO echo of ``samples`` for
    ``radar`` at the pose ``(position, orientation)`` (world, m and yaw/pitch/roll rad), with the
    radar's element patterns. Labels: the samples' ``labels`` where given, else ``label``."""
    from .echoes import Echoes

    tx_w, rx_w, rotation = element_positions(radar, position, orientation)
    g_t, g_r = element_gains(radar, samples, tx_w, rx_w, rotation)
    a, tau, doppler = po_gains(samples, tx_w, rx_w, SPEED_OF_LIGHT / radar.fc, g_t, g_r)
    labels = samples.labels if samples.labels is not None else np.full(samples.num_samples, label)
    return Echoes(a, tau, doppler, labels)


# ---------------------------------------------------------------------------------------- RCS
def channel(a, tau, frequency: float) -> np.ndarray:
    r"""Coherent sum :math:`h = \sum_p a_p e^{-j2\pi f\tau_p}` over the last axis (the PO integral)."""
    return np.sum(np.asarray(a) * np.exp(-2j * np.pi * frequency * np.asarray(tau)), axis=-1)


def monostatic_rcs(samples: SurfaceSamples, radar_point, wavelength: float, reference_point) -> float:
    r"""Monostatic PO RCS (m^2) from ``radar_point`` (world), isotropic elements:
    :math:`\sigma = (4\pi)^3R^4|h|^2/\lambda^2`, :math:`R = \|\text{reference} - \text{radar}\|`."""
    radar_point = np.asarray(radar_point, float)[None]
    a, tau, _ = po_gains(samples, radar_point, radar_point, wavelength)
    h = channel(a[0, 0], tau[0, 0], SPEED_OF_LIGHT / wavelength)
    r = np.linalg.norm(np.asarray(reference_point, float) - radar_point[0])
    return float((4 * np.pi) ** 3 * r ** 4 * np.abs(h) ** 2 / wavelength ** 2)


__all__ = ["ElementGeometry", "MAX_QUADRATIC_PHASE", "PhysicalOpticsError",
           "SurfaceSamples", "angular_grid_steps", "channel", "coherent_reflection", "element_gains",
           "element_positions", "footprint_edges", "footprint_error_bound", "footprint_factor", "in_sample_factor",
           "interpolated_normals", "monostatic_rcs", "normal_gradient_tensors", "shape_operator", "normal_incidence_reflection",
           "oriented_normals", "po_echoes", "po_gains", "render_resolution", "render_samples",
           "sinc_and_derivatives"]
