# sionnafmcw: the two commands of the README.
#   make demo   the paper's walking person (circle walk) through the path engine; plots in out/circle_walk
#   make test   runs the test suite (the heavy `slow` cases: make test-slow)
#   make docs   the documentation site (Sphinx, warnings as errors): docs/_build/html/index.html
VENV ?= .venv
PY := $(VENV)/bin/python
PYTEST_ARGS ?=

.PHONY: demo test test-slow docs setup clean

$(VENV)/.installed: pyproject.toml scripts/setup.sh
	VENV=$(VENV) bash scripts/setup.sh

# Blender as a Python module (bpy 4.5, needs numpy<2) for the Blender exporter and its tests:
# its own environment, never .venv
.venv-blender/.installed: scripts/setup_blender.sh
	bash scripts/setup_blender.sh

# OpenRadar (openradar 1.0.1, needs numpy<1.24) for the TI interoperability test: its own
# environment; it reads the DCA1000 captures sionnafmcw.ti writes
.venv-openradar/.installed: scripts/setup_openradar.sh
	bash scripts/setup_openradar.sh

setup: $(VENV)/.installed

demo: $(VENV)/.installed
	$(PY) validation/circle_walk.py --engine path --out out/circle_walk

test: $(VENV)/.installed .venv-blender/.installed .venv-openradar/.installed
	$(PY) -m pytest -m "not slow" -q $(PYTEST_ARGS)

test-slow: $(VENV)/.installed .venv-blender/.installed .venv-openradar/.installed
	$(PY) -m pytest -m slow -q $(PYTEST_ARGS)

# the notebooks are executed while building (at their small settings), so the Blender env is needed
docs: $(VENV)/.installed .venv-blender/.installed
	SIONNAFMCW_NOTEBOOK_QUICK=1 $(PY) -m sphinx -W --keep-going -b html docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

clean:
	rm -rf out .pytest_cache .hypothesis docs/_build docs/api/generated docs/_static/mathjax docs/notebooks
