r"""A person in an animation: the segment body on a moving skeleton, placed in the world, frame by frame.

:class:`MocapPerson` drives the :class:`~.segments.SegmentBody` with a BVH clip (the numpy route:
parser, forward kinematics and interpolation of :mod:`.skeleton`, no Blender);
:class:`PosedPerson` holds one posture of a clip and moves it with small parametric motions
(postural sway, breathing, heartbeat: :mod:`sionnafmcw.scenes.vitals`). Both give, per frame,
every segment's rigid motion (:class:`~sionnafmcw.animation.rigid.RigidMotion`), and
:func:`add_person` puts one person into an :class:`~sionnafmcw.scenes.writer.AnimationWriter`
under a name prefix, so that several people share one scene.

Time and placement
------------------
Animation frame :math:`i` is at :math:`t_i = i/\mathrm{fps}` and shows the clip at
:math:`\tau_i = \tau_0 + r\,t_i` (``start`` :math:`\tau_0` s into the clip, ``playback_rate``
:math:`r`). The clip is placed by a rotation about the vertical and a translation
(:func:`~.skeleton.placement_matrix`): at :math:`\tau_0` the root's ground point is at
``position`` (x, y) and the body faces ``heading`` (rad from +x towards +y; the facing direction is
the rest pose's forward turned by the root's rotation, projected on the floor); with ``floor`` the
lowest skin point over the animation's frames is put on :math:`z = 0`, else the clip's own
:math:`y = 0` becomes :math:`z = 0`.

Velocities
----------
Frame :math:`i`'s velocities are differences of the poses at :math:`t_i \pm h`, :math:`h` =
``velocity_step`` frames: the centroid's :math:`\mathbf v_c = (\mathbf c(t_+) - \mathbf c(t_-))/(t_+ -
t_-)` and :math:`\boldsymbol\omega = \log(\mathbf R(t_+)\mathbf R(t_-)^T)^\vee/(t_+ - t_-)`
(:func:`~sionnafmcw.animation.rigid.angular_velocity`), one-sided (:math:`t_- = t_i` or
:math:`t_+ = t_i`) at the first and last frames. With the default :math:`h` = 1/2 frame this is
the Blender exporter's own scheme (:mod:`sionnafmcw.blender.export`), so the numpy and the Blender
routes differ only by their interpolation of the clip between its frames (slerp against Blender's
normalised linear interpolation, :func:`~.skeleton.nlerp_slerp_bound`) and by float32 rounding.
A smaller :math:`h` approaches the instantaneous velocity of the interpolated motion (the
truncation error of a central difference is :math:`h^2\dddot{\mathbf x}/6`).
"""

from __future__ import annotations

import math

import numpy as np

from ..animation.rigid import RigidMotion, angular_velocity, area_centroid, transform_matrix
from ..scenes import meshes
from .segments import SegmentBody
from .bvh import BvhClip
from .skeleton import CMU_UNIT, Y_UP_TO_Z_UP, ClipMotion, placement_matrix

#: Default half-width of the velocity differences, in frames (the Blender exporter's).
VELOCITY_STEP_FRAMES = 0.5


def _facing_yaw(body: SegmentBody, root_rotation) -> float:
    f = np.asarray(root_rotation) @ body.forward
    if math.hypot(f[0], f[1]) < 1e-6:     # lying face up or down: the body's up axis points along the floor
        f = np.asarray(root_rotation) @ body.up
    return math.atan2(f[1], f[0])


class _Person:
    """What :func:`add_person` needs: ``body`` (segments), ``fps``, ``num_frames``, :meth:`poses`."""

    body: SegmentBody
    fps: float
    num_frames: int
    velocity_step: float

    @property
    def segment_names(self) -> list[str]:
        return self.body.names

    @property
    def times(self) -> np.ndarray:
        return np.arange(self.num_frames) / self.fps

    def poses(self, times) -> dict:  # pragma: no cover - interface
        """``{segment: (rotations [T, 3, 3], translations [T, 3])}`` of the segment frames at animation ``times``."""
        raise NotImplementedError

    def _centroids(self) -> dict:
        if not hasattr(self, "_centroid_cache"):
            self._centroid_cache = {k: area_centroid(s.vertices, s.faces) for k, s in self.body.segments.items()}
        return self._centroid_cache

    def sample_times(self, frames=None):
        """``(t, t_minus, t_plus)`` [N] of the frames (module docstring: one-sided at the ends)."""
        frames = np.arange(self.num_frames) if frames is None else np.atleast_1d(np.asarray(frames, int))
        t = frames / self.fps
        h = self.velocity_step / self.fps
        t_minus = np.where(frames > 0, t - h, t)
        t_plus = np.where((frames < self.num_frames - 1) | (self.num_frames == 1), t + h, t)
        return t, t_minus, t_plus

    def motions(self, frames=None) -> list[dict]:
        """Per frame, ``{segment: RigidMotion}`` (module docstring)."""
        t, tm, tp = self.sample_times(frames)
        now, before, after = self.poses(t), self.poses(tm), self.poses(tp)
        cents = self._centroids()
        out = []
        for i in range(t.size):
            span = tp[i] - tm[i]
            frame = {}
            for k in self.segment_names:
                r, p = now[k][0][i], now[k][1][i]
                rm, pm = before[k][0][i], before[k][1][i]
                rp, pp = after[k][0][i], after[k][1][i]
                c = cents[k]
                v = (rp @ c + pp - rm @ c - pm) / span
                w = angular_velocity(rp, rm, span)
                frame[k] = RigidMotion(r, p, v, w, r @ c + p)
            out.append(frame)
        return out

    def truth(self, frames=None) -> dict:
        """``{segment: (centroid positions [N, 3], centroid velocities [N, 3])}`` of the frames."""
        ms = self.motions(frames)
        return {k: (np.array([m[k].centroid for m in ms]), np.array([m[k].velocity for m in ms]))
                for k in self.segment_names}

    def world_vertices(self, frame: int) -> dict:
        """``{segment: world vertices [V, 3]}`` in frame ``frame``."""
        poses = self.poses(np.array([frame / self.fps]))
        return {k: s.vertices @ poses[k][0][0].T + poses[k][1][0] for k, s in self.body.segments.items()}

    def keypoint_anchors(self) -> dict:
        """``{keypoint: (segment, offset [3])}`` (:mod:`sionnafmcw.scenes.keypoints`)."""
        from ..scenes.keypoints import segment_body_anchors

        return segment_body_anchors(self.body)

    def keypoints(self, frames=None) -> np.ndarray:
        """World keypoints ``[N, K, 3]`` (m) of the frames (default all), in
        :data:`~sionnafmcw.scenes.keypoints.KEYPOINTS` order; NaN where the body has no such joint."""
        from ..scenes.keypoints import keypoint_positions

        frames = np.arange(self.num_frames) if frames is None else np.atleast_1d(np.asarray(frames, int))
        return keypoint_positions(self.poses(frames / self.fps), self.keypoint_anchors())

    def footprints(self, frames=None) -> tuple[np.ndarray, np.ndarray]:
        """Footprint discs ``(centres [N, 2], radii [N])`` (m) of the frames (default all): the body's
        horizontal extent (:func:`sionnafmcw.scenes.layout.person_footprints`)."""
        from ..scenes.layout import person_footprints, segment_capsules

        frames = np.arange(self.num_frames) if frames is None else np.atleast_1d(np.asarray(frames, int))
        if "_capsules" not in self.__dict__:
            self._capsules = segment_capsules({k: s.vertices for k, s in self.body.segments.items()})
        return person_footprints(self.poses(frames / self.fps), self._capsules)


class MocapPerson(_Person):
    """The segment body moving with a BVH clip (the numpy route; module docstring).

    Parameters
    ----------
    clip : BvhClip
    unit : float
        Metres per BVH unit (:data:`~.skeleton.CMU_UNIT` for the CMU database).
    fps : float
        Frame rate of the animation (1/s).
    num_frames : int, optional
        Frames to make; default as many as fit between ``start`` and the clip's end.
    start : float, optional
        Clip time :math:`\\tau_0` (s) of frame 0; default the first usable time (the clip's frame 1 with
        ``skip_first_frame``: CMU clips' frame 0 is an added T-pose), or its end with ``reverse``.
    playback_rate : float
        Clip seconds per animation second.
    reverse : bool
        Play the clip backwards, :math:`\\tau = \\tau_0 - r t` (e.g. a sit-down from a stand-up).
    position, heading : the start pose on the floor (m) and the facing direction (rad).
    floor : bool
        Put the lowest skin point over the animation on z = 0.
    height, build, mesh_edge : the body (:class:`~.segments.SegmentBody`).
    velocity_step : float
        Half-width :math:`h` of the velocity differences, frames.
    """

    def __init__(self, clip: BvhClip, unit: float = CMU_UNIT, fps: float = 30.0, num_frames: int | None = None,
                 start: float | None = None, playback_rate: float = 1.0, position=(0.0, 0.0), heading: float = 0.0,
                 floor: bool = True, height: float | None = None, build: str = "male",
                 mesh_edge: float = meshes.BODY_MESH_EDGE, velocity_step: float = VELOCITY_STEP_FRAMES, axes=Y_UP_TO_Z_UP, reverse: bool = False,
                 skip_first_frame: bool = True):
        where = clip.path or "BVH clip"
        if not (fps > 0 and math.isfinite(fps)):
            raise ValueError(f"MocapPerson: fps must be > 0, got {fps!r}")
        if not (playback_rate > 0 and math.isfinite(playback_rate)):
            raise ValueError(f"MocapPerson: playback_rate must be > 0, got {playback_rate!r}")
        if not (0.0 < velocity_step <= 1.0):
            raise ValueError(f"MocapPerson: velocity_step must be in (0, 1] frames, got {velocity_step!r}")
        self.clip = clip
        self.fps = float(fps)
        self.playback_rate = float(playback_rate)
        self.velocity_step = float(velocity_step)
        self.reverse = bool(reverse)
        self.motion = ClipMotion(clip, unit, axes)
        self.body = SegmentBody(self.motion, height=height, build=build, max_edge=mesh_edge)
        lo = clip.frame_time if (skip_first_frame and clip.num_frames > 1) else 0.0
        hi = clip.duration
        if start is None:
            start = hi if self.reverse else lo
        if not (lo - 1e-9 <= start <= hi + 1e-9):
            raise ValueError(f"{where}: start {start} s is outside the clip's usable times {lo:.4f}..{hi:.4f} s"
                             + (" (frame 0, an added T-pose in CMU clips, is skipped)" if lo > 0 else ""))
        self.start = float(start)
        room = (self.start - lo) if self.reverse else (hi - self.start)
        available = int(math.floor(room * self.fps / self.playback_rate + 1e-6)) + 1
        if num_frames is None:
            num_frames = available
        if num_frames < 1 or num_frames > available:
            raise ValueError(f"{where}: {num_frames} frames at {self.fps:g} fps from {self.start:.4f} s (playback "
                             f"rate {self.playback_rate:g}{', reversed' if self.reverse else ''}) do not fit in the "
                             f"clip's usable {lo:.4f}..{hi:.4f} s: at most {available}; lower num_frames or move start")
        self.num_frames = int(num_frames)
        self.motion = self.motion.placed(self._placement(position, heading, floor))

    # ---------------------------------------------------------------- placement
    def clip_times(self, times) -> np.ndarray:
        """Clip time :math:`\\tau_0 + r t` (s) of animation times ``times``."""
        sign = -1.0 if self.reverse else 1.0
        return self.start + sign * self.playback_rate * np.asarray(times, float)

    def _placement(self, position, heading, floor) -> np.ndarray:
        rot, org = self.motion.joint_frames(self.clip_times([0.0]))
        yaw = float(heading) - _facing_yaw(self.body, rot[0, 0])
        m = placement_matrix(yaw, (0.0, 0.0, 0.0))
        root_xy = (m[:3, :3] @ org[0, 0])[:2]
        m[:2, 3] = np.asarray(position, float) - root_xy
        if floor:
            m[2, 3] = -self._lowest_point(m)
        return m

    def _lowest_point(self, placement) -> float:
        """Lowest skin point (m) over the frames with ``placement`` (rotation about z: heights unchanged)."""
        rot, org = self.motion.joint_frames(self.clip_times(self.times))
        lowest = np.inf
        for seg in self.body.segments.values():
            z = np.einsum("tb,vb->tv", rot[:, seg.joint, 2, :], seg.vertices) + org[:, seg.joint, 2:3]
            lowest = min(lowest, float(z.min()))
        return lowest + placement[2, 3]

    @property
    def placement(self) -> np.ndarray:
        """The 4x4 placement of the clip in the world."""
        return self.motion.placement

    # ---------------------------------------------------------------- poses
    def poses(self, times) -> dict:
        times = np.atleast_1d(np.asarray(times, float))
        rot, org = self.motion.joint_frames(self.clip_times(times))
        return {k: (rot[:, s.joint], org[:, s.joint]) for k, s in self.body.segments.items()}

    def joint_positions(self, times) -> np.ndarray:
        """World joint origins ``[T, J, 3]`` (m) at animation ``times``."""
        return self.motion.joint_frames(self.clip_times(times))[1]


class PosedPerson(_Person):
    """One posture of a clip (its pose at clip time ``posture_time``), placed like :class:`MocapPerson`,
    moved by ``movements``: callables ``f(times, poses) -> poses`` applied in order (postural sway,
    chest-wall motion: :mod:`sionnafmcw.scenes.vitals`), each given and returning
    ``{segment: (rotations [T, 3, 3], translations [T, 3])}``."""

    def __init__(self, clip: BvhClip, posture_time: float, fps: float, num_frames: int, unit: float = CMU_UNIT,
                 position=(0.0, 0.0), heading: float = 0.0, floor: bool = True, height: float | None = None,
                 build: str = "male", mesh_edge: float = meshes.BODY_MESH_EDGE, velocity_step: float = 0.01, movements=(),
                 axes=Y_UP_TO_Z_UP):
        if num_frames < 1:
            raise ValueError(f"PosedPerson: num_frames must be >= 1, got {num_frames}")
        self.still = MocapPerson(clip, unit=unit, fps=fps, num_frames=1, start=posture_time, position=position,
                                 heading=heading, floor=floor, height=height, build=build, mesh_edge=mesh_edge, axes=axes)
        self.body = self.still.body
        self.fps = float(fps)
        self.num_frames = int(num_frames)
        self.velocity_step = float(velocity_step)
        self.movements = list(movements)
        self.posture = {k: (r[0], p[0]) for k, (r, p) in self.still.poses([0.0]).items()}

    @property
    def placement(self) -> np.ndarray:
        return self.still.placement

    def poses(self, times) -> dict:
        times = np.atleast_1d(np.asarray(times, float))
        poses = {k: (np.repeat(r[None], times.size, 0), np.repeat(p[None], times.size, 0))
                 for k, (r, p) in self.posture.items()}
        for move in self.movements:
            poses = move(times, poses)
        return poses


class WalkerPerson(_Person):
    """A :class:`~sionnafmcw.scenes.body.WalkingPerson` (the parametric Boulic-Thalmann walker) with the
    interface of :class:`MocapPerson` (``body.segments``, :meth:`poses` at many times, velocities by
    central differences over :data:`~sionnafmcw.scenes.body.VELOCITY_STEP` = 10 us, as the walker's own
    truth), so that :func:`~sionnafmcw.mocap.scene.write_people` writes it among other people."""

    def __init__(self, walker, fps: float, num_frames: int):
        from types import SimpleNamespace

        from ..scenes.body import VELOCITY_STEP

        self.walker = walker
        self.fps, self.num_frames = float(fps), int(num_frames)
        self.velocity_step = VELOCITY_STEP * self.fps          # frames
        segs = {k: SimpleNamespace(vertices=v, faces=f, normals=walker.local_normals[k])
                for k, (v, f) in walker.local_meshes.items()}
        self.body = SimpleNamespace(segments=segs, names=list(segs), height=walker.height)

    def poses(self, times) -> dict:
        times = np.atleast_1d(np.asarray(times, float))
        each = [self.walker.poses(float(t)) for t in times]
        return {k: (np.stack([p[k][0] for p in each]), np.stack([p[k][1] for p in each])) for k in each[0]}

    def keypoint_anchors(self) -> dict:
        from ..scenes.keypoints import walker_anchors

        return walker_anchors(self.walker)


def add_person(writer, person: _Person, prefix: str = "", material: str | None = None):
    """Declare ``person``'s segments as rigid objects ``prefix + segment`` of ``writer`` (an
    :class:`~sionnafmcw.scenes.writer.AnimationWriter` with the material declared, default the skin
    ``mat-skin``) and return ``rigid_at(i)``: the ``rigid=`` entries of frame ``i`` for
    :meth:`~sionnafmcw.scenes.writer.AnimationWriter.frame` (merge the dicts of several people)."""
    from ..scenes.writer import SKIN

    material = SKIN if material is None else material
    if prefix and not all(c.isalnum() or c in "_-." for c in prefix):
        raise ValueError(f"add_person: prefix {prefix!r} may hold letters, digits, '_', '-' and '.' only "
                         "(it becomes part of file names)")
    for k, s in person.body.segments.items():
        writer.rigid(prefix + k, s.vertices, s.faces, material, vertex_normals=s.normals)
    cache = {}

    def rigid_at(i: int) -> dict:
        if i not in cache:
            cache.clear()
            block = list(range(i, min(i + 64, person.num_frames)))
            for j, m in zip(block, person.motions(block)):
                cache[j] = m
        return {prefix + k: {"to_world": transform_matrix(m.rotation, m.translation), "velocity": m.velocity,
                             "angular_velocity": m.angular_velocity} for k, m in cache[i].items()}

    return rigid_at


__all__ = ["MocapPerson", "PosedPerson", "VELOCITY_STEP_FRAMES", "WalkerPerson", "add_person"]
