"""Monostatic RCS of the walking body at 77 GHz: PO (coherent share) + Lambertian (diffuse share), over aspect.

    .venv/bin/python benchmarks/body_rcs.py convergence   # mesh-resolution study (sets body.MESH_EDGE)
    .venv/bin/python benchmarks/body_rcs.py aspect        # RCS vs aspect, poses, 3 m and 10 m; figure + statistics
    .venv/bin/python benchmarks/body_rcs.py scene         # circle_walk: PLY size per frame, time to build 100 frames
    .venv/bin/python benchmarks/body_rcs.py ab            # statistics of the 8 mm flat-sampled body against the default

Method (tests/body_po.py): the body of ``sionnafmcw.scenes.body.WalkingPerson`` (1.8 m, walking at
1.4 m/s) at a gait phase, in its own frame; the radar at distance R (horizontal) and aspect phi
(0: in front, 90: the person's left, 180: behind) at 1 m height renders it on an equiangular grid
(tests/mesh_render.py, the pixel engine's first-hit ray cast in numpy, step from
physical_optics.render_resolution with the forearm's radius of curvature) with the interpolated
vertex normals; sigma_PO = physical_optics.monostatic_rcs (coherent share sqrt(1 - S^2) Gamma),
sigma_d = the diffuse share's expected RCS (random-phase Lambertian scatterers add in power);
sigma = sigma_PO + sigma_d. Skin: Gabriel's dry skin at 77 GHz (|Gamma|^2 = 0.341 at normal
incidence) with S from its rms roughness (tests/body_po.py).

Statistics over aspect (and poses): mean of sigma in m^2 then dBsm, median (dBsm), 10 and 90 %
percentiles (dBsm). Compared with 3GPP TR 38.901 (Rel-19) clause 7.9.2.1 human models as Sionna RT
2.2 ships them (sionna/rt/rcs/tr38901/parameters.py): model 1, 10 lg sigma_M = -1.37 dBsm
(angle independent) with a log-normal sigma_S of 3.94 dB and linear mean 1; model 2, front and
back lobes G_max = 2.14 dBsm, phi_3dB = 216.65 deg, sigma_max = 7.7 dB (Table 7.9.2.1-3).
"""

from __future__ import annotations

import math
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import body_po as bp  # noqa: E402
from sionnafmcw.scenes.body import MESH_EDGE, WalkingPerson  # noqa: E402

OUT = ROOT / "out" / "body_rcs"
PHASES = (0.0, 1 / 6, 1 / 3)   # gait phases (cycles) over half a cycle (the other half is its mirror image)
ASPECTS_STUDY = (0.0, 30.0, 90.0, 150.0, 180.0)
EDGES_STUDY = (0.032, 0.024, 0.016, 0.012, 0.008, 0.006, 0.004)

# 3GPP TR 38.901 human, from Sionna RT 2.2 (sionna/rt/rcs/tr38901/parameters.py)
TR_MODEL1_SIGMA_M_DB, TR_MODEL1_SIGMA_S_DB = -1.37, 3.94
TR_MODEL2 = {"g_max": 2.14, "phi_3db": 216.65, "sigma_max": 7.7}


def tr38901_model1_stats():
    """(mean dBsm, median dBsm, p10, p90) of model 1: sigma_M sigma_S, 10 lg sigma_S ~ N(mu, 3.94^2), E sigma_S = 1."""
    s = TR_MODEL1_SIGMA_S_DB
    mu = -(math.log(10) / 20) * s ** 2          # E[10^(X/10)] = 1
    z = 1.2815515655446004
    return TR_MODEL1_SIGMA_M_DB, TR_MODEL1_SIGMA_M_DB + mu, TR_MODEL1_SIGMA_M_DB + mu - z * s, \
        TR_MODEL1_SIGMA_M_DB + mu + z * s


def tr38901_model2_db(aspect_deg):
    """Model 2 (horizontal incidence, theta = 90 deg): G_max - min(12 ((phi - phi_c)/phi_3dB)^2, sigma_max),
    phi_c = 0 (front lobe, |phi| < 90) or 180 (back lobe)."""
    phi = np.mod(np.asarray(aspect_deg, float) + 180.0, 360.0) - 180.0
    off = np.where(np.abs(phi) <= 90.0, phi, 180.0 - np.abs(phi))
    p = TR_MODEL2
    return p["g_max"] - np.minimum(12 * (off / p["phi_3db"]) ** 2, p["sigma_max"])


def stats(sigma):
    sigma = np.asarray(sigma, float).ravel()
    return (float(bp.db(sigma.mean())), float(np.median(bp.db(sigma))), float(np.percentile(bp.db(sigma), 10)),
            float(np.percentile(bp.db(sigma), 90)))


def convergence(distances=(3.0, 10.0), phase=0.0):
    print("mesh convergence: PO + diffuse monostatic RCS (dBsm) of the body at 77 GHz, gait phase", phase)
    rows = {}
    for edge in EDGES_STUDY:
        t0 = time.perf_counter()
        person = WalkingPerson(mesh_edge=edge)
        mesh = bp.body_frame_mesh(person, phase)
        tris = len(mesh[1])
        vals = {}
        for d in distances:
            for a in ASPECTS_STUDY:
                vals[(d, a)] = bp.body_rcs(person, phase, a, d, mesh=mesh).total
        rows[edge] = (tris, vals, time.perf_counter() - t0)
        print(f"  edge {edge * 1e3:4.0f} mm  {tris:7d} triangles  {rows[edge][2]:6.1f} s", flush=True)
    finest = rows[EDGES_STUDY[-1]][1]
    head = "  ".join(f"{d:.0f}m/{a:3.0f}" for d in distances for a in ASPECTS_STUDY)
    print(f"\nedge(mm) triangles  RCS dBsm per range/aspect: {head}")
    for edge, (tris, vals, _) in rows.items():
        cells = "  ".join(f"{bp.db(vals[k]):7.2f}" for k in vals)
        print(f"{edge * 1e3:7.0f} {tris:9d}  {cells}")
    print("\nchange vs the finest (dB); max |change|")
    for edge, (tris, vals, _) in rows.items():
        diff = np.array([bp.db(vals[k]) - bp.db(finest[k]) for k in vals])
        cells = "  ".join(f"{x:+7.2f}" for x in diff)
        print(f"{edge * 1e3:7.0f} {tris:9d}  {cells}   max {np.abs(diff).max():.2f}")


def aspect_sweep(distances=(3.0, 10.0), step_deg=10.0):
    aspects = np.arange(0.0, 360.0, step_deg)
    person = WalkingPerson(mesh_edge=MESH_EDGE)
    print(f"body RCS vs aspect at 77 GHz: mesh edge {MESH_EDGE * 1e3:.0f} mm, skin S = "
          f"{bp.scattering_coefficient(bp.SKIN_RMS_ROUGHNESS):.3f} (rms height {bp.SKIN_RMS_ROUGHNESS * 1e3:.2f} mm), "
          f"|Gamma|^2 = {abs(bp.skin_reflection()) ** 2:.3f}")
    result = {}
    t0 = time.perf_counter()
    for d in distances:
        for ph in PHASES:
            mesh = bp.body_frame_mesh(person, ph)
            po, dif = [], []
            for a in aspects:
                r = bp.body_rcs(person, ph, a, d, mesh=mesh)
                po.append(r.po)
                dif.append(r.diffuse)
            result[(d, ph)] = (np.array(po), np.array(dif))
            print(f"  {d:4.0f} m phase {ph:.3f}: {time.perf_counter() - t0:6.1f} s", flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    np.savez(OUT / "body_rcs.npz", aspects=aspects, phases=np.array(PHASES), distances=np.array(distances),
             **{f"po_{d:.0f}m_{ph:.3f}": v[0] for (d, ph), v in result.items()},
             **{f"diffuse_{d:.0f}m_{ph:.3f}": v[1] for (d, ph), v in result.items()})
    print("\n                         mean(lin) dBsm  median dBsm  p10   p90   | PO only mean  diffuse mean")
    for d in distances:
        for ph in PHASES:
            po, dif = result[(d, ph)]
            m = stats(po + dif)
            print(f"  {d:4.0f} m  phase {ph:.3f}      {m[0]:7.2f}      {m[1]:7.2f}  {m[2]:6.2f} {m[3]:6.2f} |"
                  f" {bp.db(po.mean()):7.2f}      {bp.db(dif.mean()):7.2f}")
        allv = np.concatenate([sum(result[(d, ph)]) for ph in PHASES])
        m = stats(allv)
        print(f"  {d:4.0f} m  all poses        {m[0]:7.2f}      {m[1]:7.2f}  {m[2]:6.2f} {m[3]:6.2f}")
    for name, sel in (("front (|phi| <= 30)", np.abs(((aspects + 180) % 360) - 180) <= 30),
                      ("side (60-120, 240-300)", (np.abs(((aspects + 180) % 360) - 180) >= 60)
                       & (np.abs(((aspects + 180) % 360) - 180) <= 120)),
                      ("back (|phi - 180| <= 30)", np.abs(aspects - 180) <= 30)):
        v = np.concatenate([sum(result[(distances[0], ph)])[sel] for ph in PHASES])
        m = stats(v)
        print(f"  {distances[0]:4.0f} m  {name:24s} mean {m[0]:6.2f}  median {m[1]:6.2f}  "
              f"p10 {m[2]:6.2f}  p90 {m[3]:6.2f}")
    t1 = tr38901_model1_stats()
    m2 = tr38901_model2_db(aspects)
    print(f"\n  TR 38.901 model 1 (human): mean {t1[0]:.2f}  median {t1[1]:.2f}  p10 {t1[2]:.2f}  p90 {t1[3]:.2f} dBsm")
    print(f"  TR 38.901 model 2 (human, sigma_S = 1): mean {bp.db(np.mean(10 ** (m2 / 10))):.2f}  "
          f"front {m2[0]:.2f}  side {m2[9]:.2f} dBsm")
    figure(aspects, result, distances, m2)


def figure(aspects, result, distances, tr_model2):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(distances), figsize=(6.0 * len(distances), 4.2), sharey=True)
    for ax, d in zip(np.atleast_1d(axes), distances):
        for ph in PHASES:
            po, dif = result[(d, ph)]
            ax.plot(aspects, bp.db(po + dif), marker=".", lw=1, label=f"gait phase {ph:.3f}")
        allv = np.concatenate([sum(result[(d, ph)]) for ph in PHASES])
        ax.axhline(bp.db(allv.mean()), color="k", lw=1.5, label=f"PO+diffuse mean {bp.db(allv.mean()):.1f} dBsm")
        ax.axhline(TR_MODEL1_SIGMA_M_DB, color="tab:red", ls="--", label="TR 38.901 model 1 mean -1.37 dBsm")
        ax.plot(aspects, tr_model2, color="tab:purple", ls=":", label="TR 38.901 model 2 (sigma_S = 1)")
        ax.set_title(f"walking body, skin, 77 GHz, R = {d:.0f} m")
        ax.set_xlabel("aspect (deg; 0 = front, 90 = left side, 180 = back)")
        ax.set_xticks(np.arange(0, 361, 45))
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("monostatic RCS (dBsm)")
    np.atleast_1d(axes)[0].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    OUT.mkdir(parents=True, exist_ok=True)
    path = OUT / "body_rcs_aspect.png"
    fig.savefig(path, dpi=120)
    print(f"\n  figure: {path.relative_to(ROOT)}")


def scene_cost(num_frames=100):
    """circle_walk at the default mesh: PLY bytes per frame (with normals) and the build time."""
    import tempfile

    from sionnafmcw.animation.ply import ply_bytes
    from sionnafmcw.scenes import build
    from sionnafmcw.scenes.walking import circle_person

    person = circle_person()
    state = person.segment_state(0.0)
    plain = sum(len(ply_bytes(s.vertices, person.faces(k), s.vertex_velocities)) for k, s in state.items())
    normals = sum(len(ply_bytes(s.vertices, person.faces(k), s.vertex_velocities, vertex_normals=s.vertex_normals))
                  for k, s in state.items())
    tris = sum(len(person.faces(k)) for k in state)
    print(f"circle_walk body: mesh edge {MESH_EDGE * 1e3:.0f} mm, {tris} triangles; PLY per frame "
          f"{plain / 1e6:.2f} MB (x y z vx vy vz), {normals / 1e6:.2f} MB with nx ny nz")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        build("circle_walk", pathlib.Path(tmp) / "walk", num_frames=num_frames)
        dt = time.perf_counter() - t0
        size = sum(p.stat().st_size for p in (pathlib.Path(tmp) / "walk").rglob("*") if p.is_file())
        from sionnafmcw.animation import load_animation

        anim = load_animation(pathlib.Path(tmp) / "walk")
        print(f"circle_walk {num_frames} frames: built in {dt:.1f} s, {size / 1e6:.1f} MB on disk, "
              f"loadable ({len(anim.frames) if hasattr(anim, 'frames') else anim.num_frames} frames)")


def before_after(distances=(3.0, 10.0), step_deg=20.0, edge_a=0.008):
    """The body's RCS statistics over aspect and pose, A (``edge_a`` mesh, its area-weighted vertex
    normals, samples on the flat facets: the former default body) against B (the default body: its
    :data:`MESH_EDGE` mesh with the exact normals of its shapes, refined to its smooth surface with the
    samples on it, as the engines render it), both rendered by ``tests/smooth_po.body_rcs`` at the
    resolution rule's pixel step; the aspects interleaved A, B. Per range: mean (linear), median, 10 and
    90 % (dBsm) and the per-look difference B - A (dB: mean, rms, largest)."""
    import smooth_po as sp
    from sionnafmcw.scenes import meshes

    person_a, person_b = WalkingPerson(mesh_edge=edge_a), WalkingPerson(mesh_edge=MESH_EDGE)
    seg_a = {k: (*person_a.local_meshes[k], meshes.vertex_normals(*person_a.local_meshes[k]))
             for k in person_a.local_meshes}
    refined = sp.refined_segments(person_b)
    seg_b, surface_b = sp.refined_segment_meshes(refined), sp.refined_surface(refined)
    aspects = np.arange(0.0, 360.0, step_deg)
    print(f"body RCS, A: {edge_a * 1e3:.0f} mm flat samples, area-weighted normals; B: {MESH_EDGE * 1e3:.0f} mm "
          f"refined ({sum(len(r.faces) for r in refined.values())} triangles), exact normals, samples on the smooth "
          f"surface; aspects every {step_deg:g} deg, phases {', '.join(f'{p:.3f}' for p in PHASES)}")
    t0 = time.perf_counter()
    for d in distances:
        a_vals, b_vals = [], []
        for ph in PHASES:
            for asp in aspects:
                a_vals.append(sp.body_rcs(person_a, seg_a, ph, asp, d).total)
                b_vals.append(sp.body_rcs(person_b, seg_b, ph, asp, d, surface=surface_b).total)
        a_vals, b_vals = np.array(a_vals), np.array(b_vals)
        diff = bp.db(b_vals) - bp.db(a_vals)
        for name, v in (("A", a_vals), ("B", b_vals)):
            m = stats(v)
            print(f"  {d:4.0f} m {name}: mean {m[0]:6.2f}  median {m[1]:6.2f}  p10 {m[2]:6.2f}  p90 {m[3]:6.2f} dBsm")
        print(f"  {d:4.0f} m B - A per look: mean {diff.mean():+.2f} dB, rms {np.sqrt((diff ** 2).mean()):.2f} dB, "
              f"largest {diff[np.argmax(np.abs(diff))]:+.2f} dB ({len(diff)} looks, {time.perf_counter() - t0:.0f} s)",
              flush=True)


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "aspect"
    {"convergence": convergence, "aspect": aspect_sweep, "scene": scene_cost, "ab": before_after}[what]()
