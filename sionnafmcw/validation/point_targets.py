"""Analytic point targets through synthesis and processing, as a report with plots.

Targets with known range, radial velocity, azimuth and RCS are synthesized with thermal noise
(walk-77ghz preset by default) and processed: range-Doppler map, range-azimuth map, and per
target the interpolated range, velocity and azimuth and the peak SNR, compared with

* range: the range at the CPI centre plus the FMCW range-Doppler coupling
  (``processing.range_doppler_coupling``), within 0.1 range bin;
* velocity: within 0.1 Doppler bin; azimuth: within 1 degree;
* SNR: the radar equation, :math:`N_s L P_r / (k T_0 F F_s)` per channel times the coherent
  gain of the :math:`MN` virtual channels, less the Hann windows' processing loss, within 0.5 dB.

Writes ``range_doppler.png``, ``range_azimuth.png`` and ``metrics.json`` to ``--out`` and prints
the metrics JSON as its last line. Exit status 1 when a check fails.

    python validation/point_targets.py --out out/point_targets [--radar walk-77ghz]
    sionnafmcw validate point_targets --out out/point_targets
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from sionnafmcw import Echoes, RadarConfig, plots, processing, synthesize


def window_loss(n: int) -> float:
    """Hann processing loss (coherent gain^2 / noise gain), linear, for an n-point window."""
    from scipy.signal import get_window

    w = get_window("hann", n)
    return w.sum() ** 2 / (n * (w**2).sum())


def analyse(radar, targets, seed=0):
    ranges, speeds, azimuths, rcs = (np.asarray(t, float) for t in zip(*targets))
    echoes = Echoes.point_targets(radar, ranges, speeds, azimuths, rcs=rcs)
    cube = synthesize(echoes, radar, rng=seed)
    # 4x zero padding on both axes: scalloping below 0.1 dB and sub-bin peaks for interpolation
    pad = dict(n_range=4 * radar.num_samples, n_doppler=4 * radar.num_chirps)
    rd = processing.range_doppler(cube, radar, **pad)
    velocities = processing.velocity_axis(radar, rd.shape[0])
    rd = processing.tdm_phase_compensation(rd, radar, velocities)
    rdmap = processing.range_doppler_map(cube, radar, **pad)
    # noise floor: a map cell sums MN channels of exponential noise, so it is Gamma(MN)-distributed;
    # the median over the map (targets are a handful of cells) scaled to the Gamma mean
    from scipy.stats import gamma

    channels = radar.num_tx * radar.num_rx
    noise = np.median(rdmap.power) * channels / gamma(channels).median()
    centre = radar.phase_centre
    t_centre = 0.5 * radar.cpi_duration
    rows = []
    for r, v, az, sigma in zip(ranges, speeds, azimuths, rcs):
        i_v = int(np.argmin(np.abs(velocities - v)))
        i_r = int(np.argmin(np.abs(rdmap.ranges - r)))
        # strongest cell within +-2 bins of the truth
        sl = (slice(max(i_v - 8, 0), i_v + 9), slice(max(i_r - 8, 0), i_r + 9))
        sub = rdmap.power[sl]
        di, dk = np.unravel_index(np.argmax(sub), sub.shape)
        i_v, i_r = sl[0].start + di, sl[1].start + dk
        fv = processing.interpolate_peak(rdmap.power, (i_v, i_r), axis=0, circular=True)
        fr = processing.interpolate_peak(rdmap.power, (i_v, i_r), axis=1)
        v_est = np.interp(fv, np.arange(len(velocities)), velocities)
        r_est = np.interp(fr, np.arange(len(rdmap.ranges)), rdmap.ranges)
        # range is measured from the virtual array's phase centre, not the radar frame origin
        u = np.array([np.cos(az), np.sin(az), 0.0])
        r_centre = np.linalg.norm(r * u - centre)
        r_expected = r_centre + v * t_centre + float(processing.range_doppler_coupling(v, radar))
        az_est, _, _ = processing.estimate_direction(rd[i_v, :, :, i_r].reshape(-1), radar, elevation=False)
        # radar equation: per-channel received power, coherent over samples and chirps (Hann
        # losses), non-coherent sum over MN channels in the map; per-channel gains from Echoes
        p_r = radar.tx_power * np.abs(Echoes.point_targets(radar, [r], [v], [az], rcs=[sigma]).a) ** 2
        loss = window_loss(radar.num_samples) * window_loss(radar.num_chirps)
        snr_expected = radar.num_samples * radar.num_chirps * p_r.sum() * loss / radar.noise_power / (
            radar.num_tx * radar.num_rx)
        # zero padding leaves the noise per bin unchanged and the peak of an on-grid target too
        snr = (rdmap.power[i_v, i_r] - noise) / noise
        rows.append({
            "range_m": r, "velocity_mps": v, "azimuth_deg": float(np.rad2deg(az)), "rcs_m2": sigma,
            "range_error_bins": float((r_est - r_expected) / radar.range_resolution),
            "velocity_error_bins": float((v_est - v) / radar.velocity_resolution),
            "azimuth_error_deg": float(np.rad2deg(az_est - az)),
            "snr_db": float(10 * np.log10(snr)), "snr_expected_db": float(10 * np.log10(snr_expected)),
        })
    ramap = processing.range_azimuth_map(cube, radar)
    return rows, rdmap, ramap


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/point_targets")
    parser.add_argument("--radar", default="walk-77ghz", choices=RadarConfig.presets())
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    radar = RadarConfig.preset(args.radar)
    vmax, rmax = radar.max_velocity, radar.max_range
    targets = [  # range (m), v_r (m/s), azimuth (rad), RCS (m^2)
        (0.30 * rmax, 0.45 * vmax, np.deg2rad(-30.0), 1.0),
        (0.55 * rmax, -0.25 * vmax, np.deg2rad(12.0), 0.5),
        (0.75 * rmax, 0.10 * vmax, np.deg2rad(40.0), 2.0),
    ]
    rows, rdmap, ramap = analyse(radar, targets, args.seed)
    truth = [(t[0], t[1]) for t in targets]
    plots.save(plots.plot_range_doppler(rdmap, truth=truth, title=f"Range-Doppler, {radar.name}"),
               out / "range_doppler.png")
    plots.save(plots.plot_range_azimuth(ramap, truth=[(t[0], t[2]) for t in targets],
                                        title=f"Range-azimuth, {radar.name}"), out / "range_azimuth.png")
    checks = {
        "range_within_0.1_bin": all(abs(r["range_error_bins"]) <= 0.1 for r in rows),
        "velocity_within_0.1_bin": all(abs(r["velocity_error_bins"]) <= 0.1 for r in rows),
        "azimuth_within_1_deg": all(abs(r["azimuth_error_deg"]) <= 1.0 for r in rows),
        "snr_within_0.5_db": all(abs(r["snr_db"] - r["snr_expected_db"]) <= 0.5 for r in rows),
    }
    metrics = {"radar": radar.name, "targets": rows, "checks": checks, "passed": all(checks.values())}
    (out / "metrics.json").write_text(json.dumps(metrics, indent=1))
    print(json.dumps(metrics))
    return 0 if metrics["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
