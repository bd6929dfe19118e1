"""Matplotlib figures as a radar engineer reads them: dB colour scales, axes in m, m/s, s and degrees.

Every function draws into ``ax`` (a new figure with the Agg backend when None) and returns the
axes; :func:`save` writes the figure as PNG and closes it. Velocity axes are the radial velocity
:math:`v_r = \\dot R` (m/s, positive receding, :mod:`sionnafmcw.store`). Ground truth is drawn as red stars.

=============================  =================================================================
:func:`plot_range_doppler`     range-Doppler map of one CPI, range (m) against :math:`v_r` (m/s)
:func:`plot_range_azimuth`     range-azimuth map, range (m) against azimuth (deg), or in the
                               radar's x-y plane (``cartesian=True``, top view, equal aspect)
:func:`plot_doppler_time`      strongest-cell velocity per CPI over time, truth as red stars
:func:`plot_micro_doppler`     micro-Doppler spectrogram, time (s) against :math:`v_r` (m/s)
:func:`plot_scene_top_view`    the scene projected on the floor plane: static meshes, tracks of
                               the moving objects, radar and its field of view
=============================  =================================================================
"""

from __future__ import annotations

import numpy as np

#: Full azimuth field of view drawn by :func:`plot_scene_top_view` when none is given (rad):
#: the +-60 degrees of the TI boards' patch arrays.
DEFAULT_FOV = np.deg2rad(120.0)

#: colour map of every spectrogram (micro-Doppler, and under the Doppler-time track)
SPECTROGRAM_CMAP = "magma"
_TRUTH_STYLE = dict(marker="*", linestyle="none", color="red", markeredgecolor="white", markeredgewidth=0.6,
                    markersize=11)
#: on images: hollow red stars, so that the cell underneath stays visible
_TRUTH_STYLE_MAP = dict(marker="*", linestyle="none", color="red", markerfacecolor="none", markeredgewidth=1.4,
                        markersize=13)


def _axes(ax, figsize=(6.4, 4.8)):
    """``ax``, or the axes of a new figure. The backend is left alone (inline in Jupyter; without a
    display matplotlib itself falls back to Agg; ``MPLBACKEND`` overrides both)."""
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=figsize, constrained_layout=True)
    return ax


#: The colour scale of an image starts no lower than this percentile of its cells (dB), so that
#: the noise floor is dark and the dynamic range is spent on what stands above it.
FLOOR_PERCENTILE = 10.0


def _db(power, dynamic_range):
    """Power in dB and the colour limits ``(low, top)``: ``top`` the strongest cell, ``low`` the
    higher of ``top - dynamic_range`` and the :data:`FLOOR_PERCENTILE` percentile of the cells."""
    with np.errstate(invalid="ignore"):
        p = 10 * np.log10(np.maximum(np.asarray(power, float), 1e-300))
    finite = p[np.isfinite(p)]
    if not finite.size:
        return p, -dynamic_range, 0.0
    top = float(finite.max())
    low = max(top - dynamic_range, float(np.percentile(finite, FLOOR_PERCENTILE)))
    if low >= top:  # a flat image
        low = top - dynamic_range
    return p, low, top


def _truth_columns(truth) -> np.ndarray:
    """Truth values as ``[n, objects]`` (a 1-D sequence is one object)."""
    t = np.asarray(truth, dtype=float)
    return t[:, None] if t.ndim == 1 else t.reshape(t.shape[0], -1)


def _truth_label(names, j, count):
    if names is not None and j < len(names):
        return f"ground truth: {names[j]}"
    return "ground truth" if count == 1 or j == 0 else None


def plot_range_doppler(rdmap, ax=None, dynamic_range=60.0, truth=None, title="Range-Doppler map"):
    """Range-Doppler map of one CPI in dB: radial velocity (m/s) across, range (m) up.

    Parameters
    ----------
    rdmap : :class:`~sionnafmcw.processing.RangeDopplerMap`
        ``power [doppler, range]`` (linear), ``ranges`` (m), ``velocities`` (m/s).
    dynamic_range : float
        Largest colour scale span below the strongest cell (dB); the scale starts no lower than
        the noise floor (:data:`FLOOR_PERCENTILE`).
    truth : sequence of ``(range, v_r)``, optional
        Ground-truth cells, drawn as red stars.
    """
    ax = _axes(ax)
    p, lo, hi = _db(rdmap.power, dynamic_range)
    mesh = ax.pcolormesh(rdmap.velocities, rdmap.ranges, p.T, shading="nearest", vmin=lo, vmax=hi, cmap="viridis")
    ax.figure.colorbar(mesh, ax=ax, label="power (dB W)")
    if truth is not None and len(truth):
        truth = np.atleast_2d(np.asarray(truth, float))
        ax.plot(truth[:, 1], truth[:, 0], label="ground truth", **_TRUTH_STYLE_MAP)
        ax.legend(loc="upper right")
    _keep_limits(ax, rdmap.velocities, rdmap.ranges)
    ax.set_xlabel("radial velocity (m/s, + receding)")
    ax.set_ylabel("range (m)")
    ax.set_title(title)
    return ax


def _keep_limits(ax, x_centres, y_centres):
    """Axis limits on the image's cells (half a cell beyond the outer centres): truth markers
    outside the image (an aliased velocity, a target beyond the range) are clipped, not zoomed to."""
    for centres, setter in ((x_centres, ax.set_xlim), (y_centres, ax.set_ylim)):
        e = _edges(centres)
        setter(e[0], e[-1])


def _edges(centres) -> np.ndarray:
    """Cell edges of a (possibly non-uniform) increasing axis: midpoints, ends extrapolated."""
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def plot_range_azimuth(ramap, ax=None, dynamic_range=50.0, truth=None, title="Range-azimuth map",
                       cartesian: bool = False, max_range: float | None = None):
    """Range-azimuth map in dB.

    Parameters
    ----------
    ramap : :class:`~sionnafmcw.processing.RangeAzimuthMap`
        ``power`` ``[range, azimuth]`` (or ``[azimuth, range]``), ``ranges`` (m), ``azimuths``
        (rad, increasing, positive towards the radar's +y).
    truth : sequence of ``(range, azimuth)`` (m, rad), optional
        Drawn as red stars.
    cartesian : bool
        False: azimuth (deg) across, range (m) up. True: the map in the radar's horizontal plane
        seen from above with the radar at the bottom looking up: down-range
        :math:`x = R\\cos\\phi` up, cross-range :math:`y = R\\sin\\phi` across, increasing to
        the left (where the radar's +y lies in a view from above), equal aspect.
    max_range : float, optional
        Only ranges up to this (m) are drawn (e.g. the room size).
    """
    ax = _axes(ax, figsize=(8.0, 4.8) if cartesian else (6.4, 4.8))
    power = np.asarray(ramap.power)
    ranges = np.asarray(ramap.ranges, float)
    azimuths = np.asarray(ramap.azimuths, float)
    if power.shape == (len(azimuths), len(ranges)) and power.shape != (len(ranges), len(azimuths)):
        power = power.T
    if max_range is not None:
        keep = ranges <= max_range
        ranges, power = ranges[keep], power[keep]
    p, lo, hi = _db(power, dynamic_range)
    if truth is not None and len(truth):
        truth = np.atleast_2d(np.asarray(truth, float))
    else:
        truth = None
    if cartesian:
        # seen from above with boresight up: +y (positive azimuth) lies to the LEFT of boresight,
        # so the cross-range axis increases to the left (inverted) and the picture is not mirrored
        r_edges = np.maximum(_edges(ranges), 0.0)
        a_edges = np.clip(_edges(azimuths), -np.pi / 2, np.pi / 2)
        rr, aa = np.meshgrid(r_edges, a_edges, indexing="ij")
        mesh = ax.pcolormesh(rr * np.sin(aa), rr * np.cos(aa), p, shading="flat", vmin=lo, vmax=hi, cmap="viridis")
        if truth is not None:
            ax.plot(truth[:, 0] * np.sin(truth[:, 1]), truth[:, 0] * np.cos(truth[:, 1]), label="ground truth",
                    **_TRUTH_STYLE_MAP)
        ax.plot([0.0], [0.0], marker="^", color="black", linestyle="none", markersize=9, clip_on=False,
                label="radar (boresight up)")
        reach = float(r_edges[-1])
        ax.set_xlim(reach, -reach)
        ax.set_ylim(0.0, reach)
        ax.set_aspect("equal")
        ax.set_xlabel("cross-range y (m, + to the left of boresight: radar +y)")
        ax.set_ylabel("down-range x (m, along boresight)")
        ax.legend(loc="upper right")
    else:
        mesh = ax.pcolormesh(np.rad2deg(azimuths), ranges, p, shading="nearest", vmin=lo, vmax=hi, cmap="viridis")
        if truth is not None:
            ax.plot(np.rad2deg(truth[:, 1]), truth[:, 0], label="ground truth", **_TRUTH_STYLE_MAP)
            ax.legend(loc="upper right")
        _keep_limits(ax, np.rad2deg(azimuths), ranges)
        ax.set_xlabel("azimuth (deg, + towards radar +y)")
        ax.set_ylabel("range (m)")
    ax.figure.colorbar(mesh, ax=ax, label="power (dB W)", shrink=0.75 if cartesian else 1.0)
    ax.set_title(title)
    return ax


def plot_doppler_time(track, velocities=None, truth_times=None, truth_velocities=None, ax=None,
                      spectrogram=None, title="Doppler-time", *, times=None, truth=None, object_names=None,
                      dynamic_range=40.0, velocity_limits=None, min_span: float = 1.0):
    """Estimated radial velocity per CPI (blue line), ground truth as red stars (the paper's Fig. 3).

    Two call forms:

    * ``plot_doppler_time(track, times=frame_times, truth=truth_radial_velocity)`` with a
      :class:`~sionnafmcw.processing.DopplerTrack` (``times`` may also be the second positional
      argument; without times the x axis is the frame index);
    * ``plot_doppler_time(times, velocities, truth_times=..., truth_velocities=...)`` with arrays.

    Parameters
    ----------
    truth : array ``[frame]`` or ``[frame, object]`` (m/s), or a pair ``(times, values)``, optional
        Ground-truth radial velocity; drawn at ``truth_times`` (s) when given, else at the
        estimate's times. ``truth_velocities`` is the same argument under its older name.
    object_names : list of str, optional
        Names of the truth columns, for the legend.
    spectrogram : :class:`~sionnafmcw.processing.MicroDopplerSpectrogram`, optional
        Drawn underneath in dB (``dynamic_range`` dB below its strongest bin, the colour map of
        :func:`plot_micro_doppler`) with a colour bar, as the paper's Fig. 3 shows it; the
        estimate is then drawn in white so that it stays visible on the image.
    velocity_limits : (low, high), m/s, optional
        Velocity axis limits, e.g. :math:`\\pm v_{max}`. Default: the data, widened to at least
        ``min_span`` m/s so that millimetre-per-second differences do not look like errors.
    """
    ax = _axes(ax)
    if hasattr(track, "velocities"):
        est_v = np.asarray(track.velocities, float)
        est_t = times if times is not None else velocities
    else:
        est_t = track if times is None else times
        est_v = np.asarray(velocities, float)
    time_axis = est_t is not None
    est_t = np.arange(est_v.size, dtype=float) if est_t is None else np.asarray(est_t, float)
    if spectrogram is not None:
        power = np.asarray(spectrogram.power)
        if power.shape != (len(spectrogram.velocities), len(spectrogram.times)):
            power = power.T
        p, lo, hi = _db(power, dynamic_range)
        t, p = _with_gaps(spectrogram.times, p)
        mesh = ax.pcolormesh(t, spectrogram.velocities, np.ma.masked_invalid(p), shading="nearest", vmin=lo,
                             vmax=hi, cmap=SPECTROGRAM_CMAP)
        ax.set_facecolor("white")
        ax.figure.colorbar(mesh, ax=ax, label="micro-Doppler power (dB W)")
    estimate_style = "w.-" if spectrogram is not None else "b.-"
    ax.plot(est_t, est_v, estimate_style, label="estimate (strongest cell)")
    if truth is None:
        truth = truth_velocities
    if truth is not None:
        if isinstance(truth, tuple) and len(truth) == 2:
            truth_times, truth = truth
        values = _truth_columns(truth)
        t_truth = est_t if truth_times is None else np.asarray(truth_times, float)
        for j in range(values.shape[1]):
            ax.plot(t_truth, values[:, j], label=_truth_label(object_names, j, values.shape[1]),
                    **(_TRUTH_STYLE_MAP if spectrogram is not None else _TRUTH_STYLE))
    if velocity_limits is not None:
        ax.set_ylim(*velocity_limits)
    elif spectrogram is None:
        low, high = ax.get_ylim()
        if high - low < min_span:
            centre = 0.5 * (low + high)
            ax.set_ylim(centre - 0.5 * min_span, centre + 0.5 * min_span)
    ax.set_xlabel("time (s)" if time_axis else "frame")
    ax.set_ylabel("radial velocity (m/s, + receding)")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    return ax


def _with_gaps(times, power):
    """Insert a NaN column wherever consecutive columns are more than 1.5 typical steps apart
    (the idle time between CPIs), so that the image shows the gap instead of stretching a column."""
    t = np.asarray(times, float)
    if t.size < 3:
        return t, power
    dt = np.diff(t)
    step = np.min(dt[dt > 0]) if np.any(dt > 0) else 0.0
    gaps = np.nonzero(dt > 1.5 * step)[0] if step > 0 else np.array([], int)
    if gaps.size == 0:
        return t, power
    # two blank columns per gap, one step after the last column of a CPI and one before the next
    blank = np.sort(np.concatenate([t[gaps] + step, t[gaps + 1] - step]))
    where = np.searchsorted(t, blank)
    t_new = np.insert(t, where, blank)
    p_new = np.insert(np.asarray(power, float), where, np.nan, axis=1)
    return t_new, p_new


def plot_micro_doppler(spectrogram, ax=None, dynamic_range=40.0, title="Micro-Doppler spectrogram", truth=None,
                       truth_times=None, object_names=None):
    """Micro-Doppler spectrogram in dB: time (s) across, radial velocity (m/s) up.

    Parameters
    ----------
    spectrogram : :class:`~sionnafmcw.processing.MicroDopplerSpectrogram`
    dynamic_range : float
        Largest colour scale span below the strongest bin (dB; the scale starts no lower than the
        noise floor, :data:`FLOOR_PERCENTILE`); the time between CPIs stays blank.
    truth : array ``[time]`` or ``[time, object]`` (m/s), optional
        Ground-truth radial velocity at ``truth_times`` (s), drawn as red stars.
    """
    ax = _axes(ax)
    power = np.asarray(spectrogram.power)
    if power.shape != (len(spectrogram.velocities), len(spectrogram.times)):
        power = power.T
    p, lo, hi = _db(power, dynamic_range)
    t, p = _with_gaps(spectrogram.times, p)
    mesh = ax.pcolormesh(t, spectrogram.velocities, np.ma.masked_invalid(p), shading="nearest", vmin=lo, vmax=hi,
                         cmap=SPECTROGRAM_CMAP)
    ax.set_facecolor("white")
    ax.figure.colorbar(mesh, ax=ax, label="power (dB W)")
    if truth is not None:
        values = _truth_columns(truth)
        if truth_times is None:
            raise ValueError("plot_micro_doppler: truth needs truth_times (s)")
        for j in range(values.shape[1]):
            ax.plot(np.asarray(truth_times, float), values[:, j], label=_truth_label(object_names, j, values.shape[1]),
                    **_TRUTH_STYLE_MAP)
        ax.legend(loc="upper right")
    _keep_limits(ax, t, spectrogram.velocities)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("radial velocity (m/s, + receding)")
    ax.set_title(title)
    return ax


# ============================================================================ scene top view
def _pose_arrays(pose):
    """``(position [3], orientation [3])`` from a RadarPose, a dict or a pair."""
    if pose is None:
        return None
    if hasattr(pose, "position"):
        return np.asarray(pose.position, float), np.asarray(pose.orientation, float)
    if isinstance(pose, dict):
        return np.asarray(pose["position"], float), np.asarray(pose.get("orientation", (0, 0, 0)), float)
    position, orientation = pose
    return np.asarray(position, float), np.asarray(orientation, float)


def _footprint(xy):
    """Outline of projected points: convex hull polygon ``[K, 2]`` (a segment for a vertical plate)."""
    from scipy.spatial import ConvexHull, QhullError

    xy = np.unique(np.round(np.asarray(xy, float), 9), axis=0)
    if len(xy) >= 3:
        try:
            return xy[ConvexHull(xy).vertices]
        except QhullError:
            pass
    if len(xy) < 2:
        return xy
    centred = xy - xy.mean(axis=0)
    direction = np.linalg.svd(centred, full_matrices=False)[2][0]
    s = centred @ direction
    return xy[[np.argmin(s), np.argmax(s)]]


def plot_scene_top_view(animation, radar=None, radar_pose=None, frames=None, objects=None, ax=None,
                        fov: float = DEFAULT_FOV, title="Scene, top view", horizontal_tolerance: float = 0.5,
                        highlight=None):
    r"""The scene seen from above (world x across, y up, equal aspect), as a radar engineer sketches it.

    * static meshes projected on the floor plane: faces that look up or down (floors, ceilings,
      table tops; :math:`|n_z| >` ``horizontal_tolerance`` :math:`\|n\|`) filled in light grey,
      the other faces (walls, sides) as dark grey segments, their projection;
    * every moving object: its track (area-weighted mesh centroid in each of ``frames``), a dot
      at the first frame and an arrow head at the last, and its outline (convex hull of the
      projected mesh) at the first frame;
    * the radar: its position, boresight (the pose's local +x projected on the floor, arrow) and
      the azimuth field of view ``fov`` (rad, full width) as a wedge, out to the unambiguous
      range :math:`R_{max}` of ``radar`` when given (dashed edge; the axes show the scene, so a
      long wedge is cut at the border), else to the far side of the scene (dotted edge); a moving
      radar (a radar track) at its pose in the first of ``frames``, with its track over ``frames``.

    Parameters
    ----------
    animation : :class:`~sionnafmcw.animation.Animation` or path of an animation directory
    radar : :class:`~sionnafmcw.RadarConfig`, optional
        Gives the field of view its range :math:`R_{max}`.
    radar_pose : RadarPose, dict ``{"position", "orientation"}``, ``(position, orientation)`` or a radar track
        (a list of one RadarPose per animation frame), optional
        Default: the animation's radar pose (its radar track when it has one). No radar is drawn
        when there is none.
    frames : sequence of int, optional
        Frames whose object centroids make the tracks (default all); the static meshes and the
        object outlines are taken from the first of them.
    objects : sequence of str, optional
        Moving objects to track (default :attr:`Animation.object_names`).
    fov : float
        Full azimuth field of view (rad).
    highlight : sequence of str, optional
        Objects drawn in colour with a legend entry each; the others (e.g. the limbs of a body)
        get thin grey tracks and one legend entry together. Default: every object when there
        are at most six, else ``torso`` when there is one (the paper's ground truth), else the first.

    The legend goes below the axes when the function makes the figure, inside otherwise.
    """
    import matplotlib.patches as mpatches
    from matplotlib.collections import LineCollection, PolyCollection

    from .animation import load_animation
    from .geometry import rotation_matrix

    if not hasattr(animation, "object_positions"):
        animation = load_animation(animation)
    frames = list(range(animation.num_frames)) if frames is None else [int(f) for f in frames]
    if not frames:
        raise ValueError("plot_scene_top_view: frames is empty")
    objects = list(animation.object_names) if objects is None else list(objects)
    extent = []  # points the view must hold

    # static meshes of the first frame, projected on the floor
    f0 = frames[0]
    fills, segments = [], []
    for name, shape in animation.frame_xml(f0).shapes.items():
        if name in objects or shape.type != "ply":
            continue
        mesh = animation.mesh(f0, name)
        tri = mesh.vertices[mesh.faces]
        if not len(tri):
            continue
        extent.append(tri.reshape(-1, 3)[:, :2])
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        norm = np.linalg.norm(normal, axis=1)
        flat = np.abs(normal[:, 2]) > horizontal_tolerance * np.maximum(norm, 1e-300)
        fills.extend(tri[flat][:, :, :2])
        for t in tri[~flat][:, :, :2]:
            d = np.linalg.norm(t[:, None, :] - t[None, :, :], axis=-1)
            i, j = np.unravel_index(np.argmax(d), d.shape)
            segments.append(t[[i, j]])

    # moving objects: outline at the first frame, centroid track over frames
    movers = []
    for name in objects:
        track = np.array([animation.object_positions(f, [name])[name] for f in frames])
        outline = _footprint(animation.mesh(f0, name).vertices[:, :2])
        extent += [track[:, :2], outline]
        movers.append((name, track, outline))

    track = radar_pose if radar_pose is not None else animation.radar_track
    if isinstance(track, (list, tuple)) and track and hasattr(track[0], "position"):
        radar_track = np.array([track[f].position for f in frames])
        radar_pose = track[f0]
    else:
        radar_track = None
    pose = _pose_arrays(radar_pose if radar_pose is not None else animation.radar_pose)
    if pose is not None:
        extent.append(pose[0][None, :2])
    if radar_track is not None:
        extent.append(radar_track[:, :2])
    points = np.concatenate(extent) if extent else np.zeros((1, 2))
    lo, hi = points.min(axis=0), points.max(axis=0)
    margin = 0.08 * max(float(np.max(hi - lo)), 1.0)
    lo, hi = lo - margin, hi + margin

    own_figure = ax is None
    if own_figure:
        aspect = (hi[1] - lo[1]) / (hi[0] - lo[0])
        ax = _axes(None, figsize=(7.2, float(np.clip(6.0 * aspect + 1.9, 3.6, 9.5))))
    handles = []
    if fills:
        ax.add_collection(PolyCollection(fills, facecolors="0.55", edgecolors="none", alpha=0.18, zorder=0))
    if segments:
        ax.add_collection(LineCollection(segments, colors="0.25", linewidths=1.4, zorder=1))
    if fills or segments:
        handles.append(mpatches.Patch(facecolor="0.85", edgecolor="0.25", label="static meshes (floor projection)"))

    if highlight is None:
        highlight = objects if len(objects) <= 6 else (["torso"] if "torso" in objects else objects[:1])
    highlight = [n for n in highlight if n in objects]
    colours = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan"]
    others = [m for m in movers if m[0] not in highlight]
    for name, track, outline in others:
        if len(outline) >= 3:
            ax.add_patch(mpatches.Polygon(outline, closed=True, facecolor="0.45", edgecolor="0.35", alpha=0.25,
                                          linewidth=0.5, zorder=2))
        (line,) = ax.plot(track[:, 0], track[:, 1], "-", color="0.4", linewidth=0.7, alpha=0.6, zorder=2,
                          label=f"{len(others)} other moving object{'s' if len(others) > 1 else ''}: centroid tracks")
    if others:
        handles.append(line)
    for k, (name, track, outline) in enumerate(m for m in movers if m[0] in highlight):
        colour = colours[k % len(colours)]
        if len(outline) >= 3:
            ax.add_patch(mpatches.Polygon(outline, closed=True, facecolor=colour, edgecolor=colour, alpha=0.3,
                                          zorder=2))
        else:
            ax.plot(outline[:, 0], outline[:, 1], color=colour, linewidth=3, alpha=0.5, zorder=2)
        (line,) = ax.plot(track[:, 0], track[:, 1], ".-", color=colour, markersize=3, linewidth=1.2, zorder=3,
                          label=f"{name}: centroid track, frames {frames[0]}..{frames[-1]}")
        ax.plot(track[0, 0], track[0, 1], "o", color=colour, markersize=7, zorder=4)
        if len(track) >= 2 and np.linalg.norm(track[-1, :2] - track[-2, :2]) > 1e-6:
            ax.annotate("", xy=track[-1, :2], xytext=track[-2, :2], zorder=4,
                        arrowprops=dict(arrowstyle="-|>", color=colour, lw=1.5, mutation_scale=14))
        handles.append(line)

    if pose is not None:
        position, orientation = pose
        boresight = rotation_matrix(orientation)[:, 0]
        heading = float(np.arctan2(boresight[1], boresight[0]))
        scene_reach = float(np.max(np.linalg.norm(points - position[:2], axis=1)))
        reach = radar.max_range if radar is not None else max(scene_reach, 1.0)
        half = 0.5 * float(fov)
        label = f"field of view ±{np.rad2deg(half):.0f}°"
        if radar is not None:
            label += f", R_max = {radar.max_range:.1f} m"
        wedge = mpatches.Wedge(position[:2], reach, np.rad2deg(heading - half), np.rad2deg(heading + half),
                               facecolor="gold", edgecolor="none", alpha=0.15, zorder=0, label=label)
        ax.add_patch(wedge)
        arc = np.linspace(heading - half, heading + half, 91)
        edge = np.concatenate([[position[:2]], position[:2] + reach * np.c_[np.cos(arc), np.sin(arc)],
                               [position[:2]]])
        ax.plot(edge[:, 0], edge[:, 1], "--" if radar is not None else ":", color="goldenrod", linewidth=1.0,
                zorder=1)
        arrow = 0.12 * float(np.max(hi - lo))
        ax.annotate("", xy=position[:2] + arrow * np.array([np.cos(heading), np.sin(heading)]), xytext=position[:2],
                    zorder=5, arrowprops=dict(arrowstyle="-|>", color="black", lw=1.5))
        (marker,) = ax.plot(position[0], position[1], "^", color="black", markersize=9, zorder=6,
                            label=f"radar at ({position[0]:.2f}, {position[1]:.2f}, {position[2]:.2f}) m, "
                                  f"yaw {np.rad2deg(orientation[0]):.0f}° (arrow: boresight)")
        handles += [marker, wedge]
        if radar_track is not None and np.ptp(radar_track[:, :2], axis=0).max() > 0:
            (moving,) = ax.plot(radar_track[:, 0], radar_track[:, 1], "-", color="black", linewidth=1.0, zorder=5,
                                label=f"radar track, frames {frames[0]}..{frames[-1]}")
            ax.annotate("", xy=radar_track[-1, :2], xytext=radar_track[-2, :2] if len(radar_track) > 1 else
                        radar_track[-1, :2], zorder=5, arrowprops=dict(arrowstyle="-|>", color="black", lw=1.0))
            handles.append(moving)

    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, world)")
    ax.set_ylabel("y (m, world)")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    if handles:
        if own_figure:
            ax.figure.legend(handles=handles, loc="outside lower center", fontsize="small", ncol=2)
        else:
            ax.legend(handles=handles, loc="best", fontsize="small")
    return ax


def save(ax, path, dpi: int = 120) -> str:
    """Save the figure of ``ax`` as PNG (creating the folder) and close it; returns the path."""
    from pathlib import Path

    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = ax.figure
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return str(path)


__all__ = ["DEFAULT_FOV", "plot_doppler_time", "plot_micro_doppler", "plot_range_azimuth", "plot_range_doppler",
           "plot_scene_top_view", "save"]
