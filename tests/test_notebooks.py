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
