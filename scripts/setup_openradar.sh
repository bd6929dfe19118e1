#!/usr/bin/env bash
# Creates .venv-openradar: OpenRadar (`openradar` on PyPI, imported as `mmwave`) for the TI
# interoperability test (tests/test_openradar.py runs tests/openradar_harness.py in it).
#
# openradar 1.0.1 calls numpy.complex (removed in numpy 1.24) and imports scipy and scikit-learn
# without declaring them, while the simulator's run store (Zarr v3) needs numpy >= 2: the two never
# share an environment. The hand-off is a file both read: the DCA1000 capture of
# sionnafmcw.io.dca1000.
#
# Idempotent: does nothing when the stamp file .venv-openradar/.installed exists and mmwave imports.
# Environment: OPENRADAR_VENV (default .venv-openradar), OPENRADAR_PYTHON (an interpreter of
# Python 3.8-3.11, for which numpy 1.23 ships wheels; default: python3.11, else python3).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${OPENRADAR_VENV:-.venv-openradar}
STAMP="$VENV/.installed"
SPECS=("openradar==1.0.1" "numpy>=1.21,<1.24" "scipy>=1.7,<1.12" "scikit-learn>=1.0,<1.4")

fail() {
  echo "setup_openradar: $*" >&2
  echo "setup_openradar: the OpenRadar interoperability test needs this environment." >&2
  echo "                 Fix the cause above and run 'bash scripts/setup_openradar.sh' again, or remove $VENV to start over." >&2
  exit 1
}

if [ -f "$STAMP" ] && "$VENV/bin/python" -c "import mmwave.dsp, mmwave.dataloader" >/dev/null 2>&1; then
  exit 0
fi

if [ -z "${OPENRADAR_PYTHON:-}" ]; then
  if command -v python3.11 >/dev/null 2>&1; then OPENRADAR_PYTHON=python3.11; else OPENRADAR_PYTHON=python3; fi
fi
command -v "$OPENRADAR_PYTHON" >/dev/null 2>&1 || fail "no Python interpreter '$OPENRADAR_PYTHON' found"
PYVER=$("$OPENRADAR_PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
case "$PYVER" in
  3.8|3.9|3.10|3.11) ;;
  *) fail "$OPENRADAR_PYTHON is Python $PYVER; numpy<1.24 has wheels for Python 3.8-3.11 only (set OPENRADAR_PYTHON=/path/to/python3.11)" ;;
esac

if [ ! -x "$VENV/bin/python" ]; then
  "$OPENRADAR_PYTHON" -m venv "$VENV" || fail "'$OPENRADAR_PYTHON -m venv $VENV' failed (Debian/Ubuntu: apt-get install python3-venv)"
fi
echo "setup_openradar: installing ${SPECS[*]} into $VENV"
"$VENV/bin/python" -m pip install -q --upgrade pip || fail "could not upgrade pip in $VENV"
"$VENV/bin/python" -m pip install -q "${SPECS[@]}" || fail "pip could not install ${SPECS[*]}"
if ! err=$("$VENV/bin/python" -c "import mmwave.dsp, mmwave.dataloader, numpy; assert numpy.__version__ < '1.24'" 2>&1); then
  echo "$err" | tail -5 >&2
  fail "openradar installed but 'import mmwave' fails"
fi
touch "$STAMP"
echo "setup_openradar: $VENV ready (openradar $("$VENV/bin/python" -c 'import importlib.metadata as m; print(m.version("openradar"))'), numpy $("$VENV/bin/python" -c 'import numpy; print(numpy.__version__)'))"
