r"""Domain randomisation of RadHAR-like data sets: the physical ranges a spec draws each item from.

:data:`RADHAR_RANGES` holds, for every randomised parameter of the ``radhar`` scenario
(:mod:`sionnafmcw.scenes.radhar`) and of the radar, its draw and why that range;
:func:`radhar_spec` makes a data-set spec of them (:mod:`.spec`), the classes in turn
(``{"cycle": CLASSES}``: balanced). The ranges come from physics, data sheets and what RadHAR's
paper and recordings say of the set-up, never from fitting anything to the real data: the real
training split (``radhar/train``) served only to check that they cover it (the README of that
folder, and the guide's table: per recording the median range of its moving points is 1.2-2.5 m,
their median azimuth -18 to +32 degrees, static returns reach 5.2 m, the far wall).

Receiver: the IWR1443's data sheet gives a noise figure of 15 dB (76-77 GHz) and 16 dB (77-81 GHz)
and phase noise of -95 / -93 dBc/Hz at 1 MHz offset; units differ from the typical values and the
noise figure rises with temperature, so the noise figure is drawn over 14-18 dB and the phase noise
among -98, -95, -92 dBc/Hz at 1 MHz.
"""

from __future__ import annotations

from ..scenes.radhar import CLASSES

#: ``{parameter: (draw, why)}``: scenario parameters of ``radhar``.
RADHAR_RANGES = {
    "person_range": ({"uniform": [1.0, 2.5]}, "the span the real recordings show: per recording the median range of "
                     "the moving points is 1.2-2.5 m, and no real moving point of a person lies beyond 2.5 m "
                     "(sionnafmcw.validation.detection_budget: the moving share at 2.5-3.5 m is 0.000-0.026); a "
                     "person farther off is a different data set (2 m -> 2.8 m costs 5.8 dB, and the real moving "
                     "points sit about 5 dB over the detection floor)"),
    "person_azimuth": ({"uniform": [-0.6, 0.6]}, "+-34 degrees: the real moving points' median azimuth lies within "
                       "-18..+32 degrees per recording"),
    "heading_offset": ({"uniform": [-0.5, 0.5]}, "+-29 degrees from facing the sensor (a walk: from its "
                       "direction): the subjects faced it, turned by a comfortable stance angle"),
    "person_height": ({"uniform": [1.55, 1.95]}, "adult statures, short women to tall men; the clips are scaled "
                      "to it, so limb lengths and speeds follow"),
    "build": ({"choice": ["male", "female"]}, "girths of men or women (Heinz et al. 2003)"),
    "playback_rate": ({"uniform": [0.8, 1.1]}, "-20 to +10 % in tempo: people repeat the same movement faster or "
                      "slower (an assumed spread, not a measured one); +10 % at most so that 60 frames at 30 fps "
                      "fit in the shortest clip, the 2.29 s CMU walk (walk_source=clip)"),
    "walk_speed": ({"uniform": [0.4, 0.8]}, "walk: the real walks' pace, a slow walk in a small space: one loop "
                   "(twice the time between sign changes of the moving points' median Doppler) takes 4.7-9.3 s "
                   "(quartiles, median 7.3 s), i.e. 2 pi R / T = 0.4-1.0 m/s (median 0.6) on the loops below, and "
                   "the moving points' median forward position changes by 0.27-0.62 m in one second (10-90 %); "
                   "the captured walk (CMU 08_10) goes at 1.6 m/s"),
    "walk_radius": ({"uniform": [0.6, 0.9]}, "walk: RadHAR's walkers walked small loops in front of the sensor (the "
                    "moving points' median position circles over 1.3-1.7 m in range and 1.5-1.8 m across, 10-90 % of "
                    "recordings); clockwise when mirrored"),
    "walk_direction": ({"choice": ["toward", "away", "left", "right"]}, "walk: heading at the window's middle "
                       "(turned by heading_offset): a window starts anywhere on the loop"),
    "mirror": ({"choice": [False, True]}, "either side leads (left- and right-handed, either foot first)"),
    "fist_speed": ({"uniform": [4.0, 9.0]}, "boxing: straight punches of recreational to trained boxers (6.3 m/s "
                   "jab of juniors, 7.5-9.3 m/s in combinations and maximal punches; sionnafmcw.mocap.punches)"),
    "punch_rate": ({"uniform": [1.0, 1.8]}, "boxing: shadow-boxing tempo, one to 1.8 punches a second; at most 1.8/s "
                   "because two starts of one fist (each jittered by +-20 % of the period) come at least 1.6/rate "
                   "apart and the slowest punch of these ranges (4 m/s with a 0.9 rad trunk turn) takes up to 0.81 s "
                   "out and back"),
    "trunk_rotation": ({"uniform": [0.3, 0.9]}, "boxing: thorax axial rotation of a rear-hand straight, 17-52 "
                       "degrees: boxers turn the trunk into the cross by tens of degrees, more or less by style and "
                       "skill (sionnafmcw.mocap.punches; the spread is assumed)"),
    "weight_shift": ({"uniform": [0.02, 0.08]}, "boxing: forward shift of the pelvis in a cross, 2-8 cm (assumed: "
                     "a weight shift onto the lead leg without a full step)"),
    "bounce": ({"uniform": [0.0, 0.05]}, "boxing: peak-to-peak stance bounce on the balls of the feet, from flat-"
               "footed to a lively bounce (assumed)"),
    "bounce_rate": ({"uniform": [2.0, 3.0]}, "boxing: rate of the stance bounce (assumed, a rhythm of about 2-3 Hz)"),
    "jump_height": ({"uniform": [0.08, 0.3]}, "jump: apex rise of repeated jumps in place, a hop to a brisk jump "
                    "(a maximal countermovement jump reaches about 0.45 m)"),
    "crouch": ({"uniform": [0.08, 0.2]}, "jump: depth of the countermovement and of the landing"),
    "jump_rate": ({"uniform": [0.5, 0.7]}, "jump: repeated jumps with a stand in between; at most 0.7/s so that "
                  "the slowest jump of these ranges (1.4 s) fits"),
    "radar_height": ({"uniform": [0.8, 1.5]}, "a sensor on a desk or a tripod at chest height (not published for "
                     "RadHAR; its point clouds' z spread of +-0.5-1.5 m about the sensor suits a sensor near mid "
                     "height of the person)"),
    "radar_tilt": ({"uniform": [-0.1, 0.2]}, "-6 to +11 degrees: mounted level by eye, slightly down for a tall "
                   "mount"),
    "room_margin": ({"uniform": [1.5, 3.5]}, "free space around the person and the sensor: rooms of about "
                    "4 x 4 m to 9 x 8 m; with the person at 1-2.5 m the far wall then lies 2.5-6 m off, around the "
                    "real static returns' reach (5.2 m, 95th percentile); below 1.5 m a table may not fit beside "
                    "the person's track and the sensor's view (the draw fails)"),
    "room_height": ({"uniform": [2.5, 3.2]}, "ceilings of offices and labs"),
    "wall_material": ({"choice": ["concrete", "plasterboard", "wood", "glass", "chipboard"]},
                      "every wall material the ITU model gives at 77 GHz"),
    "floor_material": ({"choice": ["floorboard", "concrete", "wood", "chipboard"]},
                       "every floor material the ITU model gives at 77 GHz"),
    "wall_scattering": ({"uniform": [0.1, 0.4]}, "diffuse share of smooth to rough building surfaces at mm-wave"),
    "tables": ({"choice": [0, 1, 2]}, "furniture: a lab or office"),
    "chairs": ({"choice": [0, 1, 2, 3, 4]}, "clutter: chairs"),
    "shelves": ({"choice": [0, 1]}, "furniture against a wall"),
    "cabinets": ({"choice": [0, 1]}, "metal cabinets: strong static reflectors"),
}
#: ``{RadarConfig field: (draw, why)}``: receiver fields drawn per item (module docstring).
RADAR_RANGES = {
    "noise_figure": ({"uniform": [14.0, 18.0]}, "IWR1443 data sheet: 15 dB (76-77 GHz), 16 dB (77-81 GHz); "
                     "unit spread and temperature"),
    "phase_noise": ({"choice": [[[1e6, -98.0]], [[1e6, -95.0]], [[1e6, -92.0]]]},
                    "IWR1443 data sheet: -95 / -93 dBc/Hz at 1 MHz; +-3 dB between units"),
}


def radhar_spec(name: str = "radhar-synthetic", count: int = 50, seed: int = 0, radar: str = "walk-77ghz",
                engine: str = "path", engine_options: dict | None = None, num_frames: int = 60, fps: float = 30.0,
                randomise: bool = True, **fixed) -> dict:
    """A data-set spec of the ``radhar`` scenario: the classes in turn, every range of
    :data:`RADHAR_RANGES` and :data:`RADAR_RANGES` drawn per item (``randomise``; else the builder's
    defaults), ``radar`` a preset name or the path of a radar ``.json`` or TI ``.cfg`` (RadHAR's own:
    ``1443es1_short_range_3d.cfg``); ``fixed`` sets scenario parameters (overriding a range)."""
    from ..radar import RadarConfig

    params = {"activity": {"cycle": list(CLASSES)}, "num_frames": num_frames, "fps": fps}
    radar_entry: dict = {"preset": radar} if radar in RadarConfig.presets() else {"file": str(radar)}
    if randomise:
        params.update({k: d for k, (d, _) in RADHAR_RANGES.items()})
        radar_entry.update({k: d for k, (d, _) in RADAR_RANGES.items()})
    params.update(fixed)
    spec = {"name": name, "scenario": "radhar", "count": int(count), "seed": int(seed), "radar": radar_entry,
            "engine": engine, "parameters": params}
    if engine_options:
        spec["engine_options"] = dict(engine_options)
    return spec


def range_table() -> str:
    """The ranges as a Markdown table (parameter, draw, why), for the guide."""
    rows = ["| parameter | drawn from | why |", "|---|---|---|"]
    for table in (RADHAR_RANGES, RADAR_RANGES):
        for k, (d, why) in table.items():
            kind, args = next(iter(d.items()))
            text = f"U[{args[0]:g}, {args[1]:g}]" if kind == "uniform" else f"one of {args}"
            rows.append(f"| `{k}` | {text} | {why} |")
    return "\n".join(rows)


__all__ = ["RADAR_RANGES", "RADHAR_RANGES", "radhar_spec", "range_table"]
