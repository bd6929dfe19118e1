r"""The Blender side of the BVH route (runs inside Blender's Python; imports without ``bpy`` for the docs).

Run by :func:`sionnafmcw.mocap.blender_route.export_with_blender` as::

    python blender_script.py BODY.npz CLIP.bvh OUT EXPORTER.py        (a Python with the bpy module)
    blender -b --factory-startup -P blender_script.py -- BODY.npz CLIP.bvh OUT EXPORTER.py

Steps, all in a factory-empty scene:

1. Blender's own BVH importer (the add-on ``io_anim_bvh``, ``import_bvh.load``) builds the
   armature and its action from ``CLIP.bvh`` with the unit (``global_scale``) and the Y-up to Z-up
   axes (``global_matrix``) of ``BODY.npz``, pose rotations as quaternions (``rotate_mode=
   'QUATERNION'``; the importer keys them LINEAR). Its keys sit at Blender frame :math:`1 + k` for the
   clip's frame :math:`k`; they are moved to :math:`1 + (k\Delta\tau - \tau_0)\,\mathrm{fps}/r`, so that
   Blender frame :math:`f` shows clip time :math:`\tau_0 \pm r(f - 1)/\mathrm{fps}` (:mod:`.person`), and
   every bone's quaternion keys are put in one hemisphere (the importer does not: a sign flip
   between two keys would make the linear interpolation swing through the far side). The
   armature object gets the placement matrix.
2. With the armature at rest, every body segment (its vertices in the world at rest, from
   :class:`~sionnafmcw.mocap.segments.SegmentBody`) becomes a smooth-shaded mesh object parented to its
   bone (``parent_type='BONE'``) with the parent inverse of the bone's rest matrix: weighted fully
   to that bone, it follows the bone rigidly, and its world matrix is the joint's whatever length
   and direction the importer gives the bone (Blender 3.4's and 4.x's importers work out the tail of
   a joint with several children differently). Material ``skin`` with the radio material
   ``{"skin": "dry", "scattering_coefficient": s}``.
3. An empty ``radar`` at the radar pose (Euler XYZ = roll, pitch, yaw), and the exporter
   (:mod:`sionnafmcw.blender.export`, loaded from its path) writes Blender frames 1..N: each
   segment is a rigid object (one PLY, a ``to_world`` per frame), velocities by its central
   differences at :math:`\pm` ``velocity_step`` frames.

numpy (< 2) and bpy only. The exporter is loaded first: its import refuses, with one line naming
the fix, a Blender older than it supports or a Python without numpy, before anything is built.
"""

import builtins
import contextlib
import importlib.util
import json
import sys
import traceback

try:
    import numpy as np
except ImportError:  # a Blender's Python without numpy: the exporter's import names the fix (main)
    np = None
try:
    import bpy
    from mathutils import Matrix
except ImportError:  # imported for the documentation outside Blender
    bpy = None

ERROR_MARKER = "sionnafmcw-export: error: "


def _fcurves(action):
    try:
        return list(action.fcurves)
    except AttributeError:  # slotted actions without the legacy API
        return [fc for layer in action.layers for strip in layer.strips for bag in strip.channelbags
                for fc in bag.fcurves]


@contextlib.contextmanager
def _universal_newline_open(module):
    """Within the block, ``open`` in ``module`` (Blender's BVH importer) reads a mode ``'rU'`` as ``'r'``.

    Blender 3.4's ``io_anim_bvh`` (Debian 12's ``blender``) opens the clip with ``open(path, 'rU')``;
    4.5's with ``'r'``. The ``U`` asked for universal newlines (``\\r\\n`` and ``\\r`` read as ``\\n``),
    which text mode does by itself since Python 3.0; Python accepted the letter as a no-op until 3.11,
    which refuses it (``ValueError: invalid mode: 'rU'``), and a distribution's Blender 3.4 runs on its
    system's Python 3.11. ``'r'`` therefore reads the same characters the importer was written for.
    A module-level ``open`` shadows the built-in for that module only and only while the importer
    runs; Blender's files are not changed, and an importer that opens with ``'r'`` gets the built-in's
    behaviour unchanged.
    """
    def open_text(file, mode="r", *args, **kwargs):
        return builtins.open(file, mode.replace("U", ""), *args, **kwargs)

    had = "open" in vars(module)
    previous = vars(module).get("open")
    module.open = open_text
    try:
        yield
    finally:
        if had:
            module.open = previous
        else:
            del module.open


def _retime_and_align(action, frame_time, start, fps, rate):
    """Move every key from frame 1 + k to 1 + (k dt - start) fps / rate (rate < 0: the clip reversed,
    keys sorted again); align each bone's quaternion keys."""
    curves = _fcurves(action)
    for fc in curves:
        pts = fc.keyframe_points
        co = np.empty(2 * len(pts))
        pts.foreach_get("co", co)
        co = co.reshape(-1, 2)
        k = co[:, 0] - 1.0
        co[:, 0] = 1.0 + (k * frame_time - start) * fps / rate
        pts.foreach_set("co", co.ravel())
        pts.foreach_set("handle_left", co.ravel())
        pts.foreach_set("handle_right", co.ravel())
        for p in pts:
            p.interpolation = "LINEAR"
        fc.update()
    quats = {}
    for fc in curves:
        if fc.data_path.endswith("rotation_quaternion"):
            quats.setdefault(fc.data_path, {})[fc.array_index] = fc
    for path, comps in quats.items():
        if len(comps) != 4:
            continue
        vals = []
        for i in range(4):
            co = np.empty(2 * len(comps[i].keyframe_points))
            comps[i].keyframe_points.foreach_get("co", co)
            vals.append(co[1::2].copy())
        q = np.stack(vals, axis=1)
        for k in range(1, len(q)):
            if np.dot(q[k], q[k - 1]) < 0:
                q[k] *= -1.0
        for i in range(4):
            co = np.empty(2 * len(comps[i].keyframe_points))
            comps[i].keyframe_points.foreach_get("co", co)
            co[1::2] = q[:, i]
            comps[i].keyframe_points.foreach_set("co", co)
            comps[i].keyframe_points.foreach_set("handle_left", co)
            comps[i].keyframe_points.foreach_set("handle_right", co)
            comps[i].update()


def load_exporter(exporter_path):
    """The exporter (:mod:`sionnafmcw.blender.export`) as a module; its import refuses, with one line
    naming the fix (ImportError), a Blender older than it supports or a Python without numpy."""
    spec = importlib.util.spec_from_file_location("sionnafmcw_export", exporter_path)
    exporter = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(exporter)
    return exporter


def build_and_export(npz_path, bvh_path, out, exporter):
    data = np.load(npz_path, allow_pickle=False)
    meta = json.loads(str(data["meta"]))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    fps = float(meta["fps"])
    scene.render.fps = max(1, int(round(fps)))
    scene.render.fps_base = scene.render.fps / fps
    bpy.ops.preferences.addon_enable(module="io_anim_bvh")
    from io_anim_bvh import import_bvh

    before = set(bpy.data.objects)
    with _universal_newline_open(import_bvh):
        import_bvh.load(bpy.context, bvh_path, target="ARMATURE", rotate_mode="QUATERNION",
                        global_scale=float(meta["unit"]), frame_start=1, use_cyclic=False,
                        global_matrix=Matrix(data["axes4"].tolist()), use_fps_scale=False,
                        update_scene_fps=False, update_scene_duration=False)
    arms = [o for o in bpy.data.objects if o not in before and o.type == "ARMATURE"]
    if len(arms) != 1:
        raise RuntimeError(f"the BVH importer made {len(arms)} armatures")
    arm = arms[0]
    rate = float(meta["playback_rate"]) * (-1.0 if meta.get("reverse") else 1.0)
    _retime_and_align(arm.animation_data.action, float(meta["frame_time"]), float(meta["start"]), fps, rate)
    arm.matrix_world = Matrix(data["placement"].tolist())
    skin = bpy.data.materials.new("skin")
    skin["radio_material"] = json.dumps({"skin": "dry", "scattering_coefficient": float(meta["skin_scattering"])})
    arm.data.pose_position = "REST"
    bpy.context.view_layer.update()
    for k, (name, bone) in enumerate(zip(meta["segments"], meta["bones"])):
        verts, faces = data[f"v{k}"], data[f"f{k}"]
        me = bpy.data.meshes.new(name)
        me.from_pydata(verts.tolist(), [], faces.tolist())
        me.update()
        me.polygons.foreach_set("use_smooth", np.ones(len(me.polygons), dtype=bool))
        me.update()
        me.materials.append(skin)
        ob = bpy.data.objects.new(name, me)
        scene.collection.objects.link(ob)
        ob.parent = arm
        ob.parent_type = "BONE"
        ob.parent_bone = bone
        b = arm.data.bones[bone]
        rest = arm.matrix_world @ b.matrix_local @ Matrix.Translation((0.0, b.length, 0.0))
        ob.matrix_parent_inverse = rest.inverted()
        ob.matrix_basis = Matrix.Identity(4)
    arm.data.pose_position = "POSE"
    radar = bpy.data.objects.new("radar", None)
    scene.collection.objects.link(radar)
    radar.location = [float(x) for x in meta["radar_position"]]
    yaw, pitch, roll = (float(x) for x in meta["radar_orientation"])
    radar.rotation_mode = "XYZ"
    radar.rotation_euler = (roll, pitch, yaw)
    n = int(meta["num_frames"])
    scene.frame_start, scene.frame_end = 1, n
    bpy.context.view_layer.update()
    try:
        exporter.export_animation(out, 1, n, radar="radar", velocity_step=float(meta["velocity_step"]))
    except exporter.ExportError as err:
        raise RuntimeError(str(err)) from None


def main(argv=None) -> int:
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    if len(argv) != 4:
        print(ERROR_MARKER + "usage: blender_script.py BODY.npz CLIP.bvh OUT EXPORTER.py", file=sys.stderr)
        return 2
    try:
        exporter = load_exporter(argv[3])
    except ImportError as err:  # the exporter's own one-line refusal (old Blender, numpy missing)
        print(ERROR_MARKER + " ".join(str(err).split()), file=sys.stderr, flush=True)
        return 1
    try:
        build_and_export(*argv[:3], exporter)
        return 0
    except Exception as err:  # noqa: BLE001 - report everything on one marked line
        traceback.print_exc()
        print(ERROR_MARKER + " ".join(f"{type(err).__name__}: {err}".split()), file=sys.stderr, flush=True)
        return 1


if __name__ == "__main__":
    code = main()
    if code:
        sys.exit(code)
