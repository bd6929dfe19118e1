r"""The physical-optics render shared by the engines: the lit surface as :class:`SurfaceSamples`.

From a point :math:`\mathbf c` (the array's phase centre, or the centre of the Tx elements),
every object of a :class:`~sionnafmcw.engines.loaded_scene.LoadedScene` is rendered on its own
equiangular azimuth/elevation grid (radar frame) covering its angular bounding box, with the
angular step of :func:`sionnafmcw.physical_optics.render_resolution` for its size, its largest
range and its smallest radius of curvature. Rays are cast with Mitsuba's
``ray_intersect_preliminary`` on the Sionna scene (through :mod:`sionnafmcw.sionna_rt`); a ray
is kept where its *first* hit is on the object it was cast for, so visibility from the radar
comes with the cast. Every kept hit is one :class:`~sionnafmcw.physical_optics.SurfaceSamples`
sample: position (from the triangle and barycentrics, float64), shading normal, area and
footprint edges (:func:`~sionnafmcw.physical_optics.render_samples`), velocity (per-vertex field
interpolated, else the object's velocity), the material's complex reflection coefficient and
scattering coefficient, and object / triangle / barycentrics for
:mod:`sionnafmcw.diffuse`'s random phases. :func:`render` returns them as a :class:`Render`.

Shading normals
---------------
The scenes' PLY meshes carry no vertex normals (``face_normals`` is on), so a faceted sphere or
limb would be rendered as its flat facets, whose PO is a set of glints that depend on the
tessellation. :func:`shading_normals` smooths across edges whose dihedral angle is below
``crease_angle`` (default 30 degrees): every triangle corner gets the area-weighted mean of the
normals of the triangles at that vertex that lie within the crease angle of its own, and a hit
gets the barycentric interpolation of its triangle's corner normals. A flat plate (any
tessellation) keeps its plane normal, a box or a trihedral its face normals (90 degree
creases), a sphere or a body a smooth normal field. :func:`curvature_radius` reads the
smallest radius of curvature of that field (edge length over the angle between the corner
normals along it) for the resolution rule, and every sample carries the field's shape operator
:math:`\partial\hat{\mathbf n}/\partial\mathbf x` at its hit
(:func:`~sionnafmcw.physical_optics.interpolated_normals`) for the second-order in-sample phase.

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

Limits: from the second bounce on the samples are spaced by the first object's angular step at
the unfolded length (coarser than the resolution rule wants for a far second surface), and the
return to the receive elements is not checked for blocking.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import SPEED_OF_LIGHT, VACUUM_PERMITTIVITY
from ..electromagnetics import slab_reflection_coefficients, unit, vertical_polarisation
from ..physical_optics import (
    PhysicalOpticsError, SurfaceSamples, angular_grid_steps, footprint_edges, in_sample_factor, interpolated_normals,
    render_resolution,
)
from .loaded_scene import interpolate

#: Default crease angle (rad) of :func:`shading_normals`: smooth below, sharp edge above.
CREASE_ANGLE = float(np.deg2rad(30.0))
#: Most rays one object's render may cast (a guard against a resolution that would exhaust memory).
MAX_RAYS_PER_OBJECT = 4_000_000


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
    s_norm = np.linalg.norm(s_hat, axis=-1)
    te = np.ones_like(s_norm)
    ok = s_norm > 1e-9
    te[ok] = np.einsum("pi,pi->p", e_t[ok], s_hat[ok] / s_norm[ok, None]) ** 2
    return r_te * te - r_tm * (1.0 - te)


# ---------------------------------------------------------------------------------------- mesh normals
def face_normals(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Unit face normals ``[F, 3]`` (right-handed winding) and face areas ``[F]`` (m^2)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    norm = np.linalg.norm(cross, axis=-1)
    return np.divide(cross, norm[:, None], out=np.zeros_like(cross), where=norm[:, None] > 0), norm / 2


def shading_normals(vertices, faces, crease_angle: float = CREASE_ANGLE) -> np.ndarray:
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
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    rho = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        length = np.linalg.norm(v[f[:, b]] - v[f[:, a]], axis=-1)
        cos = np.clip(np.einsum("fi,fi->f", corner_normals[:, a], corner_normals[:, b]), -1.0, 1.0)
        angle = np.arccos(cos)
        rho.append(np.where(angle > 1e-4, length / np.maximum(angle, 1e-300), np.inf))
    rho = np.concatenate(rho)
    finite = rho[np.isfinite(rho)]
    if finite.size < max(1, 0.05 * rho.size):
        return float("inf")
    return float(np.quantile(rho, quantile))


# ---------------------------------------------------------------------------------------- scene description
@dataclass
class SceneObject:
    """One object of the render: name, Mitsuba shape id (int), faces, world vertices, corner normals
    ``[F, 3, 3]``, per-vertex velocity ``[V, 3]`` or None, rigid velocity ``[3]`` and material.
    ``normal_rotation`` (3x3 or None): the corner normals are those of a reference mesh that this
    one is a rigid motion of, still to be turned by it (:meth:`turned`: only the normals of hits).
    ``flat``: :attr:`flat_shaded` of these corner normals when already known (None: worked out on
    first use)."""

    name: str
    shape_id: int
    faces: np.ndarray
    vertices: np.ndarray
    corner_normals: np.ndarray
    vertex_velocity: np.ndarray | None
    velocity: np.ndarray
    material: Material
    curvature_radius: float
    normal_rotation: np.ndarray | None = None
    flat: bool | None = None

    def turned(self, normals) -> np.ndarray:
        """Normals ``[..., 3]`` of :attr:`corner_normals` (corners or interpolated), turned by
        ``normal_rotation`` (a rotation commutes with the interpolation and keeps unit length)."""
        return normals if self.normal_rotation is None else normals @ self.normal_rotation.T

    @property
    def flat_shaded(self) -> bool:
        """True when every face has one normal at its three corners (the room's planes): the
        interpolated normal is then that normal and its shape operator is zero, exactly."""
        if self.flat is None:
            self.flat = flat_shaded(self.corner_normals)
        return self.flat


def flat_shaded(corner_normals) -> bool:
    """True when every face of ``corner_normals [F, 3, 3]`` has one normal at its three corners."""
    n = np.asarray(corner_normals)
    return bool(np.all(n[:, 1:] == n[:, :1]))


#: Largest vertex residual (m) of a rigid fit for :func:`rigid_motion` to call a mesh rigidly moved
#: (PLY vertices are float32: about 1e-7 m of rounding at a few metres).
RIGID_TOLERANCE = 1e-5
#: Cache key tag of an object's reference mesh in :func:`scene_objects` (no object name equals it).
_REFERENCE = object()


def rigid_motion(old_vertices, old_faces, vertices, faces, tolerance: float = RIGID_TOLERANCE):
    r"""The rotation :math:`\mathbf R` with ``vertices`` :math:`= \mathbf R\,\mathbf x + \mathbf t` for every
    vertex :math:`\mathbf x` of ``old_vertices`` (same faces), or None when the mesh changed otherwise.

    Kabsch's least-squares fit: with the centred vertex sets :math:`A` (old) and :math:`B` (new)
    and the SVD :math:`A^TB = U\Sigma V^T`, :math:`\mathbf R = V\,\mathrm{diag}(1, 1, d)\,U^T`,
    :math:`d = \mathrm{sign}\det(VU^T)`; accepted when no vertex is off by more than ``tolerance``.
    Shading normals and curvature radii are invariant under the motion: the normals turn with
    :math:`\mathbf R`, the radii stay (the rigid segments of the walking body, a new PLY each frame).
    """
    if old_vertices.shape != vertices.shape or old_faces.shape != faces.shape or not np.array_equal(old_faces, faces):
        return None
    c_old, c_new = old_vertices.mean(axis=0), vertices.mean(axis=0)
    a, b = old_vertices - c_old, vertices - c_new
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    if np.max(np.abs(a @ rotation.T - b)) > tolerance:
        return None
    return rotation


def scene_objects(loaded, velocities: dict, materials: dict, crease_angle: float = CREASE_ANGLE,
                  vertex_doppler: bool = True, cache: dict | None = None, reference=None) -> list[SceneObject]:
    """:class:`SceneObject` of every object of a :class:`~sionnafmcw.engines.loaded_scene.LoadedScene`
    in its current frame. ``velocities``: name -> rigid velocity (m/s, used where the mesh has no
    per-vertex field or ``vertex_doppler`` is off); ``materials``: name -> :class:`Material`.
    ``cache`` (a dict the caller keeps) reuses normals and curvature of meshes whose PLY (file,
    mtime, transform: ``loaded.loaded_files``) did not change. ``reference`` (name -> ``(vertices,
    faces)`` of a fixed frame, e.g. frame 0, world frame): a mesh that is that reference moved
    rigidly (:func:`rigid_motion`: the segments of the walking body, a new PLY every frame) gets
    the reference's normals turned, computed once; the result depends on the frame only, not on
    the frames simulated before it (a resumed run gives the same echoes). The cache also keeps
    whether the normals are :func:`flat_shaded`."""
    out = []
    for name, obj in loaded.scene.objects.items():
        faces, vertices = loaded.faces[name], loaded.vertices[name]
        key = (name, loaded.loaded_files.get(name))   # changes whenever the mesh is rewritten
        turn = None
        if cache is not None and key in cache:
            normals, rho, turn, flat = cache[key]
        else:
            moved, ref = None, None
            if cache is not None and reference is not None:
                ref = cache.get((_REFERENCE, name))
                if ref is None:
                    v_ref, f_ref = reference(name)
                    v_ref, f_ref = np.asarray(v_ref, float), np.asarray(f_ref)
                    n_ref = shading_normals(v_ref, f_ref, crease_angle)
                    ref = cache[(_REFERENCE, name)] = (n_ref, curvature_radius(v_ref, f_ref, n_ref), v_ref, f_ref,
                                                       flat_shaded(n_ref))
                moved = rigid_motion(ref[2], ref[3], vertices, faces)
            if moved is not None:  # the reference mesh moved rigidly (a body segment): its normals, to be turned
                normals, rho, turn, flat = ref[0], ref[1], moved, ref[4]
            else:
                normals = shading_normals(vertices, faces, crease_angle)
                rho = curvature_radius(vertices, faces, normals)
                flat = flat_shaded(normals)
            if cache is not None:
                for old in [k for k in cache if k[0] == name]:
                    del cache[old]
                cache[key] = (normals, rho, turn, flat)
        field_v = loaded.vertex_velocity.get(name) if vertex_doppler else None
        v = np.asarray(velocities.get(name, np.zeros(3)), float)
        out.append(SceneObject(name, int(obj.object_id), faces, vertices, normals, field_v, v, materials[name], rho,
                               turn, flat))
    return out


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
    ``step [O]``: the angular step of each object's render (rad); ``num_rays``: rays cast.
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

    @property
    def num_samples(self) -> int:
        return self.samples.num_samples

    def select(self, keep) -> Render:
        """The samples where ``keep`` (``[P]`` bool or indices) holds, with everything a further bounce needs."""
        from dataclasses import replace

        keep = np.asarray(keep)
        if keep.dtype == bool and keep.shape == (self.num_samples,) and keep.all():
            return self

        def pick(x):
            return None if x is None else x[keep]

        return replace(self, samples=self.samples.select(keep), source=pick(self.source),
                       image_linear=pick(self.image_linear), image_offset=pick(self.image_offset),
                       chain_reflection=pick(self.chain_reflection), direction=pick(self.direction),
                       step_az=pick(self.step_az), step_el=pick(self.step_el), first_point=pick(self.first_point),
                       first_velocity=pick(self.first_velocity), doppler_inner=pick(self.doppler_inner),
                       second_direction=pick(self.second_direction), parent=pick(self.parent))

    def reflected(self) -> tuple[np.ndarray, np.ndarray]:
        r"""The shading normals turned to the incident side, :math:`\hat{\mathbf n}` with
        :math:`\hat{\mathbf n}\cdot\hat{\mathbf k}_{in} \le 0`, and the mirrored rays
        :math:`\hat{\mathbf k}_{out} = \hat{\mathbf k}_{in} - 2(\hat{\mathbf n}\cdot\hat{\mathbf k}_{in})\hat{\mathbf n}`, both ``[P, 3]``."""
        s, k_in = self.samples, self.direction
        n = s.normal * np.where(np.einsum("pi,pi->p", s.normal, k_in) > 0, -1.0, 1.0)[:, None]
        return n, k_in - 2 * np.einsum("pi,pi->p", n, k_in)[:, None] * n

    def carries_po(self) -> np.ndarray:
        """``[P]`` bool: the samples with a coherent share, :math:`S < 1` and (from bounce 2 on) a
        non-zero chain reflection; the others carry no PO echo."""
        keep = self.samples.scattering_coefficient < 1.0
        if self.depth > 1:
            keep &= np.abs(self.chain_reflection) > 0
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


def _hit_geometry(obj: SceneObject, triangle, bary):
    """Position, shading normal, velocity ``[K, 3]`` and the normal's shape operator ``[K, 3, 3]``
    (:func:`~sionnafmcw.physical_optics.interpolated_normals`) of hits on ``obj`` (float64)."""
    tri = obj.faces[triangle]
    w = np.stack([1.0 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1]], axis=-1)
    position = interpolate(obj.vertices, tri, w)
    if obj.flat_shaded:   # what interpolated_normals gives there, without its arithmetic
        m = obj.turned(obj.corner_normals[triangle, 0])
        normal = m / np.linalg.norm(m, axis=-1)[:, None]
        curvature = np.zeros((len(triangle), 3, 3))
    else:
        normal, curvature = interpolated_normals(obj.vertices[tri], obj.turned(obj.corner_normals[triangle]), bary)
    if obj.vertex_velocity is not None:
        velocity = interpolate(obj.vertex_velocity, tri, w)
    else:
        velocity = np.broadcast_to(obj.velocity, position.shape).copy()
    return position, normal, velocity, curvature


def _reflection(obj_index, objects, normal, k_in, rotation, wavelength):
    """Complex :math:`\\Gamma` and :math:`S` per hit (material of each hit's object)."""
    eta = np.array([o.material.eta for o in objects], dtype=complex)[obj_index]
    thick = np.array([o.material.thickness for o in objects])[obj_index]
    s = np.array([o.material.scattering_coefficient for o in objects])[obj_index]
    cos_i = np.abs(np.einsum("pi,pi->p", normal, k_in))
    e_t = vertical_polarisation(k_in, rotation)
    return complex_reflection(cos_i, eta, thick, wavelength, k_in, normal, e_t), s


def _samples(objects, obj_index, triangle, bary, source, step_az, step_el, solid, rotation, wavelength):
    """:class:`SurfaceSamples` of hits (object index per hit into ``objects``)."""
    num = len(obj_index)
    position = np.empty((num, 3))
    normal = np.empty((num, 3))
    velocity = np.empty((num, 3))
    curvature = np.empty((num, 3, 3))
    for k, obj in enumerate(objects):
        sel = np.flatnonzero(obj_index == k)
        if sel.size:
            position[sel], normal[sel], velocity[sel], curvature[sel] = _hit_geometry(obj, triangle[sel], bary[sel])
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
                          triangle=triangle, barycentric=bary, labels=names[obj_index], curvature=curvature), direction


def render(loaded, origin, rotation, wavelength: float, velocities: dict, materials: dict, *,
           samples_across: int = 16, crease_angle: float = CREASE_ANGLE, vertex_doppler: bool = True,
           max_rays_per_object: int = MAX_RAYS_PER_OBJECT, objects: list[SceneObject] | None = None,
           cache: dict | None = None, step_scale: float = 1.0) -> Render:
    """First-bounce PO render of every object of ``loaded`` from ``origin`` (world, m).

    ``rotation`` (3x3, radar frame -> world) orients the azimuth/elevation grids and the element
    polarisation (vertical) used for :math:`\\Gamma`; ``velocities`` (name -> m/s) and ``materials``
    (name -> :class:`Material`) as in :func:`scene_objects`. Each object's angular step is
    :func:`~sionnafmcw.physical_optics.render_resolution` (extent = the bounding-box diagonal,
    distance = its largest range, curvature = :func:`curvature_radius`, ``samples_across``)
    times ``step_scale`` (for convergence checks). Raises :class:`RenderError` naming the object
    when its render would cast more than ``max_rays_per_object`` rays.
    """
    origin = np.asarray(origin, float)
    rotation = np.asarray(rotation, float)
    if objects is None:
        objects = scene_objects(loaded, velocities, materials, crease_angle, vertex_doppler, cache)
    parts = []
    steps = {}
    num_rays = 0
    for k, obj in enumerate(objects):
        start, width, low, high, r_min, r_max = object_box(obj.vertices, origin, rotation)
        if r_min <= 0:
            raise RenderError(f"po_render: the render origin lies on object {obj.name!r}")
        extent = float(np.linalg.norm(obj.vertices.max(axis=0) - obj.vertices.min(axis=0)))
        step = render_resolution(extent, r_max, wavelength, curvature_radius=obj.curvature_radius,
                                 samples_across=samples_across) * float(step_scale)
        steps[obj.name] = step
        az, el, d_az, d_el = _grid(start, width, low, high, step)
        n = az.size * el.size
        if n > max_rays_per_object:
            raise RenderError(
                f"po_render: object {obj.name!r} ({extent:.2f} m, {r_min:.2f}-{r_max:.2f} m away) needs {n} rays at "
                f"{step * 1e3:.2f} mrad, more than max_rays_per_object={max_rays_per_object}; lower samples_across "
                f"({samples_across}) or raise max_rays_per_object")
        num_rays += n
        ee, aa = np.meshgrid(el, az, indexing="ij")
        ee, aa = ee.ravel(), aa.ravel()
        local = np.stack([np.cos(ee) * np.cos(aa), np.cos(ee) * np.sin(aa), np.sin(ee)], -1)
        directions = local @ rotation.T
        from ..sionna_rt import cast_rays

        valid, t, shape, prim, uv = cast_rays(loaded.scene, origin, directions)
        keep = valid & (shape == obj.shape_id)
        if not np.any(keep):
            continue
        solid = d_az * (np.sin(ee[keep] + d_el / 2) - np.sin(ee[keep] - d_el / 2))
        s_az, s_el = angular_grid_steps(local[keep], d_az, d_el, rotation)
        parts.append((np.full(int(keep.sum()), k), prim[keep], uv[keep], solid, s_az, s_el))
    if not parts:
        return _empty_render(origin, steps, num_rays)
    obj_index, triangle, bary, solid, s_az, s_el = (np.concatenate(x) for x in zip(*parts))
    samples, direction = _samples(objects, obj_index, triangle, bary, origin, s_az, s_el, solid, rotation,
                                  wavelength)
    p = samples.num_samples
    eye = np.broadcast_to(np.eye(3), (p, 3, 3)).copy()
    return Render(samples, 1, np.broadcast_to(origin, (p, 3)).copy(), eye, np.zeros((p, 3)), np.ones(p, complex),
                  direction, s_az, s_el, samples.position.copy(), samples.velocity.copy(), np.zeros(p), steps, num_rays)


def _empty_render(origin, steps, num_rays, depth=1) -> Render:
    z3 = np.zeros((0, 3))
    samples = SurfaceSamples(z3, z3, np.zeros(0), edges=np.zeros((0, 2, 3)), labels=np.zeros(0, dtype=str))
    return Render(samples, depth, z3, np.zeros((0, 3, 3)), z3, np.zeros(0, complex), z3, z3, z3, z3, z3,
                  np.zeros(0), steps, num_rays, None if depth == 1 else z3, None if depth == 1 else np.zeros(0, np.int64))


def reflect(loaded, previous: Render, objects: list[SceneObject], rotation, wavelength: float) -> Render:
    """The next bounce of ``previous``: every sample's ray reflected about its shading normal and cast
    again; the hits become the samples of bounce ``previous.depth + 1`` with the image map, chain
    reflection and mirrored steps of the module docstring."""
    s = previous.samples
    if s.num_samples == 0:
        return _empty_render(np.zeros(3), previous.step, 0, previous.depth + 1)
    k_in = previous.direction
    n, k_out = previous.reflected()
    # start a hair off the surface along the outgoing ray (float32 scene)
    eps = 1e-5 * (1.0 + np.linalg.norm(s.position, axis=-1))
    from ..sionna_rt import cast_rays

    valid, t, shape, prim, uv = cast_rays(loaded.scene, s.position + eps[:, None] * k_out, k_out)
    by_id = {o.shape_id: k for k, o in enumerate(objects)}
    known = valid & np.isin(shape, list(by_id))
    idx = np.flatnonzero(known)
    if idx.size == 0:
        return _empty_render(np.zeros(3), previous.step, int(valid.size), previous.depth + 1)
    # mirror map of this bounce: x -> (I - 2 n n^T) x + 2 n (n . p)
    reflect_lin = np.eye(3)[None] - 2 * n[idx, :, None] * n[idx, None, :]
    reflect_off = 2 * n[idx] * np.einsum("pi,pi->p", n[idx], s.position[idx])[:, None]
    if previous.depth == 1:   # the previous map is the identity
        lin, off = reflect_lin, reflect_off
    else:
        lin = np.einsum("pij,pjk->pik", reflect_lin, previous.image_linear[idx])
        off = np.einsum("pij,pj->pi", reflect_lin, previous.image_offset[idx]) + reflect_off
    source = np.einsum("pij,pj->pi", reflect_lin, previous.source[idx]) + reflect_off
    s_az = np.einsum("pij,pj->pi", reflect_lin, previous.step_az[idx])
    s_el = np.einsum("pij,pj->pi", reflect_lin, previous.step_el[idx])
    # the tube's solid angle: |step_az x step_el| (exact for the grid's pixels to first order)
    solid = np.linalg.norm(np.cross(previous.step_az[idx], previous.step_el[idx]), axis=-1)
    ids = np.array(sorted(by_id), dtype=np.int64)
    obj_index = np.array([by_id[int(i)] for i in ids], dtype=np.int64)[np.searchsorted(ids, shape[idx])]
    samples, direction = _samples(objects, obj_index, prim[idx], uv[idx], source, s_az, s_el, solid, rotation,
                                  wavelength)
    chain = previous.chain_reflection[idx] * np.sqrt(np.clip(1 - s.scattering_coefficient[idx] ** 2, 0, 1)) \
        * s.reflection[idx]
    inner = previous.doppler_inner[idx]
    if previous.depth >= 2:
        inner = inner + np.einsum("pi,pi->p", s.velocity[idx], k_out[idx] - k_in[idx]) / wavelength
    second = k_out[idx] if previous.depth == 1 else previous.second_direction[idx]
    return Render(samples, previous.depth + 1, source, lin, off, chain, direction, s_az, s_el,
                  previous.first_point[idx], previous.first_velocity[idx], inner, previous.step, int(valid.size),
                  second, idx)


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
    images = np.einsum("pij,mj->mpi", bounce.image_linear, tx) + bounce.image_offset[None]   # [M, P, 3]
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


# ---------------------------------------------------------------------------------------- merging
#: Cell size of the PO merge, as a share of the radar's range and velocity resolutions, in both
#: engines (:func:`merge_contributions`; :func:`sionnafmcw.engines.pixel.merge_contributions`).
#: The merge error is bounded relative to :math:`\sum|a|` of a cell, not to its echo, so cells
#: whose PO integral nearly cancels (off-specular surfaces) need small cells. Measured on a
#: circle-walk frame at the path engine's defaults (``python benchmarks/po_merge.py``: merged cube
#: against the unmerged one, 3.8e5 PO samples per pair): cells of 1/16 / 1/64 / 1/256 give
#: 7.2e4 / 1.2e5 / 1.8e5 contributions, a cube difference of -18.6 / -26.9 / -32.6 dB and a
#: largest change of a range-Doppler cell within 40 dB of the peak (clutter removed) of
#: 9.4 / 4.4 / 0.08 dB; a 0.2 m plate turned 0.3 rad: 4.0 / 0.27 / 0.04 dB; hence 1/256.
MERGE_FRACTION = 1 / 256


def merge_contributions(a, tau, doppler, labels, delay_cell: float, doppler_cell: float, frequency: float,
                        return_cells: bool = False):
    r"""Sum contributions that the radar cannot tell apart into one per cell and element pair.

    ``a, tau, doppler`` ``[M, N, P]``, ``labels [P]``. Contributions of one label whose centre-pair
    delay :math:`\tau_{00}` and Doppler fall in the same cell of ``delay_cell`` (s) x
    ``doppler_cell`` (Hz) become, for every pair, one contribution at the cell's mean delay
    :math:`\bar\tau` and mean Doppler :math:`\bar f` with
    :math:`\bar a = \sum_i a_i e^{-j2\pi f_c(\tau_i - \bar\tau)}` (``frequency`` :math:`f_c`): the
    channel at the carrier is unchanged, and what is lost is the beat and Doppler phase across a
    cell, at most :math:`\pi B\,\delta\tau` and :math:`\pi T_{CPI}\,\delta f` at the ends of a chirp
    and of the CPI (:math:`\pi/256` for cells of :data:`MERGE_FRACTION` = 1/256 of the range and
    velocity resolution).
    Returns ``(a, tau, doppler, labels)`` ``[M, N, G]``, ``[G]``, the cells in the order of their
    first contribution (contributions that share no cell come back in their order); with
    ``return_cells`` also the cell of every contribution ``[P]`` (index into ``G``), so that contributions can later be
    taken out of their cell at the same :math:`\bar\tau` (:mod:`~sionnafmcw.engines.static_scene`).
    """
    a = np.asarray(a)
    m, n, p = a.shape
    if p == 0:
        out = (a, tau, doppler, np.asarray(labels))
        return (*out, np.zeros(0, dtype=np.int64)) if return_cells else out
    names, lab = label_codes(labels)
    i_tau = np.floor(tau[0, 0] / delay_cell).astype(np.int64)
    i_dop = np.floor(doppler[0, 0] / doppler_cell).astype(np.int64)
    # one int64 key per contribution (label, delay cell, Doppler cell): a 1-D unique is fast
    i_tau -= i_tau.min()
    i_dop -= i_dop.min()
    n_tau, n_dop = int(i_tau.max()) + 1, int(i_dop.max()) + 1
    keys = (lab.astype(np.int64) * n_tau + i_tau) * n_dop + i_dop
    # cells numbered in the order of their first contribution
    _, first, group, counts = np.unique(keys, return_index=True, return_inverse=True, return_counts=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    group, counts, first = rank[group.reshape(-1)], counts[order], first[order]
    g = counts.size
    flat_a = a.reshape(m * n, p)
    flat_tau = np.asarray(tau).reshape(m * n, p)
    flat_dop = np.asarray(doppler).reshape(m * n, p)
    # a contribution alone in its cell is its own merge (mean delay = its delay, phase factor 1):
    # every cell starts as its first contribution (one plain copy when no cell is shared, no
    # gather), and the shared cells are summed below
    if g == p:
        out_a, out_tau, out_dop = flat_a.copy(), flat_tau.copy(), flat_dop.copy()
    else:
        out_a = np.take(flat_a, first, axis=1)
        out_tau = np.take(flat_tau, first, axis=1)
        out_dop = np.take(flat_dop, first, axis=1)
    members = np.flatnonzero(counts[group] > 1)
    if members.size:
        cells, cell = np.unique(group[members], return_inverse=True)
        c = cells.size
        cell_counts = counts[cells]
        for k in range(m * n):
            mean_tau = np.bincount(cell, flat_tau[k, members], c) / cell_counts
            z = flat_a[k, members] * np.exp(-2j * np.pi * frequency * (flat_tau[k, members] - mean_tau[cell]))
            out_a[k, cells] = np.bincount(cell, z.real, c) + 1j * np.bincount(cell, z.imag, c)
            out_tau[k, cells] = mean_tau
            out_dop[k, cells] = np.bincount(cell, flat_dop[k, members], c) / cell_counts
    out_labels = names[lab[first]]
    out = (out_a.reshape(m, n, g), out_tau.reshape(m, n, g), out_dop.reshape(m, n, g), out_labels)
    return (*out, group) if return_cells else out


def label_codes(labels) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(labels, return_inverse=True)`` for ``[P]`` string labels, read run by run (the
    labels of a render come in runs of one object, so only the runs' labels are sorted)."""
    labels = np.asarray(labels).astype(str, copy=False).reshape(-1)
    if labels.size == 0:
        return np.zeros(0, dtype=labels.dtype), np.zeros(0, dtype=np.int64)
    start = np.flatnonzero(np.concatenate([[True], labels[1:] != labels[:-1]]))
    names, run_code = np.unique(labels[start], return_inverse=True)
    return names, np.repeat(run_code.reshape(-1), np.diff(np.append(start, labels.size)))


def take_out_of_cells(a, tau, cell, cell_tau, cell_doppler, cell_labels, frequency: float):
    r"""Contributions that remove ``a, tau`` ``[M, N, K]`` (merged earlier into cells ``cell [K]``) from
    their cells: one contribution per cell touched, at the cell's delay :math:`\bar\tau` and Doppler,

    .. math:: -\sum_{i \in \text{cell}} a_i\,e^{-j2\pi f_c(\tau_i - \bar\tau)},

    so that the merged cell plus it is exactly the merge of the contributions left in it, at the same
    :math:`\bar\tau` (the merge error bound of :func:`merge_contributions` holds for any
    :math:`\bar\tau` inside the cell). ``cell_tau``, ``cell_doppler`` ``[M, N, G]`` and
    ``cell_labels [G]`` are the merged output. Returns ``(a, tau, doppler, labels)``.
    """
    m, n, k = a.shape
    cells, inverse = np.unique(cell, return_inverse=True)
    g = cells.size
    z = -a * np.exp(-2j * np.pi * frequency * (tau - cell_tau[:, :, cell]))
    flat = z.reshape(m * n, k)
    out = np.empty((m * n, g), complex)
    for j in range(m * n):
        out[j] = np.bincount(inverse, flat[j].real, g) + 1j * np.bincount(inverse, flat[j].imag, g)
    return out.reshape(m, n, g), cell_tau[:, :, cells], cell_doppler[:, :, cells], np.asarray(cell_labels)[cells]


__all__ = ["CREASE_ANGLE", "MAX_RAYS_PER_OBJECT", "Material", "RIGID_TOLERANCE", "Render", "RenderError", "SceneObject",
           "chain_po_gains", "complex_reflection", "curvature_radius", "face_normals", "label_codes",
           "merge_contributions", "object_box", "radio_material", "reflect", "render", "rigid_motion",
           "scene_objects", "shading_normals", "take_out_of_cells"]
