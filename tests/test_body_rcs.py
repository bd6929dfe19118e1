"""The walking body's mesh resolution and its physical-optics RCS at 77 GHz (32 mm segments
with exact normals, rendered on their smooth surface).

Tolerances from physics: the sagitta rules (lambda/25 for the PO surface, 1/8 of a range bin for
Sionna's proxy), the PO of a sphere (pi r^2 |Gamma|^2 (1 - S^2) within 1 dB, 1/(ka) ripple and render
quadrature), the issue's 1 dB against the body on its exact shapes, and the spread of 3GPP TR 38.901's
human model (10-90 % of model 1) for the body's RCS. Geometry and render: numpy (tests/mesh_render.py,
tests/body_po.py, tests/smooth_po.py: the body as the engines render it).
"""

from __future__ import annotations

import numpy as np
import pytest

import body_po as bp
from sionnafmcw.animation.ply import ply_bytes, read_ply
from sionnafmcw.physical_optics import monostatic_rcs, render_resolution
from sionnafmcw.scenes import meshes
import smooth_po as sp
from sionnafmcw import RadarConfig
from sionnafmcw.engines.path import PROXY_SAGITTA_FRACTION
from sionnafmcw.engines.surfaces import Surface
from sionnafmcw.scenes.body import (MAX_NORMAL_TURN, MESH_EDGE, SEGMENTS, Anthropometry, WalkingPerson, segment_meshes,
                                    segment_normals, segment_shapes)


def default_body_rcs(phase, aspect, distance, step=None):
    """The default body as the engines render it: its stored meshes refined to their smooth surface, the
    samples on it (tests/smooth_po.py)."""
    person = WalkingPerson()
    refined = sp.refined_segments(person)
    return sp.body_rcs(person, sp.refined_segment_meshes(refined), phase, aspect, distance,
                       surface=sp.refined_surface(refined), step=step)


@pytest.mark.parametrize("edge", [0.008, MESH_EDGE])
def test_segment_meshes_respect_max_edge_and_stay_closed(edge):
    meshes_ = segment_meshes(Anthropometry(1.8), edge)
    assert set(meshes_) == set(SEGMENTS)
    for name, (v, f) in meshes_.items():
        assert meshes.edge_lengths(v, f).max() <= edge * (1 + 1e-9), name
        assert meshes.signed_volume(v, f) > 0, name          # closed, outward winding


def test_default_mesh_meets_both_resolution_rules():
    """The default segment meshes (32 mm) as the engines use them: refined, every sub-facet lies within
    lambda/25 of the smooth surface (smooth_surface's level rule); as stored (Sionna's proxy), every facet
    within 1/8 of a range bin of every preset (the foot's and forearm's 2.3 mm against 5.4 mm for the
    TI boards); no grid step turns the normal by more than MAX_NORMAL_TURN."""
    from sionnafmcw.smooth_surface import SAGITTA_FRACTION, facet_sagitta

    body = Anthropometry(1.8)
    local = segment_meshes(body)
    normals = segment_normals(body, local)
    proxy_limit = PROXY_SAGITTA_FRACTION * min(RadarConfig.preset(n).range_resolution for n in RadarConfig.presets())
    for name, (v, f) in local.items():
        surface = Surface.build(name, "rigid", v, f, normals[name], wavelength=bp.WAVELENGTH)
        assert 0 < surface.bulge <= proxy_limit, (name, surface.bulge, proxy_limit)
        sub = facet_sagitta(v, f, normals[name][f]) / surface.level ** 2
        assert sub.max() <= SAGITTA_FRACTION * bp.WAVELENGTH * (1 + 1e-9), name
        n = normals[name]
        turn = np.arccos(np.clip(np.einsum("fci,fci->fc", n[f], n[np.roll(f, 1, axis=1)]), -1, 1))
        # a cell's diagonal spans two grid steps; its sides one
        assert turn.max() <= 2 * MAX_NORMAL_TURN * (1 + 1e-6), (name, turn.max())


def test_walker_normals_are_its_shapes_exact_normals():
    """The PLYs carry the exact normals of the segments' ellipsoids and capsules (the gradient of the
    quadric; radial from the capsule's axis segment): unit, and perpendicular to the surface's tangent
    plane, which a vertex's neighbours approach as the mesh is refined."""
    body = Anthropometry(1.8)
    for edge in (0.032, 0.008):
        local = segment_meshes(body, edge)
        normals = segment_normals(body, local)
        for name, shape in segment_shapes(body).items():
            v, f = local[name]
            n = normals[name]
            assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
            if shape[0] == "ellipsoid":
                grad = (v - shape[1]) / np.asarray(shape[2]) ** 2
                np.testing.assert_allclose(np.cross(n, grad), 0.0, atol=1e-9)
            area_weighted = meshes.vertex_normals(v, f)
            # the mesh's own normals approach them as the facets shrink (their angle ~ edge / curvature radius)
            worst = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, area_weighted), -1, 1))).max()
            rho = shape[3] if shape[0] == "capsule" else sorted(shape[2])[0] ** 2 / sorted(shape[2])[2]
            assert worst < np.degrees(edge / rho), (name, edge, worst)


def test_vertex_normals_are_the_smooth_surface_normals():
    """On a sphere the area-weighted vertex normals are the radial directions (within the mesh's angular step)."""
    theta, phi = meshes.ellipsoid_grid((0.1, 0.1, 0.1), MESH_EDGE)
    v, f = meshes.ellipsoid((0, 0, 0), (0.1, 0.1, 0.1), theta=theta, phi=phi)
    n = meshes.vertex_normals(v, f)
    err = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, v / 0.1), -1, 1)))
    assert err.max() < np.degrees(MESH_EDGE / 0.1) / 4


def test_walking_person_state_carries_rotated_normals():
    person = WalkingPerson(mesh_edge=0.032)
    state = person.segment_state(0.3)
    for k in ("torso", "left_lower_leg"):
        r, _ = person.poses(0.3)[k]
        np.testing.assert_allclose(state[k].vertex_normals, person.local_normals[k] @ r.T)
        np.testing.assert_allclose(np.linalg.norm(state[k].vertex_normals, axis=1), 1.0, atol=1e-12)


def test_ply_round_trips_vertex_normals(tmp_path):
    person = WalkingPerson(mesh_edge=0.032)
    state = person.segment_state(0.1)["left_upper_arm"]
    path = tmp_path / "arm.ply"
    path.write_bytes(ply_bytes(state.vertices, person.faces("left_upper_arm"), state.vertex_velocities,
                               vertex_normals=state.vertex_normals))
    ply = read_ply(path)
    np.testing.assert_allclose(ply.vertex_normals, state.vertex_normals, atol=1e-6)
    np.testing.assert_allclose(ply.vertex_velocities, state.vertex_velocities, rtol=1e-6, atol=1e-6)
    assert read_ply(_plain(tmp_path, state, person)).vertex_normals is None
    with pytest.raises(ValueError, match="unit"):
        ply_bytes(state.vertices, person.faces("left_upper_arm"), vertex_normals=2 * state.vertex_normals)


def _plain(tmp_path, state, person):
    path = tmp_path / "plain.ply"
    path.write_bytes(ply_bytes(state.vertices, person.faces("left_upper_arm")))
    return path


def test_skin_sphere_at_default_mesh_returns_pi_r2_gamma2_within_1_db():
    """A skin sphere of the forearm's radius (the body's smallest limb curvature), meshed at the default
    edge with exact normals, refined and sampled on its smooth surface as the engines do: near-field PO
    at 3 m within 1 dB of pi r^2 |Gamma|^2 (1 - S^2)."""
    from sionnafmcw.smooth_surface import pn_refine, refinement_level

    r, distance = 0.036, 3.0
    theta, phi = meshes.ellipsoid_grid((r, r, r), MESH_EDGE, MAX_NORMAL_TURN)
    v, f = meshes.ellipsoid((distance, 0, 0), (r, r, r), theta=theta, phi=phi)
    n = meshes.ellipsoid_normals(v, (distance, 0, 0), (r, r, r))
    refined = pn_refine(v, f, n[f], refinement_level(v, f, n[f], bp.WAVELENGTH))
    gamma, s = bp.skin_reflection(), bp.scattering_coefficient(bp.SKIN_RMS_ROUGHNESS)
    step = render_resolution(2 * r, distance, bp.WAVELENGTH, curvature_radius=r)
    samples = bp.render_body(refined.vertices, refined.faces, refined.normals, np.zeros(3), step,
                             {"reflection": gamma, "scattering_coefficient": s}, surface=refined.smooth_points)
    sigma = monostatic_rcs(samples, np.zeros(3), bp.WAVELENGTH, (distance, 0, 0))
    expected = np.pi * r ** 2 * abs(gamma) ** 2 * (1 - s ** 2)
    assert abs(bp.db(sigma) - bp.db(expected)) < 1.0, (bp.db(sigma), bp.db(expected))


def test_body_rcs_facing_the_radar_lies_in_the_tr38901_human_range():
    """The default body seen from the front at 3 m (PO + diffuse) lies within the 10-90 % range of 3GPP TR
    38.901's human model 1 (10 lg sigma_M = -1.37 dBsm, log-normal sigma_S of 3.94 dB: -8.2 .. +1.9 dBsm)."""
    rcs = default_body_rcs(0.0, 0.0, 3.0)
    low, high = -1.37 - 0.1151 * 3.94 ** 2 - 1.2816 * 3.94, -1.37 - 0.1151 * 3.94 ** 2 + 1.2816 * 3.94
    assert low < bp.db(rcs.total) < high, (bp.db(rcs.total), low, high)
    assert rcs.po > rcs.diffuse          # a smooth skin body: the coherent (PO) share dominates facing the radar


LOOKS = [(d, a) for d in (3.0, 10.0) for a in (0.0, 30.0, 90.0, 150.0, 180.0)]


@pytest.mark.parametrize("distance, aspect", [
    (3.0, 30.0), *(pytest.param(d, a, marks=pytest.mark.slow) for d, a in LOOKS if (d, a) != (3.0, 30.0))])
def test_default_body_within_1_db_of_its_exact_shapes(distance, aspect):
    """The default body (32 mm segments, refined, samples on the smooth surface) against the body on its
    exact ellipsoids and capsules (8 mm mesh, every hit moved onto the exact shape), at the convergence
    study's looks (gait phase 0, radar 1 m high), pixel step half the rule's (the rule's own step moves
    the exact body by up to 1.1 dB between steps 1 and 1/2, benchmarks/smooth_surface.py walker; the
    difference tested here moves by at most 0.23 dB between steps 1/2 and 1/4 at 3 m 30 / 180 deg and
    10 m 30 deg): within the issue's 1 dB. (The 8 mm body with flat samples, the former default, is
    itself up to 1.07 dB off at these looks.)"""
    exact_person = WalkingPerson(mesh_edge=0.008)
    step = bp.pixel_step(exact_person, distance) / 2
    exact = sp.body_rcs(exact_person, sp.coarse_segments(exact_person), 0.0, aspect, distance,
                        surface=sp.analytic_surface(exact_person), step=step)
    default = default_body_rcs(0.0, aspect, distance, step=step)
    assert abs(bp.db(default.po) - bp.db(exact.po)) < 1.0, (bp.db(default.po), bp.db(exact.po))
