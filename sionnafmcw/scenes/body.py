r"""A walking person: body segments as closed skin meshes on the Boulic-Thalmann kinematic chain.

Anthropometry
-------------
Segment lengths scale with the standing height :math:`H` by the ratios of D. A. Winter,
*Biomechanics and Motor Control of Human Movement*, 4th ed., Wiley 2009, Fig. 4.1 (the ones
Chen's pedestrian model uses where they differ by a few thousandths):

=====================  ===========  =========================================================
quantity               ratio of H   note
=====================  ===========  =========================================================
thigh (hip-knee)       0.245        :math:`H_t` = thigh + shank = 0.491 H (Boulic's normaliser)
shank (knee-ankle)     0.246
ankle height           0.039        sole to ankle joint
foot length            0.152        heel to toe; the ankle sits 0.031 H in front of the heel
hip joint spacing      0.191        (Chen's hip width; joints at +-0.0955 H)
torso (hip-shoulder)   0.288        shoulder height 0.818 H - hip height 0.530 H
shoulder spacing       0.259        joints at +-0.1295 H
upper arm              0.188        shoulder-elbow (Winter 0.186, Chen 0.188)
forearm + hand         0.146+0.054  elbow to the middle of the hand (fingertips at 0.146+0.108)
head (chin to top)     0.130
=====================  ===========  =========================================================

Segment radii (girths) are not in Winter's figure; they are round values for an adult of
1.8 m (thigh 6.3 cm, shank 4.5 cm, upper arm 4.5 cm, forearm 3.6 cm, torso 17 x 11 cm
half-axes), scaled with H. Each segment is one closed mesh and one object:

* ``head`` (ellipsoid), ``torso`` (thorax and abdomen, an ellipsoid from 0.03 H to 0.30 H above
  the hip joints; it turns with the upper body: back flexion and thorax torsion) and ``pelvis``
  (an ellipsoid around the hip joints; it turns with the pelvis: list and torsion) -- the torso
  is split there because Boulic's model rotates the two parts differently;
* ``left_upper_arm``, ``left_lower_arm`` (forearm and hand), ``left_upper_leg``,
  ``left_lower_leg`` (capsules), ``left_foot`` (ellipsoid), and the same ``right_...``.

Mesh resolution
---------------
Every triangle edge is at most ``mesh_edge`` (:data:`MESH_EDGE` = 32 mm by default) and no grid step
turns the normal by more than :data:`MAX_NORMAL_TURN` = 0.6 rad (:func:`.meshes.ellipsoid_grid`,
:func:`.meshes.capsule_divisions`: the foot's toe and heel, of 9 mm radius, get steps of 5 mm); the
PLYs carry the exact normals of the ellipsoids and capsules (:func:`segment_normals`, turned with each
segment: :attr:`SegmentState.vertex_normals`). The mesh is not what physical optics integrates: the
engines rebuild the smooth surface those normals describe (curved PN triangles refined to
:math:`\lambda/25`, :mod:`sionnafmcw.smooth_surface`) and put their samples on it, so the mesh need
only carry the shape's positions and normals; Sionna traces the mesh as stored for the diffuse paths
(within 2.3 mm of the skin, 1/8 of a 4 GHz range bin: :mod:`sionnafmcw.engines.path`). The body's
PO RCS at the convergence study's looks (gait phase 0, radar 1 m high, pixel step a quarter of the
rule's; ``benchmarks/smooth_surface.py walker``) against the body on its exact shapes, dB, at 3 m /
10 m and aspects 0, 30, 90, 150, 180 deg:

=====================================  =========  ===============================================  ==========
body                                   triangles  error at 3 m (0/30/90/150/180 deg)               max abs dB
=====================================  =========  ===============================================  ==========
32 mm as rendered (refined, smooth)    175 868    +0.06 / -0.66 / -0.08 / +0.10 / +0.07            0.66
32 mm, area-weighted mesh normals      175 868    -0.02 / -3.12 / -0.16 / +0.34 / +0.14            5.39
32 mm flat facets (no refinement)      12 348     +1.30 / +5.80 / +10.64 / -10.62 / +1.85          14.57
16 mm as rendered                      293 768    +0.09 / -0.45 / +0.15 / +0.08 / -0.06            0.45
8 mm flat facets (the former default)  191 276    -0.17 / -0.94 / -0.59 / +0.02 / +0.99            1.07
=====================================  =========  ===============================================  ==========

(the max column covers both ranges; tests/test_body_rcs.py holds the default within 1 dB of the
exact shapes at all ten looks). Without the smooth surface a body needs 8 mm facets (191k
triangles written every frame before the rigid contract) to come within 1 dB; the stored 32 mm mesh
is 12k triangles, written once.

Kinematic chain
---------------
Body frame: :math:`x` forward, :math:`y` left, :math:`z` up, origin at the spine origin
:math:`O_s` (mid-point of the hip joints). With :math:`R_a(\alpha)` the right-handed rotation
about axis :math:`a` (:math:`R_y(-\theta)` swings :math:`(0, 0, -L)` forward for
:math:`\theta > 0`), and angles from :class:`~.gait.BoulicGait` at phase :math:`p` (right side)
or :math:`p + 1/2` (left side):

.. math::
    R_{pelvis} &= R_z(-\text{torsion}_{pelvis})\,R_x(\text{list}), \qquad
    R_{upper} = R_z(-\text{torsion}_{thorax})\,R_y(-\text{back flexion}),\\
    R_{thigh} &= R_{pelvis} R_y(-\theta_{hip}),\quad R_{shank} = R_{thigh} R_y(\theta_{knee}),\quad
    R_{foot} = R_{shank} R_y(-\theta_{ankle}),\\
    R_{upper\,arm} &= R_{upper} R_y(-\theta_{shoulder}),\quad
    R_{forearm} = R_{upper\,arm} R_y(-\theta_{elbow}),

(Chen's ``XYZConvention`` matrices are the transposes of these rotations; the composed chain is
the same). Joints: hips :math:`R_{pelvis}(0, \pm w_h, 0)`, knee = hip + :math:`R_{thigh}(0,0,-L_t)`,
ankle = knee + :math:`R_{shank}(0,0,-L_s)`, shoulders :math:`R_{upper}(0, \pm w_s, L_{torso})`,
elbow = shoulder + :math:`R_{upper\,arm}(0,0,-L_{ua})`.

World placement: the person follows a :class:`Track` (a line or a circle, parametrised by arc
length :math:`s`) at constant speed :math:`V`: :math:`s(t) = V t + f(p)` with Boulic's forward
oscillation :math:`f`; :math:`O_s = \mathbf c(s) + l(p)\,\mathbf n(s) + (h_0 + v(p))\,\hat z`
(:math:`\mathbf n` the track's left normal, :math:`l, v` the lateral and vertical translations)
and the body yaw is the track heading at :math:`s`. The gait phase is :math:`p = p_0 + t/D_c`.
The hip height :math:`h_0` is set once so that the lowest point of the feet over a cycle just
touches the floor (:math:`z = 0`).

Velocities
----------
Every segment is rigid, so the velocity of a point is
:math:`\mathbf v = \dot{\mathbf o} + \boldsymbol\omega \times (\mathbf x - \mathbf o)`. Here it is
taken as the central difference of the *analytic* chain, :math:`(\mathbf x(t+h) - \mathbf x(t-h))/2h`
with :math:`h = 10\,\mu s`: the joint curves are C1 (PCHIP), so the error is below
:math:`h\,|\Delta\ddot{\mathbf x}|/4` (a few mm/s at a PCHIP knot, ~1e-8 m/s elsewhere).
The per-vertex velocities in the PLYs and the manifest velocity of each segment (the velocity of
its area-weighted centroid, the point the run store's truth position follows) both come from
:meth:`WalkingPerson.segment_state`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..animation.rigid import RigidMotion, angular_velocity
from . import meshes
from .gait import RV_MAX, BoulicGait, GaitTiming

#: Central-difference step (s) for velocities.
VELOCITY_STEP = 1e-5

#: Default largest triangle edge (m) of the segment meshes (module docstring, *Mesh resolution*).
MESH_EDGE = meshes.BODY_MESH_EDGE
#: Largest turn of the normal over one grid step (:data:`.meshes.MAX_NORMAL_TURN`).
MAX_NORMAL_TURN = meshes.MAX_NORMAL_TURN

# ----------------------------------------------------------------------------- anthropometry
RATIOS = {
    "thigh": 0.245, "shank": 0.246, "ankle_height": 0.039, "foot_length": 0.152, "heel": 0.031,
    "hip_width": 0.191, "torso": 0.288, "shoulder_width": 0.259, "upper_arm": 0.188,
    "forearm": 0.146, "hand": 0.108, "head": 0.130,
}
SIDES = ("left", "right")
SEGMENTS = ("head", "torso", "pelvis") + tuple(
    f"{side}_{part}" for side in SIDES for part in ("upper_arm", "lower_arm", "upper_leg", "lower_leg", "foot"))


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@dataclass(frozen=True)
class Anthropometry:
    """Segment lengths (m) of a person of standing height ``height`` (m), Winter's ratios."""

    height: float = 1.8

    def __getattr__(self, name):
        if name in RATIOS:
            return RATIOS[name] * self.height
        raise AttributeError(name)

    @property
    def thigh_height(self) -> float:
        """Boulic's :math:`H_t` = thigh + shank (m)."""
        return (RATIOS["thigh"] + RATIOS["shank"]) * self.height


def segment_shapes(body: Anthropometry) -> dict:
    """``{segment: ("ellipsoid", centre, radii) | ("capsule", p0, p1, radius)}`` in each segment's own
    frame (m): the smooth surfaces that :func:`segment_meshes` tessellates."""
    H = body.height
    out = {
        "torso": ("ellipsoid", (0.0, 0.0, 0.165 * H), (0.06 * H, 0.095 * H, 0.135 * H)),
        "pelvis": ("ellipsoid", (0.0, 0.0, 0.0), (0.06 * H, 0.095 * H, 0.065 * H)),
        "head": ("ellipsoid", (0.01 * H, 0.0, body.torso + 0.075 * H), (0.055 * H, 0.045 * H, 0.065 * H)),
    }
    foot_centre = (0.5 * body.foot_length - body.heel, 0.0, -0.5 * body.ankle_height)
    for side in SIDES:
        out[f"{side}_upper_arm"] = ("capsule", (0, 0, 0), (0, 0, -body.upper_arm), 0.025 * H)
        out[f"{side}_lower_arm"] = ("capsule", (0, 0, 0), (0, 0, -(body.forearm + 0.5 * body.hand)), 0.020 * H)
        out[f"{side}_upper_leg"] = ("capsule", (0, 0, 0), (0, 0, -body.thigh), 0.035 * H)
        out[f"{side}_lower_leg"] = ("capsule", (0, 0, 0), (0, 0, -body.shank), 0.025 * H)
        out[f"{side}_foot"] = ("ellipsoid", foot_centre,
                               (0.5 * body.foot_length, 0.0275 * H, 0.5 * body.ankle_height))
    return out


def smallest_curvature_radius(body: Anthropometry) -> float:
    """Smallest radius of curvature (m) of the body's surfaces: the foot's :math:`c^2/a` at the
    toe and heel and the capsules' radii (the forearm's 0.020 H), the bound the PO render
    resolution and the sagitta rule need."""
    radii = []
    for shape in segment_shapes(body).values():
        if shape[0] == "capsule":
            radii.append(shape[3])
        else:
            a, b, c = sorted(shape[2])
            radii.append(a * a / c)
    return float(min(radii))


def segment_meshes(body: Anthropometry, max_edge: float | None = None) -> dict:
    """``{segment: (vertices [V,3], faces [F,3])}`` in each segment's own frame (m), every triangle
    edge at most ``max_edge`` (m; default :data:`MESH_EDGE`; :func:`.meshes.ellipsoid_grid`,
    :func:`.meshes.capsule_divisions`).

    Frames: ``torso``, ``head`` -- upper body at :math:`O_s`; ``pelvis`` -- pelvis at :math:`O_s`;
    arms and legs -- the proximal joint, the segment along local :math:`-z`; feet -- the ankle.
    """
    max_edge = MESH_EDGE if max_edge is None else float(max_edge)
    if not (0.001 <= max_edge <= 0.2):
        raise ValueError(f"segment_meshes: max_edge {max_edge!r} m outside 0.001..0.2 m")
    out = {}
    for name, shape in segment_shapes(body).items():
        if shape[0] == "ellipsoid":
            theta, phi = meshes.ellipsoid_grid(shape[2], max_edge, MAX_NORMAL_TURN)
            out[name] = meshes.ellipsoid(shape[1], shape[2], theta=theta, phi=phi)
        else:
            p0, p1, radius = np.asarray(shape[1], float), np.asarray(shape[2], float), shape[3]
            n_segments, n_cap, n_body = meshes.capsule_divisions(float(np.linalg.norm(p1 - p0)), radius, max_edge,
                                                                 MAX_NORMAL_TURN)
            out[name] = meshes.capsule(p0, p1, radius, n_segments=n_segments, n_cap=n_cap, n_body=n_body)
    return out


def segment_normals(body: Anthropometry, local_meshes: dict) -> dict:
    """``{segment: unit normals [V, 3]}`` of :func:`segment_meshes`' vertices: the exact normals of the
    segments' smooth surfaces (:func:`segment_shapes`; :func:`.meshes.ellipsoid_normals`,
    :func:`.meshes.capsule_normals`), which the PLYs carry. The smooth surface the PO render rebuilds
    from a coarse mesh (:mod:`sionnafmcw.smooth_surface`) is only as good as its normals: the
    area-weighted mesh normals (:func:`.meshes.vertex_normals`) of 32 mm facets are 1.4-6.7 degrees
    off, their echo up to 3.4 dB (``benchmarks/smooth_surface.py walker``)."""
    out = {}
    for name, shape in segment_shapes(body).items():
        v = local_meshes[name][0]
        out[name] = (meshes.ellipsoid_normals(v, shape[1], shape[2]) if shape[0] == "ellipsoid"
                     else meshes.capsule_normals(v, shape[1], shape[2]))
    return out


def _area_centroid(v, f):
    tri = v[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return (tri.mean(axis=1) * area[:, None]).sum(axis=0) / area.sum()


# ----------------------------------------------------------------------------- tracks
@dataclass(frozen=True)
class LineTrack:
    """Straight track from ``start`` (x, y) (m) with heading ``heading`` (rad from +x towards +y)."""

    start: tuple = (0.0, 0.0)
    heading: float = 0.0

    def point(self, s):
        return np.asarray(self.start, float) + s * np.array([math.cos(self.heading), math.sin(self.heading)])

    def yaw(self, s) -> float:
        return float(self.heading)


@dataclass(frozen=True)
class CircleTrack:
    """Circle of ``radius`` (m) about ``centre`` (x, y), starting at polar angle ``start_angle`` (rad),
    walked anticlockwise (seen from above) unless ``clockwise``."""

    centre: tuple = (0.0, 0.0)
    radius: float = 3.0
    start_angle: float = 0.0
    clockwise: bool = False

    def _angle(self, s):
        sign = -1.0 if self.clockwise else 1.0
        return self.start_angle + sign * s / self.radius

    def point(self, s):
        a = self._angle(s)
        return np.asarray(self.centre, float) + self.radius * np.array([math.cos(a), math.sin(a)])

    def yaw(self, s) -> float:
        return float(self._angle(s) + (-math.pi / 2 if self.clockwise else math.pi / 2))


# ----------------------------------------------------------------------------- the person
@dataclass
class SegmentState:
    """One segment at one time: world ``vertices`` [V,3], ``vertex_velocities`` [V,3] (m/s),
    area-weighted ``centroid`` [3] and its ``velocity`` [3] (m/s), smooth unit ``vertex_normals`` [V,3]."""

    vertices: np.ndarray
    vertex_velocities: np.ndarray
    centroid: np.ndarray
    velocity: np.ndarray
    vertex_normals: np.ndarray | None = None


@dataclass
class WalkingPerson:
    """A person of ``height`` (m) walking ``track`` at ``speed`` (m/s), gait phase ``phase0`` (cycles) at t = 0.

    ``rv_max`` caps the relative velocity that shapes the gait (:mod:`.gait`); ``mesh_edge`` is the
    largest triangle edge (m) of the segment meshes (:data:`MESH_EDGE`). All methods are
    pure numpy: :meth:`poses` (segment rotations and origins), :meth:`segment_state` (world
    meshes and velocities), :meth:`truth` (centroid positions and velocities of every segment,
    the analytic ground truth).
    """

    height: float = 1.8
    speed: float = 1.4
    track: object = field(default_factory=LineTrack)
    phase0: float = 0.0
    rv_max: float = RV_MAX
    mesh_edge: float = MESH_EDGE

    def __post_init__(self):
        if not (0.5 <= self.height <= 2.5):
            raise ValueError(f"WalkingPerson: height {self.height} m outside 0.5..2.5 m")
        if not (0.001 <= self.mesh_edge <= 0.2):
            raise ValueError(f"WalkingPerson: mesh_edge {self.mesh_edge!r} m outside 0.001..0.2 m")
        self.body = Anthropometry(self.height)
        self.timing = GaitTiming(self.speed, self.body.thigh_height, self.rv_max)
        self.gait = BoulicGait(self.timing.rv_shape)
        self.local_meshes = segment_meshes(self.body, self.mesh_edge)
        self.local_normals = segment_normals(self.body, self.local_meshes)
        self.local_centroids = {k: _area_centroid(*m) for k, m in self.local_meshes.items()}
        self.hip_height = self._floor_contact_height()

    # ---------------------------------------------------------------- timing
    @property
    def cycle_duration(self) -> float:
        """:math:`D_c` (s)."""
        return self.timing.cycle_duration

    @property
    def cycle_length(self) -> float:
        """Stride length :math:`L_c` (m)."""
        return self.timing.cycle_length

    def phase(self, t):
        return self.phase0 + np.asarray(t, float) / self.cycle_duration

    # ---------------------------------------------------------------- chain in the body frame
    def local_poses(self, p: float) -> dict:
        """``{segment: (R [3,3], origin [3])}`` in the body frame at gait phase ``p`` (no translations)."""
        g, b = self.gait, self.body
        r_pelvis = _rz(-float(g.pelvic_torsion(p))) @ _rx(float(g.pelvic_list(p)))
        r_upper = _rz(-float(g.thorax_torsion(p))) @ _ry(-float(g.back_flexion(p)))
        o = np.zeros(3)
        poses = {"torso": (r_upper, o), "head": (r_upper, o), "pelvis": (r_pelvis, o)}
        for side, sign, q in (("right", -1.0, p), ("left", 1.0, p + 0.5)):
            hip = r_pelvis @ np.array([0.0, sign * 0.5 * b.hip_width, 0.0])
            r_thigh = r_pelvis @ _ry(-float(g.hip(q)))
            knee = hip + r_thigh @ np.array([0.0, 0.0, -b.thigh])
            r_shank = r_thigh @ _ry(float(g.knee(q)))
            ankle = knee + r_shank @ np.array([0.0, 0.0, -b.shank])
            r_foot = r_shank @ _ry(-float(g.ankle(q)))
            shoulder = r_upper @ np.array([0.0, sign * 0.5 * b.shoulder_width, b.torso])
            r_uarm = r_upper @ _ry(-float(g.shoulder(q)))
            elbow = shoulder + r_uarm @ np.array([0.0, 0.0, -b.upper_arm])
            r_farm = r_uarm @ _ry(-float(g.elbow(q)))
            poses[f"{side}_upper_leg"] = (r_thigh, hip)
            poses[f"{side}_lower_leg"] = (r_shank, knee)
            poses[f"{side}_foot"] = (r_foot, ankle)
            poses[f"{side}_upper_arm"] = (r_uarm, shoulder)
            poses[f"{side}_lower_arm"] = (r_farm, elbow)
        return poses

    def _floor_contact_height(self, n: int = 400) -> float:
        lowest = np.inf
        for p in np.arange(n) / n:
            poses = self.local_poses(p)
            dz = float(self.gait.vertical(p))
            for side in SIDES:
                r, o = poses[f"{side}_foot"]
                v = self.local_meshes[f"{side}_foot"][0]
                lowest = min(lowest, float((v @ r[2] + o[2]).min()) + dz)
        return -lowest

    # ---------------------------------------------------------------- world
    def poses(self, t: float) -> dict:
        """``{segment: (R [3,3], origin [3])}`` in the world at time ``t`` (s)."""
        p = float(self.phase(t))
        g = self.gait
        s = self.speed * t + float(g.forward(p))
        xy = self.track.point(s)
        yaw = self.track.yaw(s)
        normal = np.array([-math.sin(yaw), math.cos(yaw)])
        xy = xy + float(g.lateral(p)) * normal
        origin = np.array([xy[0], xy[1], self.hip_height + float(g.vertical(p))])
        r_body = _rz(yaw)
        return {k: (r_body @ r, origin + r_body @ o) for k, (r, o) in self.local_poses(p).items()}

    def segment_vertices(self, t: float) -> dict:
        """``{segment: world vertices [V,3]}`` at time ``t``."""
        return {k: self.local_meshes[k][0] @ r.T + o for k, (r, o) in self.poses(t).items()}

    def segment_state(self, t: float, h: float = VELOCITY_STEP) -> dict:
        """``{segment: SegmentState}`` at time ``t``: world mesh, per-vertex and centroid velocities."""
        now, ahead, behind = self.poses(t), self.poses(t + h), self.poses(t - h)
        out = {}
        for k, (v_local, _) in self.local_meshes.items():
            c_local = self.local_centroids[k]
            (r, o), (ra, oa), (rb, ob) = now[k], ahead[k], behind[k]
            out[k] = SegmentState(
                vertices=v_local @ r.T + o,
                vertex_velocities=(v_local @ ra.T + oa - v_local @ rb.T - ob) / (2 * h),
                centroid=r @ c_local + o,
                velocity=(ra @ c_local + oa - rb @ c_local - ob) / (2 * h),
                vertex_normals=self.local_normals[k] @ r.T,
            )
        return out

    def segment_motions(self, t: float, h: float = VELOCITY_STEP) -> dict:
        r"""``{segment: RigidMotion}`` at time ``t``: the segment frame's pose (``rotation``,
        ``translation``: its ``to_world``), the velocity of its area-weighted centroid and its angular
        velocity, both central differences of the analytic chain over :math:`\pm h`
        (:func:`~sionnafmcw.animation.rigid.angular_velocity`); what a rigid animation stores per frame."""
        now, ahead, behind = self.poses(t), self.poses(t + h), self.poses(t - h)
        out = {}
        for k in SEGMENTS:
            c = self.local_centroids[k]
            (r, o), (ra, oa), (rb, ob) = now[k], ahead[k], behind[k]
            out[k] = RigidMotion(r, o, (ra @ c + oa - rb @ c - ob) / (2 * h), angular_velocity(ra, rb, 2 * h),
                                 r @ c + o)
        return out

    def truth(self, times, h: float = VELOCITY_STEP) -> dict:
        """Analytic ground truth: ``{segment: (positions [T,3], velocities [T,3])}`` of the area-weighted
        segment centroids at ``times`` (s). ``truth(t)["torso"]`` is the paper's reference."""
        times = np.atleast_1d(np.asarray(times, float))
        pos = {k: np.zeros((times.size, 3)) for k in SEGMENTS}
        vel = {k: np.zeros((times.size, 3)) for k in SEGMENTS}
        for i, t in enumerate(times):
            now, ahead, behind = self.poses(t), self.poses(t + h), self.poses(t - h)
            for k in SEGMENTS:
                c = self.local_centroids[k]
                pos[k][i] = now[k][0] @ c + now[k][1]
                vel[k][i] = (ahead[k][0] @ c + ahead[k][1] - behind[k][0] @ c - behind[k][1]) / (2 * h)
        return {k: (pos[k], vel[k]) for k in SEGMENTS}

    def faces(self, segment: str) -> np.ndarray:
        return self.local_meshes[segment][1]

    def body_mesh(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The whole body at time ``t`` as one world mesh: ``(vertices [V,3], faces [F,3],
        vertex_normals [V,3], segment_of_face [F])`` (index into :data:`SEGMENTS`)."""
        vs, fs, ns, seg, off = [], [], [], [], 0
        for i, (k, (r, o)) in enumerate((k, self.poses(t)[k]) for k in SEGMENTS):
            v_local, f = self.local_meshes[k]
            vs.append(v_local @ r.T + o)
            ns.append(self.local_normals[k] @ r.T)
            fs.append(f + off)
            seg.append(np.full(len(f), i))
            off += len(v_local)
        return np.concatenate(vs), np.concatenate(fs), np.concatenate(ns), np.concatenate(seg)


def radial_velocities(positions, velocities, radar_position) -> np.ndarray:
    r"""Range rate :math:`\dot R = \hat{\mathbf r}\cdot\mathbf v` (m/s, + receding) of points seen from ``radar_position``."""
    d = np.asarray(positions, float) - np.asarray(radar_position, float)
    return np.einsum("...i,...i->...", d, np.asarray(velocities, float)) / np.linalg.norm(d, axis=-1)


__all__ = ["Anthropometry", "CircleTrack", "LineTrack", "MAX_NORMAL_TURN", "MESH_EDGE", "RATIOS", "SEGMENTS", "SegmentState",
           "VELOCITY_STEP", "WalkingPerson", "radial_velocities", "segment_meshes", "segment_normals", "segment_shapes",
           "smallest_curvature_radius"]
