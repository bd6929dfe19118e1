"""The Dr.Jit PO kernel (engines/po_kernel.py) against its numpy reference, on renders of a real scene.

The reference is ``chain_po_gains`` (``po_gains`` on bounce 1) with the element gains of
``antenna_gain`` towards the first hit and from the sample, as the path engine computed them
before the kernel. The two evaluate the same expressions in another order and with other
transcendental functions, so they agree to rounding: 1e-12 of the largest contribution
(float64 rounding is 1e-16; the sums over a few dozen terms and the polynomial sin / acos /
atan2 / exp2 of Dr.Jit stay far below 1e-12), the same relative bound on the delays, and
1e-9 Hz on Doppler shifts of kHz. These are equivalence bounds, far below what the radar
resolves (walk-77ghz: a range bin c/2B of 9.8 cm, i.e. 6.5e-10 s of delay, against 1e-12 x 3e-8 s
here; a Doppler bin of 37 Hz): the physics itself is held to closed forms and to the PO quadrature
through the engine in tests/test_path_po.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from sionnafmcw import RadarConfig
from sionnafmcw.animation import load_animation
from sionnafmcw.antenna import antenna_gain, direction_angles
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.engines import PathEngine
from sionnafmcw.engines.po_kernel import element_pair_po
from sionnafmcw.engines.po_render import chain_po_gains
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.physical_optics import PhysicalOpticsError
from sionnafmcw.scenes.registry import build
from sionnafmcw.sionna_rt import track_kernels

RADAR = RadarConfig.preset("walk-77ghz")
LAMBDA = SPEED_OF_LIGHT / RADAR.fc


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """The PO renders (bounces 1 to 3) of a frame with moving corner reflectors in a rough-walled room,
    seen from a yawed and pitched radar, and the element positions and rotation."""
    root = build("corner_reflectors", tmp_path_factory.mktemp("po_kernel") / "scene", num_frames=2,
                 ranges=(2.0, 3.0), azimuths=(-0.2, 0.25), speeds=(1.0, -0.5), room=True,
                 scattering_coefficient=0.3)
    anim = load_animation(root)
    pose = (np.asarray(anim.radar_pose.position) + [0.0, 0.05, 0.02], (0.1, -0.05, 0.02))
    engine = PathEngine(samples_per_src=5_000, max_depth=3, static_scene=False)
    engine.echoes(anim, RADAR, 1, radar_pose=pose)
    rot = rotation_matrix(pose[1])
    tx = pose[0] + RADAR.tx_positions @ rot.T
    rx = pose[0] + RADAR.rx_positions @ rot.T
    out = [b.select(b.carries_po()) for b in engine.last_renders]
    engine.close()
    assert [b.depth for b in out] == [1, 2, 3] and all(b.num_samples > 100 for b in out)
    assert np.any(out[0].samples.velocity != 0)                    # Doppler is exercised,
    assert np.any(out[2].doppler_inner != 0)                       # the middle bounce's too
    return out, tx, rx, rot


def reference(bounce, tx, rx, rot, pattern, in_sample_phase=True):
    g_t = antenna_gain(pattern, *direction_angles((bounce.first_point[None] - tx[:, None]) @ rot))
    g_r = antenna_gain(pattern, *direction_angles((bounce.samples.position[None] - rx[:, None]) @ rot))
    return chain_po_gains(bounce, tx, rx, LAMBDA, g_t, g_r, in_sample_phase)


def curved(bounce, seed=0):
    """``bounce`` with a shape operator on every sample (the corner reflectors and walls are flat, K = 0):
    symmetric, on the tangent plane, radii of curvature of 2-20 cm of either sign, as on a body."""
    from dataclasses import replace

    rng = np.random.default_rng(seed)
    n = bounce.samples.normal
    proj = np.eye(3)[None] - n[:, :, None] * n[:, None, :]
    k = rng.normal(size=(bounce.num_samples, 3, 3)) * rng.uniform(5.0, 50.0, (bounce.num_samples, 1, 1))
    k = proj @ (0.5 * (k + k.transpose(0, 2, 1))) @ proj
    return replace(bounce, samples=replace(bounce.samples, curvature=k))


@pytest.mark.parametrize("pattern", ["tr38901", "iso"])
@pytest.mark.parametrize("in_sample_phase", [True, False])
@pytest.mark.parametrize("shape", ["as rendered", "curved"])
def test_kernel_equals_the_numpy_reference(renders, pattern, in_sample_phase, shape):
    bounces, tx, rx, rot = renders
    for bounce in bounces:
        if shape == "curved":
            bounce = curved(bounce, bounce.depth)
        a0, tau0, f0 = reference(bounce, tx, rx, rot, pattern, in_sample_phase)
        a1, tau1, f1 = element_pair_po(bounce, tx, rx, rot, LAMBDA, pattern, in_sample_phase)
        assert a1.shape == tau1.shape == f1.shape == (RADAR.num_tx, RADAR.num_rx, bounce.num_samples)
        assert np.max(np.abs(a1 - a0)) <= 1e-12 * np.max(np.abs(a0)), bounce.depth
        assert np.max(np.abs(tau1 - tau0)) <= 1e-12 * np.max(tau0), bounce.depth
        assert np.max(np.abs(f1 - f0)) <= 1e-9, bounce.depth
        assert np.max(np.abs(f0)) > 1.0                              # moving targets: real Doppler shifts


def test_kernel_evaluates_board_and_measured_patterns_as_numpy(renders, tmp_path):
    """The kernel's element gains come from the same formula as antenna_gain for every pattern
    (sionnafmcw.sionna_rt.drjit_element_gain): a TI board pattern and a measured two-cut table (read
    from a file) give the numpy reference's contributions to rounding, as tr38901 and iso do."""
    from sionnafmcw.antenna import load_pattern_file

    angles = np.arange(-90.0, 91.0, 2.0)
    path = tmp_path / "cuts.csv"
    path.write_text("angle_deg,azimuth_dbi,elevation_dbi\n" + "\n".join(
        f"{a},{9.0 - 12 * (a / 70) ** 2:.4f},{9.0 - 12 * (a / 25) ** 2 if abs(a) < 40 else -20:.4f}" for a in angles))
    bounces, tx, rx, rot = renders
    for pattern in ("ti-awr1843boost", load_pattern_file(path)):
        for bounce in bounces[:2]:
            a0, _, _ = reference(bounce, tx, rx, rot, pattern)
            a1, _, _ = element_pair_po(bounce, tx, rx, rot, LAMBDA, pattern)
            assert np.max(np.abs(a1 - a0)) <= 1e-12 * np.max(np.abs(a0)), bounce.depth


def test_kernel_is_compiled_once_and_repeatable(renders):
    """A second render of another size runs the kernels already compiled (the frozen recording replayed
    with the new sizes, element positions and rotation: the numpy reference's contributions for
    those); the same input gives the same output bit for bit (no reductions: one lane per output
    element); a single sample (the width of the opaque scalars, traced without the recording) too."""
    bounces, tx, rx, rot = renders
    element_pair_po(bounces[0], tx, rx, rot, LAMBDA, "tr38901")
    element_pair_po(bounces[1], tx, rx, rot, LAMBDA, "tr38901")
    smaller = bounces[0].select(np.arange(bounces[0].num_samples // 3))
    moved = tx + [0.0, 0.0, 0.01]                                   # another pose: opaque, not baked in
    few = bounces[1].select(np.arange(7))
    with track_kernels(True, set()) as counts:
        first = element_pair_po(smaller, moved, rx, rot, LAMBDA, "tr38901")
        turned = element_pair_po(few, moved, rx, rot.T, LAMBDA, "tr38901")
    assert counts.launched > 0 and counts.compiled == 0
    for bounce, rotation, got in ((smaller, rot, first), (few, rot.T, turned)):
        want = reference(bounce, moved, rx, rotation, "tr38901")
        assert np.max(np.abs(got[0] - want[0])) <= 1e-12 * np.max(np.abs(want[0]))
        assert np.max(np.abs(got[1] - want[1])) <= 1e-12 * np.max(want[1])
    again = element_pair_po(smaller, moved, rx, rot, LAMBDA, "tr38901")
    for x, y in zip(first, again):
        np.testing.assert_array_equal(x, y)
    one = bounces[0].select(np.arange(1))
    a1, _, _ = element_pair_po(one, tx, rx, rot, LAMBDA, "tr38901")
    a0, _, _ = reference(one, tx, rx, rot, "tr38901")
    assert np.max(np.abs(a1 - a0)) <= 1e-12 * np.max(np.abs(a0))


def test_kernel_bad_input(renders):
    bounces, tx, rx, rot = renders
    with pytest.raises(PhysicalOpticsError, match="wavelength"):
        element_pair_po(bounces[0], tx, rx, rot, 0.0, "iso")
    with pytest.raises(ValueError, match="antenna_pattern='dipole'"):
        element_pair_po(bounces[0], tx, rx, rot, LAMBDA, "dipole")
    a, tau, f = element_pair_po(bounces[0].select(np.zeros(bounces[0].num_samples, bool)), tx, rx, rot, LAMBDA, "iso")
    assert a.shape == tau.shape == f.shape == (RADAR.num_tx, RADAR.num_rx, 0)


def test_chunks_give_the_same_contributions(renders, monkeypatch):
    """Samples go through the kernels in chunks of ``CHUNK`` (so that Dr.Jit reuses its buffers); every
    output element is its own lane, so the chunking changes nothing, bit for bit."""
    from sionnafmcw.engines import po_kernel

    bounces, tx, rx, rot = renders
    whole = element_pair_po(bounces[1], tx, rx, rot, LAMBDA, "tr38901")
    monkeypatch.setattr(po_kernel, "CHUNK", 97)                    # many chunks and a short last one
    assert bounces[1].num_samples > 3 * 97 and bounces[1].num_samples % 97
    chunked = element_pair_po(bounces[1], tx, rx, rot, LAMBDA, "tr38901")
    for x, y in zip(whole, chunked):
        np.testing.assert_array_equal(x, y)


def test_kernel_from_several_threads_at_once(renders):
    """Threaded Dask workers share a process: element_pair_po called from three threads at once (the
    frozen recording taken one thread at a time) gives every thread the single-threaded contributions,
    bit for bit."""
    import threading

    bounces, tx, rx, rot = renders
    want = [element_pair_po(b, tx, rx, rot, LAMBDA, "tr38901")[0] for b in bounces]
    wrong = []

    def work(seed):
        rng = np.random.default_rng(seed)
        for _ in range(12):
            k = int(rng.integers(len(bounces)))
            if not np.array_equal(element_pair_po(bounces[k], tx, rx, rot, LAMBDA, "tr38901")[0], want[k]):
                wrong.append(k)

    threads = [threading.Thread(target=work, args=(seed,)) for seed in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert wrong == []
