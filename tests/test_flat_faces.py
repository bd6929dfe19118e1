"""Objects of a few plane faces integrated over their exact apertures (sionnafmcw.engines.flat_faces)."""

import sys
from pathlib import Path

import numpy as np
import pytest
from reflector_scenes import mirror_pair_scene, reflector_faces, reflector_mesh, reflector_scene

from sionnafmcw.engines.flat_faces import aperture_pieces, clip_convex, outline_factor, plane_faces
from sionnafmcw.flat_face_po import chain_channels, fan_triangles, subdivided
from sionnafmcw.polygon_integral import polygon_normals, polygon_phase_integral
from sionnafmcw.scenes import meshes

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))


def test_plane_faces_of_reflectors_boxes_and_others():
    """A trihedral's mesh is its three triangles, a dihedral's (each plate of many triangles) its two squares,
    a box its six rectangles, each of the mesh's area; a sphere, an L-shaped plate (not convex) and an
    object of seven planes are not plane-faced objects."""
    v, f = reflector_mesh("trihedral", (3.0, 0.2, 1.0), 0.1, 0.3)
    faces = plane_faces(v, f)
    assert faces.shape == (3, 3, 3)
    assert polygon_normals(faces)[1].sum() == pytest.approx(3 * 0.1 ** 2 / 2, rel=1e-6)
    v, f = reflector_mesh("dihedral", (3.0, 0.0, 1.0), 0.2, 0.1)
    assert len(f) > 2
    faces = plane_faces(v, f)
    assert faces.shape == (2, 4, 3)
    assert polygon_normals(faces)[1] == pytest.approx([0.04, 0.04], rel=1e-6)
    v, f = meshes.box((0.0, 0.0, 0.0), (0.3, 0.2, 0.1))
    faces = plane_faces(v, f)
    assert len(faces) == 6 and polygon_normals(faces)[1].sum() == pytest.approx(2 * (0.06 + 0.03 + 0.02), rel=1e-6)
    assert plane_faces(*meshes.ellipsoid((0.0, 0.0, 0.0), (0.1, 0.1, 0.1))) is None
    ell_v = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0], [1, 0, 0], [0, 1, 0]], float)
    ell_f = np.array([[0, 6, 7], [6, 3, 7], [6, 1, 2], [6, 2, 3], [7, 3, 4], [7, 4, 5]])
    assert np.isclose(0.5 * np.linalg.norm(np.cross(ell_v[ell_f[:, 1]] - ell_v[ell_f[:, 0]],
                                                    ell_v[ell_f[:, 2]] - ell_v[ell_f[:, 0]]), axis=1).sum(), 3.0)
    assert plane_faces(ell_v, ell_f) is None
    bv, bf = meshes.box((0.0, 0.0, 0.0), (0.3, 0.2, 0.1))
    tv, tf = reflector_mesh("trihedral", (1.0, 0.0, 0.0), 0.1, 0.3)
    assert plane_faces(np.concatenate([bv, tv]), np.concatenate([bf, tf + len(bv)])) is None


@pytest.mark.parametrize("step", [0.013, 0.05, 0.4])
def test_aperture_pieces_tile_the_polygon(step):
    """Cells wholly inside and cut pieces tile a convex polygon exactly: their areas sum to its area, every
    cell lies inside it, every cut piece is convex and inside it; a cell is a square of the step."""
    rng = np.random.default_rng(3)
    angles = np.sort(rng.uniform(0, 2 * np.pi, 7))
    radius = 0.2
    flat = np.stack([radius * np.cos(angles), 0.7 * radius * np.sin(angles)], axis=1)
    frame = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    polygon = np.array([0.5, -1.0, 2.0]) + flat @ frame[:2]
    centres, edges, cut = aperture_pieces(polygon, step)
    area = polygon_normals(polygon)[1]
    cells = len(centres) * step * step
    pieces = sum(polygon_normals(p)[1] for p in cut)
    assert cells + pieces == pytest.approx(area, rel=1e-12)
    assert np.allclose(np.linalg.norm(edges, axis=-1), step)
    assert np.allclose(np.einsum("ki,ki->k", edges[:, 0], edges[:, 1]), 0.0, atol=1e-15)
    # inside: every cell corner and every cut vertex on the inner side of every edge of the polygon
    normal = polygon_normals(polygon)[0]
    inward = np.cross(normal, np.roll(polygon, -1, axis=0) - polygon)
    corners = np.concatenate([centres + s1 * edges[:, 0] / 2 + s2 * edges[:, 1] / 2
                              for s1 in (-1, 1) for s2 in (-1, 1)] + [p for p in cut])
    side = np.einsum("kei,ei->ke", corners[:, None] - polygon[None], inward)
    assert np.all(side >= -1e-12)


def test_clip_convex_against_a_triangle():
    """Clipping squares against a triangle: a square inside stays whole, one outside goes, one across an
    edge keeps the part inside (area by hand)."""
    tri = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]])
    squares = np.array([[[0.5, 0.5], [1.5, 0.5], [1.5, 1.5], [0.5, 1.5]],
                        [[5.0, 5.0], [6.0, 5.0], [6.0, 6.0], [5.0, 6.0]],
                        [[1.5, 1.5], [2.5, 1.5], [2.5, 2.5], [1.5, 2.5]]])
    cells, counts = clip_convex(squares, np.full(3, 4), tri, np.roll(tri, -1, axis=0))
    assert counts[1] == 0
    areas = []
    for c, n in zip(cells, counts):
        p = c[:n]
        areas.append(0.5 * abs(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])) if n else 0.0)
    assert areas == pytest.approx([1.0, 0.0, 0.5], abs=1e-12)   # x + y <= 4 cuts the third square's corner off


@pytest.mark.parametrize("distance, aspect", [(1.0, 0.0), (1.0, 45.0), (3.0, 30.0)])
def test_outline_factor_against_fine_triangles(distance, aspect):
    r"""The factor of a cut piece (a 2 cm cell clipped by a slanted edge) for a bistatic pair against the
    near-field sum over triangles of 0.05 mm (flat_face_po's scheme, converged there): within the
    second-order remainder :math:`\frac12\operatorname{Var}q` (Var q bounded by :math:`\max q^2`); the
    first-order form alone (without the quadratic term) misses by far more where the piece spans
    Fresnel zones (1 m)."""
    k = 2 * np.pi / 3.9e-3
    a = np.deg2rad(aspect)
    normal = np.array([-np.cos(a), np.sin(a), 0.0])
    u = np.array([np.sin(a), np.cos(a), 0.0])
    v = np.array([0.0, 0.0, 1.0])
    centre0 = np.array([distance, 0.0, 0.0])
    square = centre0 + 0.01 * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float) @ np.stack([u, v])
    piece = square[:3]                                    # the cell cut along its diagonal
    area = polygon_normals(piece)[1]
    centre = piece.mean(axis=0)
    tx = np.array([[0.0, 0.002, 0.0]])
    rx = np.array([[0.0, -0.003, 0.001], [0.0, 0.004, -0.002]])
    factor = outline_factor(piece[None], centre[None], normal[None], tx[:, None], rx, 3.9e-3)[..., 0]
    tris = subdivided(fan_triangles([piece]), 5e-5)
    c = tris.mean(axis=1)
    for n, r in enumerate(rx):
        d_t, d_r = c - tx[0], c - r
        r_t, r_r = np.linalg.norm(d_t, axis=1), np.linalg.norm(d_r, axis=1)
        w = -k * (d_t / r_t[:, None] + d_r / r_r[:, None])
        ref_c = np.linalg.norm(centre - tx[0]) + np.linalg.norm(centre - r)
        exact = np.sum(np.exp(-1j * k * (r_t + r_r - ref_c)) * polygon_phase_integral(tris - c[:, None], w)) / area
        q_max = k * 0.02 ** 2 / distance                  # the quadratic phase across the piece, both ways
        assert abs(factor[0, n] - exact) <= 0.5 * q_max ** 2 + 1e-4
        w_c = -k * ((centre - tx[0]) / np.linalg.norm(centre - tx[0]) + (centre - r) / np.linalg.norm(centre - r))
        linear = polygon_phase_integral(piece - centre, w_c) / area
        if distance == 1.0:
            assert abs(linear - exact) > 10 * abs(factor[0, n] - exact)


def _db(x):
    return 20 * np.log10(abs(x))


@pytest.mark.parametrize("kind, leg, distance", [("trihedral", 0.1, 3.0), ("dihedral", 0.1, 3.0),
                                                 pytest.param("dihedral", 0.3, 1.0, marks=pytest.mark.slow)])
def test_engine_defaults_give_the_exact_and_converged_echo(tmp_path, kind, leg, distance):
    """The path engine's defaults on a corner reflector 0-45 degrees off its axis: the whole PO echo (channel of
    an isotropic element at the phase centre) within 0.1 dB of the exact flat-face PO of every chain (the
    reference's own convergence, flat_face_po) and of the same engine with four times the density; the
    sampled render (po_flat_faces=False) is off by more than 1 dB at 45 degrees for the trihedral."""
    from po_flat_faces import bounce_channels, engine_renders

    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation
    from sionnafmcw.engines import PathEngine

    radar = RadarConfig.preset("walk-77ghz").replace(antenna_pattern="iso", num_chirps=16)
    depth = 3 if kind == "trihedral" else 2
    for aspect in (0.0, 15.0, 30.0, 45.0):
        anim = load_animation(reflector_scene(tmp_path / f"{aspect:.0f}", kind, leg, distance, np.deg2rad(aspect)))
        faces = reflector_faces(kind, (distance, 0.0, 1.0), leg, np.deg2rad(aspect), (0.0, 0.0, 1.0))
        echo = {}
        for name, options in (("default", {}), ("dense", {"po_samples_across": 64}),
                              ("sampled", {"po_flat_faces": False})):
            engine = PathEngine(max_depth=depth, diffuse=False, **options)
            engine.echoes(anim, radar, 0)
            h, _, gamma = bounce_channels(engine_renders(engine), radar.wavelength)
            echo[name] = sum(h)
        origin = engine_renders(engine)[0].source[0]
        exact = sum(chain_channels(faces, origin, radar.wavelength, depth, gamma).values())
        assert abs(_db(echo["default"]) - _db(exact)) < 0.1, (aspect, _db(echo["default"]), _db(exact))
        assert abs(_db(echo["default"]) - _db(echo["dense"])) < 0.1, aspect
        if kind == "trihedral" and aspect == 45.0:
            assert abs(_db(echo["sampled"]) - _db(exact)) > 1.0



def test_other_objects_hide_the_exact_pieces(tmp_path):
    """A 0.1 m trihedral on its axis 3 m ahead, and a 0.4 m metal plate between it and the radar: wholly
    hidden (the plate 1.5 m ahead) the trihedral returns nothing, as the sampled render's first hits say;
    the plate moved 0.3 m aside, the trihedral's echo is the unhidden one (within 0.1 dB: the rays of its
    pieces pass the plate)."""
    from po_flat_faces import object_channels

    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation
    from sionnafmcw.engines import PathEngine
    from sionnafmcw.scenes.writer import METAL, AnimationWriter, metal_material

    radar = RadarConfig.preset("walk-77ghz").replace(antenna_pattern="iso", num_chirps=16)
    echo = {}
    for name, offset in (("alone", None), ("hidden", 0.0), ("aside", 0.3)):
        w = AnimationWriter(tmp_path / name, 24.0)
        w.add_materials(metal_material(0.0))
        w.static("reflector", *reflector_mesh("trihedral", (3.0, 0.0, 1.0), 0.1, 0.0), METAL)
        if offset is not None:
            w.static("plate", *meshes.plate((1.5, offset, 1.0), (0.4, 0.4), normal=(1.0, 0.0, 0.0)), METAL)
        w.frame([])
        anim = load_animation(w.finish((0.0, 0.0, 1.0), (0.0, 0.0, 0.0)))
        engine = PathEngine(max_depth=3, diffuse=False)
        engine.echoes(anim, radar, 0)
        echo[name] = object_channels(engine, radar.wavelength).get("reflector", 0j)
        assert engine.last_exact_ids, "the trihedral is integrated over its exact apertures"
    assert abs(echo["hidden"]) == 0.0
    assert abs(_db(echo["aside"]) - _db(echo["alone"])) < 0.1


def test_exact_pieces_through_the_kernel_equal_the_numpy_reference(tmp_path):
    """The engine's contributions of the exact pieces (cells through the Dr.Jit kernel with their footprint,
    cut pieces as point samples times their outline's factor) equal chain_po_gains, the numpy reference,
    with the element gains towards the first hit and from the piece and the same outline factor, to
    rounding (1e-12 of the largest, as tests/test_po_kernel.py), on every bounce of a trihedral 30 degrees
    off its axis seen by a radar with directive elements; cells and cut pieces both occur."""
    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation
    from sionnafmcw.antenna import antenna_gain, direction_angles
    from sionnafmcw.engines import PathEngine
    from sionnafmcw.engines.po_render import chain_po_gains

    radar = RadarConfig.preset("walk-77ghz")
    anim = load_animation(reflector_scene(tmp_path / "tri", "trihedral", 0.1, 2.0, np.deg2rad(30)))
    engine = PathEngine(max_depth=3, diffuse=False)
    engine.echoes(anim, radar, 0)
    _, _, rot, tx, rx = engine._po_geometry(anim, radar, anim.radar_pose, {})
    kinds = set()
    for bounce in engine.last_exact_renders:
        a1, tau1, _, _ = engine._po_contributions(bounce, radar, tx, rx, rot, radar.wavelength)
        g_t = antenna_gain(radar.antenna_pattern, *direction_angles((bounce.first_point[None] - tx[:, None]) @ rot))
        g_r = antenna_gain(radar.antenna_pattern,
                           *direction_angles((bounce.samples.position[None] - rx[:, None]) @ rot))
        a0, tau0, _ = chain_po_gains(bounce, tx, rx, radar.wavelength, g_t, g_r, bounce.outline is None)
        if bounce.outline is not None:
            a0 = a0 * outline_factor(bounce.outline, bounce.samples.position, bounce.samples.normal,
                                     bounce.image_of(tx), rx, radar.wavelength)
        assert np.max(np.abs(a1 - a0)) <= 1e-12 * np.max(np.abs(a0)), (bounce.depth, bounce.outline is None)
        assert np.max(np.abs(tau1 - tau0)) <= 1e-12 * np.max(tau0)
        kinds.add((bounce.depth, bounce.outline is None))
    assert {(1, True), (1, False), (3, True), (3, False)} <= kinds
