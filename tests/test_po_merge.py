"""The PO merge (:mod:`sionnafmcw.engines.po_merge`): the error of merging is within the bound it
computes, the bound within the budget it is given, the cells the coarsest that fit, and contributions
from directions the array tells apart stay apart."""

from __future__ import annotations

import numpy as np
import pytest

from sionnafmcw import RadarConfig
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.echoes import Echoes
from sionnafmcw.engines.po_merge import (
    FRACTIONS, MIN_SAVING, cell_keys, count_cells, merge_budget, merge_cells, merge_contributions, merge_error_bound,
)
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.physical_optics import SurfaceSamples, element_gains, po_gains
from sionnafmcw.synthesis import noise_error_budget, synthesize

RADAR = RadarConfig.preset("walk-77ghz").replace(num_chirps=32)


def _plate_samples(range_m=3.0, size=0.3, n=50, tilt=0.25, speed=1.2, reflection=-1.0):
    """PO samples of a plate ``size`` x ``size`` (reflection coefficient ``reflection``) tilted by
    ``tilt`` rad at ``range_m``, moving towards the radar: a smooth surface whose samples' phases turn
    across it (what the merge sees)."""
    s = (np.arange(n) + 0.5) / n * size - size / 2
    yy, zz = np.meshgrid(s, s, indexing="ij")
    rot = rotation_matrix((tilt, 0.5 * tilt, 0.0))
    local = np.stack([np.zeros(yy.size), yy.ravel(), zz.ravel()], -1)
    position = local @ rot.T + [range_m, 0.1, 0.05]
    normal = np.tile(rot[:, 0], (len(position), 1))
    area = np.full(len(position), (size / n) ** 2)
    velocity = np.tile([-speed, 0.0, 0.0], (len(position), 1))
    samples = SurfaceSamples(position, normal, area, velocity=velocity, reflection=reflection)
    tx, rx = RADAR.tx_positions, RADAR.rx_positions
    g_t, g_r = element_gains(RADAR, samples, tx, rx, np.eye(3))
    a, tau, dop = po_gains(samples, tx, rx, SPEED_OF_LIGHT / RADAR.fc, g_t, g_r, in_sample_phase=False)
    u = position / np.linalg.norm(position, axis=1, keepdims=True)
    return a, tau, dop, u


def _cube(a, tau, dop):
    """The noise-free cube, its synthesis error 1e-3 of the merge budget (negligible against it)."""
    return synthesize(Echoes(a, tau, dop), RADAR, noise=False, max_error=1e-3 * merge_budget(RADAR))


@pytest.mark.parametrize("fraction", [FRACTIONS[2], FRACTIONS[4]])
def test_merge_error_within_its_bound(fraction):
    """The cube of the merged contributions differs from the unmerged one by no more than
    :func:`merge_error_bound` at any sample (plus the two syntheses' errors, 2e-3 of the budget)."""
    a, tau, dop, u = _plate_samples()
    labels = np.full(a.shape[-1], "plate")
    cell, first = merge_cells(tau[0, 0], dop[0, 0], u, np.zeros(a.shape[-1], np.int64), RADAR, fraction)
    assert first.size < 0.9 * a.shape[-1]                  # the cells really merge
    bound = merge_error_bound(a, tau, dop, cell, RADAR)
    merged = merge_contributions(a, tau, dop, labels, u, RADAR, budget=bound * (1 + 1e-9))
    assert merged.fraction is not None and merged.fraction >= fraction and merged.bound <= bound * (1 + 1e-9)
    error = np.abs(_cube(merged.a, merged.tau, merged.doppler) - _cube(a, tau, dop)).max()
    assert 0 < error <= merged.bound + 2e-3 * merge_budget(RADAR)


def test_cells_follow_the_noise_budget():
    """With the engines' budget the coarsest cell size whose bound fits is taken: the next coarser
    one's bound exceeds the budget; the merged cube is within the budget of the unmerged one. A weak
    reflector (|Gamma| = 1e-3, near the noise after processing) merges; a metal plate, 60 dB stronger,
    would need cells far below any that merge (its echo is 1e3 times the budget per sample)."""
    a, tau, dop, u = _plate_samples(range_m=4.0, size=0.4, n=80, reflection=-1e-3)
    budget = merge_budget(RADAR)
    assert budget == pytest.approx(0.1 * noise_error_budget(RADAR))
    merged = merge_contributions(a, tau, dop, np.full(a.shape[-1], "p"), u, RADAR, budget)
    assert merged.fraction is not None and merged.bound <= budget
    k = FRACTIONS.index(merged.fraction)
    if k > 0:
        cell, _ = merge_cells(tau[0, 0], dop[0, 0], u, np.zeros(a.shape[-1], np.int64), RADAR, FRACTIONS[k - 1])
        assert merge_error_bound(a, tau, dop, cell, RADAR) > budget
    error = np.abs(_cube(merged.a, merged.tau, merged.doppler) - _cube(a, tau, dop)).max()
    assert error <= budget * (1 + 2e-3)


def test_directions_the_array_tells_apart_are_not_merged():
    """Two contributions at the same range, Doppler and label but 20 degrees apart in azimuth: their
    pair delays differ by the array's path difference, so they keep their own cells; the same pair
    seen from one direction merges."""
    tau = np.full((3, 4, 2), 2e-8)
    tau[..., 1] += 1e-15
    a = np.ones((3, 4, 2), complex) * 1e-9
    dop = np.zeros((3, 4, 2))
    apart = np.array([[1.0, 0.0, 0.0], [np.cos(0.35), np.sin(0.35), 0.0]])
    assert merge_contributions(a, tau, dop, ["x", "x"], apart, RADAR, budget=np.inf).a.shape[-1] == 2
    same = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    assert merge_contributions(a, tau, dop, ["x", "x"], same, RADAR, budget=np.inf).a.shape[-1] == 1


def test_a_merge_is_made_only_where_it_saves():
    """The cell count the merge decides on (:func:`count_cells`, a sort) is the cells' count; a merge
    removing less than MIN_SAVING of the contributions is not made, whatever the budget: a plate seen
    in cells so fine that few samples share one comes back unmerged, the same plate in coarse cells
    merges."""
    a, tau, dop, u = _plate_samples(range_m=4.0, size=0.4, n=80, reflection=-1e-3)
    codes = np.zeros(a.shape[-1], np.int64)
    for fraction in FRACTIONS[::3]:
        assert count_cells(cell_keys(tau[0, 0], dop[0, 0], u, codes, RADAR, fraction)) == \
            merge_cells(tau[0, 0], dop[0, 0], u, codes, RADAR, fraction)[1].size
    labels = np.full(a.shape[-1], "p")
    assert merge_contributions(a, tau, dop, labels, u, RADAR, budget=np.inf).fraction == FRACTIONS[0]
    # every sample its own label: no two share a cell, nothing is saved, nothing is merged
    alone = merge_contributions(a, tau, dop, np.arange(a.shape[-1]).astype(str), u, RADAR, budget=np.inf)
    assert alone.fraction is None and alone.a is a
    # nine samples in ten with their own label: the saving is what the tenth merges, below MIN_SAVING
    few = np.where(np.arange(a.shape[-1]) % 10 < 9, np.arange(a.shape[-1]).astype(str), "p")
    merged = merge_contributions(a, tau, dop, few, u, RADAR, budget=np.inf)
    assert 1 - count_cells(cell_keys(tau[0, 0], dop[0, 0], u, np.unique(few, return_inverse=True)[1], RADAR,
                                     FRACTIONS[0])) / a.shape[-1] < MIN_SAVING
    assert merged.fraction is None
