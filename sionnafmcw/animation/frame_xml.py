r"""Frame XML: the Mitsuba 3 scene of one animation frame, read (:func:`parse_frame_xml`) and written
(:func:`frame_xml_text`, :func:`write_frame_xml`).

numpy and the standard library only (the radio materials are classified with
:mod:`sionnafmcw.materials`, imported when a frame is parsed): the Blender exporter (numpy < 2,
no Sionna) imports the writer.

A frame XML (layout of the animation directory in :mod:`sionnafmcw.animation`) holds shapes
``<shape type="ply" id="mesh-<name>">`` with a radio material (``<ref id=...>`` to a top-level
``<bsdf>``, or a nested ``<bsdf>``); ``<name>`` is the object name of the manifest and of the run
store's truth. Transforms (``<transform name="to_world">`` with ``translate``, ``rotate``,
``scale``, ``matrix``, ``lookat``) are applied as Mitsuba applies them: each operation
left-multiplies the ones before it,
:math:`\mathbf M = \mathbf T_n \cdots \mathbf T_2 \mathbf T_1`.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import AnimationError, read_text

def _floats(text: str, n: int | None, where: str) -> np.ndarray:
    try:
        vals = np.array([float(x) for x in re.split(r"[,\s]+", text.strip()) if x], dtype=float)
    except ValueError:
        raise AnimationError(f"{where}: cannot parse numbers from {text!r}") from None
    if n is not None and vals.size not in (n,) and not (n == 3 and vals.size == 1):
        raise AnimationError(f"{where}: expected {n} numbers, got {text!r}")
    if n == 3 and vals.size == 1:
        vals = np.repeat(vals, 3)
    return vals


def _xyz(el, where, default=0.0) -> np.ndarray:
    if "value" in el.attrib:
        return _floats(el.attrib["value"], 3, where)
    return np.array([float(el.attrib.get(k, default)) for k in "xyz"])


def _rotation(axis, angle_deg) -> np.ndarray:
    """Mitsuba's ``Transform4f.rotate``; like Mitsuba, the axis is used as given (not normalised)."""
    axis = np.asarray(axis, dtype=float)
    a = math.radians(angle_deg)
    x, y, z = axis
    c, s = math.cos(a), math.sin(a)
    C = 1 - c
    return np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                     [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                     [z * x * C - y * s, z * y * C + x * s, c + z * z * C]])


def _parse_transform(el, where) -> np.ndarray:
    """4x4 matrix of a Mitsuba ``<transform>`` element (each op left-multiplies)."""
    m = np.eye(4)
    for op in el:
        t = np.eye(4)
        w = f"{where} <{op.tag}>"
        if op.tag == "translate":
            t[:3, 3] = _xyz(op, w)
        elif op.tag == "scale":
            if "value" in op.attrib:
                t[:3, :3] = np.diag(_floats(op.attrib["value"], 3, w))
            else:
                t[:3, :3] = np.diag([float(op.attrib.get(k, 1.0)) for k in "xyz"])
        elif op.tag == "rotate":
            axis = _floats(op.attrib["value"], 3, w) if "value" in op.attrib else \
                np.array([float(op.attrib.get(k, 0.0)) for k in "xyz"])
            if "angle" not in op.attrib or not np.any(axis):
                raise AnimationError(f"{w}: rotate needs an axis and an angle")
            t[:3, :3] = _rotation(axis, float(op.attrib["angle"]))
        elif op.tag == "matrix":
            vals = _floats(op.attrib.get("value", ""), None, w)
            if vals.size == 16:
                t = vals.reshape(4, 4)
            elif vals.size == 9:
                t[:3, :3] = vals.reshape(3, 3)
            else:
                raise AnimationError(f"{w}: matrix needs 9 or 16 numbers")
        elif op.tag == "lookat":
            origin = _floats(op.attrib["origin"], 3, w)
            target = _floats(op.attrib["target"], 3, w)
            up = _floats(op.attrib.get("up", "0 0 1"), 3, w)
            d = target - origin
            d /= np.linalg.norm(d)
            left = np.cross(up, d)
            left /= np.linalg.norm(left)
            new_up = np.cross(d, left)
            t[:3, 0], t[:3, 1], t[:3, 2], t[:3, 3] = left, new_up, d, origin
        else:
            raise AnimationError(f"{w}: unsupported transform operation")
        m = t @ m
    return m


@dataclass
class ShapeInfo:
    """One ``<shape>`` of a frame XML."""

    id: str
    name: str
    type: str
    filename: Path | None
    to_world: np.ndarray
    material: object  # materials.MaterialSpec
    face_normals: bool


@dataclass
class ParsedFrameXml:
    """The parsed Mitsuba XML of one animation frame: its shapes by object name and their materials."""

    xml: Path
    shapes: dict  # name -> ShapeInfo

    def materials(self) -> dict:
        """``{material id: MaterialSpec}`` of the shapes."""
        return {s.material.id: s.material for s in self.shapes.values()}


def _substitute_defaults(root, where):
    defaults = {d.attrib["name"]: d.attrib.get("value", "") for d in root.findall("default") if "name" in d.attrib}
    if not defaults:
        return
    pattern = re.compile(r"\$(\w+)")
    for el in root.iter():
        for k, v in list(el.attrib.items()):
            if "$" in v:
                el.attrib[k] = pattern.sub(lambda m: defaults.get(m.group(1), m.group(0)), v)


def parse_frame_xml(xml_path) -> ParsedFrameXml:
    """Parse a frame's Mitsuba XML: shapes, PLY files, transforms and radio materials (checked)."""
    from ..materials import MaterialError, classify_bsdf

    xml_path = Path(xml_path)
    text = read_text(xml_path, "frame XML")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:
        raise AnimationError(f"{xml_path}: malformed XML ({err})") from None
    if root.tag != "scene":
        raise AnimationError(f"{xml_path}: root element is <{root.tag}>, expected <scene>")
    _substitute_defaults(root, xml_path)

    def props_of(el):
        return {c.attrib["name"]: c.attrib.get("value") for c in el if "name" in c.attrib}

    bsdfs = {}
    for b in root.findall("bsdf"):
        bsdfs[b.attrib.get("id")] = b
    shapes = {}
    for s in root.iter("shape"):
        sid = s.attrib.get("id", "")
        stype = s.attrib.get("type", "")
        if stype in ("merge", "instance", "shapegroup"):
            continue
        where = f"{xml_path}: shape {sid!r}"
        bsdf_el = s.find("bsdf")
        if bsdf_el is None:
            ref = s.find("ref")
            if ref is not None:
                bsdf_el = bsdfs.get(ref.attrib.get("id"))
                if bsdf_el is None:
                    raise AnimationError(f"{where}: <ref id={ref.attrib.get('id')!r}> names no top-level <bsdf>")
        if bsdf_el is None:
            raise AnimationError(f"{where}: no radio material (<bsdf> or <ref>)")
        try:
            spec = classify_bsdf(bsdf_el.attrib.get("type"), bsdf_el.attrib.get("id"), props_of(bsdf_el))
        except MaterialError as err:
            raise AnimationError(f"{where}: {err}") from None
        props = props_of(s)
        filename = None
        if stype in ("ply", "obj"):
            if not props.get("filename"):
                raise AnimationError(f"{where}: no <string name=\"filename\">")
            filename = Path(props["filename"])
            if not filename.is_absolute():
                filename = (xml_path.parent / filename).resolve()
            if not filename.is_file():
                raise AnimationError(f"{where}: mesh file {props['filename']!r} not found (looked for {filename})")
        tr = s.find("transform[@name='to_world']")
        to_world = _parse_transform(tr, where) if tr is not None else np.eye(4)
        face_normals = str(props.get("face_normals", "false")).lower() == "true"
        name = sid[5:] if sid.startswith("mesh-") else sid
        if name in shapes:
            raise AnimationError(f"{where}: object name {name!r} is used by two shapes")
        shapes[name] = ShapeInfo(sid, name, stype, filename, to_world, spec, face_normals)
    # Sionna names objects and materials alike (ids without "mesh-" / "mat-"), in one namespace
    mat_names = {(m[4:] if m.startswith("mat-") else m) for m in (s.material.id or "" for s in shapes.values())}
    clash = sorted(mat_names & set(shapes))
    if clash:
        raise AnimationError(
            f"{xml_path}: object name(s) {clash} are also material names (material ids without 'mat-'); "
            "Sionna refuses two items with one name"
        )
    return ParsedFrameXml(xml_path, shapes)


# ===================================================================================== writing
def xml_attribute(value) -> str:
    """``value`` as the text of a double-quoted XML attribute (``& < > "`` escaped)."""
    return (str(value).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
            .replace('"', "&quot;"))


def _property_tag(value) -> str:
    if isinstance(value, bool):
        return "boolean"
    return "string" if isinstance(value, str) else "float"


def _property_text(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value
    return repr(float(value))


def frame_xml_text(shapes: list, materials: dict | None = None) -> str:
    """The Mitsuba scene XML of one frame (every attribute value XML-escaped).

    ``shapes``: list of dicts ``{"name", "ply" (path relative to the XML), "material" (id),
    optional "to_world" (list of (op, attrs) like ("translate", {"x": "1"}); a 4x4 matrix gives
    :func:`matrix_ops`), optional "face_normals" (default True)}``, written as
    ``<shape type="ply" id="mesh-<name>">``; ``face_normals`` false lets Mitsuba shade with the
    PLY's vertex normals. ``materials``:
    ``{id: (bsdf type, {prop: value})}`` written as top-level BSDFs; a ``str`` value is a
    ``<string>``, a ``bool`` a ``<boolean>``, a number a ``<float>`` (``repr`` of the float, so
    it reads back bit for bit), e.g.
    ``{"refl-metal": ("itu-radio-material", {"type": "metal", "scattering_coefficient": 0.2})}``.
    """
    a = xml_attribute
    lines = ['<scene version="2.1.0">']
    for mid, (mtype, props) in (materials or {}).items():
        if not props:
            lines.append(f'    <bsdf type="{a(mtype)}" id="{a(mid)}"/>')
            continue
        lines.append(f'    <bsdf type="{a(mtype)}" id="{a(mid)}">')
        for k, v in props.items():
            lines.append(f'        <{_property_tag(v)} name="{a(k)}" value="{a(_property_text(v))}"/>')
        lines.append("    </bsdf>")
    for s in shapes:
        lines.append(f'    <shape type="ply" id="mesh-{a(s["name"])}">')
        lines.append(f'        <string name="filename" value="{a(s["ply"])}"/>')
        face = "true" if s.get("face_normals", True) else "false"
        lines.append(f'        <boolean name="face_normals" value="{face}"/>')
        if s.get("to_world") is not None and not isinstance(s["to_world"], (list, tuple)):
            s = dict(s, to_world=matrix_ops(s["to_world"]))
        if s.get("to_world"):
            lines.append('        <transform name="to_world">')
            for op, attrs in s["to_world"]:
                text = " ".join(f'{k}="{a(v)}"' for k, v in attrs.items())
                lines.append(f"            <{op} {text}/>")
            lines.append("        </transform>")
        lines.append(f'        <ref id="{a(s["material"])}"/>')
        lines.append("    </shape>")
    lines.append("</scene>")
    return "\n".join(lines) + "\n"


def matrix_ops(matrix) -> list:
    """The ``to_world`` operations of a 4x4 matrix: one ``<matrix>`` with its 16 numbers row by row
    (``repr`` of each float, so the XML reads back bit for bit)."""
    m = np.asarray(matrix, dtype=float)
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise ValueError(f"to_world must be a finite 4x4 matrix, got shape {m.shape}")
    return [("matrix", {"value": " ".join(repr(float(x)) for x in m.ravel())})]


def write_frame_xml(path, shapes: list, materials: dict | None = None) -> Path:
    """Write :func:`frame_xml_text` to ``path`` (parent folders created); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(frame_xml_text(shapes, materials))
    return path


__all__ = ["ParsedFrameXml", "ShapeInfo", "frame_xml_text", "matrix_ops", "parse_frame_xml", "write_frame_xml",
           "xml_attribute"]
