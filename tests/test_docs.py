"""The documentation site builds from the docstrings with warnings as errors, its notebooks are
rendered with their outputs (executed by a real kernel this session), and the formulas render in a real browser (headless
Chromium running the site's own MathJax): no raw LaTeX is left on a page."""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


@pytest.fixture(scope="module")
def site(tmp_path_factory, executed_notebooks):
    """The site built with warnings as errors, its notebook pages from the notebooks this session
    executed (each runs once: ``tests/notebook_runs.py``; ``make docs`` executes them itself)."""
    out = tmp_path_factory.mktemp("docs") / "html"
    env = dict(os.environ, SIONNAFMCW_NOTEBOOK_QUICK="1", SIONNAFMCW_DOCS_NOTEBOOKS=str(executed_notebooks.folder()))
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           str(ROOT / "docs"), str(out)], capture_output=True, text=True, env=env, cwd=ROOT)
    assert proc.returncode == 0, f"sphinx failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-6000:]}"
    return out


def test_every_page_is_built(site):
    for page in ("index", "install", "conventions", "data_contract", "api", "guide/engines", "guide/ti",
                 "guide/receiver",
                 "guide/datasets", "guide/scenes", "notebooks/01_quick_start", "notebooks/04_dataset_dask_tensorflow"):
        assert (site / f"{page}.html").is_file(), page
    api = (site / "api.html").read_text()
    for module in ("sionnafmcw.engines", "sionnafmcw.store", "sionnafmcw.synthesis", "sionnafmcw.ti"):
        assert module in api, module


def test_notebooks_are_rendered_with_outputs(site):
    html = (site / "notebooks" / "01_quick_start.html").read_text()
    assert "cell_output" in html                      # executed: output cells on the page
    assert re.search(r'<img[^>]+src="[^"]+\.png"', html)  # and the figures they drew


def _rendered_text(page: Path) -> tuple[str, str]:
    """The DOM of ``page`` after its scripts ran (headless Chromium), and its visible text."""
    proc = subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=30000",
                           "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=120)
    dom = proc.stdout
    visible = re.sub(r"<(script|style)\b.*?</\1>", "", dom, flags=re.S)
    return dom, re.sub(r"<[^>]+>", "", visible)


@pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium is installed by scripts/setup.sh (apt-get install chromium)")
@pytest.mark.parametrize("page", ["conventions.html", "guide/ti.html", "api/generated/sionnafmcw.engines.pixel.html"])
def test_formulas_render_in_a_browser(site, page):
    html = (site / page).read_text()
    raw = len(re.findall(r'class="math', html))
    assert raw > 0, f"{page} has no formula to render"
    dom, text = _rendered_text(site / page)
    rendered = len(re.findall(r'class="MathJax(_Display)?"', dom))
    assert rendered >= raw, f"{page}: {rendered} of {raw} formulas rendered"
    leftovers = re.findall(r"\\\(|\\\)|\\\[|\\\]|\$\$|\\frac|\\mathbf", text)
    assert not leftovers, f"{page}: raw LaTeX left on the page: {leftovers[:5]}"
