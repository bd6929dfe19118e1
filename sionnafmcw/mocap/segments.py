r"""The segment body bound to a BVH skeleton: one rigid skin mesh per bone, sized from the skeleton.

Why rigid segments (and not a skinned mesh)
-------------------------------------------
Each body segment is weighted fully to one bone (in Blender: parented to it, :mod:`.blender_route`),
so it moves rigidly with that bone. That is exactly the data contract's rigid object
(:mod:`sionnafmcw.animation.rigid`): its mesh is written once and placed per frame by a
``to_world``, and every surface point moves at :math:`\mathbf v_c + \boldsymbol\omega\times(\mathbf x -
\mathbf c)` without per-vertex velocities; the scene stays small whatever the mesh resolution.
What the echo needs is the surface the radar sees and its velocity field: at 77 GHz
(:math:`\lambda` = 3.9 mm) a skinned mesh's deformation at the joints (skin folding over a few
centimetres around a knee or an elbow, a small fraction of the body's area, moving with the
velocity of the joint) changes neither the Doppler spread nor the strong specular returns of the
limbs and the torso, which come from the segments' middles. Where segments meet they overlap
(the spheres that close a limb sit inside its neighbour), as a skinned body's joints would be.

Bones and segments
------------------
The skeleton's joints are looked up by their MotionBuilder / CMU names (those of the CMU
database's BVH conversion; a ``prefix:`` such as Mixamo's ``mixamorig:`` is ignored). A BVH joint's
rotation moves the segment from it to its child, so each segment hangs on the joint where it starts:

==============================  ========================  =========================================
segment                         joint (bone)              shape (:mod:`.anatomy`)
==============================  ========================  =========================================
``pelvis``                      the root (``Hips``)       ellipsoid, hip girth
``abdomen``                     first spine joint         ellipsoid, waist girth
                                (``LowerBack``)
``torso`` (the thorax)          the shoulders' parent     ellipsoid, chest girth
                                (``Spine1``)
``head``                        ``Head``                  ellipsoid (as :mod:`sionnafmcw.scenes.body`)
``{side}_upper_arm``            ``{Side}Arm``             tapered limb, biceps to forearm girth
``{side}_lower_arm``            ``{Side}ForeArm``         tapered limb to the wrist, and the hand
``{side}_upper_leg``            ``{Side}UpLeg``           tapered limb, thigh to knee girth
``{side}_lower_leg``            ``{Side}Leg``             tapered limb, calf to ankle girth
``{side}_foot``                 ``{Side}Foot``            ellipsoid along the ankle-to-toe direction
==============================  ========================  =========================================

The hand is part of the forearm segment (the wrist held straight) and the toes part of the foot:
the CMU hand and toe joints are the noisiest channels of the database (``75_10`` turns a hand by up
to 180 degrees between two frames), and they are small. A segment whose joint is missing is left
out (a skeleton of one arm gives the arm's segments only); at least one must be there.

Sizes
-----
Lengths come from the skeleton at rest: a limb runs from its joint to its child joint. The
stature :math:`H` that scales the girths is ``height`` when given, else
:math:`H = (L_{thigh} + L_{shank})/0.491` (Winter's leg length, 0.245 + 0.246 of :math:`H`, from
the mean of both legs). The torso ellipsoids stack along the spine at rest: pelvis from 0.05
:math:`H` below the hip joints to 0.02 :math:`H` above the root, abdomen from 0.02 :math:`H` below
the root to 0.03 :math:`H` above the thorax's lower spine joint, thorax from 0.02 :math:`H` below that
joint to 0.03 :math:`H` above the shoulders; each centred horizontally on its spine joints, its
section the ellipse of its girth (depth:width of the chest). Every mesh is built in its joint's
frame at rest (world-aligned axes, :mod:`.skeleton`), in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scenes import meshes

from . import anatomy
from .skeleton import ClipMotion

SIDES = ("left", "right")
#: Segment names, in the order they are written.
SEGMENT_ORDER = ("pelvis", "abdomen", "torso", "head") + tuple(
    f"{side}_{part}" for side in SIDES for part in ("upper_arm", "lower_arm", "upper_leg", "lower_leg", "foot"))
_LIMB_JOINTS = {"upper_arm": "Arm", "lower_arm": "ForeArm", "upper_leg": "UpLeg", "lower_leg": "Leg", "foot": "Foot"}
#: Head ellipsoid semi-axes / stature (depth, width, height) and its centre above the head joint,
#: as :func:`sionnafmcw.scenes.body.segment_shapes`.
HEAD_AXES = (0.055, 0.045, 0.065)


@dataclass(frozen=True)
class Segment:
    """One body segment: ``name``, the ``joint`` (index) it hangs on and its closed skin mesh in that
    joint's frame at rest (m): ``vertices`` [V, 3], ``faces`` [F, 3], unit ``normals`` [V, 3]."""

    name: str
    joint: int
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray

    @property
    def centroid(self) -> np.ndarray:
        """Area-weighted centroid (m, joint frame)."""
        from ..animation.rigid import area_centroid

        return area_centroid(self.vertices, self.faces)


def _canonical(name: str) -> str:
    return name.split(":")[-1]


def leg_stature(motion: ClipMotion) -> float | None:
    """Stature (m) :math:`(L_{thigh} + L_{shank})/0.491` from the skeleton's legs at rest (mean of the legs
    it has), None without a leg (``UpLeg``, ``Leg``, ``Foot`` joints)."""
    names = motion.skeleton.names
    rest = motion.rest_positions()
    legs = []
    for side in ("Left", "Right"):
        hip, knee, ankle = (_find(names, f"{side}{n}") for n in ("UpLeg", "Leg", "Foot"))
        if None not in (hip, knee, ankle):
            legs.append(np.linalg.norm(rest[knee] - rest[hip]) + np.linalg.norm(rest[ankle] - rest[knee]))
    return float(np.mean(legs)) / anatomy.WINTER["leg"] if legs else None


def _find(names, wanted):
    for i, n in enumerate(names):
        if _canonical(n) == wanted:
            return i
    return None


class SegmentBody:
    """The segments of :data:`SEGMENT_ORDER` that the skeleton of ``motion`` has joints for (module docstring).

    ``height`` (m) overrides the stature estimated from the legs; ``build`` (``"male"`` or
    ``"female"``) picks the girths; ``max_edge`` (m) the largest triangle edge.
    """

    def __init__(self, motion: ClipMotion, height: float | None = None, build: str = "male",
                 max_edge: float = meshes.BODY_MESH_EDGE):
        if build not in anatomy.BUILDS:
            raise ValueError(f"SegmentBody: build {build!r} is unknown; choose one of {', '.join(anatomy.BUILDS)}")
        if not (0.001 <= max_edge <= 0.2):
            raise ValueError(f"SegmentBody: max_edge {max_edge!r} m outside 0.001..0.2 m")
        self.motion = motion
        self.build = build
        self.max_edge = float(max_edge)
        names = motion.skeleton.names
        self.joint_names = names
        self.rest = motion.rest_positions()
        self.end_sites = motion.rest_end_sites()
        self._idx = {n: _find(names, n) for n in (
            "Hips", "LeftUpLeg", "RightUpLeg", "LeftLeg", "RightLeg", "LeftFoot", "RightFoot", "LeftToeBase",
            "RightToeBase", "LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LeftHand", "RightHand",
            "LeftShoulder", "RightShoulder", "Head", "Neck")}
        self.height = float(height) if height is not None else self._stature()
        if not (0.5 <= self.height <= 2.5):
            raise ValueError(f"SegmentBody: stature {self.height:.3f} m outside 0.5..2.5 m "
                             "(pass height=, or check the BVH unit: metres per file unit)")
        self.up = np.array([0.0, 0.0, 1.0])
        self.left = self._left_axis()
        self.forward = np.cross(self.left, self.up)
        self.segments = self._build()
        if not self.segments:
            raise ValueError(f"{motion.clip.path or 'BVH clip'}: no body segment can be bound to this skeleton: it "
                             "has none of the joints Hips, LowerBack, Spine1 (the shoulders' parent), Head, "
                             "LeftArm/RightArm, LeftForeArm, LeftUpLeg, LeftLeg, LeftFoot (MotionBuilder / CMU "
                             f"names); its joints: {', '.join(names)}")

    # ---------------------------------------------------------------- sizing
    def _child(self, j, wanted=None):
        kids = self.motion.skeleton.children(j)
        if wanted is not None:
            for k in kids:
                if _canonical(self.joint_names[k]) == wanted:
                    return k
        return kids[0] if len(kids) == 1 else None

    def _stature(self) -> float:
        h = leg_stature(self.motion)
        if h is None:
            raise ValueError(f"{self.motion.clip.path or 'BVH clip'}: the skeleton has no leg (UpLeg, Leg, Foot "
                             "joints) to estimate the stature from; pass the person's height")
        return h

    def _left_axis(self) -> np.ndarray:
        for a, b in (("LeftUpLeg", "RightUpLeg"), ("LeftArm", "RightArm"), ("LeftShoulder", "RightShoulder")):
            ia, ib = self._idx[a], self._idx[b]
            if ia is not None and ib is not None:
                d = self.rest[ia] - self.rest[ib]
                d[2] = 0.0
                if np.linalg.norm(d) > 1e-6:
                    return d / np.linalg.norm(d)
        return np.array([1.0, 0.0, 0.0])  # BVH +X (its left when facing +Z, Y up), after the axes

    def _body_rotation(self) -> np.ndarray:
        """Columns: forward, left, up (the rest pose's body frame in world-aligned axes)."""
        return np.stack([self.forward, self.left, self.up], axis=1)

    def _level(self, j) -> float:
        return float(self.rest[j][2])

    # ---------------------------------------------------------------- segments
    def _build(self) -> dict:
        out = {}
        H, e, build = self.height, self.max_edge, self.build
        ratio = anatomy.GIRTHS[build]["chest_depth"] / anatomy.GIRTHS[build]["chest_width"]
        rb = self._body_rotation()
        root = 0 if self.motion.skeleton.parents[0] < 0 else self._idx["Hips"]
        thorax = self._thorax_joint()
        chain = self._spine_chain(root, thorax) if thorax is not None else []
        hips = [self._idx[n] for n in ("LeftUpLeg", "RightUpLeg") if self._idx[n] is not None]
        shoulders = [self._idx[n] for n in ("LeftArm", "RightArm") if self._idx[n] is not None]
        z_root = self._level(root)

        def torso_piece(name, joint, girth, z_lo, z_hi, xy_joints):
            a, b = anatomy.ellipse_semi_axes(anatomy.GIRTHS[build][girth] * H, ratio)
            xy = np.mean([self.rest[j] for j in xy_joints], axis=0)
            centre = np.array([xy[0], xy[1], 0.5 * (z_lo + z_hi)])
            v, f, n = anatomy.ellipsoid_surface(centre - self.rest[joint], (a, b, 0.5 * (z_hi - z_lo)), rb, e)
            out[name] = Segment(name, joint, v, f, n)

        if hips:
            z_hips = float(np.mean([self._level(j) for j in hips]))
            torso_piece("pelvis", root, "hip", z_hips - 0.05 * H, z_root + 0.02 * H, hips)
        if len(chain) >= 3 and shoulders:   # root, abdomen joint, ..., lower thorax joint, thorax joint
            lower = chain[-2]
            z_lower = self._level(lower)
            torso_piece("abdomen", chain[1], "waist", z_root - 0.02 * H, z_lower + 0.03 * H, [root, lower])
            z_sh = float(np.mean([self._level(j) for j in shoulders]))
            torso_piece("torso", thorax, "chest", z_lower - 0.02 * H, z_sh + 0.03 * H, [lower, thorax])
        head = self._idx["Head"]
        if head is not None:
            top = self.end_sites.get(head)
            centre = 0.5 * (self.rest[head] + top) if top is not None else self.rest[head] + 0.05 * H * self.up
            centre = centre + 0.01 * H * self.forward
            v, f, n = anatomy.ellipsoid_surface(centre - self.rest[head], np.array(HEAD_AXES) * H, rb, e)
            out["head"] = Segment("head", head, v, f, n)
        for side, Side in (("left", "Left"), ("right", "Right")):
            for part, suffix in _LIMB_JOINTS.items():
                j = self._idx[f"{Side}{suffix}"]
                if j is None:
                    continue
                seg = self._limb(side, Side, part, j)
                if seg is not None:
                    out[seg.name] = seg
        return {name: out[name] for name in SEGMENT_ORDER if name in out}

    def _thorax_joint(self):
        for s in ("LeftArm", "RightArm"):
            j = self._idx[s]
            if j is None:
                continue
            p = self.motion.skeleton.parents[j]
            if p >= 0 and _canonical(self.joint_names[p]) in ("LeftShoulder", "RightShoulder"):
                p = self.motion.skeleton.parents[p]
            return p if p >= 0 else None
        return None

    def _spine_chain(self, root, thorax) -> list:
        chain = [thorax]
        parents = self.motion.skeleton.parents
        while chain[-1] != root and parents[chain[-1]] >= 0:
            chain.append(int(parents[chain[-1]]))
        if chain[-1] != root:
            return []
        return chain[::-1]   # root ... thorax

    def _limb(self, side, Side, part, j):
        H, e, build = self.height, self.max_edge, self.build
        name = f"{side}_{part}"
        if part == "foot":
            toe = self._idx[f"{Side}ToeBase"]
            toe_dir = (self.rest[toe] - self.rest[j]) if toe is not None else self.forward.copy()
            toe_dir[2] = 0.0
            fwd = toe_dir / np.linalg.norm(toe_dir) if np.linalg.norm(toe_dir) > 1e-9 else self.forward
            left = np.cross(self.up, fwd)
            rot = np.stack([fwd, left, self.up], axis=1)
            w = anatomy.WINTER
            centre = (0.5 * w["foot_length"] - w["heel"]) * H * fwd - 0.5 * w["ankle_height"] * H * self.up
            radii = (0.5 * w["foot_length"] * H, 0.0275 * H, 0.5 * w["ankle_height"] * H)
            v, f, n = anatomy.ellipsoid_surface(centre, radii, rot, e)
            return Segment(name, j, v, f, n)
        child_name = {"upper_arm": "ForeArm", "lower_arm": "Hand", "upper_leg": "Leg", "lower_leg": "Foot"}[part]
        child = self._child(j, f"{Side}{child_name}")
        if child is None:
            return None
        p1 = self.rest[child] - self.rest[j]
        profile = anatomy.limb_profile(part, float(np.linalg.norm(p1)), build, H)
        parts = [anatomy.revolved_limb(np.zeros(3), p1, profile, e)]
        if part == "lower_arm":   # the hand: an ellipsoid beyond the wrist, along the forearm
            d = p1 / np.linalg.norm(p1)
            hand = anatomy.WINTER["hand"] * H
            r_wrist = anatomy.girth_radius(build, "wrist", H)
            side_axis = np.cross(self.up, d)
            if np.linalg.norm(side_axis) < 1e-6:
                side_axis = np.cross(self.forward, d)
            side_axis /= np.linalg.norm(side_axis)
            rot = np.stack([d, side_axis, np.cross(d, side_axis)], axis=1)
            parts.append(anatomy.ellipsoid_surface(p1 + 0.5 * hand * d, (0.5 * hand, 1.5 * r_wrist, 0.6 * r_wrist),
                                                   rot, e))
        v, f, n = anatomy.merge_surfaces(*parts)
        return Segment(name, j, v, f, n)

    # ---------------------------------------------------------------- queries
    @property
    def names(self) -> list[str]:
        return list(self.segments)

    @property
    def num_triangles(self) -> int:
        return int(sum(len(s.faces) for s in self.segments.values()))

    def world_vertices(self, rotations, origins) -> dict:
        """``{segment: world vertices [V, 3]}`` for joint frames ``rotations [J, 3, 3]``, ``origins [J, 3]``."""
        return {k: s.vertices @ rotations[s.joint].T + origins[s.joint] for k, s in self.segments.items()}


__all__ = ["HEAD_AXES", "SEGMENT_ORDER", "Segment", "SegmentBody", "leg_stature"]
