r"""Motion within the CPI and the moving radar, for the engines: the frame's kinematics and what it adds
to the echoes.

Two effects, each derived in :mod:`sionnafmcw.kinematics`:

* **the moving radar** (always on: the radar pose of a frame carries its velocity, zero for a radar
  at rest): every element pair's Doppler gets the radar's share, the *ego-Doppler*
  :math:`(\dot{\mathbf t}_m\cdot\hat{\mathbf k}_m - \dot{\mathbf r}_n\cdot\hat{\mathbf k}'_n)/\lambda`
  (:func:`~sionnafmcw.kinematics.ego_doppler`), static clutter included, so every Doppler is relative;
* **motion within the CPI** (the engines' option ``cpi_motion="quadratic"``; ``"frozen"`` keeps
  the CPI at the frame's velocities, the model without motion within the CPI): every contribution gets its
  Doppler rate :math:`\dot f_D = -\ddot L/\lambda` from the accelerations of its interaction
  points and of the radar (:class:`~sionnafmcw.echoes.Echoes`), and the synthesizer applies the
  quadratic delay across the CPI's chirps.

Where the accelerations come from: the animation's (:meth:`~sionnafmcw.animation.Animation.object_acceleration`,
:meth:`~sionnafmcw.animation.Animation.vertex_accelerations`: central differences of the frames'
velocities, and for turning rigid objects :math:`\mathbf a_c + \boldsymbol\alpha\times\mathbf r
+ \boldsymbol\omega\times(\boldsymbol\omega\times\mathbf r)`) and the radar track's
(:class:`~sionnafmcw.animation.RadarPose`). :math:`\ddot L` is taken once per path, between the
centres of the Tx and of the Rx elements (the array spans centimetres: the element pairs' rates
differ by the relative :math:`|\boldsymbol\delta|/R`, some 0.3 % at 3 m, of a term that is itself
a few radians over a CPI), and summed over the path's segments:

* PO samples and diffuse scatterers are material points: the segment formula on their kinematics;
* a specular reflection of a traced path (Sionna's specular chains with ``multibounce="sionna"``,
  the specular interactions of a path with a diffuse one) is unfolded: the segment after it starts
  at the mirror image of the segment's start (:func:`~sionnafmcw.kinematics.mirror_image`, the
  mirror's normal :math:`\propto\hat{\mathbf k}_{out} - \hat{\mathbf k}_{in}` and, for a turning rigid
  object, its rotation); the PO chains' further bounces likewise carry the image of the render's
  origin through their mirrors (:mod:`~sionnafmcw.engines.po_render`, ``source_velocity``,
  ``source_acceleration``). A deforming mesh's mirror is taken as translating (its normal's turn
  is not known at a point).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..kinematics import PointKinematics, ego_doppler, element_kinematics, mirror_image, range_acceleration

#: The values of the engines' option ``cpi_motion``.
CPI_MOTIONS = ("frozen", "quadratic")


def check_cpi_motion(value, error, engine: str) -> str:
    """``value`` if it is one of :data:`CPI_MOTIONS`, else ``error`` (an exception class) naming the option."""
    if value not in CPI_MOTIONS:
        raise error(f"{engine}: cpi_motion={value!r} is unknown; choose one of {', '.join(CPI_MOTIONS)} "
                    "('frozen': the frame's velocities over the whole CPI; 'quadratic': positions, velocities "
                    "and accelerations, the Doppler sweeping across the CPI)")
    return value


@dataclass
class FrameMotion:
    """The kinematics of one frame that the echoes need beyond the frame's velocities.

    ``pose``: the radar's :class:`~sionnafmcw.animation.RadarPose` (with its motion); ``tx``, ``rx``:
    world kinematics of the Tx and Rx elements ``[M]``, ``[N]``; ``tx_centre``, ``rx_centre``: of the
    centres of the Tx and of the Rx elements; ``quadratic``: Doppler rates wanted
    (``cpi_motion="quadratic"``); ``accelerations``, ``vertex_accelerations``,
    ``angular_velocities``, ``angular_accelerations``: per object name (m/s^2 of the centroid,
    ``[V, 3]`` or None, rad/s, rad/s^2; filled only when ``quadratic``).
    """

    pose: object
    tx: PointKinematics
    rx: PointKinematics
    tx_centre: PointKinematics
    rx_centre: PointKinematics
    quadratic: bool
    accelerations: dict = field(default_factory=dict)
    vertex_accelerations: dict = field(default_factory=dict)
    angular_velocities: dict = field(default_factory=dict)
    angular_accelerations: dict = field(default_factory=dict)

    @property
    def radar_moves(self) -> bool:
        """The radar moves or turns in this frame (its elements have a velocity)."""
        return bool(self.pose.moving)

    @property
    def radar_at_rest(self) -> bool:
        """No velocity and, with ``quadratic``, no acceleration either: static clutter has neither Doppler
        nor Doppler rate (what the path engine's static scene needs)."""
        if self.radar_moves:
            return False
        if self.quadratic:
            return not (np.any(self.pose.acceleration != 0) or np.any(self.pose.angular_acceleration != 0))
        return True

    def object_acceleration(self, name: str) -> np.ndarray:
        return self.accelerations.get(name, np.zeros(3))

    def spin(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """``(angular velocity, angular acceleration)`` of ``name`` (zeros when unknown)."""
        return self.angular_velocities.get(name, np.zeros(3)), self.angular_accelerations.get(name, np.zeros(3))


def frame_motion(animation, frame: int, pose, radar, names, quadratic: bool, vertex_doppler: bool = True) -> FrameMotion:
    """:class:`FrameMotion` of ``frame`` for the objects ``names`` at the radar ``pose``; with ``quadratic`` the
    objects' accelerations from the animation (the per-vertex field only with ``vertex_doppler``)."""
    tx = element_kinematics(pose, radar.tx_positions)
    rx = element_kinematics(pose, radar.rx_positions)
    centres = element_kinematics(pose, np.stack([radar.tx_positions.mean(axis=0), radar.rx_positions.mean(axis=0)]))
    motion = FrameMotion(pose, tx, rx, centres[0], centres[1], bool(quadratic))
    if quadratic:
        for name in names:
            motion.accelerations[name] = animation.object_acceleration(frame, name) \
                if name in animation.frame(frame).objects else np.zeros(3)
            try:
                field_a = animation.vertex_accelerations(frame, name) if vertex_doppler else None
            except (KeyError, ValueError):   # not a PLY mesh: it does not move
                field_a = None
            motion.vertex_accelerations[name] = field_a
            motion.angular_velocities[name] = animation.angular_velocity(frame, name)
            motion.angular_accelerations[name] = animation.angular_acceleration(frame, name)
    return motion


def with_ego_doppler(doppler, motion: FrameMotion, first_points, last_points, wavelength: float) -> np.ndarray:
    """``doppler [M, N, P]`` plus the radar's share (:func:`~sionnafmcw.kinematics.ego_doppler`) when it
    moves; ``doppler`` itself when it does not."""
    if not motion.radar_moves or np.shape(doppler)[-1] == 0:
        return doppler
    return doppler + ego_doppler(motion.tx, motion.rx, first_points, last_points, wavelength)


def broadcast_rates(rates, shape) -> np.ndarray:
    """Per-path Doppler rates ``[P]`` as the ``[M, N, P]`` of every element pair (a read-only view)."""
    return np.broadcast_to(np.asarray(rates, float), shape)


# ---------------------------------------------------------------------------------------- traced paths
def interaction_accelerations(paths, loaded, motion: FrameMotion) -> np.ndarray:
    """Accelerations ``[P, D, 3]`` (m/s^2) of the interaction points: the per-vertex field interpolated
    on meshes that have one (:attr:`FrameMotion.vertex_accelerations`), else the object's centroid
    acceleration."""
    from .loaded_scene import barycentric_weights, interpolate

    valid = paths.valid_interactions
    out = np.zeros(paths.vertices.shape)
    for name, obj in loaded.scene.objects.items():
        on = valid & (paths.shapes == int(obj.object_id))
        if not np.any(on):
            continue
        field_a = motion.vertex_accelerations.get(name)
        if field_a is not None:
            faces = loaded.faces[name][paths.primitives[on]]
            vpos = loaded.vertices[name]
            w = barycentric_weights(paths.vertices[on], vpos[faces[:, 0]], vpos[faces[:, 1]], vpos[faces[:, 2]])
            out[on] = interpolate(field_a, faces, w)
        else:
            out[on] = motion.object_acceleration(name)
    return out


def traced_range_accelerations(paths, velocities, accelerations, names_by_id: dict, motion: FrameMotion,
                               source: PointKinematics, target: PointKinematics) -> np.ndarray:
    r""":math:`\ddot L` ``[P]`` (m/s^2) of traced paths from ``source`` to ``target`` (the Tx and Rx centres,
    or per path ``[P]``), interaction points with ``velocities``, ``accelerations`` ``[P, D, 3]``: a
    segment per material point (diffuse, refraction), the unfolded segment through a specular
    reflection (module docstring)."""
    from ..sionna_rt import InteractionType

    num, depth, _ = paths.vertices.shape
    valid = paths.valid_interactions
    specular = valid & (paths.types == int(InteractionType.SPECULAR))
    shape = (num, 3)
    src = PointKinematics(*(np.broadcast_to(np.asarray(x, float), shape).copy()
                            for x in (source.position, source.velocity, source.acceleration)))
    start = np.broadcast_to(np.asarray(source.position, float), shape)     # the physical source points
    end = np.broadcast_to(np.asarray(target.position, float), shape)
    total = np.zeros(num)
    for i in range(depth):
        active = valid[:, i]
        if not np.any(active):
            break
        q = PointKinematics(paths.vertices[:, i], velocities[:, i], accelerations[:, i])
        mirror = specular[:, i]
        material = active & ~mirror
        if np.any(material):
            total[material] += range_acceleration(src.position[material], src.velocity[material],
                                                  src.acceleration[material], q.position[material],
                                                  q.velocity[material], q.acceleration[material])
        if np.any(mirror):
            idx = np.flatnonzero(mirror)
            prev = paths.vertices[idx, i - 1] if i else start[idx]
            after = paths.vertices[idx, i + 1] if i + 1 < depth else end[idx]
            after = np.where((i + 1 < paths.num_interactions[idx])[:, None], after, end[idx])
            k_in = q.position[idx] - prev
            k_out = after - q.position[idx]
            k_in /= np.linalg.norm(k_in, axis=-1, keepdims=True)
            k_out /= np.linalg.norm(k_out, axis=-1, keepdims=True)
            normal = k_out - k_in
            normal /= np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-300)
            omega = np.zeros((idx.size, 3))
            alpha = np.zeros((idx.size, 3))
            for shape_id in np.unique(paths.shapes[idx, i]):
                name = names_by_id.get(int(shape_id))
                if name is not None:
                    sel = paths.shapes[idx, i] == shape_id
                    omega[sel], alpha[sel] = motion.spin(name)
            image = mirror_image(src[idx], q[idx], normal, omega, alpha)
            src.position[idx], src.velocity[idx], src.acceleration[idx] = (image.position, image.velocity,
                                                                           image.acceleration)
        # a material point becomes the next segment's start
        if np.any(material):
            src.position[material] = q.position[material]
            src.velocity[material] = q.velocity[material]
            src.acceleration[material] = q.acceleration[material]
    tgt = [np.broadcast_to(np.asarray(x, float), shape) for x in (target.position, target.velocity, target.acceleration)]
    return total + range_acceleration(src.position, src.velocity, src.acceleration, *tgt)


def path_ends(paths) -> tuple[np.ndarray, np.ndarray]:
    """The first and the last interaction point ``[P, 3]`` of every traced path (the ego-Doppler's directions)."""
    rows = np.arange(paths.num_paths)
    return paths.vertices[:, 0], paths.vertices[rows, np.maximum(paths.num_interactions - 1, 0)]


# ---------------------------------------------------------------------------------------- PO renders
def render_range_accelerations(bounce, motion: FrameMotion) -> np.ndarray:
    r""":math:`\ddot L` ``[P]`` (m/s^2) of the samples of a PO :class:`~sionnafmcw.engines.po_render.Render`
    rendered with accelerations: from the (image of the) render's origin to the sample, and on to
    the centre of the Rx elements (module docstring)."""
    s = bounce.samples
    rx = motion.rx_centre
    return (range_acceleration(bounce.source, bounce.source_velocity, bounce.source_acceleration, s.position,
                               s.velocity, bounce.acceleration)
            + range_acceleration(s.position, s.velocity, bounce.acceleration, rx.position, rx.velocity,
                                 rx.acceleration))


__all__ = ["CPI_MOTIONS", "FrameMotion", "broadcast_rates", "check_cpi_motion", "frame_motion",
           "interaction_accelerations", "path_ends", "render_range_accelerations", "traced_range_accelerations",
           "with_ego_doppler"]
