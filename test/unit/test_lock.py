"""The version lock (requirements/lock.txt, made by scripts/lock.sh) against setup.py and the venv.

The README's two commands install exactly the lock (scripts/venv.sh), so a fresh clone gets the versions the
suite passed with on any day; setup.py keeps version ranges for people who install the package into an
environment of their own.
"""

from __future__ import annotations

import os
from importlib import metadata
from pathlib import Path

import pytest
from packaging.markers import default_environment
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

REPO = Path(__file__).resolve().parents[2]
LOCK = REPO / 'requirements' / 'lock.txt'


def locked(path: Path = LOCK) -> list[Requirement]:
    """The pins of a lock file (``name==version ; marker``, each followed by its hash lines)."""
    pins = []
    for line in path.read_text().splitlines():
        if line and not line[0].isspace() and not line.startswith('#'):
            pins.append(Requirement(line.rstrip(' \\')))
    return pins


def pins_here() -> dict[str, str]:
    """Locked version by canonical name, for the pins whose marker holds on this machine."""
    here = {}
    for pin in locked():
        if pin.marker is None or pin.marker.evaluate():
            (spec,) = pin.specifier
            assert spec.operator == '==', pin
            here[canonicalize_name(pin.name)] = spec.version
    return here


def test_the_lock_pins_every_package_once_with_hashes() -> None:
    text = LOCK.read_text()
    pins = locked()
    assert len(pins) > 100  # the ROS wheels alone are dozens
    assert text.count('--hash=sha256:') >= len(pins)
    names = [canonicalize_name(p.name) for p in pins if p.marker is None or p.marker.evaluate()]
    assert len(names) == len(set(names)), 'a package pinned twice for this machine'


def test_every_requirement_of_setup_py_and_its_extras_is_locked_within_its_range() -> None:
    """What setup.py asks for (as installed: the editable install's metadata), extras included."""
    requirements = [Requirement(r) for r in metadata.requires('grasp_intent_ros') or []]
    extras = metadata.metadata('grasp_intent_ros').get_all('Provides-Extra') or []
    assert {'ros', 'test'} <= set(extras)
    pins = pins_here()
    uncovered = []
    for requirement in requirements:
        environment = dict(default_environment())
        applies = requirement.marker is None or any(
            requirement.marker.evaluate({**environment, 'extra': extra}) for extra in ['', *extras])
        if not applies:
            continue
        version = pins.get(canonicalize_name(requirement.name))
        if version is None or not requirement.specifier.contains(version, prereleases=True):
            uncovered.append(f'{requirement} (locked: {version})')
    assert not uncovered, f'setup.py requirements the lock does not satisfy (run scripts/lock.sh): {uncovered}'


@pytest.mark.skipif(os.environ.get('GRASP_INTENT_ROS_UNLOCKED') == '1',
                    reason='the drift run (scripts/test.sh --latest) tests newer versions than the lock on purpose')
def test_the_venv_holds_exactly_the_locked_versions() -> None:
    installed = {canonicalize_name(d.metadata['Name']): d.version for d in metadata.distributions()}
    wrong = {name: (version, installed.get(name)) for name, version in pins_here().items()
             if installed.get(name) != version}
    assert not wrong, f'locked version, installed version (run scripts/venv.sh): {wrong}'
