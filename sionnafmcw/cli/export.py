"""``sionnafmcw export``: a run store as the raw capture a TI board would record (DCA1000EVM
``.bin`` with its ``.cfg`` and a JSON sidecar), or as NumPy frames in TI's ``[chirp, rx, sample]``
layout (:func:`sionnafmcw.ti.dca1000.export_run`)."""

from __future__ import annotations

from .common import open_run_or_error, parse_frames

HELP = "Export a run store as a TI DCA1000 raw capture (or .npz frames)."
EPILOG = """\
Writes OUT/adc_data.bin (int16, TI's lane order for the board family, chirps in
firing order, frames back to back) or OUT/adc_data.npz, beside it capture.cfg
(the mmWave .cfg of the radar) and capture.json (frame times, ground truth, ADC
scaling, clipped samples per frame). Samples are scaled to ADC counts by the
receiver gain and the ADC full scale; clipped values are counted and reported.

example:
  sionnafmcw export runs/plate.zarr --format dca1000 --out captures/plate --board awr1843boost
"""


def add_parser(add) -> None:
    p = add("export", HELP, EPILOG)
    p.add_argument("run", metavar="RUN", help="run store written by 'sionnafmcw simulate'")
    p.add_argument("--out", required=True, metavar="DIR", help="capture directory to write (created whole or not at all)")
    p.add_argument("--format", choices=("dca1000", "npz"), default="dca1000", help="raw DCA1000 .bin or .npz frames")
    p.add_argument("--board", metavar="BOARD", default=None,
                   help="TI board (awr1843boost, iwr6843isk, iwr1443boost); default: the run's radar preset")
    p.add_argument("--rx-gain-db", type=float, default=30.0, metavar="DB",
                   help="receiver gain from the antenna port to the ADC (dB, default 30: the presets' rxGain)")
    p.add_argument("--adc-full-scale-dbm", type=float, default=0.0, metavar="DBM",
                   help="power of a full-scale complex tone at the ADC input (dBm, default 0)")
    p.add_argument("--frames", default=None, metavar="SEL", help="frames to export (a:b, n or i,j,k; default all)")
    p.add_argument("--replace", action="store_true", help="replace an existing capture directory")
    p.set_defaults(func=run)


def run(args) -> int:
    import math

    from ..ti.dca1000 import AdcScale, export_run

    for option, value in (("--rx-gain-db", args.rx_gain_db), ("--adc-full-scale-dbm", args.adc_full_scale_dbm)):
        if not math.isfinite(value):
            from .common import UserError

            raise UserError(f"{option} {value}: must be a finite number of dB")
    store = open_run_or_error(args.run)
    frames = parse_frames(args.frames, store.num_frames) if args.frames is not None else None
    report = export_run(args.run, args.out, format=args.format, board=args.board, frames=frames,
                        replace=args.replace, scale=AdcScale(args.rx_gain_db, args.adc_full_scale_dbm))
    print(report.summary())
    return 0
