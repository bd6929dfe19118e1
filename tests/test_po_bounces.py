"""PO multi-bounce chains sampled by rule (engines/bounce_sampling.py), on real scenes: corner reflectors
off their axis, a closed room.

Every figure is the coherent channel of a label, :math:`|\\sum a e^{-j2\\pi f_c\\tau}|^2`, the mean over
the element pairs: the echo a range-Doppler map sees. Tolerances from the issue: 0.5 dB between mirror
images, 1 dB to the converged echo (the same engine at ``po_samples_across`` 128: the bound 8 times
tighter, the first bounce 8 times finer), the K-rcs tolerance (1.5 dB) for the trihedral's far field.
"""

from __future__ import annotations

import numpy as np
import pytest

from reflector_scenes import mirror_pair_scene, reflector_scene
from sionnafmcw import RadarConfig
from sionnafmcw.animation import load_animation
from sionnafmcw.animation.model import RadarPose
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.engines import PathEngine

RADAR = RadarConfig.preset("walk-77ghz").replace(num_chirps=16)
ISO = RADAR.replace(antenna_pattern="iso")
LAMBDA = SPEED_OF_LIGHT / RADAR.fc


def db(x):
    return 10 * np.log10(x)


def power(echoes, radar, label=None) -> float:
    sel = slice(None) if label is None else echoes.labels[0, 0] == label
    h = np.sum(echoes.a[:, :, sel] * np.exp(-2j * np.pi * radar.fc * echoes.tau[:, :, sel]), axis=-1)
    return float(np.mean(np.abs(h) ** 2))


@pytest.mark.parametrize("aspect", [0, 15, 30, 45])
def test_mirror_image_trihedrals_agree(tmp_path, aspect):
    """Two 0.1 m trihedrals, mirror images in the plane y = 0, 3 m ahead and 1.5 m to either side, turned
    ``aspect`` degrees off their axis; the radar's phase centre on that plane at 0, 0.2 and 0.4 m along the
    lane: both echoes within 0.2 dB, twice what each may be off the exact flat-face PO
    (``tests/test_flat_faces.py``: 0.1 dB); their apertures' grids fall differently on the two. (0.5 dB would
    not tell the exact apertures from the sampled render, ``po_flat_faces=False``: 0.48 dB at 45 degrees.)"""
    anim = load_animation(mirror_pair_scene(tmp_path / "pair", 0.1, 3.0, 1.5, np.deg2rad(aspect)))
    engine = PathEngine(max_depth=3, diffuse=False)
    for x in (0.0, 0.2, 0.4):
        pose = RadarPose(np.array([x, -RADAR.phase_centre[1], 1.0]), np.zeros(3))
        echoes = engine.echoes(anim, RADAR, 0, radar_pose=pose)
        left, right = power(echoes, RADAR, "left"), power(echoes, RADAR, "right")
        assert left > 0 and right > 0
        assert abs(db(left / right)) < 0.2, (x, db(left), db(right))


def _converged(tmp_path, kind, leg, distance, aspect):
    anim = load_animation(reflector_scene(tmp_path / "reflector", kind, leg, distance, np.deg2rad(aspect)))
    depth = 3 if kind == "trihedral" else 2
    default = PathEngine(max_depth=depth, diffuse=False)
    fine = PathEngine(max_depth=depth, diffuse=False, po_samples_across=128)
    p_default, p_fine = power(default.echoes(anim, ISO, 0), ISO), power(fine.echoes(anim, ISO, 0), ISO)
    assert [b.depth for b in default.last_renders] == list(range(1, depth + 1))
    assert abs(db(p_default / p_fine)) < 1.0, (db(p_default), db(p_fine))


@pytest.mark.parametrize("kind, leg, distance, aspect", [
    ("trihedral", 0.1, 1.0, 30), ("trihedral", 0.05, 3.0, 15), ("trihedral", 0.3, 10.0, 0),
    ("trihedral", 0.1, 10.0, 45), ("trihedral", 0.3, 3.0, 45),
    ("dihedral", 0.3, 1.0, 30), ("dihedral", 0.1, 3.0, 15), ("dihedral", 0.05, 10.0, 0), ("dihedral", 0.3, 1.0, 45)])
def test_defaults_give_the_converged_echo(tmp_path, kind, leg, distance, aspect):
    """Trihedrals (three bounces) and dihedrals (two) of 0.05-0.3 m at 1-10 m, 0-45 degrees off their axis
    (turned about the vertical): the defaults within 1 dB of the converged echo (the sampled render before
    the bounce rule: 3.0 dB off for the 0.1 m trihedral at 1 m, 30 degrees; with it, and without the exact
    apertures, -10.4 dB for the 0.1 m trihedral at 10 m, 45 degrees: ``benchmarks/po_flat_faces.py``)."""
    _converged(tmp_path, kind, leg, distance, aspect)


@pytest.mark.slow
@pytest.mark.parametrize("kind, leg, distance, aspect", [
    ("trihedral", 0.3, 1.0, 30), ("trihedral", 0.3, 1.0, 15), ("trihedral", 0.05, 10.0, 30),
    ("trihedral", 0.1, 3.0, 0), ("trihedral", 0.1, 1.0, 45), ("trihedral", 0.05, 1.0, 45),
    ("dihedral", 0.3, 10.0, 30), ("dihedral", 0.05, 1.0, 30), ("dihedral", 0.1, 10.0, 15), ("dihedral", 0.3, 3.0, 0),
    ("dihedral", 0.1, 1.0, 45)])
def test_defaults_give_the_converged_echo_more(tmp_path, kind, leg, distance, aspect):
    """More of the grid of :func:`test_defaults_give_the_converged_echo`."""
    _converged(tmp_path, kind, leg, distance, aspect)


@pytest.mark.parametrize("distance", [10.0, 20.0])
def test_trihedral_far_field_on_axis_at_the_defaults(tmp_path, distance):
    """A 0.1 m trihedral facing the radar, the defaults with three bounces: sigma of the pair (Tx 0, Rx 0)
    within the K-rcs tolerance (1.5 dB) of 4 pi a^4 / (3 lambda^2) (tests/test_path_po.py's trihedral
    needed po_samples_across=48)."""
    leg = 0.1
    anim = load_animation(reflector_scene(tmp_path / "tri", "trihedral", leg, distance, 0.0))
    echoes = PathEngine(max_depth=3, diffuse=False).echoes(anim, ISO, 0)
    h = np.sum(echoes.a[0, 0] * np.exp(-2j * np.pi * ISO.fc * echoes.tau[0, 0]))
    sigma = (4 * np.pi) ** 3 * distance ** 4 * abs(h) ** 2 / LAMBDA ** 2
    assert abs(db(sigma / (4 * np.pi * leg ** 4 / (3 * LAMBDA ** 2)))) < 1.5


def test_quartered_tubes_tile_the_first_bounce(tmp_path):
    """Splitting every first-bounce tube of a trihedral into quarters (the empty cells beside the outline
    included) keeps the lit area it stands for: within 3 % of the finest render's, where the quarters
    without the empty cells lose the outer half of the outline's band (test of the tiling the rule rests
    on; 3 %: the outline band of the finest render, 4 tubes across a 0.1 m face's 256)."""
    from sionnafmcw.engines import bounce_sampling as bs
    from sionnafmcw.engines.po_render import join_first_bounces

    anim = load_animation(reflector_scene(tmp_path / "tri", "trihedral", 0.1, 1.0, np.deg2rad(30)))
    engine = PathEngine(max_depth=1, diffuse=False)
    engine.echoes(anim, ISO, 0)
    fine = PathEngine(max_depth=1, diffuse=False, po_samples_across=256)
    fine.echoes(anim, ISO, 0)
    truth = fine.last_renders[0].samples.area.sum()
    first = engine.last_renders[0]
    objects, _, rot, _, _ = engine._po_geometry(anim, ISO, anim.radar_pose, {})
    world = engine._state.surfaces
    neighbours = bs.grid_neighbours(first)
    empty = np.argwhere(neighbours < 0)
    everything = np.arange(first.num_samples)
    whole = bs.quartered(world, first, everything, objects, rot, LAMBDA, "static", empty)
    inner = bs.quartered(world, first, everything, objects, rot, LAMBDA, "static")
    assert abs(whole.samples.area.sum() / truth - 1) < 0.03
    assert inner.samples.area.sum() < whole.samples.area.sum()
    # a quartered tube adds up to its parent where no outline cuts it
    one = bs.quartered(world, first, everything[neighbours.min(axis=1) >= 0][:1], objects, rot, LAMBDA, "static")
    assert one.num_samples == 4
    assert abs(one.samples.area.sum() / first.samples.area[neighbours.min(axis=1) >= 0][0] - 1) < 1e-3
    assert join_first_bounces(first, one).num_samples == first.num_samples + 4


def test_an_aperture_without_outline_error_is_not_split(tmp_path):
    """A 0.3 m dihedral facing the radar at 3 m (its double-bounce aperture many tubes across, the outline's
    error within the bound) and a flat plate (no second bounce): nothing is split, the renders are the
    chains followed at the first bounce's density."""
    from sionnafmcw.engines import bounce_sampling as bs
    from sionnafmcw.engines.po_render import reflect

    anim = load_animation(reflector_scene(tmp_path / "di", "dihedral", 0.3, 3.0, 0.0))
    engine = PathEngine(max_depth=2, diffuse=False, po_samples_across=4)
    engine.echoes(anim, ISO, 0)
    renders = engine.last_renders
    objects, _, rot, _, _ = engine._po_geometry(anim, ISO, anim.radar_pose, {})
    split, empty = bs.under_resolved(renders, objects, 4, LAMBDA)
    assert renders[1].num_samples > 100
    assert split.size == 0 and empty.size == 0
    again = reflect(engine._state.surfaces, renders[0], objects, rot, LAMBDA, group="static")
    assert again.num_samples == renders[1].num_samples


def test_neighbour_search_and_chain_ids_are_the_plain_searches(tmp_path):
    """On a trihedral's real three-bounce renders: the bounded neighbour search equals the unbounded
    nearest-neighbour search on a balanced tree (the definition), and the chain ids from 1-D keys equal
    ``np.unique`` over the stacked (parent chain, surface code) rows, bit for bit (both exact rewrites)."""
    from scipy.spatial import cKDTree

    from sionnafmcw.engines import bounce_sampling as bs

    anim = load_animation(reflector_scene(tmp_path / "tri", "trihedral", 0.1, 1.0, np.deg2rad(30)))
    engine = PathEngine(max_depth=3, diffuse=False, po_flat_faces=False)   # the rule's own splits on the reflector
    engine.echoes(anim, ISO, 0)
    renders = engine.last_renders
    first = renders[0]
    assert len(renders) == 3 and renders[2].num_samples > 100
    u, p = first.direction, first.num_samples
    size = np.maximum(np.linalg.norm(first.step_az, axis=1), np.linalg.norm(first.step_el, axis=1))
    probes = np.concatenate([u - first.step_az, u + first.step_az, u - first.step_el, u + first.step_el])
    distance, index = cKDTree(u).query(probes)
    found = (distance <= bs.NEIGHBOUR_REACH * np.maximum(np.tile(size, 4), size[index])) \
        & (index != np.tile(np.arange(p), 4))
    plain = np.where(found, index, -1).reshape(4, p).T
    neighbours = bs.grid_neighbours(first)
    assert np.array_equal(neighbours, plain)
    assert 0 < np.count_nonzero(neighbours < 0) < neighbours.size
    chain = np.unique(bs.surface_codes(first), return_inverse=True)[1].reshape(-1)
    for bounce in renders[1:]:
        codes = bs.surface_codes(bounce)
        rows = np.unique(np.stack([chain[bounce.parent], codes], axis=1), axis=0, return_inverse=True)[1].reshape(-1)
        ids = bs.chain_ids(chain[bounce.parent], codes)
        assert np.array_equal(ids, rows) and ids.max() > 0
        chain = ids
