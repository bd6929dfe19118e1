"""Test helpers: write small animation directories (metal plates and boxes) with real PLY files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sionnafmcw.animation import frame_xml_text, write_animation, write_ply

METAL = {"mat-itu_metal": ("itu-radio-material", {"type": "metal"})}


def plate_mesh(center, size=(1.0, 1.0), normal_axis=0, subdiv=1):
    """A flat square plate of ``size`` (m) centred at ``center``, normal along axis ``normal_axis``.

    ``subdiv`` cells per side (2*subdiv**2 triangles). Returns ``(vertices [V,3], faces [F,3])``.
    """
    center = np.asarray(center, dtype=float)
    a, b = [k for k in range(3) if k != normal_axis]
    n = subdiv + 1
    u = np.linspace(-size[0] / 2, size[0] / 2, n)
    w = np.linspace(-size[1] / 2, size[1] / 2, n)
    uu, ww = np.meshgrid(u, w, indexing="ij")
    v = np.zeros((n * n, 3))
    v[:, a] = uu.ravel()
    v[:, b] = ww.ravel()
    v += center
    faces = []
    for i in range(subdiv):
        for j in range(subdiv):
            p = i * n + j
            faces += [(p, p + n, p + n + 1), (p, p + n + 1, p + 1)]
    return v, np.array(faces)


def box_mesh(center, size):
    """Closed axis-aligned box (12 triangles, outward winding)."""
    c = np.asarray(center, dtype=float)
    h = np.asarray(size, dtype=float) / 2
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float) * h + c
    f = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
         (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return v, np.array(f)


def write_moving_mesh_animation(root, mesh_fn, velocity, num_frames=3, fps=10.0, name="plate",
                                radar_pose=((0, 0, 0), (0, 0, 0)), materials=None, material="mat-itu_metal",
                                vertex_velocity_fn=None, static=None, binary=True, manifest_velocity=True,
                                extra_objects=()):
    """Write an animation where object ``name`` (mesh from ``mesh_fn(t)``) moves with ``velocity``.

    ``mesh_fn(t) -> (vertices, faces)`` gives the mesh at time t; ``velocity`` is a 3-vector or a
    function of t; ``vertex_velocity_fn(t, vertices)`` optional per-vertex velocities; ``static``:
    list of (name, vertices, faces, material) written once to meshes/ and referenced by every frame;
    ``extra_objects``: more moving objects as dicts with the keys name, mesh_fn, velocity and
    optionally vertex_velocity_fn, material, manifest_velocity. Returns the directory.
    """
    root = Path(root)
    (root / "frames").mkdir(parents=True, exist_ok=True)
    moving = [{"name": name, "mesh_fn": mesh_fn, "velocity": velocity, "vertex_velocity_fn": vertex_velocity_fn,
               "material": material, "manifest_velocity": manifest_velocity}] + list(extra_objects)
    frames = []
    static_shapes = []
    for sname, sv, sf, smat in static or []:
        write_ply(root / "meshes" / f"{sname}.ply", sv, sf, binary=binary)
        static_shapes.append({"name": sname, "ply": f"../meshes/{sname}.ply", "material": smat})
    for i in range(num_frames):
        t = i / fps
        shapes, objects = [], {}
        for obj in moving:
            v, f = obj["mesh_fn"](t)
            vfn = obj.get("vertex_velocity_fn")
            vel = None if vfn is None else vfn(t, v)
            write_ply(root / "meshes" / f"{obj['name']}_{i:04d}.ply", v, f, vertex_velocities=vel, binary=binary)
            shapes.append({"name": obj["name"], "ply": f"../meshes/{obj['name']}_{i:04d}.ply",
                           "material": obj.get("material", material)})
            if obj.get("manifest_velocity", True):
                velocity_t = obj["velocity"](t) if callable(obj["velocity"]) else obj["velocity"]
                objects[obj["name"]] = np.asarray(velocity_t, dtype=float)
        (root / "frames" / f"{i:04d}.xml").write_text(frame_xml_text(shapes + static_shapes, materials or METAL))
        frames.append({"xml": f"frames/{i:04d}.xml", "objects": objects})
    write_animation(root, frames, fps, radar_pose)
    return root


def write_plate_animation(root, distance=5.0, velocity=(1.0, 0.0, 0.0), num_frames=3, fps=10.0, size=(1.0, 1.0),
                          subdiv=1, **kwargs):
    """A metal plate facing the radar (at the origin, boresight +x) at ``distance`` m, moving with ``velocity``."""
    velocity = np.asarray(velocity, dtype=float)

    def mesh_fn(t):
        return plate_mesh(np.array([distance, 0.0, 0.0]) + velocity * t, size=size, subdiv=subdiv)

    return write_moving_mesh_animation(root, mesh_fn, velocity, num_frames=num_frames, fps=fps, **kwargs)
