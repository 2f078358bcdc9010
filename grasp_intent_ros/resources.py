"""Where the package's installed resources live: the ``config`` directory (URDF, models, data).

Lookup order of :func:`config_dir`:

1. the environment variable ``GRASP_INTENT_ROS_CONFIG`` (a directory), when set;
2. the source checkout: ``<repo>/config`` next to ``<repo>/package.xml`` (editable installs, tests);
3. the ament share directory ``<share>/grasp_intent_ros/config`` found through ``ament_index_python``
   (a colcon or ROS install with ``AMENT_PREFIX_PATH`` set);
4. ``<sys.prefix>/share/grasp_intent_ros/config`` (``pip install`` into a venv without a ROS environment).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = ['CONFIG_ENV_VAR', 'PACKAGE_NAME', 'config_dir']

CONFIG_ENV_VAR = 'GRASP_INTENT_ROS_CONFIG'
"""Environment variable that overrides the config directory."""

PACKAGE_NAME = 'grasp_intent_ros'


def _ament_config_dir() -> Path | None:
    try:
        from ament_index_python.packages import (  # type: ignore[import-untyped, unused-ignore]
            get_package_share_directory,
        )
    except ImportError:
        return None
    try:
        share = get_package_share_directory(PACKAGE_NAME, print_warning=False)
    except (LookupError, OSError, ValueError):  # PackageNotFoundError is a KeyError; no AMENT_PREFIX_PATH
        return None
    return Path(share) / 'config'


def config_dir() -> Path:
    """The directory holding ``mico_3f.urdf``, ``models/`` and ``data/``.

    Returns
    -------
    Path
        An existing directory (see the module docstring for the lookup order).

    Raises
    ------
    FileNotFoundError
        If ``GRASP_INTENT_ROS_CONFIG`` names something that is not a directory, or no candidate exists.
    """
    override = os.environ.get(CONFIG_ENV_VAR)
    if override:
        path = Path(override).expanduser()
        if not path.is_dir():
            raise FileNotFoundError(f'{CONFIG_ENV_VAR}={override!r} is not a directory')
        return path

    tried: list[Path] = []
    repo = Path(__file__).resolve().parents[1]
    if (repo / 'package.xml').is_file():
        tried.append(repo / 'config')
    ament = _ament_config_dir()
    if ament is not None:
        tried.append(ament)
    tried.append(Path(sys.prefix) / 'share' / PACKAGE_NAME / 'config')
    for candidate in tried:
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        f'cannot find the {PACKAGE_NAME} config directory; tried {", ".join(map(str, tried))}. '
        f'Set {CONFIG_ENV_VAR}, source the ROS install, or run from the source checkout.')
