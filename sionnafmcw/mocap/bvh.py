r"""BVH (Biovision Hierarchy) motion-capture files: read and write, with errors that name the line.

A BVH file is a skeleton and its motion::

    HIERARCHY
    ROOT Hips
    {
        OFFSET 0 0 0
        CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
        JOINT LeftUpLeg
        {
            OFFSET 1.57 -1.86 0.64
            CHANNELS 3 Zrotation Yrotation Xrotation
            End Site
            {
                OFFSET 0 -7.5 0
            }
        }
    }
    MOTION
    Frames: 2
    Frame Time: 0.0083333
    0 17.6 0  0 0 0  0 0 0
    0 17.6 0  0 0 0  5 0 0

* ``OFFSET`` is the joint's position in its parent's frame (file units) at rest; ``End Site``
  gives the tip of a chain (no joint, no channels).
* ``CHANNELS n c_1 ... c_n``: one of ``Xposition Yposition Zposition Xrotation Yrotation
  Zrotation`` each (case-insensitive), in the order their values appear on every motion line
  (joints in file order). Rotations are in degrees; :mod:`.skeleton` composes them in the listed
  order about the joint's own, already-rotated axes.
* Every motion line holds exactly the sum of all ``n`` values; there are ``Frames:`` lines, one
  per frame, ``Frame Time:`` seconds apart (> 0).

:func:`read_bvh` checks all of that and raises :class:`BvhError` naming the file, the line and
what would fix it: an unknown channel, a wrong count of values on a line, a missing ``MOTION``
section, a zero or negative frame time, a joint name declared twice (a hierarchy must be a tree:
a second declaration would give a joint two parents, a cycle when joints are looked up by name),
unbalanced braces. Lines are counted from 1, whatever the line endings (``\n``, ``\r\n``, ``\r``).
:func:`write_bvh` writes a :class:`BvhClip` back (the project writes its own test clips with it).

numpy and the standard library only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Channel names, as BVH spells them (the file may use any case).
CHANNEL_NAMES = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
_CHANNEL_BY_LOWER = {c.lower(): c for c in CHANNEL_NAMES}


class BvhError(ValueError):
    """A BVH file that cannot be used: ``path``, 1-based ``line`` (None for the whole file) and the problem."""

    def __init__(self, path, line, message):
        self.path = None if path is None else str(path)
        self.line = line
        self.reason = message
        where = self.path or "<bvh>"
        super().__init__(f"{where}:{line}: {message}" if line is not None else f"{where}: {message}")


@dataclass
class Joint:
    """One joint: ``name``, ``parent`` (index, -1 for the root), ``offset`` [3] (file units, parent
    frame), ``channels`` (names from :data:`CHANNEL_NAMES`), ``end_site`` [3] or None, ``line`` (of
    its ``ROOT``/``JOINT`` keyword) and ``children`` (indices)."""

    name: str
    parent: int
    offset: np.ndarray
    channels: tuple = ()
    end_site: np.ndarray | None = None
    line: int = 0
    children: list = field(default_factory=list)


@dataclass
class BvhClip:
    """A parsed BVH file: ``joints`` (file order: a parent comes before its children), ``frame_time``
    (s), ``motion`` [F, C] (file units and degrees) and the ``path`` it came from."""

    joints: list
    frame_time: float
    motion: np.ndarray
    path: str | None = None

    @property
    def num_frames(self) -> int:
        return int(self.motion.shape[0])

    @property
    def num_channels(self) -> int:
        return int(sum(len(j.channels) for j in self.joints))

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Time (s) from the first to the last frame."""
        return (self.num_frames - 1) * self.frame_time

    @property
    def names(self) -> list[str]:
        return [j.name for j in self.joints]

    def index(self, name: str) -> int:
        """Index of joint ``name`` (KeyError naming the joints there are)."""
        for i, j in enumerate(self.joints):
            if j.name == name:
                return i
        raise KeyError(f"{self.path or 'BVH clip'} has no joint {name!r}; joints: {', '.join(self.names)}")

    def channel_slices(self) -> list[slice]:
        """``[slice]`` per joint: where its values sit on a motion line."""
        out, start = [], 0
        for j in self.joints:
            out.append(slice(start, start + len(j.channels)))
            start += len(j.channels)
        return out


def _numbers(tokens, path, line, what, count=None):
    if count is not None and len(tokens) != count:
        raise BvhError(path, line, f"{what} needs {count} numbers, found {len(tokens)}: {' '.join(tokens) or '(none)'}")
    try:
        values = [float(t) for t in tokens]
    except ValueError:
        bad = next(t for t in tokens if not _is_float(t))
        raise BvhError(path, line, f"{what}: {bad!r} is not a number") from None
    if not all(math.isfinite(v) for v in values):
        raise BvhError(path, line, f"{what}: non-finite value in {' '.join(tokens)}")
    return values


def _is_float(text) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def parse_bvh(text: str, path=None) -> BvhClip:
    """Parse BVH ``text`` (``path`` names the file in errors); see the module docstring."""
    lines = text.splitlines()
    pos = 0  # index of the next line to read
    n_lines = len(lines)

    def next_tokens():
        """``(line number, tokens)`` of the next non-blank line, or ``(None, None)`` at the end."""
        nonlocal pos
        while pos < n_lines:
            pos += 1
            tokens = lines[pos - 1].split()
            if tokens:
                return pos, tokens
        return None, None

    line, tokens = next_tokens()
    if tokens is None:
        raise BvhError(path, None, "the file is empty; a BVH file starts with HIERARCHY")
    if tokens[0].upper() != "HIERARCHY":
        raise BvhError(path, line, f"expected HIERARCHY, found {tokens[0]!r}: this is not a BVH file")
    joints: list[Joint] = []
    declared: dict[str, int] = {}
    stack: list = []          # open blocks: ("joint", index) or ("end", index)
    expecting_brace = None    # the block that the next line must open with "{"
    seen_root = False
    motion_line = None
    last_line = line
    while True:
        line, tokens = next_tokens()
        if tokens is None:
            break
        last_line = line
        key = tokens[0].upper()
        if expecting_brace is not None:
            if tokens != ["{"]:
                raise BvhError(path, line, f"expected '{{' to open the block of {expecting_brace[2]}, found "
                                           f"{' '.join(tokens)!r}")
            stack.append(expecting_brace[:2])
            expecting_brace = None
            continue
        if key in ("ROOT", "JOINT"):
            if key == "ROOT":
                if seen_root:
                    raise BvhError(path, line, "a second ROOT: only one skeleton per file is supported")
                if stack:
                    raise BvhError(path, line, "ROOT inside a joint's block; the ROOT opens the hierarchy")
                seen_root = True
            else:
                if not stack or stack[-1][0] != "joint":
                    raise BvhError(path, line, "JOINT outside a joint's block (a JOINT belongs inside its parent's "
                                               "braces; the hierarchy starts with ROOT)")
            if len(tokens) < 2:
                raise BvhError(path, line, f"{tokens[0]} without a name")
            name = "_".join(tokens[1:])
            if name in declared:
                raise BvhError(path, line, f"joint {name!r} is declared twice (first at line {declared[name]}); a "
                                           "BVH hierarchy is a tree: a second declaration would give it two "
                                           "parents (a cycle when joints are looked up by name); rename one")
            declared[name] = line
            parent = stack[-1][1] if stack else -1
            joints.append(Joint(name, parent, np.zeros(3), line=line))
            if parent >= 0:
                joints[parent].children.append(len(joints) - 1)
            expecting_brace = ("joint", len(joints) - 1, f"joint {name!r}")
        elif key == "END":
            if len(tokens) < 2 or tokens[1].upper() != "SITE":
                raise BvhError(path, line, f"expected 'End Site', found {' '.join(tokens)!r}")
            if not stack or stack[-1][0] != "joint":
                raise BvhError(path, line, "End Site outside a joint's block")
            expecting_brace = ("end", stack[-1][1], "End Site")
        elif key == "OFFSET":
            if not stack:
                raise BvhError(path, line, "OFFSET outside a joint's block")
            kind, index = stack[-1]
            values = np.array(_numbers(tokens[1:], path, line, "OFFSET", 3))
            if kind == "joint":
                joints[index].offset = values
            else:
                joints[index].end_site = values
        elif key == "CHANNELS":
            if not stack or stack[-1][0] != "joint":
                raise BvhError(path, line, "CHANNELS outside a joint's block")
            if len(tokens) < 2 or not tokens[1].isdigit():
                raise BvhError(path, line, f"CHANNELS needs a count and the channel names, found {' '.join(tokens)!r}")
            count = int(tokens[1])
            names = tokens[2:]
            if len(names) != count:
                raise BvhError(path, line, f"CHANNELS {count} lists {len(names)} channel names; the count and the "
                                           "names must agree")
            channels = []
            for c in names:
                canon = _CHANNEL_BY_LOWER.get(c.lower())
                if canon is None:
                    raise BvhError(path, line, f"unknown channel {c!r}; valid channels: {', '.join(CHANNEL_NAMES)}")
                if canon in channels:
                    raise BvhError(path, line, f"channel {canon} is listed twice")
                channels.append(canon)
            joints[stack[-1][1]].channels = tuple(channels)
        elif tokens == ["}"]:
            if not stack:
                raise BvhError(path, line, "'}' closes no block (unbalanced braces)")
            stack.pop()
        elif key == "MOTION":
            if stack:
                raise BvhError(path, line, f"MOTION before the hierarchy's blocks are closed ({len(stack)} '{{' "
                                           "without '}'): unbalanced braces")
            motion_line = line
            break
        else:
            raise BvhError(path, line, f"unexpected {tokens[0]!r} in the hierarchy (expected ROOT, JOINT, End Site, "
                                       "OFFSET, CHANNELS, '{', '}' or MOTION)")
    if expecting_brace is not None:
        raise BvhError(path, last_line, f"the file ends before the block of {expecting_brace[2]} opens")
    if not joints:
        raise BvhError(path, last_line, "no ROOT joint in the hierarchy")
    if motion_line is None:
        if stack:
            raise BvhError(path, last_line, f"the file ends inside the hierarchy ({len(stack)} '{{' without '}}')")
        raise BvhError(path, last_line, "no MOTION section after the hierarchy (add 'MOTION', 'Frames: N', "
                                        "'Frame Time: SECONDS' and one line of channel values per frame)")
    # ---------------------------------------------------------------- MOTION header
    line, tokens = next_tokens()
    if tokens is None or tokens[0].lower() != "frames:" or len(tokens) != 2:
        raise BvhError(path, line or motion_line, "expected 'Frames: N' after MOTION"
                       + (f", found {' '.join(tokens)!r}" if tokens else ""))
    try:
        num_frames = int(tokens[1])
    except ValueError:
        raise BvhError(path, line, f"Frames: {tokens[1]!r} is not an integer") from None
    if num_frames < 1:
        raise BvhError(path, line, f"Frames: {num_frames}; a clip needs at least one frame of motion")
    frames_line = line
    line, tokens = next_tokens()
    if tokens is None or len(tokens) != 3 or tokens[0].lower() != "frame" or tokens[1].lower() != "time:":
        raise BvhError(path, line or frames_line, "expected 'Frame Time: SECONDS' after 'Frames:'"
                       + (f", found {' '.join(tokens)!r}" if tokens else ""))
    frame_time = _numbers(tokens[2:], path, line, "Frame Time", 1)[0]
    if not frame_time > 0:
        raise BvhError(path, line, f"Frame Time: {tokens[2]} s; the time between frames must be > 0 "
                                   "(e.g. 0.0083333 for 120 fps)")
    # ---------------------------------------------------------------- motion lines
    num_channels = sum(len(j.channels) for j in joints)
    motion = np.empty((num_frames, num_channels))
    k = 0
    last_seen = line
    while True:
        line, tokens = next_tokens()
        if tokens is None:
            break
        last_seen = line
        if k >= num_frames:
            raise BvhError(path, line, f"more motion lines than 'Frames: {num_frames}' (line {frames_line}); "
                                       "correct the frame count")
        if len(tokens) != num_channels:
            raise BvhError(path, line, f"frame {k} has {len(tokens)} values; the hierarchy declares {num_channels} "
                                       "channels (one value per channel on every motion line)")
        motion[k] = _numbers(tokens, path, line, f"frame {k}")
        k += 1
    if k < num_frames:
        raise BvhError(path, last_seen,
                       f"only {k} motion lines for 'Frames: {num_frames}' (line {frames_line}); the file is "
                       "truncated or the frame count is wrong")
    return BvhClip(joints, float(frame_time), motion, None if path is None else str(path))


def read_bvh(path) -> BvhClip:
    """Read and check the BVH file at ``path`` (:class:`BvhError` names the file and line of a problem)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        raise BvhError(path, None, "no such file") from None
    except IsADirectoryError:
        raise BvhError(path, None, "is a directory, not a BVH file") from None
    return parse_bvh(text, path)


def bvh_text(clip: BvhClip, decimals: int = 6) -> str:
    """The BVH text of ``clip`` (values with ``decimals`` decimals)."""
    out = ["HIERARCHY"]
    fmt = f"{{:.{decimals}f}}"

    def numbers(values):
        return " ".join(fmt.format(float(v)) for v in values)

    def write(i, depth):
        j = clip.joints[i]
        pad = "\t" * depth
        out.append(f"{pad}{'ROOT' if j.parent < 0 else 'JOINT'} {j.name}")
        out.append(pad + "{")
        out.append(f"{pad}\tOFFSET {numbers(j.offset)}")
        out.append(f"{pad}\tCHANNELS {len(j.channels)} {' '.join(j.channels)}".rstrip())
        for c in j.children:
            write(c, depth + 1)
        if j.end_site is not None:
            out.extend([f"{pad}\tEnd Site", pad + "\t{", f"{pad}\t\tOFFSET {numbers(j.end_site)}", pad + "\t}"])
        out.append(pad + "}")

    write(0, 0)
    out += ["MOTION", f"Frames: {clip.num_frames}", f"Frame Time: {clip.frame_time:.10g}"]
    out += [numbers(row) for row in clip.motion]
    return "\n".join(out) + "\n"


def write_bvh(path, clip: BvhClip, decimals: int = 6) -> Path:
    """Write ``clip`` as a BVH file at ``path``; returns the path."""
    path = Path(path)
    path.write_text(bvh_text(clip, decimals))
    return path


__all__ = ["CHANNEL_NAMES", "BvhClip", "BvhError", "Joint", "bvh_text", "parse_bvh", "read_bvh", "write_bvh"]
