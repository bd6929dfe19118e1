"""The detection budget (sionnafmcw.validation.detection_budget): the Hanning leakage against its
closed form, and real synthesised frames of RadHAR's .cfg through the xWR14xx chain: a static
reflector's Doppler-bin +-1 leakage is detected by the CFAR and removed by the Doppler peak
grouping, a reflector moving three bins away at the same range is kept; RadHAR-format point
clouds' moving share per range band."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from sionnafmcw.validation import detection_budget as budget

RADHAR = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "radhar"
if not RADHAR.exists():
    RADHAR = Path("/work/shared/realdata/radhar")
RADHAR_CFG = RADHAR / "1443es1_short_range_3d.cfg"


def _dirichlet(omega: float, n: int) -> complex:
    return complex(np.sum(np.exp(-1j * omega * np.arange(n))))


def test_hanning_leakage_is_the_closed_form():
    """w_l = (1 - cos(phi l))/2, phi = 2 pi/(L-1): W(omega) = D(omega)/2 - D(omega - phi)/4 - D(omega + phi)/4
    with D the L-term geometric sum; at bin k of a N_d-point FFT omega = 2 pi k/N_d. The demo's window
    is Q17 (error < 1e-5)."""
    for chirps in (16, 12, 32):
        size = 1 << math.ceil(math.log2(chirps))
        phi = 2 * math.pi / (chirps - 1)

        def window_sum(k):
            w = 2 * math.pi * k / size
            return abs(0.5 * _dirichlet(w, chirps) - 0.25 * _dirichlet(w - phi, chirps)
                       - 0.25 * _dirichlet(w + phi, chirps))

        for k in (1, 2, 3):
            assert budget.hanning_leakage(chirps, k) == pytest.approx(window_sum(k) / window_sum(0), abs=1e-4)
    assert 20 * math.log10(budget.hanning_leakage(16)) == pytest.approx(-5.24, abs=0.01)


@pytest.mark.skipif(not RADHAR_CFG.exists(), reason="RadHAR's .cfg is not on this machine")
def test_static_leakage_is_grouped_away_and_a_moving_reflector_is_kept():
    """A static 0.3 m^2 reflector at 2 m (far above the CFAR rule): its bins +-1 pass the CFAR
    (-5.2 dB leakage) and none survives the Doppler peak grouping; add a 0.1 m^2 reflector in the same
    range bin receding at 3 Doppler bins: one moving point at |bin| >= 2 is kept."""
    from sionnafmcw.echoes import Echoes
    from sionnafmcw.synthesis import synthesize
    from sionnafmcw.ti.cfg import read_ti_cfg
    from sionnafmcw.ti.processing import processing_from_cfg

    text = RADHAR_CFG.read_text()
    radar, processing = read_ti_cfg(text), processing_from_cfg(text)
    step = radar.centre_wavelength / (2 * radar.num_tx * radar.chirp_interval * 16)
    span = (2.0, 2.0)

    static = Echoes.point_targets(radar, ranges=[2.0], radial_velocities=[0.0], azimuths=[0.1], rcs=[0.3])
    row = budget.frame_budget(synthesize(static, radar, rng=1), radar, processing, span)
    assert row["person_static_hits"] >= 1 and row["person_static_kept"] >= 1
    assert row["person_moving_hits"] >= 2 and row["person_moving_kept"] == 0
    assert row["person_moving_beyond_leakage_hits"] == 0
    assert row["person_static_over_floor_db"] - row["person_moving_over_floor_db"] == pytest.approx(5.24, abs=1.5)

    both = Echoes.point_targets(radar, ranges=[2.0, 2.0], radial_velocities=[0.0, 3 * step], azimuths=[0.1, -0.2],
                                rcs=[0.3, 0.1])
    row = budget.frame_budget(synthesize(both, radar, rng=2), radar, processing, span)
    assert row["person_moving_beyond_leakage_hits"] >= 1 and row["person_moving_kept"] >= 1
    assert row["after_grouping"] <= row["point_limit"]


@pytest.mark.skipif(not (RADHAR / "train").exists(), reason="RadHAR's recordings are not on this machine")
def test_point_cloud_bands_and_the_cli(tmp_path, capsys):
    """Two real recordings per class in a folder of their own: the CLI prints the metrics JSON last,
    the bands' point counts add up to the points beyond 0.3 m that fall in them, moving shares are
    shares; a folder without point clouds, a missing folder or run store and bad --frames are
    one-line errors."""
    for folder in sorted((RADHAR / "train").iterdir())[:2]:
        (tmp_path / "real" / folder.name).mkdir(parents=True)
        for f in sorted(folder.glob("*.npz"))[:2]:
            (tmp_path / "real" / folder.name / f.name).symlink_to(f)
    assert budget.main(["--real", str(tmp_path / "real")]) == 0
    metrics = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    sets = metrics["point_clouds"]["real"]
    assert len(sets) == 2
    for s in sets.values():
        assert 0 < sum(b["points"] for b in s["bands"].values()) <= s["points"]
        assert 0.0 <= s["moving_share"] <= 1.0
        assert sum(s["abs_bin_share"].values()) == pytest.approx(1.0, abs=1e-9)
    (tmp_path / "empty").mkdir()
    assert budget.main(["--real", str(tmp_path / "empty")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no <class>/*.npz" in err[0]
    for argv, words in ((["--real", str(tmp_path / "absent")], "no such folder"),
                        (["--run", str(tmp_path / "absent.zarr")], "absent.zarr"),
                        (["--frames", "1,x"], "--frames")):
        assert budget.main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0]


@pytest.mark.skipif(not RADHAR_CFG.exists(), reason="RadHAR's .cfg is not on this machine")
def test_range_gated_rcs_is_the_radar_equation():
    """A 0.3 m^2 point at 2 m and 20 degrees azimuth, 5 degrees elevation, synthesised without noise
    through RadHAR's radar: the range-gated power read back as an RCS through the element pattern is
    0.3 m^2 times the IF high-pass pair's power gain at the beat frequency, within the anti-alias
    filter's 0.5 dB pass-band ripple; with receiver noise on and subtracted, within 0.5 dB of that."""
    from sionnafmcw.echoes import Echoes
    from sionnafmcw.synthesis import synthesize
    from sionnafmcw.ti.cfg import read_ti_cfg

    radar = read_ti_cfg(RADHAR_CFG.read_text())
    distance, azimuth, elevation, rcs = 2.0, math.radians(20.0), math.radians(5.0), 0.3
    echoes = Echoes.point_targets(radar, ranges=[distance], radial_velocities=[0.4], azimuths=[azimuth],
                                  elevations=[elevation], rcs=[rcs])
    beat = 2 * distance * radar.slope / 299792458.0
    corners = [s["corner"] for s in radar.if_filter if s["type"] == "highpass"]
    assert corners, "RadHAR's radar has TI's two high-pass corners"
    hpf = math.prod(beat ** 2 / (beat ** 2 + c ** 2) for c in corners)
    expected_db = 10 * math.log10(rcs * hpf)
    quiet = budget.range_gated_power(synthesize(echoes, radar, noise=False), radar, (distance, distance), noise=False)
    measured = budget.effective_rcs(quiet, radar, distance, azimuth, elevation)
    assert 10 * math.log10(measured) == pytest.approx(expected_db, abs=0.5)
    noisy = budget.range_gated_power(synthesize(echoes, radar, rng=4), radar, (distance, distance))
    assert 10 * math.log10(budget.effective_rcs(noisy, radar, distance, azimuth, elevation)) == \
        pytest.approx(10 * math.log10(measured), abs=0.5)
