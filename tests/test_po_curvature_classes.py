"""The PO render's curvature classes: the resolution rule applied per triangle (``engines/po_render.py``,
*Curvature classes*).

One metal object made of two spheres, a 0.1 m one at 3 m and a 0.02 m one 0.6 m farther: the
object's radius of curvature (its 2 % quantile) is the small sphere's, so one grid would sample the
large sphere at the small one's step. With the classes the large sphere's triangles form a class of
radius :math:`0.02\\cdot2^2` = 0.08 m and are sampled at that radius's step, twice as coarse:
a quarter of the samples (the rule's sample size grows as :math:`\\sqrt\\rho`). Reference: the PO
integral over each exact sphere for every element pair of ``walk-77ghz`` (``tests/analytic_po.py``);
tolerance the 1 dB per element pair of ``tests/test_smooth_meshes_rcs.py``, each sphere on its own
(its echoes told apart by their delay: the spheres are 0.6 m apart in range, 12 range bins).
"""

from __future__ import annotations

import numpy as np
import pytest

import analytic_po as ap
import smooth_po as sp
from sionnafmcw import RadarConfig
from sionnafmcw.animation import load_animation
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.engines import PathEngine
from sionnafmcw.engines.po_render import curvature_classes
from sionnafmcw.scenes.writer import METAL, AnimationWriter, metal_material

RADAR = RadarConfig.preset("walk-77ghz").replace(antenna_pattern="iso", num_chirps=16)
LAM = sp.WAVELENGTH
DISTANCE = 3.0
BIG, SMALL = (0.1, np.zeros(3)), (0.02, np.array([0.6, 0.3, 0.0]))


def test_curvature_classes_follow_the_ratio():
    """Class c holds the radii in [rho0 2^c, rho0 2^(c+1)) (below rho0: class 0; flat: the last); empty
    classes are dropped and the rest numbered from 0, each with its lower radius."""
    rho0 = 0.01
    radii = np.array([0.004, 0.01, 0.019, 0.02, 0.05, 0.3, np.inf])
    cls, class_radii = curvature_classes(radii, rho0, ratio=2.0, max_classes=6)
    # levels 0, 0, 0, 1, 2, 4 (0.3/0.01 = 30: 2^4 <= 30 < 2^5), 5 (flat: the last)
    assert cls.tolist() == [0, 0, 0, 1, 2, 3, 4]
    np.testing.assert_allclose(class_radii, rho0 * 2.0 ** np.array([0, 1, 2, 4, 5]))
    cls, class_radii = curvature_classes(radii, np.inf)
    assert cls.tolist() == [0] * radii.size and class_radii.tolist() == [np.inf]


def two_spheres(root):
    """One still metal object: both icospheres (1280 faces each) with their exact normals."""
    vertices, faces, normals = [], [], []
    for radius, centre in (BIG, SMALL):
        v, f = sp.icosphere(radius, 3)
        faces.append(f + sum(len(x) for x in vertices))
        vertices.append(v + centre)
        normals.append(v / radius)
    writer = AnimationWriter(root, fps=10.0)
    writer.add_materials(metal_material())
    writer.rigid("target", np.concatenate(vertices), np.concatenate(faces), METAL,
                 vertex_normals=np.concatenate(normals))
    writer.frame(rigid={"target": {"to_world": np.eye(4), "velocity": np.zeros(3), "angular_velocity": np.zeros(3)}})
    return load_animation(writer.finish((-DISTANCE, 0.0, 0.0), (0.0, 0.0, 0.0)))


def sphere_channels(echoes):
    """``[2, M, N]`` channels at the carrier of the contributions nearer and farther than the midpoint."""
    h = echoes.a * np.exp(-2j * np.pi * RADAR.fc * echoes.tau)
    far = echoes.tau > 2 * (DISTANCE + 0.3) / SPEED_OF_LIGHT
    return np.stack([np.sum(np.where(far, 0, h), axis=-1), np.sum(np.where(far, h, 0), axis=-1)])


def test_each_sphere_sampled_at_its_own_curvature_keeps_its_po(tmp_path):
    anim = two_spheres(tmp_path / "scene")
    engine = PathEngine(static_scene=False)
    h = sphere_channels(engine.echoes(anim, RADAR, 0))
    samples = engine.last_renders[0].samples.position
    big = np.linalg.norm(samples - BIG[1], axis=1) < 2 * BIG[0]
    surface = engine._state.surfaces.surfaces[0]
    cls, radii, _ = surface.curvature_classes()
    assert len(radii) >= 2 and radii[-1] >= 4 * radii[0]       # the large sphere is a class of its own
    # the same object on one grid (the object's radius for every triangle): the rule before the classes
    surface._classes = (np.zeros_like(cls), radii[:1], None)
    engine.echoes(anim, RADAR, 0)
    single = engine.last_renders[0].samples.position
    big_single = np.linalg.norm(single - BIG[1], axis=1) < 2 * BIG[0]
    assert big.sum() < 0.35 * big_single.sum()                 # (rho0 / 4 rho0) = 1/4 of the samples
    assert (~big).sum() == pytest.approx((~big_single).sum(), rel=0.05)   # the small sphere as before
    tx, rx = sp.walk_elements(DISTANCE)
    for k, (radius, centre) in enumerate((BIG, SMALL)):
        ref = ap.sphere_po_channels(radius, centre, tx, rx, LAM)
        error = 10 * np.log10(np.abs(h[k]) ** 2 / np.abs(ref) ** 2)
        assert np.all(np.abs(error) < 1.0), f"sphere {radius} m: per-pair error {error.round(2)} dB"
