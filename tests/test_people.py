r"""Several people in one scene (``sionnafmcw.scenes.people``), their keypoints, and the run store's
per-person truth.

* The ``people`` builder writes every person under its own prefix, with its activity and its
  keypoints per frame in the manifest; keypoints are points of the segments: a bone's length is the
  same in every frame, a joint sits at its segment's origin.
* People never come within ``person_clearance`` of each other, checked on every vertex of every
  frame (not on the footprints the builder used): with ``separation="tracks"`` over all pairs of
  frames (the swept bodies are disjoint), with ``"frames"`` frame by frame.
* Impossible placements and bad parameters are errors naming the parameter and the fix.
* Three people walking towards a ``walk-77ghz`` radar (12 virtual channels in a row of
  :math:`\lambda/2`: azimuth resolution :math:`2/(N_v\cos\varphi)` = 0.167 rad at boresight; range bin
  :math:`c/2B` = 9.76 cm) through the path engine: the three strongest peaks of the range-azimuth map
  (static clutter removed) that lie farther apart than a body's size (:data:`BODY_SIZE`: peaks closer
  than that to a stronger one are the same person, e.g. its thorax and a swinging arm two range bins
  behind) are the three people, each within one range bin of the range of its thorax's surface
  facing the radar (the torso centroid's range less the torso's depth towards the radar, from the
  scene's own mesh) and within one azimuth resolution of its centroid's azimuth.
* The run store: the ``person`` and ``joint`` coordinates, ``joint_position`` equal to the manifest's
  keypoints, ``object_person``, ``person_activity``, ``person_count``; a store without them still reads.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from sionnafmcw import load_animation, scenes
from sionnafmcw.scenes.keypoints import KEYPOINTS

COARSE = 0.06   # body mesh edges (m): shapes and motion only


def _build(tmp_path, name="p", **params):
    defaults = dict(num_frames=4, body_mesh_edge=COARSE, room=False)
    return load_animation(scenes.build("people", tmp_path / name, **{**defaults, **params}))


def _person_points(anim, people, person, frame):
    return np.concatenate([anim.mesh(frame, o).vertices for o in people.objects[person]])


def test_people_are_written_under_prefixes_with_activities_and_keypoints(tmp_path):
    anim = _build(tmp_path, activities="walk,wave,vital_signs", seed=5, num_frames=5)
    people = anim.people
    manifest = json.loads((anim.path / "animation.json").read_text())
    assert people.names == ["person0", "person1", "person2"]
    assert people.prefixes == ["person0_", "person1_", "person2_"]
    assert list(people.activities[0]) == ["walk", "wave", "vital_signs"]
    assert (people.activities == people.activities[0]).all()
    assert people.keypoint_names == list(KEYPOINTS) and people.keypoints.shape == (5, 3, len(KEYPOINTS), 3)
    assert np.isfinite(people.keypoints).all()
    shapes = set(anim.frame_xml(0).shapes)
    for name, objs in people.objects.items():
        assert objs and all(o.startswith(name + "_") and o in shapes for o in objs)
    assert set(anim.object_names) == {o for objs in people.objects.values() for o in objs}
    info = manifest["people"]["persons"]
    assert info[0]["track"]["kind"] == "line" and "CMU" in info[1]["motion_source"]
    assert 0.1 <= info[2]["vital_signs"]["breathing_rate"] <= 0.5
    for i, p in enumerate(people.names):                       # a joint sits at its segment's origin
        for key, seg in (("pelvis", "pelvis"), ("left_elbow", "left_lower_arm"), ("right_knee", "right_lower_leg")):
            for f in range(5):
                origin = anim.motion(f, f"{p}_{seg}").translation
                np.testing.assert_allclose(people.keypoints[f, i, KEYPOINTS.index(key)], origin, atol=1e-6)
        bones = [("left_elbow", "left_wrist"), ("right_hip", "right_knee"), ("left_knee", "left_ankle")]
        for a, b in bones:                                      # rigid bones: one length in every frame
            kp = people.keypoints[:, i]
            length = np.linalg.norm(kp[:, KEYPOINTS.index(a)] - kp[:, KEYPOINTS.index(b)], axis=-1)
            assert np.ptp(length) < 1e-5 and 0.15 < length[0] < 0.5, (p, a, b, length)
    anim.check_frequency(77e9)


@pytest.mark.parametrize("separation", ["tracks", "frames"])
def test_people_never_come_closer_than_the_clearance(tmp_path, separation):
    clearance = 0.3
    for seed in range(3):
        anim = _build(tmp_path, f"{separation}{seed}", num_people=3, activity="mixed", seed=seed, num_frames=6,
                      separation=separation, person_clearance=clearance, max_range=5.0)
        people = anim.people
        pts = {p: [_person_points(anim, people, p, f)[:, :2] for f in range(anim.num_frames)] for p in people.names}
        for i, a in enumerate(people.names):
            for b in people.names[i + 1:]:
                if separation == "frames":
                    gap = min(cKDTree(pts[b][f]).query(pts[a][f])[0].min() for f in range(anim.num_frames))
                else:
                    gap = cKDTree(np.concatenate(pts[b])).query(np.concatenate(pts[a]))[0].min()
                assert gap >= clearance, (seed, a, b, gap)
        for p in people.names:     # footprint centres in the sector (the body's pelvis within its footprint)
            pelvis = people.keypoints[:, people.names.index(p), 0, :2]
            assert np.all(np.linalg.norm(pelvis, axis=-1) < 5.0 + 1.0)


def test_people_placement_and_parameter_errors(tmp_path):
    with pytest.raises(ValueError, match=r"cannot place 8 people .* lower num_people"):
        scenes.build("people", tmp_path / "a", num_people=8, min_range=1.0, max_range=1.6, max_azimuth=0.2,
                     num_frames=2, body_mesh_edge=COARSE, room=False)
    with pytest.raises(ValueError, match=r"positions has 2 numbers; num_people=2 needs 4"):
        scenes.build("people", tmp_path / "a", num_people=2, positions=(2.0, 0.0), num_frames=2, room=False)
    with pytest.raises(ValueError, match=r"fixed positions and headings put person 1 .* move it"):
        scenes.build("people", tmp_path / "a", num_people=2, positions=(3.0, 0.0, 3.2, 0.1), headings=(0.0, 0.0),
                     num_frames=2, body_mesh_edge=COARSE, room=False)
    with pytest.raises(ValueError, match=r"activities='walk,swim' holds 'swim'"):
        scenes.build("people", tmp_path / "a", num_people=2, activities="walk,swim", room=False)
    with pytest.raises(ValueError, match=r"lists 1 activities for num_people=2"):
        scenes.build("people", tmp_path / "a", num_people=2, activities="walk", room=False)
    with pytest.raises(ValueError, match=r"clip='nope.bvh' is neither a shipped clip"):
        scenes.build("people", tmp_path / "a", num_people=1, activity="clip", clip="nope.bvh", room=False)
    with pytest.raises(ValueError, match=r"furniture .* needs room=true"):
        scenes.build("people", tmp_path / "a", num_people=1, room=False, tables=1, num_frames=2,
                     body_mesh_edge=COARSE)
    assert list(tmp_path.iterdir()) == []


def test_a_bvh_file_as_an_activity(tmp_path):
    from sionnafmcw.mocap import library

    path = library.clip_info("111_37").path
    anim = _build(tmp_path, num_people=2, activities="clip,walk_circle", clip=str(path), num_frames=3, seed=1)
    info = json.loads((anim.path / "animation.json").read_text())["people"]["persons"]
    assert info[0]["clip"] == str(path) and info[1]["track"]["kind"] == "circle"
    centre, radius = np.array(info[1]["track"]["centre"]), info[1]["track"]["radius"]
    pelvis = anim.people.keypoints[:, 1, 0, :2]              # the walker's spine origin stays on its circle
    assert np.allclose(np.linalg.norm(pelvis - centre, axis=-1), radius, atol=0.06)


# =========================================================================== through the path engine
#: A walking adult's horizontal extent (m): shoulder width and the arms' and legs' swing, about 0.6 m.
BODY_SIZE = 0.6


@pytest.fixture(scope="module")
def three_people(tmp_path_factory):
    from sionnafmcw import PathEngine, RadarConfig, simulate

    tmp = tmp_path_factory.mktemp("three")
    truth = ((2.5, -25.0), (4.0, 0.0), (5.5, 25.0))          # range (m), azimuth (deg) from the radar
    positions = [v for r, a in truth for v in (r * math.cos(math.radians(a)), r * math.sin(math.radians(a)))]
    headings = [math.atan2(-positions[2 * i + 1], -positions[2 * i]) for i in range(3)]   # walking at the radar
    out = scenes.build("people", tmp / "scene", num_people=3, activity="walk", positions=tuple(positions),
                       headings=tuple(headings), num_frames=1, body_mesh_edge=0.02, room=False)
    radar = RadarConfig.preset("walk-77ghz")
    run = simulate(load_animation(out), radar, engine=PathEngine(samples_per_src=100_000, max_depth=1),
                   out=tmp / "run.zarr", progress=False)
    return load_animation(out), radar, run


def test_three_people_resolved_in_range_azimuth(three_people):
    from sionnafmcw import processing
    from sionnafmcw.array import uniform_azimuth_row

    anim, radar, run = three_people
    ra = processing.range_azimuth_map(run.cube(0), radar, clutter_removal=True)
    peaks = np.argwhere(processing.local_maxima(ra.power, size=(5, 9), modes=("reflect", "reflect")))
    peaks = peaks[np.argsort(ra.power[tuple(peaks.T)])[::-1]]
    xy = np.stack([ra.ranges[peaks[:, 0]] * np.cos(ra.azimuths[peaks[:, 1]]),
                   ra.ranges[peaks[:, 0]] * np.sin(ra.azimuths[peaks[:, 1]])], -1)
    people = []                                     # strongest first; a peak within a body's size of a kept one is its person's
    for i in range(len(peaks)):
        if all(np.linalg.norm(xy[i] - xy[j]) > BODY_SIZE for j in people):
            people.append(i)
    strongest = peaks[people[:3]]
    range_bin = ra.ranges[1] - ra.ranges[0]
    n_v = len(uniform_azimuth_row(radar)[0])                 # virtual channels in the azimuth row
    ranges, azimuths = run.truth_in_radar_frame(0)
    centre = run.phase_centre
    matched = set()
    for person in run.people:
        torso = f"{person}_torso"
        k = run.objects.index(torso)
        los = (run.object_position(torso)[0] - centre) / ranges[k]
        mesh = anim.mesh(0, torso)
        depth = float(np.max((mesh.centroid - mesh.vertices) @ los))          # centroid to the front surface
        r_front, az = ranges[k] - depth, azimuths[k]
        resolution = 2.0 / (n_v * math.cos(az))
        d_range = (ra.ranges[strongest[:, 0]] - r_front) / range_bin
        d_az = (ra.azimuths[strongest[:, 1]] - az) / resolution
        hit = int(np.argmin(np.hypot(d_range, d_az)))
        print(f"\n{person}: truth {r_front:.3f} m (centroid {ranges[k]:.3f} m), {math.degrees(az):+.2f} deg; peak "
              f"{ra.ranges[strongest[hit, 0]]:.3f} m, {math.degrees(ra.azimuths[strongest[hit, 1]]):+.2f} deg: "
              f"{d_range[hit]:+.2f} range bins, {d_az[hit]:+.3f} azimuth resolutions")
        assert abs(d_range[hit]) <= 1.0 and abs(d_az[hit]) <= 1.0
        matched.add(hit)
    assert matched == {0, 1, 2}                     # each of the three strongest peaks is a different person


def test_the_store_carries_every_person(three_people, tmp_path):
    from sionnafmcw.store import RunStore, open_run

    anim, radar, run = three_people
    assert run.people == ["person0", "person1", "person2"] and run.joints == list(KEYPOINTS)
    np.testing.assert_allclose(run.joint_positions()[0], anim.people.keypoints[0], atol=0)
    np.testing.assert_allclose(run.joint_positions("person1")[0], anim.people.keypoints[0, 1], atol=0)
    assert run.person_objects("person2") == anim.people.objects["person2"]
    assert list(run.activities()[0]) == ["walk"] * 3 and list(run.person_count()) == [3]
    ds = run.dataset
    assert ds.joint_position.dims == ("frame", "person", "joint", "xyz")
    assert list(ds.person.values) == run.people and list(ds.object_person.values[:2]) == ["person0", "person0"]
    # a store without people (a scene without them, or written before the arrays existed) still reads
    store = RunStore.open(tmp_path / "plain.zarr", radar, 2, ["plate"], attrs={"radar": radar.to_dict(),
                          "radar_pose": {"position": [0, 0, 1], "orientation": [0, 0, 0]}, "engine": {},
                          "seed": 0, "noise": False})
    cube = np.zeros((radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples), np.complex64)
    store.write_frame(0, cube, 0.0, [[3.0, 0, 1]], [[1.0, 0, 0]], [1.0])
    plain = open_run(tmp_path / "plain.zarr")
    assert plain.people == [] and plain.joints == [] and list(plain.person_count()) == [0, -1]
    assert plain.activities().shape == (2, 0)
    with pytest.raises(Exception, match="no people"):
        plain.joint_positions()


def test_the_manifest_people_entry_is_checked(tmp_path):
    from sionnafmcw.animation import AnimationError

    anim = _build(tmp_path, num_people=1, num_frames=2)
    path = anim.path / "animation.json"
    good = json.loads(path.read_text())
    for change, match in ((lambda p: p["persons"][0]["keypoints"].pop(), r"keypoints has shape \(1, 15, 3\), expected "
                           r"\(2, 15, 3\)"),
                          (lambda p: p["persons"][0]["objects"].append("nobody"), r"objects that are not shapes of "
                           r"the scene: nobody"),
                          (lambda p: p["persons"][0].update(activity=["walk"]), r"activity must be a string or a list "
                           r"of 2 strings")):
        bad = json.loads(json.dumps(good))
        change(bad["people"])
        path.write_text(json.dumps(bad))
        with pytest.raises(AnimationError, match=match):
            load_animation(anim.path)
    path.write_text(json.dumps({k: v for k, v in good.items() if k != "people"}))    # optional: a scene without it
    assert load_animation(anim.path).people is None
