"""Locate a system libLLVM that Dr.Jit's LLVM backend can use.

Dr.Jit 1.5 crashes with libLLVM-15 ("Cannot select fmaximum"), so the simulator needs
libLLVM >= 16. When ``DRJIT_LIBLLVM_PATH`` is unset, :func:`configure_llvm` points it at the
newest libLLVM >= 16 found in the usual library folders; when there is none it raises
:class:`LLVMNotFoundError` with the command that installs one.
"""

from __future__ import annotations

import glob
import os
import re

MIN_LLVM_MAJOR = 16

SEARCH_DIRS = (
    "/usr/lib/x86_64-linux-gnu",
    "/usr/lib/aarch64-linux-gnu",
    "/usr/lib64",
    "/usr/lib",
    "/usr/local/lib",
    "/opt/homebrew/opt/llvm/lib",
    "/usr/local/opt/llvm/lib",
)

INSTALL_HINT = (
    "Install one, e.g. on Debian/Ubuntu `apt-get install -y libllvm19` (as root), "
    "or set DRJIT_LIBLLVM_PATH to the full path of a libLLVM.so of version >= 16."
)


class LLVMNotFoundError(RuntimeError):
    """No libLLVM >= 16 could be found for Dr.Jit's LLVM backend."""


def _major_version(path: str) -> int | None:
    name = os.path.basename(path)
    for pattern in (r"libLLVM-(\d+)", r"libLLVM\.so\.(\d+)", r"libLLVM\.(\d+)\.dylib", r"llvm-(\d+)"):
        match = re.search(pattern, name) or re.search(pattern, path)
        if match:
            return int(match.group(1))
    return None


def find_libllvm(min_major: int = MIN_LLVM_MAJOR, search_dirs=SEARCH_DIRS) -> str | None:
    """Return the path of the newest libLLVM with major version >= ``min_major``, or None."""
    candidates = []
    for directory in search_dirs:
        for pattern in ("libLLVM-*.so*", "libLLVM.so.*", "libLLVM*.dylib", "llvm-*/lib/libLLVM*.so*"):
            for path in glob.glob(os.path.join(directory, pattern)):
                major = _major_version(path)
                if major is not None and major >= min_major and os.path.isfile(path):
                    candidates.append((major, len(path), path))
    if not candidates:
        return None
    # newest major first; among equal majors prefer the shortest (least versioned) name
    candidates.sort(key=lambda c: (-c[0], c[1]))
    return candidates[0][2]


def configure_llvm() -> str:
    """Set ``DRJIT_LIBLLVM_PATH`` if unset and return the libLLVM path Dr.Jit will use."""
    current = os.environ.get("DRJIT_LIBLLVM_PATH")
    if current:
        if not os.path.isfile(current):
            raise LLVMNotFoundError(
                f"DRJIT_LIBLLVM_PATH={current!r} does not exist. " + INSTALL_HINT
            )
        return current
    path = find_libllvm()
    if path is None:
        raise LLVMNotFoundError(
            f"sionnafmcw needs libLLVM >= {MIN_LLVM_MAJOR} for Dr.Jit's LLVM backend "
            f"(libLLVM-15 crashes it) and found none in {', '.join(SEARCH_DIRS)}. " + INSTALL_HINT
        )
    os.environ["DRJIT_LIBLLVM_PATH"] = path
    return path
