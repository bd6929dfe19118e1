"""Near-field physical optics on render samples against an independent quadrature and the closed forms.

Tolerance: 1 dB on every RCS; the module samples the surface as a render from the radar
would (tests/mesh_render.py), the reference integrates the mesh triangles (tests/po_quadrature.py).
"""

import numpy as np
import pytest

import mesh_render
import po_quadrature as quad
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.echoes import Echoes
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.physical_optics import (PhysicalOpticsError, SurfaceSamples, channel, footprint_error_bound,
                                        footprint_factor, interpolated_normals, monostatic_rcs, po_echoes, po_gains,
                                        render_resolution, sinc_and_derivatives)
from sionnafmcw.processing.rdmap import range_doppler_map
from sionnafmcw.radar import RadarConfig
from sionnafmcw.scenes import meshes
from sionnafmcw.synthesis import synthesize

RADAR = RadarConfig.preset("walk-77ghz")
LAMBDA = SPEED_OF_LIGHT / RADAR.fc
ORIGIN = np.zeros(3)


def db(x):
    return 10 * np.log10(x)


def plate_rcs(side, distance, subdiv=1, rotation=None, samples_across=16):
    v, f = meshes.plate((0, 0, 0), (side, side), normal=(-1, 0, 0), subdiv=subdiv)
    if rotation is not None:
        v = v @ rotation.T
    v = v + [distance, 0, 0]
    step = render_resolution(side, distance, LAMBDA, samples_across=samples_across)
    samples = mesh_render.render(v, f, ORIGIN, (distance, 0, 0), 0.8 * side / distance, step)
    return v, f, monostatic_rcs(samples, ORIGIN, LAMBDA, (distance, 0, 0))


@pytest.mark.parametrize("side", [0.1, 0.2])
@pytest.mark.parametrize("distance", [2.0, 5.0, 10.0, 20.0])
def test_plate_matches_quadrature_and_closed_forms(side, distance):
    v, f, sigma = plate_rcs(side, distance)
    reference = quad.monostatic_rcs(v, f, ORIGIN, (distance, 0, 0), LAMBDA, two_sided=True)
    fresnel = quad.square_plate_rcs_fresnel(side, distance, LAMBDA)
    assert abs(db(sigma / reference)) < 1.0
    assert abs(db(reference / fresnel)) < 1.0          # the reference itself, against the near-field closed form
    far = 4 * np.pi * side ** 4 / LAMBDA ** 2
    if distance >= 2 * 2 * side ** 2 / LAMBDA:          # far field, 2 D^2 / lambda with D the diagonal
        assert abs(db(sigma / far)) < 1.0
    else:                                                # near field: below the far-field value, as PO says
        assert sigma < far


@pytest.mark.parametrize("subdiv", [1, 8])               # 2 and 128 triangles
@pytest.mark.parametrize("orientation", [(0.0, 0.0, 0.35), (0.004, 0.003, 1.1), (0.01, 0.0, 0.0)])
def test_plate_tessellation_and_orientation_invariant(subdiv, orientation):
    rot = rotation_matrix(orientation)
    v, f, sigma = plate_rcs(0.1, 5.0, subdiv=subdiv, rotation=rot)
    assert len(f) == 2 * subdiv ** 2
    _, _, sigma_two = plate_rcs(0.1, 5.0, subdiv=1, rotation=rot)
    assert abs(db(sigma / sigma_two)) < 0.01
    reference = quad.monostatic_rcs(v, f, ORIGIN, (5.0, 0, 0), LAMBDA, two_sided=True)
    assert abs(db(sigma / reference)) < 1.0


def sphere_samples(distance, step, smooth_normals, radius=0.1):
    v, f = meshes.ellipsoid((distance, 0, 0), (radius,) * 3, n_rings=64, n_segments=128)   # 4.9 mm edges
    return v, f, mesh_render.render(v, f, ORIGIN, (distance, 0, 0), 1.1 * radius / distance, step,
                                    smooth_normals=smooth_normals)


@pytest.mark.parametrize("distance", [2.0, 10.0])
def test_sphere(distance):
    """Interpolated normals (a smooth surface) at the curvature rule: PO = quadrature = pi r^2."""
    radius = 0.1
    step = render_resolution(2 * radius, distance, LAMBDA, curvature_radius=radius)
    v, f, samples = sphere_samples(distance, step, smooth_normals=True)
    sigma = monostatic_rcs(samples, ORIGIN, LAMBDA, (distance, 0, 0))
    reference = quad.monostatic_rcs(v, f, ORIGIN, (distance, 0, 0), LAMBDA)
    assert abs(db(sigma / reference)) < 1.0
    assert abs(db(sigma / (np.pi * radius ** 2))) < 1.0
    # facet normals need samples of a third of the mesh edge (render_resolution's facet_size)
    fine = render_resolution(2 * radius, distance, LAMBDA, curvature_radius=radius, facet_size=2 * np.pi * radius / 128)
    _, _, facets = sphere_samples(distance, fine, smooth_normals=False)
    assert abs(db(monostatic_rcs(facets, ORIGIN, LAMBDA, (distance, 0, 0)) / reference)) < 1.0
    # point samples (no in-sample phase) at the same samples are not PO: the correction is what converges
    points = SurfaceSamples(samples.position, samples.normal, samples.area)
    assert abs(db(monostatic_rcs(points, ORIGIN, LAMBDA, (distance, 0, 0)) / reference)) > 3.0


@pytest.mark.parametrize("distance", [10.0, 20.0])
def test_cylinder_broadside(distance):
    radius, length = 0.05, 0.1                           # far field along the axis: 2 L^2 / lambda = 5.1 m
    v, f = quad.cylinder(radius, length, n_segments=128, n_length=4, center=(distance, 0, 0))
    edge = 2 * np.pi * radius / 128
    step = render_resolution(length, distance, LAMBDA, curvature_radius=radius, facet_size=edge)
    samples = mesh_render.render(v, f, ORIGIN, (distance, 0, 0), 0.6 * length / distance, step)
    sigma = monostatic_rcs(samples, ORIGIN, LAMBDA, (distance, 0, 0))
    reference = quad.monostatic_rcs(v, f, ORIGIN, (distance, 0, 0), LAMBDA)
    assert abs(db(sigma / reference)) < 1.0
    assert abs(db(sigma / (2 * np.pi * radius * length ** 2 / LAMBDA))) < 1.0


def test_per_element_channels_near_field():
    """Every Tx/Rx pair of the 77 GHz array at 1 m from a tilted plate: complex channel = quadrature's.

    The tilt (0.02 rad) keeps the echo in the specular main lobe; far off specular (0.2 rad) the
    return is the plate's edge diffraction, 56 dB below the facing plate, which a render resolves only to a pixel.
    """
    rot = rotation_matrix((0.02, 0.01, 0.3))
    v, f = meshes.plate((0, 0, 0), (0.1, 0.1), normal=(-1, 0, 0), subdiv=2)
    v = v @ rot.T + [1.0, 0.02, 0.0]
    step = render_resolution(0.1, 1.0, LAMBDA)
    samples = mesh_render.render(v, f, ORIGIN, (1.0, 0.02, 0), 0.12, step)
    a, tau, _ = po_gains(samples, RADAR.tx_positions, RADAR.rx_positions, LAMBDA)
    h = channel(a, tau, RADAR.fc)                        # [M, N]
    for m, t in enumerate(RADAR.tx_positions):
        for n, r in enumerate(RADAR.rx_positions):
            ref = quad.po_channel(v, f, t, r, LAMBDA, two_sided=True)
            assert abs(db(abs(h[m, n]) ** 2 / abs(ref) ** 2)) < 1.0
            assert abs(np.angle(h[m, n] / ref)) < np.pi / 8   # a sixteenth of a cycle
    # the pairs differ (near field, 3 cm array at 1 m): not one plane-wave phase for all
    assert np.ptp(np.angle(h / h[0, 0])) > 0.5


def test_doppler_sign_and_radar_equation_through_synthesis():
    """A plate at 10 m receding at 1 m/s: PO echoes through the synthesizer = a point target of sigma_PO."""
    distance, speed = 10.0, 1.0
    v, f = meshes.plate((distance, 0, 0), (0.1, 0.1), normal=(-1, 0, 0))
    samples = mesh_render.render(v, f, ORIGIN, (distance, 0, 0), 0.08 / distance,
                                 render_resolution(0.1, distance, LAMBDA))
    samples.velocity[:] = [speed, 0, 0]
    echoes = po_echoes(samples, RADAR)
    assert echoes.shape == (RADAR.num_tx, RADAR.num_rx, samples.num_samples)
    assert np.allclose(echoes.doppler, -2 * speed / LAMBDA, rtol=1e-3)
    sigma = quad.monostatic_rcs(v, f, ORIGIN, (distance, 0, 0), LAMBDA, two_sided=True)
    point = Echoes.point_targets(RADAR, distance, speed, 0.0, rcs=sigma)
    p_po = range_doppler_map(synthesize(echoes, RADAR, noise=False), RADAR).power.max()
    p_pt = range_doppler_map(synthesize(point, RADAR, noise=False), RADAR).power.max()
    assert abs(db(p_po / p_pt)) < 1.0


def test_energy_split_scales_coherent_share():
    v, f = meshes.plate((5.0, 0, 0), (0.1, 0.1), normal=(-1, 0, 0))
    step = render_resolution(0.1, 5.0, LAMBDA)
    for s in (0.0, 0.5, 1.0):
        samples = mesh_render.render(v, f, ORIGIN, (5.0, 0, 0), 0.016, step, scattering_coefficient=s,
                                     reflection=-0.8)
        smooth = mesh_render.render(v, f, ORIGIN, (5.0, 0, 0), 0.016, step)
        ratio = monostatic_rcs(samples, ORIGIN, LAMBDA, (5.0, 0, 0)) / monostatic_rcs(smooth, ORIGIN, LAMBDA, (5.0, 0, 0))
        assert ratio == pytest.approx((1 - s ** 2) * 0.64, abs=1e-9)


def test_resolution_rule_and_errors():
    # flat plate at 2 m: 1/4 sqrt(lambda R) = 2.2 cm unless the size bound is smaller
    assert render_resolution(10.0, 2.0, LAMBDA) * 2.0 == pytest.approx(0.25 * np.sqrt(LAMBDA * 2.0))
    assert render_resolution(0.16, 2.0, LAMBDA) * 2.0 == pytest.approx(0.01)
    assert render_resolution(1.0, 3.0, LAMBDA, curvature_radius=0.1) * 3.0 == pytest.approx(0.25 * np.sqrt(LAMBDA * 0.1))
    with pytest.raises(PhysicalOpticsError, match="distance"):
        render_resolution(0.1, -1.0, LAMBDA)
    with pytest.raises(PhysicalOpticsError, match="max_quadratic_phase"):
        render_resolution(0.1, 1.0, LAMBDA, max_quadratic_phase=0.0)
    with pytest.raises(PhysicalOpticsError, match="curvature"):
        SurfaceSamples(np.zeros((2, 3)), np.tile([1.0, 0, 0], (2, 1)), np.ones(2), curvature=np.zeros((2, 3)))
    with pytest.raises(PhysicalOpticsError, match="normal"):
        SurfaceSamples(np.zeros((2, 3)), np.ones((2, 3)), np.ones(2))
    with pytest.raises(PhysicalOpticsError, match="tx_gain"):
        po_gains(SurfaceSamples([[1.0, 0, 0]], [[1.0, 0, 0]], [1e-4]), np.zeros((2, 3)), np.zeros((1, 3)), LAMBDA,
                 tx_gain=np.ones((3, 1)))


def test_large_plate_tends_to_the_mirror_image():
    """Geometric-optics limit, which fixes the constant phase: a 1 m metal plate at 1 m returns the
    image source of Sionna's specular path, h = Gamma lambda / (4 pi 2R) e^{-jk 2R}, Gamma = -1
    (the plate's finite edges add Fresnel ripples of a few per cent: 0.5 dB, pi/16)."""
    distance = 1.0
    v, f = meshes.plate((distance, 0, 0), (1.0, 1.0), normal=(-1, 0, 0), subdiv=3)
    samples = mesh_render.render(v, f, ORIGIN, (distance, 0, 0), 0.5, render_resolution(1.0, distance, LAMBDA))
    a, tau, _ = po_gains(samples, ORIGIN[None], ORIGIN[None], LAMBDA)
    h = channel(a[0, 0], tau[0, 0], RADAR.fc)
    image = -LAMBDA / (4 * np.pi * 2 * distance) * np.exp(-2j * np.pi / LAMBDA * 2 * distance)
    assert abs(db(abs(h) ** 2 / abs(image) ** 2)) < 0.5
    assert abs(np.angle(h / image)) < np.pi / 16


# ---------------------------------------------------------------------------------------- in-sample phase
def footprint_quadrature(k, a, b, h11, h22, h12, order=200):
    """The mean of exp(-j(a alpha + b beta + k/2 (h11 alpha^2 + h22 beta^2 + 2 h12 alpha beta))) over the
    footprint |alpha|, |beta| <= 1/2 by Gauss-Legendre (200 x 200 points: exact to 1e-12 for these phases)."""
    x, w = np.polynomial.legendre.leggauss(order)
    x, w = x / 2, w / 2
    al, be = np.meshgrid(x, x, indexing="ij")
    q = k / 2 * (h11 * al ** 2 + h22 * be ** 2 + 2 * h12 * al * be)
    return np.sum(np.outer(w, w) * np.exp(-1j * (a * al + b * be + q)))


def test_footprint_factor_within_its_bound_of_the_exact_integral():
    """The closed form of the in-sample factor (module docstring) against the footprint integral by
    quadrature: off by no more than its bound Var(q)/2, for linear phases from 0 to many pi and
    quadratic edge phases up to pi/4 (eight times the rule's); the linear factor sinc sinc
    misses by the mean quadratic phase, far beyond the bound."""
    k = 2 * np.pi / LAMBDA
    rng = np.random.default_rng(7)
    worst, linear_worst = 0.0, 0.0
    for _ in range(60):
        a, b = rng.normal(0.0, 6.0, 2) * rng.choice([0.0, 1.0])
        h = rng.normal(0.0, 1.0, 3) * rng.uniform(1e-5, 1e-3)           # edge phase k h / 8 up to ~pi/4
        exact = footprint_quadrature(k, a, b, *h)
        bound = footprint_error_bound(k, *h)
        worst = max(worst, abs(footprint_factor(k, a, b, *h) - exact) / bound)
        linear_worst = max(linear_worst, abs(footprint_factor(k, a, b, 0.0, 0.0, 0.0) - exact) / bound)
    assert worst <= 1.0 + 1e-6
    assert linear_worst > 10.0
    # quadratic phases of radians (a footprint stretched at grazing incidence): the second-order
    # bound says nothing there, and the factor is the linear one, bounded by 1 as the integral is
    for h in ((2e-2, 1.5e-2, 0.0), (5e-2, -3e-2, 1e-2)):
        assert footprint_error_bound(k, *h) >= 1.0
        for a, b in ((0.0, 0.0), (2.0, 30.0)):
            f = footprint_factor(k, a, b, *h)
            assert f == footprint_factor(k, a, b, 0.0, 0.0, 0.0) and abs(f) <= 1.0
            assert abs(f - footprint_quadrature(k, a, b, *h, order=400)) <= footprint_error_bound(k, *h)
    # no curvature: the exact factor of the linear phase, sinc(a/2) sinc(b/2)
    assert footprint_factor(k, 3.0, -1.0, 0.0, 0.0, 0.0) == pytest.approx(np.sinc(1.5 / np.pi) * np.sinc(0.5 / np.pi),
                                                                           abs=1e-15)
    # the series of S, S', S'' below |y| = 0.05 meets the closed forms (which hold there to 1e-9)
    for y in (0.0499999, 0.0500001):
        s0, s1, s2 = sinc_and_derivatives(np.array([y]))
        assert s0[0] == pytest.approx(np.sin(y) / y, abs=1e-12)
        assert s1[0] == pytest.approx((np.cos(y) - np.sin(y) / y) / y, abs=1e-9)
        assert s2[0] == pytest.approx(-np.sin(y) / y - 2 * (np.cos(y) - np.sin(y) / y) / y ** 2, abs=1e-7)


def test_interpolated_normals_give_a_spheres_shape_operator():
    """Shading normals of a sphere mesh (radius 0.1 m, vertex normals radial): the interpolated normal
    is the unit radial vector and K = dn/dx is I/rho on the tangent plane to the tessellation's accuracy
    (facet size / rho = 5 %), symmetric and with no normal component; flipping the normals flips K."""
    radius = 0.1
    v, f = meshes.ellipsoid((0.0, 0.0, 0.0), (radius,) * 3, n_rings=64, n_segments=128)
    rng = np.random.default_rng(3)
    tri = rng.integers(0, len(f), 500)
    bary = rng.dirichlet(np.ones(3), 500)[:, 1:]
    corners = v[f[tri]]
    radial = corners / np.linalg.norm(corners, axis=-1, keepdims=True)
    normal, k = interpolated_normals(corners, radial, bary)
    point = np.einsum("pc,pci->pi", np.column_stack([1 - bary.sum(1), bary]), corners)
    assert np.max(np.abs(normal - point / np.linalg.norm(point, axis=-1, keepdims=True))) < 0.05
    tangent = np.cross(normal, rng.normal(size=(500, 3)))
    tangent /= np.linalg.norm(tangent, axis=-1, keepdims=True)
    along = np.einsum("pi,pij,pj->p", tangent, k, tangent)
    assert np.all(np.abs(along * radius - 1.0) < 0.05)
    assert np.max(np.abs(np.einsum("pi,pij->pj", normal, k))) < 1e-9 / radius     # no normal component
    other = np.cross(normal, tangent)
    asym = np.einsum("pi,pij,pj->p", tangent, k, other) - np.einsum("pi,pij,pj->p", other, k, tangent)
    assert np.max(np.abs(asym)) * radius < 0.05
    _, flipped = interpolated_normals(corners, -radial, bary)
    np.testing.assert_allclose(flipped, -k, atol=1e-12)


def test_second_order_factor_converges_on_a_smooth_sphere():
    """A sphere of fine facets (r = 0.05 m, 1.2 mm facets, smooth normals with their shape operator)
    at 10 m, at the rule's samples and three grid offsets: the second-order factor's complex channel
    is within 1 dB (|dh|/|h| < 0.122) of the independent quadrature and closer than the linear factor,
    which leaves out the quadratic phase of the sag and of the range (benchmarks/po_sample_size.py:
    0.019 against 0.047 rms on r = 0.1 m at 10 m)."""
    radius, distance = 0.05, 10.0
    k = 2 * np.pi / LAMBDA
    v, f = meshes.ellipsoid((distance, 0.0, 0.0), (radius,) * 3, n_rings=128, n_segments=256)
    reference = quad.po_channel(v, f, ORIGIN, ORIGIN, LAMBDA)
    step = render_resolution(2 * radius, distance, LAMBDA, curvature_radius=radius)
    second, linear = [], []
    for shift in ((0.0, 0.0), (0.31, -0.17), (-0.42, 0.38)):
        target = (distance, distance * np.tan(shift[0] * step), distance * np.tan(shift[1] * step))
        samples = mesh_render.render(v, f, ORIGIN, target, 1.2 * radius / distance, step, smooth_normals=True)
        a, tau, _ = po_gains(samples, ORIGIN[None], ORIGIN[None], LAMBDA)
        second.append(abs(channel(a[0, 0], tau[0, 0], RADAR.fc) - reference) / abs(reference))
        a, tau, _ = po_gains(samples, ORIGIN[None], ORIGIN[None], LAMBDA, in_sample_phase=False)
        u = samples.position / np.linalg.norm(samples.position, axis=-1, keepdims=True)
        lin = footprint_factor(k, *(2 * k * np.einsum("pi,pi->p", u, samples.edges[:, e]) for e in range(2)), 0, 0, 0)
        linear.append(abs(channel(a[0, 0] * lin, tau[0, 0], RADAR.fc) - reference) / abs(reference))
    assert max(second) < 10 ** (1 / 20) - 1
    assert np.sqrt(np.mean(np.square(second))) < np.sqrt(np.mean(np.square(linear)))
