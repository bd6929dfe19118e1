r"""Blender -> sionnafmcw animation directory (layout: :mod:`sionnafmcw.animation`). Runs inside Blender's Python.

This file needs ``bpy``, ``mathutils``, numpy (< 2 inside Blender), the standard library and
the numpy-only parts of ``sionnafmcw``: the PLY, frame-XML and manifest writers of
:mod:`sionnafmcw.animation` and the atomic directory of :mod:`sionnafmcw.fs` (importing
``sionnafmcw`` loads nothing else). Run from a checkout, it puts the checkout on ``sys.path``;
installed as an add-on, it uses the copy of those modules bundled in the add-on's zip.

It runs in Blender 3.4 and newer (:data:`MIN_BLENDER`: Debian 12's ``blender`` 3.4.1 and the ``bpy``
4.5 module write the same directory to float32 rounding); an older Blender is refused with one
line naming the minimum. Blender's own builds bundle numpy; a distribution's Blender runs on the
system Python, whose numpy is a separate package (Debian/Ubuntu: ``python3-numpy``). Where numpy
cannot be imported the exporter prints one line naming the fix for that installation
(:func:`numpy_fix`) and exits with status 1 (as an add-on: the same line as an ImportError). Four
ways to run it:

* Blender binary::

      blender -b scene.blend --python-exit-code 1 -P sionnafmcw/blender/export.py -- OUT [--frames A:B] [--radar NAME]

* Blender as a Python module (the project's ``.venv-blender``, made by ``scripts/setup_blender.sh``
  or ``make .venv-blender/.installed``)::

      .venv-blender/bin/python sionnafmcw/blender/export.py scene.blend OUT [--frames A:B] [--radar NAME]

* From the simulator's environment (runs one of the above as a subprocess)::

      from sionnafmcw.blender import export_blend
      export_blend("scene.blend", "scenes/my_scene", frames=(1, 48))

* Inside a running Blender (Python console, or a script of yours), on the current scene::

      import importlib.util
      spec = importlib.util.spec_from_file_location("sionnafmcw_export", "/path/to/sionnafmcw/blender/export.py")
      exporter = importlib.util.module_from_spec(spec); spec.loader.exec_module(exporter)
      exporter.export_animation("/tmp/my_scene", frame_start=1, frame_end=48)

  or install the add-on (Edit > Preferences > Add-ons > Install from disk) and use
  File > Export > sionnafmcw radar animation. The add-on is a zip that bundles this file with the
  writers it imports; write it from the simulator's environment with
  ``python -c "from sionnafmcw.blender import addon_zip; addon_zip('sionnafmcw_export.zip')"``.

Options: ``--frames A:B`` exports Blender frames A to B, both included (default: the scene's
frame range); ``--radar NAME`` names the radar object (default ``radar``, else the scene camera);
``--velocity-step S`` the half-width of the central differences in frames (default 0.5).

What is written
---------------
``OUT/animation.json``, ``OUT/frames/NNNN.xml`` (one Mitsuba scene per exported frame, frame
index ``i = f - A`` at time :math:`t_i = i / \mathrm{fps}`, ``fps = scene.render.fps /
scene.render.fps_base``) and ``OUT/meshes/*.ply`` (binary little-endian: ``vertex`` x y z
float [+ nx ny nz float] [+ vx vy vz float], ``face`` list uchar int). A mesh file is written
once per distinct content: an object whose evaluated world geometry never changes has one file,
``meshes/<name>.ply``, shared by all frames; a **rigid** object -- one whose evaluated mesh is in
every frame a rigid motion of its first exported frame, to :data:`RIGID_TOLERANCE` (1e-5 m, see
:mod:`sionnafmcw.animation.rigid`: ten float32 roundings at 10 m, 0.03 rad of two-way phase at
77 GHz) by Kabsch's fit -- has one file too, the first frame's mesh, placed in every frame by a
``to_world`` matrix (a limb parented to a bone, a door, a car body: the mesh is written once and
the engines need not rebuild it per frame); a deforming one has ``meshes/<name>_NNNN.ply`` (NNNN:
the first frame that uses it). A mesh that is smooth-shaded in Blender (every corner normal equal
to its vertex normal: no sharp edges or split normals) carries its vertex normals (world frame of
its first frame for a rigid object; ``face_normals`` is then off in the XML): the surface those
normals describe is what physical optics renders, whatever the tessellation. The export goes to a hidden sibling directory that is renamed to
``OUT`` at the end (:func:`sionnafmcw.fs.atomic_directory`), so a failed export leaves nothing
half-written (an existing ``OUT`` is replaced only when it is empty or an earlier animation
directory).

Geometry
--------
Every object the view layer's depsgraph evaluates (objects visible in the viewport, with the
viewport settings of their modifiers, and instances from collections, particles or geometry
nodes) that has surface geometry (mesh, curve, surface, text, metaball) and is not disabled for
rendering (``hide_render``) is exported, except the radar object itself. Each is the evaluated
mesh (modifiers, shape keys and armatures applied), triangulated (Blender's loop triangles),
in world coordinates (metres, z up: Blender's world frame is Mitsuba/Sionna's). An object whose
triangles use several materials is split into one shape per material, named
``<object>/<material>``; otherwise the shape is named after the object (instances:
``<instancer>/<object>[<persistent id>]``). The shape id is ``mesh-<name>``, and ``<name>`` is
the name in the manifest and the run store's truth. Sionna keeps one scene per animation and
updates vertex positions per frame, so every exported object must exist in every frame with a
constant topology (vertex count and triangles); the exporter says which object breaks that.

Radio materials
---------------
A Blender material is mapped to a radio material by its custom property ``radio_material``
(Material Properties > Custom Properties; a string, or a dictionary set from Python):

* ``"itu:<type>"``, e.g. ``"itu:concrete"``, ``"itu:metal"``: an ``itu-radio-material`` of that
  ITU-R P.2040 type;
* ``"skin"`` (or ``"skin:dry"``), ``"skin:wet"``: a ``skin-radio-material`` (Gabriel 1996 Cole-Cole
  model, follows the carrier; see ``sionnafmcw.materials``);
* a JSON dict (or a dict set from Python), e.g. ``{"relative_permittivity": 5, "conductivity": 0.1,
  "scattering_coefficient": 0.3}``: a ``radio-material`` with these properties; with
  ``"itu": "<type>"`` an ITU material, with ``"skin": "dry" | "wet"`` skin, the other keys then
  adding scattering and thickness.

Dictionary keys: ``relative_permittivity``, ``conductivity`` (S/m), ``thickness`` (m),
``scattering_coefficient``, ``xpd_coefficient`` and the selectors ``itu`` / ``skin`` (Sionna RT
2.2 reads no scattering pattern from XML: diffuse reflection is Lambertian). Without the property, the material's *name* decides (Blender's ``.001``
suffixes ignored): ``itu_<type>`` (e.g. ``itu_concrete``) is that ITU material, ``skin`` /
``skin_dry`` / ``skin_wet`` is skin. Anything else stops the export with an error naming the
object, the material and this fix. ITU types valid at 77 GHz: concrete, plasterboard, wood,
glass, ceiling_board, chipboard, floorboard, metal (the simulator checks the carrier).

The XML material id is ``mat-<material name>``; where Sionna would misread that id (a name that
starts with ``itu_`` / ``itu-``, which Sionna replaces by its built-in ITU material and drops
the XML's scattering properties; a bare ITU type name such as ``concrete``, which Sionna
refuses; a custom material name such as ``skin``, which would override explicit properties; or
a name equal to an exported object's, since Sionna names objects and materials in one
namespace) it is ``mat-radio-<material name>`` (plus ``-2``, ``-3``... if still taken).

Velocities
----------
Let :math:`h` be the velocity step in frames (default 0.5) and :math:`\Delta = h/\mathrm{fps}`.
Frame :math:`f` is evaluated at :math:`f - h`, :math:`f` and :math:`f + h` with
``scene.frame_set(frame, subframe=...)`` (subframes are evaluated exactly like frames:
F-curves, drivers, shape keys and armatures are continuous in time). With :math:`\mathbf x(f)`
an evaluated world position,

.. math::
    \mathbf v(f) = \frac{\mathbf x(f + h) - \mathbf x(f - h)}{2\Delta},
    \qquad \mathbf v(f) - \dot{\mathbf x} = \frac{\Delta^2}{6}\,\dddot{\mathbf x} + O(\Delta^4)

for interior frames; at the first (last) exported frame the difference is one-sided,
:math:`(\mathbf x(f+h) - \mathbf x(f))/\Delta` (:math:`(\mathbf x(f) - \mathbf x(f-h))/\Delta`),
so nothing outside the exported range is evaluated (an animation usually holds still outside
its keyframes; a single exported frame uses the forward difference). :math:`h = 1/2` instead of
:math:`1` divides the truncation error by four and costs 2 instead of 1 evaluations per frame
(the half-frame samples are shared by neighbouring frames); it is exact for motion that is linear
within :math:`\pm h`, e.g. LINEAR keyframes away from a kink.

* Object velocity (manifest ``objects[name].velocity``): the derivative of the area-weighted
  centroid of the evaluated surface, :math:`\mathbf c = \sum_k A_k \mathbf m_k / \sum_k A_k`
  (triangle areas :math:`A_k`, centroids :math:`\mathbf m_k`; the same centroid the simulator
  takes as an object's truth position). The manifest lists every object that moves in some
  exported frame (a distinct mesh in some frame or a non-zero velocity), in every frame; objects
  that never move are not listed.
* Rigid objects: the manifest also gets the ``angular_velocity``
  :math:`\boldsymbol\omega = \log(\mathbf R(f+h)\mathbf R(f-h)^T)^\vee/(2\Delta)` of the fitted rotations
  at :math:`f \pm h` and the frame's ``to_world``; every point then moves at
  :math:`\mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c)` (no per-vertex velocities).
* Vertex velocity (PLY ``vx vy vz``) of a deforming object: the same difference per vertex, written in
  every frame where the field is not uniform, i.e. the mesh deforms or rotates (:math:`\max_i \|\mathbf v_i -
  \bar{\mathbf v}\| > 10^{-4}` m/s, 1/700 of a 7 cm/s Doppler bin). A mesh that only translates (or
  stands still) gets no per-vertex velocity: the simulator uses the manifest velocity, which is
  then the same for every point of it.

Radar pose
----------
The radar is the object named ``radar`` (``--radar NAME``), else the scene camera; its pose at
the first exported frame is the manifest's ``radar``. When it moves during the exported frames
(any change of its world matrix beyond :data:`RADAR_MOTION_TOLERANCE`), every frame also gets its
pose and motion, a radar track (``frames[i].radar``): position, orientation, the velocity
of its origin and the angular velocity of its axes from the same central differences at
:math:`\pm h` frames as the objects' (:func:`radar_motion`). ``position`` is the object's world origin. ``orientation`` =
(yaw, pitch, roll) (rad) with Sionna's :math:`\mathbf R = \mathbf R_z(\mathrm{yaw})\,
\mathbf R_y(\mathrm{pitch})\,\mathbf R_x(\mathrm{roll})`, whose columns are the radar's local
axes in the world: boresight :math:`\hat{\mathbf x}_r`, azimuth (left) :math:`\hat{\mathbf y}_r`,
up :math:`\hat{\mathbf z}_r`. See :func:`radar_axes` and :func:`orientation_from_rotation`.

* An empty (or any object that is not a camera) named ``radar``: local +X is the boresight,
  +Y the azimuth direction (left when looking along the boresight), +Z up. Blender's XYZ Euler
  :math:`(r_x, r_y, r_z)` is :math:`\mathbf R_z(r_z)\mathbf R_y(r_y)\mathbf R_x(r_x)`, so an
  unparented empty with rotation mode XYZ has exactly (yaw, pitch, roll) = :math:`(r_z, r_y, r_x)`.
  Positive pitch tilts the boresight down.
* A camera looks along its local -Z with +Y up and +X to the right of the image, so
  :math:`\hat{\mathbf x}_r = -\hat{\mathbf z}_c`, :math:`\hat{\mathbf z}_r = \hat{\mathbf y}_c`,
  :math:`\hat{\mathbf y}_r = \hat{\mathbf z}_r \times \hat{\mathbf x}_r = -\hat{\mathbf x}_c`
  (left of the image).
"""

import hashlib
import json
import math
import os
import re
import sys
import time
import traceback
from pathlib import Path

try:  # inside Blender (binary or bpy module); the pure maths below works without it
    import bpy
except ImportError:  # pragma: no cover - only for reading the maths outside Blender
    bpy = None

ERROR_MARKER = "sionnafmcw-export: error: "
#: The oldest Blender the exporter runs in: Debian 12's 3.4.1, the oldest the tests run
#: (tests/test_blender_binary.py exports the same scene with it and with bpy 4.5 and compares).
MIN_BLENDER = (3, 4, 0)


def blender_too_old(version, version_string):
    """The one-line refusal for a Blender older than :data:`MIN_BLENDER`, or None.

    (This file parses, and the code up to the numpy import runs, on the Python 3.7 of Blender 2.80 and
    later, so that an old Blender gets this line rather than a syntax or type error: no ``X | None``
    evaluated before the check.)"""
    if tuple(version[:3]) >= MIN_BLENDER:
        return None
    return (f"Blender {version_string} is older than {'.'.join(map(str, MIN_BLENDER))}, the oldest Blender this "
            "exporter is tested with: install Blender 3.4 or newer (blender.org, or a distribution's package of 3.4 "
            "or newer, e.g. Debian 12: apt-get install blender python3-numpy)")


def numpy_fix(prefix, executable, python_version, binary_path, blender_version=None, os_ids=()):
    """The one-line message for a Blender whose Python cannot import numpy, naming the fix for that installation.

    Three installations exist:

    * Blender's own builds (blender.org, Steam, snap) bundle a Python with numpy, at
      ``<blender>/<major.minor>/python``; numpy missing there means a damaged install;
    * a distribution's Blender (Debian, Ubuntu, Fedora, Arch...) runs on the system Python
      (``sys.prefix`` elsewhere), which has numpy only through the distribution's package
      (Debian/Ubuntu: ``python3-numpy``, not a dependency of ``blender`` there);
    * Blender as a Python module (``bpy``, ``binary_path`` empty): numpy comes from pip, and bpy 4.x
      is built against numpy 1.x.

    ``binary_path`` is None outside Blender (this file read for its maths).

    ``os_ids`` are ``ID`` and ``ID_LIKE`` of ``/etc/os-release`` (lower case).
    """
    where = f"the Python {python_version} at {prefix}"
    if binary_path is None:
        return f"numpy is not importable in {where}: install it ('{executable} -m pip install numpy')"
    if not binary_path:
        pin = '"numpy<2"' if blender_version is not None and tuple(blender_version) < (5, 0, 0) else "numpy"
        return (f"numpy is not importable in {where}, which runs Blender as the bpy module: install it with "
                f"'{executable} -m pip install {pin}' (the project's .venv-blender: bash scripts/setup_blender.sh)")
    parts = Path(prefix).parts
    bundled = len(parts) >= 2 and parts[-1].lower() == "python" and re.fullmatch(r"\d+\.\d+", parts[-2]) is not None
    if bundled:
        return (f"numpy is not importable in {where}, the Python bundled with this Blender ({binary_path}); "
                "Blender's own builds bundle numpy, so this installation is damaged: reinstall Blender from "
                f"blender.org, or run '{executable} -m pip install numpy'")
    ids = set(os_ids)
    if ids & {"debian", "ubuntu"}:
        command = "apt-get install python3-numpy"
    elif ids & {"fedora", "rhel", "centos"}:
        command = "dnf install python3-numpy"
    elif ids & {"arch"}:
        command = "pacman -S python-numpy"
    elif ids & {"suse", "opensuse"}:
        command = "zypper install python3-numpy"
    else:
        command = "install your distribution's numpy package for that Python"
    return (f"numpy is not importable in {where}, the system Python this Blender ({binary_path}) runs on; "
            f"your distribution packages numpy separately: {command} (as root), then run the export again; "
            "Blender's own builds (blender.org) bundle numpy")


def _os_ids() -> tuple:
    try:
        import platform
        info = platform.freedesktop_os_release()
    except (AttributeError, OSError):
        return ()
    return tuple(x.lower() for x in (info.get("ID", "") + " " + info.get("ID_LIKE", "")).split())


def _refuse(message):
    """Stop with ``message`` on one line: exit status 1 when run as a script (``blender -P``, or the bpy
    module's Python), ImportError when imported (an add-on being enabled, or importlib)."""
    if __name__ == "__main__":
        print(ERROR_MARKER + message, file=sys.stderr, flush=True)
        sys.exit(1)
    raise ImportError(message)


# bpy.app.version is a tuple in Blender (anything else: a stand-in, e.g. the documentation build's)
if bpy is not None and isinstance(getattr(bpy.app, "version", None), tuple) and \
        blender_too_old(bpy.app.version, bpy.app.version_string):
    _refuse(blender_too_old(bpy.app.version, bpy.app.version_string))
try:
    import numpy as np
except ImportError:
    _refuse(numpy_fix(sys.prefix, sys.executable, "%d.%d" % sys.version_info[:2],
                      bpy.app.binary_path if bpy is not None else None,
                      bpy.app.version if bpy is not None else None, _os_ids()))


def _put_sionnafmcw_on_path() -> None:
    """Make the numpy-only writers importable: the checkout this file is in (run as a script or
    loaded from its path), or the copy bundled next to it (the add-on zip, :func:`sionnafmcw.blender.addon_zip`)."""
    here = Path(__file__).resolve()
    for root in (here.parents[2] if len(here.parents) > 2 else None, here.parent):
        if root is not None and (root / "sionnafmcw" / "animation" / "__init__.py").is_file():
            if str(root) not in sys.path:
                sys.path.insert(0, str(root))
            return


_put_sionnafmcw_on_path()

from sionnafmcw.animation.frame_xml import write_frame_xml  # noqa: E402  (after the path set-up above)
from sionnafmcw.animation.manifest import write_animation  # noqa: E402
from sionnafmcw.animation.ply import ply_bytes  # noqa: E402
from sionnafmcw.animation.rigid import RIGID_TOLERANCE, angular_velocity, rigid_fit, transform_matrix  # noqa: E402
from sionnafmcw.fs import atomic_directory  # noqa: E402

bl_info = {
    "name": "sionnafmcw radar animation",
    "author": "sionnafmcw",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),  # MIN_BLENDER (Blender reads bl_info as a literal, without running this file)
    "location": "File > Export > sionnafmcw radar animation",
    "description": "Export the animated scene as a sionnafmcw animation directory (Mitsuba XML frames, "
                   "PLY meshes with vertex velocities, manifest with object velocities and radar pose)",
    "category": "Import-Export",
}

#: ITU-R P.2040 material types Sionna RT 2.2 knows (``ITU_MATERIALS_PROPERTIES``).
ITU_TYPES = ("vacuum", "concrete", "brick", "plasterboard", "wood", "glass", "ceiling_board", "chipboard",
             "plywood", "marble", "floorboard", "metal", "very_dry_ground", "medium_dry_ground", "wet_ground")
#: Custom material names sionnafmcw.materials attaches by id (must not be used for other materials).
CUSTOM_NAMES = ("skin", "skin_dry", "skin_wet")
SKIN_TISSUES = ("dry", "wet")
#: ``radio_material`` strings and material names (lower case) that mean skin, and their tissue.
SKIN_NAMES = {"skin": "dry", "skin:dry": "dry", "skin_dry": "dry", "skin-dry": "dry",
              "skin:wet": "wet", "skin_wet": "wet", "skin-wet": "wet"}
#: radio-material properties Sionna RT 2.2 reads from XML (its XML loader has no way to choose a
#: scattering pattern: diffuse scattering from XML is Lambertian).
FLOAT_KEYS = ("relative_permittivity", "conductivity", "thickness", "scattering_coefficient", "xpd_coefficient")
GEOMETRY_TYPES = ("MESH", "CURVE", "SURFACE", "FONT", "META")
#: Vertex-velocity spread (m/s) above which a mesh counts as deforming or rotating.
VELOCITY_SPREAD_TOLERANCE = 1e-4
#: Radar matrix change (m, or rad for the rotation part) reported as a moving radar.
RADAR_MOTION_TOLERANCE = 1e-6


class ExportError(Exception):
    """The scene cannot be exported; the message names the object / material and the fix."""


# ===================================================================================== radar pose
#: Radar axes in a camera's local frame: columns = boresight -Z, azimuth (left) -X, up +Y.
CAMERA_TO_RADAR = np.array([[0.0, -1.0, 0.0],
                            [0.0, 0.0, 1.0],
                            [-1.0, 0.0, 0.0]])


def _rotation_part(matrix_world) -> np.ndarray:
    r"""Proper rotation of a 4x4 world matrix (scale and shear removed by the polar decomposition
    :math:`\mathbf M_{3\times3} = \mathbf U\boldsymbol\Sigma\mathbf V^T \mapsto \mathbf U\mathbf V^T`)."""
    m = np.asarray(matrix_world, dtype=float)[:3, :3]
    u, s, vt = np.linalg.svd(m)
    if s.min() <= 1e-12 * max(s.max(), 1e-300):
        raise ExportError("the radar object's world matrix is singular (zero scale); give it a non-zero scale")
    r = u @ vt
    if np.linalg.det(r) < 0:
        raise ExportError("the radar object's world matrix mirrors (negative scale); the radar frame must be "
                          "right-handed: remove the negative scale")
    return r


def radar_axes(matrix_world, is_camera: bool) -> np.ndarray:
    r"""Rotation :math:`\mathbf R` (columns: boresight, azimuth/left, up, in world coordinates).

    For an empty, :math:`\mathbf R = \mathbf R_{obj}` (local +X boresight, +Z up). For a camera
    (looks along local -Z, +Y up), :math:`\mathbf R = \mathbf R_{cam}\,\mathbf C` with
    :math:`\mathbf C = [-\hat{\mathbf z}\;\; -\hat{\mathbf x}\;\; \hat{\mathbf y}]`
    (:data:`CAMERA_TO_RADAR`, a proper rotation: :math:`(-\hat{\mathbf z})\times(-\hat{\mathbf x})
    = \hat{\mathbf y}`).
    """
    r = _rotation_part(matrix_world)
    return r @ CAMERA_TO_RADAR if is_camera else r


def orientation_from_rotation(rotation) -> tuple[float, float, float]:
    r"""(yaw, pitch, roll) (rad) of :math:`\mathbf R = \mathbf R_z(\alpha)\mathbf R_y(\beta)\mathbf R_x(\gamma)`.

    .. math::
        \mathbf R = \begin{pmatrix}
            c_\alpha c_\beta & c_\alpha s_\beta s_\gamma - s_\alpha c_\gamma & c_\alpha s_\beta c_\gamma + s_\alpha s_\gamma\\
            s_\alpha c_\beta & s_\alpha s_\beta s_\gamma + c_\alpha c_\gamma & s_\alpha s_\beta c_\gamma - c_\alpha s_\gamma\\
            -s_\beta & c_\beta s_\gamma & c_\beta c_\gamma \end{pmatrix}

    so :math:`\beta = \operatorname{atan2}(-R_{20}, \sqrt{R_{00}^2 + R_{10}^2}) \in [-\pi/2, \pi/2]`,
    :math:`\alpha = \operatorname{atan2}(R_{10}, R_{00})`, :math:`\gamma = \operatorname{atan2}(R_{21}, R_{22})`.
    At gimbal lock (:math:`c_\beta = 0`, boresight straight up or down) only :math:`\alpha \mp \gamma`
    is defined: :math:`\gamma = 0` and :math:`\alpha = \operatorname{atan2}(-R_{01}, R_{11})` (the
    second column is then :math:`(-s_\alpha, c_\alpha, 0)`).
    """
    r = np.asarray(rotation, dtype=float)
    cos_pitch = math.hypot(r[0, 0], r[1, 0])
    pitch = math.atan2(-r[2, 0], cos_pitch)
    if cos_pitch > 1e-9:
        yaw = math.atan2(r[1, 0], r[0, 0])
        roll = math.atan2(r[2, 1], r[2, 2])
    else:
        yaw = math.atan2(-r[0, 1], r[1, 1])
        roll = 0.0
    return yaw, pitch, roll


def radar_motion(matrix_now, matrix_before, matrix_after, span: float, is_camera: bool) -> dict:
    r"""A frame's radar track entry: :func:`radar_pose_from_matrix` of ``matrix_now`` plus ``velocity``
    :math:`(\mathbf p_+ - \mathbf p_-)/\Delta t` and ``angular_velocity``
    :math:`\log(\mathbf R_+\mathbf R_-^T)^\vee/\Delta t` (:func:`~sionnafmcw.animation.rigid.angular_velocity`,
    of the radar axes) from the world matrices ``span`` seconds apart (zero when ``span`` is 0)."""
    entry = radar_pose_from_matrix(matrix_now, is_camera)
    if span > 0:
        before, after = np.asarray(matrix_before, float), np.asarray(matrix_after, float)
        entry["velocity"] = [float(x) for x in (after[:3, 3] - before[:3, 3]) / span]
        omega = angular_velocity(radar_axes(after, is_camera), radar_axes(before, is_camera), span)
        entry["angular_velocity"] = [float(x) for x in omega]
    else:
        entry["velocity"] = [0.0, 0.0, 0.0]
        entry["angular_velocity"] = [0.0, 0.0, 0.0]
    return entry


def radar_pose_from_matrix(matrix_world, is_camera: bool) -> dict:
    """Manifest ``radar`` entry ``{"position": [x, y, z], "orientation": [yaw, pitch, roll]}`` of a world matrix."""
    m = np.asarray(matrix_world, dtype=float)
    yaw, pitch, roll = orientation_from_rotation(radar_axes(m, is_camera))
    return {"position": [float(x) for x in m[:3, 3]], "orientation": [yaw, pitch, roll]}


# ===================================================================================== materials
_SUFFIX = re.compile(r"\.\d{3,}$")


def parse_radio_material(value, where: str = "") -> tuple:
    """``(bsdf_type, {prop: (xml_tag, value)})`` of a ``radio_material`` value (string or dict)."""
    pre = f"{where}: " if where else ""
    if hasattr(value, "to_dict"):  # an IDPropertyGroup set from Python
        value = value.to_dict()
    if isinstance(value, str):
        text = value.strip()
        if text.startswith("{"):
            try:
                value = json.loads(text)
            except json.JSONDecodeError as err:
                raise ExportError(f"{pre}radio_material {text!r} is not valid JSON ({err})") from None
        else:
            low = text.lower()
            if low.startswith("itu:") or low.startswith("itu_"):
                return _itu(text[4:].strip(), {}, pre)
            if low in SKIN_NAMES:
                return _skin(SKIN_NAMES[low], {})
            raise ExportError(
                f"{pre}radio_material {text!r} is not understood; use 'itu:<type>' (e.g. 'itu:concrete'), 'skin', "
                "'skin:wet' or a JSON dict such as "
                '{"relative_permittivity": 5, "conductivity": 0.1, "scattering_coefficient": 0.3}'
            )
    if not isinstance(value, dict):
        raise ExportError(f"{pre}radio_material must be a string or a dict, got {type(value).__name__}")
    props = {}
    selector = None
    for key, val in value.items():
        if key in ("itu", "skin"):
            if selector is not None:
                raise ExportError(f"{pre}radio_material has both 'itu' and 'skin'; choose one")
            selector = (key, val)
        elif key in FLOAT_KEYS:
            try:
                x = float(val)
            except (TypeError, ValueError):
                raise ExportError(f"{pre}radio_material {key}={val!r} is not a number") from None
            if not math.isfinite(x) or x < 0 or (key == "relative_permittivity" and x < 1) or \
                    (key in ("scattering_coefficient", "xpd_coefficient") and x > 1):
                raise ExportError(f"{pre}radio_material {key}={val!r} is out of range")
            props[key] = ("float", x)
        else:
            raise ExportError(
                f"{pre}radio_material key {key!r} is unknown; known: "
                f"{', '.join(('itu', 'skin') + FLOAT_KEYS)}"
            )
    if selector is None:
        if "relative_permittivity" not in props and "conductivity" not in props:
            raise ExportError(f"{pre}radio_material dict needs relative_permittivity and/or conductivity "
                              "(or 'itu': '<type>' / 'skin': 'dry'); without them Sionna loads vacuum")
        return "radio-material", props
    key, val = selector
    for forbidden in ("relative_permittivity", "conductivity"):
        if forbidden in props:
            raise ExportError(f"{pre}radio_material: {forbidden} cannot be set for an '{key}' material "
                              "(its model sets it)")
    if key == "itu":
        return _itu(str(val), props, pre)
    if val not in SKIN_TISSUES:
        raise ExportError(f"{pre}radio_material skin tissue {val!r} is unknown; choose one of {', '.join(SKIN_TISSUES)}")
    return _skin(val, props)


def _skin(tissue: str, props: dict) -> tuple:
    return "skin-radio-material", {"tissue": ("string", tissue), **props}


def _itu(itu_type: str, props: dict, pre: str) -> tuple:
    if itu_type not in ITU_TYPES:
        raise ExportError(f"{pre}ITU material type {itu_type!r} is unknown to Sionna; known: {', '.join(ITU_TYPES)}")
    return "itu-radio-material", {"type": ("string", itu_type), **props}


def radio_material_of(material, object_name: str) -> tuple:
    """Radio material of a Blender material (custom property ``radio_material``, else its name)."""
    if material is None:
        raise ExportError(
            f"object {object_name!r} has triangles without a material; give it a material with a custom property "
            "radio_material (e.g. 'itu:concrete', 'itu:metal', 'skin', or a JSON dict of radio-material properties)"
        )
    where = f"object {object_name!r}, material {material.name!r}"
    if "radio_material" in material.keys():
        return parse_radio_material(material["radio_material"], where)
    base = _SUFFIX.sub("", material.name)
    low = base.lower()
    if low.startswith("itu_") or low.startswith("itu-"):
        return _itu(low[4:], {}, f"{where} (by its name)")
    if low in SKIN_NAMES:
        return _skin(SKIN_NAMES[low], {})
    raise ExportError(
        f"{where} has no radio material. Fix: add the custom property 'radio_material' to material "
        f"{material.name!r} (Material Properties > Custom Properties), e.g. 'itu:concrete', 'itu:metal', 'skin' or "
        '{"relative_permittivity": 5, "conductivity": 0.1, "scattering_coefficient": 0.3}, or rename the material '
        "itu_<type> (e.g. itu_wood) or skin"
    )


def _material_ids(material_names, object_names) -> dict:
    """``{Blender material name: XML id}``: ``mat-<name>``, or ``mat-radio-<name>`` where Sionna would misread it."""
    taken = set(object_names)
    ids = {}
    for name in sorted(material_names):
        short = name
        # Sionna's and sionnafmcw's tests are case-sensitive (scene_utils, materials._custom_name)
        if name.startswith("itu_") or name.startswith("itu-") or name in ITU_TYPES or \
                name.replace("-", "_") in CUSTOM_NAMES or name in taken:
            short = f"radio-{name}"
        candidate, k = short, 2
        while candidate in taken:
            candidate = f"{short}-{k}"
            k += 1
        taken.add(candidate)
        ids[name] = f"mat-{candidate}"
    return ids


# ===================================================================================== evaluation
class _Part:
    """One exported shape in one evaluated sample: world vertices, triangles, its material and, for a
    smooth-shaded mesh, its world vertex normals."""

    __slots__ = ("vertices", "triangles", "material", "radio", "normals")

    def __init__(self, vertices, triangles, material, radio, normals=None):
        self.vertices = vertices      # [V, 3] float64, world (m)
        self.triangles = triangles    # [F, 3] int32
        self.material = material      # Blender material name
        self.radio = radio            # (bsdf type, {prop: (xml tag, value)})
        self.normals = normals        # [V, 3] unit world vertex normals, or None (flat or split normals)

    def centroid(self) -> np.ndarray:
        """Area-weighted surface centroid (vertex mean for a mesh without area)."""
        tri = self.vertices[self.triangles]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        total = area.sum()
        if total > 0:
            return (tri.mean(axis=1) * area[:, None]).sum(axis=0) / total
        return self.vertices.mean(axis=0)


class _Sample:
    def __init__(self, time_frames, parts, radar_matrix):
        self.time = time_frames
        self.parts = parts                # {name: _Part}
        self.radar_matrix = radar_matrix  # 4x4 or None


def _frame_set(scene, t: float) -> None:
    f = math.floor(t)
    scene.frame_set(int(f), subframe=float(t - f))


def _materials_of(obj, mesh) -> list:
    """Materials per material index of an evaluated mesh (object-linked slots override data)."""
    mats = list(mesh.materials)
    slots = obj.material_slots
    out = []
    for i in range(max(len(mats), len(slots))):
        mat = mats[i] if i < len(mats) else None
        if i < len(slots) and slots[i].link == "OBJECT":
            mat = slots[i].material
        out.append(mat)
    return out


#: Largest difference between a corner normal and its vertex normal for a mesh to count as smooth
#: (one normal per vertex): 1e-4, well above float32 rounding and below any real split or sharp edge.
SMOOTH_NORMAL_TOLERANCE = 1e-4


def _smooth_vertex_normals(mesh, nv):
    """Unit vertex normals ``[V, 3]`` (object space) of a mesh whose every corner normal equals its
    vertex normal (smooth shading, no sharp edges or custom split normals), else None: such a mesh's
    surface is the smooth one its normals describe, which the engines rebuild for physical optics.

    Blender >= 4.1 keeps the corner ("split") normals in ``Mesh.corner_normals``; older ones compute
    them on request (``Mesh.calc_normals_split``) into ``MeshLoop.normal``, and keep the vertex
    normals in ``MeshVertex.normal``. Both are the same quantities (auto smooth by angle of a 3.x
    file becomes a "Smooth by Angle" modifier in 4.1+, which marks the same sharp edges), so every
    supported Blender writes the same normals."""
    nl = len(mesh.loops)
    loop_vertex = np.empty(nl, dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", loop_vertex)
    corner = np.empty(3 * nl, dtype=np.float32)
    vertex = np.empty(3 * nv, dtype=np.float32)
    if hasattr(mesh, "corner_normals"):
        mesh.corner_normals.foreach_get("vector", corner)
        mesh.vertex_normals.foreach_get("vector", vertex)
    else:
        mesh.calc_normals_split()
        mesh.loops.foreach_get("normal", corner)
        mesh.vertices.foreach_get("normal", vertex)
    corner, vertex = corner.reshape(-1, 3), vertex.reshape(-1, 3)
    if nl == 0 or np.max(np.abs(corner - vertex[loop_vertex])) > SMOOTH_NORMAL_TOLERANCE:
        return None
    return vertex.astype(float)


def _mesh_arrays(obj, matrix_world):
    """World vertices [V,3] float64, triangles [F,3] int32, material index [F] of an evaluated object,
    and its world vertex normals [V,3] where it is smooth-shaded (:func:`_smooth_vertex_normals`)."""
    mesh = obj.to_mesh()
    try:
        nv = len(mesh.vertices)
        co = np.empty(3 * nv, dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
        mesh.calc_loop_triangles()
        nt = len(mesh.loop_triangles)
        tri = np.empty(3 * nt, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", tri)
        mat_index = np.empty(nt, dtype=np.int32)
        mesh.loop_triangles.foreach_get("material_index", mat_index)
        materials = _materials_of(obj, mesh)
        normals = _smooth_vertex_normals(mesh, nv)
    finally:
        obj.to_mesh_clear()
    m = np.asarray(matrix_world, dtype=float)
    world = co.reshape(-1, 3).astype(float) @ m[:3, :3].T + m[:3, 3]
    if normals is not None:   # normals transform with the inverse transpose
        normals = normals @ np.linalg.inv(m[:3, :3])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = normals / np.where(length > 0, length, 1.0) if np.all(length > 0) else None
    return world, tri.reshape(-1, 3), mat_index, materials, normals


def _instance_name(inst) -> str:
    pid = ".".join(str(x) for x in inst.persistent_id if x != 2147483647)
    return f"{inst.parent.original.name}/{inst.object.original.name}[{pid}]"


def _evaluate(scene, t: float, radar_obj) -> _Sample:
    """Evaluate the scene at frame time ``t`` (frames, fractional allowed)."""
    _frame_set(scene, t)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    parts = {}
    radar_name = radar_obj.name if radar_obj is not None else None
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type not in GEOMETRY_TYPES:
            continue
        orig = ob.original
        if inst.is_instance:
            if inst.parent.original.hide_render or inst.parent.original.name == radar_name:
                continue
            name = _instance_name(inst)
        else:
            if orig.hide_render or orig.name == radar_name:
                continue
            name = orig.name
        world, tri, mat_index, materials, normals = _mesh_arrays(ob, inst.matrix_world)
        if len(tri) == 0:
            continue
        if not materials:
            radio_material_of(None, name)  # raises
        mat_index = np.clip(mat_index, 0, len(materials) - 1)  # as Blender renders: last slot
        used = np.unique(mat_index)
        by_material, specs = {}, {}
        for k in used:
            mat = materials[int(k)]
            specs[getattr(mat, "name", None)] = radio_material_of(mat, name)  # the error names object + material
            by_material.setdefault(mat.name, []).append(int(k))
        split = len(by_material) > 1
        for mat_name, indices in by_material.items():
            sel = np.isin(mat_index, indices)
            t_part = tri[sel]
            if split:
                keep = np.unique(t_part)
                remap = np.full(len(world), -1, dtype=np.int64)
                remap[keep] = np.arange(len(keep))
                v_part, t_part = world[keep], remap[t_part].astype(np.int32)
                n_part = None if normals is None else normals[keep]
                part_name = f"{name}/{mat_name}"
            else:
                v_part, n_part, part_name = world, normals, name
            if part_name in parts:
                raise ExportError(f"two exported shapes would be named {part_name!r} (an object of that name and a "
                                  "part of a multi-material object, or instances); rename one of the objects")
            parts[part_name] = _Part(v_part, np.ascontiguousarray(t_part), mat_name, specs[mat_name], n_part)
    radar_matrix = None
    if radar_obj is not None:
        radar_matrix = np.array(radar_obj.evaluated_get(depsgraph).matrix_world, dtype=float)
    return _Sample(t, parts, radar_matrix)


def _check_same_topology(a: _Sample, b: _Sample) -> None:
    names_a, names_b = set(a.parts), set(b.parts)
    if names_a != names_b:
        gone, new = sorted(names_a - names_b), sorted(names_b - names_a)
        raise ExportError(
            f"the set of exported objects changes between frame {a.time:g} and {b.time:g} (gone: {gone or 'none'}, "
            f"new: {new or 'none'}; an object is not exported where it is hidden or has no triangles); the simulator "
            "keeps one scene per animation: keep every object, with triangles, in every exported frame (animate its "
            "position instead of hiding it) or export a frame range where the set is constant"
        )
    for name, pa in a.parts.items():
        pb = b.parts[name]
        if pa.vertices.shape != pb.vertices.shape or pa.triangles.shape != pb.triangles.shape or \
                not np.array_equal(pa.triangles, pb.triangles):
            raise ExportError(
                f"object {name!r} changes its topology between frame {a.time:g} and {b.time:g} "
                f"({len(pa.vertices)} -> {len(pb.vertices)} vertices, {len(pa.triangles)} -> {len(pb.triangles)} "
                "triangles); vertex velocities and the simulator's per-frame mesh updates need a constant vertex count "
                "and triangle list: disable or apply the modifier that changes it (Remesh, Decimate, Boolean, "
                "adaptive subdivision, geometry nodes that create geometry, particles)"
            )


# ===================================================================================== file names
def _safe_filename(name: str) -> str:
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "object"
    return safe[:100]


def parse_frames(text):
    """``"A:B"`` (both included), ``"A"``, ``"A:"``, ``":B"`` -> ``(A | None, B | None)``."""
    if text is None:
        return None, None
    if isinstance(text, (tuple, list)):
        if len(text) != 2:
            raise ExportError(f"frames must be (start, end), got {text!r}")
        return (None if text[0] is None else int(text[0])), (None if text[1] is None else int(text[1]))
    s = str(text).strip()
    try:
        if ":" in s:
            a, b = s.split(":", 1)
            return (int(a) if a.strip() else None), (int(b) if b.strip() else None)
        return int(s), int(s)
    except ValueError:
        raise ExportError(f"--frames {text!r}: expected A:B with integer Blender frames (both included)") from None


def _find_radar(scene, radar: str | None):
    if radar:
        obj = scene.objects.get(radar)
        if obj is not None:
            return obj, obj.type == "CAMERA", f"object {radar!r}"
        if radar != "radar":
            raise ExportError(f"no object named {radar!r} in scene {scene.name!r} for the radar; "
                              f"objects: {', '.join(sorted(o.name for o in scene.objects)) or 'none'}")
    if scene.camera is not None:
        return scene.camera, scene.camera.type == "CAMERA", f"scene camera {scene.camera.name!r}"
    raise ExportError(
        f"scene {scene.name!r} has no radar: add an empty named 'radar' (its local +X is the boresight, +Z up) or "
        "set a scene camera (the radar looks along the camera's view), or pass --radar NAME"
    )


def _check_output(out: Path) -> None:
    """Refuse an ``out`` that is a file or a non-empty directory other than an animation directory."""
    if out.exists():
        if not out.is_dir():
            raise ExportError(f"{out} exists and is not a directory; choose another output path")
        if any(out.iterdir()) and not (out / "animation.json").is_file():
            raise ExportError(f"{out} is a non-empty directory that is not an animation directory; "
                              "refusing to replace it: choose another output path")


def export_animation(out, frame_start=None, frame_end=None, radar: str | None = "radar",
                     velocity_step: float = 0.5, log=None) -> Path:
    """Export the current scene (``bpy.context.scene``) to the animation directory ``out``.

    Parameters
    ----------
    out : output directory (created; replaced if it is an earlier animation directory)
    frame_start, frame_end : Blender frames, both included (default: the scene's frame range)
    radar : name of the radar object (default ``"radar"``; if there is no such object the scene
        camera is used)
    velocity_step : half-width :math:`h` of the central differences in frames, ``0 < h <= 1``
    log : callable taking a line of progress text (default: print to stdout)

    Returns
    -------
    Path
        The animation directory.

    Raises
    ------
    ExportError
        With a message that names the object, material or setting to fix.
    """
    if bpy is None:
        raise ExportError("export_animation runs inside Blender (bpy)")
    log = log if log is not None else (lambda s: print(s, flush=True))
    scene = bpy.context.scene
    a = scene.frame_start if frame_start is None else int(frame_start)
    b = scene.frame_end if frame_end is None else int(frame_end)
    if b < a:
        raise ExportError(f"frame range {a}:{b} is empty (end before start)")
    h = float(velocity_step)
    if not (0.0 < h <= 1.0):
        raise ExportError(f"velocity_step must be in (0, 1] frames, got {velocity_step!r}")
    fps = scene.render.fps / scene.render.fps_base
    radar_obj, is_camera, radar_desc = _find_radar(scene, radar)
    out = Path(out).expanduser().resolve()
    original_frame = (scene.frame_current, scene.frame_subframe)
    _check_output(out)
    t0 = time.perf_counter()
    try:
        with atomic_directory(out, replace=True) as tmp:
            (tmp / "frames").mkdir()
            (tmp / "meshes").mkdir()
            result = _export(scene, tmp, a, b, h, fps, radar_obj, is_camera, radar_desc, log)
    finally:
        scene.frame_set(original_frame[0], subframe=original_frame[1])
    log(f"sionnafmcw-export: {out}: {result['frames']} frames at {fps:g} fps, {result['objects']} objects "
        f"({result['moving']} moving: {result['rigid']} rigid, {result['deforming']} with vertex velocities), "
        f"{result['files']} PLY files, "
        f"radar = {radar_desc}, {time.perf_counter() - t0:.1f} s")
    return out


class _Rigid:
    """An object that has been a rigid motion of its first exported mesh in every frame so far."""

    __slots__ = ("reference", "normals", "motions", "radius")

    def __init__(self, part: _Part):
        self.reference = part.vertices          # [V, 3] world vertices of the first frame (the PLY's frame)
        self.normals = part.normals             # [V, 3] or None, same frame
        self.motions = []                       # per frame: (R, p, centroid velocity, angular velocity)
        self.radius = float(np.max(np.linalg.norm(part.vertices - part.centroid(), axis=1))) if len(
            part.vertices) else 0.0             # farthest vertex from the centroid (m)

    def spin(self, omega):
        """``omega``, or zero where it moves no vertex by more than VELOCITY_SPREAD_TOLERANCE (the
        float32 noise of a translating object's fitted rotations; the rule that gives a translating
        mesh no vertex velocities)."""
        return omega if np.linalg.norm(omega) * self.radius > VELOCITY_SPREAD_TOLERANCE else np.zeros(3)

    def fit(self, vertices):
        """``(R, p)`` of ``vertices`` as a rigid motion of the reference, or None beyond the tolerance."""
        r, p, residual = rigid_fit(self.reference, vertices)
        return (r, p) if residual <= RIGID_TOLERANCE else None


def _export(scene, tmp, a, b, h, fps, radar_obj, is_camera, radar_desc, log) -> dict:
    key = lambda t: round(t, 9)  # noqa: E731
    cache: dict = {}

    def sample(t):
        k = key(t)
        if k not in cache:
            cache[k] = _evaluate(scene, t, radar_obj)
        return cache[k]

    first = None
    frames = []                       # per frame: {"shapes": {name: (kind, data, material)}, "objects": {name: entry}}
    files: dict = {}                  # name -> {sha1: file stem}
    materials_used: dict = {}         # Blender material name -> radio spec
    safe_names: dict = {}
    taken_safe: set = set()
    deforming = set()
    ever_moving = set()
    rigid: dict = {}                  # name -> _Rigid while every frame so far is a rigid motion of the first
    radar_matrix0 = None
    radar_moves = False
    radar_track = []                  # per frame: the radar's manifest entry with its motion

    def safe_name(name):
        if name not in safe_names:
            safe = _safe_filename(name)
            candidate, k = safe, 2
            while candidate.lower() in taken_safe:
                candidate = f"{safe}-{k}"
                k += 1
            taken_safe.add(candidate.lower())
            safe_names[name] = candidate
        return safe_names[name]

    def write_mesh(name, i, vertices, triangles, vertex_velocity, normals):
        data = ply_bytes(vertices, triangles, vertex_velocity, vertex_normals=normals)
        digest = hashlib.sha1(data).hexdigest()
        known = files.setdefault(name, {})
        if digest not in known:
            stem = f"{safe_name(name)}_{i:04d}"
            (tmp / "meshes" / f"{stem}.ply").write_bytes(data)
            known[digest] = stem
        return known[digest]

    def unrigid(name, triangles):
        """``name`` stopped being rigid: its earlier frames become per-frame meshes, placed from the reference
        (within RIGID_TOLERANCE of the evaluated ones) with the rigid velocity field."""
        state = rigid.pop(name)
        for j, (r, p, v_c, omega) in enumerate(state.motions):
            vertices = state.reference @ r.T + p
            centroid = _Part(vertices, triangles, None, None).centroid()
            field = v_c + np.cross(omega, vertices - centroid) if np.any(omega != 0) else None
            normals = None if state.normals is None else state.normals @ r.T
            if field is not None:
                deforming.add(name)
            kind, _, mat = frames[j]["shapes"][name]
            frames[j]["shapes"][name] = ("ply", write_mesh(name, j, vertices, triangles, field, normals), mat)
            frames[j]["objects"][name] = v_c

    for f in range(a, b + 1):
        i = f - a
        tp = f - h if f > a else f
        tn = f + h if (f < b or a == b) else f
        sp, sc, sn = sample(tp), sample(f), sample(tn)
        for s1, s2 in ((sp, sc), (sc, sn)):
            if s1 is not s2:
                _check_same_topology(s1, s2)
        if first is None:
            first = sc
            if not sc.parts:
                raise ExportError(f"frame {f} of scene {scene.name!r} has no exportable geometry (no visible mesh, "
                                  "curve or text objects with triangles)")
            rigid = {name: _Rigid(part) for name, part in sc.parts.items()}
        else:
            _check_same_topology(first, sc)
        span = (tn - tp) / fps  # seconds between the two samples
        if sc.radar_matrix is not None:
            if radar_matrix0 is None:
                radar_matrix0 = sc.radar_matrix
            elif np.max(np.abs(sc.radar_matrix - radar_matrix0)) > RADAR_MOTION_TOLERANCE:
                radar_moves = True
            for other in (sp, sn):
                if np.max(np.abs(other.radar_matrix - sc.radar_matrix)) > RADAR_MOTION_TOLERANCE:
                    radar_moves = True
            radar_track.append(radar_motion(sc.radar_matrix, sp.radar_matrix, sn.radar_matrix, span, is_camera))
        shapes, objects = {}, {}
        for name in sorted(sc.parts):
            part = sc.parts[name]
            centroid_velocity = (sn.parts[name].centroid() - sp.parts[name].centroid()) / span
            if materials_used.setdefault(part.material, part.radio) != part.radio:
                raise ExportError(f"material {part.material!r} maps to two radio materials during the animation "
                                  "(is its radio_material property animated?)")
            if np.any(centroid_velocity != 0.0):
                ever_moving.add(name)
            if name in rigid:
                state = rigid[name]
                now, before, after = (state.fit(x.parts[name].vertices) for x in (sc, sp, sn))
                if now is not None and before is not None and after is not None:
                    omega = state.spin(angular_velocity(after[0], before[0], span)) if span > 0 else np.zeros(3)
                    state.motions.append((now[0], now[1], centroid_velocity, omega))
                    shapes[name] = ("rigid", len(state.motions) - 1, part.material)
                    objects[name] = None   # filled in at the end (rigid or not)
                    continue
                if state.motions:
                    unrigid(name, part.triangles)
                else:
                    rigid.pop(name)
            vel = (sn.parts[name].vertices - sp.parts[name].vertices) / span
            spread = float(np.max(np.linalg.norm(vel - vel.mean(axis=0), axis=1))) if len(vel) else 0.0
            vertex_velocity = vel if spread > VELOCITY_SPREAD_TOLERANCE else None
            if vertex_velocity is not None:
                deforming.add(name)
            shapes[name] = ("ply", write_mesh(name, i, part.vertices, part.triangles, vertex_velocity, part.normals),
                            part.material)
            objects[name] = centroid_velocity
        frames.append({"shapes": shapes, "objects": objects})
        # samples before the next frame's first one are no longer needed
        nxt = f + 1 - h
        for k in [k for k in cache if k < key(nxt)]:
            del cache[k]
    # rigid objects: one PLY (the first frame's mesh) placed by a transform per frame; one that never
    # moves is a static mesh (no transform)
    rigid_moving = set()
    for name, state in rigid.items():
        still = all(np.allclose(r, np.eye(3), rtol=0, atol=1e-12) and np.allclose(p, 0, rtol=0, atol=1e-12)
                    and not np.any(v) and not np.any(w) for r, p, v, w in state.motions)
        stem = write_mesh(name, 0, state.reference, first.parts[name].triangles, None, state.normals)
        if not still:
            rigid_moving.add(name)
        for fr in frames:
            _, j, mat = fr["shapes"][name]
            r, p, v_c, omega = state.motions[j]
            fr["shapes"][name] = ("ply", stem, mat, None if still else transform_matrix(r, p))
            fr["objects"][name] = {"velocity": v_c, "angular_velocity": omega, "to_world": transform_matrix(r, p)}
    moving = {n for n in files if len(files[n]) > 1} | ever_moving | rigid_moving
    # final file names: an object with one distinct mesh gets <name>.ply
    rename = {}
    for name, known in files.items():
        if len(known) == 1:
            (stem,) = known.values()
            final = safe_names[name]
            os.rename(tmp / "meshes" / f"{stem}.ply", tmp / "meshes" / f"{final}.ply")
            rename[stem] = final
    all_names = set(files)
    mat_ids = _material_ids(materials_used, all_names)
    xml_materials = {mat_ids[m]: spec for m, spec in sorted(materials_used.items(), key=lambda kv: mat_ids[kv[0]])}
    has_normals = {name: first.parts[name].normals is not None for name in all_names}
    manifest_frames = []
    for i, fr in enumerate(frames):
        shapes = []
        for name, entry in sorted(fr["shapes"].items()):
            stem, mat = entry[1], entry[2]
            shape = {"name": name, "ply": f"../meshes/{rename.get(stem, stem)}.ply", "material": mat_ids[mat],
                     "face_normals": not has_normals[name]}
            if len(entry) > 3 and entry[3] is not None:
                shape["to_world"] = entry[3]
            shapes.append(shape)
        used_ids = {s["material"] for s in shapes}
        mats = {mid: (mtype, {k: v for k, (_, v) in props.items()})
                for mid, (mtype, props) in xml_materials.items() if mid in used_ids}
        write_frame_xml(tmp / "frames" / f"{i:04d}.xml", shapes, mats)
        manifest_frames.append({"xml": f"frames/{i:04d}.xml",
                                "objects": {n: v for n, v in fr["objects"].items() if n in moving}})
        if radar_moves and len(radar_track) == len(frames):
            manifest_frames[-1]["radar"] = radar_track[i]
    if radar_moves:
        log(f"sionnafmcw-export: the radar ({radar_desc}) moves during the exported frames: the manifest holds "
            "its pose and motion per frame (a radar track)")
    radar_pose = radar_pose_from_matrix(radar_matrix0 if radar_matrix0 is not None else np.eye(4), is_camera)
    write_animation(tmp, manifest_frames, fps, radar_pose, extra={
        "source": {
            "generator": "sionnafmcw/blender/export.py",
            "blender": bpy.app.version_string,
            "blend_file": bpy.data.filepath or None,
            "scene": scene.name,
            "frame_start": a, "frame_end": b,
            "velocity_step_frames": h,
            "radar_object": radar_desc,
            "rigid_tolerance_m": RIGID_TOLERANCE,
            "materials": {m: {"id": mat_ids[m], "type": spec[0],
                              "properties": {k: v for k, (_, v) in spec[1].items()}}
                          for m, spec in sorted(materials_used.items())},
        },
    })
    return {"frames": len(frames), "objects": len(all_names), "moving": len(moving), "deforming": len(deforming),
            "rigid": len(rigid_moving), "files": sum(len(k) for k in files.values())}


# ===================================================================================== command line
USAGE = """usage:
  blender -b scene.blend --python-exit-code 1 -P export.py -- OUT [--frames A:B] [--radar NAME] [--velocity-step S]
  python export.py scene.blend OUT [--frames A:B] [--radar NAME] [--velocity-step S]   (bpy module)
"""


def _parse_args(argv):
    import argparse

    parser = argparse.ArgumentParser(prog="export.py", usage=USAGE, description="Export a Blender scene as a "
                                     "sionnafmcw animation directory")
    parser.add_argument("paths", nargs="+", help="[scene.blend] OUT")
    parser.add_argument("--frames", default=None, help="Blender frames A:B, both included (default: scene range)")
    parser.add_argument("--radar", default="radar", help="radar object name (default: radar, else the scene camera)")
    parser.add_argument("--velocity-step", type=float, default=0.5, help="central-difference half-width in frames")
    args = parser.parse_args(argv)
    if len(args.paths) > 2:
        parser.error("expected [scene.blend] OUT")
    return args


def main(argv=None) -> int:
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    try:
        args = _parse_args(argv)
    except SystemExit as err:
        return int(err.code or 0)
    try:
        if len(args.paths) == 2:
            blend, out = args.paths
            if not Path(blend).is_file():
                raise ExportError(f"{blend}: no such .blend file")
            bpy.ops.wm.open_mainfile(filepath=str(Path(blend).resolve()), load_ui=False)
        else:
            (out,) = args.paths
        start, end = parse_frames(args.frames)
        export_animation(out, start, end, radar=args.radar, velocity_step=args.velocity_step)
        return 0
    except ExportError as err:
        print(ERROR_MARKER + " ".join(str(err).split("\n")), file=sys.stderr, flush=True)
        return 1
    except Exception as err:  # noqa: BLE001 - report anything else with its traceback
        traceback.print_exc()
        print(ERROR_MARKER + f"internal error: {type(err).__name__}: {err}", file=sys.stderr, flush=True)
        return 2


# ===================================================================================== add-on
if bpy is not None:
    from bpy.props import BoolProperty, FloatProperty, IntProperty, StringProperty
    from bpy_extras.io_utils import ExportHelper

    class EXPORT_SCENE_OT_sionnafmcw(bpy.types.Operator, ExportHelper):
        """Export the animation as a sionnafmcw radar animation directory"""

        bl_idname = "export_scene.sionnafmcw"
        bl_label = "Export sionnafmcw animation"
        bl_options = {"PRESET"}

        filename_ext = ""
        check_extension = None
        filter_glob: StringProperty(default="", options={"HIDDEN"})
        use_scene_range: BoolProperty(name="Scene frame range", default=True,
                                      description="Export the scene's frame range (else the range below)")
        frame_start: IntProperty(name="Start frame", default=1)
        frame_end: IntProperty(name="End frame", default=250)
        radar: StringProperty(name="Radar object", default="radar",
                              description="Empty (local +X boresight, +Z up) or camera; else the scene camera")
        velocity_step: FloatProperty(name="Velocity step (frames)", default=0.5, min=0.05, max=1.0,
                                     description="Half-width of the central differences for velocities")

        def invoke(self, context, event):
            if not self.filepath:
                stem = os.path.splitext(context.blend_data.filepath)[0] if context.blend_data.filepath else "untitled"
                self.filepath = stem + "_sionnafmcw"
            context.window_manager.fileselect_add(self)
            return {"RUNNING_MODAL"}

        def execute(self, context):
            start, end = (None, None) if self.use_scene_range else (self.frame_start, self.frame_end)
            try:
                out = export_animation(self.filepath, start, end, radar=self.radar, velocity_step=self.velocity_step)
            except ExportError as err:
                self.report({"ERROR"}, str(err))
                return {"CANCELLED"}
            self.report({"INFO"}, f"sionnafmcw animation written to {out}")
            return {"FINISHED"}

    def _menu_func(self, context):
        self.layout.operator(EXPORT_SCENE_OT_sionnafmcw.bl_idname, text="sionnafmcw radar animation")

    def register():
        bpy.utils.register_class(EXPORT_SCENE_OT_sionnafmcw)
        bpy.types.TOPBAR_MT_file_export.append(_menu_func)

    def unregister():
        bpy.types.TOPBAR_MT_file_export.remove(_menu_func)
        bpy.utils.unregister_class(EXPORT_SCENE_OT_sionnafmcw)


if __name__ == "__main__":
    code = main()
    if code:
        sys.exit(code)
