r"""Cost of a data-set frame by stage: a person jumping in a room, RadHAR's IWR1443, A against B.

What it measures: :func:`sionnafmcw.simulation.simulate` of the ``jump`` activity (CMU 75_10) with
``room=true``, 60 frames at 30 fps (built once, ``--scene`` to reuse one), with the path engine's
defaults and the radar of RadHAR's IWR1443 ``.cfg`` (16 chirp loops x 3 Tx x 4 Rx x 240 samples).
That file also holds the out-of-box demo's processing lines (``guiMonitor``, ``cfarCfg``,
``peakGrouping``, ``multiObjBeamForming``, ``clutterRemoval``, ``calibDcRangeSig``,
``compRangeBiasAndRxChanPhase``, ``measureRangeBiasAndRxChanPhase``, ``CQRxSatMonitor``,
``CQSigImgMonitor``, ``analogMonitor``); the benchmark reads a copy without them
(:data:`PROCESSING_COMMANDS`), since they configure the on-chip processing and monitors, not the
transmitted chirps or the sampled beat signal, so the RF signal is the file's.

Each run is a subprocess (``--worker``) that imports ``sionnafmcw`` from its tree (``--tree-a`` /
``--tree-b``: a checkout, e.g. ``git archive 39034ed | tar -x -C /tmp/treeA``), A and B alternating
(``--repeats`` pairs), as :mod:`circle_walk` runs them (its ``launch``). Per run: wall and CPU seconds
of ``simulate`` (user + system of the worker, all threads), the first frame apart (scene load,
kernel compilation), and per stage the wall seconds summed over frames:

* the engine's own figures (``geometry``: Mitsuba's vertex update of the moving meshes, ``static``:
  the static block, ``trace``: Sionna's trace, ``adapt``: paths to element pairs, ``po``: the PO
  stage);
* timers the worker wraps around the functions behind them, where the tree has them
  (``load``: scene load and engine set-up of the first frame, ``place``: the smooth surfaces placed
  in the frame, ``po_render``: the PO render (rays cast, samples on the surfaces, reflections),
  ``po_integral``: the PO integral per element pair, ``po_merge``: the merge, ``synth``: the beat
  synthesis, ``store``: the store writes; synthesis and store run on a worker thread, overlapping
  the engine's next frame).

Accuracy, B against A (noise seed 0 in both, so the same noise): per frame the cube power (dB)
and the strongest range-Doppler cell, of the whole map and of the moving part (Doppler bin 0
left out): ``|dP| max`` (dB), cells that differ, and the cube error power relative to A's echo
``err dB`` (:math:`10\log_{10}\sum|x_B - x_A|^2/\sum|x_A|^2`).

    python benchmarks/frame_cost.py --tree-a /tmp/treeA [--frames 60] [--repeats 2] [--scene DIR]
    python benchmarks/frame_cost.py --tree-a /tmp/treeA --sequential 12    # per-stage CPU, no overlap
    python benchmarks/frame_cost.py --tree-a /tmp/treeA --item ITEM_DIR --sequential 12   # a data-set item

Measured
--------
On the 2-core AMD EPYC (no AVX-512 VP2INTERSECT), shared with six other sessions at the time (load
average 8-11, so the wall times are stretched and only the ratios and the CPU seconds compare),
main at 39034ed (A, ``git archive 39034ed | tar -x -C /tmp/fc/treeA``) against the static block
filtered once and the render's curvature classes (B), the scene built with
``sionnafmcw scene build jump /tmp/fc/jump --param room=true --param num_frames=60 --param fps=30``::

    python benchmarks/frame_cost.py --scene /tmp/fc/jump --out /tmp/fc/out --frames 60 --repeats 2 \
        --tree-a /tmp/fc/treeA --json /tmp/fc/ab1.json

    run     wall s   cpu s s/frame  cpu/fr  first steady  adapt geometry     po static  trace |   load  place po_integral po_merge po_render po_static_frame  store  synth
    A1       282.2    97.7   4.703   1.628  10.83  2.886   4.54     6.44 123.27   7.26  34.17 |   1.75   0.10       30.95    14.60     64.00           76.95   2.72 268.28
    B1       159.0    58.8   2.649   0.981   9.75  2.358   4.09     7.33  97.65   6.18  28.98 |   2.03   0.04       20.23     8.73     57.71           69.48   6.05 142.85
    A2       269.7   104.0   4.494   1.734   8.62  2.639   3.67     5.71 114.02   4.94  30.31 |   1.77   0.07       29.29    13.46     57.74           70.53   2.80 257.95
    B2       131.8    59.2   2.197   0.987   7.31  1.947   3.52     5.75  82.57   4.85  24.04 |   1.32   0.03       18.49     7.71     45.77           56.59   5.25 118.95

    per frame: A po_rays 196748, po_samples 121946 (= po_contributions: nothing merges), B 160489 and 85537;
    static_po_samples 425240 and static_paths 7946 both
    pair 1: time B/A 0.563, CPU B/A 0.602; echoes: |dP| max 0.041 dB, strongest cell differs in 0 frames,
            strongest moving cell in 4, error -27.1 dB of A's cube power
    pair 2: time B/A 0.489, CPU B/A 0.569; (the same echo figures)

The same command half an hour later with ``--repeats 1 --out /tmp/fc/out2``, the machine quieter
(load average 3-5)::

    run     wall s   cpu s s/frame  cpu/fr  first steady  adapt geometry     po static  trace |   load  place po_integral po_merge po_render po_static_frame  store  synth
    A1        85.4    88.5   1.423   1.475   3.13  0.960   1.41     2.65  40.30   1.89   9.78 |   0.64   0.05       10.23     4.94     20.36           24.73   1.39  80.71
    B1        47.5    53.7   0.791   0.895   3.13  0.783   1.20     2.36  29.61   1.84   7.85 |   0.70   0.03        6.60     2.85     16.21           20.25   2.52  41.64

    pair 1: time B/A 0.556, CPU B/A 0.607; echoes as above (bit for bit the same cubes as the first run's)

Per frame, first frame included: A 1.48-1.73 CPU-s (1.42 s wall on the quieter machine, 4.5-4.7 s
under load), B 0.90-0.99 CPU-s (0.79 s; 2.2-2.6 s); CPU B/A 0.57-0.61, wall B/A 0.49-0.56. The
strongest range-Doppler cell is the same in all 60 frames and the cube power within 0.041 dB; the
strongest cell off zero Doppler (the body) moves in 4 frames, each time between two cells within
0.02-1.3 dB of each other in both runs (near ties: adjacent range bins 137/138 at Doppler bin 15,
and two cells of the jumping body 0.4 dB apart);
the power off zero Doppler changes by 0.003 dB on average, 0.67 dB at most (one frame).

Where a frame went (A) and why it cost twice the walk's although its cube is 20x smaller: the
cost grows with the echo's contributions, not with the cube. Engine and synthesis one after the
other in one thread of control, CPU-s (the engine's stages in wall seconds a frame)::

    python benchmarks/frame_cost.py --scene /tmp/fc/jump --out /tmp/fc/out3 --tree-a /tmp/fc/treeA --sequential 12

    A: frame 0 engine 4.15 + synthesis 3.25 CPU-s; frames 1-12: engine 0.868 + synthesis 1.016 CPU-s a frame;
       engine stages (wall s a frame): geometry 0.057, static 0.000, trace 0.235, adapt 0.030, po 1.060
    B: frame 0 engine 3.23 + synthesis 3.24 CPU-s; frames 1-12: engine 0.632 + synthesis 0.365 CPU-s a frame;
       engine stages (wall s a frame): geometry 0.057, static 0.000, trace 0.236, adapt 0.026, po 0.715

(frame 0: scene load and the static block, the room's 425k PO samples and their 433k-contribution
cube at a tenth of the budget; an earlier run of the same measurement gave frame 0 A 4.4 + 3.9,
B 4.8 + 3.7 CPU-s, steady A 0.87 + 1.22, B 0.66 + 0.36: frame 0 moves by a second with the load.)
A cProfile of B's steady frames (4 frames, one process) splits its PO stage into the frame's own
renders (``StaticPO.frame``, 0.36 s a frame: the body's render 0.18, its reflections 0.11, the
blocked static samples 0.07), the PO integral (``element_pair_po``, 0.11) and the merge's tries
(0.05).

* The synthesis filtered the room's static block (433k contributions) through the IF chain of
  the TI receiver in every frame although its cube is cached: 0.3 CPU-s a frame of work done
  twice. Now each part goes through the chain when its cube is computed.
* The body's PO samples did not depend on the radar's range (the rule's sample size is
  :math:`\frac14\sqrt{\lambda\min(R, \rho)}`, and :math:`\rho \ll R`), nor on its resolution:
  on the curvature. Each object was rendered on one grid at its most curved 2 %'s radius: the
  two forearm-and-hand objects, whose flattened hand has a 6.3 mm rim, at 1.2 mm all over: 29.5k
  of the body's 62.8k first-bounce samples, and as many second-bounce samples (their reflections,
  mostly on the floor and walls). With a grid per curvature class (``po_render``, *Curvature
  classes*) the body has 40.5k and the frame 85.5k PO contributions instead of 122k.
* Nothing merges with this radar (``po_contributions`` = ``po_samples``): the merge's error bound
  on the body's first bounce is 590 times its budget (7.9e-9 sqrt(W) per sample) in cells of 1/64
  of the resolutions and still 18 times in cells of 1/256, where merging would remove only 16 %
  of the contributions (less than ``MIN_SAVING``); the room's static renders likewise. The
  merge's tries cost 0.05-0.13 s a frame for nothing, and the synthesis pays per contribution.

What is left per steady frame (B, CPU-s, one thread of control: engine 0.63-0.66, synthesis 0.36),
and what would remove it:

* the body's PO render (rays, samples on the smooth surface: 0.18 s) and its second bounce
  (0.11 s; about half of the frame's 85k contributions are the body's reflections, mostly onto the
  floor and walls, and take about half of the PO integral, 0.11 s in all, and of the synthesis):
  a sample budget for the bounces;
* the merge's failing tries (0.05 s) and a synthesis per contribution (0.36 s): a merge whose
  bound admits the cells this radar cannot resolve (the bound is a worst case over element pairs,
  2-10 times the measured merge error, ``benchmarks/po_merge.py``);
* Sionna's full trace of the room every frame for the paths that touch the body (0.13-0.24 s):
  a trace of the rays that can reach a moving object;
* the first frame's scene load and static block (6.5-8.5 CPU-s: 0.11-0.14 CPU-s a frame over 60
  frames, about 2 CPU-s a frame over a 4-frame data-set item): kept across the items of a worker
  when the room and the radar's pose repeat.

A quarter of A's CPU (0.37-0.43 CPU-s a frame) is not reached by these two changes (0.57-0.61).

Later, on the 2-core AMD EPYC with AVX-512 (quiet but for this run), main at 8d4614a (A,
``/tmp/fc/treeM``) against the IF chain's gain by table (:func:`sionnafmcw.receiver.if_filter.tabulated_response`),
the still contributions' 1-D sum (``sionnafmcw.synthesis.nufft``, *Still contributions*), the blocked static
samples' contributions taken from the static block and index-gathered selections (B), and main at the
issue's baseline 96e6099 (``/tmp/fc/treeA``) against B::

    python benchmarks/frame_cost.py --tree-a /tmp/fc/treeM --frames 60 --repeats 2 --scene /tmp/fc/out/jump
    python benchmarks/frame_cost.py --tree-a /tmp/fc/treeA --frames 60 --repeats 1 --scene /tmp/fc/out/jump
    python benchmarks/frame_cost.py --tree-a /tmp/fc/treeM --item ITEM --sequential 12

    jump scene, 8d4614a -> B: CPU B/A 0.980 and 0.964 (wall 0.976, 0.971); 0.96-1.00 CPU-s a frame;
        cube error -83.1 dB of A's power (the table's 1e-6), the strongest cells the same in all frames
    jump scene, 96e6099 -> B: CPU B/A 0.621, wall 0.661 (0.92 against 1.48 CPU-s a frame)
    a RadHAR item (boxing, a furnished room, the item's drawn receiver: run4 item 000020),
        A: frame 0 engine 14.57 + synthesis 4.52 CPU-s; frames 1-12 engine 1.112 + synthesis 0.715
        B: frame 0 engine 13.22 + synthesis 3.21 CPU-s; frames 1-12 engine 1.097 + synthesis 0.576
        (frame 0 -14 %, a steady frame -8 %, its synthesis -19 %)

The item's frame carries 1.08e6 contributions per element pair, 0.90e6 of them the cached static block;
of the 0.175e6 summed every frame 0.099e6 are the body's PO and 0.075e6 the static samples the body
blocks, its shadow on the room and the furniture with the opposite sign (the engine's ``last_stats``
figures ``po_contributions`` and ``static_po_removed``, frames 0-2). What is left of its 1.67 CPU-s
(engine wall s a frame: the PO stage 0.45, of it the body's render and its reflections about 0.25 by a
cProfile of 12 steady frames; Sionna's trace 0.10 for the 450 or so paths of the frame that touch the
body; synthesis 0.58 CPU-s, most of it the 2-D transforms of the body's contributions), and what would
remove it:

* the blocked static samples (0.075e6 a frame, as many as half the body's), whose sum is now the cheap
  1-D one (they are still): finding them every frame (the cone test against the body's spheres, the
  casts, taking them out of merged cells: about 0.1 s a frame) could keep an anchor set and test only
  the samples near the shadow's edge;
* Sionna's full trace every frame for the few paths that touch the body: a trace of the rays that can
  reach a moving object;
* the body's PO samples (0.1e6, the in-sample quadratic-phase bound on curved limbs): a footprint
  integral exact in the quadratic phase (Fresnel) would allow samples about twice as wide.

None of these reaches a quarter of 96e6099's CPU on its own; together they might approach a half of
today's.

The exact apertures of plane-faced objects (:mod:`sionnafmcw.engines.flat_faces`) against aa66791 on the
jump scene (``--tree-a <aa66791> --frames 45 --repeats 1``, beside a test run): time B/A 1.011, CPU B/A
0.998, every cube bit for bit the same (no object of the scene is plane-faced).

The blocked static samples of a bounce the merge left as it was: ``merge_contributions`` answers a
``Merged`` whose ``fraction`` is None when no cell size is worth it, and the static block took that for
merged cells, so every frame computed the blocked samples' contributions again (the PO kernel on a
selection of the static render) and took them out of one-sample cells, where the block holds them
already (:meth:`~sionnafmcw.engines.static_scene.StaticPO.frame`). Now such a bounce is held unmerged.
With the ray index's cones queried at once per group, against fe1d74b (A; B = 728adc4, the kept
blocks below do not act within one run), 2-core AMD EPYC with AVX-512, quiet::

    python benchmarks/frame_cost.py --tree-a <fe1d74b> --tree-b <728adc4> --frames 45 --repeats 2 --scene <jump>
    python benchmarks/frame_cost.py --tree-a <fe1d74b> --tree-b <c54a091> --item <run4 item 000020> --sequential 12

    jump scene: CPU B/A 0.968 and 0.932 (wall 0.980, 0.931), every cube bit for bit (error -inf dB)
    RadHAR item: steady frame engine 0.991 -> 0.850 CPU-s, synthesis 0.554 -> 0.544; frame 0 engine 12.59 -> 11.78
    jump scene against 96e6099 (``--tree-a /tmp/fc/treeA --tree-b <c54a091> --frames 45 --repeats 1``):
        CPU B/A 0.649, wall 0.649 (0.94 against 1.44 CPU-s a frame, first frame included)

Where a frame's time goes now (``--profile``: a ``cProfile`` of frame 0 and of frames 1-12, engine and
synthesis one after the other, the stages of :data:`PROFILE_STAGES`; its overhead is in the figures)::

    python benchmarks/frame_cost.py --tree-a . --only A --scene <jump> --sequential 12 --profile
    python benchmarks/frame_cost.py --tree-a . --only A --item <run4 item 000020> --sequential 12 --profile

    wall ms                                    jump: frame 0  a later frame   RadHAR item: frame 0  a later frame
    trace: Sionna's paths                            124        60.7                 188          90.9
    traced paths to element pairs                     30         7.9                  75          13.9
    geometry: Sionna's meshes                          0        19.7                   0          23.2
    PO render: first bounce                          400        85.2                 297          90.7
    PO render: reflections                           305        66.5                 572          77.3
    bounce rule (bounds, quarters, joins, channels) 4127         0                  6111           0
    PO: static samples blocked (cones, casts, ends)   15        13.3                  57          58.7
    PO integral per element pair                     236        38.1                 459          45.0
    PO merge's tries                                 229        31.9                 554          36.7
    synthesis: IF chain's gains                      912        19.3                1038          39.6
    synthesis: beat sum (finufft)                    761       186.7                1442         295.4
    other                                           1348        37.0                2289          78.1
    total                                           8488       567.2               13084         850.5

CPU a frame (the same runs): jump 0.666 engine + 0.351 synthesis; the item 0.915 + 0.548. What is left
and what would remove it (the beat sum and the PO render are 0.60 of a later frame of the jump scene;
a quarter of 96e6099's 1.44-1.48 CPU-s a frame is 0.36-0.37 CPU-s, against today's 1.02):

* the beat sum, a third of a later frame: the body's 85-100k PO contributions through twelve 2-D type-3
  transforms at the noise floor's tolerance. Fewer contributions would remove it: a merge whose bound
  admits the cells this radar cannot resolve (the bound is 2-10 times the merge error it bounds,
  ``benchmarks/po_merge.py``; the merge's tries, 6 %, find nothing worth it here), or samples about twice
  as wide with a footprint integral exact in the quadratic phase;
* the PO render, a quarter: 159k rays cast for the body's 40k first-bounce samples (its classes' bounding
  boxes) and the second bounce of every sample onto floor and walls;
* Sionna's trace, a tenth: the room's candidates every frame for the ~20 paths through the body. Dropping
  the candidates that touch no moving object before the image method (``PathsBuffer.gather``) gave the
  same cubes bit for bit (an ad hoc check, four frames of the RadHAR item), but Dr.Jit then compiles
  other kernels as the kept count changes (6 new kernel hashes in frame 2 of
  ``tests/test_path_engine.py::test_no_kernel_compiled_after_frame_two``): left;
* frame 0's bounce rule, 4-6 s (the room's corner apertures, four rounds of quarters over 144-266k
  tubes): kept across a worker's items where the room repeats
  (:func:`sionnafmcw.engines.path.keep_static_blocks`, ``benchmarks/dataset.py``). Within one build, a
  neighbour search kept across rounds is exact only when it asks again every probe a new centre may now
  be nearest to; a ball of the first round's bound around each new centre finds ~500 probes per centre
  by the fourth round in the refined bands (14.6 s against 1.6 s for the four full searches in the circle
  walk's room, timed ad hoc; the tables were the full search's in all four rounds): a per-probe radius is
  what that needs.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import time
from pathlib import Path

import circle_walk
import walk_frames

REPO = Path(__file__).resolve().parents[1]
RADHAR_CFG = Path("/work/shared/realdata/radhar/1443es1_short_range_3d.cfg")

#: Lines of a TI mmWave SDK .cfg that configure the on-chip processing, the GUI and the monitors,
#: not the RF front end (chirps, frame, channels, ADC): left out of the benchmark's copy.
PROCESSING_COMMANDS = ("guiMonitor", "cfarCfg", "peakGrouping", "multiObjBeamForming", "clutterRemoval",
                       "calibDcRangeSig", "compRangeBiasAndRxChanPhase", "measureRangeBiasAndRxChanPhase",
                       "CQRxSatMonitor", "CQSigImgMonitor", "analogMonitor", "extendedMaxVelocity",
                       "lowPower", "bpmCfg", "lvdsStreamCfg", "nearFieldCfg", "aoaFovCfg", "cfarFovCfg")

# ----------------------------------------------------------------------------- worker (one run)
#: (module, attribute, stage): functions the worker times; a method is "Class.method".
TIMED = [
    ("sionnafmcw.engines.loaded_scene", "load_radar_scene", "load"),
    ("sionnafmcw.engines.loaded_scene", "LoadedScene.load", "load"),
    ("sionnafmcw.engines.path", "PathEngine._load", "load"),
    ("sionnafmcw.engines.surfaces", "SurfaceWorld.place", "place"),
    ("sionnafmcw.engines.po_render", "render", "po_render"),
    ("sionnafmcw.engines.po_render", "reflect", "po_render"),
    ("sionnafmcw.engines.static_scene", "StaticPO.frame", "po_static_frame"),
    ("sionnafmcw.engines.po_kernel", "element_pair_po", "po_integral"),
    ("sionnafmcw.engines.po_merge", "merge_contributions", "po_merge"),
    ("sionnafmcw.simulation", "synthesize", "synth"),
    ("sionnafmcw.store", "RunStore.write_frame", "store"),
]


def install_timers(totals: dict) -> None:
    """Wrap every :data:`TIMED` function the tree has so that its wall seconds add to ``totals[stage]``
    (outermost call only: a timed function calling another of the same stage counts once)."""
    import threading

    depth = threading.local()

    def wrap(fn, stage):
        @functools.wraps(fn)
        def timed(*args, **kwargs):
            d = getattr(depth, stage, 0)
            setattr(depth, stage, d + 1)
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                setattr(depth, stage, d)
                if d == 0:
                    totals[stage] = totals.get(stage, 0.0) + time.perf_counter() - t0
        return timed

    wrap_stages(TIMED, wrap)


def wrap_stages(timed: list, wrap, skip=lambda fn: False) -> None:
    """Replace every function ``(module, "name" or "Class.name", stage)`` of ``timed`` that the tree has
    by ``wrap(fn, stage)`` (class and static methods kept as such; ``skip(fn)`` true: left as it is)."""
    import importlib

    for module_name, attr, stage in timed:
        try:
            module = importlib.import_module(module_name)
        except ImportError:
            continue
        owner, name = module, attr
        if "." in attr:
            cls, name = attr.split(".")
            owner = getattr(module, cls, None)
        if owner is None or not hasattr(owner, name):
            continue
        fn = owner.__dict__[name] if isinstance(owner, type) else getattr(owner, name)
        if skip(getattr(fn, "__func__", fn)):
            continue
        if isinstance(fn, classmethod):
            setattr(owner, name, classmethod(wrap(fn.__func__, stage)))
        elif isinstance(fn, staticmethod):
            setattr(owner, name, staticmethod(wrap(fn.__func__, stage)))
        else:
            setattr(owner, name, wrap(fn, stage))


def rd_summary(cubes):
    """Per frame: cube power (dB), strongest range-Doppler cell of the map and of its moving part."""
    import numpy as np

    x = np.asarray(cubes)                                       # [frame, chirp, tx, rx, sample]
    power = 10 * np.log10(np.mean(np.abs(x) ** 2, axis=(1, 2, 3, 4)))
    spec = np.fft.fft(np.fft.fft(x, axis=-1), axis=1)           # range over samples, Doppler over chirps
    rd = np.sum(np.abs(spec) ** 2, axis=(2, 3))                  # [frame, doppler, range]
    n_d = rd.shape[1]
    peak = [np.unravel_index(int(np.argmax(m)), m.shape) for m in rd]
    moving = rd.copy()
    moving[:, 0, :] = 0
    peak_moving = [np.unravel_index(int(np.argmax(m)), m.shape) for m in moving]
    return {"power_db": power.tolist(), "peak": [[int(a), int(b)] for a, b in peak],
            "peak_moving": [[int(a), int(b)] for a, b in peak_moving], "num_doppler": n_d}


#: ``--profile``: the stages of a frame as the functions that do them, ``(stage, module, qualified name)``; none
#: calls another, so their times add up (the rest is ``other``). A later frame's own PO stage is the moving
#: objects' render and its reflections, the search for the static samples they block, the PO integral and the
#: merge's tries; frame 0 also builds the static block (its trace, render, reflections, bounce rule, PO integral
#: and, in the synthesis, its cube), whose work falls into the same stages.
PROFILE_STAGES = [
    ("trace: Sionna's paths", "sionnafmcw.engines.traced_paths", "trace_paths"),
    ("traced paths to element pairs", "sionnafmcw.engines.path", "PathEngine._traced_echoes"),
    ("geometry: Sionna's meshes", "sionnafmcw.engines.loaded_scene", "LoadedScene.update_geometry"),
    ("geometry: smooth surfaces placed", "sionnafmcw.engines.surfaces", "SurfaceWorld.place"),
    ("PO render: first bounce", "sionnafmcw.engines.po_render", "render"),
    ("PO render: reflections", "sionnafmcw.engines.po_render", "reflect"),
    ("bounce rule: apertures' bounds", "sionnafmcw.engines.bounce_sampling", "under_resolved"),
    ("bounce rule: quarters cast", "sionnafmcw.engines.bounce_sampling", "quartered"),
    ("bounce rule: renders joined", "sionnafmcw.engines.bounce_sampling", "_joined"),
    ("bounce rule: channels", "sionnafmcw.engines.bounce_sampling", "monostatic_channels"),
    ("PO: static samples blocked (cones)", "sionnafmcw.engines.static_scene", "RayIndex.meet"),
    ("PO: static samples blocked (casts)", "sionnafmcw.engines.static_scene", "blocked_in_world"),
    ("PO: static rays ending on a moving object", "sionnafmcw.engines.static_scene", "first_hit_moving"),
    ("PO integral per element pair", "sionnafmcw.engines.po_kernel", "element_pair_po"),
    ("PO merge's tries", "sionnafmcw.engines.po_merge", "merge_contributions"),
    ("synthesis: IF chain's gains", "sionnafmcw.receiver", "filter_echoes"),
    ("synthesis: beat sum (finufft)", "sionnafmcw.synthesis.nufft", "beat_nufft"),
]


def stage_profile(stats) -> dict:
    """Seconds per stage of :data:`PROFILE_STAGES` (their cumulative times in the ``pstats.Stats``
    ``stats``) and ``other`` (the profiled total less their sum)."""
    import importlib
    import inspect

    out = {}
    for stage, module, qualname in PROFILE_STAGES:
        try:
            obj = importlib.import_module(module)
            for part in qualname.split("."):
                obj = getattr(obj, part)
            code = inspect.unwrap(obj).__code__
        except (ImportError, AttributeError):
            continue   # a tree without it
        key = (code.co_filename, code.co_firstlineno, code.co_name)
        out[stage] = out.get(stage, 0.0) + (stats.stats[key][3] if key in stats.stats else 0.0)
    out["other"] = stats.total_tt - sum(out.values())
    return out


def sequential(spec: dict) -> dict:
    """``--sequential``: frame 0, then frames 1..N, each frame's engine and synthesis one after the other
    in one thread of control (no overlap), CPU seconds of each and the engine's stage figures; with
    ``profile``, the wall seconds per stage (:data:`PROFILE_STAGES`) of frame 0 and of frames 1..N summed,
    from a ``cProfile`` of each (its own overhead included)."""
    import cProfile
    import pstats

    import numpy as np

    from sionnafmcw import engines
    from sionnafmcw.animation import load_animation
    from sionnafmcw.radar import RadarConfig
    from sionnafmcw.synthesis import synthesize

    animation = load_animation(spec["scene"])
    radar = RadarConfig.resolve(spec["radar"])
    engine = engines.create("path", **spec["options"])
    cache, rows = {}, []
    profiles = [cProfile.Profile(), cProfile.Profile()] if spec.get("profile") else None
    for f in range(spec["frames"]):
        if profiles:
            profiles[min(f, 1)].enable()
        c0 = walk_frames.cpu_seconds()
        echoes = engine.echoes(animation, radar, f)
        c1 = walk_frames.cpu_seconds()
        synthesize(echoes, radar, frame_time=animation.frames[f].time, rng=np.random.default_rng([0, f]),
                   static_cache=cache)
        c2 = walk_frames.cpu_seconds()
        if profiles:
            profiles[min(f, 1)].disable()
        rows.append({"engine_cpu": c1 - c0, "synthesis_cpu": c2 - c1,
                     "stages": {k[:-8]: v for k, v in engine.last_stats.figures.items() if k.endswith("_seconds")}})
    out = {"rows": rows}
    if profiles:
        out["profile"] = [stage_profile(pstats.Stats(p)) for p in profiles]
    return out


def worker(spec: dict) -> dict:
    if spec.get("sequential"):
        return sequential(spec)
    t0 = time.perf_counter()
    circle_walk.limit_heap()
    import numpy as np

    from sionnafmcw import engines, sionna_rt  # noqa: F401
    from sionnafmcw.simulation import simulate

    totals: dict = {}
    install_timers(totals)
    t_import = time.perf_counter() - t0
    animation, radar, frames, engine, store = circle_walk.run_setup(spec, clear_store=True)
    cpu0 = walk_frames.cpu_seconds()
    t0 = time.perf_counter()
    run = simulate(animation, radar, engine=engine, out=store, frames=frames, progress=False, seed=0,
                   noise=spec["noise"])
    seconds = time.perf_counter() - t0
    cpu_seconds = walk_frames.cpu_seconds() - cpu0
    stats = list(engine.stats)
    accuracy = rd_summary(run.cubes(frames))
    per_frame = np.array([s.seconds for s in stats])
    keys = sorted({k for s in stats for k in s.figures if k.endswith("_seconds")})
    return {
        "options": spec["options"], "frames": len(frames), "import_seconds": t_import,
        "total_seconds": seconds, "cpu_seconds": cpu_seconds, "seconds_per_frame": seconds / len(frames),
        "cpu_per_frame": cpu_seconds / len(frames),
        "engine_seconds": float(per_frame.sum()), "first_frame_seconds": float(per_frame[0]),
        "steady_median": float(np.median(per_frame[1:])) if len(per_frame) > 1 else None,
        "kernels_compiled_first": stats[0].kernels_compiled,
        "kernels_compiled_rest": int(sum(s.kernels_compiled for s in stats[1:])),
        "stage_seconds": {k[:-8]: float(sum(s.figures.get(k, 0.0) for s in stats)) for k in keys},
        "first_stage_seconds": {k[:-8]: float(stats[0].figures.get(k, 0.0)) for k in keys},
        "timed_seconds": totals,
        "counts": {k: float(np.mean([s.figures.get(k, 0) for s in stats]))
                   for k in ("po_rays", "po_samples", "po_contributions", "num_traced_paths", "static_po_samples",
                             "static_paths")},
        "accuracy": accuracy, "store": str(store),
    }


# ----------------------------------------------------------------------------- parent
def radar_copy(cfg: Path, out: Path) -> Path:
    """``cfg`` without its processing lines (:data:`PROCESSING_COMMANDS`), written to ``out``."""
    lines = [ln for ln in cfg.read_text().splitlines()
             if not ln.strip().split(" ")[0] in PROCESSING_COMMANDS]
    out.write_text("\n".join(lines) + "\n")
    return out


def compare(a: dict, b: dict) -> dict:
    """B's echoes against A's (module docstring)."""
    import numpy as np
    import zarr

    pa, pb = np.array(a["accuracy"]["power_db"]), np.array(b["accuracy"]["power_db"])
    xa = zarr.open_group(a["store"], mode="r")["iq"][:]
    xb = zarr.open_group(b["store"], mode="r")["iq"][:]
    n = min(len(pa), len(pb))
    err = 10 * np.log10(np.sum(np.abs(xb[:n] - xa[:n]) ** 2) / np.sum(np.abs(xa[:n]) ** 2))
    return {"max_abs_power_db": float(np.max(np.abs(pb[:n] - pa[:n]))),
            "peak_differs": int(sum(x != y for x, y in zip(a["accuracy"]["peak"], b["accuracy"]["peak"]))),
            "peak_moving_differs": int(sum(x != y for x, y in zip(a["accuracy"]["peak_moving"],
                                                                   b["accuracy"]["peak_moving"]))),
            "error_db": float(err)}


def print_table(runs: list[dict]) -> dict:
    stages = sorted({k for r in runs for k in r["stage_seconds"]})
    timed = sorted({k for r in runs for k in r["timed_seconds"]})
    head = (f"{'run':<6} {'wall s':>7} {'cpu s':>7} {'s/frame':>7} {'cpu/fr':>7} {'first':>6} {'steady':>6} "
            + "".join(f"{k:>{max(len(k), 6)}} " for k in stages) + "| "
            + "".join(f"{k:>{max(len(k), 6)}} " for k in timed))
    print(head)
    print("-" * len(head))
    for r in runs:
        print(f"{r['label']:<6} {r['total_seconds']:7.1f} {r['cpu_seconds']:7.1f} {r['seconds_per_frame']:7.3f} "
              f"{r['cpu_per_frame']:7.3f} {r['first_frame_seconds']:6.2f} {r['steady_median'] or 0:6.3f} "
              + "".join(f"{r['stage_seconds'].get(k, float('nan')):{max(len(k), 6)}.2f} " for k in stages) + "| "
              + "".join(f"{r['timed_seconds'].get(k, float('nan')):{max(len(k), 6)}.2f} " for k in timed))
    print()
    for r in runs:
        print(f"{r['label']}: per frame {', '.join(f'{k} {v:.0f}' for k, v in r['counts'].items())}; kernels "
              f"compiled first frame {r['kernels_compiled_first']}, later {r['kernels_compiled_rest']}")
    pairs = {}
    for r in runs:
        pairs.setdefault(r["pair"], {})[r["method"]] = r
    summary = {"pairs": []}
    for i, p in sorted(pairs.items()):
        if "A" not in p or "B" not in p:
            continue
        a, b = p["A"], p["B"]
        c = compare(a, b)
        row = {"time_ratio": b["total_seconds"] / a["total_seconds"], "cpu_ratio": b["cpu_seconds"] / a["cpu_seconds"],
               **c}
        summary["pairs"].append(row)
        print(f"pair {i}: time B/A {row['time_ratio']:.3f}, CPU B/A {row['cpu_ratio']:.3f}; echoes: |dP| max "
              f"{c['max_abs_power_db']:.3f} dB, strongest cell differs in {c['peak_differs']} frames, strongest "
              f"moving cell in {c['peak_moving_differs']}, error {c['error_db']:.1f} dB of A's cube power")
    return summary


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--repeats", type=int, default=2, help="A/B pairs, alternated")
    p.add_argument("--scene", default=None, help="existing jump scene (default: build one under --out)")
    p.add_argument("--item", default=None, help="a data-set item folder instead (its scene/ and the radar of its "
                   "item.json, receiver draws included): e.g. a RadHAR item of validation/sim_to_real_radhar.py")
    p.add_argument("--out", default="out/bench_frame_cost")
    p.add_argument("--cfg", default=str(RADHAR_CFG), help="TI .cfg of the radar (processing lines left out)")
    p.add_argument("--method-a", type=lambda s: circle_walk.json_dict(s, "--method-a"), default={})
    p.add_argument("--method-b", type=lambda s: circle_walk.json_dict(s, "--method-b"), default={})
    p.add_argument("--only", choices=("A", "B"), default=None, help="run one method only (profiling)")
    p.add_argument("--no-noise", action="store_true", help="simulate without receiver noise")
    p.add_argument("--sequential", type=int, default=0, metavar="N",
                   help="instead: frames 0..N, engine and synthesis one after the other, CPU seconds of each")
    p.add_argument("--profile", action="store_true",
                   help="with --sequential: wall ms per stage (PROFILE_STAGES) of frame 0 and of a later frame")
    p.add_argument("--json", default=None)
    circle_walk.add_tree_and_worker_arguments(p)
    args = p.parse_args(argv)
    if circle_walk.ran_as_worker(args, worker):
        return 0
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    item_radar = None
    if args.item:
        if args.scene:
            p.error("--item and --scene: give one")
        record = Path(args.item) / "item.json"
        try:
            item_radar = json.loads(record.read_text())["radar"]
        except (OSError, ValueError, KeyError) as exc:
            p.error(f"--item {args.item}: no readable item.json with a radar ({exc})")
        args.scene = str(Path(args.item) / "scene")
    if args.scene:
        scene = Path(args.scene)
        if not (scene / "animation.json").is_file():
            p.error(f"--scene {scene}: no animation.json there")
    else:
        from sionnafmcw.scenes import build
        scene = out / "jump"
        if not (scene / "animation.json").is_file():
            build("jump", scene, room=True, num_frames=args.frames, fps=30.0)
    cfg = Path(args.cfg)
    if not cfg.is_file():
        p.error(f"--cfg {cfg}: no such file")
    radar = radar_copy(cfg, out / "radar_rf.cfg")
    if item_radar is not None:
        radar = out / "radar_item.json"
        radar.write_text(json.dumps(item_radar))
    trees = circle_walk.tree_environments(p, args)
    methods = {"A": args.method_a, "B": args.method_b}
    if args.sequential:
        for method in ("A", "B") if args.only is None else (args.only,):
            spec = {"label": method, "scene": str(scene), "radar": str(radar), "frames": args.sequential + 1,
                    "options": methods[method], "sequential": True}
            result = circle_walk.launch(spec | {"profile": args.profile}, trees.get(method), __file__)
            rows = result["rows"]
            steady = rows[1:]
            stages = {k: sum(r["stages"].get(k, 0.0) for r in steady) / len(steady) for k in steady[0]["stages"]}
            print(f"{method}: frame 0 engine {rows[0]['engine_cpu']:.2f} + synthesis {rows[0]['synthesis_cpu']:.2f} "
                  f"CPU-s; frames 1-{args.sequential}: engine "
                  f"{sum(r['engine_cpu'] for r in steady) / len(steady):.3f} + synthesis "
                  f"{sum(r['synthesis_cpu'] for r in steady) / len(steady):.3f} CPU-s a frame; engine stages (wall s a "
                  f"frame): " + ", ".join(f"{k} {v:.3f}" for k, v in stages.items()))
            if args.profile:
                first, rest = result["profile"]
                print(f"  {method}, wall ms (cProfile)          frame 0   frames 1-{args.sequential}, a frame")
                for stage in rest:
                    print(f"  {stage:<42} {1e3 * first.get(stage, 0.0):9.0f} {1e3 * rest[stage] / len(steady):9.1f}")
                print(f"  {'total':<42} {1e3 * sum(first.values()):9.0f} {1e3 * sum(rest.values()) / len(steady):9.1f}")
        return 0
    runs = []
    for i in range(args.repeats):
        for method in ("A", "B") if args.only is None else (args.only,):
            label = f"{method}{i + 1}"
            print(f"-- run {label}", file=sys.stderr)
            spec = {"label": label, "scene": str(scene), "radar": str(radar), "frames": args.frames,
                    "options": methods[method], "store": str(out / f"run_{label}.zarr"), "noise": not args.no_noise}
            runs.append(circle_walk.launch(spec, trees.get(method), __file__) | {"method": method, "pair": i + 1,
                                                                        "label": label})
    summary = print_table(runs)
    if args.json:
        Path(args.json).write_text(json.dumps({"scene": str(scene), "radar": str(radar), "trees": trees,
                                               "methods": methods, "runs": runs, "summary": summary}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
