"""The receiver effects: their cost per frame, and the figures of docs/guide/receiver.md.

    .venv/bin/python benchmarks/receiver_effects.py cost [--contributions 100000] [--repeat 5] [--seed 0]
    .venv/bin/python benchmarks/receiver_effects.py figures [--out docs/_static/figures]

``cost``: one walk-77ghz frame (256 chirps x 128 samples x 12 channels, noise on, the production
noise-budgeted NUFFT) with ``--contributions`` random point echoes per channel (1-11 m, +-8 m/s,
+-60 degrees, 1e-4 to 1e-2 m^2: a frame's worth of paths whose echo sum stays inside the ADC),
synthesised with each effect on alone (the TI presets' values: phase noise -93 dBc/Hz at 1 MHz,
the HPF 175 + 350 kHz and complex-1x anti-alias chain, a 16-bit ADC at 30 dB / 0 dBm, I/Q
imbalance 0.5 dB / 3 degrees) and with all of them, against the baseline without. The machine is
shared and its load drifts, so every variant run is paired with a baseline run next to it (in
random order), ``--repeat`` rounds with the variants in a fresh random order each; it prints the
median of the paired wall-time ratios with their quartiles, and of the paired CPU-time ratios
(this process, all threads: less sensitive to other users).

``figures``: writes ``receiver_phase_noise.png``, ``receiver_if_chain.png``, ``receiver_adc_iq.png`` and
``receiver_patterns.png`` to ``--out`` and prints the figures each shows:

* phase noise: range profile of a 1000 m^2 reflector at 3 m on the AWR1843BOOST preset (mean over
  chirps and channels) with and without phase noise, and the closed-form skirt
  :math:`4\\sin^2(\\pi\\nu\\tau)\\mathcal L(\\nu)` per bin above the thermal floor;
* IF chain: range profile of equal targets from 0.1 m to 1.4 R_max with and without the chain, and
  the chain's own response :math:`|H(f)|^2` (scipy) and noise floor;
* ADC and I/Q: an overdriven near target clipping a 16-bit ADC (harmonics), and the I/Q image;
* patterns: the element patterns of the presets in azimuth, with a point target and a path-engine
  plate swept across the field of view (their two-way response, halved).
"""

from __future__ import annotations

import argparse
import random
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from sionnafmcw import Echoes, RadarConfig, synthesize
from sionnafmcw.receiver import phase_noise, ti

ROOT = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------------------------------- cost
def variants(base):
    """The baseline and each effect alone, then all of them (TI values)."""
    effects = {
        "phase noise": dict(phase_noise=[[1e6, -93.0]]),
        "IF chain": dict(if_filter=ti.if_chain(0, 0)),
        "ADC 16 bit": dict(adc_bits=16),
        "I/Q imbalance": dict(iq_imbalance={"gain_db": 0.5, "phase_deg": 3.0}),
    }
    out = {"baseline": base}
    out.update({name: base.replace(**change) for name, change in effects.items()})
    everything = {}
    for change in effects.values():
        everything.update(change)
    out["all"] = base.replace(**everything)
    return out


def random_echoes(radar, count, seed):
    rng = np.random.default_rng(seed)
    return Echoes.point_targets(radar, ranges=rng.uniform(1.0, 11.0, count),
                                radial_velocities=rng.uniform(-8, 8, count),
                                azimuths=np.deg2rad(rng.uniform(-60, 60, count)), rcs=10 ** rng.uniform(-4, -2, count))


def _timed(echoes, radar, seed):
    """(wall s, CPU s of this process, all threads) of one noisy synthesis."""
    w0, c0 = time.perf_counter(), time.process_time()
    synthesize(echoes, radar, rng=seed)
    return time.perf_counter() - w0, time.process_time() - c0


def cost(args) -> None:
    base = RadarConfig.preset("walk-77ghz")
    radars = variants(base)
    effects = [name for name in radars if name != "baseline"]
    echoes = random_echoes(base, args.contributions, args.seed)
    print(f"walk-77ghz cube {base.num_chirps} x {base.num_tx * base.num_rx} x {base.num_samples}, "
          f"{echoes.num_contributions} contributions per channel, noise on; {args.repeat} rounds, each variant "
          "paired with a baseline run next to it (random order within the pair)")
    warnings.simplefilter("ignore")
    synthesize(echoes, base, rng=0)                       # warm-up: finufft, FFT plans
    pairs = {name: [] for name in effects}                # (variant wall, baseline wall, variant CPU, baseline CPU)
    shuffler = random.Random(args.seed)
    for r in range(args.repeat):
        shuffler.shuffle(effects)
        for name in effects:
            order = [name, "baseline"]
            shuffler.shuffle(order)
            t = {k: _timed(echoes, radars[k], r) for k in order}
            pairs[name].append((t[name][0], t["baseline"][0], t[name][1], t["baseline"][1]))
    print(f"{'effect':<15}{'wall s':>8}{'baseline s':>11}{'wall ratio':>11}{'  (quartiles)':<16}{'CPU ratio':>10}")
    for name in variants(base):
        if name == "baseline":
            continue
        p = np.array(pairs[name])
        wall, cpu = p[:, 0] / p[:, 1], p[:, 2] / p[:, 3]
        q1, q3 = np.percentile(wall, [25, 75])
        print(f"{name:<15}{np.median(p[:, 0]):>8.3f}{np.median(p[:, 1]):>11.3f}{np.median(wall):>11.3f}"
              f"  ({q1:.2f}-{q3:.2f})    {np.median(cpu):>10.3f}")


# ---------------------------------------------------------------------------------------- figures
def _profile(cube, window=None):
    r"""Mean range power over chirps and channels, :math:`|\mathrm{FFT}(w x)|^2/\sum w^2` (W per bin: white noise
    of power :math:`\sigma^2` per sample reads :math:`\sigma^2`; rectangular window unless given)."""
    x = cube.astype(np.complex128)
    w = np.ones(cube.shape[-1]) if window is None else window
    return (np.abs(np.fft.fft(x * w, axis=-1)) ** 2).mean(axis=(0, 1, 2)) / np.sum(w ** 2)


def _hann(n):
    return np.hanning(n + 2)[1:-1]


def figure_phase_noise(out: Path, plt) -> None:
    # 64 loops x 3 Tx: 192 chirps; a 1000 m^2 corner reflector at 3 m, 20 dB receiver gain (inside the ADC)
    radar = RadarConfig.preset("ti-awr1843boost").replace(num_chirps=64, rx_gain=20.0)
    off = radar.replace(phase_noise=None)
    target = Echoes.point_targets(radar, [3.0], [0.0], [0.0], rcs=[1000.0])
    n = radar.num_samples
    w = _hann(n)      # Hann: the carrier's own sidelobes stay under the skirt (a rectangular window's do not)
    with_pn = _profile(synthesize(target, radar, rng=1), w)
    without = _profile(synthesize(target, off, rng=1), w)
    # reference: the carrier's on-bin peak |A|^2 (sum w)^2 / sum w^2, free of scalloping
    carrier = np.mean(np.abs(synthesize(target, off, noise=False).astype(np.complex128)) ** 2)
    carrier *= w.sum() ** 2 / np.sum(w ** 2)
    ranges = np.arange(n) * radar.range_resolution
    tau = 2 * 3.0 / 299792458.0
    peak = int(np.argmax(without))
    offset = ((np.arange(n) - peak + n // 2) % n - n // 2) * radar.fs / n
    skirt = np.full(n, np.nan)
    ok = offset != 0
    enbw = n * np.sum(w ** 2) / w.sum() ** 2     # the window's noise bandwidth in bins (1.5 for Hann): noise-like
    # the skirt against the peak it spreads from
    skirt[ok] = carrier * 10 ** (phase_noise.skirt_dbc(radar.phase_noise, offset[ok], tau) / 10) * radar.fs / n * enbw
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    ax.plot(ranges, 10 * np.log10(without / carrier), lw=1, label="phase noise off")
    ax.plot(ranges, 10 * np.log10(with_pn / carrier), lw=1, label="phase noise on (-93 dBc/Hz at 1 MHz)")
    ax.plot(ranges, 10 * np.log10(skirt / carrier), "k--", lw=1,
            label=r"closed form $4\sin^2(\pi\nu\tau)\mathcal{L}(\nu)\,(F_s/N)\,\mathrm{ENBW}$")
    ax.set_xlabel("range (m)")
    ax.set_ylabel("power re. the carrier (dB)")
    ax.set_ylim(-110, 5)
    ax.set_title("AWR1843BOOST, 1000 m$^2$ at 3 m: range profile (Hann), mean of 192 chirps x 12 channels",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(out / "receiver_phase_noise.png", dpi=110)
    far = (np.abs(offset) > 20 * radar.fs / n) & ok
    measured = 10 * np.log10((with_pn - without)[far].mean() / carrier)
    print(f"phase noise: skirt 20+ bins from the carrier {measured:.2f} dB re. carrier per bin (mean of "
          f"{far.sum()} bins), closed form {10 * np.log10(np.nanmean(skirt[far]) / carrier):.2f} dB; thermal floor "
          f"{10 * np.log10(np.median(without) / carrier):.1f} dB")


def figure_if_chain(out: Path, plt) -> None:
    from sionnafmcw.receiver import if_filter

    radar = RadarConfig.preset("ti-awr1843boost").replace(num_chirps=32, phase_noise=None, adc_bits=None)
    ideal = radar.replace(if_filter=None)
    ranges = np.array([0.15, 0.5, 2.0, 5.0, 8.0, 9.5, 10.5, 12.3, 14.0, 15.5])
    echoes = Echoes.point_targets(radar, ranges, np.zeros(ranges.size), np.zeros(ranges.size),
                                  rcs=(ranges / 3.0) ** 4)                  # equal echo power at every range
    n = radar.num_samples
    hann = _hann(n)
    chained = _profile(synthesize(echoes, radar, rng=2), hann)
    plain = _profile(synthesize(echoes, ideal, rng=2), hann)
    f = np.arange(n) * radar.fs / n
    axis_m = f / radar.fs * radar.max_range
    ref = plain.max()
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    ax.plot(axis_m, 10 * np.log10(plain / ref), lw=1, label="ideal receiver (targets beyond R_max alias whole)")
    ax.plot(axis_m, 10 * np.log10(chained / ref), lw=1, label="TI IF chain: HPF 175+350 kHz, complex-1x anti-alias")
    h2 = np.abs(if_filter.response(radar.if_filter, f[1:], radar.fs)) ** 2
    ax.plot(axis_m[1:], 10 * np.log10(h2), "k--", lw=1, label="|H(f)|$^2$ (scipy.signal, the same filter)")
    floor = radar.noise_power * if_filter.noise_gain(radar.if_filter, f, radar.fs)
    ax.plot(axis_m, 10 * np.log10(floor / ref), "k:", lw=1, label=r"noise floor $kT_0F\sum_k|H(f+kF_s)|^2$")
    for r in ranges[ranges > radar.max_range]:
        ax.axvline(r - radar.max_range, color="tab:red", lw=0.5, alpha=0.5)
    ax.set_xlabel("range bin (m); red: folded targets beyond R_max = %.1f m" % radar.max_range)
    ax.set_ylabel("power re. strongest (dB)")
    ax.set_ylim(-120, 5)
    ax.set_title("AWR1843BOOST: equal-power targets 0.15-15.5 m, with and without the IF chain")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(out / "receiver_if_chain.png", dpi=110)
    for r in ranges:                        # each target alone, noise-free: its peak with the chain over without
        one = Echoes.point_targets(radar, [r], [0.0], [0.0])
        a = np.fft.fft(synthesize(one, radar, noise=False)[0, 0, 0].astype(complex))
        b = np.fft.fft(synthesize(one, ideal, noise=False)[0, 0, 0].astype(complex))
        k = int(np.argmax(np.abs(b)))
        freq = 2 * r / 299792458.0 * radar.slope
        print(f"IF chain: target {r:5.2f} m (beat {freq / 1e6:6.3f} MHz): {20 * np.log10(abs(a[k] / b[k])):7.2f} dB "
              f"vs |H|^2 {10 * np.log10(abs(if_filter.response(radar.if_filter, freq, radar.fs)) ** 2):7.2f} dB")


#: RCS (m^2) of the near target that overdrives the ADC in the figure (its peaks clip, about 15 % of I/Q values).
RCS_CLIPPING = 230.0


def figure_adc_iq(out: Path, plt) -> None:
    radar = RadarConfig.preset("ti-awr1843boost").replace(num_chirps=32, phase_noise=None)
    n = radar.num_samples
    axis_m = np.arange(n) / n * radar.max_range
    loud = Echoes.point_targets(radar, [1.2, 6.0], [0.0, 0.0], [0.0, 0.0], rcs=[RCS_CLIPPING, 1.0])
    w = _hann(n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stats = {}
        clipped = _profile(synthesize(loud, radar, rng=3, stats=stats), w)
    unclipped = _profile(synthesize(loud, radar.replace(adc_bits=None), rng=3), w)
    iq = radar.replace(iq_imbalance={"gain_db": 0.5, "phase_deg": 3.0})
    target = Echoes.point_targets(radar, [4.0], [0.0], [0.0], rcs=[10.0])
    image = _profile(synthesize(target, iq, rng=4), w)
    clean = _profile(synthesize(target, radar, rng=4), w)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.0), sharey=True)
    ref = unclipped.max()
    axes[0].plot(axis_m, 10 * np.log10(unclipped / ref), lw=1, label="no ADC in the cube")
    axes[0].plot(axis_m, 10 * np.log10(clipped / ref), lw=1,
                 label=f"16-bit ADC, 30 dB, 0 dBm: {100 * stats['adc_clipped'] / stats['adc_values']:.1f} % clipped")
    axes[0].set_title(f"{RCS_CLIPPING:g} m$^2$ at 1.2 m + 1 m$^2$ at 6 m: clipping harmonics (Hann)", fontsize=10)
    ref = clean.max()
    axes[1].plot(axis_m, 10 * np.log10(clean / ref), lw=1, label="no I/Q imbalance")
    axes[1].plot(axis_m, 10 * np.log10(image / ref), lw=1, label="0.5 dB, 3 deg: image at -28.2 dB")
    axes[1].set_title("10 m$^2$ at 4 m: the I/Q image at the mirrored bin (Hann)", fontsize=10)
    for ax in axes:
        ax.set_xlabel("range bin (m)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
        ax.set_ylim(-100, 5)
    axes[0].set_ylabel("power re. peak (dB)")
    fig.tight_layout()
    fig.savefig(out / "receiver_adc_iq.png", dpi=110)
    k = int(np.argmax(clean))
    print(f"ADC: {stats['adc_clipped']} of {stats['adc_values']} I/Q values clipped; I/Q image "
          f"{10 * np.log10(image[(n - k) % n] / image[k]):.2f} dB (closed form -28.20 dB)")


def figure_patterns(out: Path, plt) -> None:
    import tempfile

    sys.path.insert(0, str(ROOT / "tests"))
    from animation_helpers import write_plate_animation

    from sionnafmcw import processing
    from sionnafmcw.animation import load_animation
    from sionnafmcw.antenna import element_pattern
    from sionnafmcw.engines import PathEngine

    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    az = np.deg2rad(np.linspace(-90, 90, 361))
    for name in ("tr38901", "ti-awr1843boost", "ti-iwr1443boost", "ti-iwr6843isk"):
        g = element_pattern(name)
        ax.plot(np.rad2deg(az), 10 * np.log10(g.power_gain(np.pi / 2, az)), lw=1, label=f"{name}")
    radar = RadarConfig.preset("ti-awr1843boost").replace(phase_noise=None, if_filter=None, adc_bits=None)
    g = element_pattern("ti-awr1843boost")
    sweep = np.deg2rad(np.arange(-70.0, 71.0, 10.0))
    peaks = []
    for a in sweep:
        cube = synthesize(Echoes.point_targets(radar, [10.0], [0.0], [a]), radar, noise=False)
        rdmap = processing.range_doppler_map(cube, radar, n_range=4 * radar.num_samples)
        peaks.append(rdmap.power.max())
    point = g.peak_gain_db() + 0.5 * 10 * np.log10(np.array(peaks) / peaks[len(peaks) // 2])
    ax.plot(np.rad2deg(sweep), point, "o", ms=5, mfc="none", color="tab:orange",
            label="AWR1843BOOST point target, two-way response / 2")
    with tempfile.TemporaryDirectory() as tmp:
        anim = load_animation(write_plate_animation(Path(tmp) / "plate", distance=5.0, velocity=(0.0, 0.0, 0.0),
                                                    num_frames=1, size=(2.0, 2.0)))
        engines = {k: PathEngine(physical_optics=False, samples_per_src=2000) for k in ("iso", "board")}
        radars = {"iso": radar.replace(antenna_pattern="iso"), "board": radar}
        plate = []
        for yaw in -sweep:
            pose = ((0.0, 0.0, 0.0), (yaw, 0.0, 0.0))
            a = {k: engines[k].echoes(anim, radars[k], 0, radar_pose=pose).a[..., 0] for k in engines}
            plate.append(10 * np.log10(np.mean(np.abs(a["board"]) / np.abs(a["iso"]))))
    ax.plot(np.rad2deg(sweep), plate, "x", ms=6, color="tab:orange", label="AWR1843BOOST plate, path engine")
    ax.set_xlabel("azimuth (deg)")
    ax.set_ylabel("element gain (dBi)")
    ax.set_ylim(-25, 14)
    ax.set_title("Element patterns in azimuth; swept targets through synthesis and Sionna")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower center")
    fig.tight_layout()
    fig.savefig(out / "receiver_patterns.png", dpi=110)
    expected = 10 * np.log10(g.power_gain(np.pi / 2, sweep))
    print(f"patterns: point target sweep max |error| {np.abs(point - expected).max():.3f} dB, plate sweep "
          f"{np.abs(np.array(plate) - expected).max():.3f} dB over {expected.max() - expected.min():.1f} dB of pattern")


def figures(args) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for make in (figure_phase_noise, figure_if_chain, figure_adc_iq, figure_patterns):
        make(out, plt)
    print(f"figures in {out}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    c = sub.add_parser("cost")
    c.add_argument("--contributions", type=int, default=100_000)
    c.add_argument("--repeat", type=int, default=5)
    c.add_argument("--seed", type=int, default=0)
    f = sub.add_parser("figures")
    f.add_argument("--out", default=str(ROOT / "docs" / "_static" / "figures"))
    args = parser.parse_args(argv)
    (cost if args.command == "cost" else figures)(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
