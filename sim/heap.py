"""Large arrays handed back to the system when freed: glibc's mmap threshold held fixed.

glibc serves an allocation above its mmap threshold with its own mapping, returned to the
system by free; smaller ones come from the heap, which keeps what is freed for later. The
threshold starts at 128 KiB and slides up (to 32 MiB) each time a mapped block is freed,
so after the first large temporaries, arrays of up to 32 MiB (a level's (samples, groups)
angles of one wind, 4 MiB at 1,000 groups) land on the heap, and a heap fragmented by
them stays at its high-water mark. Fixing the threshold (mallopt(M_MMAP_THRESHOLD), which
also stops the sliding) keeps every array above it in its own mapping: the chain of
abop_1_24c peaked at 1.41 GB instead of 1.68 GB in its first process, at the same wall time
in two pairs of runs (29.3-34.0 s against 29.9-30.2 s; `make bench`). Allocation only: no
value computed changes. Elsewhere than glibc (or where the call fails) nothing is done.
"""

from __future__ import annotations

import ctypes
import sys

LARGE_ARRAY_BYTES = 4 * 1024 * 1024     # arrays above this get their own mapping
_M_MMAP_THRESHOLD = -3                  # glibc's mallopt parameter (malloc.h)


def return_large_arrays(threshold: int = LARGE_ARRAY_BYTES) -> bool:
    """Fix glibc's mmap threshold at ``threshold`` bytes for this process; True where set."""
    if not sys.platform.startswith("linux"):
        return False
    try:        # the process' own symbols (glibc's among them): no library search at start-up
        return bool(ctypes.CDLL(None).mallopt(_M_MMAP_THRESHOLD, int(threshold)))
    except (OSError, AttributeError):
        return False
