"""``sionnafmcw presets``: the radar presets (or a TI mmWave ``.cfg``) with their derived figures."""

from __future__ import annotations

import json

from .common import UserError, load_radar

HELP = "Table of the radar presets with their derived figures."
EPILOG = """\
example:
  sionnafmcw presets
  sionnafmcw presets --json
  sionnafmcw presets walk-77ghz --config > walk.json   # edit, then: simulate ... --radar walk.json
  sionnafmcw presets --from-cfg profile.cfg            # a TI mmWave SDK .cfg, as simulate --radar reads it
"""

#: Table columns: header, unit, value of a row, format.
COLUMNS = (
    ("preset", "", lambda r: r["name"], "{}"),
    ("fc", "GHz", lambda r: r["fc"] / 1e9, "{:.2f}"),
    ("bandwidth", "GHz", lambda r: r["bandwidth"] / 1e9, "{:.3f}"),
    ("range res.", "cm", lambda r: r["range_resolution"] * 100, "{:.2f}"),
    ("max range", "m", lambda r: r["max_range"], "{:.2f}"),
    ("max vel.", "m/s", lambda r: r["max_velocity"], "{:.2f}"),
    ("vel. res.", "m/s", lambda r: r["velocity_resolution"], "{:.3f}"),
    ("CPI", "ms", lambda r: r["cpi_duration"] * 1e3, "{:.2f}"),
    ("chirps", "per Tx", lambda r: r["num_chirps"], "{}"),
    ("samples", "per chirp", lambda r: r["num_samples"], "{}"),
    ("Tx x Rx", "", lambda r: f"{r['num_tx']} x {r['num_rx']}", "{}"),
    ("virtual", "channels", lambda r: r["num_virtual"], "{}"),
    ("PN@1MHz", "dBc/Hz", lambda r: _or_off(r["receiver"]["phase_noise_1mhz_dbc_hz"], "{:.0f}"), "{}"),
    ("HPF", "kHz", lambda r: "+".join(f"{c / 1e3:g}" for c in r["receiver"]["highpass_corners_hz"] or []) or "off",
     "{}"),
    ("IF band", "MHz", lambda r: _or_off(r["receiver"]["lowpass_passband_hz"],
                                          lambda b: f"{b[0] / 1e6:g}-{b[1] / 1e6:.2f}"), "{}"),
    ("ADC", "bits", lambda r: _or_off(r["receiver"]["adc_bits"], "{}"), "{}"),
    ("pattern", "", lambda r: r["receiver"]["antenna_pattern"], "{}"),
)


def _or_off(value, fmt) -> str:
    """``value`` formatted, or ``off`` for None (a receiver effect the radar does not model)."""
    if value is None:
        return "off"
    return fmt(value) if callable(fmt) else fmt.format(value)


def add_parser(add) -> None:
    p = add("presets", HELP, EPILOG)
    p.add_argument("name", nargs="?", help="only this preset")
    p.add_argument("--from-cfg", metavar="FILE.cfg", default=None,
                   help="instead of the presets, the radar of a TI mmWave SDK .cfg file")
    p.add_argument("--json", action="store_true", help="JSON (SI units) with each preset's full configuration")
    p.add_argument("--config", action="store_true",
                   help="only the RadarConfig JSON of preset NAME (a --radar file to edit)")
    p.set_defaults(func=run)


def row(name: str, radar) -> dict:
    """A table row: the radar's derived figures (SI units), its receiver (:func:`sionnafmcw.receiver.summary`)
    and its full configuration."""
    from ..receiver import summary

    d = radar.derived()
    return {
        "name": name, "fc": radar.fc, "centre_frequency": d["centre_frequency"], "bandwidth": d["bandwidth"],
        "range_resolution": d["range_resolution"], "max_range": d["max_range"],
        "max_velocity": d["max_velocity"], "velocity_resolution": d["velocity_resolution"],
        "cpi_duration": d["cpi_duration"], "num_tx": radar.num_tx, "num_rx": radar.num_rx,
        "num_virtual": d["num_virtual"], "num_samples": radar.num_samples, "num_chirps": radar.num_chirps,
        "receiver": summary(radar), "config": radar.to_dict(),
    }


def run(args) -> int:
    from ..radar import RadarConfig

    if args.from_cfg is not None:
        if args.name:
            raise UserError("presets --from-cfg takes no preset NAME")
        rows = [row(args.from_cfg, load_radar(args.from_cfg, "--from-cfg"))]
    else:
        names = RadarConfig.presets()
        if args.name and args.name not in names:
            raise UserError(f"presets: unknown preset {args.name!r}; choose one of {', '.join(names)}")
        rows = [row(name, RadarConfig.preset(name)) for name in ([args.name] if args.name else names)]
    if args.config:
        if not args.name and args.from_cfg is None:
            raise UserError("presets --config needs a preset NAME, e.g. 'sionnafmcw presets walk-77ghz --config'")
        print(json.dumps(rows[0]["config"], indent=1))
        return 0
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print_table(rows)
    return 0


def print_table(rows) -> None:
    cells = [[fmt.format(get(r)) for _, _, get, fmt in COLUMNS] for r in rows]
    widths = [max(len(h), len(u), *(len(c[i]) for c in cells)) for i, (h, u, _, _) in enumerate(COLUMNS)]

    def line(values):
        return "  ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(values, widths))).rstrip()

    print(line([h for h, _, _, _ in COLUMNS]))
    print(line([u for _, u, _, _ in COLUMNS]))
    for c in cells:
        print(line(c))
    print("\nmax vel. is the TDM-aware unambiguous radial velocity (lambda_mid / 4 M T_c); a scene's frame period "
          "must be at least the CPI.\nReceiver (sionnafmcw.receiver): LO phase noise at 1 MHz, IF high-pass corners, "
          "anti-alias pass band, ADC bits in the cube, element pattern; 'off' = ideal.")
