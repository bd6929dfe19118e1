r"""The Blender route of a BVH clip: Blender's BVH importer drives the skeleton, the exporter writes the frames.

:func:`export_with_blender` hands a :class:`~.person.MocapPerson` (its clip, placement, timing and
segment body) to Blender in a subprocess (``.venv-blender``, any Python with ``bpy``, or a Blender
binary of 3.4 or newer, found as :func:`sionnafmcw.blender.find_runner` finds it) running
:mod:`.blender_script`: the armature
and its action come from ``io_anim_bvh``, not from :mod:`.skeleton`; only the body (the segments'
meshes at rest, each with the bone it is parented to) and the placement are shared. The exporter
(:mod:`sionnafmcw.blender.export`) then detects every segment as a rigid object and writes it once
with a ``to_world`` per frame.

The two routes agree (``tests/test_mocap_routes.py``): vertex positions to the exporter's rigid
tolerance (1e-5 m, float32 rounding through Blender's pose matrices and the PLYs), velocities to
twice that over the difference interval, plus, where the velocity samples fall between the clip's
frames, the difference between slerp and Blender's normalised linear interpolation
(:func:`~.skeleton.nlerp_deviation`). Run by Debian 12's ``blender`` 3.4.1 the route writes the
``bpy`` 4.5 module's directory to float32 rounding (``tests/test_blender_binary.py``).
"""

from __future__ import annotations

import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np

ERROR_MARKER = "sionnafmcw-export: error: "


def script_path() -> Path:
    """Path of the bpy script (:mod:`.blender_script`)."""
    return Path(__file__).resolve().with_name("blender_script.py")


def write_handoff(person, path, radar_position, radar_orientation, skin_scattering: float = 0.3) -> Path:
    """Write what the Blender side needs to ``path`` (an ``.npz``): the segments' world vertices at rest
    (placed) and faces, their bones, the axes, the placement and the timing."""
    motion = person.motion
    rest = motion.rest_positions()
    p_rot, p_t = person.placement[:3, :3], person.placement[:3, 3]
    arrays = {}
    names, bones = [], []
    for k, (name, seg) in enumerate(person.body.segments.items()):
        world = (seg.vertices + rest[seg.joint]) @ p_rot.T + p_t
        arrays[f"v{k}"] = world
        arrays[f"f{k}"] = np.asarray(seg.faces, np.int64)
        names.append(name)
        bones.append(motion.skeleton.names[seg.joint])
    axes4 = np.eye(4)
    axes4[:3, :3] = motion.axes
    meta = {"segments": names, "bones": bones, "fps": person.fps, "num_frames": person.num_frames,
            "start": person.start, "playback_rate": person.playback_rate, "reverse": person.reverse, "frame_time": person.clip.frame_time,
            "unit": motion.unit, "velocity_step": person.velocity_step, "skin_scattering": float(skin_scattering),
            "radar_position": [float(x) for x in radar_position],
            "radar_orientation": [float(x) for x in radar_orientation]}
    np.savez(path, meta=np.array(json.dumps(meta)), axes4=axes4, placement=person.placement, **arrays)
    return Path(path)


def blender_command(npz, bvh, out, python=None, blender=None) -> list[str]:
    """The command line that runs :mod:`.blender_script`."""
    from ..blender import find_runner, script_path as exporter_path

    kind, exe = find_runner(python, blender)
    args = [str(npz), str(bvh), str(out), str(exporter_path())]
    if kind == "python":
        return [exe, str(script_path())] + args
    return [exe, "-b", "--factory-startup", "--python-exit-code", "1", "-P", str(script_path()), "--"] + args


def export_with_blender(person, bvh, out, radar_position, radar_orientation, skin_scattering: float = 0.3,
                        room_box=None, python=None, blender=None, timeout: float | None = None) -> Path:
    """Write ``person`` (a :class:`~.person.MocapPerson` of the clip at ``bvh``) with Blender to the animation
    directory ``out`` (module docstring); raises :class:`~sionnafmcw.blender.BlenderExportError` with
    Blender's message when it fails."""
    from ..blender import BlenderExportError

    if room_box is not None:
        raise ValueError("the Blender route writes the person only; build the room in Blender (or use the numpy "
                         "route, which adds one)")
    out = Path(out).resolve()
    with tempfile.TemporaryDirectory(prefix="sionnafmcw-bvh-") as tmp:
        npz = write_handoff(person, Path(tmp) / "body.npz", radar_position, radar_orientation, skin_scattering)
        cmd = blender_command(npz, Path(bvh).resolve(), out, python, blender)
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)
        except FileNotFoundError as err:
            raise BlenderExportError(f"cannot run Blender with {cmd[0]!r}: {err.strerror or err}") from None
        except subprocess.TimeoutExpired as err:
            raise BlenderExportError(f"the Blender route for {bvh} took longer than {timeout} s",
                                     stdout=err.stdout, stderr=err.stderr) from None
    messages = [line[len(ERROR_MARKER):].strip() for line in (proc.stderr or "").splitlines()
                if line.startswith(ERROR_MARKER)]
    if proc.returncode != 0 or messages:
        text = "; ".join(messages) if messages else "\n".join(
            ((proc.stderr or "") + (proc.stdout or "")).strip().splitlines()[-20:])
        raise BlenderExportError(f"{bvh}: the Blender route failed: {text}", proc.returncode, proc.stdout, proc.stderr)
    manifest = out / "animation.json"
    data = json.loads(manifest.read_text())
    data["mocap"] = {"bvh": str(Path(bvh).resolve()), "route": "blender", "start_s": person.start,
                     "unit_m": person.motion.unit, "stature_m": person.body.height, "build": person.body.build}
    # the person's labels as the numpy route writes them (its keypoints: the routes agree on every vertex)
    from ..animation.people import people_entry
    from ..scenes.keypoints import KEYPOINTS
    from .library import clip_label

    data["people"] = people_entry(KEYPOINTS, [{"name": "person0", "prefix": "", "objects": person.segment_names,
                                               "activity": clip_label(str(bvh)), "height_m": person.body.height,
                                               "build": person.body.build, "keypoints": person.keypoints()}])
    manifest.write_text(json.dumps(data, indent=1))
    return out


__all__ = ["blender_command", "export_with_blender", "script_path", "write_handoff"]
