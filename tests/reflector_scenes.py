"""Corner reflectors turned off their axis, written as animations (for tests and benchmarks).

The radar sits at ``(0, 0, height)`` looking along world +x. A reflector's corner is at
``(distance, offset, height)``; its aperture axis points at the radar and is then turned by
``aspect`` (rad) about the world's vertical through the corner. A trihedral is
:func:`sionnafmcw.scenes.meshes.trihedral`; a dihedral is two square metal plates of side ``leg``
meeting at a right angle along a vertical edge, opening along its aperture axis, so that turning it
about the vertical keeps the double bounce retro-reflecting (its far-field echo on the axis
:math:`8\\pi a^4/\\lambda^2` for faces :math:`a\\times a`, falling as :math:`\\cos(45^\\circ + |\\phi|)`
times the aperture's width off it).
"""

from __future__ import annotations

import numpy as np

from sionnafmcw.scenes import meshes
from sionnafmcw.scenes.writer import METAL, AnimationWriter, metal_material


def turn_about_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rotation_between(a, b) -> np.ndarray:
    from sionnafmcw.scenes.simple import _rotation_between as rot

    return rot(a, b)


def dihedral(corner, leg: float, rotation=None, subdiv: int = 2):
    """Two ``leg`` x ``leg`` plates in the planes x = 0 and y = 0 of their own frame (edge along z, from
    z = -leg/2 to leg/2), opening towards ``(1, 1, 0)``; ``rotation`` turns that frame into the world."""
    parts = [meshes.plate((0.0, leg / 2, 0.0), (leg, leg), normal=(1.0, 0.0, 0.0), subdiv=subdiv),
             meshes.plate((leg / 2, 0.0, 0.0), (leg, leg), normal=(0.0, 1.0, 0.0), subdiv=subdiv)]
    v = np.concatenate([parts[0][0], parts[1][0]])
    f = np.concatenate([parts[0][1], parts[1][1] + len(parts[0][0])])
    if rotation is not None:
        v = v @ np.asarray(rotation, float).T
    return v + np.asarray(corner, float), f


def reflector_mesh(kind: str, corner, leg: float, aspect: float, radar=(0.0, 0.0, 1.0)):
    """Vertices and faces of a ``kind`` (``"trihedral"`` or ``"dihedral"``) reflector with its corner at
    ``corner``, its aperture axis at the ``radar`` point turned by ``aspect`` (rad) about the vertical."""
    corner = np.asarray(corner, float)
    u = (corner - np.asarray(radar, float)) / np.linalg.norm(corner - np.asarray(radar, float))
    if kind == "trihedral":
        rot = turn_about_z(aspect) @ _rotation_between(np.ones(3), -u)
        return meshes.trihedral(corner, leg, rotation=rot)
    if kind == "dihedral":
        rot = turn_about_z(aspect) @ _rotation_between(np.array([1.0, 1.0, 0.0]), -u)
        return dihedral(corner, leg, rotation=rot)
    raise ValueError(f"reflector_mesh: kind must be 'trihedral' or 'dihedral', got {kind!r}")


def reflector_faces(kind: str, corner, leg: float, aspect: float, radar=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The flat faces of :func:`reflector_mesh`'s reflector as polygons ``[F, V, 3]``: a trihedral's three
    triangles, a dihedral's two squares (the mesh's triangles, merged)."""
    corner = np.asarray(corner, float)
    u = (corner - np.asarray(radar, float)) / np.linalg.norm(corner - np.asarray(radar, float))
    if kind == "trihedral":
        rot = turn_about_z(aspect) @ _rotation_between(np.ones(3), -u)
        e = np.eye(3) * leg
        local = np.array([[np.zeros(3), e[1], e[2]], [np.zeros(3), e[2], e[0]], [np.zeros(3), e[0], e[1]]])
    elif kind == "dihedral":
        rot = turn_about_z(aspect) @ _rotation_between(np.array([1.0, 1.0, 0.0]), -u)
        h = leg / 2
        local = np.array([[[0, 0, -h], [0, leg, -h], [0, leg, h], [0, 0, h]],
                          [[0, 0, -h], [leg, 0, -h], [leg, 0, h], [0, 0, h]]], float)
    else:
        raise ValueError(f"reflector_faces: kind must be 'trihedral' or 'dihedral', got {kind!r}")
    return local @ rot.T + corner


def mirrored(vertices, faces):
    """The mirror image of a mesh in the plane y = 0 (winding reversed, so normals stay outward)."""
    return np.asarray(vertices, float) * [1.0, -1.0, 1.0], np.asarray(faces)[:, ::-1]


def reflector_scene(out, kind: str, leg: float, distance: float, aspect: float, height: float = 1.0):
    """One static reflector (object ``"reflector"``) ``distance`` ahead of the radar, turned by ``aspect``."""
    w = AnimationWriter(out, 24.0)
    w.add_materials(metal_material(0.0))
    v, f = reflector_mesh(kind, (distance, 0.0, height), leg, aspect, (0.0, 0.0, height))
    w.static("reflector", v, f, METAL, truth=True)
    w.frame([])
    return w.finish((0.0, 0.0, height), (0.0, 0.0, 0.0))


def mirror_pair_scene(out, leg: float, distance: float, offset: float, aspect: float, height: float = 1.0):
    """Two trihedrals, ``"left"`` at ``(distance, offset, height)`` turned by ``aspect`` and ``"right"`` its
    mirror image in the plane y = 0: a radar on that plane sees the same echo from both."""
    w = AnimationWriter(out, 24.0)
    w.add_materials(metal_material(0.0))
    v, f = reflector_mesh("trihedral", (distance, offset, height), leg, aspect, (0.0, 0.0, height))
    w.static("left", v, f, METAL, truth=True)
    w.static("right", *mirrored(v, f), METAL, truth=True)
    w.frame([])
    return w.finish((0.0, 0.0, height), (0.0, 0.0, 0.0))
