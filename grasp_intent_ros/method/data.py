"""Demonstration data sets: grasp feature vectors labelled with the set of tasks each satisfies.

CSV format (one row per demonstration): a header with the d feature names followed by one column per
principal task; feature cells are floats in the units of :mod:`grasp_intent_ros.method.features`, task
cells are 0 or 1. Every row must satisfy at least one task.
"""

from __future__ import annotations

import csv
import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import DataError
from .features import MICO_3F, FeatureSpace
from .intent import MAX_TASKS

__all__ = ['Demonstrations', 'load_csv', 'save_csv']


@dataclass(frozen=True)
class Demonstrations:
    """A labelled demonstration set.

    Attributes
    ----------
    x : ndarray, shape (N, d)
        Grasp features, one row per demonstration.
    task_sets : ndarray of int, shape (N,)
        Bitmask of the tasks each demonstration satisfies (bit i = task i); never 0.
    task_names : tuple of str, length m
    features : FeatureSpace
    """

    x: NDArray[np.float64]
    task_sets: NDArray[np.int64]
    task_names: tuple[str, ...]
    features: FeatureSpace = MICO_3F

    def __post_init__(self) -> None:
        x = np.asarray(self.x, dtype=np.float64)
        sets = np.asarray(self.task_sets, dtype=np.int64)
        m = len(self.task_names)
        if not 1 <= m <= MAX_TASKS:
            raise DataError(f'a data set needs 1..{MAX_TASKS} tasks, got {m}')
        if x.ndim != 2 or x.shape[1] != self.features.dim:
            raise DataError(f'x must have shape (N, {self.features.dim}), got {x.shape}')
        if sets.shape != (x.shape[0],):
            raise DataError(f'task_sets must have shape ({x.shape[0]},), got {sets.shape}')
        if not np.all(np.isfinite(x)):
            raise DataError('x contains NaN or infinity')
        if np.any(sets <= 0) or np.any(sets >= (1 << m)):
            raise DataError('every demonstration must satisfy at least one of the named tasks')
        object.__setattr__(self, 'x', x)
        object.__setattr__(self, 'task_sets', sets)

    def __len__(self) -> int:
        return int(self.x.shape[0])

    def counts(self) -> dict[int, int]:
        """Number of demonstrations per task set (bitmask -> count)."""
        values, counts = np.unique(self.task_sets, return_counts=True)
        return {int(v): int(c) for v, c in zip(values, counts)}

    def select(self, keep: NDArray[np.bool_]) -> Demonstrations:
        """The demonstrations where ``keep`` is true."""
        return Demonstrations(self.x[keep], self.task_sets[keep], self.task_names, self.features)

    def sha256(self) -> str:
        """Hash of the data (features rounded to 1e-9, task sets, names): identifies a training set."""
        h = hashlib.sha256()
        h.update(','.join(self.features.names + self.task_names).encode())
        h.update(np.round(self.x, 9).astype('<f8').tobytes())
        h.update(self.task_sets.astype('<i8').tobytes())
        return h.hexdigest()


def save_csv(demos: Demonstrations, path: str | Path) -> None:
    """Write demonstrations in the CSV format described in the module docstring."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    m = len(demos.task_names)
    with path.open('w', newline='') as f:
        writer = csv.writer(f)
        writer.writerow(list(demos.features.names) + list(demos.task_names))
        for row, mask in zip(demos.x, demos.task_sets):
            writer.writerow([f'{v:.6f}' for v in row] + [str(mask >> i & 1) for i in range(m)])


def load_csv(path: str | Path, *, features: FeatureSpace = MICO_3F) -> Demonstrations:
    """Read demonstrations from CSV.

    The first ``features.dim`` columns must be the feature names in order; every further column is a
    task.

    Raises
    ------
    DataError
        With the file, line and column of the first problem found.
    FileNotFoundError
        If the file does not exist.
    """
    path = Path(path)
    with path.open(newline='') as f:
        rows = list(csv.reader(f))
    if not rows:
        raise DataError(f'{path}: empty file')
    header = [h.strip() for h in rows[0]]
    d = features.dim
    if tuple(header[:d]) != features.names:
        raise DataError(f'{path}: the first {d} columns must be {", ".join(features.names)}; '
                        f'got {", ".join(header[:d])}')
    task_names = tuple(header[d:])
    if not task_names:
        raise DataError(f'{path}: no task columns after the {d} feature columns')
    x = np.empty((len(rows) - 1, d))
    sets = np.zeros(len(rows) - 1, dtype=np.int64)
    for n, row in enumerate(rows[1:]):
        line = n + 2
        if len(row) != len(header):
            raise DataError(f'{path}:{line}: expected {len(header)} cells, got {len(row)}')
        try:
            x[n] = [float(c) for c in row[:d]]
        except ValueError as exc:
            raise DataError(f'{path}:{line}: {exc}') from None
        if not all(math.isfinite(v) for v in x[n]):
            raise DataError(f'{path}:{line}: non-finite feature value')
        for i, cell in enumerate(row[d:]):
            if cell.strip() not in ('0', '1'):
                raise DataError(f'{path}:{line}: task column {task_names[i]!r} must be 0 or 1, '
                                f'got {cell!r}')
            sets[n] |= int(cell.strip()) << i
        if sets[n] == 0:
            raise DataError(f'{path}:{line}: the demonstration satisfies no task')
    return Demonstrations(x, sets, task_names, features)
