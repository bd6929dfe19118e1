r"""Motion capture in: BVH clips drive the project's segment body, into animation directories.

Two routes make the same animation directory (layout: :mod:`sionnafmcw.animation`) from a BVH file:

* **numpy** (any machine): :mod:`.bvh` parses the file (errors name the file and line),
  :mod:`.skeleton` computes the forward kinematics (BVH's channel order and intrinsic Euler
  convention, slerp between frames, Y-up file units to Z-up metres), :mod:`.segments` binds the segment
  body to the skeleton (one rigid skin mesh per bone, tapered limbs sized from anthropometry:
  :mod:`.anatomy`), :mod:`.person` places it and gives each segment's rigid motion per frame,
  :mod:`.scene` writes it (several people under name prefixes, a radar, a room);
* **Blender** (:mod:`.blender_route`, :mod:`.blender_script`): Blender's own BVH importer
  (``io_anim_bvh``) builds the armature and its action, the same segment meshes are parented to its
  bones, and the Blender exporter (:mod:`sionnafmcw.blender.export`) writes the frames.

The routes agree on every vertex's position and velocity (``tests/test_mocap_routes.py``).
:mod:`.library` lists the shipped CMU clips (acknowledgement: :data:`.library.ACKNOWLEDGEMENT`) and
the still postures taken from them; :mod:`.synthetic` writes clips with known motion (the project's
gait as BVH, a spinning arm). The activity builders (:mod:`sionnafmcw.scenes.activities`) use all of
it; ``sionnafmcw scene from-bvh`` is the command line::

    from sionnafmcw.mocap import bvh_to_animation
    bvh_to_animation("clip.bvh", "scenes/clip", fps=30, radar_distance=4.0)
"""

from .bvh import BvhClip, BvhError, read_bvh, write_bvh
from .person import MocapPerson, PosedPerson, add_person
from .scene import bvh_to_animation, radar_in_front, write_people
from .skeleton import CMU_UNIT, ClipMotion

__all__ = ["BvhClip", "BvhError", "CMU_UNIT", "ClipMotion", "MocapPerson", "PosedPerson", "add_person",
           "bvh_to_animation", "radar_in_front", "read_bvh", "write_bvh", "write_people"]
