"""How large may a PO sample be? The in-sample factor (linear against second order) over the sample size.

The PO integral of :mod:`sionnafmcw.physical_optics` sums one footprint integral per render sample.
Two errors grow with the sample size :math:`s`: the in-sample phase that the footprint factor
leaves out, and the tiling of a curved surface by flat footprints on each sample's tangent plane,
whose seams neither meet nor share a phase. This script separates them. It evaluates the same
renders with

* ``linear``: the footprint factor of the linear phase only, :math:`\\operatorname{sinc}\\operatorname{sinc}`
  (the model before :func:`~sionnafmcw.physical_optics.footprint_factor`), and
* ``second``: :func:`~sionnafmcw.physical_optics.footprint_factor`, second order in the in-sample
  phase (range curvature and the surface's shape operator),

at the sample sizes of :func:`~sionnafmcw.physical_optics.render_resolution` with the edge phase
:math:`Q_{max}` = pi/32 (the rule), pi/16 and pi/8 (samples 1.4x and 2x larger, 2x and 4x fewer):

* ``sphere``: a metal sphere (r = 0.1 m, a fine mesh of 1.2 mm facets, smooth normals) at 2 m
  and 10 m, the complex monostatic channel against the independent triangle quadrature
  (``tests/po_quadrature.py``), over ``--offsets`` random sub-pixel shifts of the render grid:
  rms and largest relative error;
* ``body``: the walking body (``tests/body_po.py``, skin, smooth normals) at 3 m, gait phases 0
  and 1/6, 8 aspects: the PO RCS against the same body at Q = pi/128 (samples 2x smaller than the
  rule's), second order: rms and largest error in dB.

    python benchmarks/po_sample_size.py [--offsets 6] [--aspects 8]

Measured
--------
``python benchmarks/po_sample_size.py`` (2-core AMD EPYC, 295 s)::

    sphere r = 0.1 m, 1.2 mm facets: |h - h_quadrature| / |h_quadrature| over grid offsets
      R m  Q_max  s mm samples  linear rms    max  second rms    max
        2  pi/32   4.9    1289       0.096  0.145       0.025  0.035
        2  pi/16   7.0     648       0.173  0.271       0.043  0.061
        2   pi/8   9.9     325       0.289  0.592       0.053  0.089
       10  pi/32   4.9    1289       0.047  0.066       0.019  0.030
       10  pi/16   7.0     641       0.192  0.225       0.026  0.037
       10   pi/8   9.9     319       0.310  0.455       0.060  0.099
    walking body at 3 m: PO RCS against Q = pi/128 (second order), dB
     factor  Q_max  samples  rms dB  max dB
     linear  pi/32    51668    0.40    0.67
     second  pi/32    51668    0.44    0.74
     second  pi/16    25832    0.72    1.26
     second   pi/8    12918    1.13    3.54

On the smooth sphere the second-order factor is 2.5-4x closer to the quadrature at every sample
size, and samples 2x larger (pi/8) are still closer than the rule's with the linear factor. On
the body it is not: at the rule's samples the two factors are alike (0.40 and 0.44 dB rms), and
larger samples lose accuracy fast (1.13 dB rms, 3.5 dB at worst at pi/8), second order or not.
There the error is the tiling (``physical_optics`` module docstring, "Sample size"): the body's
radii are 3.6 cm (forearm) and its facets 8 mm, larger than the samples, so the render's samples
are no longer the smooth surface the shape operator describes. The resolution rule therefore
stays at pi/32.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import body_po as bp  # noqa: E402
import mesh_render  # noqa: E402
import po_quadrature as quad  # noqa: E402
from sionnafmcw.constants import SPEED_OF_LIGHT  # noqa: E402
from sionnafmcw.physical_optics import (SurfaceSamples, channel, footprint_factor, po_gains,  # noqa: E402
                                        render_resolution)
from sionnafmcw.scenes import meshes  # noqa: E402
from sionnafmcw.scenes.body import WalkingPerson  # noqa: E402

FREQUENCY = 77e9
WAVELENGTH = SPEED_OF_LIGHT / FREQUENCY
DIVISORS = (32, 16, 8)            # Q_max = pi / divisor


def monostatic_channel(samples: SurfaceSamples, radar, factor: str) -> complex:
    """The PO channel from and to ``radar`` with the ``linear`` or ``second``-order footprint factor."""
    radar = np.asarray(radar, float)[None]
    if factor == "second":
        a, tau, _ = po_gains(samples, radar, radar, WAVELENGTH)
    else:
        a, tau, _ = po_gains(samples, radar, radar, WAVELENGTH, in_sample_phase=False)
        s_hat = samples.position - radar
        s_hat /= np.linalg.norm(s_hat, axis=-1, keepdims=True)
        k = 2 * np.pi / WAVELENGTH                      # g = 2 s_hat; H = 0 leaves sinc(a/2) sinc(b/2)
        a1, a2 = (2 * k * np.einsum("pi,pi->p", s_hat, samples.edges[:, e]) for e in range(2))
        a = a * footprint_factor(k, a1, a2, 0.0, 0.0, 0.0)
    return complex(channel(a[0, 0], tau[0, 0], FREQUENCY))


def sphere_study(offsets: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    radius, origin = 0.1, np.zeros(3)
    print("sphere r = 0.1 m, 1.2 mm facets: |h - h_quadrature| / |h_quadrature| over grid offsets")
    print(f"{'R m':>5} {'Q_max':>6} {'s mm':>5} {'samples':>7}  {'linear rms':>10} {'max':>6}  "
          f"{'second rms':>10} {'max':>6}")
    for distance in (2.0, 10.0):
        v, f = meshes.ellipsoid((distance, 0.0, 0.0), (radius,) * 3, n_rings=256, n_segments=512)
        reference = quad.po_channel(v, f, origin, origin, WAVELENGTH)
        for d in DIVISORS:
            step = render_resolution(2 * radius, distance, WAVELENGTH, curvature_radius=radius,
                                     max_quadratic_phase=np.pi / d, samples_across=1)
            errors = {"linear": [], "second": []}
            for _ in range(offsets):
                shift = rng.uniform(-0.5, 0.5, 2) * step
                target = (distance, distance * np.tan(shift[0]), distance * np.tan(shift[1]))
                samples = mesh_render.render(v, f, origin, target, 1.2 * radius / distance, step, smooth_normals=True)
                for factor in errors:
                    h = monostatic_channel(samples, origin, factor)
                    errors[factor].append(abs(h - reference) / abs(reference))
            line = f"{distance:5.0f} {'pi/' + str(d):>6} {step * distance * 1e3:5.1f} {samples.num_samples:7d}"
            for factor in ("linear", "second"):
                e = np.asarray(errors[factor])
                line += f"  {np.sqrt(np.mean(e ** 2)):10.3f} {e.max():6.3f}"
            print(line, flush=True)


def body_study(aspects: int):
    person = WalkingPerson()
    distance, rho = 3.0, 0.020 * person.height
    print("walking body at 3 m: PO RCS against Q = pi/128 (second order), dB")

    def step(divisor):
        return render_resolution(person.height, distance, WAVELENGTH, curvature_radius=rho,
                                 max_quadratic_phase=np.pi / divisor)

    arms = [("linear", 32)] + [("second", d) for d in DIVISORS]
    errors = {arm: [] for arm in arms}
    samples = {arm: [] for arm in arms}
    for phase in (0.0, 1 / 6):
        mesh = bp.body_frame_mesh(person, phase)
        for aspect in np.arange(aspects) * 360.0 / aspects:
            ref = body_rcs(person, phase, aspect, distance, step(128), mesh, "second")[0]
            for factor, d in arms:
                rcs = body_rcs(person, phase, aspect, distance, step(d), mesh, factor)
                errors[(factor, d)].append(float(bp.db(rcs[0] / ref)))
                samples[(factor, d)].append(rcs[1])
    print(f"{'factor':>7} {'Q_max':>6} {'samples':>8} {'rms dB':>7} {'max dB':>7}")
    for (factor, d), e in errors.items():
        e = np.asarray(e)
        print(f"{factor:>7} {'pi/' + str(d):>6} {np.mean(samples[(factor, d)]):8.0f} {np.sqrt(np.mean(e ** 2)):7.2f} "
              f"{np.abs(e).max():7.2f}", flush=True)


def body_rcs(person, phase, aspect, distance, step, mesh, factor):
    """PO RCS (m^2) and sample count of one look (``body_po.body_look``) with the ``factor``."""
    samples, radar, reference = bp.body_look(person, phase, aspect, distance, step=step, mesh=mesh)
    h = monostatic_channel(samples, radar, factor)
    r = np.linalg.norm(radar - reference)
    return (4 * np.pi) ** 3 * r ** 4 * abs(h) ** 2 / WAVELENGTH ** 2, samples.num_samples


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--offsets", type=int, default=6, help="random grid offsets per sphere case")
    p.add_argument("--aspects", type=int, default=8, help="aspects per gait phase of the body")
    p.add_argument("--only", choices=("sphere", "body"), help="run one study")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    if args.only in (None, "sphere"):
        sphere_study(args.offsets)
    if args.only in (None, "body"):
        body_study(args.aspects)
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
