"""Sphinx configuration of the sionnafmcw documentation (``make docs``: HTML in docs/_build/html).

The API reference is generated from the docstrings (autodoc + napoleon for the NumPy style), the
maths is rendered by MathJax served from the documentation itself (no network at build or view
time: Debian's ``libjs-mathjax``, or ``SIONNAFMCW_MATHJAX`` pointing at a MathJax 2 ``MathJax.js``),
and the tutorial notebooks are executed while building (myst-nb) so that the pages show their
outputs; ``SIONNAFMCW_NOTEBOOK_QUICK=1`` (set by ``make docs`` unless given) runs them at the
notebooks' small settings.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

project = "sionnafmcw"
author = "the sionnafmcw developers"
copyright = "2026, the sionnafmcw developers"


def _version() -> str:
    for line in (ROOT / "pyproject.toml").read_text().splitlines():
        if line.startswith("version"):
            return line.split("=", 1)[1].strip().strip('"')
    return "unknown"


release = version = _version()

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "myst_nb",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]

# ---------------------------------------------------------------- API reference
autosummary_generate = True
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
# optional parts documented without their heavy or foreign dependencies: the `tf` extra and the
# Blender exporter (bpy, mathutils live only in .venv-blender)
autodoc_mock_imports = ["tensorflow", "bpy", "mathutils", "bpy_extras"]
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
nitpicky = False

# ---------------------------------------------------------------- notebooks (executed at build time)
# SIONNAFMCW_DOCS_NOTEBOOKS: a folder of notebooks executed elsewhere (the test suite executes
# each notebook once and builds the site from them): copied as they are and not executed again
_EXECUTED = os.environ.get("SIONNAFMCW_DOCS_NOTEBOOKS")
NOTEBOOKS_SOURCE = Path(_EXECUTED) if _EXECUTED else ROOT / "notebooks"
NOTEBOOKS_TARGET = HERE / "notebooks"
NOTEBOOKS_TARGET.mkdir(exist_ok=True)
for nb in sorted(NOTEBOOKS_SOURCE.glob("*.ipynb")):
    target = NOTEBOOKS_TARGET / nb.name
    if not target.exists() or target.read_bytes() != nb.read_bytes():
        shutil.copyfile(nb, target)
os.environ.setdefault("SIONNAFMCW_NOTEBOOK_QUICK", "1")
nb_execution_mode = os.environ.get("SIONNAFMCW_DOCS_EXECUTE", "off" if _EXECUTED else "force")
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_in_temp = True
nb_merge_streams = True
# Markdown a cell displays (IPython.display.Markdown: the tables of sionnafmcw's reports) parsed as
# MyST, like the pages; myst-nb's default, CommonMark, has no tables
nb_render_markdown_format = "myst"

# ---------------------------------------------------------------- maths: MathJax from the site itself
def _mathjax_dir() -> Path | None:
    given = os.environ.get("SIONNAFMCW_MATHJAX")
    candidates = [Path(given).parent] if given else []
    candidates.append(Path("/usr/share/javascript/mathjax"))
    for c in candidates:
        if (c / "MathJax.js").is_file():
            return c
    return None


_MATHJAX = _mathjax_dir()
if _MATHJAX is None:
    raise RuntimeError(
        "docs/conf.py: no local MathJax 2 found; install it (Debian/Ubuntu: apt-get install -y libjs-mathjax "
        "fonts-mathjax) or set SIONNAFMCW_MATHJAX to the path of MathJax.js")
html_static_path = ["_static"]
_STATIC = HERE / "_static"
_STATIC.mkdir(exist_ok=True)
_LOCAL_MATHJAX = _STATIC / "mathjax"
if not _LOCAL_MATHJAX.exists():
    # the minified build only (MathJax.js, config, jax, extensions, fonts, localization: ~30 MB)
    shutil.copytree(_MATHJAX, _LOCAL_MATHJAX, symlinks=False, ignore_dangling_symlinks=True,
                    ignore=shutil.ignore_patterns("unpacked", "test"))
mathjax_path = "mathjax/MathJax.js?config=TeX-AMS-MML_HTMLorMML"

# ---------------------------------------------------------------- HTML
html_theme = "furo"
html_title = f"sionnafmcw {release}"

# MathJax 2: Sphinx marks the page body tex2jax_ignore and each formula with the class "math"
mathjax2_config = {
    "tex2jax": {
        "inlineMath": [["\\(", "\\)"]],
        "displayMath": [["\\[", "\\]"]],
        "processEscapes": True,
        "processClass": "math|tex2jax_process|output_area",
        "ignoreClass": "tex2jax_ignore|mathjax_ignore",
    },
    "HTML-CSS": {"availableFonts": ["TeX"], "imageFont": None},
}
