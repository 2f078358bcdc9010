"""grasp_intent_ros.resources: where config/ is found (the environment variable, the shipped directory)."""

from __future__ import annotations

from pathlib import Path

import pytest

from grasp_intent_ros import resources
from grasp_intent_ros.mico.kinematics import default_urdf_path


def test_config_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(resources.CONFIG_ENV_VAR, raising=False)
    assert (resources.config_dir() / 'mico_3f.urdf').is_file()
    assert default_urdf_path().name == 'mico_3f.urdf'
    monkeypatch.setenv(resources.CONFIG_ENV_VAR, str(tmp_path))
    assert resources.config_dir() == tmp_path
    with pytest.raises(FileNotFoundError, match='mico_3f.urdf'):
        default_urdf_path()
    monkeypatch.setenv(resources.CONFIG_ENV_VAR, str(tmp_path / 'missing'))
    with pytest.raises(FileNotFoundError, match=resources.CONFIG_ENV_VAR):
        resources.config_dir()
