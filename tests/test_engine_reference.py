"""Both engines' echoes on fixed scenes equal, bit for bit, those stored before the engine redesign."""

import numpy as np
import pytest

from engine_reference import REFERENCE, compute


@pytest.fixture(scope="module")
def computed(tmp_path_factory):
    return compute(tmp_path_factory.mktemp("engine_reference"))


def test_reference_echoes_bit_for_bit(computed):
    stored = np.load(REFERENCE)
    assert sorted(stored.files) == sorted(computed)
    for key in stored.files:
        ref, now = stored[key], computed[key]
        assert ref.dtype == now.dtype and ref.shape == now.shape, key
        np.testing.assert_array_equal(now, ref, err_msg=key)
