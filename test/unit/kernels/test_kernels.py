"""grasp_intent_ros.kernels: the package's cache handling, and the lexicographic order against numpy's.

The kernels' maths is tested in test_planner.py, mico/test_ik.py and test_body.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_intent_ros.kernels import _drop_stale_caches, lex_order

_KEY = st.sampled_from([0.0, -0.0, 1.0, -1.0, 2.5, 1e9, -1e9, np.inf, -np.inf, np.nan])


def test_every_kernel_cache_is_dropped_when_any_kernel_source_changes(tmp_path: Path) -> None:
    """Numba checks a cache against its own file only: a caller compiled with an old callee must go too."""
    (tmp_path / 'rounds.py').write_text('x = 1\n')
    (tmp_path / 'geometry.py').write_text('y = 1\n')
    cache = tmp_path / '__pycache__'
    cache.mkdir()

    def cached() -> list[str]:
        return sorted(p.name for p in cache.glob('*.nb[ic]'))

    for name in ('rounds.f-1.py311.nbi', 'rounds.f-1.py311.1.nbc'):
        (cache / name).write_bytes(b'')
    _drop_stale_caches(tmp_path)  # no record of the sources they were compiled from
    assert cached() == []
    (cache / 'rounds.f-1.py311.nbi').write_bytes(b'')
    _drop_stale_caches(tmp_path)  # the same sources: kept
    assert cached() == ['rounds.f-1.py311.nbi']
    (cache / 'rounds.f-1.py311.nbi').write_bytes(b'')
    (tmp_path / '__init__.py').write_text('"""Compiles nothing."""\n')
    _drop_stale_caches(tmp_path)
    assert cached() == ['rounds.f-1.py311.nbi']
    (tmp_path / 'geometry.py').write_text('y = 2\n')  # another module's source
    _drop_stale_caches(tmp_path)
    assert cached() == []


@settings(max_examples=300, deadline=None, derandomize=True)
@given(rows=st.integers(1, 5), columns=st.integers(0, 40), data=st.data())
def test_the_lexicographic_order_is_numpy_s_lexsort(rows: int, columns: int, data: st.DataObject) -> None:
    """Few distinct values (ties in every key), NaN, infinities and -0.0: the same permutation as np.lexsort."""
    keys = np.array(data.draw(st.lists(_KEY, min_size=rows * columns, max_size=rows * columns))).reshape(rows, columns)
    assert np.array_equal(lex_order(keys), np.lexsort(keys))


def test_the_lexicographic_order_of_many_columns_is_numpy_s_lexsort() -> None:
    """Past the merge sort's first widths: 560 columns (a shipped model's demonstrations), four quantised keys."""
    rng = np.random.default_rng(5)
    keys = np.stack([np.rint(rng.uniform(0.0, 30.0, 560) / 1e-3), rng.integers(0, 40, 560),
                     -rng.integers(0, 5, 560), rng.integers(0, 3, 560)]).astype(np.float64)
    assert np.array_equal(lex_order(keys), np.lexsort(keys))
