"""Execute the tutorial notebooks once per test session (a real ipykernel through nbclient).

``tests/test_notebooks.py`` checks the executed notebooks, and ``tests/test_docs.py`` builds the
documentation site from the same executed notebooks (``SIONNAFMCW_DOCS_NOTEBOOKS``), so that each
notebook runs once per session instead of twice. Every notebook reads its parameters from the
environment in its first code cell: ``SIONNAFMCW_NOTEBOOK_QUICK=1`` (small settings) and
``SIONNAFMCW_NOTEBOOK_OUT`` (where it writes scenes, stores and figures). A notebook that needs data
the repository does not hold (``NEEDS``: RadHAR's real recordings) is skipped where the data is
absent, and the documentation shows it unexecuted.
"""

from __future__ import annotations

import os
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOK_DIR = Path(__file__).resolve().parents[1] / "notebooks"
EXPECTED = [
    "01_quick_start.ipynb",
    "02_walking_person.ipynb",
    "03_blender_scene.ipynb",
    "04_dataset_dask_tensorflow.ipynb",
    "05_people_activities.ipynb",
    "06_ti_point_cloud.ipynb",
    "07_sim_to_real_radhar.ipynb",
]


def radhar_folder() -> Path | None:
    """RadHAR's real recordings as ``06_ti_point_cloud`` and ``07_sim_to_real_radhar`` find them:
    ``SIONNAFMCW_RADHAR``, else ``shared/realdata/radhar`` beside or above the repository."""
    given = os.environ.get("SIONNAFMCW_RADHAR")
    if given:
        return Path(given)
    for parent in NOTEBOOK_DIR.parents:
        if (parent / "shared" / "realdata" / "radhar").is_dir():
            return parent / "shared" / "realdata" / "radhar"
    return None


def _radhar_missing() -> str | None:
    folder = radhar_folder()
    if folder is None or not (folder / "1443es1_short_range_3d.cfg").is_file() or not (folder / "train").is_dir():
        return ("RadHAR's real recordings (shared/realdata/radhar: the .cfg and train/) are absent; "
                "set SIONNAFMCW_RADHAR to the folder")
    return None


#: Data a notebook needs that the repository does not hold: ``{name: check}``, the check returning
#: why it is missing (None: present).
NEEDS = {"06_ti_point_cloud.ipynb": _radhar_missing, "07_sim_to_real_radhar.ipynb": _radhar_missing}


def missing_data(name: str) -> str | None:
    """Why notebook ``name`` cannot run here (data it needs is absent), or None."""
    check = NEEDS.get(name)
    return check() if check else None


def execute(name: str, out: Path) -> nbformat.NotebookNode:
    """Notebook ``name`` executed top to bottom at its quick settings, writing under ``out``;
    an error in a cell is kept as an ``error`` output (the tests assert there is none)."""
    nb = nbformat.read(NOTEBOOK_DIR / name, as_version=4)
    with pytest.MonkeyPatch.context() as env:   # the kernel inherits the environment
        # PYTHONFAULTHANDLER: a kernel that dies of a fatal signal prints every thread's Python stack
        # to the captured stderr (nbclient itself only reports "Kernel died")
        for key, value in (("SIONNAFMCW_NOTEBOOK_QUICK", "1"), ("SIONNAFMCW_NOTEBOOK_OUT", str(out)),
                           ("MPLBACKEND", "Agg"), ("PYTHONFAULTHANDLER", "1")):
            env.setenv(key, value)
        client = NotebookClient(nb, timeout=900, kernel_name="python3", allow_errors=True,
                                resources={"metadata": {"path": str(NOTEBOOK_DIR)}})
        client.execute()
    return nb


class ExecutedNotebooks:
    """Lazily executed notebooks of one session: ``runs[name]`` -> ``(notebook, out_dir)``;
    :meth:`folder` writes all of them, executed, into one folder (for the docs build)."""

    def __init__(self, root: Path):
        self.root = Path(root)
        self._done: dict = {}

    def __getitem__(self, name: str):
        if name not in self._done:
            out = self.root / "out" / Path(name).stem
            out.mkdir(parents=True, exist_ok=True)
            self._done[name] = (execute(name, out), out)
        return self._done[name]

    def folder(self) -> Path:
        folder = self.root / "executed"
        folder.mkdir(exist_ok=True)
        for name in EXPECTED:
            nb = nbformat.read(NOTEBOOK_DIR / name, as_version=4) if missing_data(name) else self[name][0]
            nbformat.write(nb, folder / name)
        return folder
