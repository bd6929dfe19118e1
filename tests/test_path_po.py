"""Path engine = PO direct echo + multipath + random-phase diffuse, on real scenes.

References are written apart from the engine: the triangle quadrature of the PO integral
(tests/po_quadrature.py) with the radar's own element positions, and the closed forms (plate
4 pi A^2 / lambda^2, sphere pi r^2, trihedral 4 pi a^4 / (3 lambda^2), Lambertian plate 4 A S^2 |Gamma|^2).
Tolerances: 1 dB (1.5 dB for the trihedral); 0.5 dB for the sampling invariance.
Every figure is the channel of one element pair (Tx 0, Rx 0), so the near field is the pair's own.
"""

from __future__ import annotations

import numpy as np
import pytest

import po_quadrature as quad
from animation_helpers import write_moving_mesh_animation
from sionnafmcw import RadarConfig, processing
from sionnafmcw.animation import load_animation
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.engines import PathEngine, PathEngineError
from sionnafmcw.engines.traced_paths import specular_chains
from sionnafmcw.engines.po_render import curvature_radius, shading_normals
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.scenes import meshes
from sionnafmcw.scenes.registry import build
from sionnafmcw.synthesis import synthesize

RADAR = RadarConfig.preset("walk-77ghz").replace(antenna_pattern="iso", num_chirps=16)
LAMBDA = SPEED_OF_LIGHT / RADAR.fc
ROUGH_METAL = {"mat-rough-metal": ("itu-radio-material", {"type": "metal", "scattering_coefficient": 0.5})}


def db(x):
    return 10 * np.log10(x)


def channel(echoes, tx=0, rx=0):
    return np.sum(echoes.a[tx, rx] * np.exp(-2j * np.pi * RADAR.fc * echoes.tau[tx, rx]))


def elements(anim):
    pose = anim.radar_pose
    rot = rotation_matrix(pose.orientation)
    return pose.position + RADAR.tx_positions @ rot.T, pose.position + RADAR.rx_positions @ rot.T


def rcs(h, distance):
    return (4 * np.pi) ** 3 * distance ** 4 * abs(h) ** 2 / LAMBDA ** 2


def mesh_scene(tmp_path, name, vertices, faces, materials=None, material="mat-itu_metal", velocity=(0.0, 0.0, 0.0),
               num_frames=1):
    root = write_moving_mesh_animation(tmp_path / name, lambda t: (vertices + np.asarray(velocity) * t, faces),
                                       np.asarray(velocity, float), num_frames=num_frames, materials=materials,
                                       material=material, name="target")
    return load_animation(root)


# ---------------------------------------------------------------------------------------- plates
@pytest.mark.parametrize("side", [0.1, 0.2])
@pytest.mark.parametrize("distance", [2.0, 5.0, 10.0, 20.0])
def test_metal_plate_facing_radar(tmp_path, side, distance):
    """The plate is no longer an infinite mirror: the independent quadrature within 1 dB at every range,
    the far-field 4 pi A^2 / lambda^2 within 1 dB where 2 D^2 / lambda is passed, and below it closer in
    (before: pi R^2 for both sizes, +11.8 dB at 20 m for the 0.1 m plate)."""
    anim = load_animation(build("moving_plate", tmp_path / "plate", start_range=distance, speed=0.0, size=side,
                                room=False, num_frames=1))
    engine = PathEngine(samples_per_src=10_000, max_depth=1, diffuse=False)
    echoes = engine.echoes(anim, RADAR, 0)
    assert engine.last_stats.num_traced_paths == 0            # Sionna's mirror path is gone
    tx, rx = elements(anim)
    mesh = anim.mesh(0, "plate")
    h = channel(echoes)
    reference = quad.po_channel(mesh.vertices, mesh.faces, tx[0], rx[0], LAMBDA, two_sided=True)
    assert abs(db(abs(h) ** 2 / abs(reference) ** 2)) < 1.0
    sigma, far = rcs(h, distance), 4 * np.pi * side ** 4 / LAMBDA ** 2
    if distance >= 2 * 2 * side ** 2 / LAMBDA:
        assert abs(db(sigma / far)) < 1.0
    else:
        assert sigma < far


@pytest.mark.parametrize("orientation", [(0.0, 0.0, 0.35), (0.004, 0.003, 1.1), (0.01, 0.0, 0.0)])
def test_plate_tessellation_invariant(tmp_path, orientation):
    """A 0.1 m plate at 5 m split into 2 or 128 triangles, turned: the same echo (within 1 dB; before,
    a plate turned 0.35 rad in 8+ triangles returned its mirror path 2-5 times) and the quadrature's."""
    rot = rotation_matrix(orientation)
    centre = np.array([5.0, 0.0, 0.0])
    tx = rx = None
    out = []
    for subdiv in (1, 8):
        v, f = meshes.plate((0, 0, 0), (0.1, 0.1), normal=(-1, 0, 0), subdiv=subdiv)
        assert len(f) == 2 * subdiv ** 2
        v = v @ rot.T + centre
        anim = mesh_scene(tmp_path, f"plate{subdiv}", v, f)
        tx, rx = elements(anim)
        h = channel(PathEngine(samples_per_src=10_000, max_depth=1, diffuse=False).echoes(anim, RADAR, 0))
        reference = quad.po_channel(v, f, tx[0], rx[0], LAMBDA, two_sided=True)
        assert abs(h) > 0
        assert abs(db(abs(h) ** 2 / abs(reference) ** 2)) < 1.0
        out.append(abs(h) ** 2)
    assert abs(db(out[1] / out[0])) < 1.0


@pytest.mark.parametrize("distance", [2.0, 10.0])
def test_sphere_is_pi_r_squared(tmp_path, distance):
    """A faceted metal sphere (r = 0.1 m, 4.9 mm facets, centre at ``distance``): smooth shading normals
    make it the sphere it stands for: the quadrature of the mesh and sigma = pi r^2 (R to the centre, as
    tests/test_physical_optics.py) within 1 dB (before: no echo, or pi R^2 when a facet faced the radar)."""
    radius = 0.1
    v, f = meshes.ellipsoid((distance, 0.0, 0.0), (radius,) * 3, n_rings=64, n_segments=128)
    anim = mesh_scene(tmp_path, "sphere", v, f)
    engine = PathEngine(samples_per_src=10_000, max_depth=1, diffuse=False)
    h = channel(engine.echoes(anim, RADAR, 0))
    tx, rx = elements(anim)
    reference = quad.po_channel(v, f, tx[0], rx[0], LAMBDA)
    assert abs(db(abs(h) ** 2 / abs(reference) ** 2)) < 1.0
    assert abs(db(rcs(h, distance) / (np.pi * radius ** 2))) < 1.0


# ---------------------------------------------------------------------------------------- trihedral
def hexagon_aperture(corner, axis, leg):
    """The trihedral's effective aperture at boresight: the regular hexagon common to the projected
    aperture triangle and its point reflection through the corner, area a^2 / sqrt(3), in the plane
    through the corner normal to ``axis``; as a fan of 6 triangles."""
    axis = axis / np.linalg.norm(axis)
    u = np.cross(axis, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    # regular hexagon of area a^2/sqrt(3): area = 3 sqrt(3)/2 s^2
    s = np.sqrt(leg ** 2 / np.sqrt(3) * 2 / (3 * np.sqrt(3)))
    ang = np.arange(6) * np.pi / 3
    ring = corner + s * (np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * w)
    v = np.vstack([corner, ring])
    f = np.array([(0, 1 + k, 1 + (k + 1) % 6) for k in range(6)])
    return v, f


@pytest.mark.parametrize("distance", [2.0, 5.0, 10.0, 20.0])
def test_trihedral_bounded_by_its_aperture(tmp_path, distance):
    """A 0.1 m triangular trihedral facing the radar: the triple bounce is ray-tube PO on the exit
    aperture (engines/po_render.py), i.e. the aperture hexagon radiating the image source's field.
    Reference: the quadrature of that hexagon, the image of Tx 0 being its point reflection through
    the corner (the plate-equivalent source is Tx 0 turned half a turn about the line of sight);
    within 1.5 dB, and the far field 4 pi a^4 / (3 lambda^2) within 1.5 dB at 10 and 20 m (before:
    -2.6 / +4.7 / +10.6 / +16.6 dB off at 2 / 5 / 10 / 20 m)."""
    leg = 0.1
    anim = load_animation(build("corner_reflectors", tmp_path / "tri", ranges=(distance,), azimuths=(0.0,),
                                speeds=(0.0,), leg=leg, room=False, num_frames=1))
    engine = PathEngine(samples_per_src=1_000_000, max_depth=3, diffuse=False, po_samples_across=48)
    echoes = engine.echoes(anim, RADAR, 0)
    assert [b.depth for b in engine.last_renders] == [1, 2, 3]
    assert engine.last_stats.num_traced_paths == 0            # Sionna's GO chains replaced by PO
    tx, rx = elements(anim)
    corner = anim.radar_pose.position + np.array([distance, 0.0, 0.0])
    axis = corner - 0.5 * (tx[0] + rx[0])
    v, f = hexagon_aperture(corner, axis, leg)
    a_hat = axis / np.linalg.norm(axis)
    d = tx[0] - corner
    turned = corner + 2 * np.dot(d, a_hat) * a_hat - d       # half a turn about the line of sight
    reference = quad.po_channel(v, f, turned, rx[0], LAMBDA, two_sided=True)
    h = channel(echoes)
    assert abs(db(abs(h) ** 2 / abs(reference) ** 2)) < 1.5
    if distance >= 10.0:
        far = 4 * np.pi * leg ** 4 / (3 * LAMBDA ** 2)
        assert abs(db(rcs(h, distance) / far)) < 1.5


# ---------------------------------------------------------------------------------------- energy split
@pytest.mark.parametrize("s", [0.0, 0.5, 1.0])
def test_po_plus_diffuse_equals_closed_forms(tmp_path, s):
    """A 0.3 m rough metal plate facing the radar at 2 m: the PO share is (1 - S^2) times the plate's PO
    (quadrature), the diffuse paths' power sum(|a|^2) is the Lambertian 4 A S^2 |Gamma|^2 (as an RCS);
    within 1 dB each, nothing counted twice (S = 0: no diffuse power; S = 1: no PO echo)."""
    side, distance = 0.3, 2.0
    v, f = meshes.plate((distance, 0.0, 0.0), (side, side), normal=(-1, 0, 0), subdiv=2)
    mats = {"mat-rough-metal": ("itu-radio-material", {"type": "metal", "scattering_coefficient": s})}
    anim = mesh_scene(tmp_path, "rough", v, f, materials=mats, material="mat-rough-metal")
    engine = PathEngine(samples_per_src=1_000_000, max_depth=1)
    engine.echoes(anim, RADAR, 0)
    parts = engine.last_parts
    tx, rx = elements(anim)
    po_power = abs(channel(parts["po"])) ** 2 if parts["po"] is not None else 0.0
    reference = abs(quad.po_channel(v, f, tx[0], rx[0], LAMBDA, two_sided=True)) ** 2 * (1 - s ** 2)
    if s < 1:
        assert abs(db(po_power / reference)) < 1.0
    else:
        assert po_power == 0.0
    diffuse = parts["traced"]
    diffuse_power = 0.0 if diffuse is None else float(np.sum(np.abs(diffuse.a[0, 0]) ** 2))
    lambert = LAMBDA ** 2 * 4 * side ** 2 * s ** 2 / ((4 * np.pi) ** 3 * distance ** 4)
    if s > 0:
        assert abs(db(diffuse_power / lambert)) < 1.0
    else:
        assert diffuse_power == 0.0


def _map_power(anim, radar, rays, frames):
    """Mean clutter-removed range-Doppler power over ``frames`` (noise-free cubes)."""
    engine = PathEngine(samples_per_src=rays, max_depth=1)
    power = []
    for frame in frames:
        cube = synthesize(engine.echoes(anim, radar, frame), radar, noise=False)
        power.append(np.mean(processing.range_doppler_map(cube, radar, clutter_removal=True).power))
    return float(np.mean(power))


def test_diffuse_map_power_independent_of_ray_count(tmp_path):
    """4x more rays moves the mean clutter-removed map power of a rough surface by < 0.5 dB: with a
    random phase fixed to every scatterer, neighbours add in power, so the expected map power is
    sum(|a|^2) whatever the ray count. The mean estimates that expectation only over many
    independent speckle looks (one range-Doppler-angle cell is one exponential draw: measured, a
    single rough plate's map power moves by up to 10 dB from frame to frame at a fixed
    sum(|a|^2)). Here a rough metal ground sheet (S = 1) 1 m below the radar, 2-10 m ahead and
    8 m wide, moving away at 1 m/s: ~80 range bins times ~8 angle looks of the 12-channel row,
    some 600 looks (4 %, 0.2 dB per estimate)."""
    v0, f = meshes.plate((6.0, 0.0, -1.0), (8.0, 8.0), normal=(0, 0, 1), subdiv=8)
    velocity = np.array([1.0, 0.0, 0.0])
    mats = {"mat-rough-metal": ("itu-radio-material", {"type": "metal", "scattering_coefficient": 1.0})}
    anim = mesh_scene(tmp_path, "ground", v0, f, materials=mats, material="mat-rough-metal", velocity=velocity)
    radar = RADAR.replace(num_chirps=64)
    coarse, fine = (_map_power(anim, radar, n, [0]) for n in (250_000, 1_000_000))
    assert abs(db(fine / coarse)) < 0.5


# ---------------------------------------------------------------------------------------- engine rules
def test_first_order_specular_paths_dropped_and_settings(tmp_path):
    """With PO the traced paths hold no first-order specular path (PO replaces them); the options are
    recorded in settings(); PO off gives Sionna's mirror path back."""
    anim = load_animation(build("moving_plate", tmp_path / "plate", start_range=3.0, speed=0.0, size=0.3,
                                room=True, num_frames=1))
    engine = PathEngine(samples_per_src=200_000, max_depth=2, diffuse=False, multibounce="sionna")
    engine.echoes(anim, RADAR, 0)
    assert not np.any(specular_chains(engine.last_paths, 1))
    assert engine.last_stats.num_replaced_specular > 0
    settings = engine.settings()
    assert settings["physical_optics"] is True and settings["random_phase"] is True
    assert settings["multibounce"] == "sionna" and settings["po_samples_across"] == 16
    off = PathEngine(samples_per_src=200_000, max_depth=2, diffuse=False, physical_optics=False)
    off.echoes(anim, RADAR, 0)
    assert np.any(specular_chains(off.last_paths, 1)) and off.last_parts.get("po") is None
    with pytest.raises(PathEngineError, match="multibounce"):
        PathEngine(multibounce="go")
    with pytest.raises(PathEngineError, match="per-element"):
        PathEngine(array_model="per-element")


def test_shading_normals_and_curvature():
    """A plate in any tessellation keeps its plane normal (flat: infinite radius), a box its face normals,
    a sphere's smoothed normals give its radius of curvature (within 10 %)."""
    v, f = meshes.plate((1, 2, 3), (0.4, 0.4), normal=(0.3, 0.5, 0.8), subdiv=5)
    n = shading_normals(v, f)
    plane = np.cross(v[f[0, 1]] - v[f[0, 0]], v[f[0, 2]] - v[f[0, 0]])
    plane /= np.linalg.norm(plane)
    assert np.allclose(np.abs(n @ plane), 1.0, atol=1e-9)
    assert curvature_radius(v, f, n) == np.inf
    from animation_helpers import box_mesh
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    n = shading_normals(v, f)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    fn /= np.linalg.norm(fn, axis=-1, keepdims=True)
    assert np.allclose(np.einsum("fci,fi->fc", n, fn), 1.0)
    v, f = meshes.ellipsoid((0, 0, 0), (0.1, 0.1, 0.1), n_rings=32, n_segments=64)
    n = shading_normals(v, f)
    assert abs(curvature_radius(v, f, n, quantile=0.5) / 0.1 - 1) < 0.1


def test_flat_shaded_objects_skip_the_normal_interpolation():
    """On an object whose faces have one normal at all corners (the room's axis-aligned planes, a
    box) the hit normal is that normal and the shape operator zero, as interpolated_normals gives,
    turned with the object's placement (normal R n, shape operator R K R^T); a smoothed ellipsoid is
    not flat-shaded and keeps the interpolation, and so does a tilted plate whose corner normals
    differ by rounding (None: either way, same result)."""
    from animation_helpers import box_mesh
    from sionnafmcw.engines.po_render import Material, SceneObject
    from sionnafmcw.engines.surfaces import Placement, Surface
    from sionnafmcw.physical_optics import interpolated_normals

    rng = np.random.default_rng(3)
    skin = Material("m", 5 - 1j, 0.0, 0.0)
    rot = rotation_matrix((0.4, 0.2, -0.3))
    shapes = [meshes.plate((1, 2, 3), (0.4, 0.4), normal=(0.0, 0.0, 1.0), subdiv=5), box_mesh((0, 0, 0), (1, 1, 1)),
              meshes.ellipsoid((0, 0, 0), (0.1, 0.2, 0.3), n_rings=12, n_segments=24),
              meshes.plate((1, 2, 3), (0.4, 0.4), normal=(0.3, 0.5, 0.8), subdiv=5)]
    for (v, f), flat in zip(shapes, (True, True, False, None)):
        surface = Surface.build("o", "rigid", v, f)
        for turn in (np.eye(3), rot):
            obj = SceneObject("o", 1, 0, surface, Placement(turn, np.array([0.5, -1.0, 2.0]), np.zeros(3)), skin, v)
            if flat is not None:
                assert obj.flat_shaded is flat
            tri = rng.integers(0, len(f), 200)
            bary = rng.dirichlet([1, 1, 1], 200)[:, 1:]
            position, normal, _, curvature = obj.hit_geometry(tri, bary)
            n_ref, k_ref = interpolated_normals(v[f[tri]], surface.corner_normals[tri], bary)
            w = np.stack([1 - bary.sum(1), bary[:, 0], bary[:, 1]], -1)
            np.testing.assert_allclose(position, np.einsum("pk,pki->pi", w, v[f[tri]]) @ turn.T + [0.5, -1.0, 2.0],
                                       rtol=0, atol=1e-12)
            np.testing.assert_allclose(normal, n_ref @ turn.T, rtol=0, atol=1e-15)
            np.testing.assert_allclose(curvature, turn @ k_ref @ turn.T, rtol=0, atol=1e-12)
            if flat is not None:
                assert flat == (not np.any(curvature))


@pytest.mark.parametrize("rigid", [True, False])
def test_turning_segment_echoes_do_not_depend_on_the_frames_before(tmp_path, rigid):
    """A metal ellipsoid turning about its axis and moving, written as a rigid object (one PLY and a
    transform per frame) or as a new PLY every frame: frame 2 computed after frames 0 and 1 equals
    frame 2 computed alone, bit for bit (a resumed run gives the same cube)."""
    v, f = meshes.ellipsoid((0, 0, 0), (0.05, 0.08, 0.2), n_rings=16, n_segments=32)

    def pose(t):
        return rotation_matrix((2.0 * t, 0.0, 0.0)), np.array([3.0 + 0.5 * t, 0.0, 0.0])

    if rigid:
        from sionnafmcw.animation.rigid import transform_matrix
        from sionnafmcw.scenes.writer import METAL, AnimationWriter, metal_material

        w = AnimationWriter(tmp_path / "turning", 10.0)
        w.add_materials(metal_material())
        w.rigid("segment", v, f, METAL)
        for i in range(3):
            r, p = pose(i / 10.0)
            w.frame(rigid={"segment": {"to_world": transform_matrix(r, p), "velocity": (0.5, 0.0, 0.0),
                                       "angular_velocity": (0.0, 0.0, 2.0)}})
        w.finish((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        root = tmp_path / "turning"
    else:
        def mesh(t):
            r, p = pose(t)
            return v @ r.T + p, f

        root = write_moving_mesh_animation(tmp_path / "turning", mesh, (0.5, 0, 0), num_frames=3, name="segment")
    anim = load_animation(root)
    walked = PathEngine(diffuse=False, track_kernels=False)
    for frame in range(3):
        after = walked.echoes(anim, RADAR, frame)
    alone = PathEngine(diffuse=False, track_kernels=False).echoes(anim, RADAR, 2)
    assert after.num_contributions > 0
    assert walked._state.surfaces.surfaces[0].kind == ("rigid" if rigid else "deforming")
    for name in ("a", "tau", "doppler"):
        np.testing.assert_array_equal(getattr(after, name), getattr(alone, name))


def test_merge_keeps_the_channel():
    """Merging contributions per cell keeps every pair's channel at the carrier exactly, whatever the
    budget, and keeps labels apart."""
    from sionnafmcw.engines.po_merge import merge_contributions

    rng = np.random.default_rng(1)
    p = 500
    tau = 2 * 3.0 / SPEED_OF_LIGHT + rng.uniform(0, 1e-9, (2, 3, p))
    a = (rng.normal(size=(2, 3, p)) + 1j * rng.normal(size=(2, 3, p))) * 1e-9
    dop = rng.uniform(-10, 10, (2, 3, p))
    labels = np.where(np.arange(p) % 2, "x", "y")
    u = np.tile([1.0, 0.0, 0.0], (p, 1))
    merged = merge_contributions(a, tau, dop, labels, u, RADAR, budget=np.inf)
    ma, mt, ml = merged.a, merged.tau, merged.labels
    assert merged.fraction is not None and ma.shape[-1] < p and set(ml) == {"x", "y"}
    for lab in ("x", "y"):
        h = np.sum(a[..., labels == lab] * np.exp(-2j * np.pi * RADAR.fc * tau[..., labels == lab]), axis=-1)
        hm = np.sum(ma[..., ml == lab] * np.exp(-2j * np.pi * RADAR.fc * mt[..., ml == lab]), axis=-1)
        assert np.allclose(h, hm, rtol=1e-9, atol=1e-21)
