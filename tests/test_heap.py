"""sionnafmcw.heap: freed arena memory goes back to the OS (glibc), measured on the process's resident size."""

import sys
import threading

import numpy as np
import pytest

from sionnafmcw.heap import release_free_memory


def _resident_mib() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim and /proc are Linux's")
def test_release_free_memory_returns_a_threads_freed_arena_pages():
    """A worker thread allocates 1 MiB blocks (below glibc's raised mmap threshold: served from its
    arena), frees every other one so that the arena cannot shrink from its top, and ends; the
    resident size falls by at least half of what was freed (64 MiB) once the pages are released."""
    # one large free first: glibc raises its mmap threshold past 1 MiB, as after a run's first frame
    np.ones(2**21).sum()   # 16 MiB: mmapped, and its free sets the threshold to 16 MiB
    kept = []

    def work():
        blocks = [np.ones(2**17) for _ in range(256)]   # 256 x 1 MiB
        kept.extend(blocks[1::2])                      # half stay alive, interleaved
        del blocks

    t = threading.Thread(target=work)
    t.start()
    t.join()
    before = _resident_mib()
    assert release_free_memory() is True
    after = _resident_mib()
    assert before - after >= 64, (before, after)
    assert len(kept) == 128
