"""glibc's bytes in use (``mallinfo2``), for tests that a call keeps no native memory.

tracemalloc sees only Python's allocators: a leak in a compiled extension shows only in malloc's own
count (eigenpy leaked 80 bytes per ``pin.Quaternion(R)``, once per plan of the planner).
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable

__all__ = ['malloc_in_use', 'growth_over']


class _MallInfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in (
        'arena', 'ordblks', 'smblks', 'hblks', 'hblkhd', 'usmblks', 'fsmblks', 'uordblks', 'fordblks', 'keepcost')]


_mallinfo2 = getattr(ctypes.CDLL(None), 'mallinfo2', None)  # glibc >= 2.33
if _mallinfo2 is not None:
    _mallinfo2.restype = _MallInfo2


def malloc_in_use() -> int | None:
    """Bytes malloc has handed out and not taken back (all arenas), or None without glibc's mallinfo2."""
    return None if _mallinfo2 is None else int(_mallinfo2().uordblks)


def growth_over(call: Callable[[int], object], n: int, *, warm_up: int = 100) -> int | None:
    """Bytes in use after ``call(i)`` for i < ``n`` minus before (after ``warm_up`` calls); None without mallinfo2."""
    for i in range(warm_up):
        call(i)
    before = malloc_in_use()
    for i in range(n):
        call(i)
    after = malloc_in_use()
    return None if before is None or after is None else after - before
