"""Scene builders (``sionnafmcw.scenes``): registry, simple scenes, the Boulic walking person.

Fast tests write small animation directories and check them through ``load_animation``; the
gait tests check the kinematic chain against the Boulic-Thalmann model (as V. C. Chen implements
it) and against a sagittal-plane reduction of it; the slow test runs ``straight_walk`` through the
path engine and reads the torso line and the limb envelope off the micro-Doppler spectrogram.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sionnafmcw import load_animation, scenes
from sionnafmcw.animation import read_ply
from sionnafmcw.scenes import meshes
from sionnafmcw.scenes.body import SEGMENTS, LineTrack, WalkingPerson, radial_velocities
from sionnafmcw.scenes.gait import RV_MAX, BoulicGait, GaitTiming, relative_cycle_length
from sionnafmcw.scenes.walking import analytic_truth, circle_person, straight_person

ALL = ("circle_walk", "corner_reflectors", "empty_room", "moving_plate", "straight_walk")
FLOAT32_POS = 1e-5  # m: float32 PLY coordinates at ranges below ~10 m (eps 6e-8 * 10 m, times a margin)


# =========================================================================== registry
def test_names_parameters_describe():
    assert set(ALL) <= set(scenes.names())
    assert scenes.names() == sorted(scenes.names())
    for name in ALL:
        params = scenes.parameters(name)
        assert params, name
        text = scenes.describe(name)
        for key, p in params.items():
            assert key in text
            assert isinstance(p, scenes.Parameter)
            if p.type is float:
                assert isinstance(p.default, float)
            elif p.type is tuple:
                assert all(isinstance(x, float) for x in p.default)
            else:
                assert type(p.default) is p.type, (name, key)
        assert {"num_frames", "fps"} <= set(params)


def test_unknown_scenario_lists_the_valid_ones(tmp_path):
    with pytest.raises(ValueError, match="circle_walk.*moving_plate") as err:
        scenes.build("no_such_scene", tmp_path / "x")
    assert "no_such_scene" in str(err.value)
    for fn in (scenes.parameters, scenes.describe):
        with pytest.raises(ValueError, match="no_such_scene"):
            fn("no_such_scene")


@pytest.mark.parametrize("params, match", [
    ({"sped": 1.0}, r"no parameter 'sped'.*valid parameters: start_range, speed"),
    ({"num_frames": 2.0}, r"'num_frames'=2\.0 is not an integer"),
    ({"num_frames": True}, r"'num_frames'=True is not an integer"),
    ({"speed": "fast"}, r"'speed'='fast' is not a number"),
    ({"room": 1}, r"'room'=1 is not a bool"),
    ({"fps": float("nan")}, r"'fps'=nan is not finite"),
    ({"num_frames": 0}, r"'num_frames'=0 is out of range"),
])
def test_bad_parameters_name_the_parameter(tmp_path, params, match):
    with pytest.raises(ValueError, match=match):
        scenes.build("moving_plate", tmp_path / "x", **params)
    assert not (tmp_path / "x").exists()


def test_bad_tuple_and_choice_parameters(tmp_path):
    with pytest.raises(ValueError, match="'ranges'.*not a number"):
        scenes.build("corner_reflectors", tmp_path / "x", ranges=(3.0, "far"))
    with pytest.raises(ValueError, match="'wall_material'='marble' is not an allowed choice"):
        scenes.build("empty_room", tmp_path / "x", wall_material="marble")
    with pytest.raises(ValueError, match="same non-zero length"):
        scenes.build("corner_reflectors", tmp_path / "x", ranges=(3.0, 4.0))
    assert not (tmp_path / "x").exists()


def test_parse_params_from_command_line_text():
    got = scenes.parse_params("corner_reflectors", ["ranges=3, 4.5", "room=yes", "num_frames=3", "leg=0.2"])
    assert got == {"ranges": (3.0, 4.5), "room": True, "num_frames": 3, "leg": 0.2}
    with pytest.raises(ValueError, match="'num_frames'='3.5' cannot be parsed"):
        scenes.parse_params("corner_reflectors", ["num_frames=3.5"])
    with pytest.raises(ValueError, match="key=value"):
        scenes.parse_params("corner_reflectors", ["num_frames"])
    with pytest.raises(ValueError, match="no parameter 'rnages'"):
        scenes.parse_params("corner_reflectors", ["rnages=3"])


def test_subpackages_are_attributes_of_the_package(tmp_path):
    """``import sionnafmcw as sf; sf.scenes.build(...)`` in a fresh interpreter (nothing imported before)."""
    import subprocess
    import sys

    code = ("import sys, sionnafmcw as sf\n"
            f"path = sf.scenes.build('moving_plate', {str(tmp_path / 'plate')!r}, num_frames=2)\n"
            "print(sf.load_animation(path).num_frames, sf.RadarConfig.__name__)\n"
            "for name in ('dataset', 'validation', 'tf', 'processing', 'plots', 'engines', 'ti'):\n"
            "    assert name in dir(sf), name\n"
            "print(callable(sf.engines.names), callable(sf.processing.range_doppler_map))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["2", "RadarConfig", "True", "True"]


def test_build_refuses_non_empty_output_and_overwrites_on_request(tmp_path):
    out = tmp_path / "plate"
    out.mkdir()
    assert scenes.build("moving_plate", out, num_frames=2) == out  # an empty directory is fine
    first = json.loads((out / "animation.json").read_text())
    with pytest.raises(FileExistsError, match="overwrite=True"):
        scenes.build("moving_plate", out, num_frames=3)
    assert json.loads((out / "animation.json").read_text()) == first
    scenes.build("moving_plate", out, num_frames=3, overwrite=True)
    assert len(load_animation(out).frames) == 3
    assert not (out / "meshes" / "plate_0003.ply").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plate"]  # no temporary siblings left


def test_failing_builder_leaves_nothing_behind(tmp_path):
    # the plate would run into the radar: the builder raises after its directory was created
    with pytest.raises(ValueError, match="into the radar"):
        scenes.build("moving_plate", tmp_path / "plate", start_range=1.0, speed=-5.0, num_frames=24)
    assert list(tmp_path.iterdir()) == []


# =========================================================================== simple scenes
@pytest.mark.parametrize("room", [False, True])
def test_moving_plate(tmp_path, room):
    """Plate centre at R(t) = R0 + v t along the azimuth, normal towards the radar, manifest velocity v u."""
    r0, v, az, fps = 4.0, -1.5, 0.3, 10.0
    out = scenes.build("moving_plate", tmp_path / "p", start_range=r0, speed=v, azimuth=az, num_frames=4, fps=fps,
                       room=room)
    anim = load_animation(out)
    scenario = anim.manifest["scenario"]
    assert scenario["name"] == "moving_plate"
    assert set(scenario["parameters"]) == set(scenes.parameters("moving_plate"))
    assert scenario["parameters"]["speed"] == v and scenario["parameters"]["subdiv"] == 1
    u = np.array([math.cos(az), math.sin(az), 0.0])
    radar = anim.radar_pose.position
    for i in range(anim.num_frames):
        mesh = anim.mesh(i, "plate")
        assert np.allclose(mesh.centroid - radar, (r0 + v * i / fps) * u, atol=FLOAT32_POS)
        assert np.allclose(anim.object_velocity(i, "plate"), v * u)
        tri = mesh.vertices[mesh.faces[0]]
        n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
        assert n @ u < 0  # faces the radar
    shapes = anim.frame_xml(0).shapes
    assert ("wall_x1" in shapes) == room
    if room:
        assert {s.material.itu_type for s in shapes.values()} == {"metal", "concrete", "floorboard", "plasterboard"}
        anim.check_frequency(77e9)


def test_corner_reflectors(tmp_path):
    """Corners at (R_k + v_k t) u_k; the aperture axis (1,1,1)/sqrt(3) of each trihedral points at the radar."""
    ranges, az, speeds, leg = (3.0, 5.0), (-0.3, 0.35), (0.0, 0.5), 0.15
    out = scenes.build("corner_reflectors", tmp_path / "c", ranges=ranges, azimuths=az, speeds=speeds, leg=leg,
                       num_frames=3, fps=10.0)
    anim = load_animation(out)
    assert set(anim.object_names) == {"reflector_0", "reflector_1"}  # static ones too, with zero velocity
    radar = anim.radar_pose.position
    for i in range(3):
        for k in range(2):
            u = np.array([math.cos(az[k]), math.sin(az[k]), 0.0])
            mesh = anim.mesh(i, f"reflector_{k}")
            corner = radar + (ranges[k] + speeds[k] * i / 10.0) * u
            d = np.linalg.norm(mesh.vertices - corner, axis=1)
            assert d.min() < FLOAT32_POS and d.max() == pytest.approx(leg, abs=FLOAT32_POS)
            # the aperture axis is the mean direction of the three legs from the corner: towards the radar
            tips = mesh.vertices[np.abs(d - leg) < FLOAT32_POS]
            axis = (tips - corner).mean(axis=0)
            assert np.dot(axis / np.linalg.norm(axis), -u) == pytest.approx(1.0, abs=1e-6)
            assert np.allclose(anim.object_velocity(i, f"reflector_{k}"), speeds[k] * u)


def test_empty_room(tmp_path):
    anim = load_animation(scenes.build("empty_room", tmp_path / "r", length=7.0, width=5.0, num_frames=2))
    assert anim.object_names == []
    assert len(anim.frame_xml(0).shapes) == 6
    lo = np.min([anim.mesh(0, n).vertices.min(0) for n in anim.frame_xml(0).shapes], axis=0)
    hi = np.max([anim.mesh(0, n).vertices.max(0) for n in anim.frame_xml(0).shapes], axis=0)
    assert np.allclose(lo, [-0.1, -2.6, -0.1]) and np.allclose(hi, [7.1, 2.6, 3.1])
    anim.check_frequency(77e9)


def test_trihedral_and_body_meshes_are_closed():
    """Every body segment is a closed, outward-wound surface (positive volume, each edge in two faces)."""
    person = WalkingPerson()
    for name, (v, f) in person.local_meshes.items():
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        assert np.all(counts == 2), name
        assert meshes.signed_volume(v, f) > 0, name
    # body.MESH_EDGE (32 mm edges, curvature-capped steps: the engines render the smooth surface):
    # ~2.0 m^2 of skin in right triangles of legs <= 22.6 mm, finer at the feet
    assert 10_000 < sum(len(f) for _, f in person.local_meshes.values()) < 20_000


# =========================================================================== the gait model
def test_gait_timing():
    """Boulic: RV = V/H_t, RL_c = 1.346 sqrt(RV), D_c = RL_c/RV; above RV = 3 the stride is frozen and D_c = L_c/V.

    1.8 m person: H_t = 0.491 * 1.8 = 0.8838 m. At 1.4 m/s RV = 1.584, RL_c = 1.694, L_c = 1.497 m,
    D_c = 1.069 s. At 4.52 m/s RV = 5.11 > 3: L_c = 1.346 sqrt(3) * 0.8838 = 2.060 m, D_c = 0.456 s.
    """
    walk = GaitTiming(1.4, 0.491 * 1.8)
    assert walk.rv == pytest.approx(1.4 / 0.8838, rel=1e-12) and not walk.clamped
    assert walk.cycle_duration == pytest.approx(relative_cycle_length(walk.rv) / walk.rv, rel=1e-12)
    assert walk.cycle_duration == pytest.approx(1.069, abs=1e-3)
    run = GaitTiming(2 * math.pi * 3 / (100 / 24), 0.491 * 1.8)
    assert run.clamped and run.rv_shape == RV_MAX
    assert run.cycle_length == pytest.approx(1.346 * math.sqrt(3) * 0.8838, rel=1e-12)
    assert run.cycle_duration == pytest.approx(2.060 / 4.524, abs=1e-3)


@pytest.mark.parametrize("rv_edge", [0.5, 1.3])
def test_gait_curves_continuous_across_regimes(rv_edge):
    """The gait regimes a/b/c meet at RV = 0.5 and 1.3: every curve continuous there (to first order in RV)."""
    t = np.linspace(0, 1, 101)
    below, above = BoulicGait(rv_edge - 1e-9), BoulicGait(rv_edge)
    assert below.gait != above.gait
    for curve in ("vertical", "lateral", "forward", "back_flexion", "pelvic_list", "pelvic_torsion", "hip", "knee",
                  "ankle", "thorax_torsion", "shoulder", "elbow"):
        a, b = getattr(below, curve)(t), getattr(above, curve)(t)
        assert np.max(np.abs(a - b)) < 1e-6, curve


def _chen_rotation(psi, theta, phi):
    """V. C. Chen's ``XYZConvention`` (roll psi, pitch theta, yaw phi): Rz*(Ry*Rx) of transposed rotations."""
    rx = np.array([[1, 0, 0], [0, math.cos(psi), math.sin(psi)], [0, -math.sin(psi), math.cos(psi)]])
    ry = np.array([[math.cos(theta), 0, -math.sin(theta)], [0, 1, 0], [math.sin(theta), 0, math.cos(theta)]])
    rz = np.array([[math.cos(phi), math.sin(phi), 0], [-math.sin(phi), math.cos(phi), 0], [0, 0, 1]])
    return rz @ (ry @ rx)


@pytest.mark.parametrize("speed", [0.4, 1.4, 4.52])
def test_chain_matches_chens_formulation(speed):
    """Right ankle, toe, elbow and hand in the body frame, computed the way Chen's pedestrian code does
    (toe from the ankle flexion, then knee, hip, pelvis list/torsion; hand from the elbow, then
    shoulder, then back flexion/thorax torsion), agree with :meth:`WalkingPerson.local_poses`."""
    person = WalkingPerson(height=1.75, speed=speed)
    g, b = person.gait, person.body
    foot, lt, ls, hw = b.foot_length, b.thigh, b.shank, 0.5 * b.hip_width
    sw, tl, lua, lfa = 0.5 * b.shoulder_width, b.torso, b.upper_arm, b.forearm
    for p in np.linspace(0, 1, 17):
        toe = _chen_rotation(0, g.ankle(p), 0) @ [foot, 0, 0] + [0, -hw, -(lt + ls)]
        rk = _chen_rotation(0, -g.knee(p), 0)
        ankle = rk @ [0, 0, -ls] + [0, -hw, -lt]
        toe = rk @ [toe[0], 0, toe[2] + lt] + [0, -hw, -lt]
        rh = _chen_rotation(0, g.hip(p), 0)
        ankle = rh @ [ankle[0], 0, ankle[2]] + [0, -hw, 0]
        toe = rh @ [toe[0], 0, toe[2]] + [0, -hw, 0]
        rp = _chen_rotation(-g.pelvic_list(p), 0, g.pelvic_torsion(p))
        ankle, toe = rp @ ankle, rp @ toe
        hand = _chen_rotation(0, g.elbow(p), 0) @ [0, 0, -lfa] + [0, -sw, tl - lua]
        rs = _chen_rotation(0, g.shoulder(p), 0)
        elbow = rs @ [0, 0, -lua] + [0, -sw, tl]
        hand = rs @ [hand[0], 0, hand[2] - tl] + [0, -sw, tl]
        ru = _chen_rotation(0, g.back_flexion(p), g.thorax_torsion(p))
        elbow, hand = ru @ elbow, ru @ hand

        poses = person.local_poses(p)
        r_foot, o_ankle = poses["right_foot"]
        r_farm, o_elbow = poses["right_lower_arm"]
        assert np.allclose(o_ankle, ankle, atol=1e-12)
        assert np.allclose(o_ankle + r_foot @ [foot, 0, 0], toe, atol=1e-12)
        assert np.allclose(o_elbow, elbow, atol=1e-12)
        assert np.allclose(o_elbow + r_farm @ [0, 0, -lfa], hand, atol=1e-12)
    # the left side is the right side half a cycle later, mirrored in y: the pelvis list and torsion,
    # the thorax torsion and the lateral sway are odd under p -> p + 1/2, the back flexion even
    mirror = np.diag([1.0, -1.0, 1.0])
    for p in (0.1, 0.37, 0.81):
        now, later = person.local_poses(p), person.local_poses(p + 0.5)
        for part in ("foot", "lower_leg", "upper_leg", "upper_arm", "lower_arm"):
            r_left, o_left = now[f"left_{part}"]
            r_right, o_right = later[f"right_{part}"]
            assert np.allclose(r_left, mirror @ r_right @ mirror, atol=1e-12), part
            assert np.allclose(o_left, mirror @ o_right, atol=1e-12), part


def _sagittal_foot_x(person, p):
    """Forward position (m) of the right foot's centroid relative to O_s in the sagittal plane (no pelvis/trunk motion)."""
    g, b = person.gait, person.body
    c = person.local_centroids["right_foot"]
    a1 = g.hip(p)
    a2 = a1 - g.knee(p)
    a3 = a2 + g.ankle(p)
    return b.thigh * np.sin(a1) + b.shank * np.sin(a2) + c[0] * np.cos(a3) - c[2] * np.sin(a3)


@pytest.mark.parametrize("speed", [1.0, 1.4, 2.0])
def test_foot_velocity_follows_the_boulic_curves(speed):
    r"""The foot's forward velocity, peak relative to the torso, and stance.

    Sagittal reduction of the model (hip, knee, ankle flexion only): the right foot centroid is at
    :math:`x(p) = L_t\sin a_1 + L_s\sin a_2 + c_x\cos a_3 - c_z\sin a_3` in front of :math:`O_s`
    (:math:`a_1 = \theta_h`, :math:`a_2 = \theta_h - \theta_k`, :math:`a_3 = a_2 + \theta_a`), so its
    forward velocity is :math:`V + \dot x`. The full chain adds the forward oscillation
    (velocity amplitude :math:`4\pi|a_a|/D_c`), the pelvic torsion (angular rate amplitude
    :math:`2\pi a_3/D_c` at a lever arm below :math:`\max\sqrt{x^2 + w_h^2}`) and the pelvic list
    (rate below :math:`\tfrac{20\pi}{3} a_2/D_c`, lever arm the leg length 0.53 H); their sum is the
    tolerance. For a 1.8 m person at 1.4 m/s this gives a peak of 5.39 m/s (3.85 V) +- 0.55 m/s;
    the mean over the cycle is exactly V (periodic gait).

    Stance: in single support (:math:`p \in [d_s - 1/2, 1/2]`, the other foot in the air) the
    body moves :math:`V\Delta t` over the foot; the Boulic hip sweep carries the foot back by
    almost as much, so the foot moves :math:`V\Delta t + x(1/2) - x(d_s - 1/2)` (sagittal), within
    :math:`2|a_a|` plus the torsion's :math:`2 a_3 r` of the full chain. We require less than a
    quarter of the body's travel (a foot moving with the body would travel all of it).
    """
    person = WalkingPerson(height=1.8, speed=speed, track=LineTrack((0.0, 0.0), 0.0))
    g, b, dc = person.gait, person.body, person.cycle_duration
    n = 400
    t = np.arange(n) / n * dc
    p = t / dc
    pos, vel = person.truth(t)["right_foot"]
    h = 1e-6
    vx_sag = speed + (_sagittal_foot_x(person, p + h) - _sagittal_foot_x(person, p - h)) / (2 * h * dc)
    x_sag = _sagittal_foot_x(person, p)
    lever = np.sqrt(x_sag ** 2 + (0.5 * b.hip_width) ** 2).max()
    a_a = 0.021
    a3 = np.deg2rad(4 * g.rv)
    a2 = np.deg2rad(0.01 * g.rv)
    tol = 4 * np.pi * a_a / dc + 2 * np.pi * a3 / dc * lever + 20 * np.pi / 3 * a2 / dc * 0.53 * b.height
    assert np.max(np.abs(vel[:, 0] - vx_sag)) <= tol
    # periodic gait: every segment advances exactly one stride L_c = V D_c per cycle
    (start, end), _ = person.truth([0.3 * dc, 1.3 * dc])["right_foot"]
    assert end - start == pytest.approx([speed * dc, 0.0, 0.0], abs=1e-9)
    # the peak relative to the torso, whose mean velocity is V (it too advances L_c per cycle)
    (start, end), _ = person.truth([0.1 * dc, 1.1 * dc])["torso"]
    assert end - start == pytest.approx([speed * dc, 0.0, 0.0], abs=1e-9)
    assert vel[:, 0].max() / speed == pytest.approx(vx_sag.max() / speed, abs=tol / speed)
    # stance
    ds = g.support_fraction
    t0, t1 = (ds - 0.5) * dc, 0.5 * dc
    (p0, p1), _ = person.truth([t0, t1])["right_foot"]
    travel = p1[0] - p0[0]
    body = speed * (t1 - t0)
    sag = body + _sagittal_foot_x(person, 0.5) - _sagittal_foot_x(person, ds - 0.5)
    assert travel == pytest.approx(sag, abs=2 * a_a + 2 * a3 * lever)
    assert abs(travel) < 0.25 * body


# =========================================================================== walking scenes
def test_straight_walk_manifest_and_meshes_match_the_analytic_person(tmp_path):
    """Manifest velocities, mesh centroids and PLY vertex velocities equal WalkingPerson's truth."""
    params = dict(start_range=6.0, speed=1.3, num_frames=5, fps=24.0, room=True, lateral_offset=0.4)
    anim = load_animation(scenes.build("straight_walk", tmp_path / "w", **params))
    assert anim.object_names == list(SEGMENTS)
    anim.check_frequency(77e9)
    assert anim.manifest["scenario"]["parameters"]["speed"] == 1.3
    person = straight_person(start_range=6.0, lateral_offset=0.4, speed=1.3)
    truth = person.truth(anim.times)
    # every segment is rigid: one PLY (its own frame, with its smooth vertex normals) for all frames
    for name in SEGMENTS:
        assert {anim.frame_xml(i).shapes[name].filename.name for i in range(anim.num_frames)} == {f"{name}.ply"}
        ply = read_ply(anim.frame_xml(0).shapes[name].filename)
        assert ply.vertex_velocities is None and np.allclose(ply.vertex_normals, person.local_normals[name])
    for i in range(anim.num_frames):
        motions = person.segment_motions(anim.times[i])
        for name in SEGMENTS:
            motion = anim.motion(i, name)
            assert np.allclose(motion.rotation, motions[name].rotation, atol=1e-12), name
            assert np.allclose(motion.angular_velocity, motions[name].angular_velocity, atol=1e-9), name
            mesh = anim.mesh(i, name)
            assert np.allclose(mesh.centroid, truth[name][0][i], atol=FLOAT32_POS), name
            assert np.allclose(anim.object_velocity(i, name), truth[name][1][i], atol=1e-9), name
            # centroid velocity = area-weighted mean of the vertex velocities over the faces
            tri = mesh.vertices[mesh.faces]
            area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
            v_c = (mesh.vertex_velocities[mesh.faces].mean(axis=1) * area[:, None]).sum(0) / area.sum()
            assert np.allclose(v_c, truth[name][1][i], atol=1e-4), name
    # the radar looks along +x at 1 m and the person walks towards it: the torso's v_r is -V up to
    # Boulic's oscillations (forward 4 pi |a_a|/D_c, lateral 2 pi |a_l|/D_c, vertical 4 pi a_v/D_c)
    r = radial_velocities(truth["torso"][0], truth["torso"][1], anim.radar_pose.position)
    osc = (4 * np.pi * 0.021 + 2 * np.pi * 0.032 + 4 * np.pi * 0.015 * person.gait.rv) / person.cycle_duration
    assert np.all(r < 0) and np.all(np.abs(r + 1.3) <= osc)
    assert np.allclose(anim.radar_pose.position, [0, 0, 1.0]) and np.allclose(anim.radar_pose.orientation, 0.0)


def test_segment_angular_velocities_are_the_rotation_rate():
    r"""``segment_motions``' angular velocity (central difference of the rotation's logarithm over
    :math:`\pm 10\,\mu s`) against :math:`[\boldsymbol\omega]_\times = \dot{\mathbf R}\mathbf R^T` with
    :math:`\dot{\mathbf R}` by a plain central difference over :math:`h = \pm 20\,\mu s`, and every
    vertex's velocity against the difference of the posed mesh. Away from the joint curves' PCHIP
    knots both differences err by :math:`h^2|\ddot{\boldsymbol\omega}|/6` (below 1e-6 rad/s); at a
    knot (t = 0 is one: the right ankle's control point at phase 0) the curves are only C1 and a
    central difference errs by :math:`h|\Delta\dot{\boldsymbol\omega}|/4`, so the instants are
    chosen off the knots; 1e-4 rad/s (1e-4 m/s at the vertices) is then a wide margin."""
    person = circle_person()
    h = 2e-5
    for t in (0.013, 0.37, 1.9):
        motions = person.segment_motions(t)
        ahead, behind = person.poses(t + h), person.poses(t - h)
        for name, m in motions.items():
            r_dot = (ahead[name][0] - behind[name][0]) / (2 * h)
            w = r_dot @ m.rotation.T
            assert np.allclose(0.5 * (w + w.T), 0.0, atol=1e-4), name          # skew: R stays a rotation
            assert np.allclose([w[2, 1], w[0, 2], w[1, 0]], m.angular_velocity, atol=1e-4), name
            v_local = person.local_meshes[name][0]
            moved = (v_local @ ahead[name][0].T + ahead[name][1] - v_local @ behind[name][0].T - behind[name][1]) / (2 * h)
            assert np.allclose(m.point_velocities(m.to_world(v_local)), moved, atol=1e-4), name


def test_circle_walk_torso_speed_and_radius(tmp_path):
    r"""The paper's circle: the torso goes round a 3 m circle once in 100 frames at 24 fps, 4.52 m/s.

    From the written meshes (area-weighted torso centroid per frame): the distance from the
    centre stays within 3 m +- (lateral sway :math:`|a_l|` = 0.032 m + back-flexion lean of the
    centroid, 0.165 H above :math:`O_s`, at most :math:`0.165 H \sin 4^\circ` = 0.021 m); the
    unwrapped polar angle advances :math:`2\pi\cdot 99/100` over frames 0..99, give or take the
    forward oscillation and the lean at both ends (:math:`2(|a_a| + 0.021)/R` rad), i.e. a mean
    track speed of :math:`2\pi R/(100/24)` = 4.524 m/s within 0.02 m/s. The manifest velocities
    equal the analytic model's.
    """
    anim = load_animation(scenes.build("circle_walk", tmp_path / "c"))
    assert anim.num_frames == 100 and anim.fps == 24.0
    radar = anim.radar_pose
    assert np.allclose(radar.position, [-5.0, 0.0, 1.0]) and np.allclose(radar.orientation, 0.0)
    pos = np.array([anim.mesh(i, "torso").centroid for i in range(100)])
    vel = np.array([anim.object_velocity(i, "torso") for i in range(100)])
    lean = 0.165 * 1.8 * math.sin(math.radians(4.0))
    radius = np.hypot(pos[:, 0], pos[:, 1])
    assert np.all(np.abs(radius - 3.0) <= 0.032 + lean)
    angle = np.unwrap(np.arctan2(pos[:, 1], pos[:, 0]))
    speed_expected = 2 * math.pi * 3.0 / (100 / 24)
    assert speed_expected == pytest.approx(4.52, abs=0.005)
    tol_angle = 2 * (0.021 + lean) / 3.0
    assert angle[-1] - angle[0] == pytest.approx(2 * math.pi * 99 / 100, abs=tol_angle)
    tol_speed = tol_angle * 3.0 / (99 / 24)
    assert (angle[-1] - angle[0]) * 3.0 / (99 / 24) == pytest.approx(speed_expected, abs=tol_speed)
    # the far side of the circle (8 m) is inside walk-77ghz's 12.5 m
    assert np.linalg.norm(pos - radar.position, axis=1).max() < 8.2
    # the analytic model agrees with what was written
    assert circle_person().speed == pytest.approx(speed_expected)
    truth = analytic_truth("circle_walk", anim.times[::9], radar_position=radar.position)["torso"]
    assert np.allclose(truth["position"], pos[::9], atol=FLOAT32_POS)
    assert np.allclose(truth["velocity"], vel[::9], atol=1e-9)
    assert np.allclose(truth["radial_velocity"], radial_velocities(pos[::9], vel[::9], radar.position), atol=1e-5)
    with pytest.raises(ValueError, match="no walking person"):
        analytic_truth("moving_plate", [0.0])
    # the room encloses the circle and the radar
    anim.check_frequency(77e9)
    walls = [anim.mesh(0, n).vertices for n in ("wall_x0", "wall_x1", "wall_y0", "wall_y1")]
    assert walls[0][:, 0].max() < -5.0 and walls[1][:, 0].min() > 3.5
    assert walls[2][:, 1].max() < -3.5 and walls[3][:, 1].min() > 3.5


def test_walking_speed_validation(tmp_path):
    with pytest.raises(ValueError, match="closer than 0.5 m"):
        scenes.build("straight_walk", tmp_path / "w", start_range=2.0, speed=2.0, num_frames=48)
    with pytest.raises(ValueError, match="radar stands outside the circle"):
        scenes.build("circle_walk", tmp_path / "w", radius=3.0, radar_distance=3.2, num_frames=2)
    assert list(tmp_path.iterdir()) == []


# =========================================================================== through the path engine
@pytest.mark.slow
def test_straight_walk_micro_doppler_through_the_path_engine(tmp_path):
    r"""One gait cycle of ``straight_walk`` (1.4 m/s towards the radar from 5 m, free space) through
    ``simulate(engine="path")`` with ``walk-77ghz``; whole-CPI micro-Doppler spectrogram.

    The engine gives each path the Doppler of its interaction point at the frame time
    :math:`t_n`, constant over the CPI, so every column is compared with the truth at :math:`t_n`.
    Doppler bin :math:`\Delta v = \lambda_{mid}/(2 L T_b)` = 0.0715 m/s.

    * Strongest bin: in every CPI it lies within the radial velocities of the body's surface at
      :math:`t_n` widened by :math:`\Delta v/2` (bin quantisation). With the physical-optics direct
      echo it is not always the torso: a leg seen broadside is a singly curved surface whose
      specular return (:math:`\propto L^2 a/\lambda` for a cylinder) can exceed the doubly curved
      torso's (:math:`\pi\rho_1\rho_2`), as a stance leg near zero velocity does in some CPIs.
    * Torso line: in every CPI the spectrum within the torso surface's velocities (widened by
      :math:`\Delta v/2`) reaches -20 dB of the column's peak (above the Hann window's -31.5 dB
      sidelobes), and where the peak is on the torso it is within 2 bins of the torso centroid's
      radial velocity (the run store's truth).
    * Limb envelope at -25 dB below each column's peak: above the sidelobe floor of the Hann
      window (highest sidelobe -31.5 dB; the sidelobes of two equally strong lines adding in phase,
      +6 dB, reach -25.5 dB), so sidelobes of the strongest lines do not count. (The physical-optics
      echo of the swinging foot, a small doubly curved surface, lies 20-44 dB below the column's
      peak, so the -20 dB envelope of the diffuse-only model no longer reaches it.) It never leaves the span of
      the body's vertex radial velocities at :math:`t_n` by more than the Hann main-lobe half-width
      (2 bins); over the cycle it reaches the extreme segment-centroid radial velocities of the
      truth (the swinging foot towards the radar, the feet and legs moving away) to within one bin.
    """
    from sionnafmcw import PathEngine, RadarConfig, processing, simulate
    from sionnafmcw.geometry import world_phase_centre

    radar = RadarConfig.preset("walk-77ghz")
    person = straight_person(start_range=5.0, speed=1.4)
    num_frames = int(math.ceil(person.cycle_duration * 24)) + 1  # 27 frames, one gait cycle
    anim = load_animation(scenes.build("straight_walk", tmp_path / "walk", start_range=5.0, speed=1.4,
                                       num_frames=num_frames, room=False))
    engine = PathEngine(samples_per_src=SPECTROGRAM_SAMPLES, max_depth=1)
    ds = simulate(anim, radar, engine=engine, out=tmp_path / "run.zarr", progress=False, noise=False)
    body_paths = np.array([s.num_paths for s in engine.stats])
    assert body_paths.min() > 12 * 20  # at least ~20 body echoes per Tx-Rx pair in every frame

    times = ds.frame_time.values
    names = list(ds.object.values)
    truth_vr = ds.truth_radial_velocity.values
    pose = ds.attrs["radar_pose"]
    centre = world_phase_centre(radar, pose["position"], pose["orientation"])
    surface = []
    for t in times:
        state = person.segment_state(t)
        v_all = np.concatenate([radial_velocities(s.vertices, s.vertex_velocities, centre) for s in state.values()])
        v_torso = radial_velocities(state["torso"].vertices, state["torso"].vertex_velocities, centre)
        surface.append((v_all.min(), v_all.max(), v_torso.min(), v_torso.max()))
    surface = np.array(surface)

    sg = processing.micro_doppler_spectrogram(ds.iq.values, radar, times)
    dv = sg.velocities[1] - sg.velocities[0]
    assert dv == pytest.approx(radar.centre_wavelength / (2 * radar.num_chirps * radar.block_interval))
    peak = sg.peak_velocities()
    torso = truth_vr[:, names.index("torso")]
    assert np.all(peak >= surface[:, 0] - dv / 2) and np.all(peak <= surface[:, 1] + dv / 2)
    p = sg.power
    in_torso = ((sg.velocities[:, None] >= surface[None, :, 2] - dv / 2)
                & (sg.velocities[:, None] <= surface[None, :, 3] + dv / 2))
    torso_power = np.where(in_torso, p, 0.0).max(axis=0)
    assert np.all(torso_power >= p.max(axis=0) * 10 ** (-20 / 10))
    on_torso = (peak >= surface[:, 2] - dv / 2) & (peak <= surface[:, 3] + dv / 2)
    assert on_torso.any() and np.max(np.abs(peak - torso)[on_torso]) <= 2 * dv
    above = p >= p.max(axis=0) * 10 ** (-25 / 10)
    upper = np.array([sg.velocities[np.nonzero(col)[0].max()] for col in above.T])
    lower = np.array([sg.velocities[np.nonzero(col)[0].min()] for col in above.T])
    assert np.all(lower >= surface[:, 0] - 2 * dv) and np.all(upper <= surface[:, 1] + 2 * dv)
    assert lower.min() <= truth_vr.min() + dv
    assert upper.max() >= truth_vr.max() - dv
    # the limbs spread the spectrum far beyond the torso line: the swinging foot reaches ~ -5 m/s
    assert truth_vr.min() < -3.5 * 1.4 and lower.min() < -3.5 * 1.4
    print(f"\nstraight_walk spectrogram: peak on the torso in {on_torso.sum()} of {num_frames} CPIs;"
          f" {num_frames} frames, body paths/frame {body_paths.min()}-{body_paths.max()}, "
          f"bin {dv:.4f} m/s; torso |peak - truth| max {np.max(np.abs(peak - torso)) / dv:.2f} bins; "
          f"envelope {lower.min():.2f}..{upper.max():.2f} m/s vs centroid truth {truth_vr.min():.2f}.."
          f"{truth_vr.max():.2f} m/s, vertex truth {surface[:, 0].min():.2f}..{surface[:, 1].max():.2f} m/s")


#: Rays per Tx element for the spectrogram test (see the test for the echo count it needs).
SPECTROGRAM_SAMPLES = 1_000_000
