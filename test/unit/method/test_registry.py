"""grasp_intent_ros.method.registry: the model files of one directory."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from grasp_intent_ros.errors import ModelError, ModelFormatError
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.method.registry import CACHED_MODELS, ModelFiles


def test_models_are_listed_loaded_and_reloaded_when_changed(tmp_path: Path, toy_model: GraspModel) -> None:
    toy_model.save(tmp_path / 'toy.yaml')
    (tmp_path / 'notes.txt').write_text('not a model')
    files = ModelFiles.at(str(tmp_path))
    assert files.names() == ('toy',)
    first = files.load('toy')
    assert files.load('toy') is first, 'cached while the file is unchanged'
    (tmp_path / 'toy.yaml').write_text(toy_model.to_yaml())
    stat = (tmp_path / 'toy.yaml').stat()
    os.utime(tmp_path / 'toy.yaml', ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))
    assert files.load('toy') is not first, 'a changed file is read again'


def test_unknown_malformed_and_missing(tmp_path: Path, toy_model: GraspModel) -> None:
    toy_model.save(tmp_path / 'toy.yaml')
    (tmp_path / 'broken.yaml').write_text('format_version: 1\nname: broken\n')
    files = ModelFiles(tmp_path)
    with pytest.raises(ModelError, match="unknown model 'mug' in .*; known: broken, toy"):
        files.load('mug')
    with pytest.raises(ModelFormatError, match='broken.yaml: '):
        files.load('broken')
    with pytest.raises(ModelError, match='is not a directory'):
        ModelFiles.at(str(tmp_path / 'nowhere'))
    assert ModelFiles.at('').directory.name == 'models'  # the package's config/models


def test_only_the_most_recently_used_models_stay_loaded(tmp_path: Path, toy_model: GraspModel) -> None:
    names = [f'toy{i}' for i in range(CACHED_MODELS + 1)]
    for name in names:
        toy_model.save(tmp_path / f'{name}.yaml')
    files = ModelFiles(tmp_path)
    first = {name: files.load(name) for name in names}  # names[0] is dropped by the last load
    assert all(files.load(name) is first[name] for name in names[1:]), 'the recent ones are kept'
    assert files.load(names[0]) is not first[names[0]], 'the least recently used one is read again'
    assert files.load(names[-1]) is first[names[-1]]
    assert files.load(names[1]) is not first[names[1]], 'names[1] was the least recently used one'
