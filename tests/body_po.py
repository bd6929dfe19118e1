r"""Monostatic RCS of the walking body at 77 GHz: physical optics + diffuse share, on a numpy render.

Shared by ``tests/test_body_rcs.py`` and ``benchmarks/body_rcs.py``. The body is
:class:`sionnafmcw.scenes.body.WalkingPerson` at one gait phase, in its own frame (:math:`x`
forward, :math:`y` left, :math:`z` up, feet on :math:`z = 0`); the radar stands at distance
:math:`R` and aspect :math:`\varphi` (0: in front of the person, 90 deg: on their left, 180 deg:
behind), at ``radar_height``, and renders the body on an equiangular grid
(:mod:`mesh_render`, the pixel engine's ray cast in numpy) with the smooth, interpolated vertex
normals (Mitsuba's shading normals from the PLY's ``nx, ny, nz``).

Skin
----
Dry skin (Gabriel's Cole-Cole model, :func:`sionnafmcw.materials.skin_properties`) at 77 GHz:
:math:`\hat\varepsilon = 6.57 - j8.92`, normal-incidence :math:`\Gamma = -0.559 + 0.167j`,
:math:`|\Gamma|^2 = 0.341` (-4.68 dB). The monostatic echo of a smooth body comes from its
specular points, where the incidence is normal, so :math:`\Gamma` is taken at normal incidence
for every sample (the impedance-surface PO of :mod:`sionnafmcw.physical_optics`).

Roughness: the Kirchhoff (Ament) coherent reflection of a Gaussian rough surface of rms height
:math:`h` is reduced in power by :math:`\exp(-(4\pi h\cos\theta_i/\lambda)^2)` (Beckmann &
Spizzichino 1963; Ament 1953); equating it with Sionna's specular share :math:`1 - S^2` at normal
incidence gives :math:`S = \sqrt{1 - \exp(-(4\pi h/\lambda)^2)}` (:func:`scattering_coefficient`).
:data:`SKIN_RMS_ROUGHNESS` is the literature value of the skin's surface relief (its comment gives
the source); it is not tuned.

RCS
---
Coherent share: :func:`sionnafmcw.physical_optics.monostatic_rcs` on the render samples
(:math:`\sqrt{1 - S^2}\,\Gamma`). Diffuse share: random-phase Lambertian scatterers
(:func:`sionnafmcw.diffuse.lambertian_gains`) add in power, so its expected RCS is
:math:`\sigma_d = (4\pi)^3R^4\sum_i|a_i|^2/\lambda^2 = \sum_i 4\Delta A_i\cos^2\theta_i\,S^2|\Gamma|^2`.
The mean RCS of one look is :math:`\sigma_{PO} + \sigma_d` (:func:`body_rcs`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import mesh_render
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.diffuse import lambertian_gains
from sionnafmcw.materials import skin_properties
from sionnafmcw.physical_optics import (angular_grid_steps, interpolated_normals, monostatic_rcs,
                                        normal_incidence_reflection, render_resolution, render_samples)
from sionnafmcw.scenes.body import SEGMENTS, WalkingPerson

FREQUENCY = 77e9
WAVELENGTH = SPEED_OF_LIGHT / FREQUENCY
EPSILON_0 = 8.8541878128e-12

#: rms height (m) of the skin's surface relief: its primary and secondary lines form a polygon
#: pattern 20-200 um deep (R. Bibb, *Medical Modelling*, Woodhead 2006, section 6.17.3, p. 264);
#: a sinusoidal relief of peak-to-valley depth d has rms d / (2 sqrt 2): 7-71 um, 39 um at the
#: middle depth 110 um (S = 0.125 at 77 GHz; 0.023 and 0.22 at the ends of the range).
SKIN_RMS_ROUGHNESS = 110e-6 / (2 * np.sqrt(2))


def skin_reflection(frequency: float = FREQUENCY) -> complex:
    """Normal-incidence reflection coefficient of dry skin (Gabriel's Cole-Cole model) at ``frequency``."""
    eps, sigma = skin_properties(frequency)
    return complex(normal_incidence_reflection(eps - 1j * sigma / (2 * np.pi * frequency * EPSILON_0)))


def scattering_coefficient(rms_height: float, wavelength: float = WAVELENGTH) -> float:
    r"""Sionna's :math:`S` whose specular share :math:`1 - S^2` equals the Kirchhoff coherent
    reduction :math:`\exp(-(4\pi h/\lambda)^2)` at normal incidence."""
    return float(np.sqrt(1.0 - np.exp(-(4 * np.pi * rms_height / wavelength) ** 2)))


def body_frame_mesh(person: WalkingPerson, phase: float):
    """The body at gait ``phase`` (cycles) in its own frame, feet on the floor: ``(vertices, faces, normals)``."""
    poses = person.local_poses(phase)
    lift = np.array([0.0, 0.0, person.hip_height + float(person.gait.vertical(phase))])
    vs, fs, ns, off = [], [], [], 0
    for k in SEGMENTS:
        r, o = poses[k]
        v, f = person.local_meshes[k]
        vs.append(v @ r.T + o + lift)
        ns.append(person.local_normals[k] @ r.T)
        fs.append(f + off)
        off += len(v)
    return np.concatenate(vs), np.concatenate(fs), np.concatenate(ns)


def cast_chunked(vertices, faces, origin, az, el, chunk: int = 20000):
    """:func:`mesh_render.cast` over blocks of ``chunk`` triangles (bounded memory), nearest hit kept."""
    best = None
    for start in range(0, len(faces), chunk):
        hit, t, tri, bary, d = mesh_render.cast(vertices, faces[start:start + chunk], origin, az, el)
        tri = np.where(hit, tri + start, -1)
        if best is None:
            best = [hit, t, tri, bary, d]
            continue
        closer = hit & (t < best[1])
        best[0] = best[0] | hit
        best[1] = np.where(closer, t, best[1])
        best[2] = np.where(closer, tri, best[2])
        best[3] = np.where(closer[:, None], bary, best[3])
    return tuple(best)


@dataclass
class BodyRCS:
    """One look: coherent PO and expected diffuse RCS (m^2), samples, pixel step (rad)."""

    po: float
    diffuse: float
    samples: int
    step: float

    @property
    def total(self) -> float:
        return self.po + self.diffuse


def render_body(vertices, faces, normals, radar, step, fields, surface=None):
    """:class:`SurfaceSamples` of the body seen from ``radar`` on a grid of ``step`` (rad) covering it,
    smooth normals with their shape operator. The body must lie towards +x of the radar (azimuths within +-pi/2).
    ``surface(triangle, barycentric) -> (points, normals)``: the samples moved onto a smooth surface (as the
    engines do, :meth:`sionnafmcw.smooth_surface.RefinedSurface.smooth_points`), their rays through them."""
    rel = vertices - radar
    az = np.arctan2(rel[:, 1], rel[:, 0])
    el = np.arctan2(rel[:, 2], np.hypot(rel[:, 0], rel[:, 1]))
    az_grid = np.arange(az.min() - 2 * step, az.max() + 2 * step, step)
    el_grid = np.arange(el.min() - 2 * step, el.max() + 2 * step, step)
    elg, azg = np.meshgrid(el_grid, az_grid, indexing="ij")
    hit, t, tri, bary, d = cast_chunked(vertices, faces, radar, azg, elg)
    f = faces[tri[hit]]
    b = bary[hit]
    n, curvature = interpolated_normals(vertices[f], normals[f], b)
    dirs, dist = d[hit], t[hit]
    if surface is not None:
        points, n = surface(tri[hit], b)
        dist = np.linalg.norm(points - radar, axis=1)
        dirs = (points - radar) / dist[:, None]
    step_az, step_el = angular_grid_steps(dirs, step, step)
    return render_samples(radar, dirs, dist, n, mesh_render.solid_angles(elg.ravel()[hit], step),
                          step_az, step_el, triangle=tri[hit], barycentric=b, curvature=curvature, **fields)


def pixel_step(person: WalkingPerson, distance: float) -> float:
    """Render step (rad) of :func:`sionnafmcw.physical_optics.render_resolution` for the body: extent its
    height, curvature its smallest limb radius (the forearm's 0.020 H; the toe and heel of the foot
    ellipsoid are sharper, 9 mm, but face along the floor, away from the radar)."""
    rho = 0.020 * person.height
    return render_resolution(person.height, distance, WAVELENGTH, curvature_radius=rho)


def body_look(person: WalkingPerson, phase: float, aspect_deg: float, distance: float, radar_height: float = 1.0,
              rms_height: float = SKIN_RMS_ROUGHNESS, step: float | None = None, mesh=None):
    """The render samples of ``person`` at gait ``phase`` seen from ``distance`` (m, horizontal, from the
    body axis) at ``aspect_deg`` and ``radar_height`` (m), with the radar point and the RCS reference
    point (the body axis at the radar's height): ``(samples, radar, reference)``."""
    v, f, n = body_frame_mesh(person, phase) if mesh is None else mesh
    # turn the body by -(aspect + pi) about z: the radar at (d cos a, d sin a) goes to (-d, 0), looking along +x
    a = math.radians(aspect_deg) + math.pi
    c, s_ = math.cos(a), math.sin(a)
    turn = np.array([[c, s_, 0.0], [-s_, c, 0.0], [0.0, 0.0, 1.0]])
    v, n = v @ turn.T, n @ turn.T
    radar = np.array([-distance, 0.0, radar_height])
    step = pixel_step(person, distance) if step is None else step
    gamma = skin_reflection()
    s = scattering_coefficient(rms_height)
    samples = render_body(v, f, n, radar, step, {"reflection": gamma, "scattering_coefficient": s})
    return samples, radar, np.array([0.0, 0.0, radar_height])


def body_rcs(person: WalkingPerson, phase: float, aspect_deg: float, distance: float, radar_height: float = 1.0,
             rms_height: float = SKIN_RMS_ROUGHNESS, step: float | None = None, mesh=None) -> BodyRCS:
    """Monostatic RCS of ``person`` at gait ``phase`` seen from ``distance`` (m, horizontal, from the body
    axis) at ``aspect_deg`` and ``radar_height`` (m): PO coherent share + expected diffuse share."""
    step = pixel_step(person, distance) if step is None else step
    samples, radar, reference = body_look(person, phase, aspect_deg, distance, radar_height, rms_height, step, mesh)
    po = monostatic_rcs(samples, radar, WAVELENGTH, reference)
    amp, _, _ = lambertian_gains(samples, radar[None], radar[None], WAVELENGTH)
    r = np.linalg.norm(radar - reference)
    diffuse = float((4 * np.pi) ** 3 * r ** 4 * np.sum(amp ** 2) / WAVELENGTH ** 2)
    return BodyRCS(po, diffuse, samples.num_samples, step)


def db(x):
    return 10 * np.log10(np.asarray(x, float))
