"""The PO contributions of a walk frame: numpy (A, the reference) against the Dr.Jit kernel (B), interleaved.

What it measures: for the PO renders of circle-walk frames at the path engine's defaults (the
static room's renders, built once per pose, and every frame's own: the body and its reflections),
the time to turn a render into ``(a, tau, doppler)`` for every element pair with the element gains,

* A: ``po_render.chain_po_gains`` with the gains of ``antenna.antenna_gain`` (numpy, as the engine
  did before ``engines/po_kernel.py``);
* B: ``po_kernel.element_pair_po`` (the engine's now),

one after the other on the same render, ``--repeats`` times (best of), in one process, and the
largest difference between them relative to the largest contribution. The kernels are compiled
(or read from Dr.Jit's cache) before the timing.

    python benchmarks/po_kernel.py [--scene DIR] [--frames 1 2 3] [--repeats 5]

Measured
--------
``python benchmarks/po_kernel.py --scene /tmp/cw8`` (the 100-frame circle walk, 8 mm body; 2-core
AMD EPYC, nothing else running; best of 5)::

    frame   render      samples   numpy s  kernel s   B/A  max |diff| / max |a|
    static  bounce 1     143893     0.273     0.050  0.18  9.2e-16
    static  bounce 2     143893     0.328     0.055  0.17  9.2e-16
    1       bounce 1      42681     0.076     0.017  0.22  1.2e-15
    1       bounce 2      42681     0.092     0.019  0.21  2.8e-15
    1       bounce 2        908     0.003     0.003  0.97  2.0e-15
    (frames 2 and 3 alike)
    all renders: numpy 1.104 s, kernel 0.215 s, B/A 0.19

The last render of a frame is the static chains that now end on the body (a few hundred
samples), where the kernel's fixed cost (building and launching two kernels) equals numpy's.

With the second-order in-sample factor (``physical_optics.footprint_factor``: the range curvature
and the shape operator of every sample, three sincos per element pair and sample), same command::

    frame   render      samples   numpy s  kernel s   B/A  max |diff| / max |a|
    static  bounce 1     143893     0.631     0.103  0.16  2.8e-15
    static  bounce 2     143893     0.490     0.100  0.20  4.7e-15
    1       bounce 1      42681     0.127     0.028  0.22  9.1e-15
    1       bounce 2      42681     0.152     0.035  0.23  4.3e-15
    1       bounce 2        908     0.005     0.006  1.17  2.0e-15
    (frames 2 and 3 alike)
    all renders: numpy 1.970 s, kernel 0.407 s, B/A 0.21

the kernel about 1.8x slower than with the sinc factor, its numpy reference as much (two runs a
minute apart gave the kernel 0.407 and 0.511 s: the machine's noise).

The kernel frozen (``dr.freeze``: a call replays the recorded kernels instead of tracing the Python
again), ``python benchmarks/po_kernel.py --scene /tmp/cw_quad`` (the walk at 32 mm edges as its builder
writes it now; frames 2 and 3 alike)::

    frame   render      samples   numpy s  kernel s   B/A  max |diff| / max |a|
    static  bounce 1     143893     0.251     0.035  0.14  2.8e-15
    static  bounce 2     143893     0.273     0.039  0.14  4.7e-15
    1       bounce 1      43064     0.064     0.011  0.17  6.5e-15
    1       bounce 2      43064     0.089     0.012  0.14  9.9e-15
    1       bounce 2        908     0.002     0.001  0.32  6.0e-15
    all renders: numpy 1.000 s, kernel 0.145 s, B/A 0.14

the small render (the static chains that end on the body) no longer costs as much as numpy.
"""

from __future__ import annotations

import argparse
import sys
import time

import walk_frames


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    walk_frames.add_arguments(p, "out/bench_po_kernel", [1, 2, 3], 5)
    args = p.parse_args(argv)

    import numpy as np

    from sionnafmcw import engines
    from sionnafmcw.antenna import antenna_gain, direction_angles
    from sionnafmcw.constants import SPEED_OF_LIGHT
    from sionnafmcw.engines.po_kernel import element_pair_po
    from sionnafmcw.engines.po_render import chain_po_gains
    from sionnafmcw.geometry import rotation_matrix

    anim, radar = walk_frames.load(p, args)
    pose = anim.radar_pose
    rot = rotation_matrix(pose.orientation)
    tx = np.asarray(pose.position, float) + radar.tx_positions @ rot.T
    rx = np.asarray(pose.position, float) + radar.rx_positions @ rot.T
    wavelength = SPEED_OF_LIGHT / radar.fc

    def numpy_po(b):
        g_t = antenna_gain(radar.antenna_pattern, *direction_angles((b.first_point[None] - tx[:, None]) @ rot))
        g_r = antenna_gain(radar.antenna_pattern, *direction_angles((b.samples.position[None] - rx[:, None]) @ rot))
        return chain_po_gains(b, tx, rx, wavelength, g_t, g_r)

    def kernel_po(b):
        return element_pair_po(b, tx, rx, rot, wavelength, radar.antenna_pattern)

    engine = engines.create("path", track_kernels=False)
    renders = []
    for frame in args.frames:
        engine.echoes(anim, radar, frame)
        # last_renders: the static scene's renders (built once per pose), then the frame's own
        num_static = len(engine._state.static.po.renders)
        if not renders:
            renders += [("static", b) for b in engine.last_renders[:num_static]]
        renders += [(str(frame), b) for b in engine.last_renders[num_static:]]
    engine.close()
    renders = [(label, b.select(b.carries_po())) for label, b in renders]
    renders = [(label, b) for label, b in renders if b.num_samples]
    kernel_po(renders[0][1])                                    # compile (or load) the kernels

    print(f"{'frame':<8}{'render':<10}{'samples':>9}{'numpy s':>10}{'kernel s':>10}{'B/A':>6}  max |diff| / max |a|")
    total = [0.0, 0.0]
    for label, b in renders:
        best = [np.inf, np.inf]
        for _ in range(args.repeats):
            for k, f in enumerate((numpy_po, kernel_po)):   # interleaved: A then B on the same render
                t0 = time.perf_counter()
                out = f(b)
                best[k] = min(best[k], time.perf_counter() - t0)
                if k == 0:
                    a_ref = out[0]
                else:
                    diff = float(np.max(np.abs(out[0] - a_ref)) / np.max(np.abs(a_ref)))
        total[0] += best[0]
        total[1] += best[1]
        print(f"{label:<8}{'bounce ' + str(b.depth):<10}{b.num_samples:>9}{best[0]:>10.3f}{best[1]:>10.3f}"
              f"{best[1] / best[0]:>6.2f}  {diff:.1e}")
    print(f"all renders: numpy {total[0]:.3f} s, kernel {total[1]:.3f} s, B/A {total[1] / total[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
