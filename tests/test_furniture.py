r"""Furnished rooms (``sionnafmcw.scenes.furniture``, ``sionnafmcw.scenes.layout``).

* Furniture never overlaps: over many seeds and every kind, each pair of floor pieces is checked
  with an exact convex-polygon test written here (edges crossing, a corner inside, else the
  distance of corners to edges), independent of the separating-axis test the placement uses; every
  piece's meshes lie in its footprint, inside the room, clear of every person's vertices in every
  frame and of the radar; doors stand in their wall's opening, which the wall's boxes leave free.
* The pieces' radio materials are valid at 60, 77 and 81 GHz (ITU-R P.2040 through Sionna) and
  refused where P.2040 does not define them (metal above 100 GHz).
* Furniture is static for the path engine: the static-scene cache traces it once.
* Bad requests are errors naming the parameter and the fix.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sionnafmcw import load_animation, scenes
from sionnafmcw.scenes import furniture
from sionnafmcw.scenes.layout import Rect, rects_clear

F32 = 1e-5      # PLY vertices are float32: a few um at room scale
ALL = dict(tables=2, chairs=4, sofas=1, shelves=2, cabinets=1, doors=2, monitors=2)


def _polygon_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between two convex polygons ``[4, 2]`` (0 when they meet)."""
    def cross2(u, v):
        return u[0] * v[1] - u[1] * v[0]

    def inside(p, poly):
        signs = [cross2(poly[(k + 1) % 4] - poly[k], p - poly[k]) for k in range(4)]
        return all(s >= 0 for s in signs) or all(s <= 0 for s in signs)

    def seg_dist(p, q0, q1):
        d = q1 - q0
        t = np.clip(np.dot(p - q0, d) / np.dot(d, d), 0.0, 1.0)
        return float(np.linalg.norm(p - (q0 + t * d)))

    def cross(p0, p1, q0, q1):
        def o(a, b, c):
            return cross2(b - a, c - a)
        return o(q0, q1, p0) * o(q0, q1, p1) < 0 and o(p0, p1, q0) * o(p0, p1, q1) < 0

    if any(inside(p, b) for p in a) or any(inside(p, a) for p in b):
        return 0.0
    if any(cross(a[i], a[(i + 1) % 4], b[j], b[(j + 1) % 4]) for i in range(4) for j in range(4)):
        return 0.0
    return min(min(seg_dist(p, b[j], b[(j + 1) % 4]) for p in a for j in range(4)),
               min(seg_dist(p, a[j], a[(j + 1) % 4]) for p in b for j in range(4)))


def test_the_separating_axis_test_against_exact_polygon_distances():
    rng = np.random.default_rng(0)
    for _ in range(2000):
        a = Rect(tuple(rng.uniform(-1, 1, 2)), tuple(rng.uniform(0.1, 0.8, 2)), rng.uniform(0, 2 * math.pi))
        b = Rect(tuple(rng.uniform(-1, 1, 2)), tuple(rng.uniform(0.1, 0.8, 2)), rng.uniform(0, 2 * math.pi))
        gap = rng.uniform(0.0, 0.3)
        exact = _polygon_gap(a.corners, b.corners)
        if rects_clear(a, b, gap):
            assert exact >= gap - 1e-9                     # never passes pieces closer than the gap
        if exact == 0.0:
            assert not rects_clear(a, b, 0.0)              # overlapping pieces are always refused


@pytest.mark.parametrize("seed", range(12))
def test_furniture_never_overlaps_and_keeps_off_the_people(tmp_path, seed):
    clearance = 0.1
    out = scenes.build("people", tmp_path / "room", num_people=2, activity="mixed", seed=seed, num_frames=3,
                       body_mesh_edge=0.06, furniture_seed=seed, furniture_clearance=clearance, **ALL)
    anim = load_animation(out)
    manifest = json.loads((out / "animation.json").read_text())
    pieces = manifest["furniture"]
    assert sorted(p["kind"] for p in pieces) == sorted(k for k, n in furniture.counts_of(ALL).items() for _ in range(n))
    rects = {p["name"]: Rect(tuple(p["footprint"]["centre"]), tuple(p["footprint"]["half_size"]), p["footprint"]["yaw"])
             for p in pieces}
    floor = [p for p in pieces if p["kind"] != "monitor"]
    for i, a in enumerate(floor):
        for b in floor[i + 1:]:
            gap = _polygon_gap(rects[a["name"]].corners, rects[b["name"]].corners)
            assert gap >= clearance - 1e-9, (seed, a["name"], b["name"], gap)
    walls = {n: anim.mesh(0, n).vertices for n in anim.frame_xml(0).shapes if n.startswith("wall_")}
    room_lo = np.array([walls["wall_x0"][:, 0].max(), walls["wall_y0"][:, 1].max()])
    room_hi = np.array([walls["wall_x1"][:, 0].min(), walls["wall_y1"][:, 1].min()])
    people_xy = np.concatenate([anim.mesh(f, o).vertices[:, :2] for f in range(anim.num_frames)
                                for objs in anim.people.objects.values() for o in objs])
    radar_xy = anim.radar_pose.position[:2]
    for p in pieces:
        rect = rects[p["name"]]
        v = np.concatenate([anim.mesh(0, o).vertices for o in p["objects"]])
        local = np.abs((v[:, :2] - rect.centre) @ rect.axes.T)
        if p["kind"] == "door":                             # the leaf in the wall, its swing in the room
            assert np.all(local[:, 0] <= rect.half[0] + F32)
            lo_box, hi_box = v.min(0), v.max(0)
            for name, wv in walls.items():                  # no wall box overlaps the leaf
                overlap = np.minimum(hi_box, wv.max(0)) - np.maximum(lo_box, wv.min(0))
                assert np.any(overlap <= F32), (p["name"], name)
            continue
        if p["kind"] != "monitor":
            assert np.all(local <= np.asarray(rect.half) + F32), p["name"]         # the mesh in its footprint
            assert np.all(v[:, :2] >= room_lo - F32) and np.all(v[:, :2] <= room_hi + F32), p["name"]
        else:
            table = next(q for q in pieces if q["name"] == p["table"])
            assert v[:, 2].min() == pytest.approx(table["size"][2], abs=F32)               # stands on its table
            assert np.all(np.abs((v[:, :2] - rects[table["name"]].centre) @ rects[table["name"]].axes.T)
                          <= np.asarray(rects[table["name"]].half) + F32)
            continue
        d = np.abs((people_xy - rect.centre) @ rect.axes.T) - np.asarray(rect.half)
        assert np.linalg.norm(np.maximum(d, 0), axis=1).min() >= clearance - F32, p["name"]
        assert np.linalg.norm(np.maximum(np.abs((radar_xy - rect.centre) @ rect.axes.T) - rect.half, 0)) >= 0.3


def test_furniture_materials_valid_at_the_carrier(tmp_path):
    from sionnafmcw.materials import MaterialFrequencyError

    out = scenes.build("people", tmp_path / "room", num_people=1, num_frames=2, body_mesh_edge=0.06, **ALL)
    from sionnafmcw.materials import check_material_frequency

    anim = load_animation(out)
    mats = {k: m for k, m in anim.materials().items() if k.startswith("furniture-")}
    assert {m.itu_type for m in mats.values()} == {"wood", "chipboard", "ceiling_board", "metal", "glass"}
    for f in (60e9, 77e9, 81e9):
        anim.check_frequency(f)
    refused = set()
    for key, m in mats.items():        # P.2040 defines metal to 100 GHz only; the others again from 100-110 GHz
        try:
            check_material_frequency(m, 120e9, where=key)
        except MaterialFrequencyError as err:
            assert "is not defined at 120 GHz" in str(err)
            refused.add(m.itu_type)
    assert refused == {"metal"}


def test_furniture_is_static_for_the_path_engine(tmp_path):
    from sionnafmcw import PathEngine, RadarConfig
    from sionnafmcw.engines.static_scene import moving_objects

    out = scenes.build("people", tmp_path / "room", num_people=1, activity="walk", num_frames=2, body_mesh_edge=0.06,
                       seed=2, tables=1, cabinets=1, doors=1)
    anim = load_animation(out)
    pieces = [o for p in json.loads((out / "animation.json").read_text())["furniture"] for o in p["objects"]]
    assert not set(pieces) & set(anim.object_names)
    radar = RadarConfig.preset("walk-77ghz")
    engine = PathEngine(samples_per_src=2000, max_depth=1)
    for f in range(2):
        engine.echoes(anim, radar, f)
        rigid = {n: np.asarray(anim.frame(f).objects.get(n, np.zeros(3)), float) for n in engine.scene.objects}
        moving = moving_objects(engine._loaded, rigid)
        assert moving == frozenset(anim.object_names)                  # the person's segments only
    assert engine.last_stats.static_po_samples > 0 and "static_seconds" in engine.last_stats.figures


def test_furniture_errors(tmp_path):
    with pytest.raises(ValueError, match=r"monitors=2 but tables=1; .* add tables or remove monitors"):
        scenes.build("people", tmp_path / "a", num_people=1, num_frames=2, tables=1, monitors=2)
    with pytest.raises(ValueError, match=r"cannot place sofa .* lower sofas, raise room_margin"):
        scenes.build("people", tmp_path / "a", num_people=1, num_frames=2, sofas=2, max_range=2.0, min_range=1.0,
                     max_azimuth=0.3, room_margin=0.5, body_mesh_edge=0.06)
    with pytest.raises(ValueError, match=r"furniture .* needs room=true"):
        scenes.build("wave", tmp_path / "a", num_frames=2, chairs=1)
    with pytest.raises(ValueError, match=r"'chairs'=13 is out of range"):
        scenes.build("people", tmp_path / "a", chairs=13)
    with pytest.raises(ValueError, match=r"unknown kind\(s\) piano"):
        furniture.place_furniture({"piano": 1}, (0, 0, 0), (5, 5, 3))
    assert list(tmp_path.iterdir()) == []


def test_an_activity_in_a_furnished_room(tmp_path):
    out = scenes.build("fall", tmp_path / "fall", num_frames=3, body_mesh_edge=0.06, room=True, room_margin=1.5,
                       chairs=2, shelves=1, doors=1)
    manifest = json.loads((out / "animation.json").read_text())
    assert sorted(p["kind"] for p in manifest["furniture"]) == ["chair", "chair", "door", "shelves"]
    assert manifest["people"]["persons"][0]["activity"] == "fall"
    shapes = load_animation(out).frame_xml(0).shapes
    door_wall = manifest["furniture"][0]["wall"]
    assert f"{door_wall}_1" in shapes and f"{door_wall}_2" in shapes     # the wall around the doorway: 3 boxes
