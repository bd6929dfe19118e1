"""Animation directories (layout: :mod:`sionnafmcw.animation`): loading, checks with clear errors, geometry queries, PLY I/O."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from animation_helpers import METAL, box_mesh, plate_mesh, write_moving_mesh_animation, write_plate_animation
from sionnafmcw.animation import (
    AnimationError,
    load_animation,
    frame_xml_text,
    parse_frame_xml,
    ply_bytes,
    read_ply,
    write_animation,
    write_frame_xml,
    write_ply,
)


@pytest.fixture
def plate_dir(tmp_path):
    return write_plate_animation(tmp_path / "plate", distance=5.0, velocity=(1.0, 0.0, 0.0), num_frames=3, fps=10.0)


def _manifest(root):
    return json.loads((root / "animation.json").read_text())


def _write_manifest(root, data):
    (root / "animation.json").write_text(json.dumps(data))


# ------------------------------------------------------------------------------- happy path
def test_load_plate_animation(plate_dir):
    anim = load_animation(plate_dir)
    assert anim.num_frames == 3 and len(anim) == 3
    assert anim.fps == 10.0 and anim.frame_period == pytest.approx(0.1)
    np.testing.assert_allclose(anim.times, [0.0, 0.1, 0.2])
    assert anim.object_names == ["plate"]
    np.testing.assert_array_equal(anim.radar_pose.position, [0, 0, 0])
    np.testing.assert_array_equal(anim.radar_pose.orientation, [0, 0, 0])
    f1 = anim.frames[1]
    assert f1.index == 1 and f1.time == pytest.approx(0.1) and f1.xml.name == "0001.xml"
    np.testing.assert_array_equal(f1.objects["plate"], [1.0, 0.0, 0.0])
    for i in range(3):
        np.testing.assert_allclose(anim.object_positions(i)["plate"], [5.0 + 0.1 * i, 0, 0], atol=1e-6)
    assert anim.vertex_velocities(0, "plate") is None
    # loading the manifest path itself works too
    assert load_animation(plate_dir / "animation.json").num_frames == 3


def test_object_positions_apply_xml_transform_like_mitsuba(tmp_path):
    import mitsuba as mi

    import sionnafmcw.materials  # noqa: F401  (variant + plugins)

    root = tmp_path / "tr"
    (root / "frames").mkdir(parents=True)
    v, f = box_mesh((0.2, 0.0, 0.1), (0.4, 0.6, 1.8))
    write_ply(root / "meshes" / "box.ply", v, f)
    ops = [("scale", {"value": "1.5"}), ("rotate", {"z": "1", "angle": "30"}),
           ("translate", {"x": "3", "y": "1", "z": "0.5"}), ("rotate", {"value": "1 1 0", "angle": "10"})]
    xml = frame_xml_text([{"name": "box", "ply": "../meshes/box.ply", "material": "mat-itu_metal", "to_world": ops}], METAL)
    (root / "frames" / "0000.xml").write_text(xml)
    write_animation(root, [{"xml": "frames/0000.xml", "objects": {"box": [0, 0, 0]}}], fps=24.0,
                    radar_pose=([0, 0, 0], [0, 0, 0]))
    anim = load_animation(root)
    mesh = anim.mesh(0, "box")
    scene = mi.load_file(str(root / "frames" / "0000.xml"))
    loaded = np.array(mi.traverse(scene)["mesh-box.vertex_positions"]).reshape(-1, 3)
    np.testing.assert_allclose(mesh.vertices, loaded, atol=1e-5)
    tri = loaded[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    expected = (tri.mean(axis=1) * area[:, None]).sum(0) / area.sum()
    np.testing.assert_allclose(anim.object_positions(0)["box"], expected, atol=1e-5)


@pytest.mark.parametrize("binary", [True, False])
def test_ply_roundtrip_with_vertex_velocity(tmp_path, binary):
    v, f = plate_mesh((1.0, 2.0, 3.0), size=(0.5, 0.7), subdiv=3)
    vel = np.random.default_rng(0).normal(size=v.shape)
    path = write_ply(tmp_path / "m.ply", v, f, vertex_velocities=vel, binary=binary)
    ply = read_ply(path)
    np.testing.assert_allclose(ply.vertices, v, rtol=1e-6)
    np.testing.assert_array_equal(ply.faces, f)
    np.testing.assert_allclose(ply.vertex_velocities, vel, rtol=1e-6)


def test_vertex_velocities_and_quads(tmp_path):
    # ASCII PLY with a quad face and a separate "velocity" element
    text = """ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
element velocity 4
property float vx
property float vy
property float vz
end_header
0 0 0
1 0 0
1 1 0
0 1 0
4 0 1 2 3
1 0 0
2 0 0
3 0 0
4 0 0
"""
    (tmp_path / "q.ply").write_text(text)
    ply = read_ply(tmp_path / "q.ply")
    np.testing.assert_array_equal(ply.faces, [[0, 1, 2], [0, 2, 3]])
    np.testing.assert_array_equal(ply.vertex_velocities[:, 0], [1, 2, 3, 4])


def test_rotating_mesh_vertex_velocities(tmp_path):
    omega = np.array([0.0, 0.0, 2.0])

    def vel(t, v):
        return np.cross(omega, v - np.array([3.0, 0.0, 0.0]))

    root = write_moving_mesh_animation(tmp_path / "rot", lambda t: plate_mesh((3.0, 0.5, 0.0), size=(1.0, 0.2), subdiv=2),
                                       (0, 0, 0), num_frames=2, vertex_velocity_fn=vel, manifest_velocity=False)
    anim = load_animation(root)
    assert anim.object_names == []
    vv = anim.vertex_velocities(1, "plate")
    v = anim.mesh(1, "plate").vertices
    np.testing.assert_allclose(vv, vel(0, v), atol=1e-5)


# ------------------------------------------------------------------------------- errors
def test_missing_manifest(tmp_path):
    with pytest.raises(AnimationError, match="animation.json"):
        load_animation(tmp_path)


def test_invalid_json(plate_dir):
    (plate_dir / "animation.json").write_text("{not json")
    with pytest.raises(AnimationError, match=r"animation\.json: invalid JSON"):
        load_animation(plate_dir)


def test_wrong_format(plate_dir):
    m = _manifest(plate_dir)
    m["format"] = "sionnafmcw-animation/0"
    _write_manifest(plate_dir, m)
    with pytest.raises(AnimationError, match=r"animation\.json: field 'format'"):
        load_animation(plate_dir)


@pytest.mark.parametrize("fps", [0, -24, "24", None])
def test_bad_fps(plate_dir, fps):
    m = _manifest(plate_dir)
    m["fps"] = fps
    _write_manifest(plate_dir, m)
    with pytest.raises(AnimationError, match="field 'fps'"):
        load_animation(plate_dir)


def test_frames_out_of_order(plate_dir):
    m = _manifest(plate_dir)
    m["frames"][0], m["frames"][1] = m["frames"][1], m["frames"][0]
    _write_manifest(plate_dir, m)
    with pytest.raises(AnimationError, match=r"frames\[0\]\.index is 1, expected 0"):
        load_animation(plate_dir)


def test_time_inconsistent_with_fps(plate_dir):
    m = _manifest(plate_dir)
    m["frames"][2]["time"] = 0.2 + 2e-6
    _write_manifest(plate_dir, m)
    with pytest.raises(AnimationError, match=r"frames\[2\]\.time"):
        load_animation(plate_dir)
    m["frames"][2]["time"] = 0.2 + 5e-7  # inside the 1e-6 s tolerance
    _write_manifest(plate_dir, m)
    load_animation(plate_dir)


def test_missing_frame_xml(plate_dir):
    (plate_dir / "frames" / "0001.xml").unlink()
    with pytest.raises(AnimationError, match=r"frames\[1\]\.xml.*0001\.xml"):
        load_animation(plate_dir)


def test_malformed_frame_xml(plate_dir):
    (plate_dir / "frames" / "0002.xml").write_text("<scene><shape></scene>")
    with pytest.raises(AnimationError, match=r"0002\.xml: malformed XML"):
        load_animation(plate_dir)


def test_missing_mesh_file(plate_dir):
    (plate_dir / "meshes" / "plate_0001.ply").unlink()
    with pytest.raises(AnimationError, match=r"0001\.xml: shape 'mesh-plate': mesh file"):
        load_animation(plate_dir)


@pytest.mark.parametrize("materials, message", [
    ({"mat-itu_metal": ("itu-radio-material", {"type": "unobtainium"})}, "type 'unobtainium' is unknown"),
    ({"mat-itu_metal": ("radio-material", {"thickness": 0.1})}, "neither relative_permittivity nor conductivity"),
    ({"mat-itu_metal": ("diffuse", {})}, "not a radio material"),
    ({"mat-itu_metal": ("radio-material", {"relative_permittivity": 0.5})}, "out of range"),
])
def test_unknown_radio_material(tmp_path, materials, message):
    # note: an id "mat-itu_<x>" of any type is an ITU material for Sionna; use another id
    mats = {k.replace("itu_metal", "plate-material"): val for k, val in materials.items()}
    root = write_plate_animation(tmp_path / "m", materials=mats, material="mat-plate-material")
    with pytest.raises(AnimationError, match=rf"0000\.xml: shape 'mesh-plate': .*{message}"):
        load_animation(root)


def test_itu_naming_convention_unknown_type(tmp_path):
    root = write_plate_animation(tmp_path / "m", materials={"mat-itu_granite": ("diffuse", {})},
                                 material="mat-itu_granite")
    with pytest.raises(AnimationError, match="ITU type 'granite' is unknown"):
        load_animation(root)


def test_known_custom_radio_material_and_skin_plugin(tmp_path):
    mats = {"mat-skin": ("radio-material", {}), "mat-skin-wet": ("skin-radio-material", {"tissue": "wet"})}
    root = write_plate_animation(tmp_path / "m", materials=mats, material="mat-skin")
    anim = load_animation(root)
    assert anim.frame_xml(0).shapes["plate"].material.custom == "skin"
    mats["mat-skin-wet"] = ("skin-radio-material", {"tissue": "soggy"})
    root = write_plate_animation(tmp_path / "n", materials=mats, material="mat-skin-wet")
    with pytest.raises(AnimationError, match="tissue 'soggy'"):
        load_animation(root)


def test_shape_without_material(plate_dir):
    xml = plate_dir / "frames" / "0000.xml"
    xml.write_text(xml.read_text().replace('<ref id="mat-itu_metal"/>', ""))
    with pytest.raises(AnimationError, match=r"0000\.xml: shape 'mesh-plate': no radio material"):
        load_animation(plate_dir)


def test_material_name_clashes_with_object(tmp_path):
    root = write_plate_animation(tmp_path / "m", materials={"mat-plate": ("itu-radio-material", {"type": "metal"})},
                                 material="mat-plate")
    with pytest.raises(AnimationError, match=r"object name\(s\) \['plate'\] are also material names"):
        load_animation(root)


def test_non_finite_object_velocity(plate_dir):
    m = _manifest(plate_dir)
    m["frames"][1]["objects"]["plate"]["velocity"] = [float("nan"), 0.0, 0.0]
    (plate_dir / "animation.json").write_text(json.dumps(m))  # json writes NaN
    with pytest.raises(AnimationError, match=r"frames\[1\]\.objects\['plate'\]\.velocity contains non-finite"):
        load_animation(plate_dir)


def test_bad_velocity_shape(plate_dir):
    m = _manifest(plate_dir)
    m["frames"][0]["objects"]["plate"]["velocity"] = [1.0, 0.0]
    _write_manifest(plate_dir, m)
    with pytest.raises(AnimationError, match=r"frames\[0\]\.objects\['plate'\]\.velocity must be 3 numbers"):
        load_animation(plate_dir)


def test_velocity_for_object_without_mesh(plate_dir):
    m = _manifest(plate_dir)
    m["frames"][2]["objects"]["ghost"] = {"velocity": [0.0, 1.0, 0.0]}
    _write_manifest(plate_dir, m)
    with pytest.raises(AnimationError, match=r"frames\[2\]\.objects\['ghost'\] .* no shape 'mesh-ghost'"):
        load_animation(plate_dir)


def test_bad_radar_pose(plate_dir):
    m = _manifest(plate_dir)
    m["radar"]["orientation"] = [0.0, "up", 0.0]
    _write_manifest(plate_dir, m)
    with pytest.raises(AnimationError, match="radar.orientation"):
        load_animation(plate_dir)


def test_non_finite_vertex_velocity(tmp_path):
    def vel(t, v):
        out = np.zeros_like(v)
        out[2, 1] = np.inf
        return out

    root = write_plate_animation(tmp_path / "m", vertex_velocity_fn=vel)
    with pytest.raises(AnimationError, match=r"plate_0000\.ply: non-finite vertex velocity .* vertex 2"):
        load_animation(root)


def _velocity_element_ply(path, n_vertices, n_velocities, props=("vx", "vy", "vz")):
    lines = ["ply", "format ascii 1.0", f"element vertex {n_vertices}", "property float x", "property float y",
             "property float z", "element face 1", "property list uchar int vertex_indices",
             f"element velocity {n_velocities}"] + [f"property float {p}" for p in props] + ["end_header"]
    lines += ["5 -0.5 -0.5", "5 0.5 -0.5", "5 0.5 0.5", "5 -0.5 0.5"][:n_vertices]
    lines += ["3 0 1 2"]
    lines += [" ".join(["1"] * len(props))] * n_velocities
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("n_velocities, props, message", [
    (3, ("vx", "vy", "vz"), r"3 vertex velocities \(element 'velocity', vx/vy/vz\) for 4 vertices"),
    (4, ("vx", "vy"), r"element 'velocity' has vertex velocity properties \['vx', 'vy'\]; vx, vy and vz are all needed"),
])
def test_ply_velocity_count_mismatch(plate_dir, n_velocities, props, message):
    _velocity_element_ply(plate_dir / "meshes" / "plate_0001.ply", 4, n_velocities, props)
    with pytest.raises(AnimationError, match=rf"plate_0001\.ply: {message}"):
        load_animation(plate_dir)


def test_truncated_binary_ply(plate_dir):
    path = plate_dir / "meshes" / "plate_0002.ply"
    data = path.read_bytes()
    path.write_bytes(data[:-20])
    with pytest.raises(AnimationError, match=r"plate_0002\.ply: truncated PLY"):
        load_animation(plate_dir)


def test_not_a_ply(plate_dir):
    (plate_dir / "meshes" / "plate_0000.ply").write_text("solid stl\n")
    with pytest.raises(AnimationError, match=r"plate_0000\.ply: not a PLY file"):
        load_animation(plate_dir)


def test_frame_xml_is_reparsed_per_frame_and_shared_meshes(tmp_path):
    """Frames may share one PLY (static meshes); the loader reads it once."""
    fv, ff = plate_mesh((0, 0, -1), size=(4, 4), normal_axis=2)
    root = write_plate_animation(tmp_path / "s", static=[("floor", fv, ff, "mat-itu_metal")])
    anim = load_animation(root)
    assert set(anim.frame_xml(0).shapes) == {"plate", "floor"}
    assert anim.frame_xml(0).shapes["floor"].filename == anim.frame_xml(2).shapes["floor"].filename
    np.testing.assert_allclose(anim.object_positions(1, names=["floor"])["floor"], [0, 0, -1], atol=1e-6)
    # a frame XML can be parsed on its own
    assert set(parse_frame_xml(anim.frames[0].xml).shapes) == {"plate", "floor"}
    shutil.rmtree(root / "meshes")
    with pytest.raises(AnimationError, match="mesh file"):
        load_animation(root)


def test_check_frequency_names_material_and_range(tmp_path):
    from sionnafmcw.materials import MaterialFrequencyError

    fv, ff = plate_mesh((0, 0, -1), size=(4, 4), normal_axis=2)
    mats = dict(METAL, **{"mat-itu_brick": ("itu-radio-material", {"type": "brick"})})
    root = write_plate_animation(tmp_path / "b", materials=mats, static=[("wall", fv, ff, "mat-itu_brick")])
    anim = load_animation(root)
    anim.check_frequency(24e9)  # brick is fine at 24 GHz
    with pytest.raises(MaterialFrequencyError, match=r"shape 'mesh-wall'.*'brick' is not defined at 77 GHz.*1-40 GHz, 110-330 GHz"):
        anim.check_frequency(77e9)


def test_frame_xml_writer_escapes_names_and_reads_back(tmp_path):
    """Object, material and file names with XML's special characters survive the writer and the parser."""
    v, f = box_mesh((0.0, 0.0, 0.0), (0.2, 0.2, 0.2))
    write_ply(tmp_path / "meshes" / 'a&b "c".ply', v, f)
    materials = {'mat-x<&>"y"': ("radio-material", {"relative_permittivity": 5.5, "conductivity": 0.1,
                                                      "scattering_coefficient": 0.3})}
    shapes = [{"name": 'box <1> & "2"', "ply": '../meshes/a&b "c".ply', "material": 'mat-x<&>"y"'}]
    xml = write_frame_xml(tmp_path / "frames" / "0000.xml", shapes, materials)
    parsed = parse_frame_xml(xml)
    assert set(parsed.shapes) == {'box <1> & "2"'}
    shape = parsed.shapes['box <1> & "2"']
    assert shape.filename == (tmp_path / "meshes" / 'a&b "c".ply').resolve()
    assert shape.material.id == 'mat-x<&>"y"'
    assert frame_xml_text(shapes, materials) == xml.read_text()


def test_ply_bytes_is_what_write_ply_writes(tmp_path):
    v, f = box_mesh((1.0, 2.0, 3.0), (0.3, 0.4, 0.5))
    vel = np.tile([0.5, -1.0, 0.25], (len(v), 1))
    for binary in (True, False):
        path = write_ply(tmp_path / f"box_{binary}.ply", v, f, vel, binary=binary)
        assert path.read_bytes() == ply_bytes(v, f, vel, binary=binary)
        ply = read_ply(path)
        np.testing.assert_array_equal(ply.vertices, v.astype(np.float32))
        np.testing.assert_array_equal(ply.faces, f)
        np.testing.assert_array_equal(ply.vertex_velocities, vel.astype(np.float32))
    with pytest.raises(ValueError, match="2 vertex velocities for 8 vertices"):
        ply_bytes(v, f, vel[:2])


def test_animation_package_needs_only_numpy():
    """The package and the animation writers import without Sionna, Dr.Jit, finufft or matplotlib
    (the Blender exporter imports them in an environment that has none of these)."""
    import subprocess
    import sys

    code = ("import sys, sionnafmcw, sionnafmcw.animation, sionnafmcw.fs\n"
            "heavy = ('drjit', 'mitsuba', 'sionna', 'finufft', 'matplotlib', 'zarr', 'xarray', 'scipy')\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


# ------------------------------------------------------------------------------- rigid objects
def _spin(axis, angle):
    """Rotation of ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def _rigid_box_animation(root, num_frames=4, fps=10.0, omega=(0.4, -0.3, 2.0), velocity=(0.5, -0.2, 0.1)):
    """A metal box turning at the constant ``omega`` (rad/s) while its centroid moves at ``velocity``,
    written as a rigid object: one PLY in its own frame and a to_world per frame."""
    from sionnafmcw.animation.rigid import transform_matrix
    from sionnafmcw.scenes.writer import METAL as METAL_ID
    from sionnafmcw.scenes.writer import AnimationWriter, metal_material

    v_local, faces = box_mesh((0.0, 0.0, 0.0), (0.4, 0.2, 0.3))
    omega, velocity = np.asarray(omega, float), np.asarray(velocity, float)
    w = AnimationWriter(root, fps)
    w.add_materials(metal_material())
    w.rigid("box", v_local, faces, METAL_ID)
    truth = []
    for i in range(num_frames):
        t = i / fps
        r = _spin(omega, np.linalg.norm(omega) * t)
        p = np.array([4.0, 0.5, 1.0]) + velocity * t   # the local centroid is the origin: p is the centroid
        w.frame(rigid={"box": {"to_world": transform_matrix(r, p), "velocity": velocity, "angular_velocity": omega}})
        truth.append((r, p))
    w.finish((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    return root, v_local, faces, omega, velocity, truth


def test_rigid_object_is_written_once_and_moves_exactly(tmp_path):
    root, v_local, faces, omega, velocity, truth = _rigid_box_animation(tmp_path / "rigid")
    assert sorted(p.name for p in (root / "meshes").iterdir()) == ["box.ply"]
    anim = load_animation(root)
    assert anim.object_names == ["box"]
    for i, (r, p) in enumerate(truth):
        mesh = anim.mesh(i, "box")
        np.testing.assert_allclose(mesh.vertices, v_local @ r.T + p, atol=1e-6)      # float32 PLY
        motion = anim.motion(i, "box")
        np.testing.assert_allclose(motion.rotation, r, atol=1e-12)                   # repr floats in the XML
        np.testing.assert_allclose(motion.angular_velocity, omega)
        np.testing.assert_allclose(motion.centroid, p, atol=1e-6)
        np.testing.assert_allclose(anim.object_positions(i)["box"], p, atol=1e-6)
        # v = v_c + omega x (x - c) at every vertex: the time derivative of R(t) x_L + p(t)
        np.testing.assert_allclose(mesh.vertex_velocities, velocity + np.cross(omega, mesh.vertices - p), atol=1e-9)
        h = 1e-6
        t = anim.times[i]
        numeric = (v_local @ (_spin(omega, np.linalg.norm(omega) * (t + h)).T - _spin(omega, np.linalg.norm(omega)
                   * (t - h)).T)) / (2 * h) + velocity
        np.testing.assert_allclose(mesh.vertex_velocities, numeric, atol=1e-6)
        assert np.array_equal(anim.frame(i).transforms["box"], anim.frame_xml(i).shapes["box"].to_world)


def test_rigid_manifest_errors_name_the_field(tmp_path):
    root = _rigid_box_animation(tmp_path / "rigid")[0]
    data = _manifest(root)
    data["frames"][1]["objects"]["box"]["to_world"][3] += 1e-3
    _write_manifest(root, data)
    with pytest.raises(AnimationError, match=r"frames\[1\]\.objects\['box'\]\.to_world differs .*0001\.xml"):
        load_animation(root)
    data["frames"][1]["objects"]["box"]["to_world"][3] -= 1e-3
    data["frames"][2]["objects"]["box"]["angular_velocity"] = [0.0, float("nan"), 0.0]
    _write_manifest(root, data)
    with pytest.raises(AnimationError, match=r"frames\[2\]\.objects\['box'\]\.angular_velocity contains non-finite"):
        load_animation(root)
    data["frames"][2]["objects"]["box"]["angular_velocity"] = [0.0, 0.0, 1.0]
    data["frames"][0]["objects"]["box"]["spin"] = 1.0
    _write_manifest(root, data)
    with pytest.raises(AnimationError, match=r"frames\[0\]\.objects\['box'\] has unknown field\(s\) spin"):
        load_animation(root)


def test_angular_velocity_and_vertex_velocities_conflict(tmp_path):
    root = write_moving_mesh_animation(tmp_path / "m", lambda i: plate_mesh((3.0, 0.0, 0.0)), (1.0, 0.0, 0.0),
                                       vertex_velocity_fn=lambda i, v: np.tile([1.0, 0.0, 0.0], (len(v), 1)))
    data = _manifest(root)
    data["frames"][0]["objects"]["plate"]["angular_velocity"] = [0.0, 0.0, 1.0]
    _write_manifest(root, data)
    with pytest.raises(AnimationError, match=r"frames\[0\]\.objects\['plate'\] has an angular_velocity and its mesh "
                                             r".* carries per-vertex velocities"):
        load_animation(root)


def test_writer_refuses_a_frame_without_every_rigid_transform(tmp_path):
    from sionnafmcw.scenes.writer import METAL as METAL_ID
    from sionnafmcw.scenes.writer import AnimationWriter, metal_material

    w = AnimationWriter(tmp_path / "w", 10.0)
    w.add_materials(metal_material())
    w.rigid("box", *box_mesh((0, 0, 0), (1, 1, 1)), METAL_ID)
    with pytest.raises(ValueError, match=r"rigid objects without a transform in frame 0: \['box'\]"):
        w.frame()
    with pytest.raises(ValueError, match="must be a 4x4 proper rotation"):
        w.frame(rigid={"box": {"to_world": np.diag([2.0, 1.0, 1.0, 1.0]), "velocity": np.zeros(3)}})


@pytest.mark.parametrize("angle", [1e-9, 1e-4, 0.3, 2.0, np.pi - 1e-6])
def test_rotation_vector_inverts_rodrigues(angle):
    from sionnafmcw.animation.rigid import rotation_vector

    axis = np.array([0.2, -0.7, 0.4])
    axis /= np.linalg.norm(axis)
    np.testing.assert_allclose(rotation_vector(_spin(axis, angle)), angle * axis, atol=1e-12 + 1e-9 * angle)


def test_angular_velocity_of_a_constant_rate_and_rigid_fit():
    from sionnafmcw.animation.rigid import angular_velocity, rigid_fit

    omega = np.array([0.3, 1.2, -0.5])
    rate = np.linalg.norm(omega)
    # a constant rate about a fixed axis: the central difference is exact
    np.testing.assert_allclose(angular_velocity(_spin(omega, rate * 0.52), _spin(omega, rate * 0.48), 0.04), omega,
                               rtol=1e-9)
    rng = np.random.default_rng(3)
    x = rng.normal(size=(50, 3))
    r, p = _spin(omega, 0.7), np.array([1.0, -2.0, 0.5])
    fit_r, fit_p, residual = rigid_fit(x, x @ r.T + p)
    np.testing.assert_allclose(fit_r, r, atol=1e-12)
    np.testing.assert_allclose(fit_p, p, atol=1e-12)
    assert residual < 1e-12
    bent = x @ r.T + p
    bent[0] += [0.0, 0.0, 1e-3]   # one vertex off by 1 mm: not a rigid motion
    assert rigid_fit(x, bent)[2] > 5e-4
