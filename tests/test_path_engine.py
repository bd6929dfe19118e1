"""Path engine on real Sionna RT scenes written to tmp_path; skin material; ITU frequency check."""

from __future__ import annotations

import numpy as np
import pytest

from animation_helpers import METAL, box_mesh, plate_mesh, write_moving_mesh_animation, write_plate_animation
from sionnafmcw.animation import load_animation
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.engines import EngineError, PathEngine, PathEngineError, SceneGeometryError
from sionnafmcw.materials import (
    MaterialFrequencyError,
    SKIN_DRY,
    check_itu_frequency,
    itu_valid_ranges,
    skin_properties,
)
from sionnafmcw.radar import RadarConfig

RADAR = RadarConfig.preset("walk-77ghz")  # 3 Tx x 4 Rx, tr38901 elements, 77 GHz
LAMBDA = SPEED_OF_LIGHT / RADAR.fc
ROUGH = {"mat-rough": ("radio-material", {"relative_permittivity": 5.0, "conductivity": 0.1,
                                          "scattering_coefficient": 0.5})}


def _rotation(yaw, pitch, roll):
    """Sionna's rotation matrix R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def _specular_plate_delays(tx, rx, point_on_plane, normal):
    """Image-method delay of the specular reflection off an infinite plane, [M, N] (s)."""
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    dist = (tx - point_on_plane) @ n
    image = tx - 2 * dist[:, None] * n
    return np.linalg.norm(image[:, None, :] - rx[None, :, :], axis=-1) / SPEED_OF_LIGHT


# ------------------------------------------------------------------------------- metal plate
@pytest.mark.parametrize("speed", [1.0, -1.0])
def test_metal_plate_range_doppler_gain(tmp_path, speed):
    """A plate at 5 m moving along the line of sight: one specular echo per element pair."""
    distance = 5.0
    root = write_plate_animation(tmp_path / "plate", distance=distance, velocity=(speed, 0.0, 0.0), num_frames=2)
    anim = load_animation(root)
    engine = PathEngine(physical_optics=False, samples_per_src=2000)
    echoes = engine.echoes(anim, RADAR, 1)
    assert echoes.shape == (3, 4, 1)
    assert np.all(echoes.a != 0)
    assert np.all(echoes.labels == "plate")

    # delay per element pair, from the exact element geometry (plate at 5.1 m or 4.9 m in frame 1)
    plate_x = distance + speed * anim.frame_period
    tau = _specular_plate_delays(RADAR.tx_positions, RADAR.rx_positions, np.array([plate_x, 0, 0]), [1, 0, 0])
    np.testing.assert_allclose(echoes.tau[..., 0], tau, rtol=0, atol=1e-13)
    assert echoes.tau[0, 0, 0] == pytest.approx(2 * plate_x / SPEED_OF_LIGHT, rel=1e-5)

    # Doppler: -2 v_r / lambda, negative receding, positive approaching
    np.testing.assert_allclose(echoes.doppler, -2 * speed / LAMBDA, atol=1e-2)
    assert np.sign(echoes.doppler[0, 0, 0]) == -np.sign(speed)

    # gain: image of the element pattern in a perfect mirror, |a| = lambda G / (4 pi d)
    d = SPEED_OF_LIGHT * tau
    gain = 10 ** (8.0 / 10)  # tr38901 boresight gain (8 dBi), Tx and Rx
    np.testing.assert_allclose(np.abs(echoes.a[..., 0]), LAMBDA * gain / (4 * np.pi * d), rtol=5e-3)


def test_radar_pose_orientation_and_override(tmp_path):
    """Yaw 90 deg: boresight +y, the array's local +y along world -x (Sionna's yaw, pitch, roll)."""
    position = np.array([0.3, 0.0, 0.2])
    pose = (position, (np.pi / 2, 0.0, 0.0))
    root = write_moving_mesh_animation(tmp_path / "yaw", lambda t: plate_mesh((0.3, 5.0, 0.2), normal_axis=1),
                                       (0.0, 1.0, 0.0), num_frames=1, radar_pose=pose)
    anim = load_animation(root)
    echoes = PathEngine(physical_optics=False, samples_per_src=2000).echoes(anim, RADAR, 0)
    rot = _rotation(np.pi / 2, 0.0, 0.0)
    tx = RADAR.tx_positions @ rot.T + position
    rx = RADAR.rx_positions @ rot.T + position
    np.testing.assert_allclose(rx[1] - rx[0], [-LAMBDA / 2, 0, 0], atol=1e-9)
    tau = _specular_plate_delays(tx, rx, np.array([0.3, 5.0, 0.2]), [0, 1, 0])
    assert echoes.shape == (3, 4, 1)
    np.testing.assert_allclose(echoes.tau[..., 0], tau, rtol=0, atol=1e-13)
    np.testing.assert_allclose(echoes.doppler, -2 * 1.0 / LAMBDA, atol=1e-2)

    # override: the same scene seen from 1 m further back along -y
    back = (position - [0, 1.0, 0], (np.pi / 2, 0.0, 0.0))
    engine = PathEngine(physical_optics=False, samples_per_src=2000)
    far = engine.echoes(anim, RADAR, 0, radar_pose=back)
    np.testing.assert_allclose(far.tau - echoes.tau, 2.0 / SPEED_OF_LIGHT, atol=1e-13)


def test_missing_radar_pose_is_an_error(tmp_path):
    root = write_plate_animation(tmp_path / "p", radar_pose=None, num_frames=1)
    anim = load_animation(root)
    with pytest.raises(EngineError, match="no 'radar' pose"):
        PathEngine(physical_optics=False, samples_per_src=1000).echoes(anim, RADAR, 0)
    echoes = PathEngine(physical_optics=False, samples_per_src=1000).echoes(anim, RADAR, 0, radar_pose=([0, 0, 0], [0, 0, 0]))
    assert echoes.shape == (3, 4, 1)


# ------------------------------------------------------------------------------- compilation
def test_no_kernel_compiled_after_frame_two(tmp_path):
    """Moving box with a changing velocity (rigid), rotating strip (vertex velocities), diffuse floor:
    the path count and the velocities change from frame to frame, yet no new kernel appears after
    the first frame."""
    floor_v, floor_f = plate_mesh((0, 0, -1.0), size=(8, 8), normal_axis=2, subdiv=2)
    root = tmp_path / "room"

    def person(t):
        return box_mesh((3.0 + 1.2 * t, 0.4 * np.sin(5 * t), -0.1), (0.3, 0.5, 1.7))

    def strip(t):
        v, f = plate_mesh((4.0, -1.0, 0.0), size=(0.8, 0.1), subdiv=2)
        c, s_ = np.cos(t), np.sin(t)
        rot = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1]])
        return (v - [4.0, -1.0, 0.0]) @ rot.T + [4.0, -1.0, 0.0], f

    spinning = {"name": "strip", "mesh_fn": strip, "velocity": (0, 0, 0), "material": "mat-rough",
                "vertex_velocity_fn": lambda t, v: np.cross([0, 0, 1.0], v - [4.0, -1.0, 0.0])}
    write_moving_mesh_animation(root, person, lambda t: (1.2, 2.0 * np.cos(5 * t), 0.0), num_frames=6, fps=10.0,
                                name="person", materials=dict(METAL, **ROUGH), extra_objects=[spinning],
                                static=[("floor", floor_v, floor_f, "mat-rough")])
    anim = load_animation(root)
    engine = PathEngine(physical_optics=False, samples_per_src=5000)
    counts = []
    for frame in range(anim.num_frames):
        echoes = engine.echoes(anim, RADAR, frame)
        counts.append(echoes.num_contributions)
        assert set(np.unique(echoes.labels)) <= {"", "person", "floor", "strip"}
    stats = engine.stats
    assert len(set(counts)) > 1, "the scene should change the number of paths between frames"
    assert stats[0].reloaded and not any(s.reloaded for s in stats[1:])
    assert stats[0].kernels_launched > 0
    # the brief asks for no compilation after frame 2; the engine compiles the geometry-update
    # kernels while loading, so it is flat from frame 1 on
    for s in stats[1:]:
        assert s.new_kernel_hashes == 0, f"frame {s.frame}: {s.new_kernel_hashes} new kernels"
        assert s.kernels_compiled == 0
    assert "strip" in set(np.unique(echoes.labels))
    # moving the radar is a parameter update too
    engine.echoes(anim, RADAR, 3, radar_pose=([0.2, -0.1, 0.1], [0.1, 0.0, 0.0]))
    assert engine.last_stats.new_kernel_hashes == 0 and not engine.last_stats.reloaded


def test_new_radar_reloads_scene(tmp_path):
    root = write_plate_animation(tmp_path / "p", num_frames=2)
    anim = load_animation(root)
    engine = PathEngine(physical_optics=False, samples_per_src=1000)
    engine.echoes(anim, RADAR, 0)
    other = RadarConfig.preset("ti-iwr1443boost")  # 2 Tx
    echoes = engine.echoes(anim, other, 1)
    assert echoes.shape == (2, 4, 1) and engine.last_stats.reloaded


# ------------------------------------------------------------------------------- vertex-velocity Doppler
def test_rigid_vertex_velocity_field_matches_sionna(tmp_path):
    """Per-vertex velocity = object velocity: the interpolated Doppler equals Sionna's per-object Doppler,
    for single- and double-bounce (plate-floor) diffuse paths."""
    velocity = np.array([0.7, 0.3, 0.2])
    floor_v, floor_f = plate_mesh((0, 0, -1.0), size=(8, 8), normal_axis=2, subdiv=2)
    mats = dict(ROUGH, **{"mat-plate-material": ("radio-material", {"relative_permittivity": 3.0,
                                                                    "conductivity": 1.0,
                                                                    "scattering_coefficient": 0.7})})
    common = dict(distance=3.0, velocity=velocity, num_frames=2, subdiv=3, materials=mats,
                  material="mat-plate-material", static=[("floor", floor_v, floor_f, "mat-rough")])
    rigid = load_animation(write_plate_animation(tmp_path / "rigid", **common))
    field = load_animation(write_plate_animation(tmp_path / "field", **common,
                                                 vertex_velocity_fn=lambda t, v: np.tile(velocity, (len(v), 1))))
    assert field.vertex_velocities(1, "plate") is not None
    # deterministic candidate generation: both runs trace the very same paths in the same order
    e_rigid = PathEngine(physical_optics=False, samples_per_src=5000, label="moving", deterministic=True).echoes(rigid, RADAR, 1)
    e_field = PathEngine(physical_optics=False, samples_per_src=5000, label="moving", deterministic=True).echoes(field, RADAR, 1)
    assert e_rigid.shape == e_field.shape
    np.testing.assert_array_equal(e_rigid.tau, e_field.tau)
    np.testing.assert_array_equal(e_rigid.a, e_field.a)
    np.testing.assert_allclose(e_field.doppler, e_rigid.doppler, rtol=0, atol=1e-2)
    on_plate = np.count_nonzero(np.abs(e_rigid.doppler) > 1.0)
    assert on_plate > 50  # many paths see the plate (single and double bounce)
    labels = set(np.unique(e_field.labels[e_field.a != 0]))
    assert labels == {"plate", "floor"}
    # with label="moving", every path with Doppler touches the plate
    moving = (e_field.a != 0) & (np.abs(e_field.doppler) > 1.0)
    assert np.all(e_field.labels[moving] == "plate")


def test_rotating_plate_matches_closed_form(tmp_path):
    r"""A thin strip (1 m x 5 cm, diffuse) at x = R, y in [0.5, 1.5] m, rotating about the vertical axis
    through (R, 0): a point (R, y, z) moves with v = (-omega y, 0, 0) towards the radar, so
    f = -2 v_r / lambda = 2 omega R y / (lambda r) with r = c tau / 2 and y^2 = r^2 - R^2 - z^2, |z| <= h/2."""
    R, omega, h = 3.0, 2.0, 0.05
    radar = RADAR.replace(tx_positions=[[0, 0, 0]], rx_positions=[[0, 0, 0]], tx_order=[0], antenna_pattern="iso")
    axis_point = np.array([R, 0.0, 0.0])
    mats = {"mat-diffuse": ("radio-material", {"relative_permittivity": 3.0, "conductivity": 0.1,
                                             "scattering_coefficient": 1.0})}
    root = write_moving_mesh_animation(
        tmp_path / "rot", lambda t: plate_mesh((R, 1.0, 0.0), size=(1.0, h), subdiv=8), (0, 0, 0), num_frames=1,
        vertex_velocity_fn=lambda t, v: np.cross([0.0, 0.0, omega], v - axis_point), manifest_velocity=False,
        materials=mats, material="mat-diffuse", name="strip")
    anim = load_animation(root)
    echoes = PathEngine(physical_optics=False, samples_per_src=100_000).echoes(anim, radar, 0)
    sel = echoes.a[0, 0] != 0
    tau, f = echoes.tau[0, 0][sel], echoes.doppler[0, 0][sel]
    assert len(f) >= 10
    r = SPEED_OF_LIGHT * tau / 2
    f_max = 2 * omega * R * np.sqrt(r ** 2 - R ** 2) / (LAMBDA * r)                       # z = 0
    f_min = 2 * omega * R * np.sqrt(np.maximum(r ** 2 - R ** 2 - h ** 2 / 4, 0)) / (LAMBDA * r)  # |z| = h/2
    assert np.all(f > 0), "the strip swings towards the radar: positive Doppler"
    assert np.all((f >= f_min - 0.05) & (f <= f_max + 0.05))
    assert f.max() - f.min() > 500  # the strip spans a wide Doppler range (~400-1400 Hz)


# ------------------------------------------------------------------------------- materials
def test_skin_permittivity_from_gabriel_model():
    # Gabriel (1996) dry skin at 60 GHz: the widely quoted 7.98 - j10.9
    eps, sigma = skin_properties(60e9)
    w_eps0 = 2 * np.pi * 60e9 * 8.8541878128e-12
    assert eps == pytest.approx(7.98, abs=0.01)
    assert sigma / w_eps0 == pytest.approx(10.9, abs=0.02)
    eps, sigma = skin_properties(77e9)
    assert eps == pytest.approx(6.57, abs=0.01) and sigma == pytest.approx(38.2, abs=0.1)
    wet = skin_properties(77e9, "wet")
    assert wet[0] == pytest.approx(8.54, abs=0.01) and wet[1] == pytest.approx(43.0, abs=0.1)
    with pytest.raises(MaterialFrequencyError, match="skin.*10 Hz - 100 GHz"):
        skin_properties(140e9)


@pytest.mark.parametrize("material", [("skin-radio-material", {}), ("radio-material", {})])
def test_skin_plate_reflects_fresnel_fraction_of_metal(tmp_path, material):
    """Normal incidence on a skin half-space: |a_skin| / |a_metal| = |(1 - n) / (1 + n)|, n^2 = eps_c."""
    metal = load_animation(write_plate_animation(tmp_path / "metal", num_frames=1, size=(2.0, 2.0)))
    skin = load_animation(write_plate_animation(tmp_path / "skin", num_frames=1, size=(2.0, 2.0),
                                                materials={"mat-skin": material}, material="mat-skin"))
    e_metal = PathEngine(physical_optics=False, samples_per_src=2000).echoes(metal, RADAR, 0)
    engine = PathEngine(physical_optics=False, samples_per_src=2000)
    e_skin = engine.echoes(skin, RADAR, 0)
    mat = engine.scene.get("skin")
    assert float(mat.relative_permittivity[0]) == pytest.approx(6.567, abs=1e-3)
    assert float(mat.conductivity[0]) == pytest.approx(38.2, abs=0.05)
    n = np.sqrt(SKIN_DRY.permittivity(RADAR.fc))
    gamma = abs((1 - n) / (1 + n))
    ratio = np.abs(e_skin.a[..., 0]) / np.abs(e_metal.a[..., 0])
    np.testing.assert_allclose(ratio, gamma, rtol=5e-3)
    assert gamma == pytest.approx(0.5835, abs=1e-3)  # -4.7 dB in power


def test_itu_material_outside_its_band_is_refused(tmp_path):
    assert itu_valid_ranges("brick") == [(1e9, 40e9), (110e9, 330e9)]
    check_itu_frequency("concrete", 77e9)
    with pytest.raises(MaterialFrequencyError, match=r"'marble' is not defined at 77 GHz .*1-60 GHz"):
        check_itu_frequency("marble", 77e9, where="wall")
    wall_v, wall_f = plate_mesh((8.0, 0.0, 0.0), size=(6, 3), normal_axis=0)
    mats = dict(METAL, **{"mat-itu_brick": ("itu-radio-material", {"type": "brick"})})
    anim = load_animation(write_plate_animation(tmp_path / "brick", num_frames=1, materials=mats,
                                                static=[("wall", wall_v, wall_f, "mat-itu_brick")]))
    with pytest.raises(MaterialFrequencyError, match=r"mesh-wall.*'brick' is not defined at 77 GHz.*1-40 GHz"):
        PathEngine(physical_optics=False, samples_per_src=1000).echoes(anim, RADAR, 0)
    # the same scene is fine for a 24 GHz radar
    radar24 = RADAR.replace(fc=24e9)
    echoes = PathEngine(physical_optics=False, samples_per_src=1000).echoes(anim, radar24, 0)
    assert echoes.num_contributions >= 1


def test_millimetre_wave_itu_material_loads_at_the_carrier(tmp_path):
    """``floorboard`` exists only at 50-100 GHz: Sionna must evaluate it at 77 GHz while loading."""
    mats = {"mat-floor": ("itu-radio-material", {"type": "floorboard"})}
    anim = load_animation(write_plate_animation(tmp_path / "floorboard", num_frames=1, size=(2.0, 2.0),
                                                materials=mats, material="mat-floor"))
    engine = PathEngine(physical_optics=False, samples_per_src=2000)
    echoes = engine.echoes(anim, RADAR, 0)
    eps = float(engine.scene.get("floor").relative_permittivity[0])
    assert eps == pytest.approx(3.66, abs=0.01)  # ITU-R P.2040 floorboard, a = 3.66, b = 0
    # normal incidence on the half-space: |a| / |a_metal| = |(1 - n) / (1 + n)| within the conductivity term
    metal = PathEngine(physical_optics=False, samples_per_src=2000).echoes(load_animation(
        write_plate_animation(tmp_path / "metal", num_frames=1, size=(2.0, 2.0))), RADAR, 0)
    import sionna.rt.scene as sionna_scene
    assert sionna_scene.DEFAULT_FREQUENCY == 3.5e9  # restored after loading
    n = np.sqrt(eps - 1j * float(engine.scene.get("floor").conductivity[0]) / (2 * np.pi * RADAR.fc * 8.854187817e-12))
    ratio = np.abs(echoes.a[..., 0]) / np.abs(metal.a[..., 0])
    np.testing.assert_allclose(ratio, abs((1 - n) / (1 + n)), rtol=5e-3)


def test_frames_must_keep_shapes_and_topology(tmp_path):
    floor_v, floor_f = plate_mesh((0, 0, -1.0), size=(4, 4), normal_axis=2)
    root = write_plate_animation(tmp_path / "p", num_frames=2, static=[("floor", floor_v, floor_f, "mat-itu_metal")])
    xml = root / "frames" / "0001.xml"
    text = xml.read_text()
    start = text.index('    <shape type="ply" id="mesh-floor">')
    end = text.index("</shape>", start) + len("</shape>\n")
    xml.write_text(text[:start] + text[end:])
    anim = load_animation(root)
    engine = PathEngine(physical_optics=False, samples_per_src=1000)
    engine.echoes(anim, RADAR, 0)
    with pytest.raises(SceneGeometryError, match=r"0001\.xml: frame 1 has a different set of shapes .*missing: \['floor'\]"):
        engine.echoes(anim, RADAR, 1)

    def growing(t):
        return plate_mesh((5.0, 0, 0), subdiv=1 if t == 0 else 2)

    anim = load_animation(write_moving_mesh_animation(tmp_path / "g", growing, (0, 0, 0), num_frames=2))
    engine = PathEngine(physical_optics=False, samples_per_src=1000)
    engine.echoes(anim, RADAR, 0)
    with pytest.raises(SceneGeometryError, match=r"plate_0001\.ply: mesh 'plate' has 9 vertices in frame 1 but 4"):
        engine.echoes(anim, RADAR, 1)


def test_full_path_buffer_is_an_error_not_a_silent_loss(tmp_path):
    """A rough plate filling the field of view: every ray makes a diffuse candidate, so 2000 rays per
    source cannot fit a 500-path buffer; Sionna would drop the rest silently."""
    anim = load_animation(write_plate_animation(tmp_path / "rough", num_frames=1, size=(8.0, 8.0), distance=2.0,
                                                materials=ROUGH, material="mat-rough"))
    with pytest.raises(PathEngineError, match=r"filled Sionna's path buffer .*raise max_num_paths_per_src"):
        PathEngine(physical_optics=False, max_depth=1, specular=False, samples_per_src=2000, max_num_paths_per_src=500).echoes(anim, RADAR, 0)
    echoes = PathEngine(physical_optics=False, max_depth=1, specular=False, samples_per_src=2000, max_num_paths_per_src=20_000).echoes(
        anim, RADAR, 0)
    assert echoes.num_contributions > 500


# ------------------------------------------------------------------------------- one trace for the array
def test_corner_reflectors_triple_bounce_per_element_closed_form(tmp_path):
    """Three 0.1 m metal trihedrals at 3, 5 and 7 m facing the radar, traced once from the Tx centre to
    the Rx centre (22 mm apart, so the retro-reflected path is not degenerate): one triple-bounce path per
    reflector after removing coplanar copies, and for every element pair the delay of the point reflection
    through the corner c, tau_mn = |2c - t_m - r_n| / c, within the Fermat error of fixed reflection points
    (|delta_t + delta_r|^2 / 4R <= 1e-5 m = 3e-14 s at 3 m)."""
    from sionnafmcw.scenes import registry
    from sionnafmcw.sionna_rt import InteractionType

    ranges, azimuths, height = (3.0, 5.0, 7.0), (-0.3, 0.0, 0.35), 1.0
    anim = load_animation(registry.build("corner_reflectors", tmp_path / "corners", ranges=ranges, azimuths=azimuths,
                                         height=height, num_frames=1))
    engine = PathEngine(physical_optics=False, samples_per_src=1_000_000, max_depth=3)
    echoes = engine.echoes(anim, RADAR, 0)
    paths = engine.last_paths
    triple = (paths.num_interactions == 3) & np.all(paths.types == int(InteractionType.SPECULAR), axis=1)
    ids = {int(engine.scene.objects[f"reflector_{k}"].object_id): k for k in range(3)}
    found = sorted(ids[int(s)] for s in paths.shapes[triple, 0])
    assert found == [0, 1, 2], "one triple-bounce path per reflector"
    for p in np.flatnonzero(triple):
        k = ids[int(paths.shapes[p, 0])]
        corner = np.array([ranges[k] * np.cos(azimuths[k]), ranges[k] * np.sin(azimuths[k]), height])
        origin = np.array([0.0, 0.0, height])
        tx, rx = RADAR.tx_positions + origin, RADAR.rx_positions + origin
        tau = np.linalg.norm(2 * corner - tx[:, None] - rx[None], axis=-1) / SPEED_OF_LIGHT
        np.testing.assert_allclose(echoes.tau[..., p], tau, rtol=0, atol=1e-13)


def test_coherent_and_per_element_diffuse_power_agree(tmp_path):
    """A rough plate 1 m out: the coherent model's per-pair diffuse power sum |a|^2 equals per-element
    tracing's (each element's own rays, Sionna's own spreading) within 0.05 dB (measured: 0.002 dB), so the
    ray-tube and fixed-scatterer scaling of the first and last segments keeps Sionna's power."""
    anim = load_animation(write_plate_animation(tmp_path / "rough", distance=1.0, num_frames=1, size=(0.6, 0.6),
                                                subdiv=3, materials=ROUGH, material="mat-rough"))
    power = {}
    for model in ("coherent", "per-element"):
        echoes = PathEngine(physical_optics=False, samples_per_src=200_000, specular=False, array_model=model).echoes(anim, RADAR, 0)
        power[model] = 10 * np.log10(np.sum(np.abs(echoes.a) ** 2, axis=2))
    assert np.all(np.isfinite(power["coherent"]))
    np.testing.assert_allclose(power["coherent"], power["per-element"], rtol=0, atol=0.05)
