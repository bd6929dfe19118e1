r"""Floor-plan geometry: footprints on the floor (z = 0 plane), overlap and clearance tests.

Everything here is 2-D, in metres, in the world's :math:`(x, y)`.

Oriented rectangles
-------------------
:class:`Rect` is a rectangle with centre :math:`\mathbf c`, half-sizes :math:`(h_u, h_v)` and yaw
:math:`\psi` (its :math:`u` axis :math:`\hat{\mathbf u} = (\cos\psi, \sin\psi)`, :math:`v` axis
:math:`\hat{\mathbf v} = (-\sin\psi, \cos\psi)`). Two convex polygons are disjoint if and only if
some edge normal of one of them separates their projections (the separating-axis theorem); for two
rectangles the candidate axes are the four :math:`\hat{\mathbf u}_a, \hat{\mathbf v}_a,
\hat{\mathbf u}_b, \hat{\mathbf v}_b`. The projection of a rectangle on a unit axis
:math:`\hat{\mathbf n}` is the interval :math:`\mathbf c\cdot\hat{\mathbf n} \pm (h_u|\hat{\mathbf u}\cdot
\hat{\mathbf n}| + h_v|\hat{\mathbf v}\cdot\hat{\mathbf n}|)`. :func:`rects_clear` asks for a gap of
at least ``gap`` between the intervals on one of the axes: then every point of one rectangle is at
least ``gap`` from every point of the other (the Euclidean distance is at least the gap along any
unit axis), so the test never passes two pieces closer than ``gap``; it may refuse a pair whose
nearest points are corners more than ``gap`` apart diagonally (conservative).

Distances
---------
Point to rectangle: in the rectangle's frame, :math:`\mathbf q = (|\hat{\mathbf u}\cdot(\mathbf p -
\mathbf c)| - h_u, |\hat{\mathbf v}\cdot(\mathbf p - \mathbf c)| - h_v)`, distance
:math:`\lVert\max(\mathbf q, 0)\rVert` (0 inside). Segment to rectangle: 0 if the segment meets the
rectangle (an end inside, or it crosses an edge), else the smallest of the ends' distances to the
rectangle and the corners' distances to the segment (the nearest points of two disjoint convex
sets include a vertex of one of them).

Footprints of people
--------------------
A person's footprint in a frame is a disc that holds the horizontal projection of the whole body.
Every segment lies in a capsule (:func:`segment_capsules`: axis :math:`\mathbf a_k\mathbf b_k` in the
segment's frame, radius :math:`\rho_k`), whose projection lies within :math:`\rho_k` of the projected
axis, itself within the hull of its projected ends :math:`(\mathbf R_k\mathbf a_k + \mathbf p_k)_{xy}`,
:math:`(\mathbf R_k\mathbf b_k + \mathbf p_k)_{xy}`. The footprint's centre :math:`\mathbf c` is the mid-point
of the bounding box of those ends widened by their radii, and its radius the largest
:math:`\lVert\mathbf e - \mathbf c\rVert + \rho_k` over the ends :math:`\mathbf e` (:func:`person_footprints`):
it holds the body, conservative by the capsules' slack (a few cm around tapered limbs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Rect:
    """An oriented rectangle on the floor: ``centre`` (x, y) m, ``half`` (along its u, v axes) m, ``yaw`` rad."""

    centre: tuple
    half: tuple
    yaw: float = 0.0

    @property
    def axes(self) -> np.ndarray:
        """``[2, 2]``: rows :math:`\\hat{\\mathbf u}, \\hat{\\mathbf v}`."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, s], [-s, c]])

    @property
    def corners(self) -> np.ndarray:
        """``[4, 2]`` corners, anticlockwise."""
        u, v = self.axes
        hu, hv = self.half
        c = np.asarray(self.centre, float)
        return np.array([c + hu * u + hv * v, c - hu * u + hv * v, c - hu * u - hv * v, c + hu * u - hv * v])

    def extent(self, axis) -> tuple[float, float]:
        """Projection interval ``(lo, hi)`` on the unit ``axis``."""
        u, v = self.axes
        n = np.asarray(axis, float)
        mid = float(np.asarray(self.centre, float) @ n)
        r = self.half[0] * abs(float(u @ n)) + self.half[1] * abs(float(v @ n))
        return mid - r, mid + r

    def to_dict(self) -> dict:
        return {"centre": [float(x) for x in self.centre], "half_size": [float(x) for x in self.half],
                "yaw": float(self.yaw)}


def rects_clear(a: Rect, b: Rect, gap: float = 0.0) -> bool:
    """True when one of the four axes separates ``a`` and ``b`` by at least ``gap`` m (module docstring)."""
    for axis in np.concatenate([a.axes, b.axes]):
        lo_a, hi_a = a.extent(axis)
        lo_b, hi_b = b.extent(axis)
        if lo_b - hi_a >= gap or lo_a - hi_b >= gap:
            return True
    return False


def point_rect_distance(rect: Rect, points) -> np.ndarray:
    """Distances ``[N]`` (m) of ``points [N, 2]`` to ``rect`` (0 inside)."""
    p = np.atleast_2d(np.asarray(points, float)) - np.asarray(rect.centre, float)
    local = np.abs(p @ rect.axes.T) - np.asarray(rect.half, float)
    return np.linalg.norm(np.maximum(local, 0.0), axis=-1)


def point_segment_distance(points, a, b) -> np.ndarray:
    """Distances ``[N, M]`` of ``points [N, 2]`` to the segments ``a [M, 2]`` -> ``b [M, 2]``."""
    p = np.atleast_2d(np.asarray(points, float))[:, None, :]
    a, b = np.atleast_2d(np.asarray(a, float))[None], np.atleast_2d(np.asarray(b, float))[None]
    d = b - a
    length2 = np.maximum(np.sum(d * d, axis=-1), 1e-300)
    t = np.clip(np.sum((p - a) * d, axis=-1) / length2, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * d), axis=-1)


def _segments_cross(p1, p2, q1, q2) -> np.ndarray:
    """``[M]``: segment ``p1 p2 [M, 2]`` properly crosses the single segment ``q1 q2``."""
    def orient(a, b, c):
        return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])

    d1, d2 = orient(q1, q2, p1), orient(q1, q2, p2)
    d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2)
    return (d1 * d2 < 0) & (d3 * d4 < 0)


def segment_rect_distance(rect: Rect, a, b) -> np.ndarray:
    """Distances ``[M]`` (m) of the segments ``a [M, 2]`` -> ``b [M, 2]`` to ``rect`` (module docstring)."""
    a, b = np.atleast_2d(np.asarray(a, float)), np.atleast_2d(np.asarray(b, float))
    corners = rect.corners
    d = np.minimum(point_rect_distance(rect, a), point_rect_distance(rect, b))
    d = np.minimum(d, point_segment_distance(corners, a, b).min(axis=0))
    for k in range(4):
        crossing = _segments_cross(a, b, corners[k], corners[(k + 1) % 4])
        d = np.where(crossing, 0.0, d)
    return d


# ============================================================================ people
def segment_capsules(segments: dict) -> dict:
    """``{segment: (a [3], b [3], radius)}``: a capsule holding each segment mesh, in its own frame: the
    axis along the vertices' principal direction, from their smallest to their largest projection on
    it, the radius their largest distance from that axis (every vertex lies in the capsule).
    ``segments``: ``{name: vertices [V, 3]}``."""
    out = {}
    for k, v in segments.items():
        v = np.asarray(v, float)
        mean = v.mean(axis=0)
        _, _, vt = np.linalg.svd(v - mean, full_matrices=False)
        axis = vt[0]
        t = (v - mean) @ axis
        radial = np.linalg.norm((v - mean) - t[:, None] * axis, axis=1)
        out[k] = (mean + t.min() * axis, mean + t.max() * axis, float(radial.max()))
    return out


def person_footprints(poses: dict, capsules: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per frame the footprint disc of a body, ``(centres [T, 2], radii [T])`` (module docstring), from
    segment ``poses`` ``{segment: (rotations [T, 3, 3], translations [T, 3])}`` and ``capsules``
    (:func:`segment_capsules`)."""
    ends, radii = [], []
    for k, (a, b, r) in capsules.items():
        rot, trans = poses[k]
        for p in (a, b):
            ends.append((np.einsum("tab,b->ta", rot, p) + trans)[:, :2])
            radii.append(np.full(len(trans), r))
    d = np.stack(ends, axis=1)                          # [T, 2S, 2]
    rho = np.stack(radii, axis=1)                       # [T, 2S]
    lo = (d - rho[..., None]).min(axis=1)
    hi = (d + rho[..., None]).max(axis=1)
    mid = 0.5 * (lo + hi)
    radius = (np.linalg.norm(d - mid[:, None], axis=-1) + rho).max(axis=1)
    return mid, radius


def discs_apart(c1, r1, c2, r2, gap: float, same_frame: bool = True) -> bool:
    """Two sequences of discs (``centres [T, 2]``, ``radii [T]``) at least ``gap`` m apart: frame by frame
    (``same_frame``), or every disc of one from every disc of the other (the swept footprints disjoint)."""
    c1, c2 = np.asarray(c1, float), np.asarray(c2, float)
    r1, r2 = np.asarray(r1, float), np.asarray(r2, float)
    if same_frame:
        return bool(np.all(np.linalg.norm(c1 - c2, axis=-1) >= r1 + r2 + gap))
    d = np.linalg.norm(c1[:, None] - c2[None], axis=-1)
    return bool(np.all(d >= r1[:, None] + r2[None] + gap))


__all__ = ["Rect", "discs_apart", "person_footprints", "point_rect_distance", "point_segment_distance",
           "rects_clear", "segment_capsules", "segment_rect_distance"]
