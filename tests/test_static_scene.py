"""The static scene once per pose (engines/static_scene.py): the same echoes as tracing every frame whole.

Scene: a rough concrete wall 4 m in front of the radar and a metal floor 1 m below it (static; diffuse
paths, PO first and second bounces), and a metal box that crosses the line of sight at 2.5 m
(moving; it blocks part of the wall and the floor, and adds its own chains: box, box-floor,
floor-box). References are the same engine with ``static_scene=False`` (every frame traced and
rendered whole). Tolerances:

* without the PO merge the two are the same sum of the same contributions, so the noise-free cubes
  agree to the synthesis error (relative tolerance 1e-7 of the tight default budget, and float32
  output: 1e-6);
* with the merge (default) a blocked sample leaves its cell at the cell's delay instead of the
  cell being formed without it: the channel at the carrier is unchanged by any merge, so it agrees
  to 1e-6, and the cube within the noise budget :math:`E_{max}` per sample
  (:func:`~sionnafmcw.synthesis.noise_error_budget`: each merge stays within its share of it,
  :mod:`~sionnafmcw.engines.po_merge`, and what a blocked sample changes in its cell is a few per
  cent of one cell's).
"""

from __future__ import annotations

import numpy as np
import pytest

from animation_helpers import box_mesh, plate_mesh, write_moving_mesh_animation
from sionnafmcw import RadarConfig
from sionnafmcw.animation import load_animation
from sionnafmcw.engines import PathEngine
from sionnafmcw.engines.static_scene import Spheres
from sionnafmcw.synthesis import noise_error_budget, synthesize

RADAR = RadarConfig.preset("walk-77ghz").replace(num_chirps=16)
MATERIALS = {
    "mat-itu_metal": ("itu-radio-material", {"type": "metal"}),
    "mat-rough-concrete": ("itu-radio-material", {"type": "concrete", "scattering_coefficient": 0.5}),
}
FRAMES = 5


@pytest.fixture(scope="module")
def crossing(tmp_path_factory):
    """The wall, the floor and a 0.3 m box crossing the line of sight at 2.5 m (1.2 m/s along y)."""
    wall_v, wall_f = plate_mesh(np.array([4.0, 0.0, 0.0]), size=(2.0, 2.0), normal_axis=0, subdiv=4)
    floor_v, floor_f = plate_mesh(np.array([2.5, 0.0, -1.0]), size=(4.0, 2.0), normal_axis=2, subdiv=4)
    velocity = np.array([0.0, 1.2, 0.0])

    def box(t):
        return box_mesh(np.array([2.5, -0.3, 0.0]) + velocity * t, (0.3, 0.3, 0.3))

    root = write_moving_mesh_animation(
        tmp_path_factory.mktemp("static") / "crossing", box, velocity, num_frames=FRAMES, fps=10.0, name="box",
        materials=MATERIALS, static=[("wall", wall_v, wall_f, "mat-rough-concrete"),
                                     ("floor", floor_v, floor_f, "mat-itu_metal")])
    return load_animation(root)


def frames_of(engine, anim):
    return [engine.echoes(anim, RADAR, f) for f in range(FRAMES)]


def carrier_channel(echoes):
    return np.sum(echoes.a * np.exp(-2j * np.pi * RADAR.fc * echoes.tau), axis=-1)


def cube(echoes, cache=None):
    return synthesize(echoes, RADAR, noise=False, static_cache=cache)


@pytest.mark.parametrize("depth", [2, 3])
def test_static_scene_without_merge_is_the_same_sum(crossing, depth):
    """The bookkeeping, exact: the chains at the first bounce's density (``po_bounce_rule=False``: the
    tubes do not depend on what else is in the scene) give the uncached cube to the synthesis precision."""
    full = PathEngine(static_scene=False, po_merge=False, max_depth=depth, po_bounce_rule=False)
    cached = PathEngine(po_merge=False, max_depth=depth, po_bounce_rule=False)
    cache = {}
    blocked = new = 0
    for f, (a, b) in enumerate(zip(frames_of(full, crossing), frames_of(cached, crossing))):
        figures = cached.stats[f].figures
        blocked += figures["static_po_removed"] + figures["static_blocked_paths"]
        new += figures["po_samples"]
        x, y = cube(a), cube(b, cache)
        assert np.linalg.norm(y - x) <= 1e-6 * np.linalg.norm(x), f"frame {f}"
    assert blocked > 0 and new > 0, "the box must block static chains and add its own"
    assert cached.stats[1].figures["static_seconds"] == 0.0, "the static scene is built once per pose"


@pytest.mark.parametrize("depth", [2, 3])
def test_static_scene_with_the_bounce_rule_within_its_error(crossing, depth):
    """With the multi-bounce sampling rule (the default) the static block's tubes are split by the static
    scene's apertures and the uncached render's by the whole scene's, so the two sample the same
    integrals differently, each within the rule's error share of every object's echo
    (:data:`~sionnafmcw.engines.bounce_sampling.ERROR_SHARE`): the cubes within twice that of each other."""
    from sionnafmcw.engines.bounce_sampling import ERROR_SHARE

    full = PathEngine(static_scene=False, po_merge=False, max_depth=depth)
    cached = PathEngine(po_merge=False, max_depth=depth)
    cache = {}
    for f, (a, b) in enumerate(zip(frames_of(full, crossing), frames_of(cached, crossing))):
        x, y = cube(a), cube(b, cache)
        assert np.linalg.norm(y - x) <= 2 * ERROR_SHARE * np.linalg.norm(x), f"frame {f}"


def test_static_scene_with_merge_keeps_the_channel(crossing):
    """The merge's bookkeeping (the tubes fixed: ``po_bounce_rule=False``, as the test above)."""
    full = PathEngine(static_scene=False, po_bounce_rule=False)
    cached = PathEngine(po_bounce_rule=False)
    unmerged = PathEngine(static_scene=False, po_merge=False, po_bounce_rule=False)
    cache = {}
    for f in range(FRAMES):
        a, b = full.echoes(crossing, RADAR, f), cached.echoes(crossing, RADAR, f)
        unmerged.echoes(crossing, RADAR, f)
        h_a, h_b = carrier_channel(a), carrier_channel(b)
        np.testing.assert_allclose(h_b, h_a, rtol=1e-6, atol=1e-6 * np.abs(h_a).max())
        exact = cube(unmerged.last_parts["po"]) + cube(unmerged.last_parts["traced"])
        assert np.abs(cube(b, cache) - cube(a)).max() <= noise_error_budget(RADAR), f"frame {f}"
        assert np.abs(cube(a) - exact).max() <= noise_error_budget(RADAR), f"frame {f}"
        assert cached.last_parts["po"] is not None


def test_static_bounce_that_merges_nothing_is_held_unmerged(crossing, monkeypatch):
    """A static bounce whose merge merges nothing (no cell size within the budget: here a budget of 0) is held
    as the samples' own contributions, as without merging: no cells, the frame takes the blocked samples'
    contributions from the block, and every cube is the unmerged engine's bit for bit."""
    from sionnafmcw.engines import po_merge

    monkeypatch.setattr(po_merge, "MERGE_BUDGET_SHARE", 0.0)
    nothing = PathEngine(po_bounce_rule=False)
    unmerged = PathEngine(po_merge=False, po_bounce_rule=False)
    blocked = 0
    cache_a, cache_b = {}, {}
    for f in range(FRAMES):
        a, b = nothing.echoes(crossing, RADAR, f), unmerged.echoes(crossing, RADAR, f)
        blocked += nothing.stats[f].figures["static_po_removed"]
        np.testing.assert_array_equal(cube(a, cache_a), cube(b, cache_b))
    po = nothing._state.static.po
    assert all(cells is None for cells in po.cells) and po.unmerged, "nothing merged: no cells, the block's views"
    assert blocked > 0, "the box must block static samples"


def test_static_block_is_the_same_every_frame(crossing):
    engine = PathEngine()
    echoes = frames_of(engine, crossing)
    key, count = echoes[0].static_key, echoes[0].static_count
    assert key is not None and count > 0
    for e in echoes[1:]:
        assert e.static_key == key and e.static_count == count
        np.testing.assert_array_equal(e.a[..., :count], echoes[0].a[..., :count])
        np.testing.assert_array_equal(e.tau[..., :count], echoes[0].tau[..., :count])
    assert np.all(echoes[0].doppler[..., :count] == 0), "a static scene seen from a static radar has no Doppler"
    # a new pose is a new static scene
    moved = engine.echoes(crossing, RADAR, 0, radar_pose=((0.0, 0.1, 0.0), (0.0, 0.0, 0.0)))
    assert moved.static_key != key


def test_resumed_frame_equals_uninterrupted(crossing):
    """The echoes of a frame depend on the frame only, not on the frames simulated before."""
    first = PathEngine()
    frames_of(first, crossing)
    again = PathEngine()
    late = again.echoes(crossing, RADAR, FRAMES - 1)
    np.testing.assert_array_equal(carrier_channel(late), carrier_channel(first.echoes(crossing, RADAR, FRAMES - 1)))


def test_spheres_meet_segments():
    """Segment-sphere test against its closed form: a unit sphere at (5, 0, 0)."""
    s = Spheres(np.array([[5.0, 0.0, 0.0]]), np.array([1.0]))
    o = np.zeros((5, 3))
    k = np.array([[1, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0.19, 0], [1, 0.21, 0]], float)
    k /= np.linalg.norm(k, axis=-1, keepdims=True)
    length = np.array([3.9, np.inf, np.inf, np.inf, np.inf])
    # stops 0.1 m short; passes through; perpendicular; tangent angle asin(1/5) = 0.2014 rad
    assert s.meet(o, k, length).tolist() == [False, True, False, True, False]
    behind = Spheres(np.array([[-5.0, 0.0, 0.0]]), np.array([1.0]))
    assert not behind.meet(o[:1], k[:1], np.array([np.inf]))[0]


def test_spheres_meet_all_spheres_at_once_as_one_by_one():
    """Several spheres (a body's parts, metres from the origin) tested at once against all segments:
    the same answer as each sphere's own closed-form test (``_meet_one``) or-ed over the spheres,
    for segments that end short, pass through, graze or miss, finite and unbounded."""
    from sionnafmcw.engines.static_scene import _meet_one

    rng = np.random.default_rng(3)
    centres = rng.normal(size=(13, 3)) * 0.3 + [3.0, 1.5, 1.0]
    radii = rng.uniform(0.05, 0.25, 13)
    origins = rng.uniform(-1.0, 6.0, (20_000, 3))
    k = centres[rng.integers(0, 13, 20_000)] + rng.normal(size=(20_000, 3)) * 0.3 - origins
    k /= np.linalg.norm(k, axis=-1, keepdims=True)
    length = rng.uniform(0.0, 8.0, 20_000)
    length[::5] = np.inf
    one_by_one = np.zeros(20_000, dtype=bool)
    for c, r in zip(centres, radii):
        one_by_one |= _meet_one(origins, k, length, c, r)
    got = Spheres(centres, radii).meet(origins, k, length)
    assert 2_000 < one_by_one.sum() < 18_000                        # both answers well represented
    np.testing.assert_array_equal(got, one_by_one)


def people(rng, where):
    """Bodies of 13 overlapping part spheres (0.2-0.3 m apart, radii 0.12-0.25 m) around each of ``where``."""
    centres = [c + rng.normal(size=(13, 3)) * [0.1, 0.1, 0.4] for c in np.asarray(where, float)]
    return np.concatenate(centres), rng.uniform(0.12, 0.25, 13 * len(where))


def test_spheres_group_by_touching():
    """Each body's overlapping parts form one group whose sphere holds them all; bodies apart are apart."""
    rng = np.random.default_rng(5)
    centres, radii = people(rng, [[3.0, 1.5, 1.0], [3.0, -1.5, 1.0]])
    groups = Spheres(centres, radii).groups()
    assert sorted(tuple(m) for m, _, _ in groups) == [tuple(range(13)), tuple(range(13, 26))]
    for members, centre, radius in groups:
        assert np.all(np.linalg.norm(centres[members] - centre, axis=-1) + radii[members] <= radius * (1 + 1e-12))


def test_ray_index_meets_as_spheres():
    """The index (segments grouped by apparent source, cones of the spheres) gives :meth:`Spheres.meet`'s
    answer: segments from one origin (a first bounce), reflected by planes (each plane's rays from the
    origin's image, starting on the plane), and from scattered points (groups too small: tested
    directly); ending short, passing through, grazing or missing, finite and unbounded."""
    from sionnafmcw.engines.static_scene import RayIndex

    rng = np.random.default_rng(7)
    centres, radii = people(rng, [[3.0, 1.5, 1.0], [4.0, -1.0, 1.0], [2.0, 0.0, 0.9]])
    spheres = Spheres(centres, radii)
    n = 30_000
    origin = np.array([0.0, 0.2, 1.1])
    aim = centres[rng.integers(0, len(centres), n)] + rng.normal(size=(n, 3)) * 0.3
    k0 = aim - origin
    k0 /= np.linalg.norm(k0, axis=-1, keepdims=True)
    first = RayIndex(np.broadcast_to(origin, (n, 3)), np.broadcast_to(origin, (n, 3)), k0)
    # reflections: images of the origin in 4 walls / floor, each ray starting where its line crosses the plane
    planes = [(np.array([1.0, 0, 0]), 6.0), (np.array([0, 1.0, 0]), 3.0), (np.array([0, -1.0, 0]), 3.0),
              (np.array([0, 0, 1.0]), 0.0)]
    wall = rng.integers(0, len(planes) + 1, n)           # the last: scattered sources (groups of one)
    image = np.empty((n, 3))
    start = np.empty((n, 3))
    for j, (normal, offset) in enumerate(planes):
        rows = wall == j
        image[rows] = origin - 2 * (origin @ normal - offset) * normal
    rows = wall == len(planes)
    image[rows] = rng.uniform(-2.0, 8.0, (rows.sum(), 3))
    k1 = aim - image
    k1 /= np.linalg.norm(k1, axis=-1, keepdims=True)
    for j, (normal, offset) in enumerate(planes):
        rows = wall == j
        t = (offset - image[rows] @ normal) / (k1[rows] @ normal)
        start[rows] = image[rows] + t[:, None] * k1[rows]
    rows = wall == len(planes)
    start[rows] = image[rows] + rng.uniform(0.0, 1.0, (rows.sum(), 1)) * k1[rows]
    reflected = RayIndex(image, start, k1)
    assert len(reflected.groups) == len(planes) and reflected.loose.size == (wall == len(planes)).sum()
    for index, starts, k in ((first, np.broadcast_to(origin, (n, 3)), k0), (reflected, start, k1)):
        length = rng.uniform(0.0, 8.0, n)
        length[::5] = np.inf
        expected = spheres.meet(starts, k, length)
        assert 0.2 * n < expected.sum() < 0.8 * n                  # both answers well represented
        np.testing.assert_array_equal(index.meet(spheres, starts, k, length), expected)


def test_shared_rows_keeps_every_bit():
    """Fields whose rows are bit for bit the same become one broadcast row; others (-0.0 against 0.0
    included: the same value, not the same bits) stay as they are."""
    from sionnafmcw.engines.static_scene import shared_rows
    from sionnafmcw.physical_optics import SurfaceSamples

    p = 50
    velocity = np.zeros((p, 3))
    velocity[7, 1] = -0.0
    samples = SurfaceSamples(position=np.random.default_rng(0).normal(size=(p, 3)), normal=np.tile([0, 0, 1.0], (p, 1)),
                             area=np.full(p, 1e-6), velocity=velocity, curvature=np.zeros((p, 3, 3)))
    before = {k: np.array(v) for k, v in vars(samples).items() if isinstance(v, np.ndarray)}
    shared_rows(samples)
    assert samples.normal.strides[0] == 0 and samples.area.strides[0] == 0 and samples.curvature.strides[0] == 0
    assert samples.position.strides[0] != 0 and samples.velocity.strides[0] != 0
    for name, value in before.items():
        got = np.asarray(getattr(samples, name))
        assert got.dtype == value.dtype and got.tobytes() == value.tobytes(), name
    assert samples.select(np.arange(p) % 2 == 0).normal.flags.writeable


def test_static_block_in_chunks_within_the_static_budget(crossing):
    """The static block of a real frame (the wall's diffuse paths, the wall's and floor's PO samples)
    summed in chunks of a third of it and whole: both meet the static block's share of the noise
    budget (:data:`~sionnafmcw.synthesis.STATIC_BUDGET_SHARE`), so they agree within twice that; and
    ``synthesize`` with its static cache gives the whole frame within the full budget of the uncached sum."""
    from sionnafmcw.synthesis import STATIC_BUDGET_SHARE, UPSTREAM_SHARE, static_block_cube

    echoes = PathEngine().echoes(crossing, RADAR, 0)
    k = echoes.static_count
    assert k > 300
    budget = (1 - UPSTREAM_SHARE) * noise_error_budget(RADAR)
    whole, _ = static_block_cube(echoes, RADAR, STATIC_BUDGET_SHARE * budget)
    chunked, _ = static_block_cube(echoes, RADAR, STATIC_BUDGET_SHARE * budget, chunk=k // 3 + 1)
    scale = np.abs(whole).max()
    assert scale > 100 * budget, "the static block must be far above the budget for the test to mean anything"
    assert np.abs(chunked - whole).max() <= 2 * STATIC_BUDGET_SHARE * budget + 2 ** -23 * scale
