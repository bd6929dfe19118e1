"""The xWR14xx chain's peakVal validation against RadHAR (validation/ti_sdk2_scale.py), reduced:
real .npz recordings read, real synthesis through the chain, the metrics JSON printed last and
written to metrics.json."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sionnafmcw.validation import ti_sdk2_scale

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "radhar" / "train"
if not REAL.exists():
    REAL = Path("/work/shared/realdata/radhar/train")


@pytest.mark.skipif(not REAL.exists(), reason="RadHAR's recordings are not on this machine")
def test_validation_prints_and_writes_its_metrics(tmp_path, capsys):
    """Three frames per case: every reflector of 0.01-1 m^2 at 2-3 m is detected (25 dB over the
    noise is the rule's level; 0.01 m^2 at 3 m is ~31 dB), noise alone gives no point, and no
    simulated peakVal reaches the IWR1443's 32767 limit; the real percentiles are RadHAR's own."""
    status = ti_sdk2_scale.main(["--real", str(REAL), "--frames", "3", "--out", str(tmp_path)])
    metrics = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert status == 0
    assert metrics == json.loads((tmp_path / "metrics.json").read_text())
    sim = metrics["simulated"]
    for rcs in ti_sdk2_scale.RCS_M2:
        row = sim[f"rcs_{rcs:g}_m2"]
        assert row["frames_detected"] == 3
        assert 0 < row["percentiles"]["99"] < 32767
    assert sim["noise_only"]["points_per_frame_max"] == 0
    real = metrics["real"]
    assert real["all"]["points"] > real["moving_1.5_3.2_m"]["points"] > 0
    assert real["frames"] > 0 and real["points_per_frame_beyond_6_m"] >= 0.0
    assert real["all"]["percentiles"]["5"] <= real["all"]["percentiles"]["50"] <= real["all"]["percentiles"]["95"]


def test_bad_folder_is_one_line(tmp_path, capsys):
    assert ti_sdk2_scale.main(["--real", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no RadHAR .npz recordings" in err[0]
