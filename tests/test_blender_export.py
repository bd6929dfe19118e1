r"""Blender exporter end to end: a real ``bpy`` (in ``.venv-blender``) builds and exports an animated
scene; the simulator's environment loads it, checks it against the analytic keyframe motion and
simulates it.

The scene (Blender frames 1..9 at 24 fps, all keyframes LINEAR):

* ``room``: floor (material ``Concrete``, ``radio_material = "itu:concrete"``) and four walls
  (material named ``itu_plasterboard``: the naming rule) in one object -> two static shapes;
* ``radar``: an empty at :math:`\mathbf p_r` with Euler XYZ (roll, pitch, yaw) = (10, 5, 20) deg;
* ``box``: a 0.4 m metal cube (``"itu:metal"``) turned like the radar, so one face looks at it,
  whose centre moves along the boresight :math:`\hat{\mathbf u}`:
  :math:`\mathbf c(t) = \mathbf p_r + (r_0 + v t)\hat{\mathbf u}`, :math:`r_0` = 3 m, :math:`v` = 1.5 m/s;
* ``arm``: a tube (JSON radio material) bent by an armature: the vertices past the elbow follow
  the bone ``fore``, which turns about world z at :math:`\omega = 60°/(8/24\,\mathrm{s}) = \pi` rad/s,
  so :math:`\mathbf v_i = \omega\hat{\mathbf z}\times(\mathbf x_i - \mathbf e)` there and 0 elsewhere;
* ``flag``: a horizontal 0.4 m plate (``"skin"``) sheared in its own plane by a shape key whose
  value goes 0 -> 1: :math:`\mathbf v_i = \dot w\,k\,(y_i - y_{min})\hat{\mathbf x}`,
  :math:`\dot w` = 24/8 /s, :math:`k` = 0.5; the shear keeps every triangle's area, so the
  centroid moves at :math:`\dot w k (\bar y - y_{min})` = 0.3 m/s exactly;
* ``spinner``: a smooth-shaded metal icosphere turning about a fixed tilted axis
  :math:`\hat{\mathbf a}` at the constant rate :math:`\dot\theta = 90°/(8/24\,\mathrm{s})` (axis-angle
  keyframes, LINEAR): a rigid object, written once with its vertex normals and placed per frame.

``box`` and ``spinner`` are rigid (one PLY, a ``to_world`` per frame), ``arm`` and ``flag`` deform
(a PLY per frame).

Tolerances:

* geometry is exported in float32: positions to :math:`\epsilon_{32}` = 2^-24 of ~3.5 m (2e-7 m); a
  difference of two such positions over the shortest step (1/48 s) is good to ~2e-5 m/s, so
  exact motions (LINEAR keyframes) are checked to 1e-4 m/s and 1e-5 m;
* the armature's circular motion is not linear: the central difference over :math:`\pm\Delta`
  (:math:`\Delta` = half a frame) is :math:`v\,\sin(\omega\Delta)/(\omega\Delta)`, off by at most
  :math:`(\omega\Delta)^2/6\,|v|`; the one-sided difference at the ends by
  :math:`\Delta\omega^2 r/2 + \Delta^2\omega^3 r/6`;
* the simulated range and radial velocity of the box: half a range bin :math:`c/2B` and half a
  Doppler bin :math:`\lambda_{mid}/(2 L T_b)` of ``walk-77ghz``, against the keyframed motion at the
  middle of the CPI (the range FFT integrates the CPI, during which the box moves 2 cm).
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from sionnafmcw import PathEngine, RadarConfig, load_animation, processing, simulate
from sionnafmcw.animation import read_ply
from sionnafmcw.blender import BLENDER_VENV, BlenderExportError, export_blend, script_path
from sionnafmcw.geometry import radial_velocity, world_phase_centre, rotation_matrix

FPS = 24.0
FRAMES = (1, 9)
PARAMS = {
    "fps": FPS, "frame_start": FRAMES[0], "frame_end": FRAMES[1],
    "radar_position": [-2.5, -0.8, 1.1], "radar_ypr_deg": [20.0, 5.0, 10.0],
    "box_half_size": 0.2, "box_r0": 3.0, "box_speed": 1.5,
    "arm_origin": [-3.3, 2.0, 1.5], "arm_elbow": 0.3, "arm_theta1_deg": 60.0,
    "flag_location": [-3.0, -2.0, 2.4], "flag_size": 0.4, "flag_shear": 0.5,
    "spin_location": [-3.2, 2.6, 0.6], "spin_radius": 0.15, "spin_axis": [0.3, -0.2, 0.9], "spin_angle_deg": 90.0,
    "camera_euler_deg": [80.0, 0.0, -60.0], "camera_location": [1.0, 2.0, 1.5],
}
EXACT_VELOCITY_TOL = 1e-4  # m/s, float32 positions differenced over >= 1/48 s (see the module docstring)
EXACT_POSITION_TOL = 1e-5  # m, float32 positions of a ~4 m scene
BPY_TIMEOUT = 180  # s for one bpy subprocess (a few seconds when healthy)

# ------------------------------------------------------------------------------------ bpy script
BUILD_SCENE = r'''
import importlib.util, json, math, random, sys
import bpy
from mathutils import Euler, Matrix, Vector

args = sys.argv[sys.argv.index("--") + 1:]
P = json.loads(open(args[0]).read())
out = args[1]
spec = importlib.util.spec_from_file_location("sionnafmcw_export", args[2])
exporter = importlib.util.module_from_spec(spec)
spec.loader.exec_module(exporter)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps, scene.render.fps_base = int(P["fps"]), 1.0
scene.frame_start, scene.frame_end = P["frame_start"], P["frame_end"]
f0, f1 = P["frame_start"], P["frame_end"]


def material(name, radio=None):
    m = bpy.data.materials.new(name)
    if radio is not None:
        m["radio_material"] = radio
    return m


def mesh_object(name, verts, faces, mats, material_index=None, location=(0, 0, 0)):
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(v) for v in verts], [], [tuple(f) for f in faces])
    me.update()
    for m in mats:
        me.materials.append(m)
    if material_index is not None:
        me.polygons.foreach_set("material_index", material_index)
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    scene.collection.objects.link(ob)
    return ob


def make_linear(id_):
    act = id_.animation_data.action
    curves = list(act.fcurves) if hasattr(act, "fcurves") else [
        fc for layer in act.layers for strip in layer.strips for bag in strip.channelbags for fc in bag.fcurves]
    for fc in curves:
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"


cube_v = lambda a: [(x, y, z) for x in (-a, a) for y in (-a, a) for z in (-a, a)]
cube_f = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]

# room: floor (radio_material property) + walls (material named itu_plasterboard) in one object
x0, x1, y0, y1, h = -4.0, 5.0, -3.0, 3.5, 3.0
v = [(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0), (x0, y0, h), (x1, y0, h), (x1, y1, h), (x0, y1, h)]
mesh_object("room", v, [(0, 1, 2, 3), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)],
            [material("Concrete", "itu:concrete"), material("itu_plasterboard")], [0, 1, 1, 1, 1])

# radar empty: Blender Euler XYZ = (roll, pitch, yaw)
yaw, pitch, roll = (math.radians(x) for x in P["radar_ypr_deg"])
pr = Vector(P["radar_position"])
radar = bpy.data.objects.new("radar", None)
radar.location, radar.rotation_euler = pr, (roll, pitch, yaw)
scene.collection.objects.link(radar)
u = Euler((roll, pitch, yaw), "XYZ").to_matrix() @ Vector((1, 0, 0))

# metal box on the boresight, turned like the radar, moving along it
box = mesh_object("box", cube_v(P["box_half_size"]), cube_f, [material("Steel", "itu:metal")])
box.rotation_euler = (roll, pitch, yaw)
for f in (f0, f1):
    box.location = pr + (P["box_r0"] + P["box_speed"] * (f - f0) / P["fps"]) * u
    box.keyframe_insert("location", frame=f)
make_linear(box)

# arm: tube along local +x, bent at the elbow by the bone "fore" turning about world z
rings, seg, rad = 7, 8, 0.05
tv = [(0.1 * i, rad * math.cos(2 * math.pi * k / seg), rad * math.sin(2 * math.pi * k / seg))
      for i in range(rings) for k in range(seg)]
tf = [(i * seg + k, i * seg + (k + 1) % seg, (i + 1) * seg + (k + 1) % seg, (i + 1) * seg + k)
      for i in range(rings - 1) for k in range(seg)]
arm = mesh_object("arm", tv, tf, [material("Plastic", '{"relative_permittivity": 5, "conductivity": 0.1, '
                                                      '"scattering_coefficient": 0.3}')],
                  location=P["arm_origin"])
rig = bpy.data.objects.new("rig", bpy.data.armatures.new("rig"))
rig.location = P["arm_origin"]
scene.collection.objects.link(rig)
bpy.context.view_layer.objects.active = rig
bpy.ops.object.mode_set(mode="EDIT")
e = P["arm_elbow"]
upper = rig.data.edit_bones.new("upper")
upper.head, upper.tail = (0, 0, 0), (e, 0, 0)
upper.align_roll((0, 0, 1))
fore = rig.data.edit_bones.new("fore")
fore.head, fore.tail = (e, 0, 0), (2 * e, 0, 0)
fore.align_roll((0, 0, 1))
fore.parent, fore.use_connect = upper, True
bpy.ops.object.mode_set(mode="OBJECT")
bone_z = rig.data.bones["fore"].matrix_local.to_3x3() @ Vector((0, 0, 1))
assert (bone_z - Vector((0, 0, 1))).length < 1e-6, bone_z  # local z of the bone = world z
g_up, g_fore = arm.vertex_groups.new(name="upper"), arm.vertex_groups.new(name="fore")
for i, p in enumerate(tv):
    (g_up if p[0] <= e + 1e-9 else g_fore).add([i], 1.0, "REPLACE")
arm.modifiers.new("rig", "ARMATURE").object = rig
pb = rig.pose.bones["fore"]
pb.rotation_mode = "XYZ"
for f, th in ((f0, 0.0), (f1, math.radians(P["arm_theta1_deg"]))):
    pb.rotation_euler = (0.0, 0.0, th)
    pb.keyframe_insert("rotation_euler", frame=f)
make_linear(rig)

# flag: horizontal plate sheared in its plane by a shape key
n, s, k = 5, P["flag_size"], P["flag_shear"]
fv = [(-s / 2 + s * i / (n - 1), -s / 2 + s * j / (n - 1), 0.0) for j in range(n) for i in range(n)]
ff = [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i) for j in range(n - 1) for i in range(n - 1)]
flag = mesh_object("flag", fv, ff, [material("Skin", "skin")], location=P["flag_location"])
flag.shape_key_add(name="Basis")
key = flag.shape_key_add(name="shear")
for i, p in enumerate(fv):
    key.data[i].co = (p[0] + k * (p[1] + s / 2), p[1], p[2])
for f, w in ((f0, 0.0), (f1, 1.0)):
    key.value = w
    key.keyframe_insert("value", frame=f)
make_linear(flag.data.shape_keys)

# spinner: a smooth-shaded icosphere turning about a fixed axis at a constant rate (a rigid object)
import bmesh
bm = bmesh.new()
bmesh.ops.create_icosphere(bm, subdivisions=2, radius=P["spin_radius"])
spin_mesh = bpy.data.meshes.new("spinner")
bm.to_mesh(spin_mesh)
bm.free()
spin_mesh.polygons.foreach_set("use_smooth", [True] * len(spin_mesh.polygons))
spin_mesh.update()
spin_mesh.materials.append(material("Brass", "itu:metal"))
spin = bpy.data.objects.new("spinner", spin_mesh)
spin.location = P["spin_location"]
scene.collection.objects.link(spin)
spin.rotation_mode = "AXIS_ANGLE"
for f, ang in ((f0, 0.0), (f1, math.radians(P["spin_angle_deg"]))):
    spin.rotation_axis_angle = (ang, *P["spin_axis"])
    spin.keyframe_insert("rotation_axis_angle", frame=f)
make_linear(spin)

bpy.ops.wm.save_as_mainfile(filepath=out + "/good.blend")
facts = {}

# the add-on operator, on the scene as it is
exporter.register()
result = bpy.ops.export_scene.sionnafmcw(filepath=out + "/operator_anim", use_scene_range=False,
                                         frame_start=f0, frame_end=f0 + 1)
facts["operator"] = sorted(result)
exporter.unregister()

# pose conversion: world matrices of unparented objects (Euler XYZ, non-uniform scale)
rng = random.Random(7)
cases = []
eulers = [(rng.uniform(-math.pi, math.pi), rng.uniform(-1.5, 1.5), rng.uniform(-math.pi, math.pi)) for _ in range(24)]
eulers += [(0.3, math.pi / 2, -0.4), (0.3, -math.pi / 2, 1.1), (0.0, 0.0, 0.0)]
for j, euler in enumerate(eulers):
    scale = (rng.uniform(0.3, 3), rng.uniform(0.3, 3), rng.uniform(0.3, 3))
    m = Matrix.LocRotScale(Vector((rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(0, 3))),
                           Euler(euler, "XYZ"), Vector(scale))
    is_camera = j % 2 == 1
    r3 = m.to_3x3()
    axes = [list((r3 @ Vector(d)).normalized()) for d in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    cases.append({"euler": list(euler), "is_camera": is_camera, "axes": axes,
                  "pose": exporter.radar_pose_from_matrix(m, is_camera)})
facts["pose_cases"] = cases

# unmapped material
chair = mesh_object("Chair", cube_v(0.2), cube_f, [material("Wood")], location=(2.0, -2.0, 0.3))
bpy.ops.wm.save_as_mainfile(filepath=out + "/unmapped.blend", copy=True)
bpy.data.objects.remove(chair)



def export_error(**kwargs):
    try:
        exporter.export_animation(out + "/failed_anim", **kwargs)
    except exporter.ExportError as err:
        return str(err)
    return None


# topology that changes with time: a Build modifier adds faces frame by frame (some at the start)
grow = mesh_object("grow", cube_v(0.2), cube_f, [material("itu_wood")], location=(2.0, -2.0, 0.3))
build = grow.modifiers.new("build", "BUILD")
build.frame_start, build.frame_duration = f0 - 2, f1 - f0
facts["topology_error"] = export_error()
# ... and one that has no faces at the first frame: it appears later
build.frame_start = f0
facts["appearing_error"] = export_error()
bpy.data.objects.remove(grow)

# no radar empty: the scene camera is the radar
bpy.data.objects.remove(radar)
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
cam.location = P["camera_location"]
cam.rotation_euler = [math.radians(x) for x in P["camera_euler_deg"]]
scene.collection.objects.link(cam)
scene.camera = cam
exporter.export_animation(out + "/camera_anim", f0, f0)

# names that need XML escaping, in an object and a material name
odd = mesh_object('odd <&"> name', cube_v(0.1), cube_f, [material('Steel & "Iron" <1>', "itu:metal")],
                  location=(1.0, 1.0, 0.5))
exporter.export_animation(out + "/odd_anim", f0, f0)
bpy.data.objects.remove(odd)
# the exporter writes with the simulator's own (numpy-only) writers
facts["writers"] = {name: getattr(exporter, name).__module__
                    for name in ("ply_bytes", "write_frame_xml", "write_animation", "atomic_directory")}

# neither radar nor camera
scene.camera = None
bpy.data.objects.remove(cam)
facts["noradar_error"] = export_error()
open(out + "/facts.json", "w").write(json.dumps(facts))
'''


def _blender_python() -> Path:
    python = BLENDER_VENV / "bin" / "python"
    # CI creates .venv-blender (make test depends on it): a missing one is a failure, not a skip
    assert python.exists(), (f"{python} is missing: the Blender exporter tests need bpy; run "
                             "'make .venv-blender/.installed' (or 'bash scripts/setup_blender.sh')")
    return python


@pytest.fixture(scope="module")
def blend_dir(tmp_path_factory):
    """good.blend, unmapped.blend, the operator and camera exports and facts.json, from real bpy."""
    python = _blender_python()
    root = tmp_path_factory.mktemp("blender")
    (root / "params.json").write_text(json.dumps(PARAMS))
    (root / "build.py").write_text(BUILD_SCENE)
    proc = subprocess.run([str(python), str(root / "build.py"), "--", str(root / "params.json"), str(root),
                           str(script_path())], capture_output=True, text=True, timeout=BPY_TIMEOUT)
    assert proc.returncode == 0 and (root / "facts.json").exists(), proc.stdout[-3000:] + proc.stderr[-3000:]
    return root


@pytest.fixture(scope="module")
def anim(blend_dir):
    out = export_blend(blend_dir / "good.blend", blend_dir / "anim", timeout=BPY_TIMEOUT)
    return load_animation(out)


# --------------------------------------------------------------------------------- truth (keyframes)
def radar_truth():
    yaw, pitch, roll = np.deg2rad(PARAMS["radar_ypr_deg"])
    rot = rotation_matrix([yaw, pitch, roll])
    return np.asarray(PARAMS["radar_position"], float), np.array([yaw, pitch, roll]), rot[:, 0]


def box_centre(t):
    p, _, u = radar_truth()
    return p + (PARAMS["box_r0"] + PARAMS["box_speed"] * t) * u


def arm_omega():
    span = (FRAMES[1] - FRAMES[0]) / FPS
    return math.radians(PARAMS["arm_theta1_deg"]) / span  # rad/s about world z


# ------------------------------------------------------------------------------------------ tests
def test_layout_materials_and_shared_static_meshes(anim):
    assert anim.fps == FPS and anim.num_frames == FRAMES[1] - FRAMES[0] + 1
    assert np.allclose(anim.times, np.arange(anim.num_frames) / FPS)
    # moving objects only in the manifest; the room is split per material and stays static
    assert sorted(anim.object_names) == ["arm", "box", "flag", "spinner"]
    shapes = anim.frame_xml(0).shapes
    assert sorted(shapes) == ["arm", "box", "flag", "room/Concrete", "room/itu_plasterboard", "spinner"]
    for name in ("room/Concrete", "room/itu_plasterboard"):
        files = {anim.frame_xml(i).shapes[name].filename for i in range(anim.num_frames)}
        assert len(files) == 1 and next(iter(files)).parent.name == "meshes"
        assert all(np.array_equal(anim.frame_xml(i).shapes[name].to_world, np.eye(4)) for i in range(anim.num_frames))
    for name in ("box", "spinner"):   # rigid: one mesh, a transform per frame (also in the manifest)
        files = {anim.frame_xml(i).shapes[name].filename for i in range(anim.num_frames)}
        assert len(files) == 1
        assert len({anim.frame_xml(i).shapes[name].to_world.tobytes() for i in range(anim.num_frames)}) == \
            anim.num_frames
        assert all(np.array_equal(anim.frame(i).transforms[name], anim.frame_xml(i).shapes[name].to_world)
                   for i in range(anim.num_frames))
    for name in ("arm", "flag"):      # deforming: a mesh per frame
        files = {anim.frame_xml(i).shapes[name].filename for i in range(anim.num_frames)}
        assert len(files) == anim.num_frames
    assert len(list((anim.path / "meshes").glob("*.ply"))) == 2 + 2 + 2 * anim.num_frames
    # radio materials: property, naming rule, JSON dict, skin; no id Sionna would replace
    mats = {shape.name: shape.material for shape in shapes.values()}
    assert (mats["room/Concrete"].kind, mats["room/Concrete"].itu_type) == ("itu", "concrete")
    assert (mats["room/itu_plasterboard"].kind, mats["room/itu_plasterboard"].itu_type) == ("itu", "plasterboard")
    assert (mats["box"].kind, mats["box"].itu_type) == ("itu", "metal")
    assert mats["arm"].kind == "radio" and (mats["flag"].kind, mats["flag"].custom) == ("skin", "skin")
    assert not any(m.id.startswith("mat-itu_") or m.id.startswith("mat-itu-") for m in mats.values())
    root = ET.parse(anim.frames[0].xml).getroot()
    arm_bsdf = root.find(f"bsdf[@id='{mats['arm'].id}']")
    props = {c.attrib["name"]: float(c.attrib["value"]) for c in arm_bsdf}
    assert props == {"relative_permittivity": 5.0, "conductivity": 0.1, "scattering_coefficient": 0.3}
    for name, shape in shapes.items():   # vertex normals where Blender shades smooth: Mitsuba then uses them
        has_normals = read_ply(shape.filename).vertex_normals is not None
        assert shape.face_normals == (not has_normals), name
    assert not shapes["spinner"].face_normals
    anim.check_frequency(77e9)


def test_rigid_spinner_written_once_with_its_rotation_and_normals(anim):
    """The turning icosphere: its to_world is the keyframed rotation about its centre, its angular
    velocity the constant rate about the axis, every vertex's velocity omega x (x - c), and its PLY
    carries Blender's (smooth) vertex normals, turned with the mesh.

    Tolerances: the rotation is fitted to float32 vertices 0.15 m from the axis, so it is good to
    EXACT_POSITION_TOL / r; the angular velocity differences two such rotations over 2 delta (one
    frame: a constant rate is differenced exactly); the normals of an icosphere are within its
    facets' half angle (about 9 deg at 2 subdivisions) of the radial direction."""
    axis = np.asarray(PARAMS["spin_axis"], float)
    axis /= np.linalg.norm(axis)
    rate = math.radians(PARAMS["spin_angle_deg"]) / ((FRAMES[1] - FRAMES[0]) / FPS)
    radius, centre = PARAMS["spin_radius"], np.asarray(PARAMS["spin_location"], float)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    rotation_tol = EXACT_POSITION_TOL / radius
    ply = read_ply((anim.path / "meshes" / "spinner.ply"))
    assert ply.vertex_normals is not None
    for i in range(anim.num_frames):
        angle = rate * anim.times[i]
        expected = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
        motion = anim.motion(i, "spinner")
        assert np.max(np.abs(motion.rotation - expected)) < rotation_tol
        omega_tol = 2 * rotation_tol / (1 / FPS) if 0 < i < anim.num_frames - 1 else 2 * rotation_tol / (0.5 / FPS)
        assert np.linalg.norm(motion.angular_velocity - rate * axis) < omega_tol
        mesh = anim.mesh(i, "spinner")
        assert np.max(np.abs(mesh.centroid - centre)) < EXACT_POSITION_TOL
        field = np.cross(rate * axis, mesh.vertices - mesh.centroid)
        assert np.max(np.abs(mesh.vertex_velocities - field)) < omega_tol * radius + EXACT_VELOCITY_TOL
        normals = ply.vertex_normals @ motion.rotation.T
        radial = (mesh.vertices - centre) / np.linalg.norm(mesh.vertices - centre, axis=1, keepdims=True)
        assert np.min(np.einsum("ij,ij->i", normals, radial)) > math.cos(math.radians(10.0))


def test_box_translation_matches_keyframes(anim):
    _, _, u = radar_truth()
    v_true = PARAMS["box_speed"] * u
    for i in range(anim.num_frames):
        mesh = anim.mesh(i, "box")
        assert mesh.vertex_velocities is None  # pure translation: the manifest velocity is enough
        assert np.max(np.abs(mesh.centroid - box_centre(anim.times[i]))) < EXACT_POSITION_TOL
        assert np.max(np.abs(anim.object_velocity(i, "box") - v_true)) < EXACT_VELOCITY_TOL


def test_shape_key_shear_vertex_and_object_velocity(anim):
    rate = 1.0 / ((FRAMES[1] - FRAMES[0]) / FPS)  # shape-key value per second
    k, s = PARAMS["flag_shear"], PARAMS["flag_size"]
    y_min = PARAMS["flag_location"][1] - s / 2
    for i in range(anim.num_frames):
        mesh = anim.mesh(i, "flag")
        vel = mesh.vertex_velocities
        assert vel is not None
        expected = np.zeros_like(vel)
        expected[:, 0] = rate * k * (mesh.vertices[:, 1] - y_min)
        assert np.max(np.abs(vel - expected)) < EXACT_VELOCITY_TOL
        centroid_v = np.array([rate * k * s / 2, 0.0, 0.0])  # area-preserving shear: y-bar - y_min = s/2
        assert np.max(np.abs(anim.object_velocity(i, "flag") - centroid_v)) < EXACT_VELOCITY_TOL


def test_armature_bend_vertex_velocity(anim):
    omega = arm_omega()
    delta = 0.5 / FPS  # the exporter's default half-frame step
    origin = np.asarray(PARAMS["arm_origin"], float)
    elbow = origin + np.array([PARAMS["arm_elbow"], 0.0, 0.0])
    rest = anim.mesh(0, "arm").vertices  # angle 0 at the first frame
    fore = rest[:, 0] - origin[0] > PARAMS["arm_elbow"] + 1e-4
    assert 0 < fore.sum() < len(rest)
    radius = np.linalg.norm(rest[fore] - elbow, axis=1).max()
    for i in range(anim.num_frames):
        mesh = anim.mesh(i, "arm")
        vel = mesh.vertex_velocities
        assert vel is not None and vel.shape == mesh.vertices.shape
        expected = np.zeros_like(vel)
        expected[fore] = np.cross([0.0, 0.0, omega], mesh.vertices[fore] - elbow)
        if 0 < i < anim.num_frames - 1:
            tol = (omega * delta) ** 2 / 6 * omega * radius
        else:
            tol = delta * omega ** 2 * radius / 2 + delta ** 2 * omega ** 3 * radius / 6
        err = np.linalg.norm(vel - expected, axis=1)
        assert err.max() < tol + EXACT_VELOCITY_TOL, (i, err.max(), tol)
    # the manifest velocity is the centroid's derivative: compare with the exported centroids
    # differenced over +-1 frame; the two central differences differ by (h1^2 - h2^2)/6 |c'''|,
    # |c'''| <= omega^3 r for the rigidly turning part
    c = np.array([anim.mesh(i, "arm").centroid for i in range(anim.num_frames)])
    h1, h2 = 1 / FPS, delta
    bound = (h1 ** 2 - h2 ** 2) / 6 * omega ** 3 * radius
    for i in range(1, anim.num_frames - 1):
        numeric = (c[i + 1] - c[i - 1]) / (2 * h1)
        assert np.linalg.norm(anim.object_velocity(i, "arm") - numeric) < bound + EXACT_VELOCITY_TOL


def test_radar_pose_from_empty(anim):
    position, ypr, u = radar_truth()
    pose = anim.radar_pose
    assert np.max(np.abs(pose.position - position)) < EXACT_POSITION_TOL
    assert np.max(np.abs(pose.orientation - ypr)) < 1e-6  # float32 matrix
    boresight = rotation_matrix(pose.orientation)[:, 0]
    to_box = anim.mesh(0, "box").centroid - pose.position
    assert boresight @ to_box / np.linalg.norm(to_box) > math.cos(1e-5)


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def test_pose_conversion_empty_and_camera(blend_dir):
    """Sionna's R(yaw, pitch, roll) rebuilt here has the radar axes Blender reports for the object."""
    cases = json.loads((blend_dir / "facts.json").read_text())["pose_cases"]
    assert len(cases) > 20
    for case in cases:
        r = rotation_matrix(case["pose"]["orientation"])
        x, y, z = (np.asarray(a) for a in case["axes"])  # the object's local axes in the world
        if case["is_camera"]:  # looks along -Z, up +Y: boresight -Z, azimuth (left) -X, up +Y
            expected = np.stack([-z, -x, y], axis=1)
        else:  # empty: boresight +X, azimuth +Y, up +Z
            expected = np.stack([x, y, z], axis=1)
        assert np.max(np.abs(r - expected)) < 1e-5, case
        rx, ry, rz = case["euler"]
        if not case["is_camera"] and abs(abs(ry) - np.pi / 2) > 1e-3:
            # an unparented empty: (yaw, pitch, roll) = Blender's Euler (z, y, x)
            assert np.max(np.abs(_wrap(np.subtract(case["pose"]["orientation"], [rz, ry, rx])))) < 1e-5


def test_camera_is_the_radar_without_a_radar_object(blend_dir):
    anim = load_animation(blend_dir / "camera_anim")  # exported in bpy, frames 1:1, no object named radar
    assert anim.num_frames == 1
    e = np.deg2rad(PARAMS["camera_euler_deg"])
    # Blender XYZ Euler of the camera: R_cam = Rz(e_z) Ry(e_y) Rx(e_x) = Sionna's R(e_z, e_y, e_x)
    r_cam = rotation_matrix([e[2], e[1], e[0]])
    r = rotation_matrix(anim.radar_pose.orientation)
    assert np.allclose(r[:, 0], -r_cam[:, 2], atol=1e-6)  # boresight = view direction
    assert np.allclose(r[:, 2], r_cam[:, 1], atol=1e-6)   # up = camera up
    assert np.allclose(anim.radar_pose.position, PARAMS["camera_location"], atol=EXACT_POSITION_TOL)


def test_addon_operator_exports(blend_dir):
    facts = json.loads((blend_dir / "facts.json").read_text())
    assert facts["operator"] == ["FINISHED"]
    anim = load_animation(blend_dir / "operator_anim")
    assert anim.num_frames == 2 and sorted(anim.object_names) == ["arm", "box", "flag", "spinner"]


def test_exporter_uses_the_shared_writers_and_escapes_names(blend_dir):
    facts = json.loads((blend_dir / "facts.json").read_text())
    assert facts["writers"] == {"ply_bytes": "sionnafmcw.animation.ply",
                                "write_frame_xml": "sionnafmcw.animation.frame_xml",
                                "write_animation": "sionnafmcw.animation.manifest",
                                "atomic_directory": "sionnafmcw.fs"}
    anim = load_animation(blend_dir / "odd_anim")
    shapes = anim.frame_xml(0).shapes
    assert 'odd <&"> name' in shapes
    assert shapes['odd <&"> name'].material.id == 'mat-Steel & "Iron" <1>'


ADDON_SCRIPT = r'''
import json, sys
import bpy, addon_utils
zip_path, out = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.preferences.addon_install(filepath=zip_path)
addon_utils.enable("sionnafmcw_export", default_set=True)
import sionnafmcw_export
import sionnafmcw.animation.ply as ply
scene = bpy.context.scene
me = bpy.data.meshes.new("plate")
me.from_pydata([(3, -0.2, -0.2), (3, 0.2, -0.2), (3, 0.2, 0.2), (3, -0.2, 0.2)], [], [(0, 1, 2, 3)])
m = bpy.data.materials.new("Steel")
m["radio_material"] = "itu:metal"
me.materials.append(m)
scene.collection.objects.link(bpy.data.objects.new("plate", me))
scene.collection.objects.link(bpy.data.objects.new("radar", None))
result = bpy.ops.export_scene.sionnafmcw(filepath=out, use_scene_range=False, frame_start=1, frame_end=1)
print("FACTS" + json.dumps({"addon": sionnafmcw_export.__file__, "ply": ply.__file__, "result": sorted(result)}))
'''


def test_addon_zip_installs_and_exports_without_the_checkout(tmp_path):
    """The add-on zip, installed into a fresh user-scripts folder and run outside the checkout,
    brings its own copy of the writers and exports through the File > Export operator."""
    import os

    from sionnafmcw.blender import ADDON_NAME, addon_zip

    python = _blender_python()
    zip_path = addon_zip(tmp_path / "addon.zip")
    (tmp_path / "install.py").write_text(ADDON_SCRIPT)
    env = {**os.environ, "BLENDER_USER_SCRIPTS": str(tmp_path / "scripts")}
    env.pop("PYTHONPATH", None)
    proc = subprocess.run([str(python), str(tmp_path / "install.py"), "--", str(zip_path), str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=BPY_TIMEOUT, cwd=tmp_path, env=env)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("FACTS")]
    assert proc.returncode == 0 and lines, proc.stdout[-3000:] + proc.stderr[-3000:]
    facts = json.loads(lines[0][len("FACTS"):])
    installed = tmp_path / "scripts" / "addons" / ADDON_NAME
    assert Path(facts["addon"]).parent == installed
    assert Path(facts["ply"]).is_relative_to(installed)
    assert facts["result"] == ["FINISHED"]
    anim = load_animation(tmp_path / "out")
    assert anim.num_frames == 1 and set(anim.frame_xml(0).shapes) == {"plate"}


def test_simulated_box_range_and_velocity_match_keyframes(anim, tmp_path):
    radar = RadarConfig.preset("walk-77ghz")
    frames = [0, anim.num_frames // 2, anim.num_frames - 1]
    ds = simulate(anim, radar, engine=PathEngine(samples_per_src=20_000), out=tmp_path / "run.zarr",
                  frames=frames, progress=False)
    track = processing.doppler_time(ds.iq.values[frames], radar)  # clutter removed: the box's cell
    pose = anim.radar_pose
    centre = world_phase_centre(radar, pose.position, pose.orientation)
    _, _, u = radar_truth()
    v_box = PARAMS["box_speed"] * u
    i_box = list(ds.object.values).index("box")
    for j, f in enumerate(frames):
        t_mid = anim.times[f] + radar.cpi_duration / 2
        face = box_centre(t_mid) - PARAMS["box_half_size"] * u  # the face that looks at the radar
        r_true = np.linalg.norm(face - centre)
        v_true = radial_velocity(face, v_box, centre)
        assert abs(ds.truth_radial_velocity.values[f, i_box] - radial_velocity(box_centre(anim.times[f]), v_box,
                                                                               centre)) < EXACT_VELOCITY_TOL
        assert np.sign(track.velocities[j]) == np.sign(v_true) == 1
        assert abs(track.velocities[j] - v_true) < radar.velocity_resolution / 2, (f, track.velocities[j], v_true)
        assert abs(track.ranges[j] - r_true) < radar.range_resolution / 2, (f, track.ranges[j], r_true)


def _no_leftovers(parent: Path, name: str):
    assert not (parent / name).exists()
    assert not [p for p in parent.iterdir() if p.name.startswith(f".{name}.")]


def test_unmapped_material_names_object_material_and_fix(blend_dir):
    with pytest.raises(BlenderExportError) as err:
        export_blend(blend_dir / "unmapped.blend", blend_dir / "unmapped_anim", timeout=BPY_TIMEOUT)
    msg = str(err.value)
    assert "'Chair'" in msg and "'Wood'" in msg and "radio_material" in msg and "itu:" in msg
    assert err.value.returncode == 1
    _no_leftovers(blend_dir, "unmapped_anim")


def test_missing_radar_and_camera_is_an_error(blend_dir):
    msg = json.loads((blend_dir / "facts.json").read_text())["noradar_error"]
    assert msg is not None and re.search(r"no radar.*empty named 'radar'.*camera", msg), msg
    _no_leftovers(blend_dir, "failed_anim")


def test_changing_topology_or_object_set_is_an_error(blend_dir):
    facts = json.loads((blend_dir / "facts.json").read_text())
    assert facts["topology_error"] is not None and "object 'grow' changes its topology" in facts["topology_error"]
    assert facts["appearing_error"] is not None and "new: ['grow']" in facts["appearing_error"]
    _no_leftovers(blend_dir, "failed_anim")


def test_export_blend_reports_a_missing_interpreter(blend_dir, tmp_path):
    with pytest.raises(BlenderExportError, match="cannot run the exporter"):
        export_blend(blend_dir / "good.blend", tmp_path / "x", python=tmp_path / "no-such-python", timeout=BPY_TIMEOUT)
    with pytest.raises(BlenderExportError, match="no such .blend"):
        export_blend(tmp_path / "missing.blend", tmp_path / "x", timeout=BPY_TIMEOUT)
