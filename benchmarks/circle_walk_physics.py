"""The paper's circle walk under two engine models: the scattering physics, or motion within the CPI.

``--models physics`` (default):

``before``: ``PathEngine(physical_optics=False, random_phase=False)`` (one coherent trace, Sionna's
geometric-optics mirror paths, diffuse paths with their deterministic phases); ``after``: the
defaults (PO direct echo from the render of ``engines/po_render.py``, Sionna's first-order
specular paths dropped, random phase fixed to every diffuse scatterer). Same scene (``circle_walk``,
radar walk-77ghz), same rays (``--samples-per-src``, depth 1 as ``validation/circle_walk.py``), same
solver seeds (``--seeds``), same noise seed; for every solver seed the two runs follow each other
(``before`` first, then ``after``) so that both see the same machine load.

``--models cpi_motion``: ``frozen`` (``PathEngine(cpi_motion="frozen")``, the defaults:
every contribution keeps the frame's Doppler over the CPI) against ``quadratic``
(``cpi_motion="quadratic"``: every contribution's Doppler rate from the accelerations of its
interaction points, the Doppler sweeping across the CPI).

Per run: the paper's estimator (strongest cell after static clutter removal,
``sionnafmcw.validation.circle_walk.analyse``) against the torso's truth: ``e_velo`` and the
fraction within one Doppler bin, and ``e_velo_cpi_centre`` (against the torso's truth at the CPI centre);
per CPI whether a limb outshines the torso (noise-free, clutter-removed range-Doppler maps of the
limb contributions -- arms, legs, feet -- and of the torso's, peak against peak, from the frame's
echoes; with the noise budget of ``simulate``) and whether the limbs' map is above the torso's in the
strongest cell of the run's own (noisy, clutter-removed) map, the cell the estimator picks
(``limb_cell``); the engine's and ``simulate``'s seconds per frame;
``doppler_time_<model>_seed<k>.png`` (the paper's Fig. 3) in ``--out``.

    python benchmarks/circle_walk_physics.py --frames 100 --seeds 1 2 3 --out out/circle_walk_physics
    python benchmarks/circle_walk_physics.py --models cpi_motion --frames 100 --seeds 1 2 3 --scene DIR

Measured (100 frames, solver seeds 1, 2, 3, ``--samples-per-src 100000`` -- 1e6 rays puts ~1e6
diffuse room paths x 12 pairs through the synthesizer per frame, beyond this session's two shared
cores --, depth 1, noise seed 0; seed 3 run as its own process ``--seeds 3``, and its ``before``
repeated bit for bit by the first process):

========  =====================  ==================  ===================  ====================
model     e_velo per seed (m/s)  mean e_velo (m/s)   limb > torso (CPIs)  within one bin
========  =====================  ==================  ===================  ====================
before    0.562, 0.634, 0.416    0.537               60, 70, 65           0.30, 0.20, 0.28
after     0.338, 0.318, 0.311    0.322               48, 49, 45           0.41, 0.41, 0.46
========  =====================  ==================  ===================  ====================

Median torso-map peak -121 dB after against -130 dB before (limbs -124.5 against -129.5): PO gives
the torso a specular echo that the diffuse-only body lacked. Seconds per frame, the two models of a
seed under the same load: engine 2.1 -> 4.6 and simulate 2.6 -> 6.6 (seed 2), engine 2.05 -> 3.5
and simulate 2.8 -> 4.1 (seed 3); the PO render of the room (1.5e5 of 1.9e5 samples) is most of
the difference.

``--models cpi_motion`` measured (100 frames, solver seeds 1, 2, 3, the defaults: 32 mm
rigid walker on its smooth PO surface, ``--samples-per-src`` default, scene built by the script)::

    model      e_velo per seed      mean   e_velo (CPI centre)  within one bin    limb > torso  limb cell
    frozen     0.474 0.458 0.452    0.461  0.523 0.502 0.493    0.42 0.43 0.43    41 43 46      39 38 40
    quadratic  0.471 0.463 0.496    0.477  0.411 0.403 0.440    0.11 0.16 0.18    44 44 48      42 41 40

The limbs win as often with the Doppler rates (docs/guide/motion.md); the quadratic model's peak
follows the CPI-centre velocity. Seconds per frame (engine with the two recording syntheses,
simulate): 0.78 / 0.83 frozen, 3.0-4.7 / 3.7-5.3 quadratic.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from sionnafmcw import plots, processing
from sionnafmcw.animation import load_animation
from sionnafmcw.engines import PathEngine
from sionnafmcw.engines import options as engine_options
from sionnafmcw.radar import RadarConfig
from sionnafmcw.synthesis import UPSTREAM_SHARE, noise_error_budget, synthesize
from sionnafmcw.validation.circle_walk import TRUTH_OBJECT, analyse
from sionnafmcw.validation.common import build_scene, run_engine

LIMBS = ("upper_arm", "lower_arm", "upper_leg", "lower_leg", "foot")
MODEL_SETS = {
    "physics": {"before": {"physical_optics": False, "random_phase": False}, "after": {}},
    "cpi_motion": {"frozen": {"cpi_motion": "frozen"}, "quadratic": {"cpi_motion": "quadratic"}},
}
MODELS = MODEL_SETS["physics"]


class _Recording(PathEngine):
    """PathEngine that also records, per frame, the noise-free clutter-removed maps of the torso's and the
    limbs' own contributions (synthesised within the noise budget ``simulate`` uses)."""

    def __init__(self, radar, **options):
        super().__init__(**options)
        self._radar = radar
        self.maps: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    @property
    def peaks(self) -> dict:
        return {f: (float(t.max()), float(m.max())) for f, (t, m) in self.maps.items()}

    def _frame_echoes(self, animation, radar, frame, pose):
        echoes, figures = super()._frame_echoes(animation, radar, frame, pose)
        labels = np.asarray(echoes.labels)[0, 0] if echoes.labels is not None else np.zeros(0, str)
        budget = (1 - UPSTREAM_SHARE) * noise_error_budget(radar)
        maps = []
        for select in (labels == TRUTH_OBJECT, np.array([any(l.endswith(s) for s in LIMBS) for l in labels], bool)):
            if not np.any(select):
                maps.append(np.zeros((radar.num_chirps, radar.num_samples), np.float32))
                continue
            cube = synthesize(echoes.select(select), radar, noise=False, max_error=budget)
            maps.append(processing.range_doppler_map(cube, radar, clutter_removal=True).power.astype(np.float32))
        self.maps[frame] = (maps[0], maps[1])
        return echoes, figures


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3], help="solver seeds")
    parser.add_argument("--samples-per-src", type=int, default=engine_options("path")["samples_per_src"])
    parser.add_argument("--max-depth", type=int, default=engine_options("path")["max_depth"])
    parser.add_argument("--noise-seed", type=int, default=0)
    parser.add_argument("--scene", default=None, help="existing circle_walk animation (default: build one in --out)")
    parser.add_argument("--out", default="out/circle_walk_physics")
    parser.add_argument("--models", choices=tuple(MODEL_SETS), default="physics",
                        help="physics: GO paths before, PO and random phases after; cpi_motion: frozen/quadratic CPI")
    args = parser.parse_args(argv)
    models = MODEL_SETS[args.models]

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = Path(args.scene) if args.scene else build_scene("circle_walk", out / "scene")
    animation = load_animation(scene)
    radar = RadarConfig.preset("walk-77ghz")
    frames = list(range(min(args.frames, animation.num_frames)))
    results = []
    for seed in args.seeds:
        for model, options in models.items():
            engine = _Recording(radar, samples_per_src=args.samples_per_src, max_depth=args.max_depth, seed=seed,
                                **options)
            run, seconds = run_engine(animation, radar, engine, out / f"run_{model}_{seed}.zarr", frames=frames,
                                      seed=args.noise_seed, progress=False)
            result = analyse(run, frames=frames)
            peaks = np.array([engine.peaks[f] for f in frames])
            limb_wins = int(np.sum(peaks[:, 1] > peaks[:, 0]))
            limb_cell = 0   # the limbs' map above the torso's in the estimator's own cell (the run's map)
            for f in frames:
                i, k = processing.range_doppler_map(run.cube(f), radar, clutter_removal=True).peak()
                torso_map, limb_map = engine.maps[f]
                limb_cell += int(limb_map[i, k] > torso_map[i, k])
            engine_seconds = [s.seconds for s in engine.stats[1:]] or [engine.stats[0].seconds]
            ax = plots.plot_doppler_time(result["times"], result["track"].velocities, truth_times=result["times"],
                                         truth_velocities=result["truth"], spectrogram=result["spectrogram"],
                                         title=f"Doppler-time, path engine {model} (seed {seed}): "
                                               f"e_velo = {result['e_velo']:.3f} m/s")
            plots.save(ax, out / f"doppler_time_{model}_seed{seed}.png")
            row = {"model": model, "seed": seed, "e_velo": result["e_velo"],
                   "e_velo_cpi_centre": result["e_velo_cpi_centre"],
                   "fraction_within_one_bin": result["fraction_within_one_bin"],
                   "median_abs_error": result["median_abs_error"], "limb_outshines_torso_cpis": limb_wins,
                   "limb_cell_cpis": limb_cell,
                   "num_cpis": len(frames), "engine_s_per_frame_median": float(np.median(engine_seconds)),
                   "simulate_s_per_frame": seconds / len(frames),
                   "traced_paths_median": float(np.median([s.figures.get("num_traced_paths", 0) for s in engine.stats])),
                   "po_samples_median": float(np.median([s.figures.get("po_samples", 0) for s in engine.stats])),
                   "torso_peak_db_median": float(np.median(10 * np.log10(np.maximum(peaks[:, 0], 1e-300)))),
                   "limb_peak_db_median": float(np.median(10 * np.log10(np.maximum(peaks[:, 1], 1e-300))))}
            results.append(row)
            print(json.dumps(row), flush=True)
    summary = {}
    for model in models:
        rows = [r for r in results if r["model"] == model]
        summary[model] = {"e_velo_per_seed": [r["e_velo"] for r in rows],
                          "e_velo_mean": float(np.mean([r["e_velo"] for r in rows])),
                          "e_velo_cpi_centre_per_seed": [r["e_velo_cpi_centre"] for r in rows],
                          "limb_outshines_torso_cpis": [r["limb_outshines_torso_cpis"] for r in rows],
                          "limb_cell_cpis": [r["limb_cell_cpis"] for r in rows],
                          "engine_s_per_frame": float(np.median([r["engine_s_per_frame_median"] for r in rows])),
                          "simulate_s_per_frame": float(np.median([r["simulate_s_per_frame"] for r in rows]))}
    (out / "summary.json").write_text(json.dumps({"runs": results, "summary": summary,
                                                  "samples_per_src": args.samples_per_src, "frames": len(frames),
                                                  "seeds": args.seeds}, indent=1))
    print(json.dumps(summary), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
