r"""Animation directories: the scene on disk that every engine reads, written by the Blender
exporter (:mod:`sionnafmcw.blender`), the scene builders (:mod:`sionnafmcw.scenes`) or by hand.

This docstring is the data contract of the directory::

    <scene>/animation.json
    <scene>/frames/0000.xml, 0001.xml, ...   Mitsuba 3 scene XML, one per frame
    <scene>/meshes/*.ply                     shared by frames where a mesh does not change

``animation.json``::

    {"format": "sionnafmcw-animation/1",
     "fps": 24.0,
     "radar": {"position": [x, y, z], "orientation": [yaw, pitch, roll]},
     "frames": [{"index": 0, "time": 0.0, "xml": "frames/0000.xml",
                 "objects": {"<name>": {"velocity": [vx, vy, vz]},
                             "<rigid name>": {"velocity": [vx, vy, vz], "angular_velocity": [wx, wy, wz],
                                              "to_world": [16 numbers, row by row]}}}]}

* Frame ``i`` starts at :math:`t_i = i/\mathrm{fps}` (s). ``radar`` is the default radar pose:
  position (m, world) and orientation (yaw, pitch, roll) (rad, Sionna's
  :math:`\mathbf R = \mathbf R_z(\mathrm{yaw})\mathbf R_y(\mathrm{pitch})\mathbf R_x(\mathrm{roll})`);
  a caller may override it.
* Shapes are ``<shape type="ply" id="mesh-<name>">`` with a radio material (``itu-radio-material``,
  ``radio-material`` or sionnafmcw's ``skin-radio-material``, see :mod:`sionnafmcw.materials`);
  ``<name>`` is the object name of the manifest and of the run store's truth.
* An object's manifest ``velocity`` is the linear velocity (m/s, world frame) of its area-weighted
  centroid in that frame (the point the run store's truth follows). A PLY may carry per-vertex
  velocities ``vx, vy, vz`` (m/s, world frame); where it does, Doppler is computed from them at the
  interaction points (deforming meshes).
* **Rigid objects** are stored once: one PLY, in the object's own frame, referenced by every frame
  XML with that frame's ``<transform name="to_world"><matrix value="..."/></transform>`` (a proper
  rotation :math:`\mathbf R` and a translation :math:`\mathbf p`). The manifest gives, besides the
  centroid's ``velocity`` :math:`\mathbf v_c`, the ``angular_velocity`` :math:`\boldsymbol\omega`
  (rad/s, world, :math:`\dot{\mathbf R} = [\boldsymbol\omega]_\times\mathbf R`) and, optionally, the
  same ``to_world`` (checked against the XML). Every point moves at
  :math:`\mathbf v_c + \boldsymbol\omega\times(\mathbf x - \mathbf c)`, exactly (:mod:`.rigid`). Such a
  PLY carries no ``vx, vy, vz``; it may carry vertex normals ``nx, ny, nz`` (its own frame).
* **People** (optional): a top-level ``people`` entry names every person, its objects, its activity
  (for the whole animation or per frame) and its keypoints per frame (:mod:`sionnafmcw.animation.people`); a
  ``furniture`` entry (informative) lists the pieces of a furnished room.

Rooms, one job each:

* :mod:`.ply` -- PLY meshes, read and write (numpy only);
* :mod:`.frame_xml` -- the Mitsuba XML of a frame, read (:class:`ParsedFrameXml`) and write (numpy only);
* :mod:`.model` -- :class:`Animation`, :class:`RadarPose`, :class:`Frame`, :class:`Mesh`;
* :mod:`.rigid` -- :class:`RigidMotion` (a rigid object's transform and velocity field), the rigid
  fit (Kabsch) and the angular velocity of two rotations;
* :mod:`sionnafmcw.animation.people` -- the optional ``people`` entry (who is in the scene, their activities and keypoints
  per frame), :class:`People`;
* :mod:`.manifest` -- :func:`load_animation` (checks everything it can without ray tracing and
  raises an :class:`AnimationError` naming the file and field that is wrong) and
  :func:`write_animation`.

The whole package needs only numpy and the standard library, so the Blender exporter (numpy < 2,
no Sionna) imports its writers.
"""

from .errors import AnimationError
from .frame_xml import ParsedFrameXml, ShapeInfo, frame_xml_text, matrix_ops, parse_frame_xml, write_frame_xml
from .manifest import FORMAT, TIME_TOLERANCE, load_animation, write_animation
from .model import Animation, Frame, Mesh, RadarPose
from .people import People, parse_people, people_entry
from .ply import PlyData, ply_bytes, read_ply, write_ply
from .rigid import RIGID_TOLERANCE, RigidMotion, angular_velocity, rigid_fit, transform_matrix

__all__ = [
    "FORMAT", "RIGID_TOLERANCE", "TIME_TOLERANCE", "Animation", "AnimationError", "Frame", "Mesh", "ParsedFrameXml",
    "People", "PlyData", "RadarPose", "RigidMotion", "ShapeInfo", "angular_velocity", "frame_xml_text",
    "load_animation", "matrix_ops", "parse_frame_xml", "parse_people", "people_entry", "ply_bytes", "read_ply",
    "rigid_fit", "transform_matrix", "write_animation", "write_frame_xml", "write_ply",
]
