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
* ``echo``: the engine's whole echo at the largest N (every bounce, the same channel), and
  ``b1/echo``: the exact first bounce's share of it (dB): how much the first bounce's error can move
  the echo a user reads.

Measured
--------
See the module's report in the issue note; every figure comes from this script.
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

    from reflector_scenes import reflector_mesh, reflector_scene
    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation
    from sionnafmcw.engines import PathEngine
    from sionnafmcw.flat_face_po import part_channels

    radar = RadarConfig.preset("walk-77ghz").replace(antenna_pattern="iso", num_chirps=16)
    wavelength = radar.wavelength
    folder = pathlib.Path(tempfile.mkdtemp(prefix="po_flat_faces_"))
    print("first-bounce channel |h1|^2 (dB) of an isotropic element at the phase centre: exact flat-face PO, "
          "far field - exact, engine at samples_across N - exact [samples], whole echo and b1 share")
    for kind in args.kinds:
        depth = 3 if kind == "trihedral" else 2
        for leg in args.legs:
            for distance in args.distances:
                for aspect in args.aspects:
                    anim = load_animation(reflector_scene(folder / f"{kind}_{leg}_{distance}_{aspect}", kind, leg,
                                                          distance, np.deg2rad(aspect)))
                    v, f = reflector_mesh(kind, (distance, 0.0, 1.0), leg, np.deg2rad(aspect), (0.0, 0.0, 1.0))
                    rows, exact = [], None
                    for n in args.across:
                        engine = PathEngine(po_samples_across=n, max_depth=depth, diffuse=False)
                        engine.echoes(anim, radar, 0)
                        h, samples, gamma = bounce_channels(engine.last_renders, wavelength)
                        if exact is None:
                            origin = engine.last_renders[0].source[0]
                            t0 = time.perf_counter()
                            exact = complex(np.sum(part_channels(v[f], origin, wavelength, gamma)))
                            seconds = time.perf_counter() - t0
                            far = complex(np.sum(part_channels(v[f], origin, wavelength, gamma, far_field=True)))
                        rows.append((n, h, samples, first_bounce_bound(engine.last_renders, wavelength)))
                    print(f"{kind} {leg:.2f} m at {distance:.1f} m, {aspect:.0f} deg: exact first bounce "
                          f"{db(exact):.2f} dB ({seconds:.1f} s), far field {db(far) - db(exact):+.2f} dB", flush=True)
                    echo_ref, hybrid_ref = sum(rows[-1][1]), exact + sum(rows[-1][1][1:])
                    for n, h, samples, bound in rows:
                        later = "  ".join(f"b{d + 1} {db(x):8.2f}" for d, x in enumerate(h[1:], start=1))
                        echo, hybrid = sum(h), exact + sum(h[1:])
                        print(f"  N={n:3d}: b1 - exact {db(h[0]) - db(exact):+7.2f} [{samples:6d}] "
                              f"|b1 - exact|/|echo| {db(abs(h[0] - exact) / abs(echo)):+7.2f}, E1/|echo| "
                              f"{db(bound / abs(echo)):+7.2f}  {later}  "
                              f"echo {db(echo):8.2f} ({db(echo) - db(echo_ref):+6.2f} vs N={rows[-1][0]})  "
                              f"with exact b1 {db(hybrid):8.2f} ({db(hybrid) - db(hybrid_ref):+6.2f})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
