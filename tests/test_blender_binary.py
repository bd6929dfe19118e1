r"""The Blender binary route as users run it: a distribution's ``blender -b ... -P export.py``.

A .blend is made by that Blender (Debian 12's 3.4.1, installed by ``scripts/setup_blender.sh`` when
root on Debian/Ubuntu) in the test, Blender frames 1..5 at 24 fps, every key Blender's default
(Bezier, auto-clamped handles: the motions ease in and out):

* ``floor``: a static concrete plate (``"itu:concrete"``);
* ``box``: a 0.4 m metal cube sliding away along +x (3.0 -> 3.6 m): a rigid part (one PLY, a
  ``to_world`` per frame);
* ``flag``: a plate sheared by a shape key (skin) and ``arm``: a smooth-shaded tube bent by an
  armature (JSON radio material): deforming parts (a PLY per frame with vertex velocities);
* ``ball``: a static smooth-shaded metal icosphere (vertex normals);
* ``cam``: the scene camera, looking along +x and moving towards the box (x 0 -> 0.2 m): the radar,
  so the manifest holds a radar track.

It is exported with the README's command, ``blender -b scene.blend --python-exit-code 1 -P
sionnafmcw/blender/export.py -- OUT``, through the add-on zip installed in that Blender, and through
the ``bpy`` 4.5 module (``.venv-blender``); the three animation directories must agree to float32
rounding:

* positions (vertices, origins, the ``to_world`` translation): Blender evaluates in float32, so a
  coordinate of the 8 m scene is good to :math:`2^{-24}\cdot 8` m = 4.8e-7 m; four such roundings
  (object matrix times vertex, the PLY's float32) give ``POSITION_TOL`` = 1.9e-6 m;
* velocities are differences of two positions over the shortest interval the exporter uses (half a
  frame, 1/48 s): ``VELOCITY_TOL`` = 2 ``POSITION_TOL`` x 48 /s = 1.8e-4 m/s; angular velocities that
  over the smallest lever, the box's half size (0.2 m);
* rotations (orientation angles, matrix entries): float32 matrices, ``ANGLE_TOL`` = 1e-6 rad;
* vertex normals: the exporter's own criterion for two normals being the same one,
  :data:`~sionnafmcw.blender.export.SMOOTH_NORMAL_TOLERANCE` = 1e-4 (measured on the armature-bent
  tube: Blender 3.4.1's vertex normals are the angle-weighted normals of its float32 vertices to
  1e-7, bpy 4.5's to 4e-6, so the two are up to 8e-6 apart; the static sphere's agree to 1e-7);
* everything else (names, materials, files, triangles, flags) exactly; the ``source.blender`` field
  names the Blender that wrote it.

The binary route's directory is then loaded and simulated (path engine, two frames): the box's
range peak lies within half a range bin of the distance from the moving radar's phase centre to
the box's face at the middle of the CPI, and its Doppler within half a Doppler bin of the store's
truth (the box's radial velocity relative to the moving radar), sign included.

The BVH route (:func:`~sionnafmcw.mocap.blender_route.export_with_blender`) in the binary, whose
Blender 3.4 importer opens the clip with mode ``'rU'`` (refused by Python 3.11; the route's script
reads it as ``'r'``), writes the same directory as in the ``bpy`` module to the same float32
tolerances: the person stands within a metre of the origin and the radar 3 m in front of it (inside
``SCENE_EXTENT``), at 24 fps with the exporter's half-frame velocity differences. Where that
Blender's Python lacks numpy, the route stops with the exporter's one line naming the fix.

Where the Blender binary's Python lacks numpy (Debian's ``blender`` without ``python3-numpy``), the
exporter prints one line naming the fix; the test hides numpy from that Blender's Python by
blocking its import (``sys.modules["numpy"] = None``, Python's documented import block) before the
exporter runs, so it runs where python3-numpy is installed too.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import shlex
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from sionnafmcw import PathEngine, RadarConfig, load_animation, processing, simulate
from sionnafmcw.animation import read_ply
from sionnafmcw.blender import (ADDON_NAME, BLENDER_VENV, ERROR_MARKER, BlenderExportError, addon_zip, export_blend,
                                script_path)
from sionnafmcw.geometry import world_phase_centre
from sionnafmcw.mocap import library
from sionnafmcw.mocap.blender_route import export_with_blender
from sionnafmcw.mocap.person import MocapPerson
from sionnafmcw.mocap.scene import radar_in_front, radar_orientation

BLENDER = shutil.which("blender")
pytestmark = pytest.mark.skipif(
    BLENDER is None, reason="no 'blender' binary on PATH: scripts/setup_blender.sh installs Debian's "
    "(apt-get install blender python3-numpy) when run as root on Debian/Ubuntu")

FPS = 24
FRAMES = (1, 5)
SCENE_EXTENT = 8.0                                  # m, largest coordinate magnitude of the scene (bound)
POSITION_TOL = 4 * 2.0 ** -24 * SCENE_EXTENT        # m
VELOCITY_TOL = 2 * POSITION_TOL * 2 * FPS           # m/s: two positions half a frame apart
BOX_HALF = 0.2                                      # m
ANGULAR_VELOCITY_TOL = VELOCITY_TOL / BOX_HALF      # rad/s
ANGLE_TOL = 1e-6                                    # rad
TIMEOUT = 180                                       # s for one Blender run (a few seconds when healthy)
BPY_PYTHON = BLENDER_VENV / "bin" / "python"
#: Clip time (s) where each shipped clip moves most (as in tests/test_mocap_routes.py).
BUSY = {"08_10": 1.1, "09_01": 0.5, "111_10": 1.2, "111_37": 2.3, "75_10": 1.4, "90_18": 0.9, "115_06": 0.6}

BUILD_SCENE = r'''
import json, math, sys
import bpy, bmesh

out_blend = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps, scene.render.fps_base = 24, 1.0
scene.frame_start, scene.frame_end = 1, 5


def material(name, radio):
    m = bpy.data.materials.new(name)
    m["radio_material"] = radio
    return m


def mesh_object(name, verts, faces, mat, location=(0, 0, 0), smooth=False):
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.polygons.foreach_set("use_smooth", [smooth] * len(me.polygons))
    me.update()
    me.materials.append(mat)
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    scene.collection.objects.link(ob)
    return ob


a = 0.2
cube_v = [(x, y, z) for x in (-a, a) for y in (-a, a) for z in (-a, a)]
cube_f = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
mesh_object("floor", [(-1, -3, 0), (6, -3, 0), (6, 3, 0), (-1, 3, 0)], [(0, 1, 2, 3)],
            material("Concrete", "itu:concrete"))
box = mesh_object("box", cube_v, cube_f, material("Steel", "itu:metal"), location=(3.0, 0.0, 1.0))
for f, x in ((1, 3.0), (5, 3.6)):
    box.location.x = x
    box.keyframe_insert("location", frame=f)

bm = bmesh.new()
bmesh.ops.create_icosphere(bm, subdivisions=2, radius=0.15)
me = bpy.data.meshes.new("ball")
bm.to_mesh(me)
bm.free()
me.polygons.foreach_set("use_smooth", [True] * len(me.polygons))
me.update()
me.materials.append(material("Brass", "itu:metal"))
ball = bpy.data.objects.new("ball", me)
ball.location = (4.5, 1.8, 0.8)
scene.collection.objects.link(ball)

n, s = 4, 0.4
fv = [(-s / 2 + s * i / (n - 1), -s / 2 + s * j / (n - 1), 0.0) for j in range(n) for i in range(n)]
ff = [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i) for j in range(n - 1) for i in range(n - 1)]
flag = mesh_object("flag", fv, ff, material("Skin", "skin"), location=(3.5, -1.6, 2.0))
flag.shape_key_add(name="Basis")
key = flag.shape_key_add(name="shear")
for i, p in enumerate(fv):
    key.data[i].co = (p[0] + 0.5 * (p[1] + s / 2), p[1], p[2])
for f, w in ((1, 0.0), (5, 1.0)):
    key.value = w
    key.keyframe_insert("value", frame=f)

rings, seg, rad = 5, 6, 0.05
tv = [(0.1 * i, rad * math.cos(2 * math.pi * k / seg), rad * math.sin(2 * math.pi * k / seg))
      for i in range(rings) for k in range(seg)]
tf = [(i * seg + k, i * seg + (k + 1) % seg, (i + 1) * seg + (k + 1) % seg, (i + 1) * seg + k)
      for i in range(rings - 1) for k in range(seg)]
arm = mesh_object("arm", tv, tf, material("Plastic", '{"relative_permittivity": 5, "conductivity": 0.1}'),
                  location=(3.2, 1.6, 1.8), smooth=True)
rig = bpy.data.objects.new("rig", bpy.data.armatures.new("rig"))
rig.location = arm.location
scene.collection.objects.link(rig)
bpy.context.view_layer.objects.active = rig
bpy.ops.object.mode_set(mode="EDIT")
upper = rig.data.edit_bones.new("upper")
upper.head, upper.tail = (0, 0, 0), (0.2, 0, 0)
fore = rig.data.edit_bones.new("fore")
fore.head, fore.tail = (0.2, 0, 0), (0.4, 0, 0)
fore.parent, fore.use_connect = upper, True
bpy.ops.object.mode_set(mode="OBJECT")
g_up, g_fore = arm.vertex_groups.new(name="upper"), arm.vertex_groups.new(name="fore")
for i, p in enumerate(tv):
    (g_up if p[0] <= 0.2 + 1e-9 else g_fore).add([i], 1.0, "REPLACE")
arm.modifiers.new("rig", "ARMATURE").object = rig
pb = rig.pose.bones["fore"]
pb.rotation_mode = "XYZ"
for f, th in ((1, 0.0), (5, 1.0)):
    pb.rotation_euler = (0.0, 0.0, th)
    pb.keyframe_insert("rotation_euler", frame=f)

cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
cam.rotation_euler = (math.pi / 2, 0.0, -math.pi / 2)   # looks along +x, up +z
scene.collection.objects.link(cam)
scene.camera = cam
for f, x in ((1, 0.0), (5, 0.2)):
    cam.location = (x, 0.0, 1.0)
    cam.keyframe_insert("location", frame=f)
bpy.ops.wm.save_as_mainfile(filepath=out_blend)
print("BLENDER_VERSION " + bpy.app.version_string)
'''

ADDON_SCRIPT = r'''
import json, sys
import bpy, addon_utils
zip_path, blend, out = sys.argv[sys.argv.index("--") + 1:]
hide_numpy = out == "-"
if hide_numpy:
    sys.modules["numpy"] = None
bpy.ops.preferences.addon_install(filepath=zip_path)
errors = []
addon_utils.enable("sionnafmcw_export", default_set=True, handle_error=lambda err: errors.append(str(err)))
facts = {"errors": errors}
if not hide_numpy:
    import sionnafmcw_export
    import sionnafmcw.animation.ply as ply
    bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
    result = bpy.ops.export_scene.sionnafmcw(filepath=out, use_scene_range=True)
    facts.update(addon=sionnafmcw_export.__file__, ply=ply.__file__, result=sorted(result))
print("FACTS" + json.dumps(facts))
'''


def run_blender(args, timeout=TIMEOUT, env=None):
    """``blender -b ARGS`` in the user's environment (without the test run's PYTHONPATH: the exporter
    finds the checkout it lives in by itself)."""
    if env is None:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([BLENDER, "-b", *args], capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL, env=env)


@pytest.fixture(scope="module")
def blend(tmp_path_factory):
    """scene.blend made by the Blender binary, and its version."""
    root = tmp_path_factory.mktemp("blender_binary")
    (root / "build.py").write_text(BUILD_SCENE)
    proc = run_blender(["--factory-startup", "--python-exit-code", "1", "-P", str(root / "build.py"), "--",
                        str(root / "scene.blend")])
    versions = [ln.split()[1] for ln in proc.stdout.splitlines() if ln.startswith("BLENDER_VERSION ")]
    assert proc.returncode == 0 and versions and (root / "scene.blend").is_file(), proc.stdout[-3000:] + proc.stderr
    return root / "scene.blend", versions[0]


@pytest.fixture(scope="module")
def binary_export(blend):
    """The README's command, verbatim (no --factory-startup: as a user types it)."""
    path, _ = blend
    out = path.parent / "binary_anim"
    proc = run_blender([str(path), "--python-exit-code", "1", "-P", str(script_path()), "--", str(out)])
    assert proc.returncode == 0 and (out / "animation.json").is_file(), proc.stdout[-3000:] + proc.stderr[-3000:]
    assert ERROR_MARKER not in proc.stderr
    return out


@pytest.fixture(scope="module")
def module_export(blend):
    python = BLENDER_VENV / "bin" / "python"
    assert python.exists(), f"{python} is missing: run 'make .venv-blender/.installed'"
    path, _ = blend
    return export_blend(path, path.parent / "module_anim", python=python, timeout=TIMEOUT)


# ------------------------------------------------------------------------------ comparing directories
def _tolerance(key_path: tuple) -> float:
    keys = set(k for k in key_path if isinstance(k, str))
    if "angular_velocity" in keys:
        return ANGULAR_VELOCITY_TOL
    if "velocity" in keys:
        return VELOCITY_TOL
    if "orientation" in keys:
        return ANGLE_TOL
    if "to_world" in keys:   # rotation entries (dimensionless) and translation (m)
        return max(ANGLE_TOL, POSITION_TOL)
    return POSITION_TOL


def compare_json(a, b, key_path=()):
    """Differences between two manifests: numbers beyond their tolerance, anything else unequal."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return [f"{'.'.join(map(str, key_path))}: keys {sorted(set(a) ^ set(b))} in one only"]
        return [d for k in a for d in compare_json(a[k], b[k], key_path + (k,))]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{'.'.join(map(str, key_path))}: lengths {len(a)} != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in compare_json(x, y, key_path + (i,))]
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, (int, float)) and isinstance(b, (int, float)) and abs(a - b) <= _tolerance(key_path):
            return []
    elif a == b:
        return []
    return [f"{'.'.join(map(str, key_path))}: {a!r} != {b!r}"]


def compare_frame_xml(a: Path, b: Path):
    """Differences between two frame XMLs: ``to_world`` matrices numerically, everything else exactly."""
    ra, rb = ET.parse(a).getroot(), ET.parse(b).getroot()
    ea, eb = list(ra.iter()), list(rb.iter())
    if [e.tag for e in ea] != [e.tag for e in eb]:
        return [f"{a.name}: element structure differs"]
    out = []
    for x, y in zip(ea, eb):
        if x.tag == "matrix":
            ma = np.array(x.attrib["value"].split(), float)
            mb = np.array(y.attrib["value"].split(), float)
            if np.max(np.abs(ma - mb)) > max(ANGLE_TOL, POSITION_TOL):
                out.append(f"{a.name}: matrix {ma} != {mb}")
        elif x.attrib != y.attrib:
            out.append(f"{a.name}: {x.attrib} != {y.attrib}")
    return out


def compare_directories(a: Path, b: Path):
    """Every difference between two animation directories beyond float32 rounding."""
    from sionnafmcw.blender.export import SMOOTH_NORMAL_TOLERANCE

    ma, mb = (json.loads((d / "animation.json").read_text()) for d in (a, b))
    ma["source"].pop("blender"), mb["source"].pop("blender")
    diffs = compare_json(ma, mb)
    xml_a, xml_b = sorted(p.name for p in (a / "frames").iterdir()), sorted(p.name for p in (b / "frames").iterdir())
    ply_a, ply_b = sorted(p.name for p in (a / "meshes").iterdir()), sorted(p.name for p in (b / "meshes").iterdir())
    if xml_a != xml_b or ply_a != ply_b:
        return diffs + [f"files differ: {xml_a} {ply_a} vs {xml_b} {ply_b}"]
    for name in xml_a:
        diffs += compare_frame_xml(a / "frames" / name, b / "frames" / name)
    for name in ply_a:
        pa, pb = read_ply(a / "meshes" / name), read_ply(b / "meshes" / name)
        if not np.array_equal(np.asarray(pa.faces), np.asarray(pb.faces)):
            diffs.append(f"{name}: triangles differ")
        for field, tol in (("vertices", POSITION_TOL), ("vertex_velocities", VELOCITY_TOL),
                           ("vertex_normals", SMOOTH_NORMAL_TOLERANCE)):
            x, y = getattr(pa, field), getattr(pb, field)
            if (x is None) != (y is None) or (x is not None and (x.shape != y.shape or np.max(np.abs(x - y)) > tol)):
                diffs.append(f"{name}: {field} differ")
    return diffs


# ------------------------------------------------------------------------------------------- tests
def test_binary_route_writes_rigid_deforming_and_the_camera_track(blend, binary_export):
    _, version = blend
    anim = load_animation(binary_export)
    manifest = json.loads((binary_export / "animation.json").read_text())
    assert manifest["source"]["blender"] == version and manifest["source"]["radar_object"] == "scene camera 'cam'"
    assert anim.num_frames == FRAMES[1] - FRAMES[0] + 1 and anim.fps == FPS
    assert sorted(anim.object_names) == ["arm", "box", "flag"]
    shapes = anim.frame_xml(0).shapes
    assert sorted(shapes) == ["arm", "ball", "box", "flag", "floor"]
    box_files = {anim.frame_xml(i).shapes["box"].filename for i in range(anim.num_frames)}
    assert len(box_files) == 1                              # rigid: one PLY placed per frame
    for name in ("arm", "flag"):                            # deforming: a PLY per frame with vertex velocities
        assert len({anim.frame_xml(i).shapes[name].filename for i in range(anim.num_frames)}) == anim.num_frames
        assert all(anim.mesh(i, name).vertex_velocities is not None for i in range(1, anim.num_frames - 1))
    assert read_ply(shapes["ball"].filename).vertex_normals is not None   # smooth shading: normals, also in 3.x
    assert read_ply(shapes["arm"].filename).vertex_normals is not None
    # the moving camera is the radar: per-frame poses, looking along +x; the Bezier keys hold the
    # ends (0 and 0.2 m) and, by the symmetry of the ease, the middle frame at the midpoint
    assert anim.radar_moves
    xs = [anim.radar_pose_at(i).position[0] for i in range(anim.num_frames)]
    assert abs(xs[0]) < POSITION_TOL and abs(xs[-1] - 0.2) < POSITION_TOL and abs(xs[2] - 0.1) < POSITION_TOL
    assert np.all(np.diff(xs) > 0)
    assert np.max(np.abs(anim.radar_pose_at(2).orientation)) < ANGLE_TOL   # yaw = pitch = roll = 0: boresight +x
    anim.check_frequency(77e9)


def test_bpy_module_route_writes_the_same_directory(binary_export, module_export):
    manifest = json.loads((module_export / "animation.json").read_text())
    assert manifest["source"]["blender"].startswith("4.")
    assert compare_directories(binary_export, module_export) == []


def test_export_blend_runs_the_blender_binary(blend, binary_export, tmp_path):
    """The simulator-side launcher, given the binary, writes the same directory as the README's command."""
    path, _ = blend
    out = export_blend(path, tmp_path / "anim", blender=BLENDER, timeout=TIMEOUT)
    assert compare_directories(binary_export, out) == []


def test_addon_zip_installs_in_the_blender_binary_and_exports(blend, binary_export, tmp_path):
    path, _ = blend
    zip_path = addon_zip(tmp_path / "addon.zip")
    (tmp_path / "install.py").write_text(ADDON_SCRIPT)
    env = {**os.environ, "BLENDER_USER_SCRIPTS": str(tmp_path / "scripts")}
    env.pop("PYTHONPATH", None)
    out = tmp_path / "addon_anim"
    proc = run_blender(["--factory-startup", "--python-exit-code", "1", "-P", str(tmp_path / "install.py"), "--",
                        str(zip_path), str(path), str(out)], env=env)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("FACTS")]
    assert proc.returncode == 0 and lines, proc.stdout[-3000:] + proc.stderr[-3000:]
    facts = json.loads(lines[0][len("FACTS"):])
    installed = tmp_path / "scripts" / "addons" / ADDON_NAME
    assert facts["errors"] == [] and facts["result"] == ["FINISHED"]
    assert Path(facts["addon"]).parent == installed and Path(facts["ply"]).is_relative_to(installed)
    assert compare_directories(binary_export, out) == []


def test_binary_without_numpy_prints_one_line_with_the_fix(blend, tmp_path):
    path, _ = blend
    out = tmp_path / "anim"
    hide_numpy = "import sys; sys.modules['numpy'] = None"
    proc = run_blender([str(path), "--python-exit-code", "1", "--python-expr", hide_numpy,
                        "-P", str(script_path()), "--", str(out)])
    assert proc.returncode == 1
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(ERROR_MARKER + "numpy is not importable"), proc.stderr
    assert "Traceback" not in proc.stdout + proc.stderr
    if Path("/etc/debian_version").is_file():   # Debian and Ubuntu: the distribution's package
        assert "apt-get install python3-numpy" in lines[0]
    assert not out.exists() and not list(tmp_path.glob(".anim*"))
    # the add-on, enabled in that Blender, fails with the same line (and Blender reports it)
    env = {**os.environ, "BLENDER_USER_SCRIPTS": str(tmp_path / "scripts")}
    env.pop("PYTHONPATH", None)
    (tmp_path / "install.py").write_text(ADDON_SCRIPT)
    proc = run_blender(["--factory-startup", "--python-exit-code", "1", "-P", str(tmp_path / "install.py"), "--",
                        str(addon_zip(tmp_path / "addon.zip")), str(path), "-"], env=env)
    facts = [json.loads(ln[len("FACTS"):]) for ln in proc.stdout.splitlines() if ln.startswith("FACTS")]
    assert facts and len(facts[0]["errors"]) == 1, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert facts[0]["errors"][0] == lines[0][len(ERROR_MARKER):]


def test_bpy_module_without_numpy_prints_the_pip_fix(blend, tmp_path):
    """The bpy module's Python without numpy (import blocked as above): the exporter's last line, exit 1."""
    path, _ = blend
    python = BLENDER_VENV / "bin" / "python"
    code = ("import runpy, sys; sys.modules['numpy'] = None; sys.argv = sys.argv[1:]; "
            "runpy.run_path(sys.argv[0], run_name='__main__')")
    proc = subprocess.run([str(python), "-c", code, str(script_path()), str(path), str(tmp_path / "anim")],
                          capture_output=True, text=True, timeout=TIMEOUT, stdin=subprocess.DEVNULL)
    assert proc.returncode == 1
    ours = [ln for ln in proc.stderr.splitlines() if ln.startswith(ERROR_MARKER)]
    assert len(ours) == 1 and proc.stderr.strip().splitlines()[-1] == ours[0], proc.stderr
    assert f"{python} -m pip install \"numpy<2\"" in ours[0]
    assert not (tmp_path / "anim").exists()


def _exporter_module():
    spec = importlib.util.spec_from_file_location("sionnafmcw_export_maths", script_path())
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("prefix, binary, os_ids, expected", [
    ("/usr", "/usr/bin/blender", ("debian",), "apt-get install python3-numpy"),
    ("/usr", "/usr/bin/blender", ("ubuntu", "debian"), "apt-get install python3-numpy"),
    ("/usr", "/usr/bin/blender", ("fedora",), "dnf install python3-numpy"),
    ("/usr", "/usr/bin/blender", ("arch",), "pacman -S python-numpy"),
    ("/opt/blender-4.2.3-linux-x64/4.2/python", "/opt/blender-4.2.3-linux-x64/blender", ("debian",),
     "reinstall Blender from blender.org"),
    ("/Applications/Blender.app/Contents/Resources/4.2/python", "/Applications/Blender.app/Contents/MacOS/Blender",
     (), "reinstall Blender from blender.org"),
    ("/home/u/.venv-blender", "", ("debian",), "-m pip install \"numpy<2\""),
])
def test_numpy_fix_names_the_installation(prefix, binary, os_ids, expected):
    """Which fix each kind of Blender installation gets (distribution, Blender's own build, bpy module)."""
    message = _exporter_module().numpy_fix(prefix, prefix + "/bin/python3", "3.11", binary, (4, 5, 0), os_ids)
    assert expected in message and "\n" not in message and prefix in message


def test_blender_older_than_the_minimum_is_refused_with_the_version():
    exporter = _exporter_module()
    assert exporter.blender_too_old((3, 4, 1), "3.4.1") is None
    assert exporter.blender_too_old((4, 5, 15), "4.5.15") is None
    message = exporter.blender_too_old((3, 3, 21), "3.3.21")
    assert message is not None and "3.3.21" in message and "3.4" in message and "\n" not in message
    assert exporter.bl_info["blender"] == exporter.MIN_BLENDER


def test_binary_export_simulates_the_box_from_the_moving_camera(binary_export, tmp_path):
    """The box seen from the moving camera: range within half a range bin of the face at the CPI's middle,
    Doppler within half a Doppler bin of the store's truth (radial velocity relative to the radar).
    (Measured: 3-7 mm and 1 mm/s off; about 5 s for the two frames on 2 cores.)"""
    anim = load_animation(binary_export)
    radar = RadarConfig.preset("walk-77ghz")
    frames = [1, 2]
    ds = simulate(anim, radar, engine=PathEngine(samples_per_src=20_000), out=tmp_path / "run.zarr", frames=frames,
                  progress=False)
    track = processing.doppler_time(ds.iq.values[frames], radar)
    i_box = list(ds.object.values).index("box")
    for j, f in enumerate(frames):
        pose = anim.radar_pose_at(f)
        t_half = radar.cpi_duration / 2
        entry = json.loads((binary_export / "animation.json").read_text())["frames"][f]
        v_radar = np.asarray(entry["radar"]["velocity"])
        centre = world_phase_centre(radar, pose.position + v_radar * t_half, pose.orientation)
        face = anim.mesh(f, "box").centroid + anim.object_velocity(f, "box") * t_half - [BOX_HALF, 0.0, 0.0]
        r_true = float(np.linalg.norm(face - centre))
        v_true = float(ds.truth_radial_velocity.values[f, i_box])
        assert v_true > 0                                    # the box recedes faster than the camera follows
        assert abs(track.ranges[j] - r_true) < radar.range_resolution / 2, (f, track.ranges[j], r_true)
        assert abs(track.velocities[j] - v_true) < radar.velocity_resolution / 2, (f, track.velocities[j], v_true)
        assert math.copysign(1, track.velocities[j]) == 1


@pytest.mark.skipif(not BPY_PYTHON.exists(), reason=f"the bpy environment is not installed ({BPY_PYTHON}): "
                    "'make .venv-blender/.installed' makes it")
@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n == "90_18" else pytest.mark.slow) for n in sorted(BUSY)])
def test_mocap_route_in_the_blender_binary_writes_the_module_routes_directory(blend, tmp_path, name):
    """Five frames of a shipped clip where it moves most (the fall, 90_18, in the fast set), through
    Blender's BVH importer in the binary and in the bpy module: the same directory to float32 rounding.
    (Measured on every shipped clip, Debian's 3.4.1 against bpy 4.5.15: vertices 6e-7 m, ``to_world``
    entries 7e-7, velocities 2.3e-5 m/s, angular velocities 2.8e-5 rad/s apart at most.)"""
    _, version = blend
    person = MocapPerson(library.load_clip(name), fps=FPS, num_frames=5, start=BUSY[name], mesh_edge=0.06)
    radar, target = radar_in_front((0.0, 0.0), 0.0, 3.0, 1.0)
    orientation = radar_orientation(radar, target)
    bvh = library.clip_info(name).path
    binary = export_with_blender(person, bvh, tmp_path / "binary", radar, orientation, blender=BLENDER,
                                 timeout=TIMEOUT)
    module = export_with_blender(person, bvh, tmp_path / "module", radar, orientation, python=BPY_PYTHON,
                                 timeout=TIMEOUT)
    sources = [json.loads((d / "animation.json").read_text())["source"]["blender"] for d in (binary, module)]
    assert sources[0] == version and sources[1].startswith("4."), sources
    assert load_animation(binary).num_frames == person.num_frames
    assert compare_directories(binary, module) == []


def test_mocap_route_in_the_blender_binary_without_numpy_names_the_fix(tmp_path):
    """The BVH route in a Blender whose Python cannot import numpy (blocked as above, by a wrapper that
    runs the binary with the block first): the error is the exporter's one line, nothing is written."""
    wrapper = tmp_path / "blender-without-numpy"
    wrapper.write_text("#!/bin/sh\nexec " + shlex.quote(BLENDER) + " --python-expr "
                       + shlex.quote("import sys; sys.modules['numpy'] = None") + ' "$@"\n')
    wrapper.chmod(0o755)
    person = MocapPerson(library.load_clip("90_18"), fps=FPS, num_frames=3, start=BUSY["90_18"], mesh_edge=0.08)
    radar, target = radar_in_front((0.0, 0.0), 0.0, 3.0, 1.0)
    out = tmp_path / "anim"
    with pytest.raises(BlenderExportError) as info:
        export_with_blender(person, library.clip_info("90_18").path, out, radar, radar_orientation(radar, target),
                            blender=wrapper, timeout=TIMEOUT)
    message = str(info.value)
    assert "\n" not in message and message.endswith("bundle numpy"), message
    assert "the Blender route failed: numpy is not importable in the Python" in message
    assert "Traceback" not in message
    if Path("/etc/debian_version").is_file():
        assert "apt-get install python3-numpy" in message
    assert not out.exists() and not list(tmp_path.glob(".anim*"))
