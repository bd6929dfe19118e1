"""The PO render's surfaces (:mod:`sionnafmcw.engines.surfaces`): rigid objects built once in their own
frame and placed per frame by the engine's own instancing must be hit exactly where the same
meshes, moved in the world, are hit; one object hides another as it should; nothing recompiles."""

from __future__ import annotations

import numpy as np
import pytest

from animation_helpers import box_mesh
from sionnafmcw.animation import load_animation
from sionnafmcw.animation.rigid import transform_matrix
from sionnafmcw.engines.loaded_scene import LoadedScene, load_radar_scene
from sionnafmcw.engines.po_render import Material, render, scene_objects
from sionnafmcw.engines.surfaces import Surface, SurfaceWorld, surface_kinds
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.scenes import meshes
from sionnafmcw.scenes.room import add_room
from sionnafmcw.scenes.writer import METAL, AnimationWriter, metal_material
from sionnafmcw.sionna_rt import cast_rays, track_kernels

WAVELENGTH = 299_792_458.0 / 77e9
RADAR = np.array([-2.5, 0.0, 1.0])


def _pose(i):
    """Frame ``i``'s poses of the torso (an ellipsoid), the arm (a capsule 0.25 m in front of it,
    between it and the radar) and a box."""
    return {"torso": (rotation_matrix((0.3 * i, 0.1, 0.0)), np.array([1.0, 0.05 * i, 1.1])),
            "arm": (rotation_matrix((0.0, 0.0, 0.2 * i)), np.array([0.75, -0.05, 1.1])),
            "box": (rotation_matrix((1.0 + 0.4 * i, -0.3, 0.5)), np.array([1.2, 0.9, 0.6]))}


@pytest.fixture(scope="module")
def rigid_scene(tmp_path_factory):
    """Three rigid metal objects in a room, three frames; the Sionna scene and the surface world."""
    root = tmp_path_factory.mktemp("surfaces") / "scene"
    w = AnimationWriter(root, 10.0)
    w.add_materials(metal_material())
    add_room(w, (-3.0, -2.0, 0.0), (3.0, 2.0, 2.5))
    shapes = {"torso": meshes.ellipsoid((0, 0, 0), (0.12, 0.18, 0.3), n_rings=24, n_segments=48),
              "arm": meshes.capsule((0, 0, -0.3), (0, 0, 0.3), 0.04, n_segments=24, n_cap=6, n_body=8),
              "box": box_mesh((0, 0, 0), (0.2, 0.3, 0.25))}
    for name, (v, f) in shapes.items():
        w.rigid(name, v, f, METAL, vertex_normals=meshes.vertex_normals(v, f))
    for i in range(3):
        w.frame(rigid={name: {"to_world": transform_matrix(*_pose(i)[name]), "velocity": (0.1 * i, 0.0, 0.0),
                              "angular_velocity": (0.0, 0.0, 0.3)} for name in shapes})
    w.finish(RADAR, (0.0, 0.0, 0.0))
    anim = load_animation(root)
    scene = load_radar_scene(anim.frames[0].xml, 77e9)
    loaded = LoadedScene.load(scene, anim)
    world = SurfaceWorld.build(anim, list(scene.objects))
    return anim, scene, loaded, world, shapes


def _place(anim, scene, loaded, world, frame):
    if loaded.update_geometry(anim, frame):
        scene.scene_geometry_updated()
    world.place(anim, frame, loaded, {n: anim.object_velocity(frame, n) for n in world.names})


def test_kinds_and_the_atlas(rigid_scene):
    anim, scene, loaded, world, shapes = rigid_scene
    kinds = surface_kinds(anim, world.names)
    assert {n: kinds[n] for n in shapes} == {n: "rigid" for n in shapes}
    assert all(kinds[n] == "static" for n in world.names if n not in shapes)
    slots = np.array([s.slot for s in world.surfaces if s.kind == "rigid"])
    radii = np.array([s.radius for s in world.surfaces if s.kind == "rigid"])
    # the atlas slots' spheres are apart, so a ray clipped to one sphere meets no other slot
    gaps = np.linalg.norm(slots[:, None] - slots[None], axis=-1) - radii[:, None] - radii[None]
    assert np.all(gaps[~np.eye(len(slots), dtype=bool)] > 0)


@pytest.mark.parametrize("frame", [0, 2])
def test_instanced_casts_hit_what_the_moved_meshes_hit(rigid_scene, frame):
    """Random rays from the radar, from inside the room and from points on the objects: the nearest
    object and distance agree with a cast into Sionna's scene, whose meshes were moved in the world.

    The two casts round differently (float32 world coordinates at a few metres, ~3e-7 m, against
    the objects' own frames), so a ray within rounding of a silhouette may go either way: at most
    1e-3 of the rays (measured: none of 2e5 on the walking body); distances agree to 1e-5 m."""
    anim, scene, loaded, world, shapes = rigid_scene
    _place(anim, scene, loaded, world, frame)
    rng = np.random.default_rng(frame)
    n = 20000
    targets = np.array([_pose(frame)[name][1] for name in shapes])
    origins = np.concatenate([np.tile(RADAR, (n, 1)), rng.uniform((-2.5, -1.5, 0.2), (2.5, 1.5, 2.2), (n, 3))])
    aims = targets[rng.integers(0, len(targets), 2 * n)] + rng.normal(scale=0.2, size=(2 * n, 3))
    d = aims - origins
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    valid, t, obj, _, _ = world.cast(origins, d)
    ref_valid, ref_t, shape, _, _ = cast_rays(scene, origins, d)
    ids = {int(scene.objects[name].object_id): k for k, name in enumerate(world.names)}
    ref_obj = np.array([ids.get(int(x), -1) for x in shape])
    ref_obj[~ref_valid] = -1
    agree = obj == ref_obj
    assert agree.mean() >= 1 - 1e-3
    assert np.max(np.abs(t[agree & valid] - ref_t[agree & valid])) < 1e-5
    assert np.isin(obj, [world.index[n] for n in shapes]).sum() > n / 2    # the objects are really hit
    # "moving" only: the rigid objects, and nothing of the room
    valid_m, _, obj_m, _, _ = world.cast(origins, d, "moving")
    assert set(np.unique(obj_m[valid_m])) <= {world.index[n] for n in shapes}
    hit_both = agree & np.isin(obj, [world.index[n] for n in shapes])
    assert np.all(valid_m[hit_both]) and np.array_equal(obj_m[hit_both], obj[hit_both])


def test_the_arm_hides_the_torso_behind_it(rigid_scene):
    """The torso's PO render with the arm in front: the torso keeps exactly the samples of its grid
    whose rays reach it first, i.e. its samples without the arm less the grid rays that hit the arm
    (cast into a scene of the arm alone), and none of its samples lies behind the arm."""
    anim, scene, loaded, world, shapes = rigid_scene
    _place(anim, scene, loaded, world, 1)
    metal = Material("metal", -1j * 1e9, 0.0, 0.0)
    objects = scene_objects(loaded, world, {n: metal for n in world.names})
    torso, arm = world.index["torso"], world.index["arm"]
    with_arm = render(world, objects, RADAR, np.eye(3), WAVELENGTH, targets=[torso])
    samples = with_arm.samples
    assert np.all(samples.labels == "torso")
    # without the arm: the same grid cast over a world whose arm is moved far away
    place = world.placements[arm]
    far = type(place)(place.rotation, place.translation + [0.0, 0.0, 50.0], place.velocity, place.motion)
    world.placements[arm] = far
    without = render(world, objects, RADAR, np.eye(3), WAVELENGTH, targets=[torso])
    world.placements[arm] = place
    # the torso grid's rays that meet the arm first: cast into the arm's posed mesh alone
    v, f = shapes["arm"]
    r, p = _pose(1)["arm"]
    from sionnafmcw.engines.surfaces import mitsuba_mesh, mitsuba_scene
    from sionnafmcw.sionna_rt import cast_scene

    arm_scene, _ = mitsuba_scene({"arm": mitsuba_mesh("arm", v @ r.T + p, f)})
    d = without.direction
    dist = np.linalg.norm(without.samples.position - RADAR, axis=1)
    hit, t_arm, _, _, _ = cast_scene(arm_scene, RADAR, d)
    shadowed = hit & (t_arm < dist)
    assert 100 < shadowed.sum() < without.num_samples / 2          # the arm casts a real shadow
    assert with_arm.num_samples == without.num_samples - shadowed.sum()
    kept = {tuple(np.round(x, 9)) for x in without.samples.position[~shadowed]}
    assert kept == {tuple(np.round(x, 9)) for x in samples.position}


def test_casts_compile_once(rigid_scene):
    """Poses are opaque to Dr.Jit: casting in another frame launches no kernel the first cast did not."""
    anim, scene, loaded, world, shapes = rigid_scene
    rng = np.random.default_rng(5)
    d = rng.normal(size=(5000, 3)) + [1.0, 0.0, 0.0]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    seen = set()
    for frame in (0, 1, 2):
        _place(anim, scene, loaded, world, frame)
        with track_kernels(True, seen) as counts:
            world.cast(RADAR, d)
        if frame:
            assert counts.new == 0, frame


def test_given_vertex_normals_are_used_where_the_surface_is_smooth():
    """A PLY's vertex normals shade the surface where it is smooth; across a crease (a box's edges)
    the crease-aware shading normals keep the faces flat, whatever the averaged normals say."""
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    averaged = meshes.vertex_normals(v, f)                  # what a smooth-shaded box exports
    box = Surface.build("box", "static", v, f, averaged)
    facet = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    facet /= np.linalg.norm(facet, axis=1, keepdims=True)
    np.testing.assert_allclose(box.corner_normals, np.repeat(facet[:, None], 3, axis=1), atol=1e-12)
    assert box.flat and box.curvature_radius == np.inf
    v, f = meshes.ellipsoid((0, 0, 0), (0.1, 0.2, 0.3), n_rings=16, n_segments=32)
    exact = v / np.array([0.1, 0.2, 0.3]) ** 2                # the ellipsoid's own normals
    exact /= np.linalg.norm(exact, axis=1, keepdims=True)
    ellipsoid = Surface.build("e", "rigid", v, f, exact)
    np.testing.assert_allclose(ellipsoid.corner_normals, exact[f], atol=1e-12)


def test_refined_hits_in_one_kernel_as_per_object(rigid_scene):
    """Hits on refined rigid surfaces, turned, moved and spinning (frame 2): the kernel of
    engines.hit_geometry gives the point and normal of the smooth surface, the sub-facet's shape
    operator and the velocity v_c + w x (x - c) that SceneObject.hit_geometry gives per object, to
    float64 rounding (the box's faces are flat patches of its refined surface: the plane branch);
    the room's flat static walls stay on the per-object path."""
    from sionnafmcw.engines.hit_geometry import refined_hit_geometry

    anim, scene, loaded, _, shapes = rigid_scene
    world = SurfaceWorld.build(anim, list(scene.objects), wavelength=WAVELENGTH)
    _place(anim, scene, loaded, world, 2)
    metal = Material("metal", -1j * 1e9, 0.0, 0.0)
    objects = scene_objects(loaded, world, {n: metal for n in world.names})
    tables = world.refined_tables()
    covered = {world.names[k] for k in np.flatnonzero(tables.offset >= 0)}
    assert covered == {"torso", "arm", "box"}                        # the room's walls are flat-shaded
    rng = np.random.default_rng(7)
    obj, tri, bary = [], [], []
    for name in ("arm", "torso", "box", "arm"):
        k = world.index[name]
        n = 4000
        obj.append(np.full(n, k))
        tri.append(rng.integers(0, len(world.surfaces[k].faces), n))
        b = rng.uniform(0.0, 1.0, (n, 2))
        bary.append(np.where(b.sum(axis=1, keepdims=True) > 1, 1.0 - b[:, ::-1], b))
    obj, tri, bary = np.concatenate(obj), np.concatenate(tri), np.concatenate(bary)
    assert np.all(tables.covers(obj))
    got = refined_hit_geometry(tables, objects, obj, tri, bary)
    for k in np.unique(obj):
        sel = obj == k
        want = objects[k].hit_geometry(tri[sel], bary[sel])
        assert objects[k].placement.motion is not None               # spinning: the rotation field is exercised
        for x, y, scale in zip([g[sel] for g in got], want, (1.0, 1.0, 1.0, 1.0 / 0.04)):
            assert np.max(np.abs(x - y)) <= 1e-12 * scale
