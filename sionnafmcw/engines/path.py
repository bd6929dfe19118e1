r"""Path engine: per-element echoes of an animation frame from Sionna RT's path solver.

One :class:`~sionna.rt.Transmitter` and one :class:`~sionna.rt.Receiver` sit at the radar pose and
carry the radar's exact element layout (a custom :class:`~sionna.rt.AntennaArray` with the
element positions of :class:`~sionnafmcw.radar.RadarConfig`, pattern ``radar.antenna_pattern``,
vertical polarisation). The solver runs with ``synthetic_array=False``: every Tx element is a
source and every Rx element a target, so each path has its own gain, delay and Doppler per
element pair, with spherical wavefronts and no far-field approximation across the array.

Conventions and choices
-----------------------
* **Orientation**: the radar pose is Sionna's ``(yaw, pitch, roll)`` (rad) applied to the radar
  frame (boresight local +x, azimuth along local y, elevation along local z). The element
  positions of ``RadarConfig`` are in that frame; Sionna rotates them with the same orientation.
* **No direct coupling**: the Tx and Rx elements are millimetres apart and Sionna drops segments
  shorter than 1 cm, so the solver runs with ``los=False``; Tx-Rx leakage is *not* modelled by
  this engine (add it on its own if wanted).
* **Labels**: each contribution is labelled with the object name of its *first* interaction (the
  object the transmitted wave hits first) by default. ``label="last"`` takes the last interaction
  (the object the receiver sees), ``label="moving"`` the first interaction on an object that moves
  in that frame (manifest or vertex velocity), falling back to the first. For single-bounce paths
  all three agree. Padding entries have the label ``""``.
* **Doppler**: rigid objects use Sionna's per-object velocity (the manifest velocity of the frame).
  For a mesh whose PLY carries per-vertex velocities ``vx, vy, vz``, Sionna's velocity of that
  object is set to zero and the engine adds, for every interaction on it,
  :math:`\mathbf v(\mathbf p)\cdot(\hat{\mathbf k}_{out} - \hat{\mathbf k}_{in})/\lambda` with
  :math:`\mathbf v(\mathbf p)` interpolated barycentrically at the interaction point and
  :math:`\lambda = c/f_c` -- Sionna's own formula, so a rigid field reproduces Sionna's value, and
  the sign is Sionna's (positive approaching).
* **No recompilation**: the scene is loaded once per animation (``merge_shapes=False`` so moving
  meshes stay separate objects); each frame writes the vertex positions of the meshes whose PLY
  changed through the Mitsuba scene parameters and the object velocities as parameter updates,
  with a fixed seed. The engine takes the solver's path buffer directly instead of building
  Sionna's ``Paths`` tensors (whose kernels bake the per-frame path count in as a constant and
  would recompile whenever it changes) and scatters it into per-element arrays with numpy. The
  kernels of a geometry update are run once while loading, so from the second frame on no new
  kernel is launched at all (:attr:`PathEngine.stats`, ``new_kernel_hashes``).
* **Determinism**: a fixed seed gives the same rays, but Sionna's default candidate generator
  may order paths differently between runs and, rarely, keep or drop a path that grazes a
  triangle edge. ``deterministic=True`` uses Sionna's deterministic generator (identical output,
  about 4x slower on CPU).

Defaults (indoor 77 GHz radar)
------------------------------
``max_depth=2``: the target echo (one bounce) and the target-floor/wall multipath (two bounces),
the multipath that matters for an indoor radar; a third bounce costs about 50 % more time
(measured: 0.55 -> 0.86 s per frame in a closed room) for echoes tens of dB weaker.
``samples_per_src=100_000`` rays per Tx element: about 750 rays on a person at 3 m
(0.5 x 1.7 m). Specular and diffuse reflection on (diffuse paths only carry energy on materials
with a ``scattering_coefficient``), refraction off (through-wall paths at 77 GHz are negligible,
and a closed body is not a thin slab), diffraction off (first order only in Sionna, and weak at
millimetre waves). ``seed=1`` fixed, so a static scene gives the same rays every frame.

Measured on two CPU cores (shared, so +-30 %), 3 Tx x 4 Rx: a plate alone 0.13-0.17 s per frame;
box + diffuse floor + wall (123k paths) 0.13-0.26 s; a 9.8k-triangle body in a closed
10 x 10 x 3 m room (62k paths) 0.55-1.0 s, most of it Sionna's ray-casting kernel. 10 kernels
are launched per frame and none compiled after the first frame.

A faceted smooth body returns few purely specular echoes: a flat facet sends the echo back only if
its normal points at the radar to within about facet size / range (a milliradian), while the facet
normals of a 10k-triangle body are some 60 mrad apart. Give skin a ``scattering_coefficient``
(e.g. 0.3: 64 -> 250 body contributions per frame in the room above) or tessellate finely.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..animation import Animation, RadarPose
from ..constants import SPEED_OF_LIGHT
from ..echoes import Echoes
from ..sionna_rt import (
    INVALID_SHAPE, AntennaArray, InteractionType, PathSolver, Receiver, Transmitter, antenna_pattern_registry, dr, mi,
    set_min_segment_length, solve_fields, trace_candidates,
)
from .base import Engine, EngineError
from .loaded_scene import barycentric_weights, interpolate

#: Minimum path segment length (m) for a radar. Sionna's 1 cm (``MIN_SEGMENT_LENGTH``, meant for
#: communication links) drops every retro-reflected path of a radar: a trihedral's or dihedral's
#: image-method path between Tx and Rx elements a distance d apart passes within ~d/2 of the
#: corner, so its segments between bounces are millimetres long (measured: the triple bounce of a
#: 0.3 m trihedral at 4 m vanishes for Tx-Rx offsets below ~1 cm and is found at 2 mm with
#: 0.1 mm). Set when this module is imported, before any path is solved; it applies to every
#: solver in the process (:func:`sionnafmcw.sionna_rt.set_min_segment_length`, which fails loudly
#: when Sionna no longer has the constant).
RADAR_MIN_SEGMENT_LENGTH = 1e-4
set_min_segment_length(RADAR_MIN_SEGMENT_LENGTH)


class PathEngineError(EngineError):
    """The path engine cannot run this animation / radar combination; the message says why."""


@dataclass
class _State:
    """Per-scene state of the path engine: the radar's devices and what is set in Sionna."""

    tx: object
    rx: object
    names_by_id: dict
    velocities: dict = field(default_factory=dict)  # name -> velocity currently set in Sionna
    pose: tuple | None = None


def _pose_key(pose: RadarPose) -> tuple:
    return tuple(np.round(np.concatenate([pose.position, pose.orientation]), 12))


class PathEngine(Engine):
    """Sionna RT path solver turned into per-element radar echoes.

    Parameters
    ----------
    max_depth : int
        Maximum number of interactions per path.
    samples_per_src : int
        Rays shot per Tx element.
    max_num_paths_per_src : int
        Candidate buffer size per Tx element (Sionna's default).
    diffuse, specular, refraction, diffraction : bool
        Interaction types (see the module docstring for the defaults).
    seed : int
        Solver seed, fixed across frames.
    vertex_doppler : bool
        Use per-vertex velocities from the PLYs where present (else Sionna's per-object velocity).
    label : str
        ``"first"``, ``"last"`` or ``"moving"`` (see the module docstring).
    track_kernels : bool
        Record Dr.Jit kernel launches per frame in :attr:`last_stats` / :attr:`stats`.
    deterministic : bool
        Sionna's deterministic candidate generator (same paths in the same order on every run, a
        little more memory). With the default, a fixed seed gives the same rays, but the order
        of the paths, and rarely a path near a triangle edge, can differ between runs.

    :attr:`stats` figures: ``num_paths`` (valid paths of the frame, all element pairs).
    """

    name = "path"
    FIXED_SETTINGS = {"los": False, "synthetic_array": False}
    LABELS = ("first", "last", "moving")

    def __init__(self, max_depth: int = 2, samples_per_src: int = 100_000, max_num_paths_per_src: int = 1_000_000,
                 diffuse: bool = True, specular: bool = True, refraction: bool = False, diffraction: bool = False,
                 seed: int = 1, vertex_doppler: bool = True, label: str = "first", track_kernels: bool = True,
                 deterministic: bool = False):
        if label not in self.LABELS:
            raise PathEngineError(f"PathEngine: label={label!r} is unknown; choose one of {', '.join(self.LABELS)}")
        for name, value, low in (("max_depth", max_depth, 1), ("samples_per_src", samples_per_src, 1),
                                 ("max_num_paths_per_src", max_num_paths_per_src, 1), ("seed", seed, 0)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise PathEngineError(
                    f"PathEngine: {name} must be an integer >= {low}, got {value!r}"
                    + (" (with los=False a depth-0 radar sees nothing)" if name == "max_depth" else "")
                )
        super().__init__(track_kernels=track_kernels)
        self.max_depth = int(max_depth)
        self.samples_per_src = int(samples_per_src)
        self.max_num_paths_per_src = int(max_num_paths_per_src)
        self.diffuse = bool(diffuse)
        self.specular = bool(specular)
        self.refraction = bool(refraction)
        self.diffraction = bool(diffraction)
        self.seed = int(seed)
        self.vertex_doppler = bool(vertex_doppler)
        self.label = label
        self.deterministic = bool(deterministic)
        self._solver = PathSolver(deterministic=self.deterministic)

    def _settings(self) -> dict:
        return {"max_depth": self.max_depth, "samples_per_src": self.samples_per_src,
                "max_num_paths_per_src": self.max_num_paths_per_src, "diffuse": self.diffuse,
                "specular": self.specular, "refraction": self.refraction, "diffraction": self.diffraction,
                "seed": self.seed, "deterministic": self.deterministic, "vertex_doppler": self.vertex_doppler,
                "label": self.label}

    # ------------------------------------------------------------------ hooks
    def _load(self, scene, animation: Animation, radar) -> _State:
        """The radar's Tx and Rx (its exact element layout) and a velocity parameter per object."""
        wavelength = float(scene.wavelength[0]) if hasattr(scene.wavelength, "__len__") else float(scene.wavelength)
        pattern = antenna_pattern_registry.get(radar.antenna_pattern)(polarization="V")
        pattern_rx = antenna_pattern_registry.get(radar.antenna_pattern)(polarization="V")

        def array(positions, pat):
            p = np.asarray(positions, dtype=float) / wavelength
            return AntennaArray(pat, mi.Point3f(mi.Float(p[:, 0]), mi.Float(p[:, 1]), mi.Float(p[:, 2])))

        scene.tx_array = array(radar.tx_positions, pattern)
        scene.rx_array = array(radar.rx_positions, pattern_rx)
        tx = Transmitter("radar-tx", position=mi.Point3f(0, 0, 0), orientation=mi.Point3f(0, 0, 0))
        rx = Receiver("radar-rx", position=mi.Point3f(0, 0, 0), orientation=mi.Point3f(0, 0, 0))
        scene.add(tx)
        scene.add(rx)

        names_by_id = {}
        for name, obj in scene.objects.items():
            names_by_id[int(obj.object_id)] = name
            obj.velocity = mi.Vector3f(0.0, 0.0, 0.0)  # create every velocity parameter up front
        return _State(tx, rx, names_by_id)

    def _geometry_changed(self) -> None:
        self._loaded.scene.scene_geometry_updated()

    def _frame_echoes(self, animation: Animation, radar, frame: int, pose: RadarPose):
        self._set_pose(pose)
        velocities = self._update_velocities(animation, frame)
        buf, src_positions, tgt_positions = self._trace(self._loaded.scene)
        echoes, num_paths = self._to_echoes(buf, src_positions, tgt_positions, velocities, radar)
        return echoes, {"num_paths": num_paths}

    # ------------------------------------------------------------------ per frame
    def _update_velocities(self, animation: Animation, frame: int) -> dict:
        """Set Sionna's object velocities; returns the velocity used per object (m/s)."""
        state, loaded = self._state, self._loaded
        used = {}
        fr = animation.frame(frame)
        for name, obj in loaded.scene.objects.items():
            v = np.asarray(fr.objects.get(name, np.zeros(3)), dtype=float)
            if self.vertex_doppler and loaded.vertex_velocity.get(name) is not None:
                v = np.zeros(3)  # the per-vertex field replaces Sionna's rigid velocity
            used[name] = v
            if name not in state.velocities or not np.array_equal(state.velocities[name], v):
                obj.velocity = mi.Vector3f(float(v[0]), float(v[1]), float(v[2]))
                state.velocities[name] = v
        return used

    def _set_pose(self, pose: RadarPose) -> None:
        state = self._state
        key = _pose_key(pose)
        if state.pose == key:
            return
        p = [float(x) for x in pose.position]
        o = [float(x) for x in pose.orientation]
        for dev in (state.tx, state.rx):
            # opaque: a literal pose would be baked into the first frame's kernels
            position, orientation = mi.Point3f(*p), mi.Point3f(*o)
            dr.make_opaque(position, orientation)
            dev.position = position
            dev.orientation = orientation
        state.pose = key

    def _trace(self, scene):
        """The solver's steps up to the path buffer (no ``Paths`` tensors, see the module docstring)."""
        candidates = trace_candidates(
            self._solver, scene, samples_per_src=self.samples_per_src,
            max_num_paths_per_src=self.max_num_paths_per_src, max_depth=self.max_depth,
            specular_reflection=self.specular, diffuse_reflection=self.diffuse, refraction=self.refraction,
            diffraction=self.diffraction, seed=self.seed)
        found, capacity = candidates.found, candidates.capacity
        if found >= capacity:
            # Sionna keeps counting past the end of its candidate buffer and silently drops the
            # rest (measured: a closed room, diffuse only, 1e6 rays per source: 250k paths kept of
            # ~12M, 17 dB of power lost and the body gone), so a full buffer is an error here.
            raise PathEngineError(
                f"PathEngine: {found} candidate paths filled Sionna's path buffer ({capacity} = "
                f"max_num_paths_per_src={self.max_num_paths_per_src} x {capacity // self.max_num_paths_per_src} "
                f"sources) and the rest would be dropped silently; raise max_num_paths_per_src "
                f"(e.g. to {4 * self.max_num_paths_per_src}) or lower samples_per_src={self.samples_per_src}")
        buf = solve_fields(self._solver, scene, candidates, samples_per_src=self.samples_per_src,
                           diffraction=self.diffraction)
        return buf, candidates.src_positions, candidates.tgt_positions

    # ------------------------------------------------------------------ buffer -> Echoes
    def _to_echoes(self, buf, src_positions, tgt_positions, velocities: dict, radar):
        loaded, names_by_id = self._loaded, self._state.names_by_id
        m_tx, n_rx = radar.num_tx, radar.num_rx
        num = int(buf.buffer_size)
        if num == 0:
            e = Echoes.empty(m_tx, n_rx)
            e.labels = np.zeros((m_tx, n_rx, 0), dtype=str)
            return e, 0
        a = buf.a[0][0]
        arrays = [buf.source_indices, buf.target_indices, dr.real(a), dr.imag(a), buf.tau, buf.doppler,
                  buf.shapes, buf.interaction_types, buf.primitives, buf.vertices_x, buf.vertices_y,
                  buf.vertices_z, src_positions, tgt_positions]
        dr.eval(*arrays)
        src = buf.source_indices.numpy().astype(np.int64)
        tgt = buf.target_indices.numpy().astype(np.int64)
        gain = dr.real(a).numpy().astype(np.float64) + 1j * dr.imag(a).numpy().astype(np.float64)
        tau = buf.tau.numpy().astype(np.float64)
        doppler = buf.doppler.numpy().astype(np.float64)
        depth = buf.depth_dim_size
        shapes = np.asarray(buf.shapes.array.numpy(), dtype=np.int64).reshape(num, depth)
        types = np.asarray(buf.interaction_types.array.numpy(), dtype=np.int64).reshape(num, depth)
        valid_int = (types != InteractionType.NONE) & (shapes != int(INVALID_SHAPE))

        # --- per-vertex-velocity Doppler
        vv_names = [n for n, v in loaded.vertex_velocity.items() if v is not None] if self.vertex_doppler else []
        if vv_names:
            prims = np.asarray(buf.primitives.array.numpy(), dtype=np.int64).reshape(num, depth)
            verts = np.stack([np.asarray(buf.vertices_x.array.numpy(), dtype=np.float64),
                              np.asarray(buf.vertices_y.array.numpy(), dtype=np.float64),
                              np.asarray(buf.vertices_z.array.numpy(), dtype=np.float64)], axis=-1).reshape(num, depth, 3)
            src_pos = np.stack([src_positions.x.numpy(), src_positions.y.numpy(), src_positions.z.numpy()], -1)
            tgt_pos = np.stack([tgt_positions.x.numpy(), tgt_positions.y.numpy(), tgt_positions.z.numpy()], -1)
            doppler = doppler + self._vertex_doppler(src_pos[src].astype(float), tgt_pos[tgt].astype(float), verts,
                                                     valid_int, shapes, prims, loaded, vv_names,
                                                     SPEED_OF_LIGHT / radar.fc)

        # --- labels
        id_list = sorted(names_by_id)
        lut_ids = np.array(id_list, dtype=np.int64)
        lut_names = np.array([names_by_id[i] for i in id_list], dtype=object)
        pos = np.searchsorted(lut_ids, shapes)
        pos = np.clip(pos, 0, len(lut_ids) - 1)
        found = valid_int & (lut_ids[pos] == shapes)
        per_int = np.where(found, lut_names[pos], "")
        n_int = valid_int.sum(axis=1)
        rows = np.arange(num)
        first = per_int[:, 0]
        last = per_int[rows, np.maximum(n_int - 1, 0)]
        if self.label == "first":
            labels = first
        elif self.label == "last":
            labels = last
        else:
            moving = {n for n, v in velocities.items() if np.any(v != 0)}
            moving |= {n for n in vv_names if np.any(loaded.vertex_velocity[n] != 0)}
            is_moving = np.vectorize(lambda s: s in moving, otypes=[bool])(per_int) & found
            has = is_moving.any(axis=1)
            idx = np.argmax(is_moving, axis=1)
            labels = np.where(has, per_int[rows, idx], first)

        # --- scatter into [num_tx, num_rx, P]
        link = src * n_rx + tgt
        order = np.argsort(link, kind="stable")
        link_sorted = link[order]
        counts = np.bincount(link, minlength=m_tx * n_rx)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        rank = np.empty(num, dtype=np.int64)
        rank[order] = np.arange(num) - starts[link_sorted]
        p_max = int(counts.max())
        shape = (m_tx, n_rx, p_max)
        out_a = np.zeros(shape, dtype=np.complex128)
        out_tau = np.zeros(shape)
        out_dop = np.zeros(shape)
        out_lab = np.full(shape, "", dtype=object)
        out_a[src, tgt, rank] = gain
        out_tau[src, tgt, rank] = tau
        out_dop[src, tgt, rank] = doppler
        out_lab[src, tgt, rank] = labels
        return Echoes(out_a, out_tau, out_dop, out_lab.astype(str)), num

    @staticmethod
    def _vertex_doppler(src_pos, tgt_pos, verts, valid_int, shapes, prims, loaded, vv_names, wavelength):
        """Sum over interactions on meshes with vertex velocities of v(p).(k_out - k_in)/lambda (Hz)."""
        num, depth, _ = verts.shape
        n_int = valid_int.sum(axis=1)
        # polyline: src, v_1..v_d, tgt (padded with the target after the last interaction)
        pts = np.empty((num, depth + 2, 3))
        pts[:, 0] = src_pos
        pts[:, 1:depth + 1] = verts
        for d in range(depth):
            pad = n_int <= d
            pts[pad, d + 1] = tgt_pos[pad]
        pts[:, depth + 1] = tgt_pos
        seg = np.diff(pts, axis=1)
        norm = np.linalg.norm(seg, axis=-1, keepdims=True)
        k = np.divide(seg, norm, out=np.zeros_like(seg), where=norm > 0)
        extra = np.zeros(num)
        ids = {int(obj.object_id): name for name, obj in loaded.scene.objects.items() if name in vv_names}
        for d in range(depth):
            k_in, k_out = k[:, d], k[:, d + 1]
            for oid, name in ids.items():
                sel = valid_int[:, d] & (shapes[:, d] == oid)
                if not np.any(sel):
                    continue
                faces = loaded.faces[name][prims[sel, d]]
                vpos = loaded.vertices[name]
                w = barycentric_weights(verts[sel, d], vpos[faces[:, 0]], vpos[faces[:, 1]], vpos[faces[:, 2]])
                v = interpolate(loaded.vertex_velocity[name], faces, w)
                extra[sel] += np.einsum("ij,ij->i", v, k_out[sel] - k_in[sel]) / wavelength
        return extra


__all__ = ["PathEngine", "PathEngineError", "RADAR_MIN_SEGMENT_LENGTH"]
