"""RCS table: physical optics on render samples vs the independent quadrature vs the closed forms.

    .venv/bin/python benchmarks/rcs.py

Prints per case: target, range, sigma from sionnafmcw.physical_optics (PO module, on a numpy render
from the radar at the render_resolution rule), from tests/po_quadrature.py (quadrature over the mesh
triangles), the closed form, the differences (dB), the sample count and the cost of each (s).
Closed forms: square plate, near-field paraxial Fresnel form (-> 4 pi A^2 / lambda^2); sphere pi r^2;
cylinder 2 pi a L^2 / lambda (far field only: R >= 2 L^2 / lambda).
"""

from __future__ import annotations

import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))

import mesh_render  # noqa: E402
import po_quadrature as quad  # noqa: E402
from sionnafmcw.constants import SPEED_OF_LIGHT  # noqa: E402
from sionnafmcw.physical_optics import monostatic_rcs, render_resolution  # noqa: E402
from sionnafmcw.radar import RadarConfig  # noqa: E402
from sionnafmcw.scenes import meshes  # noqa: E402

LAMBDA = SPEED_OF_LIGHT / RadarConfig.preset("walk-77ghz").fc
ORIGIN = np.zeros(3)


def db(x):
    return 10 * np.log10(x)


def cases():
    for side in (0.1, 0.2):
        for r in (2.0, 5.0, 10.0, 20.0):
            v, f = meshes.plate((r, 0, 0), (side, side), normal=(-1, 0, 0))
            yield (f"plate {side} m", r, v, f, dict(two_sided=True), render_resolution(side, r, LAMBDA),
                   0.8 * side / r, False, quad.square_plate_rcs_fresnel(side, r, LAMBDA))
    a = 0.1
    for r in (2.0, 5.0, 10.0, 20.0):
        v, f = meshes.ellipsoid((r, 0, 0), (a,) * 3, n_rings=64, n_segments=128)
        yield (f"sphere r={a} (smooth normals)", r, v, f, {}, render_resolution(2 * a, r, LAMBDA, curvature_radius=a),
               1.1 * a / r, True, np.pi * a ** 2)
        yield (f"sphere r={a} (facet normals)", r, v, f, {},
               render_resolution(2 * a, r, LAMBDA, curvature_radius=a, facet_size=2 * np.pi * a / 128),
               1.1 * a / r, False, np.pi * a ** 2)
    a, length = 0.05, 0.1
    for r in (5.0, 10.0, 20.0):
        v, f = quad.cylinder(a, length, 128, 4, center=(r, 0, 0))
        yield (f"cylinder a={a} L={length}", r, v, f, {},
               render_resolution(length, r, LAMBDA, curvature_radius=a, facet_size=2 * np.pi * a / 128),
               0.6 * length / r, False, 2 * np.pi * a * length ** 2 / LAMBDA if r >= 2 * length ** 2 / LAMBDA else np.nan)


def diffuse_table():
    """Clutter-removed map power over sum |a|^2: random phases (4 spinning plates, 4 realisations) and
    deterministic phases (a 0.5 m plate facing the radar), at 1x, 4x (and 16x) samples."""
    import test_diffuse as td
    from sionnafmcw.diffuse import diffuse_echoes
    from sionnafmcw.echoes import Echoes

    print("\ndiffuse map power / (sum|a|^2 x unit-contribution map power), dB")
    for factor in (1, 2):
        measured = expected = 0.0
        count = 0
        t0 = time.perf_counter()
        for realisation in range(4):
            parts = []
            for d in (3.0, 4.5, 6.0, 7.5):
                samples, cells = td.spinning_plate(render_resolution(1.0, d, LAMBDA, samples_across=32) / factor, d,
                                                   realisation=realisation)
                parts.append(diffuse_echoes(samples, td.RADAR, cells))
                count += samples.num_samples
            e = Echoes.concatenate(parts)
            measured += td.map_power(e)
            expected += td.unit_map_power(e) * np.sum(np.abs(e.a) ** 2)
        print(f"  random phases, spinning plates, {count // 4:6d} samples/map: {db(measured / expected):+.2f} dB "
              f"({time.perf_counter() - t0:.1f} s)")
    v, f = meshes.plate((4.0, 0, 0), (0.5, 0.5), normal=(-1, 0, 0))
    step = render_resolution(0.5, 4.0, LAMBDA, samples_across=32)
    for factor in (1, 2, 4):
        samples = mesh_render.render(v, f, ORIGIN, (4.0, 0, 0), 0.07, step / factor, scattering_coefficient=1.0)
        samples.velocity[:] = [1.0, 0, 0]
        e = diffuse_echoes(samples, td.RADAR, cells=1)
        det = Echoes(np.abs(e.a), e.tau, e.doppler)
        ratio = td.map_power(det) / (td.unit_map_power(det) * np.sum(np.abs(det.a) ** 2))
        print(f"  deterministic phases, facing plate, {samples.num_samples:6d} samples: {db(ratio):+.2f} dB")


def main():
    print(f"{'target':32s} {'R/m':>5s} {'PO/dBsm':>8s} {'quad':>8s} {'closed':>8s} {'PO-quad':>8s} "
          f"{'PO-closed':>9s} {'samples':>8s} {'t_PO/s':>7s} {'t_quad/s':>8s}")
    for name, r, v, f, kw, step, half, smooth, closed in cases():
        t0 = time.perf_counter()
        samples = mesh_render.render(v, f, ORIGIN, (r, 0, 0), half, step, smooth_normals=smooth)
        t1 = time.perf_counter()
        sigma = monostatic_rcs(samples, ORIGIN, LAMBDA, (r, 0, 0))
        t2 = time.perf_counter()
        ref = quad.monostatic_rcs(v, f, ORIGIN, (r, 0, 0), LAMBDA, **kw)
        t3 = time.perf_counter()
        print(f"{name:32s} {r:5.1f} {db(sigma):8.2f} {db(ref):8.2f} {db(closed):8.2f} {db(sigma / ref):8.2f} "
              f"{db(sigma / closed):9.2f} {samples.num_samples:8d} {t2 - t1:7.3f} {t3 - t2:8.2f}   (render {t1 - t0:.2f} s)",
              flush=True)
    diffuse_table()


if __name__ == "__main__":
    main()
