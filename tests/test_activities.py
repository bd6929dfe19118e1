r"""The activity library (``sionnafmcw.scenes.activities``) and ``sionnafmcw scene from-bvh``.

* Every builder is registered with typed, bounded parameters and writes a person of rigid segments
  (one PLY each, a ``to_world`` per frame), standing on the floor, the radar where the parameters
  put it, the motion source and the CMU acknowledgement in the manifest.
* ``person_height`` scales the clip uniformly: the body's stature is the parameter, positions about
  the start point and speeds scale by its ratio (the timing does not).
* ``sit_down`` is ``stand_up`` played backwards: frame :math:`i` of one is the other's pose at the
  mirrored clip time, velocities negated (to float32 positions and the half-frame differences).
* Several people in one scene under name prefixes.
* The fall's micro-Doppler (path engine, ``walk-77ghz``, a radar 2.6 m up looking down at the person):
  at the CPI where the fall reads fastest, the spectrogram's peak lies within one Doppler bin
  (:math:`\lambda_{mid}/(2LT_b)` = 0.0715 m/s) of the trunk's radial velocities (pelvis, abdomen,
  thorax centroids from the run store; the trunk turns backwards as it falls, so they differ by up to
  0.2 m/s), and throughout the descent the torso's line stands within 20 dB of each column's peak
  (above the Hann window's -31.5 dB sidelobes).
* The command line: one line and exit status 2 for a bad BVH file, a help text that ends with an example.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sionnafmcw import load_animation, scenes
from sionnafmcw.animation.rigid import RIGID_TOLERANCE
from sionnafmcw.mocap import library
from sionnafmcw.mocap.segments import SEGMENT_ORDER
from sionnafmcw.mocap.person import MocapPerson
from sionnafmcw.mocap.scene import radar_in_front, radar_orientation, write_people

ACTIVITIES = ("run", "sit_down", "stand_up", "wave", "jump", "fall", "pick_up", "mocap_clip", "stand_still",
              "vital_signs", "jumping_jacks", "squat", "boxing", "jump_in_place")
FLOAT32_POS = 1e-5


def test_activities_are_registered_with_bounded_parameters():
    assert set(ACTIVITIES) <= set(scenes.names())
    for name in ACTIVITIES:
        params = scenes.parameters(name)
        for key, p in params.items():
            if p.type in (int, float):
                assert p.low is not None and p.high is not None, (name, key)    # a data set can draw it
            if p.type is str:
                assert p.choices, (name, key)
        text = scenes.describe(name)
        assert "CMU" in text or "posture" in text, name
    assert "motion" in scenes.activities.__doc__ and library.ACKNOWLEDGEMENT.split(".")[0] in library.__doc__


@pytest.mark.parametrize("name", ACTIVITIES)
def test_every_activity_builds(tmp_path, name):
    out = scenes.build(name, tmp_path / name, num_frames=3, body_mesh_edge=0.06)
    anim = load_animation(out)
    manifest = json.loads((out / "animation.json").read_text())
    activity = manifest["activity"]
    assert activity["name"] == name and "CMU" in activity["motion_source"]
    assert activity["acknowledgement"] == library.ACKNOWLEDGEMENT
    shapes = anim.frame_xml(0).shapes
    assert sorted(shapes) == sorted(SEGMENT_ORDER)
    assert sorted(p.name for p in (out / "meshes").iterdir()) == sorted(f"{n}.ply" for n in SEGMENT_ORDER)
    assert all(anim.motion(i, n) is not None for i in range(3) for n in SEGMENT_ORDER)
    lowest = min(float(anim.mesh(i, n).vertices[:, 2].min()) for i in range(3) for n in SEGMENT_ORDER)
    if name not in ("stand_still", "vital_signs"):
        assert lowest == pytest.approx(0.0, abs=FLOAT32_POS)          # on the floor (over its frames)
    else:
        assert abs(lowest) < 0.01                                      # the posture's floor, then mm of motion
    anim.check_frequency(77e9)


def test_radar_pose_and_start_pose(tmp_path):
    out = scenes.build("wave", tmp_path / "w", num_frames=2, body_mesh_edge=0.06, x=1.0, y=-2.0,
                       heading=math.pi / 2, radar_distance=4.0, radar_azimuth=math.pi / 6, radar_height=2.5,
                       radar_target_height=1.0)
    anim = load_animation(out)
    angle = math.pi / 2 + math.pi / 6
    expected = np.array([1.0 + 4.0 * math.cos(angle), -2.0 + 4.0 * math.sin(angle), 2.5])
    assert np.allclose(anim.radar_pose.position, expected)
    yaw, pitch, _ = anim.radar_pose.orientation
    assert yaw == pytest.approx(angle - math.pi) or yaw == pytest.approx(angle + math.pi)
    assert pitch == pytest.approx(math.atan2(1.5, 4.0))                   # looking down at 1 m above the start
    pelvis = anim.mesh(0, "pelvis").centroid
    assert math.hypot(pelvis[0] - 1.0, pelvis[1] + 2.0) < 0.1             # the root's ground point at (x, y)


def test_person_height_scales_the_motion(tmp_path):
    base = {k: p.default for k, p in scenes.parameters("run").items()}
    base.update(num_frames=6, body_mesh_edge=0.06)
    tall = scenes.activities.mocap_person("09_01", {**base, "person_height": 2.0})
    short = scenes.activities.mocap_person("09_01", {**base, "person_height": 1.5})
    assert tall.body.height == pytest.approx(2.0) and short.body.height == pytest.approx(1.5)
    ratio = 2.0 / 1.5
    jt, js = tall.joint_positions(tall.times), short.joint_positions(short.times)
    rt = jt - jt[0, 0] * [1, 1, 0]
    rs = js - js[0, 0] * [1, 1, 0]
    # heights about the floor and displacements about the start point scale with the stature
    assert np.allclose(rt[..., :2], ratio * rs[..., :2], atol=1e-9)
    assert np.allclose(rt[..., 2] - tall.placement[2, 3], ratio * (rs[..., 2] - short.placement[2, 3]), atol=1e-9)
    vt = tall.truth()["torso"][1]
    vs = short.truth()["torso"][1]
    assert np.allclose(vt, ratio * vs, atol=1e-9)


def test_sit_down_is_stand_up_backwards():
    base = {k: p.default for k, p in scenes.parameters("sit_down").items()}
    base.update(body_mesh_edge=0.06, num_frames=10, time_offset=0.3)
    sit = scenes.activities.mocap_person("111_10", base, None, 2.0, reverse=True)
    dt = library.load_clip("111_10").frame_time     # the forward window starts at frame 1
    stand = scenes.activities.mocap_person("111_10", {**base, "time_offset": 1.4 - dt}, None, 2.0)
    assert sit.clip_times([0.0])[0] == pytest.approx(1.7) and sit.clip_times([9 / 30])[0] == pytest.approx(1.4)
    assert np.allclose(stand.clip_times(stand.times)[::-1], sit.clip_times(sit.times))
    ja = sit.joint_positions(sit.times)
    jb = stand.joint_positions(stand.times)[::-1]
    offset = ja[0, 0, :2] - jb[0, 0, :2]                        # both placed at the origin at their own frame 0
    assert np.allclose(ja[..., :2] - offset, jb[..., :2], atol=0.05)   # placement differs by the facing at frame 0
    ms, mt = sit.motions(), stand.motions()[::-1]
    for i in range(1, 9):                                       # interior frames: central differences
        assert np.allclose(ms[i]["pelvis"].velocity[2], -mt[i]["pelvis"].velocity[2], atol=1e-9)


def test_people_compose_under_prefixes(tmp_path):
    a = MocapPerson(library.load_clip("111_37"), fps=30.0, num_frames=3, mesh_edge=0.06, position=(0.0, 0.0))
    b = MocapPerson(library.load_clip("90_18"), fps=30.0, num_frames=3, mesh_edge=0.06, position=(2.0, 1.0),
                    heading=math.pi)
    radar, target = radar_in_front((1.0, 0.5), -math.pi / 2, 4.0, 1.0)
    out = write_people(tmp_path / "two", [(a, "p0_"), (b, "p1_")], radar, radar_orientation(radar, target)).parent
    anim = load_animation(out)
    assert sorted(anim.frame_xml(0).shapes) == sorted([f"p0_{n}" for n in a.body.names] +
                                                      [f"p1_{n}" for n in b.body.names])
    assert np.linalg.norm(anim.mesh(0, "p1_pelvis").centroid[:2] - [2.0, 1.0]) < 0.1
    with pytest.raises(ValueError, match="prefixes .* repeat"):
        write_people(tmp_path / "bad", [(a, "p0_"), (b, "p0_")], radar, radar_orientation(radar, target))
    with pytest.raises(ValueError, match="prefix 'p/0' may hold letters"):
        write_people(tmp_path / "bad2", [(a, "p/0")], radar, radar_orientation(radar, target))


def test_bad_activity_parameters_name_the_parameter(tmp_path):
    with pytest.raises(ValueError, match=r"num_frames=500 at 30 fps .* at most \d+ frames"):
        scenes.build("fall", tmp_path / "f", num_frames=500)
    with pytest.raises(ValueError, match=r"time_offset=3.5 s leaves nothing of the clip window"):
        scenes.build("fall", tmp_path / "f", time_offset=3.5)
    with pytest.raises(ValueError, match=r"'posture'='kneeling' is not an allowed choice"):
        scenes.build("vital_signs", tmp_path / "f", posture="kneeling")
    with pytest.raises(ValueError, match=r"'clip'='01_01' is not an allowed choice"):
        scenes.build("mocap_clip", tmp_path / "f", clip="01_01")
    assert list(tmp_path.iterdir()) == []


# =========================================================================== the fall's micro-Doppler
def test_fall_micro_doppler_shows_the_downward_velocity(tmp_path):
    from sionnafmcw import PathEngine, RadarConfig, processing, simulate

    radar = RadarConfig.preset("walk-77ghz")
    out = scenes.build("fall", tmp_path / "fall", time_offset=0.8, num_frames=8, body_mesh_edge=0.03,
                       radar_distance=1.0, radar_height=2.6, radar_target_height=0.5)
    run = simulate(load_animation(out), radar, engine=PathEngine(samples_per_src=100_000, max_depth=1),
                   out=tmp_path / "fall.zarr", progress=False)
    ds = run.dataset
    names = list(ds.object.values)
    vr = ds.truth_radial_velocity.values
    vz = ds.truth_velocity.values[:, names.index("pelvis"), 2]
    sg = processing.micro_doppler_spectrogram(ds.iq.values, radar, ds.frame_time.values)
    dv = sg.velocities[1] - sg.velocities[0]
    assert dv == pytest.approx(radar.centre_wavelength / (2 * radar.num_chirps * radar.block_interval))
    peak = sg.peak_velocities()
    trunk = vr[:, [names.index(k) for k in ("pelvis", "abdomen", "torso")]]
    falling = vz < -2.0                                      # the descent, pelvis faster than 2 m/s down
    assert falling.sum() >= 3
    n = int(np.flatnonzero(falling)[np.argmax(peak[falling])])          # where the fall reads fastest
    assert trunk[n].min() - dv <= peak[n] <= trunk[n].max() + dv
    torso = vr[:, names.index("torso")]
    p = sg.power
    for i in np.flatnonzero(falling):
        near = np.abs(sg.velocities - torso[i]) <= dv
        assert p[near, i].max() >= 10 ** (-20 / 10) * p[:, i].max(), i
    print(f"\nfall: fastest reading {peak[n]:+.3f} m/s (CPI {n}, pelvis {vz[n]:+.2f} m/s vertical); trunk radial "
          f"velocities {trunk[n].min():+.3f}..{trunk[n].max():+.3f} m/s; torso {torso[n]:+.3f}; bin {dv:.4f} m/s; "
          f"peak - torso = {(peak[n] - torso[n]) / dv:+.2f} bins")


# =========================================================================== command line
def test_from_bvh_command_line(tmp_path, capsys):
    from sionnafmcw.cli import main

    out = tmp_path / "clip"
    code = main(["scene", "from-bvh", str(library.clip_info("111_37").path), str(out), "--frames", "3",
                 "--mesh-edge", "0.06", "--start-pose", "1,2,90", "--radar", "2.5,1.2"])
    assert code == 0
    anim = load_animation(out)
    assert anim.num_frames == 3 and anim.fps == 30.0
    assert np.allclose(anim.radar_pose.position, [1.0, 4.5, 1.2])
    bad = tmp_path / "bad.bvh"
    bad.write_text(library.clip_info("111_37").path.read_text().replace("Zrotation", "Wrotation", 1))
    for argv, message in (
            ([str(bad), str(tmp_path / "x")], f"{bad}:5: unknown channel 'Wrotation'"),
            ([str(tmp_path / "missing.bvh"), str(tmp_path / "x")], "missing.bvh: no such file"),
            ([str(library.clip_info("111_37").path), str(tmp_path / "x"), "--radar", "1,2,3"],
             "--radar '1,2,3': write 2 comma-separated finite numbers or 6"),
            ([str(library.clip_info("111_37").path), str(tmp_path / "x"), "--frames", "100000"],
             "do not fit in the clip"),
            ([str(library.clip_info("111_37").path), str(out)], "exists and is not empty")):
        capsys.readouterr()
        assert main(["scene", "from-bvh", *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    capsys.readouterr()
    assert main(["scene", "from-bvh", "--help"]) == 0
    text = capsys.readouterr().out.rstrip()
    assert text.splitlines()[-1].strip().startswith("sionnafmcw scene from-bvh")
