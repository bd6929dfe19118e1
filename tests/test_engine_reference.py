"""Both engines' echoes on fixed scenes equal those stored (tests/engine_reference.py): bit for bit on the
platform that wrote them, elsewhere within what a 1 µm change of the geometry moves them."""

import numpy as np
import pytest

from engine_reference import COUNT_TOLERANCE, POWER_TOLERANCE_DB, REFERENCE, compute, platform_tag


@pytest.fixture(scope="module")
def computed(tmp_path_factory):
    return compute(tmp_path_factory.mktemp("engine_reference"))


def test_reference_echoes(computed):
    stored = np.load(REFERENCE)
    files = [k for k in stored.files if k != "#platform"]
    assert sorted(files) == sorted(computed)
    if str(stored["#platform"]) == platform_tag():
        for key in files:
            ref, now = stored[key], computed[key]
            assert ref.dtype == now.dtype and ref.shape == now.shape, key
            np.testing.assert_array_equal(now, ref, err_msg=key)
        return
    # another CPU or Dr.Jit: Dr.Jit's kernels round differently (tests/engine_reference.py)
    for key in files:
        if key.endswith("#count"):
            assert abs(int(computed[key]) - int(stored[key])) <= COUNT_TOLERANCE * int(stored[key]), key
        elif key.endswith("#power"):
            ratio_db = 10 * np.log10(computed[key] / stored[key])
            assert np.max(np.abs(ratio_db)) <= POWER_TOLERANCE_DB, key
