"""RadHAR's sensor on a simulated person: the on-chip point cloud against the real recordings.

A person (an activity builder) in a furnished room is simulated with the radar of RadHAR's own
``.cfg`` (TI IWR1443BOOST, SDK 1.x/2.x out-of-box demo; RF and processing lines), the run goes
through the board's on-chip chain (:func:`sionnafmcw.ti.oob.run_point_clouds`) and the ROS
driver's conversion (:func:`~sionnafmcw.ti.formats.radhar.recording_from_frames`), and the
recording is described by the same statistics as the real training split
(:mod:`sionnafmcw.validation.point_cloud_statistics`): points per frame, the zero-velocity share,
intensity, height and forward extent.

This is a report, not a fit: nothing here is tuned to the real data, which only stands beside the
simulated figures. The scenes are the ``radhar`` builder's five classes in its default room with
one table and two chairs, the person 2 m in front of the sensor (RadHAR: 1.5-3 m), the sensor
level, 1 m above the floor (not published).

    python validation/ti_radhar.py --real ../shared/realdata/radhar/train --out out/ti_radhar [--frames 30]

Writes ``statistics.md`` (the table), ``metrics.json`` and one RadHAR ``.npz`` per simulated
activity, and prints the metrics JSON as its last line.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
from pathlib import Path

#: RadHAR's frame rate (its .cfg's ``frameCfg``: 33.333 ms).
FPS = 30.0
#: The furnished room around the person (the ``radhar`` builder's room with one table and two chairs).
ROOM = {"room": True, "tables": 1, "chairs": 2}
#: Simulated activity -> (scenario, builder parameters, RadHAR class it stands beside): the ``radhar``
#: builder's five classes, the person 2 m in front of a level sensor 1 m above the floor.
SCENES = {name: ("radhar", {"activity": activity, "person_range": 2.0, "radar_height": 1.0, **ROOM}, cls)
          for name, activity, cls in (("boxing", "boxing", "boxing"), ("jack", "jumping_jacks", "jack"),
                                      ("jump", "jump", "jump"), ("squats", "squat", "squats"),
                                      ("walk", "walk", "walk"))}


def simulate_activity(name: str, cfg: Path, out: Path, frames: int, seed: int = 0):
    """Build and simulate ``name`` with the radar of ``cfg``; returns the recording (ROS driver's points)."""
    from .. import simulate
    from ..radar import RadarConfig
    from ..ti.formats.radhar import recording_from_frames, write_npz
    from ..ti.formats.ros_driver import DriverParams
    from ..ti.oob import run_point_clouds
    from .common import build_scene

    scenario, params, activity = SCENES[name]
    radar = RadarConfig.resolve(str(cfg))
    scene = build_scene(scenario, out / "scenes" / name, {**params, "num_frames": frames, "fps": FPS})
    store = out / "runs" / f"{name}.zarr"
    simulate(scene, radar, engine="path", out=store, frames=slice(0, frames), progress=False, seed=seed)
    recording = recording_from_frames(run_point_clouds(store), DriverParams.from_radar(radar),
                                      activity=activity, source=f"sionnafmcw:{scenario}")
    write_npz(out / f"{name}.npz", recording)
    return recording


def real_statistics(real: Path) -> dict:
    """Statistics per class of the real recordings under ``real``."""
    from ..ti.formats.radhar import read_dataset
    from .point_cloud_statistics import recording_statistics

    by_class = collections.defaultdict(list)
    for recording in read_dataset(real):
        by_class[recording.activity].append(recording)
    return {k: recording_statistics(v) for k, v in sorted(by_class.items())}


def table(simulated: dict, real: dict) -> str:
    """The comparison as a Markdown table."""
    rows = ["| | points/frame median (5-95 %) | zero-velocity share | intensity median (5-95 %), dB "
            "| height 5-95 %, m | forward 5-95 %, m |", "|---|---|---|---|---|---|"]

    def row(label, s):
        p, i = s["points_per_frame"], s["intensity_db"]
        return (f"| {label} | {p['median']:.0f} ({p['p05']:.0f}-{p['p95']:.0f}) | {s['zero_velocity_share']:.2f} "
                f"| {i['median']:.1f} ({i['p05']:.1f}-{i['p95']:.1f}) | {s['height_m']['p05']:.2f} to "
                f"{s['height_m']['p95']:.2f} | {s['forward_m']['p05']:.2f} to {s['forward_m']['p95']:.2f} |")

    for name, s in simulated.items():
        cls = SCENES[name][2]
        rows.append(row(f"simulated {name}", s))
        if cls in real:
            rows.append(row(f"real {cls}", real[cls]))
    return "\n".join(rows) + "\n"


def main(argv=None) -> int:
    from ..heap import limit_arenas
    from .point_cloud_statistics import recording_statistics

    limit_arenas(1)
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--real", type=Path, required=True, help="RadHAR recordings (the .npz folder or Data/Train)")
    p.add_argument("--cfg", type=Path, default=None, help="the sensor's .cfg (default: REAL/../1443es1_short_range_3d.cfg)")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--frames", type=int, default=30)
    p.add_argument("--activities", default=",".join(SCENES))
    a = p.parse_args(argv)
    cfg = a.cfg or a.real.resolve().parent / "1443es1_short_range_3d.cfg"
    if not cfg.is_file():
        p.error(f"{cfg}: no such .cfg; give the sensor's .cfg with --cfg")
    unknown = sorted(set(a.activities.split(",")) - set(SCENES))
    if unknown:
        p.error(f"--activities: unknown {', '.join(unknown)} (choose from {', '.join(SCENES)})")
    a.out.mkdir(parents=True, exist_ok=True)
    real = real_statistics(a.real)
    simulated = {name: recording_statistics(simulate_activity(name, cfg, a.out, a.frames))
                 for name in a.activities.split(",")}
    (a.out / "statistics.md").write_text(table(simulated, real))
    metrics = {"simulated": simulated, "real": real, "frames": a.frames, "cfg": str(cfg)}
    (a.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(table(simulated, real))
    print(json.dumps(metrics))
    return 0


if __name__ == "__main__":
    sys.exit(main())
