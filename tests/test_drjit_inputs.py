"""Numpy arrays handed to Dr.Jit kernels: padded so that a kernel's whole-vector loads stay readable.

Dr.Jit's LLVM backend maps a contiguous numpy array without copying it, and its kernels load the
last vector of an input whole (up to ``W - 1`` elements past the end, ``W`` = 16 lanes on AVX-512).
An array that ends at a page followed by an unmapped one then faults. Each case runs in a
subprocess (a segmentation fault ends it with -SIGSEGV): an array ending at a guard page (a page
with no access, ``mprotect``) goes (a) straight into Dr.Jit -- the fault, shown where the lanes
overhang the page, and (b) through :func:`sionnafmcw.sionna_rt.aligned_copy`, whose copy carries
:data:`~sionnafmcw.sionna_rt.LLVM_TAIL_PAD` readable elements and must compute the right values.
"""

from __future__ import annotations

import signal
import subprocess
import sys

import numpy as np
import pytest

from sionnafmcw.sionna_rt import LLVM_TAIL_PAD, aligned_copy

SCRIPT = r"""
import ctypes, mmap, sys
import numpy as np
import sionnafmcw.sionna_rt as srt
import drjit as dr
import drjit.llvm as L

n, dtype, through_copy = int(sys.argv[1]), np.dtype(sys.argv[2]), sys.argv[3] == "copy"
page = mmap.PAGESIZE
buf = mmap.mmap(-1, 2 * page, prot=mmap.PROT_READ | mmap.PROT_WRITE)
base = ctypes.addressof(ctypes.c_char.from_buffer(buf))
assert ctypes.CDLL(None).mprotect(ctypes.c_void_p(base + page), page, 0) == 0   # the guard page
arr = np.frombuffer(buf, dtype=np.uint8, count=page)[page - n * dtype.itemsize:].view(dtype)  # ends at it
arr[:] = np.arange(n)
T = {"float64": L.Float64, "float32": L.Float, "uint32": L.UInt32}[dtype.name]
x = T(srt.aligned_copy(arr, dtype)) if through_copy else T(arr)
y = x * 3
dr.eval(y)
assert np.array_equal(np.asarray(y.numpy(), dtype=float), 3.0 * np.arange(n)), "wrong values"
print("ok")
"""


def run(n: int, dtype: str, how: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", SCRIPT, str(n), dtype, how], capture_output=True, text=True,
                          timeout=120)


def test_the_copy_is_aligned_and_padded():
    for dtype in (np.float32, np.float64, np.uint32, np.int32):
        for n in (1, 15, 16, 17, 1000):
            a = aligned_copy(np.arange(n), dtype)
            assert a.dtype == dtype and a.ctypes.data % 64 == 0 and np.array_equal(a, np.arange(n))
            base = a.base
            tail = base.ctypes.data + base.nbytes - (a.ctypes.data + a.nbytes)
            assert tail >= LLVM_TAIL_PAD * a.itemsize
            assert not np.any(np.frombuffer(base, dtype=np.uint8)[base.nbytes - tail:])   # zeros, not garbage


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_an_array_at_a_guard_page_faults_unless_copied(dtype):
    """17 elements: the last vector overhangs the end by 15 (AVX-512) or 7 (AVX2) elements, into the
    guard page. Straight into Dr.Jit it faults; through the copy it computes the right values."""
    straight = run(17, dtype, "straight")
    assert straight.returncode == -signal.SIGSEGV, (straight.returncode, straight.stderr[-500:])
    copied = run(17, dtype, "copy")
    assert copied.returncode == 0 and copied.stdout.strip() == "ok", copied.stderr[-500:]


def test_a_whole_number_of_vectors_does_not_fault():
    """The control: 16 elements end with the last vector (no lane past the end), no fault either way."""
    for how in ("straight", "copy"):
        done = run(16, "float64", how)
        assert done.returncode == 0 and done.stdout.strip() == "ok", (how, done.stderr[-500:])
