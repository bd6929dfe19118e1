"""Smooth surfaces from vertex normals: PN refinement, its level, and the PO it gives.

    .venv/bin/python benchmarks/smooth_surface.py geometry   # levels, triangle counts, distance to the true surface
    .venv/bin/python benchmarks/smooth_surface.py po         # icospheres and cylinder against the exact-surface PO
    .venv/bin/python benchmarks/smooth_surface.py walker [--step-scale 0.25]   # the walking body, 32 / 16 mm refined

Method (tests/smooth_po.py, tests/analytic_po.py): ``po`` integrates the PO of every walk-77ghz element
pair (radar at (-d, 0, 0), yaw 0) over the mesh's facets with a Gauss quadrature, samples on the flat
(sub-)facets with interpolated corner normals ("flat": what the engine's render does today) or moved
onto the smooth PN surface at their parameters ("surface": ``RefinedSurface.smooth_points``), and
compares with the same integral over the exact sphere / cylinder; it prints the per-pair error range
(dB of |h|^2) and the error of the coherent sum over all pairs. ``walker`` renders the body as
tests/body_po.py does (numpy ray cast, monostatic PO at 1 m height, skin, gait phase 0) at
``--step-scale`` times the resolution rule's pixel step (the rule's own sampling moves the body's
RCS by up to 1 dB between steps 1 and 1/2 at some aspects, so the default is 1/4); reference: the
8 mm body with every hit moved onto the exact segment shapes (ellipsoids and capsules).
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import analytic_po as ap  # noqa: E402
import smooth_po as sp  # noqa: E402
from sionnafmcw import smooth_surface as ss  # noqa: E402
from sionnafmcw.scenes import meshes  # noqa: E402
from sionnafmcw.scenes.body import SEGMENTS, WalkingPerson, segment_shapes  # noqa: E402

LAM = sp.WAVELENGTH
ASPECTS = (0.0, 30.0, 90.0, 150.0, 180.0)
DISTANCES = (3.0, 10.0)


def test_meshes():
    """``{name: (vertices, faces, corner_normals, exact_channels(tx, rx), quadrature cell)}``."""
    out = {}
    for sub, name in ((2, "icosphere 320"), (3, "icosphere 1280")):
        v, f = sp.icosphere(0.1, sub)
        out[name] = (v, f, (v / 0.1)[f], lambda tx, rx: ap.sphere_po_channels(0.1, (0, 0, 0), tx, rx, LAM), LAM / 2)
    v, f, cn = sp.cylinder(0.05, 0.3, 24)
    out["cylinder 24"] = (v, f, cn, lambda tx, rx: ap.cylinder_po_channels(0.05, 0.3, (0, 0, 0), tx, rx, LAM), 2 * LAM)
    return out


def _err(h, ref):
    pair, total = sp.db_error(h, ref)
    return f"[{pair.min():+6.2f},{pair.max():+6.2f}] {total:+6.2f}"


def geometry():
    print("PN refinement: level (lambda/25 and lambda/100), triangles, distance of the PN surface to the exact one")
    w = ss._simplex_grid(24)
    rows = [(k, v, f, cn, None) for k, (v, f, cn, _, _) in test_meshes().items()]
    for edge in (0.032, 0.016):
        person = WalkingPerson(mesh_edge=edge)
        shapes = segment_shapes(person.body)
        for normals in ("analytic", "mesh"):
            for k in SEGMENTS:
                if k.startswith("right_"):
                    continue
                v, f = person.local_meshes[k]
                vn = sp.analytic_segment_normals(shapes[k], v) if normals == "analytic" else meshes.vertex_normals(v, f)
                rows.append((f"walker {edge * 1e3:.0f} mm {normals:8s} {k}", v, f, vn[f], shapes[k]))
    print(f"{'mesh':45s} {'F':>6s} {'L25':>4s} {'F(L25)':>8s} {'L100':>4s} {'F(L100)':>8s}  "
          f"{'circular um':>16s} {'pn um':>16s} {'flat um':>8s} {'normal deg':>10s}")
    for name, v, f, cn, shape in rows:
        l25, l100 = ss.refinement_level(v, f, cn, LAM), ss.refinement_level(v, f, cn, LAM, LAM / 100)
        dist = {}
        faces_w = np.repeat(np.arange(len(f)), len(w))
        for handles in ("circular", "pn"):
            pn = ss.pn_triangles(v, f, cn, handles=handles)
            p, n = pn.position(faces_w, np.tile(w, (len(f), 1))), pn.normal(faces_w, np.tile(w, (len(f), 1)))
            q, nq = _exact(name, shape, p, faces_w)
            dist[handles] = np.einsum("ij,ij->i", p - q, nq)
            if handles == "circular":
                normal_err = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, nq), -1, 1))).max()
        flat = np.einsum("gk,fkc->fgc", w, v[f]).reshape(-1, 3)
        q, nq = _exact(name, shape, flat, faces_w)
        flat_d = np.abs(np.einsum("ij,ij->i", flat - q, nq)).max()
        c, p_ = dist["circular"], dist["pn"]
        print(f"{name:45s} {len(f):6d} {l25:4d} {len(f) * l25 ** 2:8d} {l100:4d} {len(f) * l100 ** 2:8d}  "
              f"[{c.min() * 1e6:6.0f},{c.max() * 1e6:6.0f}] [{p_.min() * 1e6:6.0f},{p_.max() * 1e6:6.0f}] "
              f"{flat_d * 1e6:8.0f} {normal_err:10.2f}")
    for edge in (0.032, 0.016, 0.008):
        person = WalkingPerson(mesh_edge=edge)
        shapes = segment_shapes(person.body)
        total = {"analytic": 0, "mesh": 0}
        for k in SEGMENTS:
            v, f = person.local_meshes[k]
            for normals in total:
                vn = sp.analytic_segment_normals(shapes[k], v) if normals == "analytic" else meshes.vertex_normals(v, f)
                total[normals] += len(f) * ss.refinement_level(v, f, vn[f], LAM) ** 2
        raw = sum(len(person.local_meshes[k][1]) for k in SEGMENTS)
        print(f"walker {edge * 1e3:.0f} mm: {raw} triangles, refined at lambda/25 {total['analytic']} "
              f"(analytic normals), "
              f"{total['mesh']} (mesh normals)")


def _exact(name, shape, points, face):
    """Nearest-ish points on the exact surface and its normals (sphere, cylinder side / caps by ``face``: the
    prism's first 48 faces are its side, body shapes)."""
    if shape is not None:
        return sp.project_to_shape(shape, points)
    if name.startswith("icosphere"):
        n = points / np.linalg.norm(points, axis=1, keepdims=True)
        return 0.1 * n, n
    side = face < 48
    q, n = points.copy(), np.zeros_like(points)
    r = np.hypot(points[:, 0], points[:, 1])
    q[side, :2] *= (0.05 / r[side])[:, None]
    n[side, :2] = points[side, :2] / r[side, None]
    q[~side, 2] = np.sign(points[~side, 2]) * 0.15
    n[~side, 2] = np.sign(points[~side, 2])
    return q, n


def po():
    print("PO of refined meshes against the exact surface, walk-77ghz (3 Tx x 4 Rx), metal; "
          "per-pair error range and coherent-sum error, dB")
    for name, (v, f, cn, exact, cell) in test_meshes().items():
        l25, l100 = ss.refinement_level(v, f, cn, LAM), ss.refinement_level(v, f, cn, LAM, LAM / 100)
        r25, r100 = ss.pn_refine(v, f, cn, l25), ss.pn_refine(v, f, cn, l100)
        print(f"\n{name}: {len(f)} triangles; lambda/25 level {l25} ({len(r25.faces)}), lambda/100 level {l100} "
              f"({len(r100.faces)}); quadrature cell lambda/{LAM / cell:.1f}")
        for d in DISTANCES:
            tx, rx = sp.walk_elements(d)
            t0 = time.perf_counter()
            ref = exact(tx, rx)
            conv = ap.convergence(lambda **g: ap.sphere_po_channels(0.1, (0, 0, 0), tx, rx, LAM, **g), panels=96,
                                  n_phi=96) if name.startswith("ico") else ap.convergence(
                lambda **g: ap.cylinder_po_channels(0.05, 0.3, (0, 0, 0), tx, rx, LAM, **g), panels=64, z_panels=32)
            raw = sp.mesh_po_channels(v, f, cn, tx, rx, max_cell=cell)
            flat25 = sp.refined_po_channels(r25, tx, rx, samples="flat", max_cell=cell)
            surf25 = sp.refined_po_channels(r25, tx, rx, samples="surface", max_cell=cell)
            surf25_half = sp.refined_po_channels(r25, tx, rx, samples="surface", max_cell=cell / 2)
            flat100 = sp.refined_po_channels(r100, tx, rx, samples="flat", max_cell=cell)
            print(f"  {d:4.0f} m  exact |h|^2 {10 * np.log10(np.mean(np.abs(ref) ** 2)):7.2f} dB (reference halving "
                  f"{conv:.4f} dB; mesh quadrature halving {np.abs(sp.db_error(surf25_half, surf25)[0]).max():.4f} dB)")
            print(f"        facets as given         {_err(raw, ref)}")
            print(f"        lambda/25,  flat        {_err(flat25, ref)}")
            print(f"        lambda/25,  surface     {_err(surf25, ref)}")
            print(f"        lambda/100, flat        {_err(flat100, ref)}   ({time.perf_counter() - t0:.1f} s)")
            if name.startswith("cylinder"):
                straight = ss.pn_refine(v, f, cn, l25, creases="straight")
                h = sp.refined_po_channels(straight, tx, rx, samples="surface", max_cell=cell)
                print(f"        lambda/25,  surface, straight rims {_err(h, ref)}")
        if name == "icosphere 320":
            print("  level sweep (3 m / 10 m coherent-sum error, flat | surface):")
            for level in (1, 2, 3, 4, 5, 6, 8):
                r = ss.pn_refine(v, f, cn, level)
                cells = []
                for d in DISTANCES:
                    tx, rx = sp.walk_elements(d)
                    ref = exact(tx, rx)
                    flat = sp.db_error(sp.refined_po_channels(r, tx, rx, samples="flat", max_cell=cell), ref)[1]
                    surf = sp.db_error(sp.refined_po_channels(r, tx, rx, samples="surface", max_cell=cell), ref)[1]
                    cells.append(f"{flat:+6.2f} | {surf:+6.2f}")
                sag = ss.facet_sagitta(v, f, cn).max() / level ** 2
                print(f"    level {level}: sub-facet sagitta lambda/{LAM / sag:5.1f}   " + "   ".join(cells))


def walker(step_scale: float):
    import body_po as bp

    p8, p16, p32 = (WalkingPerson(mesh_edge=e) for e in (0.008, 0.016, 0.032))
    t0 = time.perf_counter()
    r32a, r32m, r16a = sp.refined_segments(p32, "analytic"), sp.refined_segments(p32, "mesh"), sp.refined_segments(p16)
    print(f"refinement of the 32 mm (both normals) and 16 mm walkers: {time.perf_counter() - t0:.2f} s")
    shapes32 = segment_shapes(p32.body)
    surf32 = sp.refined_surface(r32a)

    def exact_feet(k, tri, bary, points):
        p, n = surf32(k, tri, bary, points)
        return sp.project_to_shape(shapes32[k], p) if k.endswith("foot") else (p, n)

    c8 = sp.coarse_segments(p8)
    configs = {
        "exact": (p8, c8, sp.analytic_surface(p8)),
        "8mm": (p8, c8, None),
        "32raw": (p32, sp.coarse_segments(p32), None),
        "32a-flat": (p32, sp.refined_segment_meshes(r32a), None),
        "32a-surf": (p32, sp.refined_segment_meshes(r32a), surf32),
        "32m-surf": (p32, sp.refined_segment_meshes(r32m), sp.refined_surface(r32m)),
        "32a-surf+feet": (p32, sp.refined_segment_meshes(r32a), exact_feet),
        "16a-surf": (p16, sp.refined_segment_meshes(r16a), sp.refined_surface(r16a)),
    }
    for k, (person, seg, _) in configs.items():
        print(f"  {k:14s} {sum(len(s[1]) for s in seg.values()):7d} triangles")
    print(f"\nwalker PO RCS (gait phase 0, radar 1 m high, pixel step x {step_scale}): exact-surface reference (dBsm) "
          "and every mesh's error against it (dB); last column: 32a-surf against today's 8 mm")
    head = " ".join(f"{k:>13s}" for k in configs if k != "exact")
    print(f"{'look':>10s} {'exact':>7s} {head} {'32a-surf-8mm':>13s}")
    worst = {k: 0.0 for k in (*configs, "vs8")}
    for d in DISTANCES:
        for a in ASPECTS:
            step = bp.pixel_step(p8, d) * step_scale
            res = {k: sp.body_rcs(person, seg, 0.0, a, d, surface=srf, step=step).po
                   for k, (person, seg, srf) in configs.items()}
            err = {k: float(bp.db(x) - bp.db(res["exact"])) for k, x in res.items()}
            vs8 = float(bp.db(res["32a-surf"]) - bp.db(res["8mm"]))
            for k, e in (*err.items(), ("vs8", vs8)):
                worst[k] = max(worst[k], abs(e))
            print(f"{d:4.0f} m {a:3.0f} {bp.db(res['exact']):7.2f} "
                  + " ".join(f"{err[k]:+13.2f}" for k in configs if k != "exact") + f" {vs8:+13.2f}", flush=True)
    print(f"{'max |dB|':>10s} {'':7s} " + " ".join(f"{worst[k]:13.2f}" for k in configs if k != "exact")
          + f" {worst['vs8']:13.2f}")


if __name__ == "__main__":
    ap_ = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap_.add_argument("what", choices=("geometry", "po", "walker"))
    ap_.add_argument("--step-scale", type=float, default=0.25)
    args = ap_.parse_args()
    if args.what == "walker":
        walker(args.step_scale)
    else:
        {"geometry": geometry, "po": po}[args.what]()
