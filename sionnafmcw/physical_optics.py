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
:math:`-k(r_t + r_r)` changes across its footprint. To first order in the offset
:math:`\mathbf x` from :math:`\mathbf p_i`, :math:`r_t + r_r \approx r_{t} + r_{r} + \mathbf g\cdot\mathbf x`
with :math:`\mathbf g = \hat{\mathbf s}_t + \hat{\mathbf s}_r`; over the parallelogram footprint
:math:`\{\alpha\mathbf e_1 + \beta\mathbf e_2,\ |\alpha|,|\beta|\le\frac12\}` (the pixel's
angular cell projected along the ray onto the tangent plane, :func:`footprint_edges`) the exact
integral of the linear phase is

.. math::
    F_{mni} = \operatorname{sinc}\!\Bigl(\frac{k\,\mathbf g\cdot\mathbf e_1}{2}\Bigr)
              \operatorname{sinc}\!\Bigl(\frac{k\,\mathbf g\cdot\mathbf e_2}{2}\Bigr),
    \qquad \operatorname{sinc}x = \frac{\sin x}{x},

a real factor per element pair. With it a tiling of a flat facet integrates the linear phase
exactly, whatever the sample size; what remains is the quadratic phase across one sample,
:math:`k x^2/R` from the range curvature and :math:`2k x^2/(2\rho)` from a surface curvature
radius :math:`\rho`. Keeping it below :math:`\pi/32` at the sample's edge (:math:`x = s/2`) gives
the resolution rule of :func:`render_resolution`:

.. math::
    s \le \tfrac14\sqrt{\lambda\,\min(R, \rho)},\qquad s \le D/N_{across},

(2.2 cm at 2 m for a flat plate; 5 mm on a 0.1 m sphere), the second bound keeping a target of
size :math:`D` at least :math:`N_{across}` samples wide so its outline is resolved. (Measured on
a 0.1 m sphere with interpolated normals: :math:`\pi/8`, i.e. 1 cm samples, is up to 1.5 dB off
the quadrature at 20 m; :math:`\pi/32` is within 0.6 dB at 2-20 m.)

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

#: Largest in-sample quadratic phase (rad) the resolution rule allows at the sample's edge.
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
        s = self.scattering_coefficient
        if np.any((s < 0) | (s > 1)):
            raise PhysicalOpticsError("SurfaceSamples.scattering_coefficient must lie in [0, 1]")
        if self.labels is not None:
            self.labels = np.asarray(self.labels).astype(str)
        for name in ("area", "edges", "labels"):
            value = getattr(self, name)
            if value is not None and value.shape[0] != p:
                raise PhysicalOpticsError(f"SurfaceSamples.{name} has {value.shape[0]} samples, position has {p}")

    @property
    def num_samples(self) -> int:
        return int(self.position.shape[0])

    def select(self, mask) -> "SurfaceSamples":
        """The samples where ``mask`` (``[P]`` bool or indices) holds."""
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
                      samples_across: int = 16, facet_size: float | None = None) -> float:
    r"""Largest angular pixel step (rad) for PO on a target of size ``extent`` at ``distance``.

    Sample size :math:`s = \min(\frac12\sqrt{\lambda\min(R, \rho)},\ D/N_{across})` (module
    docstring: in-sample quadratic phase :math:`\le\pi/32`, outline resolved), step :math:`s/R`.
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
    # k x^2 / rho_eff <= MAX at x = s/2 with rho_eff = min(R, rho): s = 2 sqrt(MAX rho_eff / k)
    k = 2 * np.pi / wavelength
    s = min(2.0 * np.sqrt(MAX_QUADRATIC_PHASE * min(distance, curvature_radius) / k), extent / int(samples_across))
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


def oriented_normals(samples: SurfaceSamples, towards) -> np.ndarray:
    """Sample normals turned to the side of the point ``towards`` (the phase centre)."""
    side = np.sign(_dot(samples.normal, np.asarray(towards, float) - samples.position))
    side[side == 0] = 1.0
    return samples.normal * side[:, None]


def multiply_sinc(footprint, k: float, proj_t, proj_r) -> None:
    r"""``footprint [M, N, P] *=``
    :math:`\operatorname{sinc}(k(\mathbf s_t\cdot\mathbf e + \mathbf s_r\cdot\mathbf e)/2)` for
    ``proj_t [M, P]``, ``proj_r [N, P]`` (the in-sample phase factor of one footprint edge), in
    place: ``np.sinc(k (proj_t + proj_r) / (2 pi))`` operation for operation, without its
    temporaries."""
    x = np.add(proj_t[:, None], proj_r[None])
    x *= k
    x /= 2 * np.pi
    x *= np.pi                                   # np.sinc: y = pi x, y = where(y, y, eps), sin(y) / y
    x[x == 0] = np.finfo(x.dtype).eps
    y = np.sin(x)
    y /= x
    footprint *= y


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
    normal = oriented_normals(samples, centre)
    cos_t = -_dot(normal[None], geo.s_t)                      # n . u_t  [M, P]
    cos_r = -_dot(normal[None], geo.s_r)                      # n . u_r  [N, P]
    obliquity = np.clip((cos_t[:, None] + cos_r[None]) / 2, 0.0, None)
    gamma = coherent_reflection(samples.reflection, samples.scattering_coefficient)
    k = 2 * np.pi / wavelength
    footprint = np.ones((m, n, p))
    if in_sample_phase and samples.edges is not None:
        for e in range(2):
            proj_t = _dot(geo.s_t, samples.edges[None, :, e])   # [M, P]
            proj_r = _dot(geo.s_r, samples.edges[None, :, e])   # [N, P]
            multiply_sinc(footprint, k, proj_t, proj_r)
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


__all__ = ["ElementGeometry", "MAX_QUADRATIC_PHASE", "PhysicalOpticsError", "SurfaceSamples", "angular_grid_steps",
           "channel", "coherent_reflection", "element_gains", "element_positions", "footprint_edges",
           "monostatic_rcs", "multiply_sinc", "normal_incidence_reflection", "oriented_normals", "po_echoes",
           "po_gains", "render_resolution", "render_samples"]
