r"""The motion-capture clips shipped with sionnafmcw and the postures taken from them.

Seven clips of the CMU Graphics Lab Motion Capture Database (BVH conversion by B. Hahne), one per
activity, and two excerpts of an eighth (``13_29``: its jumping jacks and its squats, the lines of
the file that hold them), in ``sionnafmcw/mocap/clips/`` with their provenance, checks and terms of use
(``clips/README.md``). **Acknowledgement** (:data:`ACKNOWLEDGEMENT`, as the database asks of
published results): *The data used in this project was obtained from mocap.cs.cmu.edu. The database
was created with funding from NSF EIA-0196217.*

Units: :data:`~.skeleton.CMU_UNIT` m per BVH unit; 120 frames per second; frame 0 of every clip is
an added T-pose, so motion starts at frame 1 (:class:`~.person.MocapPerson`'s default start).

==========  ============  ===========================================================================
clip        activity      what happens (clip seconds; the CMU unit, the subjects' own size)
==========  ============  ===========================================================================
``08_10``   walk          walks 3.7 m forward, pelvis at about 1.6 m/s (subject 8)
``09_01``   run           runs 4.3 m forward, pelvis at 3.3-4.2 m/s, limbs up to 8.3 m/s (subject 9)
``111_10``  stand up      seated (pelvis 0.5 m up) until about 0.9 s, rises by 1.5 s (pelvis up at up
                          to 1.5 m/s at 1.3 s), then steps forward (subject 111)
``111_37``  wave          stands still and waves (hands up to 1.1 m/s; subject 111)
``75_10``   jump          stands, one long jump forward: take-off at about 1.45 s (pelvis 6.2 m/s
                          forward, 4.8 m/s up), landing at 1.74 s (5.0 m/s down); limbs up to 11 m/s
                          (subject 75)
``90_18``   fall          stands until about 0.8 s, a rug is pulled: falls backwards (pelvis down at
                          up to 4.0 m/s at 1.0 s), lies on the floor from 1.1 s (subject 90)
``115_06``  pick up       bends the knees (pelvis down at up to 1.6 m/s at 0.65 s, to 0.55 m at 0.8 s)
                          to pick up a box and stands up again (subject 115)
``13_29_``  jumping       frames 0-480 of ``13_29`` (subject 13): seven jumping jacks, one every 0.55 s
``jacks``   jacks         (root-height peaks at clip frames 41, 101, 170, 237, 302, 372, 438), under way
                          from frame 1
``13_29_``  squat         frame 0 (the T-pose) and frames 3800-4520 of ``13_29``: stands, two deep squats
``squats``                (``13_29`` frames 3822-4108 and 4193-4474; excerpt 0.19-2.58 s and 3.28-5.63 s,
                          pelvis from 1.03 m down to 0.45 and 0.41 m in the CMU unit), stands
==========  ============  ===========================================================================

:data:`POSTURES`: still postures for :class:`~.person.PosedPerson` -- ``standing`` (``90_18`` at
0.2 s, before the rug is pulled), ``sitting`` (``111_10`` at 0.3 s, on the chair, which is not
modelled) and ``lying`` (``90_18`` at 3.2 s, on its back on the floor after the fall).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

from .bvh import BvhClip, read_bvh

#: The acknowledgement the CMU database asks for.
ACKNOWLEDGEMENT = ("The data used in this project was obtained from mocap.cs.cmu.edu. "
                   "The database was created with funding from NSF EIA-0196217.")
CLIP_DIR = Path(__file__).resolve().with_name("clips")


@dataclass(frozen=True)
class ClipInfo:
    """A shipped clip: ``name`` (CMU subject_trial), ``activity``, CMU index ``description``, ``sha256_prefix``."""

    name: str
    activity: str
    description: str
    sha256_prefix: str

    @property
    def path(self) -> Path:
        return CLIP_DIR / f"{self.name}.bvh"


CLIPS = {c.name: c for c in (
    ClipInfo("08_10", "walk", "08_10 walk", "e85c3f5315ba9fdc"),
    ClipInfo("09_01", "run", "09_01 run", "6de0986260ec352a"),
    ClipInfo("111_10", "stand_up", "111_10 get up from chair", "c3c179f98af024e7"),
    ClipInfo("111_37", "wave", "111_37 Wave", "5d0588355bde987a"),
    ClipInfo("75_10", "jump", "75_10 2 jump", "1363c90b8294d965"),
    ClipInfo("90_18", "fall", "90_18 RugPullFall", "35a8e9b8b02bf4b6"),
    ClipInfo("115_06", "pick_up", "115_06 Picking box up, bending knees", "cf6b0a7bda68eb7f"),
    ClipInfo("13_29_jacks", "jumping_jacks", "13_29 jumping jacks, side twists, bend over, squats",
             "e725492fb10456c4"),
    ClipInfo("13_29_squats", "squat", "13_29 jumping jacks, side twists, bend over, squats", "150b271ca019521e"),
)}
#: Still postures: ``{name: (clip, clip time s)}`` (module docstring).
POSTURES = {"standing": ("90_18", 0.2), "sitting": ("111_10", 0.3), "lying": ("90_18", 3.2)}


def clip_info(name: str) -> ClipInfo:
    if name not in CLIPS:
        raise ValueError(f"no shipped clip {name!r}; shipped clips: {', '.join(CLIPS)}")
    return CLIPS[name]


@functools.lru_cache(maxsize=None)
def load_clip(name: str) -> BvhClip:
    """The parsed shipped clip ``name`` (cached; do not modify it)."""
    return read_bvh(clip_info(name).path)


def clip_label(ref: str) -> str:
    """The activity label of a person playing clip ``ref``: a shipped clip's activity (``08_10``: ``walk``,
    also for a copy of it under its CMU name), else the file's name without its extension."""
    stem = Path(ref).stem
    return CLIPS[stem].activity if stem in CLIPS else stem


__all__ = ["ACKNOWLEDGEMENT", "CLIPS", "CLIP_DIR", "ClipInfo", "POSTURES", "clip_info", "clip_label", "load_clip"]
