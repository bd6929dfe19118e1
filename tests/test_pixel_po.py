"""The pixel engine's physical-optics mode and random-phase diffuse scatterers, through the engine on real scenes.

Closed forms: a square plate of side a facing the radar at range R has the near-field
PO RCS of the Fresnel integral (``po_quadrature.square_plate_rcs_fresnel``), tending to
4 pi a^4 / lambda^2 in the far field; a sphere pi r^2; a rough plate splits its reflected power
into (1 - S^2) through PO and S^2 through the Lambertian scatterers (4 A |Gamma|^2 facing the
radar). Tolerances: 1 dB for PO against the closed forms, 0.5 dB for the diffuse map
power, the Monte-Carlo scatter of a few speckle realisations stated where used.

Received power: the PO contributions are summed coherently (the channel h = sum a e^{-j 2 pi f tau},
what the beat synthesizer does), sigma = (4 pi)^3 R^4 |h|^2 / lambda^2 for an isotropic point radar;
the diffuse share as sum |a|^2 (its expectation over the random phases).
"""

from __future__ import annotations

import numpy as np
import pytest

import po_quadrature as quad
from animation_helpers import write_moving_mesh_animation
from sionnafmcw.animation import load_animation
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.echoes import Echoes
from sionnafmcw.engines import PixelEngine, PixelEngineError
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.physical_optics import channel
from sionnafmcw.processing.rdmap import range_doppler_map
from sionnafmcw.radar import RadarConfig
from sionnafmcw.scenes import meshes, registry
from sionnafmcw.synthesis import synthesize

RADAR = RadarConfig.preset("walk-77ghz")
LAMBDA = SPEED_OF_LIGHT / RADAR.fc
#: one isotropic element at the origin (the radar equation without element patterns)
POINT_RADAR = RADAR.replace(tx_positions=[[0, 0, 0]], rx_positions=[[0, 0, 0]], tx_order=[0], antenna_pattern="iso")


def db(x):
    return 10 * np.log10(x)


def narrow_engine(half_angle, n=16, **kw):
    """A pixel engine whose whole-FoV (diffuse) grid just covers +-half_angle around boresight."""
    return PixelEngine(n_az=n, n_el=n, fov_az=2 * half_angle, fov_el=2 * half_angle, track_kernels=False, **kw)


def split(echoes, engine):
    """(diffuse pixels, PO contributions) of the engine's echoes: the PO contributions follow the pixels."""
    num_po = engine.last_stats.num_po_contributions
    n = echoes.num_contributions
    mask = np.arange(n) >= n - num_po
    return echoes.select(~mask), echoes.select(mask)


def po_rcs(echoes, distance, radar=POINT_RADAR):
    """Monostatic RCS (m^2) from the coherent channel of the first element pair."""
    h = channel(echoes.a[0, 0], echoes.tau[0, 0], radar.fc)
    return (4 * np.pi) ** 3 * distance ** 4 * np.abs(h) ** 2 / LAMBDA ** 2


def plate_scene(tmp_path, side, distance, s=0.0):
    root = registry.build("moving_plate", tmp_path / f"plate_{side}_{distance}_{s}", start_range=distance, speed=0.0,
                          size=side, num_frames=1, room=False, scattering_coefficient=s)
    return load_animation(root)


RCS_TABLE = []


@pytest.mark.parametrize("side", [0.1, 0.2])
@pytest.mark.parametrize("distance", [2.0, 5.0, 10.0, 20.0])
def test_plate_rcs_matches_near_field_po(tmp_path, side, distance):
    """Metal (S = 0) plate of moving_plate facing the radar: engine PO = Fresnel PO within 1 dB, and
    the far-field 4 pi A^2 / lambda^2 beyond 2 D^2 / lambda (nearer, the Fresnel PO is below it)."""
    anim = plate_scene(tmp_path, side, distance)
    engine = narrow_engine(1.5 * np.arctan(side / distance))
    echoes = engine.echoes(anim, POINT_RADAR, 0)
    _, po = split(echoes, engine)
    assert engine.last_stats.num_po_samples >= (16 / np.sqrt(2)) ** 2   # po_samples_across over the diagonal
    assert np.all(po.labels == "plate")
    sigma = po_rcs(po, distance)
    fresnel = quad.square_plate_rcs_fresnel(side, distance, LAMBDA)
    far = 4 * np.pi * side ** 4 / LAMBDA ** 2
    RCS_TABLE.append((side, distance, db(sigma), db(fresnel), db(sigma / fresnel)))
    print(f"plate {side} m at {distance} m: engine {db(sigma):.2f} dBsm, PO {db(fresnel):.2f} dBsm, "
          f"difference {db(sigma / fresnel):+.3f} dB (far field {db(far):.2f} dBsm)")
    assert abs(db(sigma / fresnel)) < 1.0
    if distance >= 2 * 2 * side ** 2 / LAMBDA:
        assert abs(db(sigma / far)) < 1.0
    else:
        assert fresnel < far
    # the Lambertian model (the paper's eq. (2)) sees nothing of a smooth metal plate
    with pytest.warns(UserWarning, match="scattering_coefficient 0"):
        dark = narrow_engine(1.5 * np.arctan(side / distance), model="lambertian").echoes(anim, POINT_RADAR, 0)
    assert dark.num_contributions == 0


def tilted_plate_animation(tmp_path, subdiv, orientation, distance=5.0, side=0.1):
    rot = rotation_matrix(orientation)
    v, f = meshes.plate((0, 0, 0), (side, side), normal=(-1, 0, 0), subdiv=subdiv)
    v = v @ rot.T + [distance, 0.0, 0.0]
    root = write_moving_mesh_animation(tmp_path / f"tilt_{subdiv}_{'_'.join(map(str, orientation))}",
                                       lambda t: (v, f), (0, 0, 0), num_frames=1)
    return load_animation(root), v, f


@pytest.mark.parametrize("orientation", [(0.0, 0.0, 0.35), (0.004, 0.003, 1.1), (0.01, 0.0, 0.0)])
def test_plate_split_in_2_or_128_triangles_same_echo(tmp_path, orientation):
    """A 0.1 m metal plate at 5 m turned about its normal (and slightly off it), 2 vs 128 triangles:
    the same PO echo (0.1 dB, float32 hits), and both equal the independent quadrature within 1 dB."""
    sigmas = []
    for subdiv in (1, 8):
        anim, v, f = tilted_plate_animation(tmp_path, subdiv, orientation)
        assert len(f) == 2 * subdiv ** 2
        engine = narrow_engine(0.03)
        _, po = split(engine.echoes(anim, POINT_RADAR, 0), engine)
        sigmas.append(po_rcs(po, 5.0))
        reference = quad.monostatic_rcs(v, f, np.zeros(3), (5.0, 0, 0), LAMBDA, two_sided=True)
        print(f"orientation {orientation}, {len(f)} triangles: engine {db(sigmas[-1]):.3f} dBsm, "
              f"quadrature {db(reference):.3f} dBsm")
        assert abs(db(sigmas[-1] / reference)) < 1.0
    print(f"2 vs 128 triangles: {db(sigmas[1] / sigmas[0]):+.4f} dB")
    assert abs(db(sigmas[1] / sigmas[0])) < 0.1


@pytest.mark.parametrize("distance", [2.0, 10.0, 20.0])
def test_sphere_is_pi_r_squared(tmp_path, distance):
    """A faceted metal sphere (r = 0.1 m, 4.9 mm edges, facet normals as the frame XML asks): the
    independent quadrature of the same facets and pi r^2 within 1 dB (samples of a sixth of the
    edge keep to their facets: measured within 0.05 dB of the quadrature at 2-20 m)."""
    radius = 0.1
    v, f = meshes.ellipsoid((distance, 0, 0), (radius,) * 3, n_rings=64, n_segments=128)
    root = write_moving_mesh_animation(tmp_path / f"sphere_{distance}", lambda t: (v, f), (0, 0, 0), num_frames=1,
                                       name="sphere")
    engine = narrow_engine(1.5 * np.arctan(radius / distance))
    _, po = split(engine.echoes(load_animation(root), POINT_RADAR, 0), engine)
    sigma = po_rcs(po, distance)
    reference = quad.monostatic_rcs(v, f, np.zeros(3), (distance, 0, 0), LAMBDA)
    print(f"sphere at {distance} m: engine {db(sigma):.2f} dBsm, quadrature {db(reference):.2f} dBsm, "
          f"pi r^2 {db(np.pi * radius ** 2):.2f} dBsm, {engine.last_stats.num_po_rays} rays")
    assert abs(db(sigma / reference)) < 1.0
    assert abs(db(sigma / (np.pi * radius ** 2))) < 1.0


@pytest.mark.parametrize("s", [0.0, 0.5, 1.0])
def test_energy_split_po_plus_diffuse_equals_closed_forms(tmp_path, s):
    """A 0.1 m rough metal plate facing the radar at 20 m (far field): PO carries (1 - S^2) of
    4 pi A^2 |Gamma|^2 / lambda^2, the random-phase Lambertian pixels S^2 of 4 A |Gamma|^2; nothing
    is counted twice (the PO share vanishes at S = 1, the diffuse one at S = 0)."""
    distance, side = 20.0, 0.1
    anim = plate_scene(tmp_path, side, distance, s)
    engine = narrow_engine(1.3 * np.arctan(side / (2 * distance)), n=64)   # 0.1 mrad pixels, 50 across
    diffuse, po = split(engine.echoes(anim, POINT_RADAR, 0), engine)
    gamma2 = np.abs(engine.last_po_samples.reflection[0]) ** 2 if po.num_contributions else 1.0
    sigma_po = po_rcs(po, distance) if po.num_contributions else 0.0
    sigma_diffuse = (4 * np.pi) ** 3 * distance ** 4 * np.sum(np.abs(diffuse.a[0, 0]) ** 2) / LAMBDA ** 2
    po_closed = (1 - s ** 2) * 4 * np.pi * side ** 4 / LAMBDA ** 2
    diffuse_closed = s ** 2 * 4 * side ** 2
    print(f"S = {s}: PO {sigma_po:.4g} m^2 (closed {po_closed:.4g}), diffuse {sigma_diffuse:.4g} m^2 "
          f"(closed {diffuse_closed:.4g}), |Gamma|^2 = {gamma2:.5f}")
    if s < 1:
        assert abs(db(sigma_po / (po_closed * gamma2))) < 1.0
    else:
        assert po.num_contributions == 0 and engine.last_stats.num_po_rays == 0
    if s > 0:
        assert abs(db(sigma_diffuse / diffuse_closed)) < 0.5
    else:
        assert diffuse.num_contributions == 0


# ------------------------------------------------------------------------------- random-phase diffuse
def spinning_plate_animation(tmp_path, num_frames=4, distance=4.0, omega=8.0, bulk=1.0):
    """A 1 m rough (S = 1) plate at ``distance``, tilted 60 deg, spinning about its normal while receding.

    At 10 fps it turns 0.8 rad between frames, so each frame's pixels fall in other surface cells:
    the frames are independent speckle realisations (as tests/test_diffuse.py's relabelled plates)."""
    rot = rotation_matrix((np.deg2rad(60.0), 0.0, 0.0))
    normal = rot @ [-1.0, 0.0, 0.0]
    v0, f = meshes.plate((0, 0, 0), (1.0, 1.0), normal=normal, subdiv=4)

    def centre(t):
        return np.array([distance + bulk * t, 0.0, 0.0])

    def spin(t):
        a = omega * t
        k = np.array([[0, -normal[2], normal[1]], [normal[2], 0, -normal[0]], [-normal[1], normal[0], 0]])
        return np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * k @ k      # Rodrigues, about the normal

    materials = {"mat-rough": ("radio-material", {"relative_permittivity": 5.0, "conductivity": 0.1,
                                                  "scattering_coefficient": 1.0})}
    root = write_moving_mesh_animation(
        tmp_path / "spinning", lambda t: (v0 @ spin(t).T + centre(t), f), (bulk, 0.0, 0.0), num_frames=num_frames,
        fps=10.0, vertex_velocity_fn=lambda t, v: bulk * np.array([1.0, 0, 0]) + omega * np.cross(normal,
                                                                                                 v - centre(t)),
        manifest_velocity=False, materials=materials, material="mat-rough")
    return load_animation(root)


def map_power(echoes, radar=RADAR):
    cube = synthesize(echoes, radar, noise=False)
    return range_doppler_map(cube, radar, clutter_removal=True).power.sum()


def unit_map_power(echoes, radar=RADAR):
    """Map power of one contribution of |a| = 1 per channel at the echoes' mean delay and Doppler, per channel."""
    shape = (radar.num_tx, radar.num_rx, 1)
    one = Echoes(np.ones(shape, complex), np.full(shape, echoes.tau.mean()), np.full(shape, echoes.doppler.mean()))
    return map_power(one, radar) / (radar.num_tx * radar.num_rx)


def test_diffuse_map_power_equals_incoherent_sum_whatever_the_pixel_count(tmp_path):
    """The spinning rough plate, 4 frames (realisations), 64^2 vs 128^2 pixels over the same FoV (4x):
    the mean clutter-removed map power equals sum |a|^2 times a unit contribution's map power within
    0.5 dB, and 4x pixels moves it by < 0.5 dB (one map scatters by ~0.35 dB, tests/test_diffuse.py).
    Measured: -0.30 / -0.09 dB at 64^2 / 128^2 pixels, +0.21 dB for 4x. The deterministic phases of
    the paper's eq. (2) give +0.17 / +0.74 dB here (+0.57 dB for 4x: the spin and tilt spread the
    pixels over many range-Doppler cells); on a plate facing the radar they grow by 6 dB per 4x
    (:func:`test_deterministic_phases_grow_with_the_pixel_count`)."""
    anim = spinning_plate_animation(tmp_path)
    ratios, counts, growth = {}, {}, {}
    for phase in ("random",):
        for n in (64, 128):
            engine = PixelEngine(n_az=n, n_el=n, fov_az=np.deg2rad(24.0), fov_el=np.deg2rad(24.0),
                                 diffuse_phase=phase, track_kernels=False)
            measured = expected = 0.0
            count = 0
            for frame in range(anim.num_frames):
                echoes = engine.echoes(anim, RADAR, frame)
                assert engine.last_stats.num_po_samples == 0           # S = 1: no coherent share
                expected += unit_map_power(echoes) * np.sum(np.abs(echoes.a) ** 2)
                measured += map_power(echoes)
                count += echoes.num_contributions
            ratios[phase, n], counts[phase, n] = measured / expected, count
        growth[phase] = db(ratios[phase, 128] / ratios[phase, 64])
    print({k: round(db(v), 3) for k, v in ratios.items()}, {k: round(v, 2) for k, v in growth.items()})
    assert counts["random", 128] == pytest.approx(4 * counts["random", 64], rel=0.05)
    assert abs(db(ratios["random", 64])) < 0.5 and abs(db(ratios["random", 128])) < 0.5
    assert abs(growth["random"]) < 0.5


def test_deterministic_phases_grow_with_the_pixel_count(tmp_path):
    """Contrast (the paper's Lambertian eq. (2)): a 0.5 m rough plate facing the radar at 4 m, receding at
    1 m/s; without their own phases (``diffuse_phase="deterministic"``) the pixels add coherently and
    the map power over sum |a|^2 grows with the pixel count N as N (6 dB per 4x) where all add in
    phase; the plate's range curvature (2 lambda across it) leaves some phase structure. Measured
    +7.4 dB for 4x pixels; asserted > 4.5 dB (random phases: < 0.5 dB, the test above)."""
    materials = {"mat-rough": ("radio-material", {"relative_permittivity": 5.0, "conductivity": 0.1,
                                                  "scattering_coefficient": 1.0})}
    v, f = meshes.plate((4.0, 0, 0), (0.5, 0.5), normal=(-1, 0, 0))
    root = write_moving_mesh_animation(tmp_path / "facing", lambda t: (v + [t, 0, 0], f), (1.0, 0, 0), num_frames=1,
                                       materials=materials, material="mat-rough")
    anim = load_animation(root)
    growth = []
    for n in (32, 64):
        engine = PixelEngine(n_az=n, n_el=n, fov_az=0.14, fov_el=0.14, diffuse_phase="deterministic",
                             track_kernels=False)
        echoes = engine.echoes(anim, RADAR, 0)
        growth.append(map_power(echoes) / np.sum(np.abs(echoes.a) ** 2))
    print(f"deterministic phases, 4x pixels: {db(growth[1] / growth[0]):+.2f} dB")
    assert db(growth[1] / growth[0]) > 4.5


def test_diffuse_phase_is_one_scatterer_for_the_array_and_fixed_to_the_surface(tmp_path):
    """Every element pair sees the same phase of a pixel's scatterer (plane-wave delays aside), and a
    static surface keeps its phases from frame to frame (static clutter removal removes it)."""
    v, f = meshes.plate((4.0, 0, 0), (1.0, 1.0), normal=(-1, 0, 0), subdiv=2)
    materials = {"mat-rough": ("radio-material", {"relative_permittivity": 5.0, "conductivity": 0.1,
                                                  "scattering_coefficient": 1.0})}
    root = write_moving_mesh_animation(tmp_path / "static", lambda t: (v, f), (0, 0, 0), num_frames=2,
                                       materials=materials, material="mat-rough", name="wall")
    anim = load_animation(root)
    engine = PixelEngine(n_az=24, n_el=24, fov_az=np.deg2rad(12.0), fov_el=np.deg2rad(12.0))
    e0 = engine.echoes(anim, RADAR, 0)
    e1 = engine.echoes(anim, RADAR, 1)
    phase = np.angle(e0.a)
    assert e0.num_contributions > 400
    np.testing.assert_allclose(np.exp(1j * (phase - phase[:1, :1])), 1.0, atol=1e-12)   # one phase per pixel
    # uniform over the pixels: the mean phasor of N ~ 1/sqrt(N) (5 sigma)
    assert abs(np.mean(np.exp(1j * phase[0, 0]))) < 5 / np.sqrt(e0.num_contributions)
    np.testing.assert_array_equal(e0.a, e1.a)
    deterministic = PixelEngine(n_az=24, n_el=24, fov_az=np.deg2rad(12.0), fov_el=np.deg2rad(12.0),
                                diffuse_phase="deterministic").echoes(anim, RADAR, 0)
    np.testing.assert_allclose(np.abs(deterministic.a), np.abs(e0.a), rtol=1e-12)
    assert np.all(np.imag(deterministic.a) == 0)


# ------------------------------------------------------------------------------- options and settings
def test_models_and_settings():
    engine = PixelEngine()
    settings = engine.settings()
    assert settings["model"] == "physical-optics" and settings["diffuse_phase"] == "random"
    assert settings["specular"] is True and settings["scattering"] == "physical-optics+diffuse"
    paper = PixelEngine(model="lambertian", diffuse_phase="deterministic").settings()
    assert paper["model"] == "lambertian" and paper["specular"] is False and paper["scattering"] == "diffuse"
    for options, name in (({"model": "po"}, "model"), ({"diffuse_phase": "speckle"}, "diffuse_phase"),
                          ({"diffuse_cell_size": 0.0}, "diffuse_cell_size"),
                          ({"po_samples_across": 0}, "po_samples_across"), ({"po_max_rays": 2.5}, "po_max_rays")):
        with pytest.raises(PixelEngineError, match=name):
            PixelEngine(**options)


def test_diffuse_phases_do_not_depend_on_the_first_frame_rendered(tmp_path):
    """A stretching rough plate (edge lengths change from frame to frame): an engine that starts at
    frame 2 (a data-set worker) gives frame 2 the same echoes, bit for bit, as one that rendered
    frames 0 and 1 before (the surface cells come from frame 0's PLY)."""
    materials = {"mat-rough": ("radio-material", {"relative_permittivity": 5.0, "conductivity": 0.1,
                                                  "scattering_coefficient": 0.7})}

    def mesh(t):
        v, f = meshes.plate((4.0, 0, 0), (0.6, 0.6), normal=(-1, 0, 0), subdiv=2)
        return (v - [4.0, 0, 0]) * [1.0, 1.0 + 2 * t, 1.0] + [4.0, 0, 0], f

    root = write_moving_mesh_animation(tmp_path / "stretch", mesh, (0, 0, 0), num_frames=3, materials=materials,
                                       material="mat-rough")
    anim = load_animation(root)
    first = PixelEngine(n_az=24, n_el=24, fov_az=np.deg2rad(16.0), fov_el=np.deg2rad(16.0), track_kernels=False)
    for frame in (0, 1):
        first.echoes(anim, RADAR, frame)
    e_first = first.echoes(anim, RADAR, 2)
    late = PixelEngine(n_az=24, n_el=24, fov_az=np.deg2rad(16.0), fov_el=np.deg2rad(16.0), track_kernels=False)
    e_late = late.echoes(anim, RADAR, 2)
    assert late.last_stats.num_po_samples > 0 and e_first.num_contributions > 100
    np.testing.assert_array_equal(e_first.a, e_late.a)
    np.testing.assert_array_equal(e_first.tau, e_late.tau)


def test_merged_po_contributions_give_the_same_radar_data(tmp_path):
    """A 0.2 m metal plate at 10 m, facing the radar or turned 0.7 rad (an integral that nearly cancels,
    far weaker), receding at 1 m/s, walk-77ghz: merging the PO samples the radar cannot tell apart (in
    the coarsest cells whose bound fits the budget and that save at least MIN_SAVING of them) leaves
    every pair's channel at the carrier unchanged (1e-9) and the synthesized cube within the merge's
    bound: its power within 0.1 dB, the difference 40 dB below it (measured: 144 -> 76 samples, 4e-4 dB,
    -86 dB facing; 108 -> 18, 0.025 dB, -50 dB turned). At 5 m the facing plate's fitting cells would save too little
    (MIN_SAVING) and it comes back unmerged."""
    for yaw in (0.0, 0.7):
        rot = rotation_matrix((yaw, 0.0, 0.0))
        v, f = meshes.plate((0, 0, 0), (0.2, 0.2), normal=(-1, 0, 0), subdiv=2)
        v = v @ rot.T + [10.0, 0, 0]
        root = write_moving_mesh_animation(tmp_path / f"turned_{yaw}", lambda t: (v + [t, 0, 0], f), (1.0, 0, 0),
                                           num_frames=1)
        anim = load_animation(root)
        cubes, counts, channels = [], [], []
        for merge in (False, True):
            engine = narrow_engine(0.04, po_merge=merge)
            _, po = split(engine.echoes(anim, RADAR, 0), engine)
            counts.append(po.num_contributions)
            channels.append(channel(po.a, po.tau, RADAR.fc))
            cubes.append(synthesize(po, RADAR, noise=False))
        power = db(np.sum(np.abs(cubes[1]) ** 2) / np.sum(np.abs(cubes[0]) ** 2))
        error = db(np.sum(np.abs(cubes[1] - cubes[0]) ** 2) / np.sum(np.abs(cubes[0]) ** 2))
        print(f"yaw {yaw}: PO contributions {counts[0]} -> {counts[1]}; cube power {power:+.4f} dB, "
              f"difference {error:.1f} dB")
        assert counts[1] < counts[0]
        np.testing.assert_allclose(channels[1], channels[0], rtol=1e-9)
        assert abs(power) < 0.1 and error < -40
