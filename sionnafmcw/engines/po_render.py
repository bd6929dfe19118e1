r"""The physical-optics render shared by the engines: the lit surface as :class:`SurfaceSamples`.

From a point :math:`\mathbf c` (the array's phase centre, or the centre of the Tx elements),
every object is rendered on its own equiangular azimuth/elevation grid (radar frame) covering its
angular bounding box, with the angular step of :func:`sionnafmcw.physical_optics.render_resolution`
for its size, its largest range and its smallest radius of curvature. Rays are cast with
Mitsuba's ``ray_intersect_preliminary`` over the objects' surfaces, each built once in its own
frame and placed per frame (:mod:`~sionnafmcw.engines.surfaces`: no acceleration structure is
rebuilt for a rigid object); a ray is kept where its *nearest* hit is on the object it was cast
for, so visibility from the radar comes with the cast. Every kept hit is one :class:`~sionnafmcw.physical_optics.SurfaceSamples`
sample: position (from the triangle and barycentrics, float64), shading normal, area and
footprint edges (:func:`~sionnafmcw.physical_optics.render_samples`), velocity (per-vertex field
interpolated, else the object's velocity), the material's complex reflection coefficient and
scattering coefficient, and object / triangle / barycentrics for
:mod:`sionnafmcw.diffuse`'s random phases. :func:`render` returns them as a :class:`Render`.

Shading normals
---------------
A faceted sphere or limb rendered with its facet normals would be its flat facets, whose PO is a
set of glints that depend on the tessellation. Where the PLY carries vertex normals the surface
takes them at its smooth vertices (:class:`~sionnafmcw.engines.surfaces.Surface`); elsewhere
:func:`shading_normals` smooths across edges whose dihedral angle is below
``crease_angle`` (default 30 degrees): every triangle corner gets the area-weighted mean of the
normals of the triangles at that vertex that lie within the crease angle of its own, and a hit
gets the barycentric interpolation of its triangle's corner normals. A flat plate (any
tessellation) keeps its plane normal, a box or a trihedral its face normals (90 degree
creases), a sphere or a body a smooth normal field. :func:`curvature_radius` reads the
smallest radius of curvature of that field (edge length over the angle between the corner
normals along it) for the resolution rule, and every sample carries the field's shape operator
:math:`\partial\hat{\mathbf n}/\partial\mathbf x` at its hit
(:func:`~sionnafmcw.physical_optics.interpolated_normals`) for the second-order in-sample phase.

Curvature classes
-----------------
The resolution rule is local: a sample of size :math:`s` on a surface of radius of curvature
:math:`\rho` keeps its quadratic phase within bounds when :math:`s \le \tfrac14\sqrt{\lambda\min(R, \rho)}`
(:func:`~sionnafmcw.physical_optics.render_resolution`). One grid per object at the object's smallest
radius samples all of it as finely as its most curved part needs: a forearm capsule of 35 mm
radius that ends in a flattened hand, whose rim curves at 6 mm, is sampled at 1.2 mm all over,
where the capsule needs 2.9 mm (on the ``jump`` scene's body at 6 m, the two forearms then hold
29k of its 63k first-bounce samples; 8k with the classes). So the triangles of a
curved surface are put in *curvature classes* (:func:`curvature_classes`): class :math:`c`
holds the triangles whose own radius (:func:`triangle_curvature_radii`, the smallest over its
edges) is at least :math:`\rho_0 r^c`, :math:`\rho_0` the object's radius (:func:`curvature_radius`,
the robust quantile as before), :math:`r` = :data:`CURVATURE_CLASS_RATIO`, and is rendered on its
own grid at the rule's step for :math:`\rho_0 r^c` over the angular box of its own triangles. A
ray of class :math:`c`'s grid keeps its hit only where it is the nearest hit and lies on a triangle
of class :math:`c`: every visible point of the surface is the first hit of every grid's rays there
and is kept by the grid of its own class alone, so the classes tile the lit surface as the objects
of a scene do (a sample stands for its pixel's footprint; at a class boundary the pixels whose
centre falls on a class are that class's, the same point sampling as where two objects meet).
Every triangle is then sampled within the rule for its own curvature (and as finely as before
where that is the object's), and the solid angle and footprint of each sample are its own
grid's. An object whose triangles all lie in one class (flat ones, spheres, the room) is
rendered exactly as with one grid.

Multiple bounces: ray-tube PO on the last surface
-------------------------------------------------
:func:`reflect` continues the render's rays: each sample's ray is reflected about the shading
normal, :math:`\hat{\mathbf k}_{out} = \hat{\mathbf k}_{in} - 2(\hat{\mathbf n}\cdot\hat{\mathbf k}_{in})\hat{\mathbf n}`,
and cast again. After :math:`d - 1` reflections on locally flat surfaces the geometric-optics
field is the spherical wave of the *image source* :math:`\mathbf t' = M(\mathbf t)`, :math:`M` the
composition of the mirror maps :math:`\mathbf x \mapsto \mathbf x - 2\hat{\mathbf n}_i(\hat{\mathbf n}_i\cdot(\mathbf x - \mathbf p_i))`
of the previous bounces, times the product of their (coherent) reflection coefficients. The
:math:`d`-th surface then carries the PO current of that incident field, and its radiation to
the receive elements is the same integral as the single bounce with every Tx element
:math:`\mathbf t_m` replaced by its image :math:`M(\mathbf t_m)` (:func:`chain_po_gains`; for
:math:`d = 1` this is :func:`~sionnafmcw.physical_optics.po_gains`). The ray tube of a sample
keeps its solid angle :math:`\Delta\Omega` through plane mirrors, so its area on surface
:math:`d` is :math:`L^2\Delta\Omega/|\cos\theta_i|` with :math:`L = \|\mathbf p_d - M(\mathbf c)\|`
the unfolded length, and its footprint edges are the mirrored angular steps; only the rays
that went through the whole chain reach surface :math:`d`, so the integral runs over the *exit
aperture* of the chain.

For a trihedral corner reflector (three mutually orthogonal faces, :math:`M` the point
reflection through the corner :math:`\mathbf o`) seen monostatically from range :math:`R`, the
image :math:`2\mathbf o - \mathbf c` lies at :math:`R` behind the corner on the line of sight,
so a point of the exit aperture at a distance :math:`\rho` off that line has the two-way length
:math:`2\sqrt{R^2 + \rho^2} \approx 2R + \rho^2/R` -- the phase of a flat plate of the exit
aperture's shape facing the radar at :math:`R`. The triple bounce therefore tends to
:math:`4\pi A_{eff}^2/\lambda^2` with :math:`A_{eff} = a^2/\sqrt3` (the hexagon common to the
aperture triangle and its point reflection), i.e. :math:`4\pi a^4/(3\lambda^2)`, in the far
field, and to the image-method (GO) value :math:`\pi R^2` when the aperture spans many Fresnel
zones, exactly as a plate does. The return to the receiver is not tested for shadowing beyond
the last surface (exact for the single bounce, where it retraces the incident ray).

Limits: from the second bounce on the samples are the first bounce's tubes at the unfolded length
(coarser than the resolution rule wants for a far second surface); where an exit aperture's outline
needs finer tubes, :mod:`~sionnafmcw.engines.bounce_sampling` splits them. The return to the receive
elements is not checked for blocking.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import SPEED_OF_LIGHT, VACUUM_PERMITTIVITY
from ..electromagnetics import slab_reflection_coefficients, unit, vertical_polarisation
from ..physical_optics import (
    PhysicalOpticsError, SurfaceSamples, footprint_edges, in_sample_factor, render_resolution, shape_operator,
)
from .loaded_scene import interpolate

#: Default crease angle (rad) of :func:`shading_normals`: smooth below, sharp edge above.
CREASE_ANGLE = float(np.deg2rad(30.0))
#: Most rays one object's render may cast (a guard against a resolution that would exhaust memory).
MAX_RAYS_PER_OBJECT = 4_000_000
#: Ratio :math:`r` of the radii of curvature of neighbouring curvature classes (module docstring,
#: *Curvature classes*): a class's samples may be :math:`\sqrt r` times as large as the class below's.
CURVATURE_CLASS_RATIO = 2.0
#: Most curvature classes of one object (the last one holds every flatter triangle).
MAX_CURVATURE_CLASSES = 6


class RenderError(PhysicalOpticsError):
    """The PO render cannot be made as asked; the message names the object and the parameter."""


# ---------------------------------------------------------------------------------------- materials
@dataclass(frozen=True)
class Material:
    """What PO needs of a radio material: complex relative permittivity :math:`\\eta`, slab
    thickness (m) and Sionna's scattering coefficient :math:`S`."""

    name: str
    eta: complex
    thickness: float
    scattering_coefficient: float


def radio_material(mat, obj_name: str = "") -> Material:
    """:class:`Material` of a Sionna ``RadioMaterial`` at its scene's frequency."""
    needed = ("relative_permittivity", "conductivity", "thickness", "scattering_coefficient")
    missing = [a for a in needed if not hasattr(mat, a)]
    if missing:
        raise RenderError(f"po_render: object {obj_name!r} has radio material {getattr(mat, 'name', mat)!r} "
                          f"without {', '.join(missing)}; PO needs Sionna's RadioMaterial model")
    omega = float(np.asarray(mat.scene.angular_frequency).ravel()[0])
    eps_r = float(np.asarray(mat.relative_permittivity).ravel()[0])
    sigma = float(np.asarray(mat.conductivity).ravel()[0])
    return Material(str(getattr(mat, "name", "")), complex(eps_r, -sigma / (omega * VACUUM_PERMITTIVITY)),
                    float(np.asarray(mat.thickness).ravel()[0]),
                    float(np.asarray(mat.scattering_coefficient).ravel()[0]))


def complex_reflection(cos_i, eta, thickness, wavelength, k_in, normal, e_t) -> np.ndarray:
    r"""Co-polar complex reflection coefficient :math:`\Gamma = r_{TE}(\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2
    - r_{TM}(1 - (\hat{\mathbf e}_t\cdot\hat{\mathbf s})^2)` (:mod:`sionnafmcw.physical_optics`,
    "Dielectrics"; slab coefficients :func:`~sionnafmcw.electromagnetics.slab_reflection_coefficients`,
    :math:`\hat{\mathbf s} = \hat{\mathbf k}_{in}\times\hat{\mathbf n}` normalised, TE at normal incidence).
    ``cos_i``, ``eta``, ``thickness`` ``[P]``; ``k_in``, ``normal``, ``e_t`` ``[P, 3]``."""
    r_te, r_tm = slab_reflection_coefficients(np.clip(cos_i, 0.0, 1.0), eta, thickness, wavelength)
    s_hat = np.cross(k_in, normal)
    s2 = np.einsum("pi,pi->p", s_hat, s_hat)
    # (e_t . s/|s|)^2 = (e_t . s)^2/|s|^2; normal incidence (|s| <= 1e-9): TE
    te = np.divide(np.einsum("pi,pi->p", e_t, s_hat) ** 2, s2, out=np.ones_like(s2), where=s2 > 1e-18)
    return r_te * te - r_tm * (1.0 - te)


# ---------------------------------------------------------------------------------------- mesh normals
def face_normals(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Unit face normals ``[F, 3]`` (right-handed winding) and face areas ``[F]`` (m^2)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    norm = np.linalg.norm(cross, axis=-1)
    return np.divide(cross, norm[:, None], out=np.zeros_like(cross), where=norm[:, None] > 0), norm / 2


def shading_normals(vertices, faces, crease_angle: float = CREASE_ANGLE):
    """Corner normals ``[F, 3, 3]``: at every corner the area-weighted mean normal of the triangles at
    that vertex within ``crease_angle`` (rad) of the triangle's own normal (module docstring).

    Normals are compared up to sign (a mesh's winding need not be consistent): a neighbour whose
    normal points the other way is flipped before it is averaged.
    """
    n_f, area = face_normals(vertices, faces)
    f = np.asarray(faces, np.int64)
    num_f = len(f)
    corner_face = np.repeat(np.arange(num_f), 3)
    corner_vertex = f.reshape(-1)
    order = np.argsort(corner_vertex, kind="stable")
    vert_sorted = corner_vertex[order]
    face_sorted = corner_face[order]
    starts = np.searchsorted(vert_sorted, vert_sorted, side="left")
    ends = np.searchsorted(vert_sorted, vert_sorted, side="right")
    degree = ends - starts
    # all (corner, neighbour face at the same vertex) pairs
    own = np.repeat(np.arange(len(order)), degree)
    offset = np.arange(len(own)) - np.repeat(np.cumsum(degree) - degree, degree)
    neighbour = face_sorted[starts[own] + offset]
    own_face = face_sorted[own]
    cos = np.einsum("pi,pi->p", n_f[own_face], n_f[neighbour])
    sign = np.where(cos < 0, -1.0, 1.0)
    use = np.abs(cos) >= np.cos(crease_angle)
    weight = np.where(use, area[neighbour], 0.0) * sign
    contribution = weight[:, None] * n_f[neighbour]
    acc = np.stack([np.bincount(own, contribution[:, c], len(order)) for c in range(3)], axis=-1)
    acc_norm = np.linalg.norm(acc, axis=-1)
    smooth = np.where(acc_norm[:, None] > 0, acc / np.maximum(acc_norm, 1e-300)[:, None], n_f[face_sorted])
    out = np.empty((len(order), 3))
    out[order] = smooth
    return out.reshape(num_f, 3, 3)


def curvature_radius(vertices, faces, corner_normals, quantile: float = 0.02) -> float:
    r"""Smallest radius of curvature (m) of a shading-normal field: along every triangle edge
    :math:`\rho = |\mathbf e|/\angle(\hat{\mathbf n}_a, \hat{\mathbf n}_b)`, the ``quantile`` over the
    edges (robust to a few odd corners); ``inf`` where the field is flat."""
    rho = _edge_radii(vertices, faces, corner_normals).T.reshape(-1)   # edge by edge, as the quantile reads them
    finite = rho[np.isfinite(rho)]
    if finite.size < max(1, 0.05 * rho.size):
        return float("inf")
    return float(np.quantile(rho, quantile))


def _edge_radii(vertices, faces, corner_normals) -> np.ndarray:
    r"""Per triangle and edge ``[F, 3]``: :math:`|\mathbf e|/\angle(\hat{\mathbf n}_a, \hat{\mathbf n}_b)` (m; inf where
    the normals agree to 1e-4 rad)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    rho = np.empty((len(f), 3))
    for j, (a, b) in enumerate(((0, 1), (1, 2), (2, 0))):
        length = np.linalg.norm(v[f[:, b]] - v[f[:, a]], axis=-1)
        cos = np.clip(np.einsum("fi,fi->f", corner_normals[:, a], corner_normals[:, b]), -1.0, 1.0)
        angle = np.arccos(cos)
        rho[:, j] = np.where(angle > 1e-4, length / np.maximum(angle, 1e-300), np.inf)
    return rho


def triangle_curvature_radii(vertices, faces, corner_normals) -> np.ndarray:
    """Radius of curvature ``[F]`` (m) of the shading-normal field on every triangle: the smallest of its
    three edges' (:func:`curvature_radius`'s measure); ``inf`` on a triangle where the field is flat."""
    return _edge_radii(vertices, faces, corner_normals).min(axis=1)


def curvature_classes(triangle_radii, radius: float, ratio: float = CURVATURE_CLASS_RATIO,
                      max_classes: int = MAX_CURVATURE_CLASSES) -> tuple[np.ndarray, np.ndarray]:
    r"""The curvature class of every triangle ``[F]`` (0, 1, ...; module docstring) and each class's
    radius ``[C]`` (m): triangle radii ``triangle_radii`` against the object's radius ``radius``
    (:func:`curvature_radius`); class :math:`c` holds the radii in :math:`[\rho_0 r^c, \rho_0 r^{c+1})`
    (class 0 also those below :math:`\rho_0`, the last class all above), its radius is
    :math:`\rho_0 r^c`. Only the classes that hold a triangle are kept, numbered from 0."""
    rho = np.asarray(triangle_radii, float)
    if not np.isfinite(radius) or rho.size == 0:
        return np.zeros(rho.size, dtype=np.int64), np.array([float(radius)])
    with np.errstate(divide="ignore"):
        level = np.floor(np.log(np.maximum(rho, radius) / radius) / np.log(ratio))
    level = np.clip(np.nan_to_num(level, posinf=max_classes - 1), 0, max_classes - 1).astype(np.int64)
    present, cls = np.unique(level, return_inverse=True)
    return cls.reshape(-1).astype(np.int64), radius * ratio ** present.astype(float)


# ---------------------------------------------------------------------------------------- scene description
@dataclass
class SceneObject:
    """One object of the render in the current frame: ``name``, Sionna object id ``shape_id``, its
    ``index`` in the :class:`~.surfaces.SurfaceWorld`, its ``surface`` (own frame: vertices, faces,
    corner normals, curvature radius), its ``placement`` (rotation, translation and velocity field of
    the frame), its ``material`` and ``box_vertices`` (world points that bound it, for its angular
    box: the loaded mesh). ``vertex_doppler`` False: the object's uniform velocity only (no rigid
    rotation field or per-vertex velocities)."""

    name: str
    shape_id: int
    index: int
    surface: object
    placement: object
    material: Material
    box_vertices: np.ndarray
    vertex_doppler: bool = True

    @property
    def curvature_radius(self) -> float:
        return self.surface.curvature_radius

    @property
    def flat_shaded(self) -> bool:
        """True when every face has one normal at its three corners (the room's planes): the
        interpolated normal is then that normal and its shape operator is zero, exactly."""
        return self.surface.flat

    def facet_normals(self, triangle) -> np.ndarray:
        """Unit facet normals ``[K, 3]`` (world, the surface's winding) of the surface triangles ``triangle [K]``."""
        v = self.surface.vertices[self.surface.faces[triangle]]
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        return n @ self.placement.rotation.T

    def hit_geometry(self, triangle, bary):
        r"""Position, shading normal, velocity ``[K, 3]`` (world) and the normal's shape operator
        ``[K, 3, 3]`` (:func:`~sionnafmcw.physical_optics.interpolated_normals`) of hits on triangles
        ``triangle [K]`` at barycentrics ``bary [K, 2]`` of the surface (float64). On a refined surface
        the position and normal are the smooth surface's at the hit's parameters
        (:meth:`~.surfaces.Surface.smooth_points`: on the flat sub-facets the lattice acts as a phase
        grating, 1.2-1.4 dB low on a refined icosphere at the lambda/25 rule, within 0.15 dB on the smooth
        surface, :mod:`sionnafmcw.smooth_surface`); the shape operator is the sub-facet's. Computed in the
        surface's own frame and placed, :math:`\mathbf x = \mathbf R\mathbf x_L + \mathbf p`,
        :math:`\hat{\mathbf n} = \mathbf R\hat{\mathbf n}_L`, :math:`\mathbf K = \mathbf R\mathbf K_L\mathbf R^T`;
        velocity :math:`\mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c)` for a turning
        rigid object, the interpolated vertex velocities of a deforming one, else the uniform one."""
        surface, place = self.surface, self.placement
        rot = place.rotation
        smooth = surface.smooth_points(triangle, bary)
        if smooth is None:
            w = np.stack([1.0 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1]], axis=-1)
            local = interpolate(surface.vertices, surface.faces[triangle], w)
        else:
            local = smooth[0]
        if surface.flat:   # what interpolated_normals gives there, without its arithmetic
            m = surface.corner_normals[triangle, 0]
            normal = m / np.linalg.norm(m, axis=-1)[:, None]
            curvature = np.zeros((len(triangle), 3, 3))
        else:
            normal, curvature = shape_operator(surface.corner_normals[triangle], surface.normal_gradients()[triangle],
                                               bary)
            if smooth is not None:
                normal = smooth[1]
        position = place.to_world(local)
        if not np.array_equal(rot, np.eye(3)):
            normal = normal @ rot.T
            if not surface.flat:   # K = R K_L R^T: rows turned, then columns (two products with the 3x3)
                k = len(triangle)
                turned = (curvature.reshape(-1, 3) @ rot.T).reshape(k, 3, 3).transpose(0, 2, 1)
                curvature = (np.ascontiguousarray(turned).reshape(-1, 3) @ rot.T).reshape(k, 3, 3).transpose(0, 2, 1)
        if self.vertex_doppler and place.vertex_velocity is not None:
            w = np.stack([1.0 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1]], axis=-1)
            velocity = interpolate(place.vertex_velocity, surface.faces[triangle], w)
        elif self.vertex_doppler and place.motion is not None:
            velocity = place.motion.point_velocities(position)
        else:
            velocity = np.broadcast_to(place.velocity, position.shape).copy()
        return position, normal, velocity, curvature

    def hit_acceleration(self, triangle, bary) -> np.ndarray | None:
        """Accelerations ``[K, 3]`` (m/s^2, world) of hits on triangles ``triangle [K]`` at barycentrics
        ``bary [K, 2]``: the placement's per-vertex field interpolated (exact for a rigid motion, whose
        field is affine), else its uniform acceleration; None when the placement has none (no motion
        within the CPI, :class:`~sionnafmcw.engines.surfaces.Placement`)."""
        place = self.placement
        if place.acceleration is None:
            return None
        if self.vertex_doppler and place.vertex_acceleration is not None:
            w = np.stack([1.0 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1]], axis=-1)
            return interpolate(place.vertex_acceleration, self.surface.faces[triangle], w)
        return np.broadcast_to(place.acceleration, (len(triangle), 3)).copy()


def flat_shaded(corner_normals) -> bool:
    """True when every face of ``corner_normals [F, 3, 3]`` has one normal at its three corners."""
    n = np.asarray(corner_normals)
    return bool(np.all(n[:, 1:] == n[:, :1]))


def scene_objects(loaded, world, materials: dict, vertex_doppler: bool = True) -> list[SceneObject]:
    """:class:`SceneObject` of every object of ``world`` (a :class:`~.surfaces.SurfaceWorld` placed in
    the current frame: :meth:`~.surfaces.SurfaceWorld.place`), in its order; ``materials``: name ->
    :class:`Material`; the angular box of each from the loaded mesh of the frame (``loaded.vertices``)."""
    return [SceneObject(name, int(loaded.scene.objects[name].object_id), k, world.surfaces[k], world.placements[k],
                        materials[name], loaded.vertices[name], vertex_doppler)
            for k, name in enumerate(world.names)]


# ---------------------------------------------------------------------------------------- render
@dataclass
class Render:
    """The samples of one bounce of the PO render, and what a further bounce needs.

    ``samples``: :class:`SurfaceSamples` (world; ``labels`` the object names; ``reflection`` the
    material's :math:`\\Gamma` of this bounce, ``scattering_coefficient`` its :math:`S`);
    ``depth``: the bounce (1 = first hit); ``source [P, 3]``: the image of the render's origin
    (the origin itself for ``depth`` 1); ``image_linear [P, 3, 3]``, ``image_offset [P, 3]``: the
    mirror map :math:`M(\\mathbf x) = A\\mathbf x + \\mathbf b` of the previous bounces;
    ``chain_reflection [P]``: the product of the previous bounces' coherent reflection
    coefficients :math:`\\sqrt{1 - S_i^2}\\Gamma_i`; ``direction [P, 3]``: the incident ray;
    ``step_az``, ``step_el`` ``[P, 3]``: its angular steps (mirrored); ``first_point [P, 3]``,
    ``first_velocity [P, 3]``: the first hit of the ray and its velocity; ``second_direction [P, 3]``:
    the ray's direction after the first bounce (None for bounce 1); ``parent [P]``: the index of
    each sample's ray in the previous bounce's samples (None for bounce 1); ``doppler_inner [P]``:
    :math:`\\sum_{i=2}^{d-1}\\mathbf v_i\\cdot(\\hat{\\mathbf k}_{out,i} - \\hat{\\mathbf k}_{in,i})/\\lambda` (Hz);
    ``step [O]``: the angular step of each object's render (rad); ``num_rays``: rays cast. For
    motion within the CPI (rendered with the placements' accelerations, else None):
    ``acceleration [P, 3]`` of the samples and ``source_velocity``, ``source_acceleration`` ``[P, 3]``
    of the image source (:func:`~sionnafmcw.kinematics.mirror_image` through the previous bounces'
    mirrors; the render's origin's on bounce 1). ``one_object [P]``: the Sionna object id of the
    sample's object where every bounce of its chain was on it, else -1; ``outline [P, W, 3]``: the
    convex polygon each sample stands for where it is not its footprint parallelogram (the cut pieces
    of :mod:`~sionnafmcw.engines.flat_faces`), else None.
    """

    samples: SurfaceSamples
    depth: int
    source: np.ndarray
    image_linear: np.ndarray
    image_offset: np.ndarray
    chain_reflection: np.ndarray
    direction: np.ndarray
    step_az: np.ndarray
    step_el: np.ndarray
    first_point: np.ndarray
    first_velocity: np.ndarray
    doppler_inner: np.ndarray
    step: dict = field(default_factory=dict)
    num_rays: int = 0
    second_direction: np.ndarray | None = None
    parent: np.ndarray | None = None
    acceleration: np.ndarray | None = None
    source_velocity: np.ndarray | None = None
    source_acceleration: np.ndarray | None = None
    one_object: np.ndarray | None = None
    outline: np.ndarray | None = None

    @property
    def num_samples(self) -> int:
        return self.samples.num_samples

    def select(self, keep) -> Render:
        """The samples where ``keep`` (``[P]`` bool or indices) holds, with everything a further bounce needs."""
        from dataclasses import replace

        keep = np.asarray(keep)
        if keep.dtype == bool and keep.shape == (self.num_samples,):
            if keep.all():
                return self
            keep = np.flatnonzero(keep)   # one pass over the mask; then each field gathers its rows only

        def pick(x):
            return None if x is None else x[keep]

        return replace(self, samples=self.samples.select(keep), source=pick(self.source),
                       image_linear=pick(self.image_linear), image_offset=pick(self.image_offset),
                       chain_reflection=pick(self.chain_reflection), direction=pick(self.direction),
                       step_az=pick(self.step_az), step_el=pick(self.step_el), first_point=pick(self.first_point),
                       first_velocity=pick(self.first_velocity), doppler_inner=pick(self.doppler_inner),
                       second_direction=pick(self.second_direction), parent=pick(self.parent),
                       acceleration=pick(self.acceleration), source_velocity=pick(self.source_velocity),
                       source_acceleration=pick(self.source_acceleration), one_object=pick(self.one_object),
                       outline=pick(self.outline))

    def image_of(self, points) -> np.ndarray:
        r"""``[M, P, 3]``: the images of ``points [M, 3]`` (the Tx elements) through every sample's mirror map
        :math:`M(\mathbf x) = A\mathbf x + \mathbf b` (the points themselves on bounce 1)."""
        return np.einsum("pij,mj->mpi", self.image_linear, np.atleast_2d(np.asarray(points, float))) \
            + self.image_offset[None]

    def reflected(self) -> tuple[np.ndarray, np.ndarray]:
        r"""The shading normals turned to the incident side, :math:`\hat{\mathbf n}` with
        :math:`\hat{\mathbf n}\cdot\hat{\mathbf k}_{in} \le 0`, and the mirrored rays
        :math:`\hat{\mathbf k}_{out} = \hat{\mathbf k}_{in} - 2(\hat{\mathbf n}\cdot\hat{\mathbf k}_{in})\hat{\mathbf n}`, both ``[P, 3]``."""
        s, k_in = self.samples, self.direction
        n = s.normal * np.where(np.einsum("pi,pi->p", s.normal, k_in) > 0, -1.0, 1.0)[:, None]
        return n, k_in - 2 * np.einsum("pi,pi->p", n, k_in)[:, None] * n

    def directions(self, centre, rotation) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors ``[P, 3]`` in the radar frame (``rotation``: radar -> world) from ``centre`` (the
        array's phase centre) to every sample's first interaction point and to the sample: the
        directions of the chain's first and last segment, which the PO merge keys on
        (:func:`~sionnafmcw.engines.po_merge.merge_cells`)."""
        out = []
        for points in (self.first_point, self.samples.position)[:1 if self.depth == 1 else 2]:
            d = points - np.asarray(centre, float)
            out.append((d / np.linalg.norm(d, axis=1, keepdims=True)) @ np.asarray(rotation, float))
        return out[0], out[-1]   # bounce 1: one array for both (the first point is the sample)

    def carries_po(self, exact_ids=()) -> np.ndarray:
        """``[P]`` bool: the samples with a coherent share, :math:`S < 1` and (from bounce 2 on) a
        non-zero chain reflection, whose chain does not stay on one of the objects ``exact_ids`` (Sionna
        object ids: the objects whose own chains :mod:`~sionnafmcw.engines.flat_faces` integrates); the
        others carry no PO echo."""
        keep = self.samples.scattering_coefficient < 1.0
        if self.depth > 1:
            keep &= np.abs(self.chain_reflection) > 0
        if len(exact_ids) and self.one_object is not None:
            keep &= ~np.isin(self.one_object, np.fromiter(exact_ids, np.int64))
        return keep


def _circular_span(az):
    """Smallest azimuth interval ``(start, width)`` holding every angle of ``az`` (rad)."""
    a = np.sort(np.mod(az, 2 * np.pi))
    if a.size == 1:
        return float(a[0]), 0.0
    gaps = np.diff(np.concatenate([a, [a[0] + 2 * np.pi]]))
    i = int(np.argmax(gaps))
    start = a[(i + 1) % a.size]
    return float(start), float(2 * np.pi - gaps[i])


def object_box(vertices, origin, rotation):
    """Angular bounding box of ``vertices`` seen from ``origin`` in the frame of ``rotation`` (radar frame):
    ``(az_start, az_width, el_low, el_high, r_min, r_max)``. An object that surrounds the origin in
    azimuth (its largest azimuth gap below 90 degrees) gets the full circle and its elevation range
    extended to the pole on its side(s)."""
    d = (np.asarray(vertices, float) - np.asarray(origin, float)) @ rotation
    r = np.linalg.norm(d, axis=-1)
    el = np.arcsin(np.clip(d[:, 2] / np.maximum(r, 1e-300), -1, 1))
    az = np.arctan2(d[:, 1], d[:, 0])
    start, width = _circular_span(az)
    low, high = float(el.min()), float(el.max())
    if width > 1.5 * np.pi:
        start, width = -np.pi, 2 * np.pi
        if low < 0:
            low = -np.pi / 2
        if high > 0:
            high = np.pi / 2
    return start, width, low, high, float(r.min()), float(r.max())


def _grid(start, width, low, high, step, pad=1):
    """Equiangular grid over the box (padded by ``pad`` steps): azimuths, elevations, d_az, d_el."""
    low, high = max(low - pad * step, -np.pi / 2), min(high + pad * step, np.pi / 2)
    el_min_abs = 0.0 if low <= 0 <= high else min(abs(low), abs(high))
    d_az = step / max(np.cos(el_min_abs), 1e-3)
    if width < 2 * np.pi:
        start, width = start - pad * d_az, min(width + 2 * pad * d_az, 2 * np.pi)
    n_az = max(1, int(np.ceil(width / d_az)))
    n_el = max(1, int(np.ceil((high - low) / step)))
    d_az, d_el = width / n_az, (high - low) / n_el
    az = start + (np.arange(n_az) + 0.5) * d_az
    el = low + (np.arange(n_el) + 0.5) * d_el
    return az, el, d_az, d_el


def _reflection(obj_index, objects, normal, k_in, rotation, wavelength):
    """Complex :math:`\\Gamma` and :math:`S` per hit (material of each hit's object)."""
    eta = np.array([o.material.eta for o in objects], dtype=complex)[obj_index]
    thick = np.array([o.material.thickness for o in objects])[obj_index]
    s = np.array([o.material.scattering_coefficient for o in objects])[obj_index]
    cos_i = np.abs(np.einsum("pi,pi->p", normal, k_in))
    e_t = vertical_polarisation(k_in, rotation)
    return complex_reflection(cos_i, eta, thick, wavelength, k_in, normal, e_t), s


def _samples(world, objects, obj_index, triangle, bary, source, step_az, step_el, solid, rotation, wavelength):
    """:class:`SurfaceSamples` of hits (object index per hit into ``objects``, the world's
    :func:`scene_objects`): the geometry of hits on refined static and rigid surfaces in one kernel
    (:func:`~.hit_geometry.refined_hit_geometry`), of the others per object
    (:meth:`SceneObject.hit_geometry`)."""
    from .hit_geometry import refined_hit_geometry

    num = len(obj_index)
    position = np.empty((num, 3))
    normal = np.empty((num, 3))
    velocity = np.empty((num, 3))
    curvature = np.empty((num, 3, 3))
    acceleration = None
    tables = world.refined_tables()
    fast = np.flatnonzero(tables.covers(obj_index))
    if fast.size:
        position[fast], normal[fast], velocity[fast], curvature[fast] = refined_hit_geometry(
            tables, objects, obj_index[fast], triangle[fast], bary[fast])
    slow = np.ones(len(objects), dtype=bool)
    slow[tables.offset >= 0] = False
    for k in np.flatnonzero(slow):
        sel = np.flatnonzero(obj_index == k)
        if sel.size:
            position[sel], normal[sel], velocity[sel], curvature[sel] = objects[k].hit_geometry(triangle[sel], bary[sel])
    if num and all(objects[k].surface.flat for k in np.unique(obj_index)):
        curvature = np.broadcast_to(np.zeros((3, 3)), (num, 3, 3))   # K = 0 on every hit: no [P, 3, 3] of zeros
    if any(obj.placement.acceleration is not None for obj in objects):
        for k in np.unique(obj_index):
            sel = np.flatnonzero(obj_index == k)
            acc = objects[k].hit_acceleration(triangle[sel], bary[sel])
            if acc is not None:
                if acceleration is None:
                    acceleration = np.zeros((num, 3))
                acceleration[sel] = acc
    # the sample's distance along the ray from the (image) source, float64 from the triangle point
    distance = np.linalg.norm(position - source, axis=-1)
    direction = unit(position - source)
    cos = np.abs(np.einsum("pi,pi->p", normal, direction))
    area = np.divide(distance ** 2 * solid, cos, out=np.zeros(num), where=cos > 1e-6)
    edges = footprint_edges(position, normal, source, step_az, step_el)
    gamma, s = _reflection(obj_index, objects, normal, direction, rotation, wavelength)
    names = np.array([o.name for o in objects], dtype=str)
    return SurfaceSamples(position, normal, area, edges=edges, velocity=velocity, reflection=gamma,
                          scattering_coefficient=s, object_id=np.array([o.shape_id for o in objects])[obj_index],
                          triangle=triangle, barycentric=bary, labels=names[obj_index], curvature=curvature), \
        direction, acceleration


def _clip_box(start, width, low, high, half_az, half_el):
    """The part of an angular box (:func:`object_box`) within the field of view ``|az| <= half_az``,
    ``|el| <= half_el`` (rad, ``half_az <= pi/2``), as ``(start, width, low, high)``, or None."""
    a0 = float(np.mod(start + np.pi, 2 * np.pi) - np.pi)
    pieces = [(a0, a0 + width)] if a0 + width <= np.pi else [(a0, np.pi), (-np.pi, a0 + width - 2 * np.pi)]
    parts = [(max(lo, -half_az), min(hi, half_az)) for lo, hi in pieces if min(hi, half_az) > max(lo, -half_az)]
    low, high = max(low, -half_el), min(high, half_el)
    if not parts or high <= low:
        return None
    lo, hi = min(p[0] for p in parts), max(p[1] for p in parts)
    return lo, hi - lo, low, high


def render(world, objects: list[SceneObject], origin, rotation, wavelength: float, *, targets=None,
           group: str = "all", samples_across: int = 16, max_rays_per_object: int = MAX_RAYS_PER_OBJECT,
           step_scale: float = 1.0, field_of_view=None, origin_velocity=None, origin_acceleration=None) -> Render:
    r"""First-bounce PO render from ``origin`` (world, m) of the ``targets`` (indices into ``objects``,
    default all) of a :class:`~.surfaces.SurfaceWorld` placed in the frame; ``objects`` are the
    world's :func:`scene_objects`, in its order.

    ``rotation`` (3x3, radar frame -> world) orients the azimuth/elevation grids and the element
    polarisation (vertical) used for :math:`\Gamma`. Each object's angular step is
    :func:`~sionnafmcw.physical_optics.render_resolution` (extent = the bounding-box diagonal,
    distance = its largest range, curvature = its surface's curvature radius, ``samples_across``)
    times ``step_scale`` (for convergence checks). All the targets' rays are cast at once over the
    surfaces of ``group`` (:meth:`~.surfaces.SurfaceWorld.cast`); a ray keeps its hit only where the
    nearest hit is on the object it was cast for. Raises :class:`RenderError` naming the object when
    its render would cast more than ``max_rays_per_object`` rays. ``field_of_view`` ``(half_az,
    half_el)`` (rad, radar frame) keeps each object's box within it (the pixel engine's camera).
    ``origin_velocity``, ``origin_acceleration`` (m/s, m/s^2, world; zero when None): the origin's
    motion, the image source's start when the placements carry accelerations (:class:`Render`).
    """
    origin = np.asarray(origin, float)
    rotation = np.asarray(rotation, float)
    targets = range(len(objects)) if targets is None else targets
    # every object's grid as 1-D elevations and azimuths; a ray is (object, elevation, azimuth) indices
    # into them, its direction built from their sines and cosines (no per-ray trigonometry)
    els, azs, owner, el_index, az_index, cells = [], [], [], [], [], []
    n_el_total = n_az_total = 0
    steps = {}
    ray_class, split = [], []
    for k in targets:
        obj = objects[k]
        extent = float(np.linalg.norm(obj.box_vertices.max(axis=0) - obj.box_vertices.min(axis=0)))
        triangle_class, radii, class_vertices = obj.surface.curvature_classes()
        if len(radii) > 1:
            split.append(k)
        for c, radius in enumerate(radii):   # one grid per curvature class (module docstring)
            box_vertices = obj.box_vertices if len(radii) == 1 else \
                obj.placement.to_world(obj.surface.vertices[class_vertices[c]])
            start, width, low, high, r_min, r_max = object_box(box_vertices, origin, rotation)
            if r_min <= 0:
                raise RenderError(f"po_render: the render origin lies on object {obj.name!r}")
            if obj.surface.bulge > 0 and width < 2 * np.pi:   # the smooth surface reaches beyond the stored facets
                pad = float(np.arcsin(min(1.0, obj.surface.bulge / r_min)))
                pad_az = pad / max(np.cos(max(abs(low), abs(high))), 1e-3)
                start, width = start - pad_az, min(width + 2 * pad_az, 2 * np.pi)
                low, high = max(low - pad, -np.pi / 2), min(high + pad, np.pi / 2)
            if field_of_view is not None:
                box = _clip_box(start, width, low, high, *field_of_view)
                if box is None:
                    continue
                start, width, low, high = box
            step = render_resolution(extent, r_max, wavelength, curvature_radius=radius,
                                     samples_across=samples_across) * float(step_scale)
            if c == 0:
                steps[obj.name] = step
            az, el, d_az, d_el = _grid(start, width, low, high, step)
            n = az.size * el.size
            if n > max_rays_per_object:
                raise RenderError(
                    f"po_render: object {obj.name!r} ({extent:.2f} m, {r_min:.2f}-{r_max:.2f} m away) needs {n} rays "
                    f"at {step * 1e3:.2f} mrad, more than max_rays_per_object={max_rays_per_object}; lower "
                    f"samples_across ({samples_across}) or raise max_rays_per_object")
            ei, ai = np.divmod(np.arange(n, dtype=np.int64), az.size)      # row-major: elevation, then azimuth
            els.append(el)
            azs.append(az)
            el_index.append(ei + n_el_total)
            az_index.append(ai + n_az_total)
            n_el_total += el.size
            n_az_total += az.size
            owner.append(np.full(n, k, dtype=np.int64))
            ray_class.append(np.full(n, c, dtype=np.int64))
            cells.append(np.array([d_az, d_el]))
    num_rays = int(sum(o.size for o in owner))
    if not num_rays:
        return _empty_render(origin, steps, 0)
    el, az = np.concatenate(els), np.concatenate(azs)
    ce, se, ca, sa = np.cos(el), np.sin(el), np.cos(az), np.sin(az)
    ei, ai = np.concatenate(el_index), np.concatenate(az_index)
    cell = np.repeat(np.stack(cells), [o.size for o in owner], axis=0)
    owner = np.concatenate(owner)
    local = np.stack([ce[ei] * ca[ai], ce[ei] * sa[ai], se[ei]], -1)
    valid, _, hit_obj, prim, uv = world.cast(origin, local @ rotation.T, group)
    hits = valid & (hit_obj == owner)   # objects are in the world's order
    if split:                           # and, on an object of several classes, on a triangle of the ray's class
        ray_class = np.concatenate(ray_class)
        for k in split:
            rows = np.flatnonzero(hits & (owner == k))
            hits[rows] = objects[k].surface.curvature_classes()[0][prim[rows]] == ray_class[rows]
    keep = np.flatnonzero(hits)
    if keep.size == 0:
        return _empty_render(origin, steps, num_rays)
    d_az, d_el = cell[keep, 0], cell[keep, 1]
    c_e, s_e, c_a, s_a = ce[ei[keep]], se[ei[keep]], ca[ai[keep]], sa[ai[keep]]
    solid = d_az * 2.0 * c_e * np.sin(d_el / 2)          # d_az (sin(el + d_el/2) - sin(el - d_el/2))
    # angular_grid_steps of the kept rays, from their grid angles
    s_az = (np.stack([-c_e * s_a, c_e * c_a, np.zeros_like(c_e)], -1) * d_az[:, None]) @ rotation.T
    s_el = (np.stack([-s_e * c_a, -s_e * s_a, c_e], -1) * d_el[:, None]) @ rotation.T
    samples, direction, acceleration = _samples(world, objects, owner[keep], prim[keep], uv[keep], origin, s_az, s_el, solid,
                                                rotation, wavelength)
    return first_bounce(samples, direction, s_az, s_el, origin, steps, num_rays, acceleration,
                        None if acceleration is None else (origin_velocity, origin_acceleration))


def first_bounce(samples, direction, step_az, step_el, origin, steps, num_rays, acceleration=None,
                 origin_motion=None) -> Render:
    """The :class:`Render` of bounce 1 of ``samples`` seen from ``origin``: the source is the origin, the
    image map the identity, the chain empty, the first point the sample itself (read-only broadcasts and
    the samples' own arrays, no per-sample copies); with ``acceleration`` ``[P, 3]``, ``origin_motion``
    ``(velocity, acceleration)`` of the origin (None entries: zero)."""
    p = samples.num_samples
    out = Render(samples, 1, np.broadcast_to(origin, (p, 3)), np.broadcast_to(np.eye(3), (p, 3, 3)),
                 np.broadcast_to(np.zeros(3), (p, 3)), np.broadcast_to(np.complex128(1.0), (p,)),
                 direction, step_az, step_el, samples.position, samples.velocity, np.broadcast_to(0.0, (p,)), steps,
                 num_rays, one_object=samples.object_id)
    if acceleration is not None:
        velocity, accel = (None, None) if origin_motion is None else origin_motion
        out.acceleration = acceleration
        out.source_velocity = np.broadcast_to(np.zeros(3) if velocity is None else velocity, (p, 3)).astype(float)
        out.source_acceleration = np.broadcast_to(np.zeros(3) if accel is None else accel, (p, 3)).astype(float)
    return out


def join_renders(a: Render, b: Render, parent_offset: int = 0) -> Render:
    """The renders ``a`` and ``b`` of one bounce (depth 2 or more) as one: ``a``'s samples, then ``b``'s, whose
    ``parent`` indices are moved by ``parent_offset`` (the previous bounce joined the same way)."""
    from dataclasses import fields, replace

    kw = {}
    for f in fields(Render):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "samples":
            kw[f.name] = SurfaceSamples(**{n: None if getattr(x, n) is None or getattr(y, n) is None else
                                           np.concatenate([getattr(x, n), getattr(y, n)])
                                           for n in x.__dataclass_fields__})
        elif f.name == "parent":
            kw[f.name] = np.concatenate([x, y + parent_offset])
        elif isinstance(x, np.ndarray) and isinstance(y, np.ndarray):
            kw[f.name] = np.concatenate([x, y])
        elif f.name == "num_rays":
            kw[f.name] = x + y
    return replace(a, **kw)


def join_first_bounces(a: Render, b: Render) -> Render:
    """The bounce-1 renders ``a`` and ``b`` (the same origin) as one: ``a``'s samples, then ``b``'s."""
    sa, sb = a.samples, b.samples
    kw = {}
    for name in sa.__dataclass_fields__:
        x, y = getattr(sa, name), getattr(sb, name)
        kw[name] = None if x is None or y is None else np.concatenate([x, y])
    acceleration = None if a.acceleration is None else np.concatenate([a.acceleration, b.acceleration])
    either = a if a.num_samples else b
    motion = None if a.acceleration is None else (either.source_velocity[0], either.source_acceleration[0])
    origin = a.source[0] if a.num_samples else b.source[0]
    return first_bounce(SurfaceSamples(**kw), np.concatenate([a.direction, b.direction]),
                        np.concatenate([a.step_az, b.step_az]), np.concatenate([a.step_el, b.step_el]), origin,
                        a.step, a.num_rays + b.num_rays, acceleration, motion)


def _empty_render(origin, steps, num_rays, depth=1) -> Render:
    z3 = np.zeros((0, 3))
    samples = SurfaceSamples(z3, z3, np.zeros(0), edges=np.zeros((0, 2, 3)), labels=np.zeros(0, dtype=str))
    return Render(samples, depth, z3, np.zeros((0, 3, 3)), z3, np.zeros(0, complex), z3, z3, z3, z3, z3,
                  np.zeros(0), steps, num_rays, None if depth == 1 else z3, None if depth == 1 else np.zeros(0, np.int64),
                  one_object=np.zeros(0, np.int64))


def reflect(world, previous: Render, objects: list[SceneObject], rotation, wavelength: float,
            group: str = "all") -> Render:
    """The next bounce of ``previous``: every sample's ray reflected about its shading normal and cast
    again over the surfaces of ``group`` (:meth:`~.surfaces.SurfaceWorld.cast`; ``objects`` the
    world's :func:`scene_objects`); the hits become the samples of bounce ``previous.depth + 1`` with
    the image map, chain reflection and mirrored steps of the module docstring."""
    s = previous.samples
    if s.num_samples == 0:
        return _empty_render(np.zeros(3), previous.step, 0, previous.depth + 1)
    k_in = previous.direction
    n, k_out = previous.reflected()
    # start a hair off the surface along the outgoing ray (float32 scene)
    eps = 1e-5 * (1.0 + np.linalg.norm(s.position, axis=-1))
    valid, t, hit_obj, prim, uv = world.cast(s.position + eps[:, None] * k_out, k_out, group)
    idx = np.flatnonzero(valid)
    if idx.size == 0:
        return _empty_render(np.zeros(3), previous.step, int(valid.size), previous.depth + 1)
    # mirror map of this bounce: x -> (I - 2 n n^T) x + 2 n (n . p), applied as v - 2 n (n . v)
    normal = n[idx]

    def mirrored(v):
        return v - 2.0 * normal * np.einsum("pi,pi->p", normal, v)[:, None]

    reflect_off = 2 * normal * np.einsum("pi,pi->p", normal, s.position[idx])[:, None]
    if previous.depth == 1:   # the previous map is the identity
        lin, off = np.eye(3)[None] - 2 * normal[:, :, None] * normal[:, None, :], reflect_off
    else:
        before = previous.image_linear[idx]
        lin = before - 2.0 * normal[:, :, None] * np.einsum("pi,pij->pj", normal, before)[:, None, :]
        off = mirrored(previous.image_offset[idx]) + reflect_off
    source = mirrored(previous.source[idx]) + reflect_off
    s_az = mirrored(previous.step_az[idx])
    s_el = mirrored(previous.step_el[idx])
    # the tube's solid angle: |step_az x step_el| (exact for the grid's pixels to first order)
    solid = np.linalg.norm(np.cross(previous.step_az[idx], previous.step_el[idx]), axis=-1)
    samples, direction, acceleration = _samples(world, objects, hit_obj[idx], prim[idx], uv[idx], source, s_az, s_el, solid,
                                                rotation, wavelength)
    chain = previous.chain_reflection[idx] * np.sqrt(np.clip(1 - s.scattering_coefficient[idx] ** 2, 0, 1)) \
        * s.reflection[idx]
    inner = previous.doppler_inner[idx]
    if previous.depth >= 2:
        inner = inner + np.einsum("pi,pi->p", s.velocity[idx], k_out[idx] - k_in[idx]) / wavelength
    second = k_out[idx] if previous.depth == 1 else previous.second_direction[idx]
    out = Render(samples, previous.depth + 1, source, lin, off, chain, direction, s_az, s_el,
                 previous.first_point[idx], previous.first_velocity[idx], inner, previous.step, int(valid.size),
                 second, idx)
    if previous.one_object is not None:
        out.one_object = np.where(previous.one_object[idx] == samples.object_id, samples.object_id, -1)
    if previous.acceleration is not None:
        out.acceleration = np.zeros((idx.size, 3)) if acceleration is None else acceleration
        out.source_velocity, out.source_acceleration = _image_motion(previous, idx, n[idx], objects)
    return out


def _image_motion(previous: Render, idx, normal, objects):
    """Velocity and acceleration ``[K, 3]`` of the image source after the mirrors at ``previous``'s samples
    ``idx`` (normals ``normal``, the mirrors' turn from their objects' placements):
    :func:`~sionnafmcw.kinematics.mirror_image` of the previous image source."""
    from ..kinematics import PointKinematics, mirror_image

    s = previous.samples
    omega = np.zeros((idx.size, 3))
    alpha = np.zeros((idx.size, 3))
    ids = s.object_id[idx]
    for obj in objects:
        place = obj.placement
        if place.angular_velocity is None:
            continue
        sel = ids == obj.shape_id
        if np.any(sel):
            omega[sel], alpha[sel] = place.angular_velocity, place.angular_acceleration
    image = mirror_image(PointKinematics(previous.source[idx], previous.source_velocity[idx],
                                         previous.source_acceleration[idx]),
                         PointKinematics(s.position[idx], s.velocity[idx], previous.acceleration[idx]),
                         normal, omega, alpha)
    return image.velocity, image.acceleration


# ---------------------------------------------------------------------------------------- PO of a bounce
def chain_po_gains(bounce: Render, tx_positions, rx_positions, wavelength: float, tx_gain=None, rx_gain=None,
                   in_sample_phase: bool = True):
    r"""PO contributions ``(a, tau, doppler)`` ``[M, N, P]`` of the samples of one bounce.

    Bounce 1 is :func:`~sionnafmcw.physical_optics.po_gains` exactly. From bounce 2 on, Tx element
    :math:`m` is replaced by its image :math:`M(\mathbf t_m)` (module docstring): with
    :math:`r_t = \|\mathbf p - M(\mathbf t_m)\|`, :math:`\hat{\mathbf u}_t` towards the image and
    :math:`\hat{\mathbf n}` turned to the incident side,

    .. math::
        a_{mn} = \frac{j\,\Gamma_{chain}\sqrt{1 - S^2}\,\Gamma}{4\pi}\sqrt{G_tG_r}\,
                 \frac{\hat{\mathbf n}\cdot(\hat{\mathbf u}_t + \hat{\mathbf u}_r)}{2}\,
                 \frac{\Delta A\,F_{mn}}{r_t r_r},\qquad \tau_{mn} = \frac{r_t + r_r}{c},

    Doppler :math:`[\mathbf v_1\cdot(\hat{\mathbf k}_{out,1} - \hat{\mathbf k}^m_{in,1}) + \sum_{i=2}^{d-1}\dots
    + \mathbf v_d\cdot(\hat{\mathbf k}^n_{out,d} - \hat{\mathbf k}_{in,d})]/\lambda`, element gains
    ``tx_gain [M, P]`` towards the first hit, ``rx_gain [N, P]`` from the last.
    """
    from ..physical_optics import po_gains

    s = bounce.samples
    tx = np.atleast_2d(np.asarray(tx_positions, float))
    rx = np.atleast_2d(np.asarray(rx_positions, float))
    if bounce.depth == 1:
        return po_gains(s, tx, rx, wavelength, tx_gain, rx_gain, in_sample_phase)
    m, n, p = tx.shape[0], rx.shape[0], s.num_samples
    images = bounce.image_of(tx)                                                             # [M, P, 3]
    d_t = s.position[None] - images
    r_t = np.linalg.norm(d_t, axis=-1)
    s_t = d_t / r_t[..., None]                                   # image -> sample
    d_r = s.position[None] - rx[:, None]
    r_r = np.linalg.norm(d_r, axis=-1)
    s_r = d_r / r_r[..., None]                                   # Rx element -> sample
    side = np.where(np.einsum("pi,pi->p", s.normal, bounce.direction) > 0, -1.0, 1.0)
    normal = s.normal * side[:, None]
    cos_t = -np.einsum("pi,mpi->mp", normal, s_t)
    cos_r = -np.einsum("pi,npi->np", normal, s_r)
    obliquity = np.clip((cos_t[:, None] + cos_r[None]) / 2, 0.0, None)
    gamma = bounce.chain_reflection * np.sqrt(np.clip(1 - s.scattering_coefficient ** 2, 0, 1)) * s.reflection
    k = 2 * np.pi / wavelength
    footprint = 1.0
    if in_sample_phase and s.edges is not None:
        curvature = None if s.curvature is None else s.curvature * side[:, None, None]
        footprint = in_sample_factor(k, s.edges, s_t, r_t, cos_t, s_r, r_r, cos_r, curvature)
    g_t = np.ones((m, p)) if tx_gain is None else np.asarray(tx_gain, float)
    g_r = np.ones((n, p)) if rx_gain is None else np.asarray(rx_gain, float)
    a = (1j * gamma / (4 * np.pi)) * np.sqrt(g_t[:, None] * g_r[None]) * obliquity * s.area * footprint / (
        r_t[:, None] * r_r[None])
    tau = (r_t[:, None] + r_r[None]) / SPEED_OF_LIGHT
    # Doppler: first bounce per Tx element (real element -> first point), last bounce per Rx element
    d_1 = bounce.first_point[None] - tx[:, None]
    k_in_1 = d_1 / np.linalg.norm(d_1, axis=-1, keepdims=True)                       # [M, P, 3]
    k_out_1 = bounce.second_direction                                               # [P, 3]
    f1 = np.einsum("pi,mpi->mp", bounce.first_velocity, k_out_1[None] - k_in_1) / wavelength
    k_out_d = -s_r                                                                   # sample -> Rx element
    fd = np.einsum("pi,npi->np", s.velocity, k_out_d - bounce.direction[None]) / wavelength
    doppler = f1[:, None] + bounce.doppler_inner[None, None] + fd[None]
    return a, tau, doppler


__all__ = ["CREASE_ANGLE", "CURVATURE_CLASS_RATIO", "MAX_CURVATURE_CLASSES", "MAX_RAYS_PER_OBJECT", "Material",
           "Render", "RenderError", "SceneObject", "chain_po_gains", "complex_reflection", "curvature_classes",
           "curvature_radius", "face_normals", "first_bounce", "flat_shaded", "join_first_bounces", "join_renders",
           "object_box", "radio_material", "reflect", "render", "scene_objects", "shading_normals",
           "triangle_curvature_radii"]
