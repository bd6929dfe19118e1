#!/usr/bin/env bash
# Creates the simulator's virtual environment (.venv) and the system library it needs.
#   - libLLVM >= 16 for Dr.Jit's LLVM backend (libLLVM-15 crashes it): installed with apt-get
#     when we are root on Debian/Ubuntu, otherwise we stop and say what to install.
#   - libjs-mathjax, fonts-mathjax, chromium for the documentation and its test (apt-get as root).
#   - .venv with the package and its test, tf, torch and docs extras (tensorflow-cpu: ~270 MB download, ~1.4 GB
#     installed; PyTorch's CPU build: ~190 MB download, ~0.87 GB installed with its dependencies, see below).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VENV:-.venv}
PYTHON=${PYTHON:-python3}

have_llvm() {
  if [ -n "${DRJIT_LIBLLVM_PATH:-}" ] && [ -f "$DRJIT_LIBLLVM_PATH" ]; then return 0; fi
  for f in /usr/lib/*/libLLVM-1[6-9]*.so* /usr/lib/*/libLLVM-[2-9][0-9]*.so* /usr/lib/*/libLLVM.so.1[6-9]* \
           /usr/lib/*/libLLVM.so.[2-9][0-9]* /usr/lib64/libLLVM-1[6-9]*.so* /usr/lib/libLLVM-1[6-9]*.so*; do
    [ -f "$f" ] && return 0
  done
  return 1
}

if ! have_llvm; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup: installing libllvm19 (Dr.Jit needs libLLVM >= 16)"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libllvm19 >/dev/null
  else
    echo "setup: Dr.Jit's LLVM backend needs libLLVM >= 16 and none was found." >&2
    echo "       Install one (Debian/Ubuntu: sudo apt-get install -y libllvm19; macOS: brew install llvm)" >&2
    echo "       or set DRJIT_LIBLLVM_PATH to a libLLVM.so of version >= 16, then run this again." >&2
    exit 1
  fi
fi

# The documentation's maths is rendered by a local MathJax 2 and checked in headless Chromium
# (tests/test_docs.py): both from the distribution when we are root on Debian/Ubuntu.
need_pkgs=()
[ -f /usr/share/javascript/mathjax/MathJax.js ] || need_pkgs+=(libjs-mathjax fonts-mathjax)
command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || need_pkgs+=(chromium)
if [ ${#need_pkgs[@]} -gt 0 ]; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup: installing ${need_pkgs[*]} (documentation: local MathJax, headless Chromium)"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_pkgs[@]}" >/dev/null
  else
    echo "setup: the documentation needs ${need_pkgs[*]} (Debian/Ubuntu: sudo apt-get install -y ${need_pkgs[*]});" >&2
    echo "       'make docs' and its test fail without them." >&2
  fi
fi

if [ ! -x "$VENV/bin/python" ]; then
  "$PYTHON" -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install -q --upgrade pip
# PyTorch (sionnafmcw.torch) as its CPU build: PyPI's Linux wheel (~555 MB) is the CUDA build and pulls
# ~2.2 GB of nvidia-* wheels and triton (~0.25 GB), of no use without a GPU; without them it does not
# import (libcudnn.so.9 missing). The CPU build (a torch-*+cpu wheel, ~190 MB) is taken from the folder
# TORCH_WHEELS (default: /opt/wheels, pip's find-links on this project's machines) or from the index
# TORCH_INDEX (PyTorch's CPU wheel index, see docs/install.md); its pure-Python dependencies come first
# from the usual indexes, then torch alone, so that no other index can hand pip the CUDA build. With
# neither, PyPI's CUDA build is installed (correct on a CPU too, only larger).
TORCH_WHEELS=${TORCH_WHEELS:-/opt/wheels}
if ! "$VENV/bin/python" -c "import torch" >/dev/null 2>&1; then
  "$VENV/bin/python" -m pip install -q filelock "typing-extensions>=4.10" "sympy>=1.13.3" "networkx>=2.5.1" jinja2 \
    "fsspec>=0.8.5" "setuptools>=77"
  if compgen -G "$TORCH_WHEELS/torch-*+cpu-*.whl" >/dev/null; then
    "$VENV/bin/python" -m pip install -q --no-deps --no-index --find-links "$TORCH_WHEELS" "torch>=2.4"
  elif [ -n "${TORCH_INDEX:-}" ]; then
    "$VENV/bin/python" -m pip install -q --no-deps --index-url "$TORCH_INDEX" "torch>=2.4"
  else
    echo "setup: no CPU build of PyTorch in $TORCH_WHEELS and no TORCH_INDEX: installing PyPI's CUDA build (~3 GB)"
  fi
fi
"$VENV/bin/python" -m pip install -q -e ".[test,tf,torch,docs]"
touch "$VENV/.installed"
echo "setup: $VENV ready"
