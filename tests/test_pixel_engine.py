"""Pixel engine (a render from the radar, every hit pixel a point target) on real Mitsuba scenes.

Tolerances: float32 ray casting (Mitsuba's llvm_ad_mono_polarized variant) for per-pixel
geometry, half a range/Doppler bin for the processed peak, the midpoint-rule error bound for
pixel quadratures, the second-order remainder of the near-field expansion, and Monte-Carlo
statistics of the path engine's rays for the power comparison.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.constants import epsilon_0

from animation_helpers import METAL, box_mesh, plate_mesh, write_moving_mesh_animation, write_plate_animation
import sionnafmcw
from sionnafmcw import processing, simulate
from sionnafmcw.animation import load_animation
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw import engines
from sionnafmcw.electromagnetics import slab_reflection_coefficients
from sionnafmcw.engines import EngineError, PathEngine, PixelEngine, PixelEngineError, PixelGrid
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.array import phase_centre as array_phase_centre
from sionnafmcw.radar import RadarConfig

RADAR = RadarConfig.preset("walk-77ghz")  # 3 Tx x 4 Rx (a 12-element lambda/2 virtual row), tr38901 elements
LAMBDA = SPEED_OF_LIGHT / RADAR.fc
#: one isotropic element at the origin: phase centre at the origin, no element offsets
POINT_RADAR = RADAR.replace(tx_positions=[[0, 0, 0]], rx_positions=[[0, 0, 0]], tx_order=[0], antenna_pattern="iso")
#: float32 unit roundoff: Mitsuba's rays, intersection distances and barycentrics are single precision
EPS32 = 2.0 ** -24


def rough(s=1.0, kx=0.0):
    return {"mat-rough": ("radio-material", {"relative_permittivity": 5.0, "conductivity": 0.1,
                                             "scattering_coefficient": s, "xpd_coefficient": kx})}


def small_engine(**kw):
    options = dict(n_az=24, n_el=24, fov_az=np.deg2rad(20.0), fov_el=np.deg2rad(20.0))
    options.update(kw)
    return PixelEngine(**options)


# ------------------------------------------------------------------------------- pixel grid and parameters
@pytest.mark.parametrize("n_az, n_el, fov_az, fov_el", [(128, 64, np.deg2rad(120), np.deg2rad(60)),
                                                        (7, 3, 0.3, 0.1), (1, 1, np.pi, np.pi),
                                                        (64, 32, np.pi, np.pi)])
def test_pixel_solid_angles_sum_to_the_field_of_view(n_az, n_el, fov_az, fov_el):
    grid = PixelGrid(n_az, n_el, fov_az, fov_el)
    omega = grid.solid_angles()
    assert omega.shape == (n_el, n_az) and np.all(omega > 0)
    # the solid angle of the FoV: integral of cos(el) d el d az over the rectangle
    np.testing.assert_allclose(omega.sum(), 2 * fov_az * np.sin(fov_el / 2), rtol=1e-12)
    if fov_az == np.pi and fov_el == np.pi:
        np.testing.assert_allclose(omega.sum(), 2 * np.pi, rtol=1e-12)  # the front hemisphere
    # pixel centres: symmetric about boresight, unit directions, pixels narrower near the poles
    u = grid.directions()
    np.testing.assert_allclose(np.linalg.norm(u, axis=-1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(grid.azimuths, -grid.azimuths[::-1], atol=1e-15)
    np.testing.assert_allclose(omega[:, 0], 2 * grid.d_az * np.cos(grid.elevations) * np.sin(grid.d_el / 2),
                               rtol=1e-12)


@pytest.mark.parametrize("options, name", [
    ({"n_az": 0}, "n_az"), ({"n_az": -3}, "n_az"), ({"n_el": 0}, "n_el"), ({"n_el": 2.5}, "n_el"),
    ({"n_az": True}, "n_az"),
    ({"fov_az": 0.0}, "fov_az"), ({"fov_az": -0.2}, "fov_az"), ({"fov_az": np.pi + 1e-9}, "fov_az"),
    ({"fov_el": 60.0}, "fov_el"), ({"fov_el": float("nan")}, "fov_el"),
    ({"array_model": "spherical"}, "array_model"), ({"scattering_coefficient": 1.5}, "scattering_coefficient"),
    ({"model": "mirror"}, "model"), ({"diffuse_phase": 1}, "diffuse_phase"),
])
def test_bad_parameters_name_the_parameter(options, name):
    with pytest.raises(PixelEngineError, match=name):
        PixelEngine(**options)
    with pytest.raises(PixelEngineError, match=name):
        engines.create("pixel", **options)


def test_registered_as_engine_pixel():
    assert "pixel" in engines.names()
    assert sionnafmcw.PixelEngine is PixelEngine
    engine = engines.create("pixel", n_az=8, n_el=4)
    assert isinstance(engine, PixelEngine) and engine.settings()["engine"] == "pixel"
    assert engine.settings()["n_az"] == 8 and engine.settings()["array_model"] == "plane-wave"
    with pytest.raises(EngineError, match="path, pixel"):
        engines.create("raster")


# ------------------------------------------------------------------------------- electromagnetics
@pytest.mark.parametrize("eta, thickness", [(5.0 - 0.0234j, 0.1), (1.0 - 2.3e6j, 0.1), (6.57 - 8.9j, 0.01)])
def test_slab_coefficients_match_sionna(eta, thickness):
    import mitsuba as mi
    from sionna.rt.utils import itu_coefficients_single_layer_slab

    cos_theta = np.linspace(0.05, 1.0, 40)
    r_te, r_tm, _, _ = itu_coefficients_single_layer_slab(
        mi.Float(cos_theta), mi.Complex2f(eta.real, eta.imag), mi.Float(thickness), mi.Float(LAMBDA))
    te, tm = slab_reflection_coefficients(cos_theta, eta, thickness, LAMBDA)
    # Sionna works in float32: its slab phase 2q (hundreds of radians for a 10 cm slab) carries an
    # absolute error of a few ulp; allow 16 ulp of |2q|
    two_q = np.abs(4 * np.pi * thickness / LAMBDA * np.sqrt(eta - (1 - cos_theta ** 2)))
    tol = 1e-6 + 16 * EPS32 * two_q
    assert np.all(np.abs(r_te.numpy() - te) <= tol)
    assert np.all(np.abs(r_tm.numpy() - tm) <= tol)


def test_spherical_basis_is_the_angles_basis():
    """theta_hat = [cos t cos p, cos t sin p, -sin t], phi_hat = [-sin p, cos p, 0] with t = arccos k_z and
    p = atan2(k_y, k_x), computed from the components without the angles: the same vectors to rounding,
    on the z axis too (p = 0, or pi for k_x = -0, as atan2 gives), for any leading shape."""
    from sionnafmcw.electromagnetics import spherical_basis

    rng = np.random.default_rng(5)
    k = rng.normal(size=(5000, 3))
    k /= np.linalg.norm(k, axis=-1, keepdims=True)
    k[:4] = [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [-0.0, 0.0, 1.0], [0.0, -0.0, -1.0]]
    t, p = np.arccos(np.clip(k[:, 2], -1, 1)), np.arctan2(k[:, 1], k[:, 0])
    theta_hat = np.stack([np.cos(t) * np.cos(p), np.cos(t) * np.sin(p), -np.sin(t)], axis=-1)
    phi_hat = np.stack([-np.sin(p), np.cos(p), np.zeros_like(p)], axis=-1)
    got_theta, got_phi = spherical_basis(k)
    assert np.max(np.abs(got_theta - theta_hat)) < 1e-12 and np.max(np.abs(got_phi - phi_hat)) < 1e-12
    # away from the poles (where sin t = sqrt(1 - k_z^2) loses digits) to rounding
    assert np.max(np.abs(got_theta - theta_hat)[np.abs(k[:, 2]) < 0.999]) < 1e-14
    for i in (0, 2, 3, 10):                                          # one vector at a time
        one = spherical_basis(k[i])
        np.testing.assert_allclose(one[0], got_theta[i], atol=1e-15)
        np.testing.assert_allclose(one[1], got_phi[i], atol=1e-15)
    np.testing.assert_allclose(spherical_basis(k.reshape(50, 100, 3))[0].reshape(-1, 3), got_theta, atol=0)


# ------------------------------------------------------------------------------- geometry, range and Doppler
def test_plate_ranges_and_doppler_per_pixel(tmp_path):
    """Plate (0.6 m, diffuse) at 4 m receding at 1.5 m/s: in frame 1 (plate moved to 4.15 m through the
    per-frame vertex update) every pixel that sees it has R = (x_plate - c_x)/u_x, f_D = -2 v.u/lambda,
    tau_mn = (2R - (t_m + r_n - 2c).u)/c, and the hit pixels are exactly those whose ray meets the plate."""
    speed, distance, size = 1.5, 4.0, 0.6
    root = write_plate_animation(tmp_path / "plate", distance=distance, velocity=(speed, 0, 0), num_frames=2,
                                 size=(size, size), materials=rough(), material="mat-rough")
    anim = load_animation(root)
    engine = small_engine(fov_az=np.deg2rad(12.0), fov_el=np.deg2rad(12.0))  # 0.5 deg pixels, the plate +-4 deg
    engine.echoes(anim, RADAR, 0)
    echoes = engine.echoes(anim, RADAR, 1)
    render = engine.last_render
    x_plate = distance + speed * anim.frame_period
    c = array_phase_centre(RADAR)
    u = engine.grid.directions().reshape(-1, 3)
    # which rays meet the square plate (analytic), away from float32 ties at the edges
    r_plane = (x_plate - c[0]) / u[:, 0]
    hit_point = c + r_plane[:, None] * u
    margin = np.maximum(np.abs(hit_point[:, 1]), np.abs(hit_point[:, 2])) - size / 2
    inside, outside = margin < -1e-5, margin > 1e-5
    assert inside.sum() > 200
    assert set(np.nonzero(inside)[0]) <= set(render.pixel) and not set(np.nonzero(outside)[0]) & set(render.pixel)
    assert echoes.shape == (3, 4, render.num_hits) and np.all(echoes.labels == "plate")

    # ranges: float32 intersection, a few ulp of the 4 m range
    np.testing.assert_allclose(render.range, r_plane[render.pixel], rtol=0, atol=8 * EPS32 * x_plate)
    np.testing.assert_allclose(render.position[:, 0], x_plate, atol=8 * EPS32 * x_plate)
    np.testing.assert_allclose(render.velocity, np.tile([speed, 0, 0], (render.num_hits, 1)))
    # the direction to the hit point is the pixel centre's, to float32 precision
    u_hit = (render.position - c) / render.range[:, None]
    np.testing.assert_allclose(u_hit, u[render.pixel], rtol=0, atol=8 * EPS32)
    # Doppler: receding -> negative, -2 v.u / lambda for every element pair (plane-wave model)
    f_d = -2 * speed * u[render.pixel, 0] / LAMBDA
    np.testing.assert_allclose(echoes.doppler, np.broadcast_to(f_d, echoes.shape), rtol=8 * EPS32)
    assert np.all(echoes.doppler < 0)
    np.testing.assert_allclose(render.radial_velocity, speed * u_hit[:, 0], rtol=1e-12)
    # delays: far-field model of eq. (2) around the phase centre
    tx_off = (RADAR.tx_positions - c) @ u_hit.T
    rx_off = (RADAR.rx_positions - c) @ u_hit.T
    tau = (2 * render.range[None, None] - tx_off[:, None] - rx_off[None, :]) / SPEED_OF_LIGHT
    np.testing.assert_allclose(echoes.tau, tau, rtol=0, atol=1e-18)
    # the render puts the pixels back on the grid
    image = render.image(render.range)
    assert image.shape == (24, 24) and np.isnan(image).sum() == 24 * 24 - render.num_hits


@pytest.mark.parametrize("speed", [1.5, -2.0])
def test_simulate_pixel_engine_range_doppler_peak(tmp_path, speed):
    """simulate(engine="pixel") + processing: the plate's range and radial velocity within half a bin."""
    radar = RADAR.replace(num_chirps=64)  # 9.8 cm range bins, 0.29 m/s Doppler bins
    root = write_plate_animation(tmp_path / "plate", distance=4.0, velocity=(speed, 0, 0), num_frames=2,
                                 fps=24.0, size=(0.5, 0.5))
    options = dict(n_az=32, n_el=16, fov_az=np.deg2rad(40.0), fov_el=np.deg2rad(20.0), scattering_coefficient=1.0)
    ds = simulate(root, radar, engine="pixel", engine_options=options, out=tmp_path / "run.zarr", progress=False)
    assert ds.attrs["engine"]["engine"] == "pixel" and ds.attrs["engine"]["n_az"] == 32
    track = processing.doppler_time(ds.iq.values, radar)
    truth_v = ds.truth_radial_velocity.values[:, 0]
    truth_r = ds["truth_position"].values[:, 0, 0]
    assert np.all(np.sign(track.velocities) == np.sign(speed))
    assert np.all(np.abs(track.velocities - truth_v) < radar.velocity_resolution / 2)
    assert np.all(np.abs(track.ranges - truth_r) < radar.range_resolution / 2)


def test_rotating_plate_vertex_velocity_doppler(tmp_path):
    r"""A strip in the plane x = R0 rotating about the vertical axis through (R0, 0, 0) (per-vertex
    velocities v = omega z x (p - a), no manifest velocity). On the plane v = (-omega y, 0, 0), so the
    pixel at (az, el) sees f_D = -2 v.u / lambda = 2 omega R0 cos(el) sin(az) / lambda."""
    r0, omega = 3.0, 2.0
    axis_point = np.array([r0, 0.0, 0.0])
    root = write_moving_mesh_animation(
        tmp_path / "rot", lambda t: plate_mesh((r0, 0.5, 0.0), size=(1.6, 0.4), subdiv=6), (0, 0, 0), num_frames=1,
        vertex_velocity_fn=lambda t, v: np.cross([0.0, 0.0, omega], v - axis_point), manifest_velocity=False,
        materials=rough(), material="mat-rough", name="strip")
    anim = load_animation(root)
    for model in PixelEngine.ARRAY_MODELS:
        engine = PixelEngine(n_az=48, n_el=12, fov_az=np.deg2rad(60.0), fov_el=np.deg2rad(15.0), array_model=model)
        echoes = engine.echoes(anim, POINT_RADAR, 0)
        render = engine.last_render
        assert render.num_hits > 100 and np.all(echoes.labels == "strip")
        f = 2 * omega * r0 * np.cos(render.elevation) * np.sin(render.azimuth) / LAMBDA
        # float32 hit point (barycentrics, ray direction): a few ulp of the 3.5 m coordinates
        atol = 2 * omega * 16 * EPS32 * 3.5 / LAMBDA
        np.testing.assert_allclose(echoes.doppler[0, 0], f, rtol=0, atol=atol)
        assert f.max() - f.min() > 1000  # the field, not one velocity: -800 .. +1900 Hz across the strip
        assert np.any(f < 0) and np.any(f > 0)


# ------------------------------------------------------------------------------- array models
def test_plane_wave_phase_is_the_papers_ula_phase(tmp_path):
    """walk-77ghz is a 12-element lambda_d/2 virtual row along y (index k = m N + n): the plane-wave delays
    give the carrier phase 2 pi f_c (tau_mn - tau_00) = -2 pi k (lambda_d/2) cos(el) sin(az) / lambda."""
    root = write_plate_animation(tmp_path / "p", distance=4.0, num_frames=1, size=(2.0, 2.0),
                                 materials=rough(), material="mat-rough")
    engine = small_engine(fov_az=np.deg2rad(40.0))
    echoes = engine.echoes(load_animation(root), RADAR, 0)
    render = engine.last_render
    spacing = RADAR.rx_positions[1, 1] - RADAR.rx_positions[0, 1]
    np.testing.assert_allclose(RADAR.tx_positions[1, 1] - RADAR.tx_positions[0, 1], RADAR.num_rx * spacing)
    k = np.arange(RADAR.num_tx)[:, None] * RADAR.num_rx + np.arange(RADAR.num_rx)[None, :]
    u_hit = (render.position - array_phase_centre(RADAR)) / render.range[:, None]
    sin_theta = u_hit[:, 1]  # cos(el) sin(az) of the point target
    np.testing.assert_allclose(sin_theta, np.cos(render.elevation) * np.sin(render.azimuth), atol=8 * EPS32)
    expected = -2 * np.pi * k[..., None] * spacing * sin_theta[None, None] / LAMBDA
    phase = 2 * np.pi * RADAR.fc * (echoes.tau - echoes.tau[:1, :1])
    np.testing.assert_allclose(phase, expected, rtol=0, atol=1e-6)
    assert np.ptp(sin_theta) > 0.4  # pixels across +-14 degrees (the 2 m plate at 4 m)


@pytest.mark.parametrize("distance, near", [(0.5, True), (30.0, False)])
def test_plane_wave_vs_exact(tmp_path, distance, near):
    r"""Exact minus plane-wave delay = sum over the two elements of (|d|^2 - (d.u)^2)/(2 R c) (second
    order, d the element offset from the phase centre), with a third-order remainder below
    (|d_t|^3 + |d_r|^3)/(R^2 c). Near (0.5 m): a clearly visible carrier phase (> 0.1 rad); far (30 m):
    the two models agree to a few hundredths of a radian."""
    size = 2 * (distance * np.tan(np.deg2rad(6.0)) + 0.03)  # covers the FoV seen from the phase centre (y = 1.9 cm)
    velocity = np.array([1.0, 0.3, 0.0])
    root = write_plate_animation(tmp_path / "p", distance=distance, velocity=velocity, num_frames=1, size=(size, size),
                                 materials=rough(), material="mat-rough")
    anim = load_animation(root)
    grid = dict(n_az=16, n_el=8, fov_az=np.deg2rad(10.0), fov_el=np.deg2rad(5.0))
    plane = PixelEngine(array_model="plane-wave", **grid)
    exact = PixelEngine(array_model="exact", **grid)
    e_pw = plane.echoes(anim, RADAR, 0)
    e_ex = exact.echoes(anim, RADAR, 0)
    assert e_pw.shape == e_ex.shape and e_pw.shape[2] == 16 * 8
    render = plane.last_render
    np.testing.assert_array_equal(render.pixel, exact.last_render.pixel)
    c = array_phase_centre(RADAR)
    r = render.range
    u = (render.position - c) / r[:, None]
    d_t = RADAR.tx_positions - c
    d_r = RADAR.rx_positions - c
    q_t = (d_t ** 2).sum(-1)[:, None] - (d_t @ u.T) ** 2          # [M, P]
    q_r = (d_r ** 2).sum(-1)[:, None] - (d_r @ u.T) ** 2          # [N, P]
    second = (q_t[:, None] + q_r[None]) / (2 * r * SPEED_OF_LIGHT)

    # |R u - d| = (R - a) + b^2 / (2 (R - a)) - ..., a = d.u, b^2 = |d|^2 - a^2: the remainder of the
    # second-order form is below |d|^3 / (2 R (R - |d|)) + |d|^4 / (8 (R - |d|)^3) per element
    def remainder(d):
        n = np.linalg.norm(d, axis=-1)[:, None]
        return n ** 3 / (2 * r * (r - n)) + n ** 4 / (8 * (r - n) ** 3)

    bound = (remainder(d_t)[:, None] + remainder(d_r)[None]) / SPEED_OF_LIGHT
    diff = e_ex.tau - e_pw.tau
    assert np.all(np.abs(diff - second) <= bound + 1e-20)
    phase = 2 * np.pi * RADAR.fc * diff
    if near:
        assert np.max(np.abs(phase)) > 0.1
    else:
        assert np.max(np.abs(phase)) < 0.02
        # far: powers equal to first order in (element offset)/R (distances (1 +- d/R)^-2 for two
        # elements, angle-dependent factors with log-derivatives below 1 per radian)
        rel = 8 * max(np.linalg.norm(d_t, axis=-1).max(), np.linalg.norm(d_r, axis=-1).max()) / distance
        np.testing.assert_allclose(np.abs(e_ex.a) ** 2, np.abs(e_pw.a) ** 2, rtol=rel)
        # Doppler: a unit vector towards the point moves by at most |d| / (R - |d|) from one element to the
        # phase centre, so |f_exact - f_plane| <= |v| (|d_t| + |d_r|) / ((R - |d|) lambda)
        n_t, n_r = np.linalg.norm(d_t, axis=-1), np.linalg.norm(d_r, axis=-1)
        d_max = max(n_t.max(), n_r.max())
        bound_f = np.linalg.norm(velocity) * (n_t[:, None, None] + n_r[None, :, None]) / (
            (r.min() - d_max) * LAMBDA)
        assert np.all(np.abs(e_ex.doppler - e_pw.doppler) <= bound_f)
        assert np.max(np.abs(e_ex.doppler - e_pw.doppler)) > 0  # the exact model does use the element geometry


# ------------------------------------------------------------------------------- absolute power
def test_absolute_power_facing_metal_plate_closed_form(tmp_path):
    r"""A metal plate (ITU, S = 0) facing an isotropic point radar at D = 2 m, wider than the FoV.

    S = 0: the pixel engine's Lambertian model (the paper's eq. (2)) sees nothing (diffuse only) and
    warns. With scattering_coefficient=1 every pixel is Sionna's Lambertian scatterer: |a|^2 = (lambda/4 pi)^2 Gamma^2 (cos(theta)/pi) dOmega / R^2
    with R = D / cos(theta), cos(theta) = cos(el) cos(az), so

        sum |a|^2 = (lambda/4 pi)^2 Gamma^2 / (pi D^2) * int cos^3(az) d az * int cos^4(el) d el

    with Gamma^2 between the extremes of |r_TE|^2 and |r_TM|^2 over the FoV, and the pixel sum within the
    midpoint-rule error bound of the integrals."""
    distance = 2.0
    fov_az, fov_el, n_az, n_el = np.deg2rad(60.0), np.deg2rad(30.0), 32, 16
    root = write_moving_mesh_animation(tmp_path / "wall", lambda t: plate_mesh((distance, 0, 0), size=(3.0, 2.0)),
                                       (0, 0, 0), num_frames=1, name="wall")
    anim = load_animation(root)
    grid = dict(n_az=n_az, n_el=n_el, fov_az=fov_az, fov_el=fov_el)
    with pytest.warns(UserWarning, match="scattering_coefficient 0"):
        dark = PixelEngine(model="lambertian", **grid).echoes(anim, POINT_RADAR, 0)
    assert dark.num_contributions == 0
    engine = PixelEngine(scattering_coefficient=1.0, model="lambertian", **grid)
    echoes = engine.echoes(anim, POINT_RADAR, 0)
    assert echoes.num_contributions == n_az * n_el
    power = np.sum(np.abs(echoes.a) ** 2)

    a_half, e_half = fov_az / 2, fov_el / 2
    i_az = 2 * (np.sin(a_half) - np.sin(a_half) ** 3 / 3)
    i_el = 2 * (3 * e_half / 8 + np.sin(2 * e_half) / 4 + np.sin(4 * e_half) / 32)
    # midpoint rule in az (|f''| <= 3 for cos^3), midpoint-in-cos^3 against the exact cos(el) band in el
    h_az, h_el = fov_az / n_az, fov_el / n_el
    err_az = fov_az * h_az ** 2 * 3 / 24
    err_el = fov_el * h_el ** 2 / 12 * (3 / 2 + 2 / np.sqrt(3) * 1)
    err = err_az * (i_el + err_el) + i_az * err_el
    mat = engine.scene.objects["wall"].radio_material
    eta = float(mat.relative_permittivity[0]) - 1j * float(mat.conductivity[0]) / (
        2 * np.pi * POINT_RADAR.fc * epsilon_0)
    cos_range = np.linspace(np.cos(a_half) * np.cos(e_half), 1.0, 400)
    r_te, r_tm = slab_reflection_coefficients(cos_range, eta, float(mat.thickness[0]), LAMBDA)
    g_lo = min((np.abs(r_te) ** 2).min(), (np.abs(r_tm) ** 2).min())
    g_hi = max((np.abs(r_te) ** 2).max(), (np.abs(r_tm) ** 2).max())
    k = (LAMBDA / (4 * np.pi)) ** 2 / (np.pi * distance ** 2)
    # float32 ray casting: ranges to a few ulp (1e-6 relative covers it)
    assert k * g_lo * (i_az * i_el - err) * (1 - 1e-6) <= power <= k * g_hi * (i_az * i_el + err) * (1 + 1e-6)
    print(f"sum |a|^2 = {power:.6e}, closed form {k * g_lo * i_az * i_el:.6e} .. {k * g_hi * i_az * i_el:.6e}, "
          f"midpoint bound {err / (i_az * i_el):.1e}")
    assert g_hi - g_lo < 1e-3  # metal: a bracket 0.004 dB wide
    # the render's pixel RCS: sigma_p = 4 R^2 dOmega Gamma^2 cos(theta) (Lambertian, monostatic)
    render = engine.last_render
    cos_t = render.cos_incidence
    np.testing.assert_allclose(cos_t, np.cos(render.azimuth) * np.cos(render.elevation), rtol=1e-6)
    sigma = 4 * render.range ** 2 * render.solid_angle * cos_t
    assert np.all((render.rcs >= g_lo * sigma * (1 - 1e-6)) & (render.rcs <= g_hi * sigma * (1 + 1e-6)))


def _mc_sigma(a2, num_pairs):
    """Conservative Monte-Carlo standard error of the path engine's sum |a|^2: ray directions treated as
    independent uniform samples, and the element pairs of one ray as fully correlated."""
    return np.sqrt(num_pairs * np.sum(a2 ** 2))


@pytest.mark.slow
@pytest.mark.parametrize("scattering", [0.5, 1.0])
def test_power_matches_path_engine_on_tilted_rough_plate(tmp_path, scattering):
    """A 1 m rough plate (eps 5, sigma 0.1 S/m, K_x 0.3) at 5 m, turned 30 deg in yaw and 20 deg in pitch
    (its mirror echo misses the radar), radar pitched 5 deg: the pixel engine's sum |a|^2 equals the path
    engine's (max_depth 1, diffuse + specular, 4e6 rays per Tx) within 4 sigma of the path engine's
    Monte-Carlo error plus the pixel grid's edge error (the cut pixels at the plate's outline)."""
    v0, faces = plate_mesh([0, 0, 0], size=(1.0, 1.0), normal_axis=0, subdiv=4)
    rot = rotation_matrix([np.deg2rad(30.0), np.deg2rad(20.0), 0.0])
    root = write_moving_mesh_animation(tmp_path / "tilted", lambda t: (v0 @ rot.T + [5.0, 0, 0], faces), (0, 0, 0),
                                       num_frames=1, materials=rough(scattering, kx=0.3), material="mat-rough",
                                       radar_pose=((0, 0, 0), (0, np.deg2rad(5.0), 0)))
    anim = load_animation(root)
    pixel = PixelEngine(n_az=640, n_el=640, fov_az=np.deg2rad(26.0), fov_el=np.deg2rad(26.0), model="lambertian")
    e_pix = pixel.echoes(anim, RADAR, 0)
    path = PathEngine(max_depth=1, samples_per_src=4_000_000, max_num_paths_per_src=2_000_000)
    e_path = path.echoes(anim, RADAR, 0)
    assert set(np.unique(e_path.labels[e_path.a != 0])) == {"plate"}
    p_pix = np.sum(np.abs(e_pix.a) ** 2)
    a2 = np.abs(e_path.a) ** 2
    p_path = a2.sum()
    sigma_mc = _mc_sigma(a2, RADAR.num_tx * RADAR.num_rx)
    # edge error: a pixel cut by the outline has a hit/miss neighbour (8-neighbourhood); its error is
    # w (1[centre on plate] - covered fraction), zero-mean and at most w / sqrt(12) rms for a covered
    # fraction uniform in [0, 1]
    render = pixel.last_render
    hit = render.image(np.ones(render.num_hits), fill=0.0)
    assert hit[0].sum() == hit[-1].sum() == hit[:, 0].sum() == hit[:, -1].sum() == 0  # plate inside the FoV
    padded = np.pad(hit, 1)
    border = np.zeros_like(hit)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            border = np.maximum(border, np.abs(padded[1 + di:1 + di + hit.shape[0], 1 + dj:1 + dj + hit.shape[1]] - hit))
    w_max = (np.abs(e_pix.a) ** 2).sum(axis=(0, 1)).max()
    sigma_edge = w_max * np.sqrt(border.sum() / 12)
    tol = 4 * np.hypot(sigma_mc, sigma_edge)
    print(f"S={scattering}: pixel {10 * np.log10(p_pix):.3f} dB, path {10 * np.log10(p_path):.3f} dB, "
          f"difference {10 * np.log10(p_pix / p_path):+.3f} dB, 4 sigma = {100 * tol / p_path:.1f} %")
    assert abs(p_pix - p_path) <= tol
    assert tol / p_path < 0.1  # the comparison means something: better than 0.4 dB


# ------------------------------------------------------------------------------- compilation
def test_no_kernel_compiled_after_the_first_frame(tmp_path):
    """Moving box, rotating strip (vertex velocities), diffuse floor, and a pose change: after the first
    frame no new kernel appears (the ray cast is the only kernel, its inputs are aligned data)."""
    floor_v, floor_f = plate_mesh((0, 0, -1.0), size=(8, 8), normal_axis=2, subdiv=2)

    def strip(t):
        v, f = plate_mesh((4.0, -1.0, 0.0), size=(0.8, 0.4), subdiv=2)
        c, s = np.cos(t), np.sin(t)
        return (v - [4.0, -1.0, 0.0]) @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T + [4.0, -1.0, 0.0], f

    spinning = {"name": "strip", "mesh_fn": strip, "velocity": (0, 0, 0), "material": "mat-rough",
                "vertex_velocity_fn": lambda t, v: np.cross([0, 0, 1.0], v - [4.0, -1.0, 0.0])}
    root = write_moving_mesh_animation(
        tmp_path / "room", lambda t: box_mesh((3.0 + 1.2 * t, 0.4 * np.sin(5 * t), -0.1), (0.3, 0.5, 1.7)),
        lambda t: (1.2, 2.0 * np.cos(5 * t), 0.0), num_frames=5, fps=10.0, name="person",
        materials=dict(METAL, **rough(0.5)), material="mat-rough", extra_objects=[spinning],
        static=[("floor", floor_v, floor_f, "mat-rough")])
    anim = load_animation(root)
    engine = PixelEngine(n_az=64, n_el=32)
    counts = []
    for frame in range(anim.num_frames):
        echoes = engine.echoes(anim, RADAR, frame)
        counts.append(echoes.num_contributions)
        assert set(np.unique(echoes.labels)) == {"person", "floor", "strip"}
    stats = engine.stats
    assert stats[0].reloaded and not any(s.reloaded for s in stats[1:])
    assert stats[0].kernels_launched > 0
    for s in stats[1:]:
        assert s.new_kernel_hashes == 0, f"frame {s.frame}: {s.new_kernel_hashes} new kernels"
        assert s.kernels_compiled == 0
    engine.echoes(anim, RADAR, 2, radar_pose=([0.2, -0.1, 0.1], [0.1, 0.05, 0.0]))
    assert engine.last_stats.new_kernel_hashes == 0 and not engine.last_stats.reloaded
    # a new radar reloads the scene
    echoes = engine.echoes(anim, RadarConfig.preset("ti-iwr1443boost"), 1)
    assert echoes.shape[:2] == (2, 4) and engine.last_stats.reloaded


def test_missing_radar_pose_is_an_error(tmp_path):
    root = write_plate_animation(tmp_path / "p", radar_pose=None, num_frames=1, materials=rough(),
                                 material="mat-rough")
    anim = load_animation(root)
    with pytest.raises(EngineError, match="no 'radar' pose"):
        small_engine().echoes(anim, RADAR, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        echoes = small_engine().echoes(anim, RADAR, 0, radar_pose=([0, 0, 0], [0, 0, 0]))
    assert echoes.num_contributions > 0
