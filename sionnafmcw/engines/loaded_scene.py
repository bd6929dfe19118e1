"""The loaded scene of an engine: a Sionna scene at the carrier and the geometry of the current frame.

Every engine loads an animation's scene once (:func:`load_radar_scene`, ``merge_shapes=False``
so that moving meshes stay separate objects) and then moves it from frame to frame without
reloading (:class:`~sionnafmcw.engines.base.Engine` does both). This module holds:

* :func:`load_radar_scene` -- the scene XML at the radar's carrier
  (:func:`sionnafmcw.sionna_rt.load_scene_at`), with the custom materials (skin) attached and
  every material checked at the carrier (:mod:`sionnafmcw.materials`);
* :class:`LoadedScene` -- the loaded scene, its Mitsuba parameters and, per object, the geometry
  of the current frame (faces, world vertices, per-vertex velocities). :meth:`LoadedScene.load`
  checks that what Mitsuba loaded equals the PLYs read by :mod:`sionnafmcw.animation` and writes
  the meshes that move once, so the kernels of a geometry update are compiled while loading;
  :meth:`LoadedScene.update_geometry` writes the vertex positions of the meshes whose PLY changed
  through the Mitsuba scene parameters;
* :func:`barycentric_weights` and :func:`interpolate` -- per-vertex values (velocities,
  positions) at points on a triangle.

Errors are :class:`~sionnafmcw.engines.base.SceneLoadError` and
:class:`~sionnafmcw.engines.base.SceneGeometryError` (both :class:`~sionnafmcw.engines.base.EngineError`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..animation import Animation
from ..materials import apply_custom_materials, check_scene_materials
from ..sionna_rt import aligned_float, dr, load_scene_at, mi
from .errors import SceneGeometryError, SceneLoadError


# ---------------------------------------------------------------------------------------- loading
def load_radar_scene(xml, frequency: float):
    """Load ``xml`` with ``merge_shapes=False`` as a Sionna scene evaluated at ``frequency`` (Hz).

    Every material is built at ``frequency`` (:func:`~sionnafmcw.sionna_rt.load_scene_at`: ITU
    materials defined only at millimetre waves, such as ``floorboard``, would fail at Sionna's
    default 3.5 GHz), moving meshes stay separate objects, skin and other custom materials are
    attached (:func:`~sionnafmcw.materials.apply_custom_materials`) and every material is checked
    at ``frequency``. Raises :class:`SceneLoadError` naming the file when Sionna refuses it.
    """
    xml = Path(xml)
    try:
        scene = load_scene_at(xml, frequency)
    except Exception as err:  # noqa: BLE001  (Sionna and Mitsuba raise plain exceptions)
        raise SceneLoadError(f"{xml}: Sionna could not load the scene: {err}") from err
    apply_custom_materials(scene)
    check_scene_materials(scene, frequency)
    scene.frequency = frequency
    return scene


# ---------------------------------------------------------------------------------------- geometry
@dataclass
class LoadedScene:
    """A loaded Sionna scene and the per-object geometry of the frame currently written into it.

    ``shape_ids`` maps each object name to its Mitsuba shape id (the prefix of its scene
    parameters). ``faces`` (``[F, 3]`` int64), ``vertices`` (``[V, 3]`` world, float64) and
    ``vertex_velocity`` (``[V, 3]`` or None) hold every object's geometry of the current frame: the
    PLY's for PLY meshes, as Mitsuba loaded it (float32, no velocities) for the other shapes, which
    may not move. ``loaded_files`` is what is written into the scene per object (PLY file, mtime
    and transform; ``"not-ply"`` and the transform otherwise), so that unchanged meshes are skipped.
    ``changing``: the objects whose mesh changes in some frame of the animation.
    """

    scene: object
    params: object
    shape_ids: dict = field(default_factory=dict)        # name -> Mitsuba shape id
    faces: dict = field(default_factory=dict)            # name -> [F, 3] int64
    vertices: dict = field(default_factory=dict)         # name -> [V, 3] float64 (world, current frame)
    vertex_velocity: dict = field(default_factory=dict)  # name -> [V, 3] or None (current frame)
    loaded_files: dict = field(default_factory=dict)     # name -> what is written into the scene
    changing: frozenset = frozenset()                    # names whose mesh changes in some frame

    @classmethod
    def load(cls, scene, animation: Animation) -> LoadedScene:
        """The geometry of frame 0 of ``animation`` in the freshly loaded Sionna ``scene``.

        Reads ``scene.mi_scene_params`` now (so call it after adding devices or velocities), checks
        that the vertices and faces Mitsuba loaded for every PLY mesh equal the PLY read by
        sionnafmcw (else :class:`SceneGeometryError`), and writes the frame-0 vertices of the meshes that move in
        a later frame once, followed by ``dr.eval()``: the kernels of a geometry update are then
        compiled while loading rather than in frame 1.
        """
        params = scene.mi_scene_params
        state = cls(scene, params)
        first_frame = animation.frame_xml(0)
        for name, obj in scene.objects.items():
            state.shape_ids[name] = obj.mi_mesh.id()
        # reference geometry: what Sionna loaded for frame 0, compared with our own PLY reading
        for name, shape_id in state.shape_ids.items():
            loaded = np.asarray(params[f"{shape_id}.vertex_positions"], dtype=float).reshape(-1, 3)
            faces = np.asarray(params[f"{shape_id}.faces"], dtype=np.int64).reshape(-1, 3)
            info = first_frame.shapes.get(name)
            if info is None or info.type != "ply":
                # not a PLY: static geometry as Mitsuba loaded it (float32), no vertex velocities
                state.vertices[name], state.faces[name], state.vertex_velocity[name] = loaded, faces, None
                state.loaded_files[name] = ("not-ply", None if info is None else tuple(info.to_world.ravel()))
                continue
            mesh = animation.mesh(0, name)
            if loaded.shape != mesh.vertices.shape or not np.allclose(loaded, mesh.vertices, atol=1e-4, rtol=1e-5):
                raise SceneGeometryError(
                    f"{info.filename}: the vertices Mitsuba loaded differ from the PLY read by sionnafmcw "
                    f"({loaded.shape[0]} vs {mesh.vertices.shape[0]} vertices); cannot update this mesh per frame")
            if faces.shape != mesh.faces.shape or not np.array_equal(faces, mesh.faces):
                raise SceneGeometryError(
                    f"{info.filename}: the faces Mitsuba loaded differ from the PLY read by sionnafmcw; "
                    "cannot interpolate vertex velocities on this mesh")
            state.vertices[name], state.faces[name] = mesh.vertices, faces
            state.vertex_velocity[name] = mesh.vertex_velocities
            state.loaded_files[name] = (info.filename, info.filename.stat().st_mtime, tuple(info.to_world.ravel()))
        # write the frame-0 vertices of the meshes that move once now: the kernels of a geometry
        # update are compiled while loading, not in frame 1
        dynamic = set()
        for i in range(1, animation.num_frames):
            for name, info in animation.frame_xml(i).shapes.items():
                first = first_frame.shapes.get(name)
                if first is not None and info.type == "ply" and (
                        info.filename != first.filename or not np.array_equal(info.to_world, first.to_world)):
                    dynamic.add(name)
        state.changing = frozenset(dynamic & set(state.shape_ids))
        for name in sorted(state.changing):
            state._write_vertices(name, state.vertices[name])
        if dynamic:
            params.update()
        dr.eval()
        return state

    def _write_vertices(self, name: str, vertices) -> None:
        self.params[f"{self.shape_ids[name]}.vertex_positions"] = aligned_float(vertices)

    def update_geometry(self, animation: Animation, frame: int) -> bool:
        """Write the meshes of ``frame`` whose PLY (file, mtime or transform) changed; True if any did.

        The frame must have the same shapes as frame 0, only PLY meshes may change, and a changed
        mesh must keep its vertex count and faces (else :class:`SceneGeometryError`). The new vertex positions
        go through the Mitsuba scene parameters followed by ``params.update()``; what else a
        geometry change needs (a Sionna callback, an evaluation) is the caller's, when this
        returns True.
        """
        fs = animation.frame_xml(frame)
        missing = sorted(set(self.shape_ids) - set(fs.shapes))
        extra = sorted(set(fs.shapes) - set(self.shape_ids))
        if missing or extra:
            raise SceneGeometryError(
                f"{fs.xml}: frame {frame} has a different set of shapes than frame 0 "
                f"(missing: {missing or 'none'}, new: {extra or 'none'}); the engine keeps one scene per animation")
        changed = False
        for name, info in fs.shapes.items():
            if info.type != "ply":
                if self.loaded_files.get(name) != ("not-ply", tuple(info.to_world.ravel())):
                    raise SceneGeometryError(
                        f"{fs.xml}: shape {info.id!r} of type {info.type!r} changes its transform in frame {frame}; "
                        "only PLY meshes can move (export moving objects as PLY)")
                continue
            stamp = (info.filename, info.filename.stat().st_mtime, tuple(info.to_world.ravel()))
            if self.loaded_files.get(name) == stamp:
                continue
            mesh = animation.mesh(frame, name)
            if mesh.vertices.shape != self.vertices[name].shape:
                raise SceneGeometryError(
                    f"{info.filename}: mesh {name!r} has {mesh.vertices.shape[0]} vertices in frame {frame} but "
                    f"{self.vertices[name].shape[0]} in frame 0; per-frame meshes must keep their topology")
            if mesh.faces.shape != self.faces[name].shape or not np.array_equal(mesh.faces, self.faces[name]):
                raise SceneGeometryError(
                    f"{info.filename}: mesh {name!r} changes its faces in frame {frame}; per-frame meshes must keep "
                    "their topology (only vertex positions may change)")
            self._write_vertices(name, mesh.vertices)
            self.vertices[name] = mesh.vertices
            self.vertex_velocity[name] = mesh.vertex_velocities
            self.loaded_files[name] = stamp
            changed = True
        if changed:
            self.params.update()
        return changed


# ---------------------------------------------------------------------------------------- barycentrics
def barycentric_weights(p, a, b, c) -> np.ndarray:
    """Barycentric weights ``[N, 3]`` of points ``p`` in triangles ``(a, b, c)`` (clipped to the triangle)."""
    v0, v1, v2 = b - a, c - a, p - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(den == 0, 1.0, den)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    bary = np.stack([1.0 - v - w, v, w], axis=-1)
    bary = np.clip(bary, 0.0, 1.0)
    return bary / bary.sum(axis=1, keepdims=True)


def interpolate(values, faces, weights) -> np.ndarray:
    """Per-vertex ``values [V, K]`` at points of the triangles ``faces [N, 3]`` with barycentric ``weights [N, 3]``."""
    return (weights[:, 0:1] * values[faces[:, 0]] + weights[:, 1:2] * values[faces[:, 1]]
            + weights[:, 2:3] * values[faces[:, 2]])


__all__ = ["LoadedScene", "barycentric_weights", "interpolate", "load_radar_scene"]
