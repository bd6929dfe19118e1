r"""The surfaces physical optics renders: every object's surface built once in its own frame, and the
ray casts that place them in a frame.

Sionna RT accepts triangle meshes only, and moving one means rewriting its vertices and letting
Mitsuba rebuild the whole acceleration structure (Embree's BVH, rebuilt for every shape group on the
LLVM backend). For the PO render that was the fine body: 191k triangles rebuilt every frame although
its 13 segments are rigid. Here each object gets a :class:`Surface` -- its mesh in its own frame
(the PLY as written: a rigid object's own frame, the world for the others), its corner normals, the
smallest radius of curvature of its normal field -- and a Mitsuba scene of that surface alone, built
once. The engine does the instancing: a ray :math:`\mathbf o + t\hat{\mathbf d}` meets a rigid object
placed by :math:`\mathbf x = \mathbf R\mathbf x_L + \mathbf p` where the ray
:math:`\mathbf R^T(\mathbf o - \mathbf p) + t\,\mathbf R^T\hat{\mathbf d}` meets its surface in its
own frame, at the same :math:`t` (a rigid motion keeps lengths). :meth:`SurfaceWorld.cast` returns
the nearest hit over every group it is asked for:

* the **static** group: every object that never moves, in one scene in world coordinates;
* the **rigid** atlas: every rigid object's surface in one scene, each in a slot of its own (its
  bounding sphere's centre moved to the slot's centre, the slots' spheres apart); a ray is cast
  into an object's slot only where it passes through that object's bounding sphere, from where it
  enters the sphere to where it leaves it (``maxt``), so it can meet no other slot;
* one **deforming** group per object whose mesh changes (its scene's vertices written per frame).

All of it is one Dr.Jit kernel per cast (:meth:`SurfaceWorld.cast`): the per-frame cost is the
rays, not the meshes. Slots keep coordinates within a few metres of the
atlas origin: float32 there is good to a micrometre, and a hit's position is recomputed in
float64 from its triangle and barycentrics.
Shadowing is as before: a render keeps a ray's hit only when the nearest hit over every group is on
the object the ray was cast for (an arm in front of the torso hides it; the room hides and is
hidden).

Corner normals. Where the PLY carries vertex normals (the smooth surface the writer meant: the
walking body's segments, a smooth-shaded Blender mesh) a corner takes its vertex's normal where
that normal is within the crease angle of the triangle's own facet normal, and the crease-aware
shading normal of :func:`~.po_render.shading_normals` elsewhere: a box or a cylinder's rim whose
normals were averaged across the edge (54.7 and 45 degrees from the faces) stays sharp, a coarse
sphere (its vertex normals some degrees from its facets) is the sphere; without PLY normals every
corner takes the shading normal. Everything here is numpy plus Mitsuba's ray cast (through :mod:`sionnafmcw.sionna_rt`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..animation.rigid import RigidMotion, area_centroid

#: Groups of :meth:`SurfaceWorld.cast`.
GROUPS = ("all", "static", "moving")


@dataclass
class Surface:
    """One object's PO surface in its own frame (module docstring): ``vertices [V, 3]`` (m, float64),
    ``faces [F, 3]``, ``corner_normals [F, 3, 3]`` (unit), ``curvature_radius`` (m, :func:`~.po_render.curvature_radius`),
    ``flat`` (every face has one normal at its three corners), the bounding sphere ``centre [3]`` /
    ``radius`` (m) and ``centroid [3]`` (area-weighted), all in its own frame; ``kind`` ``"static"``,
    ``"rigid"`` or ``"deforming"``. ``scene``: the Mitsuba scene of this surface alone (None for
    static surfaces, which share the static group's)."""

    name: str
    kind: str
    vertices: np.ndarray
    faces: np.ndarray
    corner_normals: np.ndarray
    curvature_radius: float
    flat: bool
    centre: np.ndarray
    radius: float
    centroid: np.ndarray
    scene: object = None
    shape_key: int = -1      # the Mitsuba shape of this surface in its scene (reinterpreted pointer)
    slot: np.ndarray | None = None   # rigid surfaces: where the atlas puts the sphere's centre
    first_vertices: np.ndarray | None = None   # the vertices it was built with (a deforming surface's frame 0)
    level: int = 1                    # the smooth-surface refinement's subdivisions per edge (1: the mesh itself)
    bulge: float = 0.0                # how far (m) the smooth surface leaves the stored mesh's facets
    vertex_map: tuple | None = None   # refined surfaces: (input triangle [V'], barycentric weights [V', 3]) per vertex
    mesh_faces: np.ndarray | None = None   # the stored mesh's faces (what the vertex map's triangles index)
    refined: object = None            # the :class:`~sionnafmcw.smooth_surface.RefinedSurface` (None: the mesh itself)
    mesh_edge: float = 0.0            # the stored mesh's longest edge (m)
    _gradients: np.ndarray | None = field(default=None, repr=False)   # normal_gradients(), once computed
    _classes: tuple | None = field(default=None, repr=False)          # curvature_classes(), once computed
    _plane_faces: object = field(default=False, repr=False)   # flat_faces.exact_objects: polygons, None, or not yet
    _exact_pieces: tuple | None = field(default=None, repr=False)     # flat_faces.exact_renders: (key, pieces)

    def __post_init__(self):
        if self.first_vertices is None:
            self.first_vertices = self.vertices

    def normal_gradients(self) -> np.ndarray:
        """Per triangle the tensor :math:`\\mathbf T` of the interpolated normal's shape operator
        (:func:`~sionnafmcw.physical_optics.normal_gradient_tensors`, ``[F, 3, 3]``, own frame): computed
        on first use and kept (a deforming surface's rewrite drops it)."""
        if self._gradients is None:
            from ..physical_optics import normal_gradient_tensors

            self._gradients = normal_gradient_tensors(self.vertices[self.faces], self.corner_normals)
        return self._gradients

    def curvature_classes(self) -> tuple:
        """``(triangle_class [F], radii [C], class_vertices)``: the curvature class of every triangle and each
        class's radius of curvature (m) for the PO render's grids
        (:func:`~sionnafmcw.engines.po_render.curvature_classes`), and per class the indices of its
        triangles' vertices (None when there is one class: a flat surface, or one whose triangles all
        curve alike); computed on first use and kept (a deforming surface's rewrite drops it)."""
        if self._classes is None:
            from .po_render import curvature_classes, triangle_curvature_radii

            if self.flat or not np.isfinite(self.curvature_radius):
                triangle_class, radii = np.zeros(len(self.faces), dtype=np.int64), np.array([self.curvature_radius])
            else:
                triangle_class, radii = curvature_classes(
                    triangle_curvature_radii(self.vertices, self.faces, self.corner_normals), self.curvature_radius)
            class_vertices = None if len(radii) == 1 else \
                [np.unique(self.faces[triangle_class == c]) for c in range(len(radii))]
            self._classes = (triangle_class, radii, class_vertices)
        return self._classes

    @staticmethod
    def corner_normals_of(vertices, faces, vertex_normals=None, crease_angle=None) -> np.ndarray:
        """The corner normals ``[F, 3, 3]`` of a mesh (module docstring: the given vertex normals where they
        agree with the facet within the crease angle, the crease-aware shading normals elsewhere)."""
        from .po_render import CREASE_ANGLE, shading_normals

        v = np.asarray(vertices, float)
        f = np.asarray(faces, np.int64)
        crease = CREASE_ANGLE if crease_angle is None else float(crease_angle)
        normals = shading_normals(v, f, crease)
        if vertex_normals is not None:
            given = np.asarray(vertex_normals, float)[f]                      # [F, 3, 3]
            facet = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
            facet /= np.maximum(np.linalg.norm(facet, axis=1, keepdims=True), 1e-300)
            agrees = np.abs(np.einsum("fci,fi->fc", given, facet)) >= np.cos(crease)
            normals = np.where(agrees[..., None], given, normals)
        return normals

    @classmethod
    def build(cls, name: str, kind: str, vertices, faces, vertex_normals=None, crease_angle=None,
              wavelength: float | None = None, level: int | None = None) -> Surface:
        """The surface of a mesh (own frame): corner normals (:meth:`corner_normals_of`), and, with a
        ``wavelength`` (m), the smooth surface those normals describe tessellated finely enough for
        physical optics (:func:`~sionnafmcw.smooth_surface.refinement_level`, or the given ``level``;
        :func:`~sionnafmcw.smooth_surface.pn_refine`: a flat mesh stays itself); then its curvature
        radius, flatness, bounding sphere and centroid."""
        from ..smooth_surface import facet_sagitta, pn_refine, refinement_level
        from .po_render import curvature_radius, flat_shaded

        v = np.ascontiguousarray(vertices, dtype=float)
        f = np.ascontiguousarray(faces, dtype=np.int64)
        normals = cls.corner_normals_of(v, f, vertex_normals, crease_angle)
        mesh_edge = float(np.max(np.linalg.norm(v[f] - v[np.roll(f, 1, axis=1)], axis=-1))) if len(f) else 0.0
        bulge, vertex_map, used, refined = 0.0, None, 1, None
        if (wavelength is not None or level is not None) and len(f) and not flat_shaded(normals):
            sagitta = facet_sagitta(v, f, normals)
            bulge = float(sagitta.max()) if sagitta.size else 0.0
            used = refinement_level(v, f, normals, wavelength) if level is None else int(level)
            if used > 1:
                refined = pn_refine(v, f, normals, used)
                vertex_map = _vertex_map(refined)
                v, f, normals = refined.vertices, refined.faces, refined.corner_normals
        lo, hi = v.min(axis=0), v.max(axis=0)
        centre = 0.5 * (lo + hi)
        radius = float(np.max(np.linalg.norm(v - centre, axis=1))) if len(v) else 0.0
        return cls(name, kind, v, f, normals, curvature_radius(v, f, normals), flat_shaded(normals), centre,
                   radius * (1 + 1e-6) + 1e-6, area_centroid(v, f), level=used, bulge=bulge, vertex_map=vertex_map,
                   mesh_faces=np.ascontiguousarray(faces, dtype=np.int64), refined=refined, mesh_edge=mesh_edge)

    def smooth_points(self, triangle, bary) -> tuple[np.ndarray, np.ndarray] | None:
        """Points and unit normals ``[K, 3]`` (own frame) on the smooth surface at hits ``triangle [K]``,
        ``bary [K, 2]`` of this surface's triangles (:meth:`~sionnafmcw.smooth_surface.RefinedSurface.smooth_points`:
        where the PO samples belong); None for a surface that is its mesh (flat, or not refined)."""
        if self.refined is None:
            return None
        return self.refined.smooth_points(triangle, bary)

    def vertex_values(self, values) -> np.ndarray:
        """Per-vertex ``values [V, K]`` of the stored mesh (e.g. a deforming mesh's velocities) at this
        surface's vertices: interpolated over the input triangle each refined vertex lies on."""
        if self.vertex_map is None:
            return np.asarray(values)
        triangle, weights = self.vertex_map
        corners = np.asarray(values)[self.mesh_faces[triangle]]                # [V', 3, K]
        return np.einsum("vc,vck->vk", weights, corners)


def _vertex_map(refined) -> tuple:
    """``(input triangle [V'], barycentric weights [V', 3])`` of every vertex of a refined surface (from any
    sub-triangle corner at it: a vertex shared by two input triangles lies on their common edge, where
    both give the same linear interpolation)."""
    faces = refined.faces
    triangle = np.zeros(len(refined.vertices), dtype=np.int64)
    bary = np.zeros((len(refined.vertices), 2))
    triangle[faces.reshape(-1)] = np.repeat(refined.parent, 3)
    bary[faces.reshape(-1)] = refined.barycentric.reshape(-1, 2)
    return triangle, np.stack([1.0 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1]], axis=-1)


def mitsuba_mesh(name: str, vertices, faces):
    """A Mitsuba triangle mesh of ``vertices [V, 3]`` (float32) and ``faces [F, 3]``."""
    from ..sionna_rt import aligned_float, drjit_array, mi

    v = np.asarray(vertices, dtype=np.float32).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.uint32).reshape(-1, 3)
    mesh = mi.Mesh(name, len(v), len(f), has_vertex_normals=False, has_vertex_texcoords=False)
    params = mi.traverse(mesh)
    params["vertex_positions"] = aligned_float(v)
    params["faces"] = drjit_array(mi.UInt32, f, np.uint32)
    params.update()
    return mesh


def mitsuba_scene(meshes: dict):
    """A Mitsuba scene of ``{name: mesh}`` and ``{name: shape key}``: each shape's pointer
    reinterpreted as an integer, the value a ray cast reports for a hit on it."""
    from ..sionna_rt import dr, mi

    scene = mi.load_dict({"type": "scene", **{f"s{k}": m for k, m in enumerate(meshes.values())}})
    keys = {}
    for name, mesh in meshes.items():
        keys[name] = int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(mesh)).numpy()[0])
    return scene, keys


@dataclass
class Placement:
    """Where a surface is in the current frame: ``rotation [3, 3]`` and ``translation [3]`` (own frame
    -> world), and its velocity field: ``motion`` (:class:`~sionnafmcw.animation.rigid.RigidMotion`:
    centroid velocity and angular velocity) or ``vertex_velocity [V, 3]`` (deforming meshes, world)
    or the uniform ``velocity [3]``. For motion within the CPI (None otherwise): the
    acceleration field, ``vertex_acceleration [V, 3]`` (world, per vertex of the surface) or the
    uniform ``acceleration [3]``, and the rotation's ``angular_velocity`` and
    ``angular_acceleration`` (a mirror's turn, :mod:`~sionnafmcw.engines.cpi_motion`)."""

    rotation: np.ndarray
    translation: np.ndarray
    velocity: np.ndarray
    motion: RigidMotion | None = None
    vertex_velocity: np.ndarray | None = None
    acceleration: np.ndarray | None = None
    vertex_acceleration: np.ndarray | None = None
    angular_velocity: np.ndarray | None = None
    angular_acceleration: np.ndarray | None = None

    def to_world(self, points) -> np.ndarray:
        return np.asarray(points, float) @ self.rotation.T + self.translation


@dataclass
class SurfaceWorld:
    """Every object's :class:`Surface` (in the order of ``names``), the static group's scene, and each
    moving surface's placement in the current frame (module docstring)."""

    names: list
    surfaces: list
    static_scene: object = None
    static_keys: dict = field(default_factory=dict)      # shape key -> object index (static group)
    placements: list = field(default_factory=list)       # per object: Placement of the current frame
    frame: int | None = None
    atlas: object = None                                 # the rigid surfaces' scene (module docstring)
    atlas_indices: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    _opaque: dict = field(default_factory=dict, repr=False)   # per surface: its placement as opaque Dr.Jit values
    _refined_tables: object = field(default=None, repr=False)  # refined_tables(), once built
    _stamps: dict = field(default_factory=dict, repr=False)   # deforming surfaces: the loaded file they show

    @property
    def index(self) -> dict:
        return {n: k for k, n in enumerate(self.names)}

    @classmethod
    def build(cls, animation, names, kinds: dict | None = None, crease_angle=None,
              wavelength: float | None = None) -> SurfaceWorld:
        """The surfaces of ``names`` from frame 0 of ``animation``: ``kinds[name]`` (default
        :func:`surface_kinds`) is ``"static"``, ``"rigid"`` or ``"deforming"``. Rigid surfaces are
        built in the PLY's own frame, the others in the world; with a ``wavelength`` (m) every curved
        surface is its smooth surface, refined for physical optics (:meth:`Surface.build`)."""
        from ..animation.ply import read_ply_cached

        kinds = surface_kinds(animation, names) if kinds is None else kinds
        surfaces, static_meshes = [], {}
        for name in names:
            kind = kinds[name]
            info = animation.frame_xml(0).shapes[name]
            ply = read_ply_cached(info.filename)
            if kind == "rigid":
                v, normals = ply.vertices, ply.vertex_normals
            else:
                mesh = animation.mesh(0, name)
                v = mesh.vertices
                normals = ply.vertex_normals
                if normals is not None:   # normals transform with the inverse transpose
                    normals = normals @ np.linalg.inv(info.to_world[:3, :3])
                    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
            surface = Surface.build(name, kind, v, ply.faces, normals, crease_angle, wavelength)
            if kind == "static":
                static_meshes[name] = mitsuba_mesh(name, surface.vertices, surface.faces)
            elif kind == "deforming":
                surface.scene, keys = mitsuba_scene({name: mitsuba_mesh(name, surface.vertices, surface.faces)})
                surface.shape_key = keys[name]
            surfaces.append(surface)
        world = cls(list(names), surfaces)
        index = world.index
        if static_meshes:
            world.static_scene, keys = mitsuba_scene(static_meshes)
            world.static_keys = {key: index[name] for name, key in keys.items()}
            for name, key in keys.items():
                surfaces[index[name]].shape_key = key
        rigid = [k for k, surface in enumerate(surfaces) if surface.kind == "rigid"]
        if rigid:
            world.atlas_indices = np.array(rigid, dtype=np.int64)
            spacing = 2.0 * max(surfaces[k].radius for k in rigid) * 1.01 + 1e-3
            side = int(np.ceil(len(rigid) ** (1 / 3)))
            meshes = {}
            for j, k in enumerate(rigid):
                cell = np.array([j % side, (j // side) % side, j // (side * side)], float) - (side - 1) / 2
                surfaces[k].slot = cell * spacing
                meshes[surfaces[k].name] = mitsuba_mesh(surfaces[k].name,
                                                        surfaces[k].vertices - surfaces[k].centre + surfaces[k].slot,
                                                        surfaces[k].faces)
            world.atlas, keys = mitsuba_scene(meshes)
            for name, key in keys.items():
                surfaces[index[name]].shape_key = key
        world.placements = [Placement(np.eye(3), np.zeros(3), np.zeros(3)) for _ in surfaces]
        return world

    # ------------------------------------------------------------------ per frame
    def place(self, animation, frame: int, loaded, velocities: dict, motion=None) -> None:
        """The placements of ``frame``: a rigid surface's rotation, translation and velocity field from
        :meth:`~sionnafmcw.animation.Animation.motion`; a deforming surface's vertices (from
        ``loaded``, the :class:`~.loaded_scene.LoadedScene` of the frame: its scene is rewritten when
        they changed) and vertex velocities; every surface's uniform ``velocities[name]`` (m/s, the
        object's manifest velocity) where it has no field. ``motion``: the frame's
        :class:`~sionnafmcw.engines.cpi_motion.FrameMotion` with accelerations (``quadratic``), which
        fill every placement's acceleration field; None: none."""
        for k, (name, surface) in enumerate(zip(self.names, self.surfaces)):
            v = np.asarray(velocities.get(name, np.zeros(3)), float)
            if surface.kind == "rigid":
                m = animation.motion(frame, name)
                if m is None:
                    raise ValueError(f"{animation.frame(frame).xml}: rigid object {name!r} has a to_world that "
                                     "scales or shears its mesh in this frame")
                spin = np.any(m.angular_velocity != 0)
                self.placements[k] = Placement(m.rotation, m.translation, v, m if spin else None)
            elif surface.kind == "deforming":
                vertices = loaded.vertices[name]
                if self._stamps.get(k) != loaded.loaded_files.get(name):
                    self._rewrite(surface, vertices)
                    self._stamps[k] = loaded.loaded_files.get(name)
                field = loaded.vertex_velocity.get(name)
                self.placements[k] = Placement(np.eye(3), np.zeros(3), v,
                                               vertex_velocity=None if field is None else surface.vertex_values(field))
            else:
                self.placements[k] = Placement(np.eye(3), np.zeros(3), v)
            if motion is not None and motion.quadratic:
                place = self.placements[k]
                place.acceleration = motion.object_acceleration(name)
                field_a = motion.vertex_accelerations.get(name)   # per vertex of the stored mesh
                place.vertex_acceleration = None if field_a is None else surface.vertex_values(field_a)
                place.angular_velocity, place.angular_acceleration = motion.spin(name)
        self.frame = frame

    @staticmethod
    def _rewrite(surface: Surface, vertices) -> None:
        """A deforming surface in this frame: the stored mesh's vertices (rebuilt at the surface's level:
        the same topology) written into its scene, normals and figures recomputed."""
        from ..sionna_rt import aligned_float, dr, mi
        from .po_render import curvature_radius, flat_shaded

        new = Surface.build(surface.name, surface.kind, vertices, surface.mesh_faces, level=surface.level)
        if new.vertices.shape != surface.vertices.shape:
            raise ValueError(f"{surface.name!r}: its mesh changes its vertex count from frame to frame")
        surface.vertices, surface.faces, surface.corner_normals = new.vertices, new.faces, new.corner_normals
        surface.vertex_map, surface.refined = new.vertex_map, new.refined
        surface._gradients = surface._classes = None
        surface.curvature_radius = curvature_radius(surface.vertices, surface.faces, surface.corner_normals)
        surface.flat = flat_shaded(surface.corner_normals)
        lo, hi = surface.vertices.min(axis=0), surface.vertices.max(axis=0)
        surface.centre = 0.5 * (lo + hi)
        surface.radius = float(np.max(np.linalg.norm(surface.vertices - surface.centre, axis=1))) * (1 + 1e-6) + 1e-6
        surface.centroid = area_centroid(surface.vertices, surface.faces)
        params = mi.traverse(surface.scene)
        key = next(k for k in params.keys() if k.endswith("vertex_positions"))
        params[key] = aligned_float(surface.vertices)
        params.update()
        dr.eval()

    def _opaque_placement(self, j: int):
        """Surface ``j``'s sphere centre (world), radius, rotation and slot as opaque Dr.Jit values (so the
        cast's kernel does not depend on the frame), made once per frame."""
        from ..sionna_rt import dr, mi

        cache = self._opaque.get(j)
        if cache is None or cache[0] is not self.placements[j]:
            surface, place = self.surfaces[j], self.placements[j]
            opaque = lambda x: dr.opaque(mi.Float, float(x))  # noqa: E731
            slot = surface.slot if surface.slot is not None else np.zeros(3)
            cache = (place, mi.Point3f(*[opaque(x) for x in place.to_world(surface.centre)]), opaque(surface.radius),
                     [[opaque(place.rotation[a, b]) for b in range(3)] for a in range(3)], [opaque(x) for x in slot])
            self._opaque[j] = cache
        return cache[1:]

    def refined_tables(self):
        """The :class:`~.hit_geometry.RefinedTables` of the refined static and rigid surfaces (built on
        first use: they do not change from frame to frame in their own frames)."""
        if self._refined_tables is None:
            from .hit_geometry import RefinedTables

            self._refined_tables = RefinedTables(self.surfaces)
        return self._refined_tables

    def moving(self) -> list[int]:
        """Indices of the surfaces that are not static."""
        return [k for k, s in enumerate(self.surfaces) if s.kind != "static"]

    def bounding_spheres(self, indices=None):
        """World centres ``[K, 3]`` and radii ``[K]`` of the bounding spheres of ``indices`` (default: the moving ones)."""
        indices = self.moving() if indices is None else list(indices)
        centres = np.array([self.placements[k].to_world(self.surfaces[k].centre) for k in indices]).reshape(-1, 3)
        radii = np.array([self.surfaces[k].radius for k in indices], float)
        return centres, radii

    # ------------------------------------------------------------------ casting
    def cast(self, origins, directions, group: str = "all"):
        r"""Nearest hits of rays ``origins [K, 3]`` (or one ``[3]``) + t ``directions [K, 3]`` (unit,
        world) over the surfaces of ``group`` (:data:`GROUPS`): ``(valid [K] bool, t [K] (m),
        obj [K] (object index, -1 where nothing is hit), triangle [K], barycentric [K, 2])``.

        One Dr.Jit computation (one kernel, compiled once per scene: every per-frame value is
        opaque): the static scene's hit, then for every moving surface, where the ray passes through
        its bounding sphere before the nearest hit so far
        (:math:`t_c = (\mathbf c - \mathbf o)\cdot\hat{\mathbf d}`, :math:`d^2 = |\mathbf c - \mathbf o|^2 - t_c^2 \le r^2`,
        entering at :math:`t_c - h`, :math:`h = \sqrt{r^2 - d^2}`), the ray moved into its slot of the
        atlas (:math:`\mathbf R^T(\mathbf o + t_{in}\hat{\mathbf d} - \mathbf c) + \mathbf s`,
        :math:`\mathbf R^T\hat{\mathbf d}`, ``maxt`` to where it leaves the sphere) or, for a deforming
        surface, cast into its own scene; the nearer hit wins."""
        from ..sionna_rt import aligned_float, dr, drjit_array, mi

        if group not in GROUPS:
            raise ValueError(f"SurfaceWorld.cast: group={group!r} is unknown; choose one of {', '.join(GROUPS)}")
        d = np.asarray(directions, float)
        k = d.shape[0]
        o = np.broadcast_to(np.asarray(origins, float), (k, 3))
        if k == 0:
            return (np.zeros(0, bool), np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)))
        origin = mi.Point3f(*[aligned_float(o[:, i]) for i in range(3)])
        direction = mi.Vector3f(*[aligned_float(d[:, i]) for i in range(3)])
        best = dr.full(mi.Float, np.inf, k)
        obj = dr.full(mi.Int32, -1, k)
        prim = dr.zeros(mi.UInt32, k)
        u, v = dr.zeros(mi.Float, k), dr.zeros(mi.Float, k)
        if group in ("all", "static") and self.static_scene is not None:
            pi = self.static_scene.ray_intersect_preliminary(mi.Ray3f(origin, direction), coherent=True)
            key = dr.reinterpret_array(mi.UInt32, pi.shape)
            table = np.full(max(self.static_keys) + 1, -1, dtype=np.int32)
            table[list(self.static_keys)] = list(self.static_keys.values())
            index = dr.gather(mi.Int32, drjit_array(mi.Int32, table, np.int32), dr.minimum(key, len(table) - 1))
            hit = pi.is_valid() & (index >= 0)
            best = dr.select(hit, pi.t, best)
            obj, prim = dr.select(hit, index, obj), dr.select(hit, pi.prim_index, prim)
            u, v = dr.select(hit, pi.prim_uv.x, u), dr.select(hit, pi.prim_uv.y, v)
        if group in ("all", "moving"):
            for j in self.moving():
                surface = self.surfaces[j]
                centre, radius, r, slot = self._opaque_placement(j)
                oc = centre - origin
                tc = dr.dot(oc, direction)
                d2 = dr.squared_norm(oc) - tc * tc
                h = dr.sqrt(dr.maximum(radius * radius - d2, 0.0))
                near = (d2 <= radius * radius) & (tc + h >= 0.0) & (tc - h <= best)
                if surface.kind == "rigid":
                    enter = dr.maximum(tc - h, 0.0)
                    start = origin + direction * enter - centre
                    ray = mi.Ray3f(mi.Point3f(*[r[0][a] * start.x + r[1][a] * start.y + r[2][a] * start.z + slot[a]
                                                for a in range(3)]),
                                   mi.Vector3f(*[r[0][a] * direction.x + r[1][a] * direction.y + r[2][a] * direction.z
                                                 for a in range(3)]))
                    ray.maxt = dr.maximum(dr.minimum(tc + h, best) - enter, 0.0)
                    pi = self.atlas.ray_intersect_preliminary(ray, coherent=True, active=near)
                    t = pi.t + enter
                else:
                    pi = surface.scene.ray_intersect_preliminary(mi.Ray3f(origin, direction), coherent=True,
                                                                 active=near)
                    t = pi.t
                hit = near & pi.is_valid() & (t < best)
                best = dr.select(hit, t, best)
                obj, prim = dr.select(hit, j, obj), dr.select(hit, pi.prim_index, prim)
                u, v = dr.select(hit, pi.prim_uv.x, u), dr.select(hit, pi.prim_uv.y, v)
        dr.eval(best, obj, prim, u, v)
        obj = np.asarray(obj.numpy(), dtype=np.int64)
        valid = obj >= 0
        with np.errstate(invalid="ignore"):
            uv = np.stack([np.asarray(u.numpy(), dtype=np.float64), np.asarray(v.numpy(), dtype=np.float64)], axis=-1)
        uv[~valid] = 0.0
        return valid, np.asarray(best.numpy(), dtype=np.float64), obj, np.asarray(prim.numpy(), dtype=np.int64), uv


def surface_kinds(animation, names) -> dict:
    """``{name: kind}``: ``"deforming"`` when an object's PLY changes between frames or carries per-vertex
    velocities, ``"rigid"`` when its ``to_world`` changes or it has a velocity or an angular velocity
    in some frame (a spinning wheel keeps its mesh and its transform), ``"static"`` otherwise: the
    objects that never move, which the static PO render and the static scene cache take once."""
    from ..animation.ply import read_ply_cached

    first = animation.frame_xml(0).shapes
    kinds = {}
    for name in names:
        info0 = first[name]
        kind = "static"
        if read_ply_cached(info0.filename).vertex_velocities is not None:
            kind = "deforming"
        for i in range(animation.num_frames):
            info = animation.frame_xml(i).shapes.get(name)
            if info is None or info.filename != info0.filename:   # (a frame without it: LoadedScene says so)
                kind = "deforming"
                break
            fr = animation.frame(i)
            if kind == "static" and (not np.array_equal(info.to_world, info0.to_world)
                                     or np.any(fr.objects.get(name, np.zeros(3)) != 0)
                                     or np.any(fr.angular_velocities.get(name, np.zeros(3)) != 0)):
                kind = "rigid"
        kinds[name] = kind
    return kinds


__all__ = ["GROUPS", "Placement", "Surface", "SurfaceWorld", "mitsuba_mesh", "mitsuba_scene", "surface_kinds"]
