"""Static blocks kept across runs of one process (:func:`sionnafmcw.engines.path.keep_static_blocks`): a run
whose static scene (meshes, materials, radar, pose, settings) equals the last one's takes its static block and
static cube, with Sionna's object ids of its own load, and writes the cubes a fresh run writes, bit for bit; a
different room is built anew."""

from __future__ import annotations

import numpy as np
import pytest

from sionnafmcw import simulate
from sionnafmcw.engines import PathEngine
from sionnafmcw.engines.path import keep_static_blocks, static_blocks_kept
from sionnafmcw.radar import RadarConfig
from sionnafmcw.scenes import build
from sionnafmcw.sionna_rt import INVALID_SHAPE

#: A small cube (walk-77ghz with 8 chirps): the block is what is tested, not the cube size.
RADAR = RadarConfig.preset("walk-77ghz").replace(num_chirps=8)
FRAMES = 2


def people_room(root, seed, margin=0.5):
    """One person walking a circle in a closed room; the room depends on ``margin`` only, the person on ``seed``."""
    return build("people", root, overwrite=True, num_frames=FRAMES, fps=30.0, num_people=1, room=True,
                 activity="walk_circle", seed=seed, max_range=3.0, room_margin=margin)


def run(scene, out, engine=None):
    engine = PathEngine(samples_per_src=20_000) if engine is None else engine
    cubes = simulate(scene, RADAR, engine=engine, out=out, progress=False, seed=3).cubes(range(FRAMES))
    return cubes, engine.stats[0].figures["static_seconds"]


def object_ids_of(engine) -> tuple:
    """The Sionna object ids the engine's static block holds (paths, PO samples, one-object chains) and the
    ids of the static objects in the engine's own scene."""
    static, scene = engine._state.static, engine._loaded.scene
    held = set(np.unique(static.paths.shapes).tolist()) - {int(INVALID_SHAPE)}
    for r in static.po.renders:
        held |= set(np.unique(r.samples.object_id).tolist()) | (set(np.unique(r.one_object).tolist()) - {-1})
    return held, {int(scene.objects[n].object_id) for n in static.object_ids}


@pytest.fixture
def keeping():
    keep_static_blocks(True)
    yield
    keep_static_blocks(False)


def test_a_kept_block_gives_the_fresh_runs_cubes(tmp_path, keeping):
    first, second = people_room(tmp_path / "a", seed=1), people_room(tmp_path / "b", seed=2)
    other_room = people_room(tmp_path / "c", seed=2, margin=0.8)
    earlier = PathEngine(samples_per_src=20_000)    # alive: the next load's object ids are new ones
    _, built = run(first, tmp_path / "a.zarr", earlier)
    assert built > 0 and static_blocks_kept()
    engine = PathEngine(samples_per_src=20_000)
    kept, seconds = run(second, tmp_path / "b.zarr", engine)
    assert seconds == 0.0, "the same room, radar and settings: the block is taken, not built"
    held, own = object_ids_of(engine)
    assert held and held <= own, "the kept block names the objects by the ids of this run's load"
    assert not held & object_ids_of(earlier)[1], "ids of the earlier load (the test needs them to differ)"
    _, seconds = run(other_room, tmp_path / "c.zarr")
    assert seconds > 0, "another room is built anew"
    keep_static_blocks(False)
    fresh, seconds = run(second, tmp_path / "b_fresh.zarr")
    assert seconds > 0
    np.testing.assert_array_equal(kept, fresh)
