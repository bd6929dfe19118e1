"""Motion within the CPI and the moving radar: their cost per frame, and the
figures of docs/guide/motion.md.

    .venv/bin/python benchmarks/cpi_motion.py cost [--frames 6] [--rounds 2] [--scene DIR]
    .venv/bin/python benchmarks/cpi_motion.py figures [--out docs/_static/figures]

``cost``: the paper's circle walk (``circle_walk`` scene, radar ``walk-77ghz``, path engine defaults,
noise on, the production noise-budgeted synthesis with the static block's cube cached as
``simulate`` does) frame by frame, each effect against its baseline on the same frame next to it
(the shared machine's load drifts): ``frozen`` vs ``quadratic`` (``cpi_motion``), and the radar at
rest vs moving (0.5 m/s along its boresight, a radar track through the API: every frame traced and
rendered whole, no static scene, static clutter at its ego-Doppler). Each variant has its own engine
(scene loaded and kernels compiled in a first frame that is not timed), ``--frames`` timed frames
spread over the walk, ``--rounds`` passes in alternating order. Prints, per effect, the median of the
paired ratios of the engine's, the synthesis's and their sum's wall seconds, with their quartiles,
and the median seconds per frame of each variant.

``figures``: writes ``motion_cpi.png`` (a point target accelerating at 40 m/s^2: its Doppler spectrum
frozen and quadratic with the closed-form band; one walk frame's clutter-removed range-Doppler map,
frozen and quadratic) and ``motion_ego.png`` (the ``car_park`` corridor from a radar at rest and
from one driving at 5 m/s: range-Doppler maps with every pillar's closed-form range and ego-Doppler
marked) to ``--out``, and prints the numbers they show.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sionnafmcw import Echoes, RadarConfig, processing, scenes, synthesize
from sionnafmcw.animation import RadarPose, load_animation
from sionnafmcw.engines import create

ROOT = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------------------------------- cost
def _moving_track(animation, speed: float = 0.5):
    """The animation's radar pose moving at ``speed`` (m/s) along its boresight from frame 0 (a track)."""
    from sionnafmcw.geometry import rotation_matrix

    pose = animation.radar_pose
    v = speed * rotation_matrix(pose.orientation)[:, 0]
    return [RadarPose(pose.position + v * t, pose.orientation, velocity=v) for t in animation.times]


def _frame_seconds(engine, animation, radar, frame, pose, cache, seed):
    """(engine s, synthesis s) of one frame (wall)."""
    t0 = time.perf_counter()
    echoes = engine.echoes(animation, radar, frame, radar_pose=pose)
    t1 = time.perf_counter()
    synthesize(echoes, radar, rng=[seed, frame], static_cache=cache)
    return t1 - t0, time.perf_counter() - t1


def cost(args) -> None:
    radar = RadarConfig.preset("walk-77ghz")
    scene = Path(args.scene) if args.scene else scenes.build("circle_walk", Path(tempfile.mkdtemp()) / "walk")
    animation = load_animation(scene)
    track = _moving_track(animation)
    variants = {
        "frozen": (create("path", cpi_motion="frozen"), None),
        "quadratic": (create("path", cpi_motion="quadratic"), None),
        "radar at rest": (create("path"), None),
        "radar moving": (create("path"), track),
    }
    caches = {name: {} for name in variants}
    for name, (engine, pose) in variants.items():   # load, compile, build the static scene: not timed
        _frame_seconds(engine, animation, radar, 0, None if pose is None else pose, caches[name], args.seed)
    frames = np.linspace(1, animation.num_frames - 1, args.frames).astype(int)
    pairs = {"cpi_motion quadratic / frozen": ("quadratic", "frozen"),
             "moving radar / at rest": ("radar moving", "radar at rest")}
    samples = {name: [] for name in variants}
    ratios = {key: {"engine": [], "synthesis": [], "total": []} for key in pairs}
    for r in range(args.rounds):
        for f in frames:
            for key, (effect, base) in pairs.items():
                order = (effect, base) if (r + int(f)) % 2 else (base, effect)
                got = {}
                for name in order:
                    engine, pose = variants[name]
                    got[name] = _frame_seconds(engine, animation, radar, int(f), pose, caches[name], args.seed)
                    samples[name].append(got[name])
                e, b = got[effect], got[base]
                ratios[key]["engine"].append(e[0] / b[0])
                ratios[key]["synthesis"].append(e[1] / b[1])
                ratios[key]["total"].append(sum(e) / sum(b))
            print(f"round {r} frame {f}: " + ", ".join(f"{n} {sum(samples[n][-1]):.2f} s" for n in variants),
                  flush=True)
    print(f"\n{len(frames)} frames x {args.rounds} rounds, circle walk, walk-77ghz, 2-core machine (shared)")
    for name, values in samples.items():
        arr = np.array(values)
        print(f"  {name:14s} engine {np.median(arr[:, 0]):.2f} s  synthesis {np.median(arr[:, 1]):.2f} s  "
              f"frame {np.median(arr.sum(axis=1)):.2f} s (median per frame)")
    for key, parts in ratios.items():
        text = []
        for part, values in parts.items():
            q = statistics.quantiles(values, n=4) if len(values) > 1 else [values[0]] * 3
            text.append(f"{part} {statistics.median(values):.2f} [{q[0]:.2f}, {q[2]:.2f}]")
        print(f"  {key}: " + "; ".join(text))


# ---------------------------------------------------------------------------------------- figures
def _cpi_figure(out: Path, scene: Path | None) -> list[str]:
    import matplotlib.pyplot as plt

    radar = RadarConfig.preset("walk-77ghz")
    lines = []
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    # (a) a point target accelerating at 40 m/s^2 from 1 m/s
    v0, a, T = 1.0, 40.0, radar.cpi_duration
    echoes = Echoes.point_targets(radar, [4.0], [v0], [0.0], radial_accelerations=[a])
    ax = axes[0]
    for label, e, style in (("frozen", echoes.frozen(), "-"), ("quadratic", echoes, "-")):
        m = processing.range_doppler_map(synthesize(e, radar, rng=1), radar, window_doppler=None)
        k = int(np.argmax(m.power.max(axis=0)))
        p = 10 * np.log10(m.power[:, k] / m.power[:, k].max())
        ax.plot(m.velocities, p, style, label=f"cpi_motion='{label}'")
    ax.axvspan(v0, v0 + a * T, color="tab:green", alpha=0.15, label=f"closed form [v0, v0 + aT], aT = {a * T:.2f} m/s")
    ax.set_xlim(v0 - 0.5, v0 + a * T + 0.5)
    ax.set_ylim(-40, 2)
    ax.set_xlabel("radial velocity (m/s)")
    ax.set_ylabel("power (dB, rectangular Doppler window)")
    ax.set_title(f"point target at 4 m, {a:.0f} m/s² over the {T * 1e3:.1f} ms CPI")
    ax.legend(fontsize=8, loc="lower center")
    lines.append(f"point target: closed-form smear {a * T / radar.velocity_resolution:.1f} Doppler bins")
    # (b, c) one walk frame
    scene = scene or scenes.build("circle_walk", Path(tempfile.mkdtemp()) / "walk")
    animation = load_animation(scene)
    frame = 60   # the body near the radar (4 m), approaching at 3.9 m/s
    maps = []
    for mode in ("frozen", "quadratic"):
        echoes = create("path", cpi_motion=mode).echoes(animation, radar, frame)
        cube = synthesize(echoes, radar, rng=[0, frame])
        maps.append((mode, processing.range_doppler_map(cube, radar, clutter_removal=True)))
    top = max(float(m.power.max()) for _, m in maps)
    from sionnafmcw.geometry import radial_velocity, world_phase_centre

    centre = world_phase_centre(radar, animation.radar_pose.position, animation.radar_pose.orientation)
    torso = animation.object_positions(frame, ["torso"])["torso"]
    torso_v = radial_velocity(torso, animation.object_velocity(frame, "torso"), centre)
    for ax, (mode, m) in zip(axes[1:], maps):
        db = 10 * np.log10(np.maximum(m.power / top, 1e-12))
        ax.imshow(db, origin="lower", aspect="auto", vmin=-40, vmax=0, cmap="viridis",
                  extent=[m.ranges[0], m.ranges[-1], m.velocities[0], m.velocities[-1]])
        r_t = float(np.linalg.norm(torso - centre))
        ax.set_xlim(r_t - 1.5, r_t + 1.5)
        ax.set_ylim(torso_v - 2.5, torso_v + 2.5)
        ax.set_xlabel("range (m)")
        ax.set_ylabel("radial velocity (m/s)")
        i, k = m.peak()
        ax.plot(m.ranges[k], m.velocities[i], "r+", markersize=12, label="strongest cell")
        ax.plot(np.linalg.norm(torso - centre), torso_v, "wx", markersize=9, label="torso truth (CPI start)")
        ax.legend(fontsize=8, loc="upper right")
        ax.set_title(f"circle walk, frame {frame}, cpi_motion='{mode}' (dB)")
        gate = np.abs(m.ranges - r_t) <= 1.0
        occupied = int(np.sum(m.power[:, gate].max(axis=1) > 1e-2 * top))
        lines.append(f"walk frame {frame} {mode}: strongest cell {m.ranges[k]:.2f} m, {m.velocities[i]:.3f} m/s "
                     f"(torso truth {r_t:.2f} m, {torso_v:.3f} m/s); Doppler bins within 20 dB of the peak "
                     f"within 1 m of the torso {occupied}")
    fig.tight_layout()
    path = out / "motion_cpi.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [str(path), *lines]


def _ego_figure(out: Path) -> list[str]:
    import matplotlib.pyplot as plt

    from sionnafmcw.geometry import world_phase_centre

    radar = RadarConfig.preset("walk-77ghz")
    lines = []
    tmp = Path(tempfile.mkdtemp())
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    frame = 6
    for ax, speed in zip(axes, (0.0, 5.0)):
        scene = scenes.build("car_park", tmp / f"park_{speed:g}", num_pillars=3, spacing=2.5, first=4.0,
                             lane_width=3.0, speed=speed, leg=0.15, num_frames=24)
        animation = load_animation(scene)
        pose = animation.radar_pose_at(frame)
        echoes = create("path", max_depth=3).echoes(animation, radar, frame)
        m = processing.range_doppler_map(synthesize(echoes, radar, rng=[0, frame]), radar)
        db = 10 * np.log10(np.maximum(m.power / m.power.max(), 1e-12))
        ax.imshow(db, origin="lower", aspect="auto", vmin=-50, vmax=0, cmap="viridis",
                  extent=[m.ranges[0], m.ranges[-1], m.velocities[0], m.velocities[-1]])
        centre = world_phase_centre(radar, pose.position, pose.orientation)
        for name in animation.object_names:
            _, k, side = name.split("_")
            corner = np.array([4.0 + int(k) * 2.5, (1.5 if side == "left" else -1.5), 1.0])
            r = np.linalg.norm(corner - centre - pose.velocity * radar.cpi_duration / 2)
            v = -np.dot(pose.velocity, corner - centre) / np.linalg.norm(corner - centre)
            ax.plot(r, v, "o", mfc="none", mec="red", ms=10)
            if side == "left":
                lines.append(f"car park, {speed:g} m/s, {name}: range {r:.2f} m, ego radial velocity {v:.2f} m/s")
        ax.set_xlim(2.0, 10.0)
        ax.set_ylim(-6, 1.5)
        ax.set_xlabel("range (m)")
        ax.set_title(f"car_park, frame {frame}: radar {'at rest' if speed == 0 else f'driving at {speed:g} m/s'}")
    axes[0].set_ylabel("radial velocity (m/s)")
    fig.tight_layout()
    path = out / "motion_ego.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [str(path), *lines]


def figures(args) -> None:
    import matplotlib

    matplotlib.use("Agg")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for line in _cpi_figure(out, Path(args.scene) if args.scene else None) + _ego_figure(out):
        print(line, flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    c = sub.add_parser("cost")
    c.add_argument("--frames", type=int, default=6)
    c.add_argument("--rounds", type=int, default=2)
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--scene", default=None, help="a circle_walk animation directory (default: build one)")
    f = sub.add_parser("figures")
    f.add_argument("--out", default=str(ROOT / "docs" / "_static" / "figures"))
    f.add_argument("--scene", default=None, help="a circle_walk animation directory (default: build one)")
    args = parser.parse_args(argv)
    (cost if args.command == "cost" else figures)(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
