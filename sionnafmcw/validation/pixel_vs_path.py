r"""Pixel-RT against path-RT: the pixel engine (the paper's eq. 2) against the single-bounce path engine.

Both engines end in the same :class:`~sionnafmcw.Echoes`, synthesizer and processing, so any
difference comes from the scattering model. The path engine runs with ``max_depth=1`` (one
bounce: the pixel engine has no multipath), both without receiver noise, on the same animation.

Like with like: by default both engines model the same physics, the coherent share
:math:`(1 - S^2)|\Gamma|^2` by near-field physical optics and the diffuse share :math:`S^2|\Gamma|^2`
by random-phase Lambertian scatterers (``--pixel-model physical-optics``, the pixel engine's
default); ``--pixel-model lambertian`` compares the paper's diffuse-only eq. (2) with it instead.
The metrics name the models (``models``). What follows about the diffuse-only model describes
the latter comparison.

Scenes: ``moving_plate``, ``corner_reflectors`` (moving radially) and ``circle_walk``.
The pixel engine models the diffuse (Lambertian) share :math:`S^2` of the reflected power only;
a smooth surface (:math:`S = 0`, Sionna's and every ITU material's default) is invisible to it,
and the path engine's mirror echo (which grows like :math:`\pi R^2` for a plate facing the radar)
has no counterpart in it. The simple scenes are therefore built *rough*
(``scattering_coefficient=1``) and without a room, so that both engines see the same physical
surface; the walking person keeps its skin (:math:`S = 0.3`, so 91 % of the reflected power is
specular in the path engine) and its room, the paper's setting. There the engines differ by the
specular share, not by the diffuse physics: on circle_walk frame 25 the path engine with
``specular=False`` (1e6 rays, ``max_num_paths_per_src=4e6``) and the pixel engine (256 x 128)
give torso -113.3 / -113.2 dB, the wall facing the radar -96.8 / -96.8 dB, upper legs
-111.7 / -111.4 dB; floor and ceiling differ by 2-3 dB because the pixel field of view
(+-30 degrees in elevation) cuts their near parts.

Metrics per scene (:math:`N` frames, each one CPI):

* ``range_profile_correlation``: Pearson correlation of the two frame-averaged range profiles
  :math:`A(r) = \sqrt{\frac1N\sum_n\sum_{v} P_n(v, r)}` (amplitude, clutter-removed maps for
  scenes with motion); target :math:`\ge 0.95`;
* ``expected_range_profile_correlation`` (reported): the same correlation for the speckle-free
  profiles :func:`expected_range_profile` (moving contributions, power-summed); where the measured
  profiles disagree but these agree, the difference is speckle, not the engines' physics;
* ``range_doppler_correlation``: mean over frames of the Pearson correlation of the amplitude
  range-Doppler maps :math:`\sqrt{P_n}`;
* ``doppler_time_within_one_bin``: fraction of CPIs whose strongest-cell velocities
  (:func:`~sionnafmcw.processing.doppler_time`) differ by at most one Doppler bin; target
  :math:`\ge 0.95`. The cell competes inside a range gate of :math:`\pm` ``gate`` around each
  moving object's truth range (one track per object): with several targets of similar strength
  the strongest cell of the whole map hops between them with their speckle (a rough target is a
  coherent sum of many scatterers, its power exponentially distributed from CPI to CPI), which
  says nothing about either engine;
* ``power_difference_db``: :math:`10\log_{10}(\sum_n\sum_p|a^{pixel}_{p,n}|^2 / \sum_n\sum_p|a^{path}_{p,n}|^2)`,
  the received power the radar equation predicts (summed over contributions, element pairs and
  frames), target :math:`|\cdot| \le 3` dB. ``map_energy_difference_db`` gives the same ratio of
  the (clutter-removed) range-Doppler map energies: one speckle realisation of that power. A rough
  surface is a coherent sum of many scatterers whose phases change with the ray or pixel sampling,
  so its map energy in one CPI is exponentially distributed about the incoherent sum (measured on
  the rough plate: -86.8 to -91.9 dB map energy for 5e4-1e6 rays against a constant -74.3 dB
  :math:`\sum|a|^2`); averaged over :math:`N` decorrelated frames its spread shrinks like
  :math:`1/\sqrt N`;
* ``received_power_db`` / ``received_power_by_object_db`` (reported): :math:`\sum|a|^2` per
  frame, in all and per object hit (the label of the contribution);
* ``angle_peak_difference_deg``: per frame, the azimuth of the maximum of each engine's angle
  spectrum (Bartlett range-azimuth map, TDM-compensated, clutter-removed, summed over range);
  the mean absolute difference, against the array's half-power beamwidth (reported, no target;
  an extended target's single-cell spectrum is speckle, so the map is summed over its cells).

Writes per scene ``<scene>_range_profile.png``, ``<scene>_range_doppler.png``,
``<scene>_doppler_time.png``, ``<scene>_angle.png`` (each engine overlaid or side by side) and
``metrics.json``; prints the metrics JSON last; exit status 1 when a target is missed.

    python validation/pixel_vs_path.py --out out/pixel_vs_path
    python validation/pixel_vs_path.py --scenes moving_plate --frames 8
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .. import engines, plots, processing
from ..array import uniform_azimuth_row
from ..engines import Engine
from ..radar import RadarConfig
from .common import build_scene, run_engine, write_metrics

SCENES = {
    # name: (builder parameters, frames by default)
    "moving_plate": ({"start_range": 3.0, "speed": 1.5, "azimuth": 0.2, "size": 0.5, "room": False,
                      "scattering_coefficient": 1.0, "num_frames": 16}, 16),
    "corner_reflectors": ({"ranges": (3.0, 5.0, 7.0), "azimuths": (-0.3, 0.0, 0.35), "speeds": (0.8, -1.2, 2.0),
                           "leg": 0.3, "room": False, "scattering_coefficient": 1.0, "num_frames": 12}, 12),
    "circle_walk": ({}, 100),
}
#: objects tracked for the Doppler-time agreement (None: every object of the run's truth), gate (m)
TRACKED = {"moving_plate": (None, 0.5), "corner_reflectors": (None, 0.5), "circle_walk": (["torso"], 1.0)}
TARGETS = {"range_profile_correlation": 0.95, "doppler_time_within_one_bin": 0.95, "power_difference_db": 3.0}


def _pearson(a, b) -> float:
    a = np.asarray(a, float).ravel()
    b = np.asarray(b, float).ravel()
    a = a - a.mean()
    b = b - b.mean()
    den = np.sqrt(np.sum(a * a) * np.sum(b * b))
    return float(np.sum(a * b) / den) if den > 0 else float("nan")


def expected_range_profile(echoes, radar, moving_only: bool = True) -> np.ndarray:
    r"""Speckle-free range profile ``[range bin]`` of one frame's echoes (linear, arbitrary scale).

    The range FFT (Hann window :math:`w_s`, :math:`K = N_s` bins) of one contribution with beat
    frequency :math:`\mu\tau` puts :math:`|a|^2|H(k - x)|^2` into bin :math:`k`, with
    :math:`x = \mu\tau K/F_s` and :math:`H(\delta) = \sum_s w_s e^{-j2\pi\delta s/K}`. Summed
    over contributions and element pairs *in power* this is the mean of the measured profile over
    the speckle (the random relative phases of a rough surface's scatterers), which is what two
    engines that sample the same rough surface differently should agree on. ``moving_only``
    leaves out contributions within half a Doppler bin of zero (what clutter removal takes away).
    """
    from ..processing.windows import window_weights

    K = radar.num_samples
    w = window_weights("hann", K)
    a2 = np.abs(echoes.a) ** 2
    keep = a2 > 0
    if moving_only:
        f_bin = 1.0 / (radar.num_chirps * radar.block_interval)
        keep &= np.abs(echoes.doppler) > f_bin / 2
    x = (radar.slope * echoes.tau[keep] * K / radar.fs)
    p = a2[keep]
    base = np.floor(x).astype(np.int64)
    profile = np.zeros(K)
    s = np.arange(K)
    for off in range(-4, 6):
        k = base + off
        inside = (k >= 0) & (k < K)
        delta = k[inside] - x[inside]
        h = np.exp(-2j * np.pi * np.outer(delta, s) / K) @ w if delta.size < 20000 else \
            np.concatenate([np.exp(-2j * np.pi * np.outer(d, s) / K) @ w for d in np.array_split(delta, 1 + delta.size // 20000)])
        np.add.at(profile, k[inside], p[inside] * np.abs(h) ** 2)
    return profile


class _PowerRecorder(Engine):
    r"""An engine that forwards :meth:`echoes` to another one and records, per frame, the received
    power :math:`\sum|a|^2` and the speckle-free range profile (:func:`expected_range_profile`).

    It replaces the whole template method (the wrapped engine runs its own), so the per-frame
    hooks are never called; :meth:`settings` are the wrapped engine's, so the run store records
    the engine that made the echoes.
    """

    def __init__(self, engine: Engine, moving_only: bool = True):
        super().__init__(track_kernels=False)
        self.engine = engine
        self.name = engine.name
        self.moving_only = moving_only
        self.power = {}
        self.profile = {}
        self.by_object = {}

    def echoes(self, animation, radar, frame, radar_pose=None):
        echoes = self.engine.echoes(animation, radar, frame, radar_pose=radar_pose)
        a2 = np.abs(echoes.a) ** 2
        self.power[frame] = float(np.sum(a2))
        for label in np.unique(echoes.labels):
            if label:
                self.by_object[str(label)] = self.by_object.get(str(label), 0.0) + float(a2[echoes.labels == label].sum())
        self.profile[frame] = expected_range_profile(echoes, radar, self.moving_only)
        return echoes

    def settings(self) -> dict:
        return self.engine.settings()

    def close(self) -> None:
        self.engine.close()

    def _settings(self) -> dict:
        return self.engine.settings()

    def _load(self, scene, animation, radar):
        raise NotImplementedError("_PowerRecorder forwards echoes() to its engine")

    def _frame_echoes(self, animation, radar, frame, pose):
        raise NotImplementedError("_PowerRecorder forwards echoes() to its engine")


def _half_power_beamwidth_deg(radar) -> float:
    r"""Broadside half-power beamwidth of the uniform virtual row, :math:`0.886\lambda/(N_v d)` (rad -> deg)."""
    elements, d = uniform_azimuth_row(radar)
    return float(np.rad2deg(0.886 * radar.centre_wavelength / (len(elements) * d)))


def _gated_tracks(run_path, run_pixel, frames, objects, gate: float, clutter_removal: bool) -> dict:
    """Strongest-cell velocity ``[frame, object]`` inside a range gate of +-``gate`` m around each object."""
    radar = run_path.radar
    objects = [o for o in (objects or run_path.objects) if o in run_path.objects]
    rng = {o: run_path.object_range(o) for o in objects}  # [frame] from the phase centre
    out = {}
    for k, run in (("path", run_path), ("pixel", run_pixel)):
        v = np.zeros((len(frames), len(objects)))
        for i, f in enumerate(frames):
            cube = run.cube(f)
            for j, o in enumerate(objects):
                r = rng[o][f]
                track = processing.doppler_time([cube], radar, clutter_removal=clutter_removal,
                                                range_gate=(r - gate, r + gate))
                v[i, j] = track.velocities[0]
        out[k] = v
    out["objects"] = objects
    return out


def compare(run_path, run_pixel, clutter_removal: bool = True, objects=None, gate: float = 0.5,
            frames=None) -> dict:
    """The metrics of the module docstring for two :class:`~sionnafmcw.store.Run` of the same scene and
    radar, on ``frames`` (default: every frame done in the path run)."""
    radar = run_path.radar
    frames = [int(f) for f in (run_path.done_frames if frames is None else frames)]
    n = len(frames)
    profiles = {"path": 0.0, "pixel": 0.0}
    energy = {"path": 0.0, "pixel": 0.0}
    rd_corr, angle_diff, maps = [], [], {}
    az_grid = np.deg2rad(np.arange(-90.0, 90.0001, 0.25))
    for i, f in enumerate(frames):
        cubes = {"path": run_path.cube(f), "pixel": run_pixel.cube(f)}
        rd = {k: processing.range_doppler(c, radar, clutter_removal=clutter_removal) for k, c in cubes.items()}
        power = {k: np.sum(np.abs(v) ** 2, axis=(1, 2)) for k, v in rd.items()}
        for k in power:
            profiles[k] = profiles[k] + power[k].sum(axis=0) / n
            energy[k] += float(power[k].sum())
        rd_corr.append(_pearson(np.sqrt(power["path"]), np.sqrt(power["pixel"])))
        velocities = processing.velocity_axis(radar, rd["path"].shape[0])
        az_peak = {}
        for k, c in cubes.items():
            ramap = processing.range_azimuth_map(c, radar, method="bartlett", azimuths=az_grid,
                                                 clutter_removal=clutter_removal)
            spec = ramap.power.sum(axis=0)
            az_peak[k] = float(az_grid[np.argmax(spec)])
            maps.setdefault(k, []).append(spec)
        angle_diff.append(abs(az_peak["pixel"] - az_peak["path"]))
        if i == n // 2:
            maps["rd"] = {k: processing.RangeDopplerMap(power[k], processing.range_axis(radar, power[k].shape[1]),
                                                        velocities) for k in power}
            maps["angle_frame"], maps["angle_index"] = f, i
    tracks = _gated_tracks(run_path, run_pixel, frames, objects, gate, clutter_removal)
    dv = np.abs(tracks["pixel"] - tracks["path"]).ravel()
    ranges = processing.range_axis(radar, radar.num_samples)
    return {
        "range_profile_correlation": _pearson(np.sqrt(profiles["path"]), np.sqrt(profiles["pixel"])),
        "range_doppler_correlation": float(np.nanmean(rd_corr)),
        "doppler_time_within_one_bin": float(np.mean(dv <= radar.velocity_resolution)),
        "doppler_time_mean_abs_difference": float(np.mean(dv)),
        "map_energy_difference_db": float(10 * np.log10(energy["pixel"] / energy["path"])),
        "angle_peak_difference_deg": float(np.rad2deg(np.mean(angle_diff))),
        "half_power_beamwidth_deg": _half_power_beamwidth_deg(radar),
        "frames": int(n),
        "_profiles": profiles, "_ranges": ranges, "_tracks": tracks, "_maps": maps, "_az_grid": az_grid,
    }


_STYLES = {"path": "b-", "pixel": "r--"}


def _overlay(path: Path, curves: dict, xlabel: str, ylabel: str, title: str, ylim=None, marker: str = "") -> str:
    """One figure with the two engines' curves ``{engine: [(x, y), ...]}`` overlaid (path blue, pixel red)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    for k, lines in curves.items():
        for j, (x, y) in enumerate(lines):
            ax.plot(x, y, marker + _STYLES[k], label=f"{k} engine" if j == 0 else None)
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return plots.save(ax, path)


def _db(p, floor=1e-300):
    return 10 * np.log10(np.maximum(p, floor))


def _plots(out: Path, scene: str, m: dict, times) -> list[str]:
    import matplotlib.pyplot as plt

    engines = ("path", "pixel")
    files = [_overlay(out / f"{scene}_range_profile.png",
                      {k: [(m["_ranges"], _db(m["_profiles"][k]))] for k in engines}, "range (m)", "power (dB W)",
                      f"{scene}: range profile, correlation {m['range_profile_correlation']:.3f}")]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    for ax, k in zip(axes, engines):
        plots.plot_range_doppler(m["_maps"]["rd"][k], ax=ax, title=f"{scene}: {k} engine, frame {m['_maps']['angle_frame']}")
    files.append(plots.save(axes[0], out / f"{scene}_range_doppler.png"))
    tracks = m["_tracks"]
    files.append(_overlay(out / f"{scene}_doppler_time.png",
                          {k: [(times, tracks[k][:, j]) for j in range(len(tracks["objects"]))] for k in engines},
                          "time (s)", "radial velocity (m/s, + receding)",
                          f"{scene}: Doppler-time, {100 * m['doppler_time_within_one_bin']:.0f} % of CPIs within one bin",
                          marker="."))
    f = m["_maps"]["angle_frame"]
    spectra = {k: np.asarray(m["_maps"][k][m["_maps"]["angle_index"]], float) for k in engines}
    files.append(_overlay(out / f"{scene}_angle.png",
                          {k: [(np.rad2deg(m["_az_grid"]), _db(v / v.max(), 1e-12))] for k, v in spectra.items()},
                          "azimuth (deg)", "Bartlett power (dB, normalised)",
                          f"{scene}: angle spectrum (summed over range), frame {f}", ylim=(-40, 2)))
    return files


def _plot_expected(out: Path, scene: str, expected: dict, ranges, corr: float) -> str:
    top = max(float(np.max(v)) for v in expected.values())
    return _overlay(out / f"{scene}_expected_range_profile.png",
                    {k: [(ranges, _db(v / top, 1e-30))] for k, v in expected.items()}, "range (m)",
                    "power (dB, common reference)",
                    f"{scene}: speckle-free range profile (sum of |a|^2), correlation {corr:.3f}", ylim=(-80, 3))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     epilog="example: python validation/pixel_vs_path.py --scenes moving_plate --frames 8")
    parser.add_argument("--out", default="out/pixel_vs_path")
    parser.add_argument("--radar", default="walk-77ghz", help="preset name or RadarConfig JSON file")
    parser.add_argument("--scenes", nargs="+", choices=list(SCENES), default=list(SCENES))
    parser.add_argument("--frames", type=int, default=None, help="frames per scene (default: each scene's own)")
    parser.add_argument("--samples-per-src", type=int, default=1_000_000, help="path engine rays per Tx element")
    parser.add_argument("--n-az", type=int, default=256, help="pixel engine azimuth pixels")
    parser.add_argument("--n-el", type=int, default=128, help="pixel engine elevation pixels")
    parser.add_argument("--array-model", choices=("plane-wave", "exact"), default="exact")
    parser.add_argument("--pixel-model", choices=("physical-optics", "lambertian"), default="physical-optics",
                        help="pixel engine model (default: PO + diffuse, the path engine's physics)")
    parser.add_argument("--no-path-specular", action="store_true",
                        help="path engine without specular reflection (the pixel engine's physics: diffuse only)")
    parser.add_argument("--path-buffer", type=int, default=None,
                        help="path engine max_num_paths_per_src (default 1e6; 4 x rays per source without specular: "
                             "in a room every ray gives a diffuse candidate for each of the 4 Rx elements)")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)

    from ..animation import load_animation

    out = Path(args.out)
    radar = RadarConfig.resolve(args.radar)  # inputs checked before the output folder is made
    out.mkdir(parents=True, exist_ok=True)
    metrics = {"experiment": "pixel_vs_path", "radar": radar.name, "targets": TARGETS, "scenes": {}, "figures": [],
               "path_specular": not args.no_path_specular,
               "models": {"path": "physical optics (coherent share) + random-phase diffuse paths, one bounce",
                          "pixel": {"physical-optics": "physical optics (coherent share) + random-phase diffuse pixels",
                                    "lambertian": "the paper's eq. (2): random-phase diffuse pixels only"}[args.pixel_model]}}
    for scene in args.scenes:
        params, default_frames = SCENES[scene]
        n = default_frames if args.frames is None else int(args.frames)
        params = dict(params)
        if "num_frames" in params:
            params["num_frames"] = max(n, 2)
        animation = load_animation(build_scene(scene, out / "scenes" / scene, params))
        n = min(n, animation.num_frames)
        frames = list(range(n))
        runs, seconds, received, expected, by_object = {}, {}, {}, {}, {}
        buffer = args.path_buffer or (4 * args.samples_per_src if args.no_path_specular else 1_000_000)
        path_options = {"max_depth": 1, "samples_per_src": args.samples_per_src,
                        "max_num_paths_per_src": buffer, "specular": not args.no_path_specular}
        for engine, options in (("path", path_options),
                                ("pixel", {"n_az": args.n_az, "n_el": args.n_el, "array_model": args.array_model,
                                           "model": args.pixel_model})):
            recorder = _PowerRecorder(engines.create(engine, **options))
            runs[engine], sec = run_engine(animation, radar, recorder, out / "runs" / f"{scene}_{engine}.zarr",
                                           frames=frames, noise=False, progress=not args.quiet)
            seconds[engine] = sec / n
            received[engine] = sum(recorder.power.values())
            by_object[engine] = recorder.by_object
            expected[engine] = sum(recorder.profile.values())
        objects, gate = TRACKED[scene]
        m = compare(runs["path"], runs["pixel"], clutter_removal=True, objects=objects, gate=gate, frames=frames)
        times = runs["path"].frame_times[frames]
        metrics["figures"] += _plots(out, scene, m, times)
        public = {k: v for k, v in m.items() if not k.startswith("_")}
        public["power_difference_db"] = float(10 * np.log10(received["pixel"] / received["path"]))
        public["expected_range_profile_correlation"] = _pearson(np.sqrt(expected["path"]), np.sqrt(expected["pixel"]))
        metrics["figures"].append(_plot_expected(out, scene, expected, m["_ranges"],
                                                 public["expected_range_profile_correlation"]))
        public["received_power_db"] = {k: float(10 * np.log10(v / n)) for k, v in received.items()}
        public["received_power_by_object_db"] = {
            k: {o: float(10 * np.log10(p / n)) for o, p in sorted(v.items()) if p > 0} for k, v in by_object.items()}
        public["seconds_per_frame"] = seconds
        public["checks"] = {
            "range_profile_correlation": public["range_profile_correlation"] >= TARGETS["range_profile_correlation"],
            "doppler_time_within_one_bin": public["doppler_time_within_one_bin"] >= TARGETS["doppler_time_within_one_bin"],
            "power_difference_db": abs(public["power_difference_db"]) <= TARGETS["power_difference_db"],
        }
        public["passed"] = all(public["checks"].values())
        metrics["scenes"][scene] = public
    metrics["passed"] = all(s["passed"] for s in metrics["scenes"].values())
    write_metrics(out, metrics)
    return 0 if metrics["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
