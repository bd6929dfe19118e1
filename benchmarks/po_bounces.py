"""Corner reflectors off their axis: the PO multi-bounce sampling rule against the density raised.

    PYTHONPATH=.:tests python benchmarks/po_bounces.py issue        # the issue's car_park measurement
    PYTHONPATH=.:tests python benchmarks/po_bounces.py mirror       # mirror-image trihedrals along a lane
    PYTHONPATH=.:tests python benchmarks/po_bounces.py grid         # defaults against the converged echo
    PYTHONPATH=.:tests python benchmarks/po_bounces.py cost [--frames 13] [--scenes DIR]

Every mode compares, in one process, the engines of :data:`VARIANTS`: **A**, the chains followed at the
first bounce's density (``PathEngine(..., po_bounce_rule=False, po_flat_faces=False)``, the engine
before the bounce rule), **B**, the rule of :mod:`sionnafmcw.engines.bounce_sampling` on sampled faces
(``po_flat_faces=False``, the engine before the exact apertures) and **C**, the defaults (the rule, and
the plane-faced objects' own chains over their exact apertures, :mod:`sionnafmcw.engines.flat_faces`).
The figures under *Measured* before the section *Exact apertures* were taken when B was the default.

* ``issue``: ``car_park`` with the radar at rest (``speed=0``), its first pair of 0.1 m trihedrals 3 m
  ahead and 1.5 m to either side (their aperture axes at the radar's start), the radar at x = 0 ...
  0.4 m on the lane's axis (``radar_pose``), radar ``walk-77ghz``, path engine defaults (two
  bounces) and ``po_samples_across`` 16 / 48 / 64. Per reflector two figures: ``sum|a|^2``, the
  power summed over the echo's contributions (what the issue read: after the PO merge a
  contribution is a cell of samples, so this is no echo power and depends on the sampling), and
  ``|h|^2``, the coherent channel (every contribution of the label summed with its carrier phase,
  mean over the 12 element pairs): the echo a range-Doppler map sees. Printed with the radar at
  y = 0 (the issue's pose: the array's phase centre then sits 19 mm off the lane's axis) and with
  the phase centre on it; and with three bounces, which a trihedral's echo needs.
* ``mirror``: two 0.1 m trihedrals, mirror images in the plane y = 0, 3 m ahead and 1.5 m to
  either side, turned 0 / 15 / 30 / 45 degrees off their axis; the radar's phase centre on that
  plane at x = 0, 0.2, 0.4 m; three bounces, ``|h|^2`` of each and their difference, and the wall
  seconds of an engine frame at a new pose (everything rendered again, as for a moving radar).
* ``grid``: a trihedral (three bounces) or a dihedral (two) of 0.05 / 0.1 / 0.3 m at 1 / 3 / 10 m,
  turned 0 / 15 / 30 / 45 degrees about the vertical (``tests/reflector_scenes.py``), radar
  ``walk-77ghz`` with isotropic elements: ``|h|^2`` of A, B and C at the default ``po_samples_across``
  16 against the converged echo (C at 128; before the exact apertures B at 128: the bound 8 times
  tighter and the first bounce 8 times finer), in dB, and the samples per bounce of the sampled render.
* ``cost``: the circle walk (``circle_walk``, one walker in its room) and a furnished room with
  three walkers (``people``, the furniture of ``benchmarks/furnished_room.py``): two variants
  (``--pair``, default B and C) take turns frame by frame (the order alternating), each with its own
  engine; per frame the engine's wall and CPU seconds and its PO samples; the first frame (scene
  load, the static block built and rendered once per pose) apart from the steady frames; and per
  object of frame 0 what the second variant changes in ``|h|^2``.

Measured
--------
2-core AMD EPYC, shared with other work (the cost rows: A and B interleaved in one process).

``issue``: the issue's -129 ... -119 dB (defaults) and -118.7 ... -117.8 dB (48 across) are
``sum|a|^2``, which moves with the sampling (at 64 across it reads -120 ... -121 dB, and at depth 3
it falls from -91 to -103 dB as the samples get finer while the echo stays put): not an echo power.
The echo, ``|h|^2``: with the defaults' two bounces a trihedral has no triple bounce and reads
-149 ... -124 dB (A) / -124 ... -111 dB (B, 16 across), its dihedral pairs' residue, 45-70 dB below
the echo; with three bounces -76.3 ... -75.3 dB, left and right within 0.4 dB and within 0.3 dB from
16 to 64 across, A and B alike: seen from the radar's start the pair is on its axis (``car_park``
points the apertures at it). With the radar at y = 0 its phase centre is 19 mm off the lane's axis,
so the two are not mirror images of each other for it; ``mirror`` puts the phase centre on the axis.

``mirror`` (three bounces): left - right within 0.22 dB at 0-45 degrees, x = 0-0.4 m, A and B alike.

``grid`` (converged minus nothing: the default's error, dB): at 0-30 degrees A up to +3.01 (0.1 m
trihedral, 1 m, 30 degrees: 9 tubes in its triple bounce), +1.62 (0.3 m trihedral, 1 m, 15), +1.20
(0.1 m dihedral, 3 m, 30); B within 0.99 dB everywhere (0.1 m trihedral at 10 m, 15 degrees: -0.99,
unsplit: its bound held), the worst cases split to 4252 / 3966 / 1768 samples per bounce. At 45
degrees a trihedral has no triple bounce (its echo 25-55 dB below the axis's, first-bounce and
dihedral residue): A and B off by up to 16 and 5 dB there, the first bounce's sampling; a dihedral
at 45 degrees shows one face to the radar and no double bounce (first bounce only, up to 1.9 dB).

``cost --frames 9``: circle walk: steady frames B/A wall 1.196, CPU 1.260 (0.603 -> 0.760 CPU-s a
frame; frame PO samples 80969 -> 82924: the walker's own chains, over curved surfaces, are not
split; the extra time is the static block's size, 287786 -> 739508 samples, which every frame tests
against the walker), first frame (the static block) wall 1.70, CPU 3.1. Furnished room, three
walkers: steady wall 1.860, CPU 1.692 (static samples 225166 -> 929882: the furniture's corners
with the floor), first frame wall 4.48. What it buys (one frame, ``max_depth=2``, per label, against
``po_samples_across=32``): the metal cabinet -7.77 -> +1.03 dB, the door -6.62 -> +0.04 dB, wall_x1
+2.75 -> -0.43 dB, the floor +1.57 -> -0.31 dB; the walls that see no corner move by <= 0.1 dB.

Exact apertures (C)
-------------------
2-core AMD EPYC with AVX-512; ``mirror`` alone on the machine, ``cost`` beside a test run.

``mirror``: left - right within 0.10 dB for C at 0-45 degrees and x = 0-0.4 m (A 0.22, B 0.18 dB; the
array's elements are not symmetric about the plane, so not 0); a new pose (everything rendered again,
as for a moving radar) costs C 0.17-0.32 s of wall for the two reflectors against 0.05-0.09 s for A
and B (the apertures clipped, the pieces cast and integrated; a radar at rest keeps the pieces).

``cost --frames 9`` (B then C, alternating): circle walk steady C/B wall 1.008, CPU 0.994, first frame
wall 1.105 (no plane-faced object in the scene; every object's ``|h|^2`` in frame 0 within 0.05 dB);
furnished room with three walkers steady wall 1.004, CPU 1.019, first frame wall 1.049, every object
within 0.05 dB but the monitor's glass, the room's one plane-faced object, +2.94 dB (its own chains
now over their exact apertures; its label also holds the sampled chains from other surfaces that end
on it).
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import tempfile
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))


def db(x):
    return 10 * np.log10(x)


#: The engines compared: A the chains at the first bounce's density, B the bounce rule (sampled faces), C the
#: defaults (the rule, and the plane-faced objects' own chains over their exact apertures).
VARIANTS = {"A": {"po_bounce_rule": False, "po_flat_faces": False}, "B": {"po_flat_faces": False}, "C": {}}


def engine_of(name: str, **options):
    """The path engine of variant ``name`` (:data:`VARIANTS`) with ``options``."""
    from sionnafmcw.engines import PathEngine

    return PathEngine(**VARIANTS[name], **options)


def channel_power(echoes, radar, label=None) -> float:
    """Mean over element pairs of the coherent channel's power (the contributions of ``label``)."""
    sel = slice(None) if label is None else echoes.labels[0, 0] == label
    h = np.sum(echoes.a[:, :, sel] * np.exp(-2j * np.pi * radar.fc * echoes.tau[:, :, sel]), axis=-1)
    return float(np.mean(np.abs(h) ** 2))


def summed_power(echoes, label) -> float:
    """The issue's figure: sum |a|^2 over the label's contributions, per element pair."""
    sel = echoes.labels[0, 0] == label
    return float(np.sum(np.abs(echoes.a[:, :, sel]) ** 2) / (echoes.a.shape[0] * echoes.a.shape[1]))


def issue(args):
    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation
    from sionnafmcw.animation.model import RadarPose
    from sionnafmcw.scenes.registry import build

    radar = RadarConfig.preset("walk-77ghz")
    folder = pathlib.Path(tempfile.mkdtemp(prefix="po_bounces_"))
    anim = load_animation(build("car_park", folder / "car_park", speed=0.0, num_pillars=1, num_frames=1))
    labels = ("pillar_0_left", "pillar_0_right")
    print("car_park, first pair; dB; L/R: left/right reflector; sum|a|^2 (the issue's figure) and |h|^2 (the echo)")
    for depth in (2, 3):
        for centred in (False, True):
            for name in VARIANTS:
                for n in (16, 48, 64):
                    engine = engine_of(name, po_samples_across=n, max_depth=depth)
                    row = []
                    for x in (0.0, 0.1, 0.2, 0.3, 0.4):
                        y = -radar.phase_centre[1] if centred else 0.0
                        e = engine.echoes(anim, radar, 0, radar_pose=RadarPose(np.array([x, y, 1.0]), np.zeros(3)))
                        s = [db(summed_power(e, lab)) for lab in labels]
                        h = [db(channel_power(e, radar, lab)) for lab in labels]
                        row.append(f"{s[0]:7.1f}{s[1]:7.1f} |{h[0]:7.1f}{h[1]:7.1f}")
                    print(f"depth {depth} {'centred' if centred else 'y=0    '} {name} n={n:3d}  " + "  ".join(row),
                          flush=True)


def mirror(args):
    from reflector_scenes import mirror_pair_scene
    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation
    from sionnafmcw.animation.model import RadarPose

    radar = RadarConfig.preset("walk-77ghz")
    folder = pathlib.Path(tempfile.mkdtemp(prefix="po_bounces_"))
    print("mirror-image 0.1 m trihedrals at (3, +-1.5) m, three bounces; left, right |h|^2 (dB) and left - right")
    for aspect in (0, 15, 30, 45):
        anim = load_animation(mirror_pair_scene(folder / f"pair_{aspect}", 0.1, 3.0, 1.5, np.deg2rad(aspect)))
        for name in VARIANTS:
            engine = engine_of(name, max_depth=3, diffuse=False)
            row, seconds = [], []
            for x in (0.0, 0.2, 0.4):
                pose = RadarPose(np.array([x, -radar.phase_centre[1], 1.0]), np.zeros(3))
                t0 = time.perf_counter()
                e = engine.echoes(anim, radar, 0, radar_pose=pose)
                seconds.append(time.perf_counter() - t0)
                left, right = (db(channel_power(e, radar, lab)) for lab in ("left", "right"))
                row.append(f"x={x:.1f}: {left:7.2f} {right:7.2f} {left - right:+5.2f}")
            print(f"aspect {aspect:2d} deg {name}  " + "   ".join(row)
                  + f"   ({np.mean(seconds[1:]):.2f} s a new pose)", flush=True)


def grid(args):
    from reflector_scenes import reflector_scene
    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation

    radar = RadarConfig.preset("walk-77ghz").replace(antenna_pattern="iso", num_chirps=16)
    folder = pathlib.Path(tempfile.mkdtemp(prefix="po_bounces_"))
    print("|h|^2 dB: converged (C at po_samples_across=128); A, B and C at the default 16 minus it; samples per "
          "bounce of the sampled render")
    for kind in args.kinds:
        depth = 3 if kind == "trihedral" else 2
        for leg in (0.05, 0.1, 0.3):
            for distance in (1.0, 3.0, 10.0):
                for aspect in (0, 15, 30, 45):
                    anim = load_animation(reflector_scene(folder / f"{kind}_{leg}_{distance}_{aspect}", kind, leg,
                                                          distance, np.deg2rad(aspect)))
                    out = {}
                    for name, variant, n in (("ref", "C", 128), ("A", "A", 16), ("B", "B", 16), ("C", "C", 16)):
                        engine = engine_of(variant, po_samples_across=n, max_depth=depth, diffuse=False)
                        t0 = time.perf_counter()
                        e = engine.echoes(anim, radar, 0)
                        out[name] = (db(channel_power(e, radar)), [b.num_samples for b in engine.last_renders],
                                     time.perf_counter() - t0)
                    ref = out["ref"][0]
                    print(f"{kind:9s} {leg:4.2f} m {distance:4.1f} m {aspect:2d} deg  converged {ref:8.2f}  "
                          f"A {out['A'][0] - ref:+6.2f} {out['A'][1]}  B {out['B'][0] - ref:+6.2f} {out['B'][1]}  "
                          f"C {out['C'][0] - ref:+6.2f}", flush=True)


def cost(args):
    from furnished_room import FURNITURE
    from walk_frames import cpu_seconds
    from sionnafmcw import RadarConfig, load_animation, scenes

    folder = pathlib.Path(args.scenes) if args.scenes else pathlib.Path(tempfile.mkdtemp(prefix="po_bounces_"))
    paths = {"walk": folder / "circle_walk",
             "room": folder / f"people_{args.frames}"}
    params = {"walk": ("circle_walk", {}),
              "room": ("people", {"num_people": 3, "activity": "walk", "seed": 1, "num_frames": args.frames,
                                  "fps": 24.0, **FURNITURE})}
    radar = RadarConfig.preset("walk-77ghz")
    for scene, path in paths.items():
        if not (path / "animation.json").is_file():
            scenes.build(params[scene][0], path, **params[scene][1])
        anim = load_animation(path)
        first, second = args.pair
        engines = {first: engine_of(first), second: engine_of(second)}
        rows = {first: [], second: []}
        echoes = {}
        for f in range(args.frames):
            for name in ((first, second) if f % 2 == 0 else (second, first)):
                w0, c0 = time.perf_counter(), cpu_seconds()
                e = engines[name].echoes(anim, radar, f)
                w1, c1 = time.perf_counter(), cpu_seconds()
                if f == 0:
                    echoes[name] = e
                stats = engines[name].last_stats
                rows[name].append((w1 - w0, c1 - c0, stats.figures.get("po_samples", 0),
                                   stats.figures.get("static_po_samples", 0)))
        print(f"{scene}: {args.frames} frames, {first} and {second} alternating")
        for name in (first, second):
            r = np.array(rows[name])
            print(f"  {name}: first frame {r[0, 0]:.2f} s wall {r[0, 1]:.2f} s CPU, static PO samples "
                  f"{int(r[0, 3])}; steady {r[1:, 0].mean():.3f} s wall {r[1:, 1].mean():.3f} s CPU per frame, "
                  f"frame PO samples {r[1:, 2].mean():.0f}")
        labels = sorted(set(np.unique(echoes[first].labels[0, 0])) | set(np.unique(echoes[second].labels[0, 0])))
        change = {lab: db(channel_power(echoes[second], radar, lab) / channel_power(echoes[first], radar, lab))
                  for lab in labels}
        moved = {lab: d for lab, d in change.items() if abs(d) > 0.05}
        print(f"  frame 0, {second} - {first} per object (|h|^2, dB): "
              + (", ".join(f"{lab} {d:+.2f}" for lab, d in moved.items()) or "none moved by more than 0.05")
              + f"; the other {len(change) - len(moved)} within 0.05")
        a, b = np.array(rows[first]), np.array(rows[second])
        print(f"  {second}/{first}: first frame wall {b[0, 0] / a[0, 0]:.3f}; steady wall "
              f"{b[1:, 0].mean() / a[1:, 0].mean():.3f}, CPU {b[1:, 1].mean() / a[1:, 1].mean():.3f}", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("issue", "mirror", "grid", "cost"))
    parser.add_argument("--kinds", nargs="+", default=["trihedral", "dihedral"], choices=("trihedral", "dihedral"))
    parser.add_argument("--frames", type=int, default=13, help="cost: frames per scene (the first apart)")
    parser.add_argument("--scenes", default=None, help="cost: folder of the scenes (built there when missing)")
    parser.add_argument("--pair", nargs=2, default=["B", "C"], choices=tuple(VARIANTS),
                        help="cost: the two variants that take turns (default: B then C, the exact apertures' cost)")
    args = parser.parse_args(argv)
    {"issue": issue, "mirror": mirror, "grid": grid, "cost": cost}[args.mode](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
