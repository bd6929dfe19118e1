"""The static echo block: its beat cube computed once and reused (``synthesize(..., static_cache=)``).

Reference: the direct sum of all contributions (:func:`beat_direct`, exact to float64). The cached
cube is :math:`x_S + x_D`, two fast sums; each meets the bound of :mod:`sionnafmcw.synthesis.accuracy`
for its own budget (half the per-sample budget each when there is one, the tight relative
defaults otherwise), so their errors add. Float32 output: every complex64 rounding moves a sample
by at most :math:`2^{-24}` of its magnitude (round to nearest, per component).
"""

from __future__ import annotations

import numpy as np
import pytest

import sionnafmcw.synthesis as synthesis
from sionnafmcw import Echoes, RadarConfig, synthesize
from sionnafmcw.synthesis import (STATIC_BUDGET_SHARE, UPSTREAM_SHARE, beat_direct, noise_error_budget,
                                  synthesis_accuracy, thermal_noise)

FLOAT32_ROUNDING = 2.0 ** -24


@pytest.fixture(scope="module")
def radar():
    # walk-77ghz timing and array, fewer chirps/samples so the direct sum stays cheap
    return RadarConfig.preset("walk-77ghz").replace(num_chirps=32, num_samples=64, fs=2.5e6)


def targets(radar, count, seed, max_speed, label):
    rng = np.random.default_rng(seed)
    return Echoes.point_targets(radar, rng.uniform(0.5, 0.95 * radar.max_range, count),
                                rng.uniform(-max_speed, max_speed, count), np.deg2rad(rng.uniform(-70, 70, count)),
                                np.deg2rad(rng.uniform(-30, 30, count)), rng.uniform(0.01, 2.0, count),
                                labels=np.full(count, label))


def room(radar, count=120, seed=1, key="room"):
    """A static room (zero Doppler) marked as the static block ``key``."""
    s = targets(radar, count, seed, 0.0, "room")
    return Echoes(s.a, s.tau, s.doppler, s.labels, static_count=s.num_contributions, static_key=key)


def frame(radar, static, seed, count=80):
    """The static block followed by this frame's movers."""
    return Echoes.concatenate([static, targets(radar, count, seed, 9.0, "person")])


def part(echoes, start, stop=None):
    return Echoes(echoes.a[..., start:stop], echoes.tau[..., start:stop], echoes.doppler[..., start:stop])


def split_bound(echoes, radar, max_error=None):
    """Error bound per sample of the cached cube: the static and the dynamic sum's bounds added
    (with a budget, split as synthesize splits it)."""
    k = echoes.static_count
    shares = (None, None) if max_error is None else \
        (STATIC_BUDGET_SHARE * max_error, (1 - STATIC_BUDGET_SHARE) * max_error)
    return sum(synthesis_accuracy(p, radar, max_error=e).error_bound
               for p, e in zip((part(echoes, 0, k), part(echoes, k)), shares) if p.num_contributions)


@pytest.fixture
def calls(monkeypatch):
    """The budgets (``max_error``) of the fast sums synthesize runs, one per call; each delegates
    to the real beat_nufft."""
    budgets = []
    real = synthesis.beat_nufft

    def counted(*args, **kwargs):
        budgets.append(kwargs.get("max_error"))
        return real(*args, **kwargs)

    monkeypatch.setattr(synthesis, "beat_nufft", counted)
    return budgets


def test_cached_cube_is_the_sum_of_both_parts_noise_off(radar, calls):
    echoes = frame(radar, room(radar), seed=2)
    cache = {}
    cached = synthesize(echoes, radar, noise=False, static_cache=cache)
    assert len(calls) == 2 and list(cache) == ["room"]
    direct = beat_direct(echoes, radar)
    # tight defaults per part: bounds relative to each part's strength sum, which add up per channel
    bound = split_bound(echoes, radar)
    assert np.abs(cached - direct).max() <= bound + FLOAT32_ROUNDING * np.abs(direct).max()
    whole = synthesize(echoes, radar, noise=False)
    whole_bound = synthesis_accuracy(echoes, radar).error_bound
    assert np.abs(cached - whole).max() <= bound + whole_bound + 2 * FLOAT32_ROUNDING * np.abs(direct).max()
    # the stored cube is the static block's alone
    static = beat_direct(part(echoes, 0, echoes.static_count), radar)
    assert np.abs(cache["room"][2] - static).max() <= split_bound(room(radar), radar)


def test_cached_cube_meets_the_noise_budget_with_the_same_noise(radar, calls):
    echoes = frame(radar, room(radar), seed=3)
    # the synthesis keeps 1 - UPSTREAM_SHARE of the noise budget (the engines' PO merge the rest)
    budget = (1 - UPSTREAM_SHARE) * noise_error_budget(radar)
    cached = synthesize(echoes, radar, noise=True, rng=5, static_cache={})
    # the static part gets a tenth of that, the per-frame part the rest: the sum stays within it
    assert calls == pytest.approx([STATIC_BUDGET_SHARE * budget, (1 - STATIC_BUDGET_SHARE) * budget], rel=1e-12)
    assert split_bound(echoes, radar, max_error=budget) <= budget * (1 + 1e-9)
    whole = synthesize(echoes, radar, noise=True, rng=5)
    noise = thermal_noise(cached.shape, radar, np.random.default_rng(5))  # what both drew after the sum
    direct = beat_direct(echoes, radar)
    # four float32 roundings at most: signal cast, + noise, - noise here, whole's cast
    rounding = 4 * FLOAT32_ROUNDING * (np.abs(direct).max() + np.abs(noise).max())
    assert np.abs((cached - noise) - direct).max() <= budget + rounding
    assert np.abs(cached - whole).max() <= 2 * budget + rounding


def test_second_frame_reuses_the_static_cube(radar, calls):
    static = room(radar)
    cache = {}
    synthesize(frame(radar, static, seed=4), radar, noise=False, static_cache=cache)
    entry = cache["room"]
    assert len(calls) == 2
    second = frame(radar, static, seed=5)  # other movers, same static block
    cube = synthesize(second, radar, frame_time=0.7, noise=False, static_cache=cache)
    assert len(calls) == 3, "only the dynamic part is synthesised again"
    assert cache["room"] is entry and len(cache) == 1
    direct = beat_direct(second, radar)
    assert np.abs(cube - direct).max() <= split_bound(second, radar) + FLOAT32_ROUNDING * np.abs(direct).max()


def test_new_key_or_radar_replaces_the_entry(radar, calls):
    cache = {}
    synthesize(frame(radar, room(radar), seed=6), radar, noise=False, static_cache=cache)
    moved = frame(radar, room(radar, count=90, seed=7, key="room-moved"), seed=6)
    cube = synthesize(moved, radar, noise=False, static_cache=cache)
    assert len(calls) == 4 and list(cache) == ["room-moved"], "one entry: the new block's"
    direct = beat_direct(moved, radar)
    assert np.abs(cube - direct).max() <= split_bound(moved, radar) + FLOAT32_ROUNDING * np.abs(direct).max()
    # same key, another radar (6 dB more power): the stored cube is not that radar's
    louder = radar.replace(tx_power=4 * radar.tx_power)
    cube = synthesize(moved, louder, noise=False, static_cache=cache)
    assert len(calls) == 6 and cache["room-moved"][0] is louder
    direct = beat_direct(moved, louder)
    assert np.abs(cube - direct).max() <= split_bound(moved, louder) + FLOAT32_ROUNDING * np.abs(direct).max()


def test_all_static_and_empty_static_block(radar, calls):
    static = room(radar)
    cache = {}
    cube = synthesize(static, radar, noise=True, rng=8, static_cache=cache)  # nothing dynamic
    assert len(calls) == 1
    stored = cache["room"][2].copy()
    again = synthesize(static, radar, noise=True, rng=8, static_cache=cache)
    assert len(calls) == 1 and np.array_equal(cube, again)
    assert np.array_equal(cache["room"][2], stored), "the noise is not added to the cached cube"
    # a key with an empty block: nothing to cache, the plain fast sum
    movers = targets(radar, 20, 9, 9.0, "person")
    empty = Echoes(movers.a, movers.tau, movers.doppler, static_count=0, static_key="empty-room")
    cube = synthesize(empty, radar, noise=False, static_cache=cache)
    assert np.array_equal(cube, synthesize(movers, radar, noise=False))
    assert list(cache) == ["room"]


def test_direct_method_ignores_the_cache(radar, calls):
    echoes = frame(radar, room(radar, count=10), seed=10, count=5)
    cache = {}
    cube = synthesize(echoes, radar, noise=False, method="direct", static_cache=cache)
    assert cache == {} and len(calls) == 0
    assert np.array_equal(cube, beat_direct(echoes, radar).astype(np.complex64))


def test_leakage_belongs_to_the_dynamic_part(radar):
    echoes = frame(radar, room(radar), seed=11)
    cache = {}
    cube = synthesize(echoes, radar, noise=False, leakage_db=-30.0, static_cache=cache)
    leaky = Echoes.concatenate([echoes, Echoes.leakage(radar, -30.0)])
    assert leaky.static_count == echoes.static_count and leaky.static_key == "room"
    direct = beat_direct(leaky, radar)
    assert np.abs(cube - direct).max() <= split_bound(leaky, radar) + FLOAT32_ROUNDING * np.abs(direct).max()
    # the cached cube is the room's alone, without the leakage tone
    static = beat_direct(part(echoes, 0, echoes.static_count), radar)
    assert np.abs(cache["room"][2] - static).max() <= split_bound(room(radar), radar)


@pytest.mark.parametrize("count, key, field", [(-1, "room", "static_count"), (4, "room", "static_count"),
                                               (1.5, "room", "static_count"), (True, "room", "static_count"),
                                               (2, None, "static_key"), (2, ["room"], "static_key")])
def test_bad_static_block_is_refused(count, key, field):
    z = np.zeros((1, 2, 3))
    with pytest.raises(ValueError, match=f"Echoes.{field}"):
        Echoes(z + 0j, z, z, static_count=count, static_key=key)


def test_concatenate_and_select_keep_the_block_only_as_a_prefix(radar):
    first = room(radar, count=4)
    other = room(radar, count=3, seed=2, key="other")
    joined = Echoes.concatenate([first, other])
    assert (joined.static_count, joined.static_key) == (4, "room")
    np.testing.assert_array_equal(joined.a[..., :4], first.a)
    plain = Echoes.concatenate([targets(radar, 2, 3, 1.0, "person"), first])
    assert (plain.static_count, plain.static_key) == (0, None)
    assert Echoes.empty(3, 4).static_key is None
    kept = joined.select(np.ones(joined.num_contributions, bool))
    assert (kept.static_count, kept.static_key) == (0, None)


def test_concatenate_labels_fast_path_gives_the_same_labels(radar):
    parts = [room(radar, count=4), targets(radar, 3, 4, 2.0, "person-arm"), Echoes.leakage(radar, -30.0)]
    joined = Echoes.concatenate(parts)
    expected = np.concatenate([np.array(p.labels) for p in parts], axis=2)  # the full [M, N, P] arrays
    assert joined.labels.dtype == expected.dtype and np.array_equal(joined.labels, expected)
    assert joined.labels.strides[:2] == (0, 0), "[P] labels stay a broadcast view"
    # a part with labels that differ per element pair: the full arrays are joined
    per_pair = targets(radar, 2, 5, 2.0, "x")
    per_pair = Echoes(per_pair.a, per_pair.tau, per_pair.doppler,
                      np.array([[[f"tx{m}-rx{n}-{p}" for p in range(2)] for n in range(4)] for m in range(3)]))
    mixed = [parts[0], per_pair, parts[2]]
    expected = np.concatenate([np.array(p.labels) for p in mixed], axis=2)
    joined = Echoes.concatenate(mixed)
    assert joined.labels.dtype == expected.dtype and np.array_equal(joined.labels, expected)
    assert joined.labels[1, 2, 5] == "tx1-rx2-1"
    # select: the same labels as selecting in the full arrays
    rng = np.random.default_rng(6)
    for e in (Echoes.concatenate(parts), joined):
        mask = rng.random(e.num_contributions) < 0.5
        assert np.array_equal(e.select(mask).labels, np.array(e.labels)[..., mask])


def test_a_joined_frame_shares_the_static_block_until_its_arrays_are_read(radar):
    """Echoes.concatenate joins the arrays on first read: the synthesizer takes the static block and
    the rest as views (a frame's echoes do not copy the ~3e5-contribution static block), and what is
    read is the join of the parts, bit for bit."""
    static = room(radar, count=6)
    movers = [targets(radar, 3, 7, 4.0, "arm"), targets(radar, 2, 8, 4.0, "leg")]
    joined = Echoes.concatenate([static, Echoes.concatenate(movers)])
    assert joined.shape == (radar.num_tx, radar.num_rx, 11) and "a" not in vars(joined)
    block, rest = joined.contributions(0, joined.static_count), joined.contributions(joined.static_count)
    assert np.shares_memory(block.a, static.a) and "a" not in vars(joined), "the static block is a view"
    assert rest.num_contributions == 5 and rest.static_key is None and rest.labels is None
    for start, stop in [(0, 6), (6, None), (4, 9), (7, 8), (11, 11), (0, None)]:
        np.testing.assert_array_equal(joined.contributions(start, stop).tau,
                                      np.concatenate([static.tau, *(m.tau for m in movers)], axis=2)[..., start:stop])
    expected = np.concatenate([static.a, *(m.a for m in movers)], axis=2)
    np.testing.assert_array_equal(joined.a, expected)
    # the cached cube of the joined frame is the cube of the same contributions given whole
    whole = Echoes(expected, joined.tau, joined.doppler, static_count=6, static_key="whole")
    cache = {}
    np.testing.assert_array_equal(
        synthesize(Echoes.concatenate([static, *movers]), radar, noise=False, static_cache=cache),
        synthesize(whole, radar, noise=False, static_cache={}))


def test_a_joined_frame_carries_doppler_rates_and_replaced_gains(radar):
    """The lazy join covers the optional Doppler rates (zeros for a part without), and a joined frame
    whose gains are replaced (the IF chain's filter) reads the new gains everywhere: in
    :meth:`Echoes.contributions` too, not its parts' old ones."""
    static = room(radar, count=6)
    rng = np.random.default_rng(9)
    accelerating = Echoes.point_targets(radar, [2.0, 3.0], [1.0, -1.0], [0.1, -0.1],
                                        radial_accelerations=[20.0, -30.0])
    joined = Echoes.concatenate([static, accelerating])
    rates = joined.contributions(joined.static_count).doppler_rate
    np.testing.assert_array_equal(rates, accelerating.doppler_rate)
    assert joined.contributions(0, 6).doppler_rate is None
    np.testing.assert_array_equal(joined.doppler_rate[..., :6], 0.0)
    np.testing.assert_array_equal(joined.doppler_rate[..., 6:], accelerating.doppler_rate)
    frozen = Echoes.concatenate([static, accelerating]).frozen()
    assert frozen.doppler_rate is None and frozen.static_count == 6
    gains = np.exp(1j * rng.uniform(0, 2 * np.pi, joined.a.shape[-1]))
    replaced = Echoes.concatenate([static, accelerating])
    replaced.a = replaced.a * gains
    np.testing.assert_array_equal(replaced.contributions(0, 6).a, static.a * gains[:6])
    np.testing.assert_array_equal(replaced.contributions(4, 8).tau, joined.tau[..., 4:8])
    mapped = Echoes.concatenate([static, accelerating]).map_parts(
        lambda e: Echoes(2 * e.a, e.tau, e.doppler, e.labels, doppler_rate=e.doppler_rate,
                         static_count=e.static_count, static_key=e.static_key))
    assert (mapped.static_count, mapped.static_key) == (6, "room") and "a" not in vars(mapped)
    np.testing.assert_array_equal(mapped.a, 2 * joined.a)


@pytest.mark.parametrize("noise", [False, True])
def test_static_block_in_chunks_meets_the_static_budget(radar, calls, noise):
    """The static block summed in chunks (120 contributions in chunks of 50: three) is the direct sum
    within the static block's budget (with noise: the chunks' budgets add up to it, each in proportion
    to its strength sum; without: the tight bounds of the chunks added), and the whole block's
    cube within both bounds; the weighted (phase-noise) cube likewise."""
    from sionnafmcw.synthesis import static_block_cube
    from sionnafmcw.synthesis.nufft import synthesis_accuracy as accuracy_of

    echoes = frame(radar, room(radar), seed=4)
    k = echoes.static_count
    static = part(echoes, 0, k)
    budget = STATIC_BUDGET_SHARE * (1 - UPSTREAM_SHARE) * noise_error_budget(radar) if noise else None
    cube, weighted = static_block_cube(echoes, radar, budget, weighted=True, chunk=50)
    assert len(calls) == 3
    whole, whole_weighted = static_block_cube(echoes, radar, budget, weighted=True)
    assert len(calls) == 4
    direct, direct_weighted = beat_direct(static, radar, weights=synthesis._delay_weights(static, radar))
    rounding = 2 * FLOAT32_ROUNDING * np.abs(direct).max()
    if noise:
        assert sum(calls[:3]) == pytest.approx(budget, rel=1e-12) and max(calls[:3]) < budget
        bound = budget
    else:
        assert calls == [None] * 4
        bound = sum(accuracy_of(part(echoes, a, b), radar).error_bound for a, b in ((0, 40), (40, 80), (80, 120)))
    whole_bound = accuracy_of(static, radar, max_error=budget).error_bound
    assert np.abs(cube - direct).max() <= bound + rounding
    assert np.abs(cube - whole).max() <= bound + whole_bound + rounding
    # the weighted sum's bound (beat_nufft's ``weights``): the plain sum's scaled by the largest weight, or
    # with the constant term alone WEIGHTED_RESIDUAL_MAX of each weighted strength
    from sionnafmcw.synthesis.nufft import WEIGHTED_RESIDUAL_MAX

    weights = np.abs(synthesis._delay_weights(static, radar))
    strength = np.sqrt(radar.tx_power) * (np.abs(static.a) * weights).sum(axis=-1).max()
    bound_w = weights.max() * bound + WEIGHTED_RESIDUAL_MAX * strength
    assert np.abs(weighted - direct_weighted).max() <= bound_w + 2 * FLOAT32_ROUNDING * np.abs(direct_weighted).max()


def test_static_block_chunk_must_be_positive(radar):
    from sionnafmcw.synthesis import static_block_cube

    with pytest.raises(ValueError, match="chunk must be >= 1"):
        static_block_cube(room(radar), radar, None, chunk=0)
