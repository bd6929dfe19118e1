r"""The two routes from a BVH clip to an animation directory agree, and the motion is the clip's.

The numpy route (``sionnafmcw.mocap``: parser, forward kinematics, slerp) and the Blender route
(Blender's own importer ``io_anim_bvh`` drives an armature, the segment meshes are parented to its
bones, ``sionnafmcw/blender/export.py`` writes the frames) write the same segments; every vertex's
world position and velocity (:math:`\mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c)` of the
rigid motion each route wrote) must agree within

.. math::
    \epsilon_x = \epsilon_{32} + |\mathbf v|\,\tau_{key} + L\,\Delta\theta, \qquad
    \epsilon_v = \frac{2\epsilon_{32} + 2|\mathbf v|\,\tau_{key} + 2L\,\Delta\theta}{t_+ - t_-} + \epsilon_\omega,

* :math:`\epsilon_{32}` = 1e-5 m, the exporter's rigid tolerance (float32 rounding through Blender's
  pose matrices, its vertices and the PLYs: about 1e-6 m measured, see the printout);
* :math:`\tau_{key}` = 1e-4 frames / fps: Blender's F-curve evaluation returns a key's value when
  asked within 1e-4 frames of it (measured: ``fcurve.evaluate(10.00009)`` = the value at 10); the
  importer's keys are moved to the clip's times, which CMU's ``Frame Time: .0083333`` (120.0005 fps)
  puts within that of the animation's frames, so the vertex speed :math:`|\mathbf v|` times it;
* :math:`L\,\Delta\theta`: between the clip's frames Blender interpolates the quaternions linearly and
  normalises (nlerp), the numpy route slerps: :math:`\Delta\theta = \sum_j \delta_j^3|g(u)|/4` over the
  joints from the root to the segment (:func:`~sionnafmcw.mocap.skeleton.nlerp_deviation`, step
  :math:`\delta_j` of joint :math:`j` between the two frames, fraction :math:`u`), :math:`L` = 2 m (no
  vertex is farther than that from a joint of its chain);
* :math:`t_+ - t_-`: the velocity differences' interval (one frame inside, half a frame at the ends);
  :math:`\epsilon_\omega` = 1e-4 m/s: the exporter writes no rotation where :math:`|\boldsymbol\omega|`
  times the object's radius is below that.

Checked on a few frames of every shipped clip where it moves fastest (fast), on the whole clips
(slow), on our gait as BVH and on the spinning arm, whose velocity field has the closed form
:math:`\omega\hat{\mathbf z}\times(\mathbf x - \mathbf s)`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sionnafmcw import load_animation
from sionnafmcw.animation.rigid import RIGID_TOLERANCE
from sionnafmcw.blender import BLENDER_VENV
from sionnafmcw.mocap import library
from sionnafmcw.mocap.blender_route import export_with_blender
from sionnafmcw.mocap.bvh import read_bvh, write_bvh
from sionnafmcw.mocap.person import MocapPerson
from sionnafmcw.mocap.scene import radar_in_front, radar_orientation, write_people
from sionnafmcw.mocap.skeleton import nlerp_deviation, rotation_angle
from sionnafmcw.mocap.synthetic import gait_clip, spinning_arm_clip

HAVE_BPY = (BLENDER_VENV / "bin" / "python").exists()
needs_blender = pytest.mark.skipif(not HAVE_BPY, reason="the bpy environment .venv-blender is not installed")
KEY_SNAP_FRAMES = 1e-4
LEVER = 2.0
SPIN_TOLERANCE = 1e-4
#: Clip time (s) where each clip moves most (fast test): a window around it.
BUSY = {"08_10": 1.1, "09_01": 0.5, "111_10": 1.2, "111_37": 2.3, "75_10": 1.4, "90_18": 0.9, "115_06": 0.6,
        "13_29_jacks": 0.3, "13_29_squats": 1.0}


def both_routes(tmp_path, person, bvh_path, tag):
    radar, target = radar_in_front((0.0, 0.0), 0.0, 3.0, 1.0)
    orientation = radar_orientation(radar, target)
    a = write_people(tmp_path / f"{tag}_numpy", [(person, "")], radar, orientation).parent
    b = export_with_blender(person, bvh_path, tmp_path / f"{tag}_blender", radar, orientation, timeout=300)
    return load_animation(a), load_animation(b)


def _velocities(anim, i, name):
    mesh = anim.mesh(i, name)
    v = mesh.vertex_velocities
    if v is None:
        v = np.broadcast_to(anim.object_velocity(i, name), mesh.vertices.shape)
    return mesh.vertices, v


def _interp_angle(person, seg, clip_time):
    """:math:`\\sum_j \\delta_j^3|g(u)|/4` over the chain of ``seg`` at clip time ``clip_time``."""
    sk = person.motion.skeleton
    pos = clip_time / person.clip.frame_time
    k = min(int(math.floor(pos)), person.clip.num_frames - 2)
    u = pos - k
    chain, j = [], person.body.segments[seg].joint
    while j >= 0:
        chain.append(j)
        j = sk.parents[j]
    total = 0.0
    for j in chain:
        delta = float(rotation_angle(sk.local_rotations[k, j].T @ sk.local_rotations[k + 1, j]))
        total += float(nlerp_deviation(delta, u))
    return total


def compare(person, a, b):
    """Largest position and velocity differences and their ratios to the tolerances of the module docstring."""
    assert a.num_frames == b.num_frames == person.num_frames
    # every segment is a shape of every frame; the exporter lists in the manifest only those that move
    for anim in (a, b):
        assert sorted(anim.frame_xml(0).shapes) == sorted(person.body.names)
    assert set(b.object_names) <= set(a.object_names) == set(person.body.names)
    t, tm, tp = person.sample_times()
    worst = {"dx": 0.0, "dv": 0.0, "rx": 0.0, "rv": 0.0}
    for i in range(person.num_frames):
        span = tp[i] - tm[i]
        for name in person.body.names:
            xa, va = _velocities(a, i, name)
            xb, vb = _velocities(b, i, name)
            speed = float(np.linalg.norm(va, axis=1).max())
            theta = max(_interp_angle(person, name, c) for c in person.clip_times([tm[i], t[i], tp[i]]))
            tau = KEY_SNAP_FRAMES / person.fps
            tol_x = RIGID_TOLERANCE + speed * tau + LEVER * theta
            tol_v = (2 * RIGID_TOLERANCE + 2 * speed * tau + 2 * LEVER * theta) / span + SPIN_TOLERANCE
            dx = float(np.linalg.norm(xa - xb, axis=1).max())
            dv = float(np.linalg.norm(va - vb, axis=1).max())
            worst["dx"], worst["dv"] = max(worst["dx"], dx), max(worst["dv"], dv)
            worst["rx"], worst["rv"] = max(worst["rx"], dx / tol_x), max(worst["rv"], dv / tol_v)
    return worst


def _report(label, w):
    print(f"\n{label}: max |dx| {w['dx'] * 1e6:.2f} um ({w['rx']:.2f} of the tolerance), "
          f"max |dv| {w['dv'] * 1e3:.3f} mm/s ({w['rv']:.2f} of the tolerance)")


@needs_blender
@pytest.mark.parametrize("name", sorted(library.CLIPS))
def test_every_shipped_clip_imports_by_both_routes(tmp_path, name):
    """Five frames at 24 fps (the velocity samples fall between the clip's frames) where the clip moves most."""
    clip = library.load_clip(name)
    person = MocapPerson(clip, fps=24.0, num_frames=5, start=BUSY[name], mesh_edge=0.06)
    a, b = both_routes(tmp_path, person, library.clip_info(name).path, name)
    w = compare(person, a, b)
    _report(f"{name} (both routes, 5 frames)", w)
    assert w["rx"] <= 1.0 and w["rv"] <= 1.0


@needs_blender
@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(library.CLIPS))
def test_whole_shipped_clips_by_both_routes(tmp_path, name):
    person = MocapPerson(library.load_clip(name), fps=30.0, mesh_edge=0.05)
    a, b = both_routes(tmp_path, person, library.clip_info(name).path, name)
    w = compare(person, a, b)
    _report(f"{name} (both routes, {person.num_frames} frames)", w)
    assert w["rx"] <= 1.0 and w["rv"] <= 1.0


@needs_blender
def test_our_gait_as_bvh_by_both_routes(tmp_path):
    from sionnafmcw.scenes.walking import straight_person

    walker = straight_person(start_range=5.0, speed=1.4)
    path = write_bvh(tmp_path / "gait.bvh", gait_clip(walker, 1.0))
    person = MocapPerson(read_bvh(path), unit=1.0, fps=25.0, num_frames=6, start=0.3, mesh_edge=0.06)
    assert person.body.height == pytest.approx(walker.height, rel=1e-6)   # the legs give Winter's stature back
    a, b = both_routes(tmp_path, person, path, "gait")
    w = compare(person, a, b)
    _report("gait BVH (both routes)", w)
    assert w["rx"] <= 1.0 and w["rv"] <= 1.0


def test_spinning_arm_velocity_is_the_closed_form(tmp_path):
    r"""Arm vertices move at :math:`\omega\hat{\mathbf z}\times(\mathbf x - \mathbf s)`. With a velocity step of
    0.01 frame (:math:`\Delta` = 0.3 ms) the central difference of the uniform turn errs by
    :math:`(\omega\Delta)^2/6` of the speed (4e-7) plus float rounding: 1e-6 m/s. With the exporter's half
    frame (:math:`\Delta` = 1/60 s) the centroid's difference is :math:`v_c\sin(\omega\Delta)/(\omega\Delta)`,
    short by :math:`(\omega\Delta)^2/6` of :math:`|\mathbf v_c|`, and every vertex inherits that error."""
    rate = math.pi
    clip = read_bvh(write_bvh(tmp_path / "spin.bvh", spinning_arm_clip(rate=rate, duration=1.0)))
    for step, rel in ((0.01, None), (0.5, None)):
        person = MocapPerson(clip, unit=1.0, fps=30.0, num_frames=8, start=0.2, height=1.75, mesh_edge=0.03,
                             velocity_step=step, floor=False)
        assert set(person.body.names) == {"abdomen", "torso", "left_upper_arm", "left_lower_arm"}
        shoulder = person.joint_positions(person.times)[:, clip.index("LeftArm")]
        delta = step / person.fps
        for i, frame in enumerate(person.motions()):
            for name in ("left_upper_arm", "left_lower_arm"):
                m = frame[name]
                x = m.to_world(person.body.segments[name].vertices)
                v = m.point_velocities(x)
                truth = np.cross([0.0, 0.0, rate], x - shoulder[i])
                if 0 < i < person.num_frames - 1:
                    tol = (rate * delta) ** 2 / 6 * np.linalg.norm(m.velocity) + 1e-6
                    assert np.abs(v - truth).max() <= tol, (step, i, name)
                assert np.allclose(m.angular_velocity, [0.0, 0.0, rate], atol=1e-9)
            assert np.allclose(frame["torso"].velocity, 0.0) and np.allclose(frame["torso"].angular_velocity, 0.0)


@needs_blender
def test_spinning_arm_by_both_routes(tmp_path):
    clip_path = write_bvh(tmp_path / "spin.bvh", spinning_arm_clip(rate=math.pi, duration=1.0))
    person = MocapPerson(read_bvh(clip_path), unit=1.0, fps=30.0, num_frames=6, start=0.2, height=1.75,
                         mesh_edge=0.04)
    a, b = both_routes(tmp_path, person, clip_path, "spin")
    w = compare(person, a, b)
    _report("spinning arm (both routes)", w)
    assert w["rx"] <= 1.0 and w["rv"] <= 1.0
    # the written field is the turn's: omega z x (x - s) at every arm vertex, to (omega Delta)^2 / 6
    s = person.joint_positions(person.times)[:, person.clip.index("LeftArm")]
    for i in range(1, person.num_frames - 1):
        x, v = _velocities(b, i, "left_lower_arm")
        truth = np.cross([0.0, 0.0, math.pi], x - s[i])
        vc = np.linalg.norm(b.object_velocity(i, "left_lower_arm"))
        assert np.abs(v - truth).max() <= (math.pi / 60) ** 2 / 6 * vc + 2 * RIGID_TOLERANCE * 30 + 1e-4


def test_routes_write_the_same_layout(tmp_path):
    """The numpy route writes each segment once (rigid, with vertex normals) and the floor contact."""
    person = MocapPerson(library.load_clip("90_18"), fps=30.0, num_frames=3, start=0.1, mesh_edge=0.05)
    radar, target = radar_in_front((0.0, 0.0), 0.0, 3.0, 1.0)
    out = write_people(tmp_path / "fall", [(person, "p0_")], radar, radar_orientation(radar, target)).parent
    anim = load_animation(out)
    assert anim.object_names == [f"p0_{n}" for n in person.body.names]
    plys = sorted(p.name for p in (out / "meshes").iterdir())
    assert plys == sorted(f"p0_{n}.ply" for n in person.body.names)
    lowest = min(float(anim.mesh(i, n).vertices[:, 2].min()) for i in range(3) for n in anim.object_names)
    assert lowest == pytest.approx(0.0, abs=RIGID_TOLERANCE)


def test_spinning_arm_doppler_through_the_path_engine(tmp_path):
    r"""The arm held out and turning at :math:`\omega = \pi` rad/s, seen from 3 m in its plane, at right
    angles to it (``walk-77ghz``, path engine, no noise): a turning rod seen broadside returns a band of
    Doppler from its pivot to its end, :math:`v_r = \omega\rho\cos\alpha` at distance :math:`\rho` from the
    shoulder (:math:`\alpha` the small angle off the line of sight). Every CPI's spectrum, 25 dB below its
    peak (above the Hann window's sidelobes), lies inside the closed form's span over the arm's vertices
    (widened by the main lobe, 2 bins) and reaches the wrist's :math:`\omega\rho_{wrist}` within a bin (the
    hand beyond, a small doubly curved ellipsoid, is weaker)."""
    from sionnafmcw import PathEngine, RadarConfig, processing, simulate
    from sionnafmcw.geometry import radial_velocity, world_phase_centre

    rate = math.pi
    clip = read_bvh(write_bvh(tmp_path / "spin.bvh", spinning_arm_clip(rate=rate, duration=1.2)))
    person = MocapPerson(clip, unit=1.0, fps=30.0, num_frames=4, start=0.95, height=1.75, mesh_edge=0.02,
                         floor=False, velocity_step=0.01)
    joints = person.joint_positions([1.5 / 30])[0]
    shoulder, wrist = joints[clip.index("LeftArm")], joints[clip.index("LeftHand")]
    arm = (wrist - shoulder) / np.linalg.norm(wrist - shoulder)
    radar_position = shoulder + 3.0 * np.cross([0.0, 0.0, 1.0], arm)
    out = write_people(tmp_path / "spin", [(person, "")], radar_position,
                       radar_orientation(radar_position, shoulder)).parent
    anim = load_animation(out)
    radar = RadarConfig.preset("walk-77ghz")
    run = simulate(anim, radar, engine=PathEngine(samples_per_src=100_000, max_depth=1), out=tmp_path / "spin.zarr",
                   progress=False, noise=False)
    sg = processing.micro_doppler_spectrogram(run.dataset.iq.values, radar, run.dataset.frame_time.values)
    dv = sg.velocities[1] - sg.velocities[0]
    centre = world_phase_centre(radar, anim.radar_pose.position, anim.radar_pose.orientation)
    joints = person.joint_positions(person.times)
    for i in range(anim.num_frames):
        vr = np.concatenate([radial_velocity(anim.mesh(i, n).vertices, anim.mesh(i, n).vertex_velocities, centre)
                             for n in ("left_upper_arm", "left_lower_arm")])
        w = joints[i, clip.index("LeftHand")]
        v_wrist = radial_velocity(w, np.cross([0.0, 0.0, rate], w - joints[i, clip.index("LeftArm")]), centre)
        col = sg.power[:, i]
        band = sg.velocities[col >= col.max() * 10 ** (-25 / 10)]
        assert vr.min() - 2 * dv <= band.min() and band.max() <= vr.max() + 2 * dv, i
        assert band.min() <= v_wrist + dv, (i, band.min(), v_wrist)
        print(f"\nspinning arm CPI {i}: spectrum {band.min():+.3f}..{band.max():+.3f} m/s, vertices {vr.min():+.3f}.."
              f"{vr.max():+.3f}, wrist {float(v_wrist):+.3f} m/s (bin {dv:.4f})")
