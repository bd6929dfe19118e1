"""The tutorial notebooks, executed top to bottom by a real Jupyter kernel (ipykernel) with nbclient.

Every notebook reads two parameters from the environment in its first code cell:
``SIONNAFMCW_NOTEBOOK_QUICK=1`` (small settings: fewer frames, rays and pixels) and
``SIONNAFMCW_NOTEBOOK_OUT`` (where it writes scenes, stores and figures). The notebooks are kept
in git with their outputs cleared. Each is executed once per session (``executed_notebooks``,
``tests/notebook_runs.py``); the documentation build renders the same executed notebooks.
"""

from __future__ import annotations

import os

import nbformat
import pytest

from notebook_runs import EXPECTED, NOTEBOOK_DIR, missing_data


def test_the_tutorials_exist_with_outputs_cleared():
    found = sorted(p.name for p in NOTEBOOK_DIR.glob("*.ipynb"))
    assert found == EXPECTED
    for name in EXPECTED:
        nb = nbformat.read(NOTEBOOK_DIR / name, as_version=4)
        nbformat.validate(nb)
        code = [c for c in nb.cells if c.cell_type == "code"]
        assert code, f"{name} has no code cell"
        assert "SIONNAFMCW_NOTEBOOK_QUICK" in code[0].source, f"{name}: the first code cell must read the parameters"
        for cell in code:
            assert not cell.get("outputs") and cell.get("execution_count") is None, (
                f"{name}: outputs must be cleared in git (jupyter nbconvert --clear-output --inplace {name})")
        assert nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# "), f"{name}: title cell"


@pytest.mark.parametrize("name", EXPECTED)
def test_notebook_executes(name, executed_notebooks):
    if missing_data(name):
        pytest.skip(missing_data(name))
    nb, out = executed_notebooks[name]
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert not errors, errors
    # every cell ran, and every notebook ends by showing at least one figure
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(c.get("execution_count") is not None for c in code), f"{name}: a cell did not run"
    images = [o for c in code for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
    assert images, f"{name} produced no figure"
    assert os.listdir(out), f"{name} wrote nothing to SIONNAFMCW_NOTEBOOK_OUT"


def test_ti_notebook_writes_what_the_real_recordings_reader_reads(executed_notebooks):
    """06: the simulated recording has the arrays and dtypes of RadHAR's real ``.npz``, reads back with
    the same reader, holds only frames the notebook simulated (QUICK: 3), and the notebook shows it
    next to the real recordings (table and figures)."""
    import numpy as np

    from notebook_runs import radhar_folder
    from sionnafmcw.ti.formats import read_recording

    name = "06_ti_point_cloud.ipynb"
    if missing_data(name):
        pytest.skip(missing_data(name))
    nb, out = executed_notebooks[name]
    real_file = sorted((radhar_folder() / "train" / "jump").glob("*.npz"))[0]
    with np.load(out / "sim_jump.npz") as sim, np.load(real_file) as real:
        assert sorted(sim.files) == sorted(real.files)
        for key in real.files:
            assert sim[key].dtype.kind == real[key].dtype.kind and sim[key].ndim == real[key].ndim, key
    recording = read_recording(out / "sim_jump.npz")
    assert recording.activity == "jump"
    assert set(recording.frame.tolist()) <= {0, 1, 2}
    text = "".join(o.get("data", {}).get("text/plain", "") + o.get("text", "")
                   for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []))
    assert "simulated (this run)" in text and "RadHAR jump, all" in text
    images = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if "image/png" in o.get("data", {})]
    assert len(images) >= 3          # the scene, simulated next to real, the range CFAR


def test_notebook_07_exports_radhar_files_and_scores_every_class(executed_notebooks):
    """07: the synthetic set it exported is one RadHAR ``.npz`` per class (QUICK: one item of 5 frames
    each) that RadHAR's reader reads, with the real recordings' arrays; its classifier was scored on
    real windows of all five classes (confusion matrix 5 x 5, every row a class with real windows,
    its sum the windows scored) and the ceiling tested too; the notebook shows the figures."""
    import json

    import numpy as np

    from notebook_runs import radhar_folder
    from sionnafmcw.ti.formats.radhar import read_dataset
    from sionnafmcw.validation.sim_to_real_radhar import FOLDERS

    name = "07_sim_to_real_radhar.ipynb"
    if missing_data(name):
        pytest.skip(missing_data(name))
    nb, out = executed_notebooks[name]
    files = sorted((out / "synthetic").glob("*/*.npz"))
    assert sorted(p.parent.name for p in files) == sorted(FOLDERS)
    recordings = list(read_dataset(out / "synthetic"))
    assert sorted(r.activity for r in recordings) == sorted(FOLDERS)
    for rec in recordings:
        assert rec.num_points > 0 and set(rec.frame.tolist()) <= set(range(5))
    real_file = sorted((radhar_folder() / "train" / "jump").glob("*.npz"))[0]
    with np.load(files[0]) as sim, np.load(real_file) as real:
        assert sorted(sim.files) == sorted(real.files)
    metrics = json.loads((out / "metrics.json").read_text())
    for key in ("sim_to_real", "real_to_real"):
        confusion = np.asarray(metrics[key]["confusion"])
        assert confusion.shape == (5, 5) and confusion.sum() == metrics[key]["windows"] > 0, key
        assert set(metrics[key]["recall"]) == set(FOLDERS), key
        assert 0 <= metrics[key]["accuracy"] <= 1, key
    assert np.asarray(metrics["sim_to_real"]["confusion"]).sum(1).all()     # every class has real windows
    assert metrics["sim_to_real"]["train_windows"] == 5
    assert set(metrics["statistics"]["simulated"]) == set(FOLDERS) == set(metrics["statistics"]["real"])
    images = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if "image/png" in o.get("data", {})]
    assert len(images) >= 3          # frames side by side, Doppler histograms, confusion matrices
