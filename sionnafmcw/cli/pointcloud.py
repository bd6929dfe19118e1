"""``sionnafmcw pointcloud``: a run store through the TI board's own on-chip chain
(:mod:`sionnafmcw.ti.oob`, configured by the processing lines of a ``.cfg``), written in a format a
real pipeline reads (:mod:`sionnafmcw.ti.formats`)."""

from __future__ import annotations

from pathlib import Path

from .common import UserError, open_run_or_error, parse_frames, progress, ranges_text

HELP = "The point cloud a TI board computes on chip from a run, in a real pipeline's format."
FORMAT_HELP = {
    "npz": "one .npz with RadHAR's per-point arrays (frame, point_id, x, y, z, ...)",
    "radhar": "RadHAR's text dump of the ROS driver's RadarScan messages",
    "tlv": "the demo's UART byte stream (header, TLVs as guiMonitor selects, padding)",
    "rosbag2": "a ROS 2 bag as TI's ROS 2 driver records it (PointCloud2 + RadarScan)",
}
EPILOG = """\
The chain is the mmWave SDK out-of-box demo's (SDK 1.x/2.x for an xWR14xx .cfg,
SDK 3.x otherwise), configured by the .cfg's cfarCfg, peakGrouping,
multiObjBeamForming, clutterRemoval, aoaFovCfg, cfarFovCfg, calibDcRangeSig,
compRangeBiasAndRxChanPhase and guiMonitor lines. Formats:
  npz      {npz}
  radhar   {radhar}
  tlv      {tlv}
  rosbag2  {rosbag2}
npz, radhar and rosbag2 hold what TI's ROS driver publishes (ROS axes: x forward,
y left, z up). OUT is written whole or not at all.

example:
  sionnafmcw pointcloud runs/walk.zarr --cfg 1443es1_short_range_3d.cfg --format radhar --out walk.txt
""".format(**FORMAT_HELP)


def add_parser(add) -> None:
    from ..ti.formats import FORMATS

    p = add("pointcloud", HELP, EPILOG)
    p.add_argument("run", metavar="RUN", help="run store written by 'sionnafmcw simulate'")
    p.add_argument("--cfg", default=None, metavar="FILE",
                   help="TI .cfg whose processing lines configure the chain (default: the .cfg the "
                        "run's radar was read from)")
    p.add_argument("--out", required=True, metavar="PATH",
                   help="file to write (a folder for rosbag2); must not exist")
    p.add_argument("--format", choices=FORMATS, default="npz", help="output format (default npz)")
    p.add_argument("--frames", default=None, metavar="SEL", help="frames (a:b, n or i,j,k; default all)")
    p.add_argument("--activity", default="", metavar="NAME",
                   help="activity label stored in npz output (e.g. walk)")
    p.add_argument("--stamp0", type=float, default=0.0, metavar="S",
                   help="ROS time (s) of the run's time 0 in npz, radhar and rosbag2 stamps (default 0)")
    p.set_defaults(func=run)


def run(args) -> int:
    import math

    from ..ti.formats import (DriverParams, recording_from_frames, write_npz, write_rosbag2, write_text,
                              write_tlv)

    out = Path(args.out)
    if out.exists() or out.is_symlink():
        raise UserError(f"--out {out}: exists; remove it or choose another path")
    if not out.parent.is_dir():
        raise UserError(f"--out {out}: folder {out.parent} does not exist")
    if not math.isfinite(args.stamp0):
        raise UserError(f"--stamp0 {args.stamp0}: must be a finite number of seconds")
    from ..ti.oob import run_point_clouds, run_processing

    store = open_run_or_error(args.run)
    # --cfg's processing lines, or those the run's radar kept from the .cfg it was read from
    processing = run_processing(store, Path(args.cfg) if args.cfg is not None else None)
    frames = parse_frames(args.frames, store.num_frames) if args.frames is not None else None
    if frames is not None:
        missing = sorted(set(frames) - set(store.done_frames.tolist()))
        if missing:
            raise UserError(f"--frames {args.frames}: frame(s) {ranges_text(missing)} of {args.run} are not "
                            "simulated yet; finish the run with the same 'sionnafmcw simulate' command")
    total = len(frames) if frames is not None else len(store.done_frames)
    counted = {"frames": 0, "points": 0}

    def stream():
        for points in progress(run_point_clouds(args.run, processing, frames), args.quiet,
                               total=total, desc="pointcloud", unit="frame"):
            counted["frames"] += 1
            counted["points"] += points.num_points
            yield points

    if args.format == "tlv":
        write_tlv(out, stream(), processing.gui_monitor)
    else:
        params = DriverParams.from_radar(store.radar)
        if args.format == "rosbag2":
            write_rosbag2(out, stream(), params, stamp0=args.stamp0)
        else:
            recording = recording_from_frames(stream(), params, stamp0=args.stamp0, activity=args.activity,
                                              source=str(args.run))
            (write_npz if args.format == "npz" else write_text)(out, recording)
    sdk = "SDK 3.x" if processing.sdk == 3 else "SDK 1.x/2.x"
    print(f"wrote {out} ({args.format}, {sdk} chain): {counted['frames']} frames, "
          f"{counted['points']} detected points")
    return 0
