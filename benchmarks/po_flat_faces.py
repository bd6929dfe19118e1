"""The engine's first bounce on corner reflectors against the exact flat-face PO integral.

    PYTHONPATH=.:tests python benchmarks/po_flat_faces.py [--kinds trihedral dihedral] [--legs 0.1]
        [--distances 3] [--aspects 0 15 30 45] [--across 16 32 64 128]

The scene is ``benchmarks/po_bounces.py``'s ``grid`` (``tests/reflector_scenes.py``: one metal reflector
``distance`` ahead, its aperture axis at the radar turned ``aspect`` degrees about the vertical; radar
``walk-77ghz`` with isotropic elements; three bounces for a trihedral, two for a dihedral). Per case:

* ``exact``: the first bounce's channel of an isotropic element at the render origin (the array's phase
  centre), each face's lit and visible part integrated exactly (:func:`sionnafmcw.flat_face_po.part_channels`,
  near field, the reflector's mesh triangles as faces, the engine's own reflection coefficient: the
  mean of its bounce-1 samples'); ``ff`` the same integral in the far field, minus ``exact``;
* per ``samples_across`` N: the engine's (``PathEngine(po_samples_across=N)``) first bounce, the same
  channel (:func:`~sionnafmcw.engines.bounce_sampling.monostatic_channels` of its bounce-1 render), minus
  ``exact`` (dB), and its samples;
* ``|b1 - exact|/|echo|``: the engine's first-bounce error against its whole echo at that N, and
  ``E1/|echo|`` the outline bound of :mod:`sionnafmcw.engines.bounce_sampling` applied to bounce 1 (its
  boundary tubes: a grid neighbour on another face, or none), both in dB; the rule's share at N = 16
  is ERROR_SHARE = 0.1, -20 dB;
* ``b2``, ``b3``: the engine's later bounces (dB); ``echo``: all bounces, and its change against the
  largest N; ``with exact b1``: the echo with the engine's first bounce replaced by the exact one.

Measured
--------
2-core AMD EPYC, shared with other work; ``PYTHONPATH=.:tests python benchmarks/po_flat_faces.py``
(0.1 m trihedral at 3 m), ``... --kinds dihedral``, ``... --legs 0.05 0.3 --distances 1 10 --aspects
45 --across 16 128``. First bounce: engine minus exact (dB) at N = 16 / 32 / 64 / 128; b1/echo the
exact first bounce against the engine's echo at N = 128:

===========================  ==========  =====================================  ==========  =======
case                         exact b1    engine b1 - exact, N=16/32/64/128      b1/echo     far - exact
===========================  ==========  =====================================  ==========  =======
trihedral 0.1 m 3 m, 0 deg   -126.52     -28.69 / -23.97 / -26.07 / -15.07      -40.5       +1.74
trihedral 15 deg             -161.26     +12.04 / +11.16 / -6.22 / +5.55        -73.2       +1.30
trihedral 30 deg             -149.52     -2.10 / -6.32 / +1.17 / -3.80          -51.6       -2.17
trihedral 45 deg             -163.16     +25.42 / +19.90 / +21.70 / +2.66       -26.8       +8.72
dihedral 0.1 m 3 m, 0 deg    -126.50     -24.34 / -19.32 / -22.54 / -4.26       -44.8       +1.83
dihedral 45 deg              -92.95      +0.71 / +0.42 / +0.04 / +0.19          -0.2        +1.33
===========================  ==========  =====================================  ==========  =======

The exact first bounce is reproduced by a brute-force Gauss-Legendre quadrature to 0.0002 dB (the
trihedral on its axis, where no face hides another). Point sampling of a face seen obliquely does
not converge: the engine's trihedral first bounce is 1.2-28.7 dB off at every N up to 128 at 0-30
degrees and up to +25 dB at 45, the dihedral's 0.06-24 dB at 0-30 (the footprint factor integrates each tube exactly, but the tubes that the outline
cuts count whole; the outline's error is a sum of staircase steps, each a sinc-weighted edge term
that does not fall until the step is well under :math:`1/|\mathbf w_t| = \lambda/(4\pi\sin\theta)`, about
0.4 mm at 77 GHz: ``samples_across`` ~ 300 for a 0.1 m target). Where it matters:

* 0-30 degrees: the engine's first-bounce error at N = 16 is 40-63 dB (trihedral) and 37-53 dB
  (dihedral) below the echo (``|b1 - exact|/|echo|``); it moves the echo by <= 0.13 dB. The echo's
  convergence there is the later bounces' (``bounce_sampling``: within 0.4 dB of N = 128 at N = 16).
* 45 degrees, trihedral (no triple bounce, the echo 50 dB below the axis's): the default is not within
  1 dB. 0.1 m at 3 m: echo +2.29 / -1.39 / -6.64 dB at N = 16 / 32 / 64 against N = 128; the engine's
  first-bounce error is -3.7 dB of the echo at N = 16 (E1 -3.9 dB: the bound sees it), and the double
  bounce b2 moves by 4.7 dB between N (-139.3 / -134.6 / -137.3 / -137.0 dB), so with the exact first
  bounce the echo still moves by -2.22 / +2.25 / -0.29 dB. 0.05 m at 1 m: default +1.12 dB (with the
  exact b1 -0.26 dB); 0.05 m at 10 m: +0.51 (+0.35); 0.3 m at 1 m: +0.56 dB against N = 128, but the
  engine's first bounce is +11.1 dB off the exact one even at N = 128, so N = 128 is no converged
  echo there: the echo with the exact first bounce is -112.91 dB against the engine's -108.89 (4.0 dB).
* 45 degrees, dihedral (one face square to the radar, no double bounce): the echo is the first bounce,
  which has a specular point; the engine is within 0.71 dB of the exact integral at N = 16.

The far field (``ff``) is no reference at these ranges: 1.7-8.7 dB off the near-field integral at 3 m
for 0.1 m, -23 dB for 0.3 m at 1 m, 0.08 dB for 0.05 m at 10 m.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import tempfile
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))


def db(x) -> float:
    with np.errstate(divide="ignore"):
        return float(20 * np.log10(np.abs(x)))


def bounce_channels(renders, wavelength: float) -> tuple[list, int, complex]:
    """``(channels, first-bounce samples, mean Gamma)``: per bounce (1, 2, ...) the channel of an isotropic
    element at the render origin (``monostatic_channels``) from the engine's renders, the first bounce's
    samples and its samples' mean reflection coefficient."""
    from sionnafmcw.engines.bounce_sampling import monostatic_channels

    first = [r for r in renders if r.depth == 1]
    origin = first[0].source[:1]
    depth = max(r.depth for r in renders)
    h = [sum(complex(np.sum(monostatic_channels([r], wavelength, origin)[0])) for r in renders if r.depth == d)
         for d in range(1, depth + 1)]
    gamma = np.concatenate([r.samples.reflection for r in first])
    return h, sum(r.num_samples for r in first), complex(np.mean(gamma))


def first_bounce_bound(renders, wavelength: float) -> float:
    r"""The outline bound of :mod:`sionnafmcw.engines.bounce_sampling` applied to the first bounce: over its
    boundary tubes (a grid neighbour on another face or none), :math:`E_1 = \frac12|\sum h_i| +
    (\frac1{12}\sum|h_i|^2)^{1/2}`, the tubes counted whole where the outline cuts them."""
    from sionnafmcw.engines.bounce_sampling import grid_neighbours, monostatic_channels, surface_codes

    first = [r for r in renders if r.depth == 1][0]
    h = monostatic_channels([first], wavelength)[0]
    code = surface_codes(first)
    nb = grid_neighbours(first)
    other = np.where(nb >= 0, code[np.maximum(nb, 0)], -1)
    boundary = np.any(other != code[:, None], axis=1)
    hb = h[boundary]
    return float(0.5 * abs(np.sum(hb)) + np.sqrt(np.sum(np.abs(hb) ** 2) / 12.0))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kinds", nargs="+", default=["trihedral"], choices=("trihedral", "dihedral"))
    parser.add_argument("--legs", nargs="+", type=float, default=[0.1])
    parser.add_argument("--distances", nargs="+", type=float, default=[3.0])
    parser.add_argument("--aspects", nargs="+", type=float, default=[0.0, 15.0, 30.0, 45.0])
    parser.add_argument("--across", nargs="+", type=int, default=[16, 32, 64, 128])
    args = parser.parse_args(argv)

    from reflector_scenes import reflector_faces, reflector_scene
    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation
    from sionnafmcw.engines import PathEngine
    from sionnafmcw.flat_face_po import chain_channels, part_channels

    radar = RadarConfig.preset("walk-77ghz").replace(antenna_pattern="iso", num_chirps=16)
    wavelength = radar.wavelength
    folder = pathlib.Path(tempfile.mkdtemp(prefix="po_flat_faces_"))
    print("channel of an isotropic element at the phase centre (dB): exact flat-face PO per bounce and all "
          "bounces; the engine at samples_across N minus it")
    for kind in args.kinds:
        depth = 3 if kind == "trihedral" else 2
        for leg in args.legs:
            for distance in args.distances:
                for aspect in args.aspects:
                    anim = load_animation(reflector_scene(folder / f"{kind}_{leg}_{distance}_{aspect}", kind, leg,
                                                          distance, np.deg2rad(aspect)))
                    faces = reflector_faces(kind, (distance, 0.0, 1.0), leg, np.deg2rad(aspect), (0.0, 0.0, 1.0))
                    rows, exact = [], None
                    for n in args.across:
                        engine = PathEngine(po_samples_across=n, max_depth=depth, diffuse=False)
                        engine.echoes(anim, radar, 0)
                        h, samples, gamma = bounce_channels(engine.last_renders, wavelength)
                        h = h + [0j] * (depth - len(h))
                        if exact is None:
                            origin = engine.last_renders[0].source[0]
                            t0 = time.perf_counter()
                            chains = chain_channels(faces, origin, wavelength, depth, gamma)
                            exact = [sum((x for c, x in chains.items() if len(c) == d), 0j) for d in range(1, depth + 1)]
                            seconds = time.perf_counter() - t0
                            far = complex(np.sum(part_channels(faces, origin, wavelength, gamma, far_field=True)))
                        rows.append((n, h, samples, first_bounce_bound(engine.last_renders, wavelength)))
                    echo = sum(exact)
                    print(f"{kind} {leg:.2f} m at {distance:.1f} m, {aspect:.0f} deg: exact "
                          + "  ".join(f"b{d + 1} {db(x):8.2f}" for d, x in enumerate(exact))
                          + f"  echo {db(echo):8.2f} ({seconds:.1f} s); b1 far field - near {db(far) - db(exact[0]):+.2f}",
                          flush=True)
                    for n, h, samples, bound in rows:
                        per = "  ".join(f"b{d + 1} {db(x) - db(e):+7.2f}" if abs(x) + abs(e) else f"b{d + 1}    none"
                                        for d, (x, e) in enumerate(zip(h, exact)))
                        print(f"  N={n:3d} [{samples:6d}]: {per}  echo {db(sum(h)) - db(echo):+6.2f}  "
                              f"|b1 - exact|/|echo| {db(abs(h[0] - exact[0]) / abs(echo)):+7.2f}  "
                              f"E1/|echo| {db(bound / abs(echo)):+7.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
