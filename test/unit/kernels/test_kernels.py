"""grasp_intent_ros.kernels: the package's cache handling.

The kernels' maths is tested in test_planner.py, test_kinematics.py and test_body.py.
"""

from __future__ import annotations

from pathlib import Path

from grasp_intent_ros.kernels import _drop_stale_caches


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
