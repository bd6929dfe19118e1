r"""Body segment shapes from anthropometry: girths, tapered limbs with curved generators, torso ellipsoids.

Anthropometric source
---------------------
Girths (circumferences) as fractions of the stature :math:`H`, the means of the 247 men and 260
women of G. Heinz, L. J. Peterson, R. W. Johnson and C. J. Kerk, "Exploring relationships in body
dimensions", *Journal of Statistics Education* 11(2), 2003 (the ``bdims`` data set; ratios of the
group means, computed from the published data):

==================  ======  ======  =====================================================
girth / H           men     women   where it is measured
==================  ======  ======  =====================================================
thigh               0.3179  0.3469  below the gluteal fold (the thigh's largest girth)
knee                0.2093  0.2139  over the patella, knee slightly flexed
calf                0.2093  0.2123  largest girth of the calf
ankle               0.1303  0.1286  smallest girth above the malleoli
biceps              0.1936  0.1704  flexed, largest
forearm             0.1589  0.1441  largest, arm extended, palm up
wrist               0.0967  0.0913  smallest, distal to the styloid processes
chest               0.5682  0.5220  at the nipples, mid-expiration
waist               0.4756  0.4234  narrowest part of the torso
hip                 0.5500  0.5802  largest girth of the buttocks
chest depth         0.1171  0.1075  sternum to spine at the nipples (a diameter)
chest width         0.1685  0.1583  at the nipples (a diameter)
==================  ======  ======  =====================================================

A girth :math:`G` becomes a circular section of radius :math:`G/2\pi` (limbs) or an elliptic one
(torso) of semi-axes :math:`(a, b)` with the chest's depth:width ratio :math:`a/b` and the perimeter
:math:`G` (Ramanujan's formula, :func:`sionnafmcw.scenes.meshes.ellipse_perimeter`). Lengths
along the limbs come from the skeleton (:mod:`.segments`); the hand (0.108 H wrist to fingertip), the
foot (0.152 H long, the ankle 0.039 H above the sole and 0.031 H in front of the heel) and the
head follow D. A. Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed., 2009,
Fig. 4.1, as :mod:`sionnafmcw.scenes.body` does.

Tapered limbs (why not capsules)
--------------------------------
A cylinder of radius :math:`a` and length :math:`L` seen broadside returns the physical-optics
flash :math:`\sigma = 2\pi a L^2/\lambda` (21 m\ :sup:`2` for a 0.43 m thigh of 7 cm radius at
77 GHz, +13 dBsm): every straight generator makes one, a cone's too (off broadside by its taper
angle). A real thigh or shank is curved along its length. Each limb here is a surface of
revolution whose radius profile is a parabola along the bone,

.. math:: r(s) = r_p - k\,(s/L - s_p)^2, \qquad k = \frac{r_p - r_e}{(s_e - s_p)^2},

through its anthropometric stations (the largest girth :math:`r_p` at the fraction :math:`s_p` of the
bone, a second girth :math:`r_e` at :math:`s_e`), closed at both ends by spherical caps tangent to
it (centre on the axis at :math:`s_0 + r\,r'`, radius :math:`r\sqrt{1 + r'^2}`: C1 everywhere). Its
generator has the curvature :math:`\kappa = 2k/L^2` (about 0.3 m\ :sup:`-1` for the thigh and
the shank): the specular point is doubly curved, :math:`\sigma \approx \pi a/\kappa`, a few
tenths of a square metre, with no line flash. Stations (fractions of the bone from its proximal
joint): thigh :math:`(0, \text{thigh})` to :math:`(1, \text{knee})`; shank
:math:`(0.3, \text{calf})` to :math:`(1, \text{ankle})` (the calf's largest girth about a third of
the way down, where the gastrocnemius is); upper arm :math:`(0.5, \text{biceps})` to
:math:`(1, \text{forearm})`; forearm :math:`(0.2, \text{forearm})` to :math:`(1, \text{wrist})`.

Meshes and normals
------------------
The meridian (cap, profile, cap) is cut into arcs of at most :math:`e/\sqrt2` and the
circumference into equal arcs of at most :math:`e/\sqrt 2` at the largest radius, so every
triangle edge is at most :math:`e` (``max_edge``), as :mod:`sionnafmcw.scenes.meshes` does for
its ellipsoids; no step turns the normal by more than
:data:`~sionnafmcw.scenes.meshes.MAX_NORMAL_TURN` (the caps and the feet, where the radius of
curvature is a few centimetres). Vertex normals are the exact normals of the smooth surface (profile:
:math:`\propto (-r'(s), 1)` in (axial, radial); caps and ellipsoids: their gradients), which the
physical-optics render interpolates.

numpy only (and :mod:`sionnafmcw.scenes.meshes`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scenes import meshes

#: Girth / stature and the chest's diameters / stature (module docstring), Heinz et al. 2003.
GIRTHS = {
    "male": {"thigh": 0.3179, "knee": 0.2093, "calf": 0.2093, "ankle": 0.1303, "biceps": 0.1936,
             "forearm": 0.1589, "wrist": 0.0967, "chest": 0.5682, "waist": 0.4756, "hip": 0.5500,
             "chest_depth": 0.1171, "chest_width": 0.1685},
    "female": {"thigh": 0.3469, "knee": 0.2139, "calf": 0.2123, "ankle": 0.1286, "biceps": 0.1704,
               "forearm": 0.1441, "wrist": 0.0913, "chest": 0.5220, "waist": 0.4234, "hip": 0.5802,
               "chest_depth": 0.1075, "chest_width": 0.1583},
}
BUILDS = tuple(GIRTHS)
#: Lengths / stature from Winter (module docstring).
WINTER = {"hand": 0.108, "foot_length": 0.152, "ankle_height": 0.039, "heel": 0.031, "leg": 0.245 + 0.246}
#: Limb profiles: (peak fraction, peak girth, end fraction, end girth) along the bone.
LIMB_STATIONS = {
    "upper_leg": (0.0, "thigh", 1.0, "knee"),
    "lower_leg": (0.3, "calf", 1.0, "ankle"),
    "upper_arm": (0.5, "biceps", 1.0, "forearm"),
    "lower_arm": (0.2, "forearm", 1.0, "wrist"),
}


def girth_radius(build: str, girth: str, height: float) -> float:
    """Radius (m) of the circle whose perimeter is the ``girth`` of a person of stature ``height`` (m)."""
    if build not in GIRTHS:
        raise ValueError(f"build {build!r} is unknown; choose one of {', '.join(BUILDS)}")
    return GIRTHS[build][girth] * height / (2 * math.pi)


def ellipse_semi_axes(girth: float, ratio: float) -> tuple[float, float]:
    """Semi-axes ``(a, b)`` (m), :math:`a = \\text{ratio}\\,b`, of the ellipse of perimeter ``girth`` (m)."""
    unit = meshes.ellipse_perimeter(ratio, 1.0)
    b = girth / unit
    return ratio * b, b


@dataclass(frozen=True)
class ParabolicProfile:
    r"""Radius :math:`r(s) = r_p - k(s/L - s_p)^2` (m) along a limb of length ``length`` (module docstring)."""

    length: float
    peak_fraction: float
    peak_radius: float
    end_fraction: float
    end_radius: float

    @property
    def k(self) -> float:
        return (self.peak_radius - self.end_radius) / (self.end_fraction - self.peak_fraction) ** 2

    def radius(self, s):
        return self.peak_radius - self.k * (np.asarray(s, float) / self.length - self.peak_fraction) ** 2

    def slope(self, s):
        """:math:`dr/ds`."""
        return -2 * self.k * (np.asarray(s, float) / self.length - self.peak_fraction) / self.length

    @property
    def generator_curvature(self) -> float:
        """:math:`|r''| = 2k/L^2` (1/m), the curvature of the generator where it is parallel to the axis."""
        return 2 * abs(self.k) / self.length ** 2


def limb_profile(kind: str, length: float, build: str, height: float) -> ParabolicProfile:
    """The :class:`ParabolicProfile` of limb ``kind`` (a key of :data:`LIMB_STATIONS`) of bone ``length`` (m)."""
    sp, gp, se, ge = LIMB_STATIONS[kind]
    profile = ParabolicProfile(float(length), sp, girth_radius(build, gp, height), se, girth_radius(build, ge, height))
    if np.any(profile.radius(np.linspace(0.0, length, 65)) <= 0):
        raise ValueError(f"limb {kind!r}: the profile through its girths is not positive over the bone ({length} m)")
    return profile


def _equal_arcs(points, spacing: float, minimum: int, max_turn: float | None = None) -> np.ndarray:
    r"""The dense polyline ``points [N, K]`` (its first two columns the curve, the next two its unit
    normal when ``max_turn`` is given, the others carried along) cut into ``n >= minimum`` arcs of at
    most ``spacing`` each turning the normal by at most ``max_turn`` (rad): equal steps of
    :math:`\int\max(ds/h,\ d\psi/\psi_{max})`; the cut points ``[n + 1, K]``."""
    step = np.linalg.norm(np.diff(points[:, :2], axis=0), axis=1) / spacing
    if max_turn is not None:
        cos = np.clip(np.einsum("ij,ij->i", points[1:, 2:4], points[:-1, 2:4]), -1.0, 1.0)
        step = np.maximum(step, np.arccos(cos) / max_turn)
    arc = np.concatenate([[0.0], np.cumsum(step)])
    n = max(minimum, int(math.ceil(arc[-1] - 1e-9)))
    targets = np.linspace(0.0, arc[-1], n + 1)
    return np.stack([np.interp(targets, arc, points[:, k]) for k in range(points.shape[1])], axis=1)


def revolved_limb(p0, p1, profile: ParabolicProfile, max_edge: float):
    r"""Closed tapered limb from ``p0`` to ``p1`` (m): ``(vertices [V, 3], faces [F, 3], normals [V, 3])``.

    The surface of revolution of ``profile`` about the axis :math:`\mathbf p_0\to\mathbf p_1`, capped
    by tangent spheres (module docstring), every triangle edge at most ``max_edge``.
    """
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    axis = p1 - p0
    length = float(np.linalg.norm(axis))
    if not length > 0:
        raise ValueError("revolved_limb: p0 and p1 coincide")
    d = axis / length
    e1 = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    # dense meridian in (axial s, radial r) with its normal angle
    r0, r1 = float(profile.radius(0.0)), float(profile.radius(length))
    g0, g1 = float(profile.slope(0.0)), float(profile.slope(length))
    c0, rho0 = r0 * g0, r0 * math.hypot(1.0, g0)
    c1, rho1 = length + r1 * g1, r1 * math.hypot(1.0, g1)
    th0 = math.atan2(1.0, g0)           # start cap: polar angle from -axis to the end ring's normal
    th1 = math.atan2(1.0, -g1)          # end cap: polar angle from +axis
    dense = 2048
    t = np.linspace(0.0, th0, dense)
    cap0 = np.stack([c0 - rho0 * np.cos(t), rho0 * np.sin(t), -np.cos(t), np.sin(t)], 1)
    s = np.linspace(0.0, length, 4 * dense)
    r = profile.radius(s)
    g = profile.slope(s)
    norm = np.hypot(1.0, g)
    body = np.stack([s, r, -g / norm, 1.0 / norm], 1)
    t = np.linspace(th1, 0.0, dense)
    cap1 = np.stack([c1 + rho1 * np.cos(t), rho1 * np.sin(t), np.cos(t), np.sin(t)], 1)
    meridian = np.concatenate([cap0, body[1:], cap1[1:]])
    h = max_edge / math.sqrt(2.0)
    # [n + 1, 4]: s, r, n_axial, n_radial (interpolated); steps turn the normal by MAX_NORMAL_TURN at most
    cut = _equal_arcs(meridian, h, 8, meshes.MAX_NORMAL_TURN)
    nrm = np.hypot(cut[:, 2], cut[:, 3])
    cut[:, 2:] /= nrm[:, None]
    rings = cut[1:-1]
    # around: arcs of at most h at the largest radius and at most MAX_NORMAL_TURN of the normal
    n_seg = max(8, int(math.ceil(2 * math.pi * float(rings[:, 1].max()) / h - 1e-9)),
                int(math.ceil(2 * math.pi / meshes.MAX_NORMAL_TURN - 1e-9)))
    phi = np.linspace(0.0, 2 * math.pi, n_seg, endpoint=False)
    radial = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2        # [n_seg, 3]
    verts = [p0 + cut[0, 0] * d]
    normals = [-d]
    for sk, rk, na, nr in rings:
        verts.extend(p0 + sk * d + rk * radial)
        normals.extend(na * d + nr * radial)
    verts.append(p0 + cut[-1, 0] * d)
    normals.append(d)
    faces = _lat_long_faces(len(rings), n_seg)
    v = np.array(verts)
    n = np.array(normals)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    if meshes.signed_volume(v, faces) < 0:
        faces = faces[:, ::-1].copy()
    return v, faces, n


def _lat_long_faces(n_rings: int, n_seg: int) -> np.ndarray:
    """Faces of a closed lat-long surface: pole 0, ``n_rings`` rings of ``n_seg``, the other pole last."""
    last = 1 + n_rings * n_seg
    ring = lambda i, j: 1 + i * n_seg + (j % n_seg)  # noqa: E731
    faces = []
    for j in range(n_seg):
        faces.append((0, ring(0, j + 1), ring(0, j)))
        faces.append((last, ring(n_rings - 1, j), ring(n_rings - 1, j + 1)))
    for i in range(n_rings - 1):
        for j in range(n_seg):
            faces.append((ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)))
            faces.append((ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)))
    return np.array(faces, dtype=np.int64)


def ellipsoid_surface(centre, radii, rotation, max_edge: float):
    r"""Closed ellipsoid ``(vertices, faces, normals)``: semi-axes ``radii`` along the columns of
    ``rotation`` (3x3), centred at ``centre``; edges at most ``max_edge``
    (:func:`sionnafmcw.scenes.meshes.ellipsoid_grid`); normals :math:`\propto \mathbf R\,(x/a^2, y/b^2, z/c^2)`
    of the local coordinates."""
    radii = np.asarray(radii, float)
    rotation = np.asarray(rotation, float)
    theta, phi = meshes.ellipsoid_grid(radii, max_edge, meshes.MAX_NORMAL_TURN)
    local, faces = meshes.ellipsoid((0.0, 0.0, 0.0), radii, theta=theta, phi=phi)
    n = local / radii ** 2
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return local @ rotation.T + np.asarray(centre, float), faces, n @ rotation.T


def merge_surfaces(*parts):
    """Concatenate ``(vertices, faces, normals)`` triples into one."""
    v, f = meshes.merge(*[(p[0], p[1]) for p in parts])
    return v, f, np.concatenate([p[2] for p in parts])


__all__ = ["BUILDS", "GIRTHS", "LIMB_STATIONS", "ParabolicProfile", "WINTER", "ellipse_semi_axes",
           "ellipsoid_surface", "girth_radius", "limb_profile", "merge_surfaces", "revolved_limb"]
