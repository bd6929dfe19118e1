"""The figures of :mod:`sionnafmcw.plots`: axis labels and units, limits, colour scales, truth markers
where they belong, and the scene top view (equal aspect, tracks, radar and field of view).

No ray tracing: maps come from analytic point targets or hand-made arrays, scenes from the
animation helpers.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402
from matplotlib.patches import Wedge  # noqa: E402

from animation_helpers import box_mesh, write_plate_animation  # noqa: E402
from sionnafmcw import RadarConfig, plots  # noqa: E402
from sionnafmcw.animation import load_animation  # noqa: E402
from sionnafmcw.processing import (DopplerTrack, MicroDopplerSpectrogram, RangeAzimuthMap,  # noqa: E402
                                   RangeDopplerMap)


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def truth_lines(ax):
    return [line for line in ax.get_lines() if line.get_marker() == "*"]


def mesh_of(ax):
    meshes = [c for c in ax.collections if hasattr(c, "get_clim") and c.get_array() is not None]
    assert len(meshes) == 1
    return meshes[0]


# ============================================================================ range-Doppler / azimuth
def test_range_doppler_axes_scale_and_truth():
    ranges = np.linspace(0, 10, 41)
    velocities = np.linspace(-5, 5, 32, endpoint=False)
    power = np.full((32, 41), 1e-12)
    power[20, 12] = 1e-6  # 60 dB above the floor
    ax = plots.plot_range_doppler(RangeDopplerMap(power, ranges, velocities), dynamic_range=30.0,
                                  truth=[(3.0, 1.25), (7.5, -2.0)])
    assert ax.get_xlabel() == "radial velocity (m/s, + receding)"
    assert ax.get_ylabel() == "range (m)"
    assert mesh_of(ax).get_clim() == pytest.approx((-90.0, -60.0))
    assert ax.get_xlim()[0] <= velocities[0] and ax.get_xlim()[1] >= velocities[-1]
    assert ax.get_ylim()[1] >= ranges[-1]
    (stars,) = truth_lines(ax)
    np.testing.assert_allclose(stars.get_xdata(), [1.25, -2.0])  # velocity across
    np.testing.assert_allclose(stars.get_ydata(), [3.0, 7.5])   # range up
    assert stars.get_markeredgecolor() == "red"
    assert ax.figure.axes[1].get_ylabel() == "power (dB W)"


def test_range_doppler_without_truth_has_no_markers():
    rd = RangeDopplerMap(np.ones((4, 5)), np.arange(5.0), np.arange(4.0) - 2)
    ax = plots.plot_range_doppler(rd)
    assert truth_lines(ax) == [] and ax.get_legend() is None


@pytest.fixture
def ramap():
    ranges = np.linspace(0, 10, 51)
    azimuths = np.deg2rad(np.linspace(-80, 80, 81))
    power = np.full((51, 81), 1e-10)
    power[15, 50] = 1e-5
    return RangeAzimuthMap(power, ranges, azimuths)


def test_range_azimuth_in_degrees(ramap):
    ax = plots.plot_range_azimuth(ramap, truth=[(3.0, np.deg2rad(20.0))], dynamic_range=40.0)
    assert ax.get_xlabel().startswith("azimuth (deg")
    assert ax.get_ylabel() == "range (m)"
    assert ax.get_xlim()[0] <= -80 and ax.get_xlim()[1] >= 80  # degrees, not radians
    (stars,) = truth_lines(ax)
    np.testing.assert_allclose(stars.get_xdata(), [20.0])
    np.testing.assert_allclose(stars.get_ydata(), [3.0])
    assert mesh_of(ax).get_clim() == pytest.approx((-90.0, -50.0))


def test_range_azimuth_transposed_power_is_accepted(ramap):
    ax = plots.plot_range_azimuth(RangeAzimuthMap(ramap.power.T, ramap.ranges, ramap.azimuths))
    assert mesh_of(ax).get_array().shape == (51, 81)


def test_range_azimuth_cartesian_is_a_top_view(ramap):
    az = np.deg2rad(30.0)
    ax = plots.plot_range_azimuth(ramap, truth=[(4.0, az)], cartesian=True, max_range=6.0)
    assert ax.get_aspect() == 1.0
    assert ax.get_xlabel().startswith("cross-range y (m")
    assert ax.get_ylabel().startswith("down-range x (m")
    x0, x1 = ax.get_xlim()
    assert x0 > 0 > x1  # +y (positive azimuth) to the left, as seen from above
    assert ax.get_ylim()[0] == 0.0 and 6.0 <= ax.get_ylim()[1] <= 6.2  # cropped at max_range (+ half a cell)
    (stars,) = truth_lines(ax)
    np.testing.assert_allclose(stars.get_xdata(), [4.0 * np.sin(az)])
    np.testing.assert_allclose(stars.get_ydata(), [4.0 * np.cos(az)])
    assert mesh_of(ax).get_array().shape == (31, 81)  # ranges <= 6 m kept


# ============================================================================ Doppler-time
def test_doppler_time_track_form_with_objects():
    times = np.arange(5) / 24.0
    track = DopplerTrack(np.array([1.0, 1.1, 0.9, 1.0, 1.05]), np.full(5, 3.0), np.ones(5))
    truth = np.stack([np.full(5, 1.0), np.full(5, -2.0)], axis=1)  # [frame, object]
    ax = plots.plot_doppler_time(track, times=times, truth=truth, object_names=["torso", "arm"],
                                 velocity_limits=(-9.0, 9.0))
    assert ax.get_xlabel() == "time (s)"
    assert ax.get_ylabel() == "radial velocity (m/s, + receding)"
    assert ax.get_ylim() == (-9.0, 9.0)
    stars = truth_lines(ax)
    assert [s.get_label() for s in stars] == ["ground truth: torso", "ground truth: arm"]
    assert all(s.get_color() == "red" for s in stars)
    np.testing.assert_allclose(stars[1].get_ydata(), -2.0)
    np.testing.assert_allclose(stars[0].get_xdata(), times)
    (estimate,) = [line for line in ax.get_lines() if line.get_marker() == "."]
    np.testing.assert_allclose(estimate.get_ydata(), track.velocities)
    assert {t.get_text() for t in ax.get_legend().get_texts()} == {"estimate (strongest cell)",
                                                                    "ground truth: torso", "ground truth: arm"}


def test_doppler_time_array_form_matches_the_track_form():
    times = np.arange(4) * 0.1
    v = np.array([0.5, 0.6, 0.7, 0.8])
    a = plots.plot_doppler_time(times, v, truth_times=times + 0.01, truth_velocities=v + 0.02)
    b = plots.plot_doppler_time(DopplerTrack(v, v, v), times, truth=(times + 0.01, v + 0.02))
    for ax in (a, b):
        (stars,) = truth_lines(ax)
        np.testing.assert_allclose(stars.get_xdata(), times + 0.01)
        np.testing.assert_allclose(stars.get_ydata(), v + 0.02)


def test_doppler_time_small_spread_is_not_magnified():
    track = DopplerTrack(np.array([-1.5045, -1.5044, -1.5046]), np.zeros(3), np.ones(3))
    ax = plots.plot_doppler_time(track, times=[0.0, 0.04, 0.08], truth=[-1.5, -1.5, -1.5])
    low, high = ax.get_ylim()
    assert high - low >= 1.0  # a 5 mm/s bias must not fill the whole axis
    assert low < -1.5045 and high > -1.5


def test_doppler_time_without_times_uses_frame_index():
    ax = plots.plot_doppler_time(DopplerTrack(np.zeros(3), np.zeros(3), np.ones(3)))
    assert ax.get_xlabel() == "frame"


# ============================================================================ micro-Doppler
@pytest.fixture
def spectrogram():
    # two CPIs of 4 columns, 1 ms apart, 40 ms between CPI starts
    times = np.concatenate([np.arange(4) * 1e-3, 0.04 + np.arange(4) * 1e-3])
    velocities = np.linspace(-4, 4, 16, endpoint=False)
    power = np.full((16, 8), 1e-9)
    power[10, :] = 1e-4
    return MicroDopplerSpectrogram(times, velocities, power)


def test_micro_doppler_axes_gaps_and_truth(spectrogram):
    ax = plots.plot_micro_doppler(spectrogram, dynamic_range=30.0, truth=[1.0, 1.0], truth_times=[0.0, 0.04],
                                  object_names=["plate"])
    assert ax.get_xlabel() == "time (s)"
    assert ax.get_ylabel() == "radial velocity (m/s, + receding)"
    mesh = mesh_of(ax)
    assert mesh.get_clim() == pytest.approx((-70.0, -40.0))
    data = mesh.get_array()
    assert data.shape == (16, 10)  # two blank columns in the gap between the CPIs
    assert int(np.ma.getmaskarray(data).all(axis=0).sum()) == 2
    assert ax.get_xlim()[1] < 0.05  # seconds, not frames or milliseconds
    (stars,) = truth_lines(ax)
    np.testing.assert_allclose(stars.get_xdata(), [0.0, 0.04])
    np.testing.assert_allclose(stars.get_ydata(), [1.0, 1.0])
    assert stars.get_label() == "ground truth: plate"
    assert ax.figure.axes[1].get_ylabel() == "power (dB W)"


def test_micro_doppler_truth_needs_times(spectrogram):
    with pytest.raises(ValueError, match="truth_times"):
        plots.plot_micro_doppler(spectrogram, truth=[1.0, 1.0])


def test_with_gaps_leaves_uniform_time_alone():
    t = np.arange(6) * 1e-3
    p = np.ones((3, 6))
    t2, p2 = plots._with_gaps(t, p)
    assert t2 is t and p2 is p


# ============================================================================ scene top view
@pytest.fixture(scope="module")
def room_scene(tmp_path_factory):
    """A 6 x 5 m room (floor + three walls + a table) and a plate moving (1, 0.5) m/s, 6 frames at 4 fps."""
    metal = "mat-itu_metal"
    static = [("floor", *box_mesh([2.5, 0, -0.05], [6, 5, 0.1]), metal),
              ("wall_north", *box_mesh([2.5, 2.5, 1.5], [6, 0.1, 3]), metal),
              ("wall_south", *box_mesh([2.5, -2.5, 1.5], [6, 0.1, 3]), metal),
              ("wall_east", *box_mesh([5.5, 0, 1.5], [0.1, 5, 3]), metal),
              ("table", *box_mesh([3.5, 1.5, 0.4], [1.0, 0.6, 0.8]), metal)]
    root = tmp_path_factory.mktemp("room") / "scene"
    return write_plate_animation(root, distance=2.0, velocity=(1.0, 0.5, 0.0), num_frames=6, fps=4.0,
                                 size=(0.5, 0.5), static=static, radar_pose=((-0.4, 0.0, 1.0), (0.0, 0.0, 0.0)))


def test_scene_top_view_geometry(room_scene):
    anim = load_animation(room_scene)
    radar = RadarConfig.preset("walk-77ghz")
    ax = plots.plot_scene_top_view(anim, radar=radar, fov=np.deg2rad(100.0))
    assert ax.get_aspect() == 1.0
    assert ax.get_xlabel() == "x (m, world)" and ax.get_ylabel() == "y (m, world)"
    # the view holds the room (x -0.5..5.55, y -2.55..2.55) and the radar, with a small margin
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    assert x0 < -0.5 and x1 > 5.55 and y0 < -2.55 and y1 > 2.55
    assert x1 - x0 < 8.0 and y1 - y0 < 7.0
    # walls as segments, floor and table top as fills
    walls = [c for c in ax.collections if isinstance(c, LineCollection)]
    fills = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(walls) == 1 and len(walls[0].get_segments()) > 0
    assert len(fills) == 1 and len(fills[0].get_paths()) > 0
    # the track: centroids of every frame
    (track,) = [line for line in ax.get_lines() if line.get_label().startswith("plate: centroid track")]
    expected = np.array([anim.object_positions(f)["plate"] for f in range(6)])
    np.testing.assert_allclose(track.get_xdata(), expected[:, 0])
    np.testing.assert_allclose(track.get_ydata(), expected[:, 1])
    np.testing.assert_allclose(track.get_xdata()[-1] - track.get_xdata()[0], 1.0 * 5 / 4.0, atol=1e-9)
    # radar and field of view: wedge centred on boresight (+x), out to R_max
    (wedge,) = [p for p in ax.patches if isinstance(p, Wedge)]
    assert wedge.r == pytest.approx(radar.max_range)
    assert (wedge.theta1, wedge.theta2) == pytest.approx((-50.0, 50.0))
    np.testing.assert_allclose(wedge.center, [-0.4, 0.0])
    (marker,) = [line for line in ax.get_lines() if line.get_label().startswith("radar at")]
    np.testing.assert_allclose([marker.get_xdata()[0], marker.get_ydata()[0]], [-0.4, 0.0])
    labels = [t.get_text() for t in ax.figure.legends[0].get_texts()]
    assert any("R_max = 12.5 m" in t for t in labels) and any("static meshes" in t for t in labels)


def test_scene_top_view_pose_override_frames_and_path(room_scene):
    pose = {"position": [0.0, -2.0, 1.0], "orientation": [np.pi / 4, 0.0, 0.0]}  # as stored in a run
    fig, ax = plt.subplots()
    out = plots.plot_scene_top_view(str(room_scene), radar_pose=pose, frames=[1, 2, 3], ax=ax)
    assert out is ax
    (wedge,) = [p for p in ax.patches if isinstance(p, Wedge)]
    assert (wedge.theta1, wedge.theta2) == pytest.approx((45.0 - 60.0, 45.0 + 60.0))  # default 120 degree FoV
    # without a radar config the wedge reaches the scene's far corner
    assert 6.0 < wedge.r < 8.0
    (track,) = [line for line in ax.get_lines() if line.get_label().startswith("plate")]
    assert len(track.get_xdata()) == 3 and "frames 1..3" in track.get_label()
    assert ax.get_legend() is not None  # the caller's axes: legend inside


def test_scene_top_view_objects_and_no_radar(room_scene, tmp_path):
    anim = load_animation(room_scene)
    anim.radar_pose = None
    ax = plots.plot_scene_top_view(anim, objects=[])
    assert not [p for p in ax.patches if isinstance(p, Wedge)]
    assert not [line for line in ax.get_lines() if "track" in line.get_label()]
    path = plots.save(ax, tmp_path / "sub" / "top.png")
    assert open(path, "rb").read(8) == b"\x89PNG\r\n\x1a\n"


def test_scene_top_view_rejects_empty_frames(room_scene):
    with pytest.raises(ValueError, match="frames is empty"):
        plots.plot_scene_top_view(room_scene, frames=[])


def test_scene_top_view_many_objects_highlights_the_torso(tmp_path):
    """Seven moving parts (a body): the torso in colour, the other six as one grey legend entry."""
    from animation_helpers import plate_mesh, write_moving_mesh_animation

    def part(name, y):
        return {"name": name, "velocity": (0.5, 0.0, 0.0),
                "mesh_fn": lambda t, y=y: plate_mesh([2.0 + 0.5 * t, y, 1.0], size=(0.1, 0.1))}

    names = ["torso", "head", "arm_l", "arm_r", "leg_l", "leg_r"]
    root = write_moving_mesh_animation(tmp_path / "body", part("foot", -0.6)["mesh_fn"], (0.5, 0.0, 0.0),
                                       num_frames=3, fps=10.0, name="foot",
                                       extra_objects=[part(n, 0.2 * k - 0.5) for k, n in enumerate(names)])
    ax = plots.plot_scene_top_view(root)
    labels = [t.get_text() for t in ax.figure.legends[0].get_texts()]
    assert "torso: centroid track, frames 0..2" in labels
    assert "6 other moving objects: centroid tracks" in labels
    assert not any(label.startswith("head") for label in labels)
    coloured = [line for line in ax.get_lines() if line.get_label().startswith("torso")]
    grey = [line for line in ax.get_lines() if "other moving" in line.get_label()]
    assert len(coloured) == 1 and len(grey) == 6
    ax2 = plots.plot_scene_top_view(root, highlight=["head", "foot"])
    labels2 = [t.get_text() for t in ax2.figure.legends[0].get_texts()]
    assert {"head: centroid track, frames 0..2", "foot: centroid track, frames 0..2",
            "5 other moving objects: centroid tracks"} <= set(labels2)


def test_colour_scale_starts_at_the_noise_floor():
    """With a generous dynamic range the scale starts at the 10th percentile of the cells, not 80 dB down."""
    rng = np.random.default_rng(0)
    power = rng.exponential(1e-15, size=(64, 64))  # noise around -150 dB
    power[10, 20] = 1e-11                           # a target at -110 dB
    ax = plots.plot_range_doppler(RangeDopplerMap(power, np.arange(64.0), np.arange(64.0) - 32), dynamic_range=80.0)
    low, high = mesh_of(ax).get_clim()
    assert high == pytest.approx(-110.0)
    assert low == pytest.approx(np.percentile(10 * np.log10(power), plots.FLOOR_PERCENTILE))
    assert low > -110.0 - 80.0 + 20.0


def test_doppler_time_over_a_spectrogram(spectrogram):
    """The circle_walk call form: arrays, truth, and the spectrogram in dB underneath (the micro-Doppler
    colour map, a colour bar, gaps blank), as the paper's Fig. 3 shows it."""
    times = np.array([0.0, 0.04])
    ax = plots.plot_doppler_time(times, [1.0, 1.1], truth_times=times, truth_velocities=[1.0, 1.0],
                                 spectrogram=spectrogram, title="Doppler-time", dynamic_range=30.0)
    mesh = mesh_of(ax)
    assert mesh.get_cmap().name == plots.SPECTROGRAM_CMAP != "Greys"
    low, high = mesh.get_clim()
    assert high - low <= 30.0 + 1e-9 and high == pytest.approx(np.nanmax(np.ma.filled(mesh.get_array(), np.nan)))
    colorbars = [a for a in ax.figure.axes if a is not ax]
    assert len(colorbars) == 1 and "dB" in colorbars[0].get_ylabel()
    assert int(np.ma.getmaskarray(mesh.get_array()).all(axis=0).sum()) == 2
    assert len(truth_lines(ax)) == 1
