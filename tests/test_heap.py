"""sionnafmcw.heap: after limit_arenas the threads share one glibc arena, counted from glibc's own malloc_info report."""

import subprocess
import sys
import textwrap

import pytest

# In a fresh interpreter (only the main arena), N threads alive at once each allocate: glibc gives
# every one a new arena (up to eight per core); after limit_arenas(1) they share the one there is. The
# heaps are counted in malloc_info's XML (one <heap nr=...> per arena).
SCRIPT = textwrap.dedent("""
    import ctypes, sys, threading
    import numpy as np
    from sionnafmcw.heap import limit_arenas

    libc = ctypes.CDLL("libc.so.6")
    libc.open_memstream.restype = ctypes.c_void_p
    libc.malloc_info.argtypes = [ctypes.c_int, ctypes.c_void_p]
    libc.fclose.argtypes = [ctypes.c_void_p]

    def heaps():
        buf, size = ctypes.c_char_p(), ctypes.c_size_t()
        stream = libc.open_memstream(ctypes.byref(buf), ctypes.byref(size))
        libc.malloc_info(0, stream)
        libc.fclose(stream)
        return buf.value.decode().count("<heap nr=")

    def allocate_together(n):
        ready, done, kept = threading.Barrier(n + 1), threading.Event(), []
        def work():
            kept.append(np.ones(2**14))      # 128 KiB: from the thread's arena
            ready.wait()
            done.wait()
        threads = [threading.Thread(target=work) for _ in range(n)]
        for t in threads:
            t.start()
        ready.wait()
        count = heaps()
        done.set()
        for t in threads:
            t.join()
        return count

    if sys.argv[1] == "one":
        assert limit_arenas(1)
    print(allocate_together(4))
""")


def _heaps(mode: str) -> int:
    done = subprocess.run([sys.executable, "-c", SCRIPT, mode], capture_output=True, text=True, check=True)
    return int(done.stdout.split()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt and malloc_info")
def test_limit_arenas_keeps_new_threads_on_one_heap():
    """Four threads allocating at once: four more arenas without the limit, none with it."""
    assert _heaps("default") >= 1 + 4
    assert _heaps("one") == 1
