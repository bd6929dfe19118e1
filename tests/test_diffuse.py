"""Random-phase diffuse scatterers: fixed to the surface, and map power independent of the sample count."""

import numpy as np
import pytest

import mesh_render
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.diffuse import cells_per_edge, diffuse_echoes, lambertian_gains, scatterer_phases, shared_cells
from sionnafmcw.echoes import Echoes
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.physical_optics import monostatic_rcs, render_resolution
from sionnafmcw.processing.rdmap import range_doppler_map
from sionnafmcw.radar import RadarConfig
from sionnafmcw.scenes import meshes
from sionnafmcw.synthesis import synthesize

RADAR = RadarConfig.preset("walk-77ghz")
LAMBDA = SPEED_OF_LIGHT / RADAR.fc
ORIGIN = np.zeros(3)


def db(x):
    return 10 * np.log10(x)


def test_phases_fixed_to_surface_uniform_and_independent():
    rng = np.random.default_rng(1)
    n = 20000
    tri = rng.integers(0, 5000, n)
    bary = rng.random((n, 2)) * 0.5
    phi = scatterer_phases(np.full(n, "torso"), tri, bary, 64)
    assert np.all((phi >= 0) & (phi < 2 * np.pi))
    # uniform and independent: the mean phasor of N scatterers is ~ 1/sqrt(N) (5 sigma)
    assert abs(np.mean(np.exp(1j * phi))) < 5 / np.sqrt(n)
    assert abs(np.mean(np.exp(2j * phi))) < 5 / np.sqrt(n)
    # deterministic, and the same cell gives the same phase (the surface point moved with the body)
    assert np.array_equal(phi, scatterer_phases(np.full(n, "torso"), tri, bary, 64))
    inside = np.floor(bary * 64) / 64 + 0.5 / 64
    assert np.array_equal(phi, scatterer_phases(np.full(n, "torso"), tri, inside, 64))
    # another object or a neighbouring cell: unrelated phases
    other = scatterer_phases(np.full(n, "arm"), tri, bary, 64)
    assert abs(np.mean(np.exp(1j * (phi - other)))) < 5 / np.sqrt(n)
    shifted = scatterer_phases(np.full(n, "torso"), tri, np.clip(bary + 1 / 64, 0, 1), 64)
    assert abs(np.mean(np.exp(1j * (phi - shifted)))) < 5 / np.sqrt(n)
    with pytest.raises(ValueError, match="barycentric"):
        scatterer_phases(np.full(3, "a"), np.zeros(3), np.zeros((3, 3)), 4)


def spinning_plate(step, distance, omega=8.0, bulk=5.0, realisation=0):
    """A 1 m rough (S = 1) metal plate at ``distance``, tilted 60 deg, spinning about its normal while receding."""
    rot = rotation_matrix((np.deg2rad(60.0), 0.0, 0.0))
    normal = rot @ [-1.0, 0.0, 0.0]
    centre = np.array([distance, 0.0, 0.0])
    v, f = meshes.plate(centre, (1.0, 1.0), normal=normal, subdiv=4)
    samples = mesh_render.render(v, f, ORIGIN, centre, 0.4 / distance, step, scattering_coefficient=1.0,
                                 labels=np.full(len(f), f"plate at {distance} m #{realisation}"))
    samples.velocity[:] = bulk * centre / np.linalg.norm(centre) + omega * np.cross(normal, samples.position - centre)
    edge = np.max(np.linalg.norm(np.diff(v[f], axis=1, append=v[f][:, :1]), axis=2), axis=1)
    cells = cells_per_edge(edge[samples.triangle], LAMBDA / 4)
    return samples, cells


def map_power(echoes):
    cube = synthesize(echoes, RADAR, noise=False)
    return range_doppler_map(cube, RADAR, clutter_removal=True).power.sum()


def unit_map_power(echoes):
    """Map power of one contribution of |a| = 1 per channel at the echoes' mean delay and Doppler, per channel."""
    shape = (RADAR.num_tx, RADAR.num_rx, 1)
    one = Echoes(np.ones(shape, complex), np.full(shape, echoes.tau.mean()), np.full(shape, echoes.doppler.mean()))
    return map_power(one) / (RADAR.num_tx * RADAR.num_rx)


def test_map_power_equals_incoherent_sum_whatever_the_sample_count():
    """Four spinning rough plates at 3-7.5 m, each filling ~9 range x ~100 Doppler cells; the mean
    map power over 4 realisations (frames with other surfaces) against sum |a|^2 times the map
    power of a unit contribution. One map scatters by ~0.35 dB (measured over realisations), the
    mean of four by ~0.2 dB."""
    ratios, counts = [], []
    for factor in (1, 2):                                              # 4x samples
        measured, expected, count = 0.0, 0.0, 0
        for realisation in range(4):
            parts = []
            for distance in (3.0, 4.5, 6.0, 7.5):
                step = render_resolution(1.0, distance, LAMBDA, samples_across=32) / factor   # ~3 cm, then 1.6 cm
                samples, cells = spinning_plate(step, distance, realisation=realisation)
                assert shared_cells(samples, cells) == 0
                parts.append(diffuse_echoes(samples, RADAR, cells))
                count += samples.num_samples
            echoes = Echoes.concatenate(parts)
            expected += unit_map_power(echoes) * np.sum(np.abs(echoes.a) ** 2)
            measured += map_power(echoes)
        ratios.append(measured / expected)
        counts.append(count)
    assert counts[1] == pytest.approx(4 * counts[0], rel=0.05)
    assert all(abs(db(r)) < 0.5 for r in ratios)
    assert abs(db(ratios[1] / ratios[0])) < 0.5


def test_deterministic_phases_grow_6db_per_4x_samples():
    """Contrast: diffuse contributions without their own phase add coherently."""
    v, f = meshes.plate((4.0, 0, 0), (0.5, 0.5), normal=(-1, 0, 0))
    step = render_resolution(0.5, 4.0, LAMBDA, samples_across=32)
    growth = []
    for factor in (1, 2):
        samples = mesh_render.render(v, f, ORIGIN, (4.0, 0, 0), 0.07, step / factor, scattering_coefficient=1.0)
        samples.velocity[:] = [1.0, 0, 0]
        echoes = diffuse_echoes(samples, RADAR, cells=1)
        assert shared_cells(samples, 1) == samples.num_samples   # one phase per triangle: all coherent
        deterministic = Echoes(np.abs(echoes.a), echoes.tau, echoes.doppler)
        growth.append(map_power(deterministic) / np.sum(np.abs(echoes.a) ** 2))
    assert 4.5 < db(growth[1] / growth[0]) < 7.5


@pytest.mark.parametrize("s", [0.0, 0.5, 1.0])
def test_energy_split_po_plus_diffuse_equals_closed_forms(s):
    """A 0.1 m rough metal plate facing the radar at 20 m (far field): PO carries (1 - S^2) of
    4 pi A^2 / lambda^2, the Lambertian scatterers S^2 of 4 A cos^2(theta) = 4 A."""
    distance, side = 20.0, 0.1
    v, f = meshes.plate((distance, 0, 0), (side, side), normal=(-1, 0, 0))
    samples = mesh_render.render(v, f, ORIGIN, (distance, 0, 0), 0.8 * side / distance,
                                 render_resolution(side, distance, LAMBDA), scattering_coefficient=s)
    sigma_po = monostatic_rcs(samples, ORIGIN, LAMBDA, (distance, 0, 0))
    amp, _, _ = lambertian_gains(samples, ORIGIN[None], ORIGIN[None], LAMBDA)
    sigma_diffuse = (4 * np.pi) ** 3 * distance ** 4 * np.sum(amp ** 2) / LAMBDA ** 2
    po_closed = (1 - s ** 2) * 4 * np.pi * side ** 4 / LAMBDA ** 2
    diffuse_closed = s ** 2 * 4 * side ** 2
    if s < 1:
        assert abs(db(sigma_po / po_closed)) < 1.0
    else:
        assert sigma_po == 0.0
    if s > 0:
        assert abs(db(sigma_diffuse / diffuse_closed)) < 0.5
    else:
        assert sigma_diffuse == 0.0
