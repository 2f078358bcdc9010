"""The trained models of one directory: listed, loaded on demand, the last few cached by modification time."""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

from ..errors import ModelError, ModelFormatError
from ..resources import config_dir
from .model import GraspModel, ModelRequirements

__all__ = ['ModelFiles', 'CACHED_MODELS']

CACHED_MODELS = 2
"""Models a :class:`ModelFiles` keeps loaded, the most recently used: the model server's active model and
the one a parameter change checks before it activates it. A bound, so that the memory held does not grow
with the models used (about 0.15 MB of arrays per 7-zone model); another model is read from its file
again (about 40 ms for a 7-zone model)."""


class ModelFiles:
    """The model YAML files (``<name>.yaml``) of one directory.

    Parameters
    ----------
    directory : Path
    """

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self._cache: OrderedDict[str, tuple[int, GraspModel]] = OrderedDict()  # least recently used first

    @classmethod
    def at(cls, models_dir: str) -> ModelFiles:
        """The models of ``models_dir`` ('' means the package's ``config/models``).

        Raises
        ------
        ModelError
            If the directory does not exist (or the package's config directory cannot be found).
        """
        try:
            directory = Path(models_dir).expanduser() if models_dir else config_dir() / 'models'
        except FileNotFoundError as exc:
            raise ModelError(str(exc)) from None
        if not directory.is_dir():
            raise ModelError(f'models_dir {str(directory)!r} is not a directory')
        return cls(directory)

    def names(self) -> tuple[str, ...]:
        """Stems of the ``*.yaml`` files, sorted."""
        return tuple(sorted(p.stem for p in self.directory.glob('*.yaml') if p.is_file()))

    def load(self, name: str, *, requires: ModelRequirements | None = None) -> GraspModel:
        """The model stored as ``<name>.yaml``: the cached one while its file is unchanged (:data:`CACHED_MODELS`).

        Raises
        ------
        ModelError
            If there is no such model (the reason lists the known names), or ``requires`` refuses it.
        ModelFormatError
            If the file is not a valid model document.
        """
        known = self.names()
        if name not in known:
            raise ModelError(f'unknown model {name!r} in {self.directory}; known: '
                             f'{", ".join(known) or "none"}')
        path = self.directory / f'{name}.yaml'
        mtime = path.stat().st_mtime_ns
        cached = self._cache.get(name)
        try:
            if cached is None or cached[0] != mtime:
                cached = (mtime, GraspModel.load(path, requires=requires))
            elif requires is not None:
                requires.check(cached[1].task_names, cached[1].feature_names)
        except ModelFormatError as exc:
            raise ModelFormatError(f'{path}: {exc}') from None
        except ModelError as exc:
            raise ModelError(f'model {name!r} refused: {exc}') from None
        if cached is not self._cache.get(name):
            self._cache[name] = cached
            while len(self._cache) > CACHED_MODELS:
                self._cache.popitem(last=False)
        self._cache.move_to_end(name)
        return cached[1]
