#!/usr/bin/env bash
# Creates .venv-blender: Blender as a Python module (bpy 4.5, Python 3.11 wheel from PyPI,
# ~370 MB) for the Blender exporter (sionnafmcw/blender/export.py) and its tests, and, when root on
# Debian/Ubuntu, installs the distribution's Blender binary with the numpy of the system Python it
# runs on (apt-get install blender python3-numpy: Blender 3.4.1 on Debian 12, ~185 packages, ~165 MB of .deb)
# for the test of the binary route, tests/test_blender_binary.py (skipped where there is no blender).
#
# bpy is built against numpy 1.x (its wheel needs numpy<2), while the simulator needs numpy 2:
# the two never share an environment. The exporter runs here (or inside a Blender binary) as a
# subprocess; the simulator's .venv only reads the animation directory it writes.
#
# Idempotent: does nothing when the stamp file .venv-blender/.installed exists and bpy imports.
# Environment: BLENDER_VENV (default .venv-blender), BLENDER_PYTHON (an interpreter of Python
# 3.11, the only version bpy 4.5 ships wheels for; default: python3.11, else python3).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${BLENDER_VENV:-.venv-blender}
STAMP="$VENV/.installed"
BPY_SPEC=${BPY_SPEC:-"bpy==4.5.*"}

fail() {
  echo "setup_blender: $*" >&2
  echo "setup_blender: the Blender exporter and its tests need bpy (Blender as a Python module)." >&2
  echo "               Fix the cause above and run 'bash scripts/setup_blender.sh' again, or remove $VENV to start over." >&2
  exit 1
}

# The distribution's Blender runs on the system Python, which has numpy only through python3-numpy
# (not a dependency of Debian's blender package): the exporter needs both.
need_pkgs=()
command -v blender >/dev/null 2>&1 || need_pkgs+=(blender)
if command -v dpkg >/dev/null 2>&1 && ! dpkg -s python3-numpy >/dev/null 2>&1; then need_pkgs+=(python3-numpy); fi
if [ ${#need_pkgs[@]} -gt 0 ]; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup_blender: installing ${need_pkgs[*]} (the distribution's Blender, for the binary-route test)"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_pkgs[@]}" >/dev/null
  else
    echo "setup_blender: ${need_pkgs[*]} missing: tests/test_blender_binary.py (the Blender binary route) is skipped" >&2
    echo "               without blender and fails without numpy (Debian/Ubuntu: sudo apt-get install -y blender python3-numpy)." >&2
  fi
fi

if [ -f "$STAMP" ] && "$VENV/bin/python" -c "import bpy" >/dev/null 2>&1; then
  exit 0
fi

if [ -z "${BLENDER_PYTHON:-}" ]; then
  if command -v python3.11 >/dev/null 2>&1; then BLENDER_PYTHON=python3.11; else BLENDER_PYTHON=python3; fi
fi
command -v "$BLENDER_PYTHON" >/dev/null 2>&1 || fail "no Python interpreter '$BLENDER_PYTHON' found"
PYVER=$("$BLENDER_PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
if [ "$PYVER" != "3.11" ]; then
  fail "$BLENDER_PYTHON is Python $PYVER; bpy 4.5 is published for Python 3.11 only (set BLENDER_PYTHON=/path/to/python3.11)"
fi

if [ ! -x "$VENV/bin/python" ]; then
  "$BLENDER_PYTHON" -m venv "$VENV" || fail "'$BLENDER_PYTHON -m venv $VENV' failed (Debian/Ubuntu: apt-get install python3-venv)"
fi
echo "setup_blender: installing $BPY_SPEC and numpy<2 into $VENV (about 370 MB download)"
"$VENV/bin/python" -m pip install -q --upgrade pip || fail "could not upgrade pip in $VENV"
"$VENV/bin/python" -m pip install -q "$BPY_SPEC" "numpy<2" || fail "pip could not install '$BPY_SPEC' 'numpy<2'"
# bpy needs some X/GL client libraries even headless; name them if the import fails
if ! err=$("$VENV/bin/python" -c "import bpy, numpy; assert numpy.__version__ < '2'" 2>&1); then
  echo "$err" | tail -5 >&2
  fail "bpy installed but does not import (missing system libraries? Debian/Ubuntu: apt-get install -y libxrender1 libxxf86vm1 libxfixes3 libxi6 libxkbcommon0 libsm6 libgl1)"
fi
touch "$STAMP"
echo "setup_blender: $VENV ready ($("$VENV/bin/python" -c 'import bpy; print("Blender", bpy.app.version_string)'))"
