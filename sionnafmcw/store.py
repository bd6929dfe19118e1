"""The run store: a Zarr v3 group written frame by frame (NOTES section 3).

Layout (named dimensions, readable with ``xarray.open_zarr(path)``):

=========================  =======================================  ===========
variable                   dimensions                               dtype
=========================  =======================================  ===========
``iq``                     frame, chirp, tx, rx, sample             complex64
``frame_time``             frame                                    float64, s
``truth_position``         frame, object, xyz                       float64, m
``truth_velocity``         frame, object, xyz                       float64, m/s
``truth_radial_velocity``  frame, object                            float64, m/s
``frame_done``             frame                                    bool
``object``                 object (coordinate: moving object names) str
=========================  =======================================  ===========

Attributes: ``radar`` (``RadarConfig.to_dict()``), ``radar_pose``, ``engine`` (name and
settings), ``scene``, ``seed``, ``noise``, ``leakage_db``, ``sionnafmcw_version``.

Resumable and never half-written: ``iq`` has one chunk per frame, and ``frame_done[f]`` is set
only after every array of frame ``f`` is written. Re-opening a store with the same settings
skips the frames marked done and rewrites any other (a frame interrupted mid-write included);
opening it with different settings is an error that says which attribute differs.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import zarr

FORMAT = "sionnafmcw-run/1"


class RunStoreError(ValueError):
    """A run store that cannot be created, resumed or read; the message names the store."""


def _json_safe(value):
    return json.loads(json.dumps(value, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))


class RunStore:
    """Writer of one run store (see the module docstring)."""

    def __init__(self, group: zarr.Group, path: Path):
        self.group = group
        self.path = path

    # ------------------------------------------------------------------ create / resume
    @classmethod
    def open(cls, path, radar, num_frames: int, object_names: list[str], attrs: dict) -> "RunStore":
        """Create the store, or reopen it for resuming when its attributes equal ``attrs``."""
        path = Path(path)
        attrs = _json_safe({"format": FORMAT, **attrs})
        if path.exists():
            try:
                group = zarr.open_group(str(path), mode="r+", zarr_format=3)
            except Exception as exc:  # not a Zarr group at all
                raise RunStoreError(f"{path} exists and is not a run store ({exc}); choose another --out path") from exc
            old = dict(group.attrs)
            if old.get("format") != FORMAT:
                raise RunStoreError(f"{path} exists and is not a sionnafmcw run store; choose another output path")
            for key, value in attrs.items():
                if key == "sionnafmcw_version":
                    continue
                if old.get(key) != value:
                    raise RunStoreError(
                        f"{path} was written with a different {key!r}; resume only with the same settings, "
                        "or write to a new path (or delete the old store)"
                    )
            shape = group["iq"].shape
            expected = (num_frames, radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
            if shape != expected:
                raise RunStoreError(f"{path}: iq has shape {shape}, this run needs {expected}")
            return cls(group, path)

        group = zarr.open_group(str(path), mode="w-", zarr_format=3)
        n_obj = len(object_names)
        cube = (radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
        group.create_array("iq", shape=(num_frames, *cube), chunks=(1, *cube), dtype="complex64",
                           fill_value=0, dimension_names=["frame", "chirp", "tx", "rx", "sample"])
        group.create_array("frame_time", shape=(num_frames,), dtype="float64", fill_value=np.nan,
                           dimension_names=["frame"])
        group.create_array("frame_done", shape=(num_frames,), dtype="bool", fill_value=False,
                           dimension_names=["frame"])
        for name, extra, dims in (("truth_position", (3,), ["frame", "object", "xyz"]),
                                  ("truth_velocity", (3,), ["frame", "object", "xyz"]),
                                  ("truth_radial_velocity", (), ["frame", "object"])):
            group.create_array(name, shape=(num_frames, n_obj, *extra), chunks=(1, max(n_obj, 1), *extra),
                               dtype="float64", fill_value=np.nan, dimension_names=dims)
        objects = group.create_array("object", shape=(n_obj,), dtype=str, dimension_names=["object"])
        if n_obj:
            objects[:] = np.array(object_names, dtype=str)
        group.attrs.update(attrs)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # consolidated metadata is not in the v3 spec yet
            zarr.consolidate_metadata(str(path))
        return cls(group, path)

    # ------------------------------------------------------------------ frames
    def done(self) -> np.ndarray:
        """``[frame]`` bool: which frames are complete."""
        return np.asarray(self.group["frame_done"][:], dtype=bool)

    def write_frame(self, index: int, iq: np.ndarray, time: float, positions, velocities,
                    radial_velocities) -> None:
        """Write every array of frame ``index``, then mark it done (last)."""
        g = self.group
        g["iq"][index] = iq.astype(np.complex64, copy=False)
        g["frame_time"][index] = time
        if g["truth_position"].shape[1]:
            g["truth_position"][index] = positions
            g["truth_velocity"][index] = velocities
            g["truth_radial_velocity"][index] = radial_velocities
        g["frame_done"][index] = True


def open_run(path):
    """Open a run store as an ``xarray.Dataset`` (lazy), checking that it is one."""
    import xarray as xr

    path = Path(path)
    if not path.exists():
        raise RunStoreError(f"{path}: no such run store")
    try:
        ds = xr.open_zarr(str(path), consolidated=True)
    except Exception as exc:
        raise RunStoreError(f"{path} is not a readable run store: {exc}") from exc
    if ds.attrs.get("format") != FORMAT:
        raise RunStoreError(f"{path} is not a sionnafmcw run store (attribute 'format' missing)")
    return ds
