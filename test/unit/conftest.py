"""Fixtures for the ROS-free unit tests: small synthetic models with a known structure."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from grasp_intent_ros.method.data import Demonstrations
from grasp_intent_ros.method.features import MICO_3F
from grasp_intent_ros.method.intent import DEFAULT_TASKS, all_zones
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.kinematics import MicoKinematics
from grasp_intent_ros.sessions.pairing import Step, load_paired_session

from .fixed_reference import FixedReference
from .session_bags import session_messages, write_bag


def synthetic_demos(seed: int = 0, per_set: int = 40, spread: float = 0.12) -> Demonstrations:
    """Demonstrations for all 7 task sets of 3 tasks, each set around its own mean inside the bounds."""
    rng = np.random.default_rng(seed)
    centre = 0.5 * (MICO_3F.lower + MICO_3F.upper)
    half = 0.5 * (MICO_3F.upper - MICO_3F.lower)
    x, sets = [], []
    for zone in all_zones(3):
        mean = centre + rng.uniform(-0.3, 0.3, MICO_3F.dim) * half
        for _ in range(per_set):
            row = mean + rng.normal(0.0, spread, MICO_3F.dim) * half
            row[3:6] /= np.linalg.norm(row[3:6])
            x.append(np.clip(row, MICO_3F.lower, MICO_3F.upper))
            sets.append(zone)
    return Demonstrations(np.array(x), np.array(sets), DEFAULT_TASKS)


@pytest.fixture(scope='session')
def demos() -> Demonstrations:
    return synthetic_demos()


@pytest.fixture(scope='session')
def toy_model(demos: Demonstrations) -> GraspModel:
    return GraspModel.fit(demos, name='toy')


@pytest.fixture(scope='module')
def kin() -> MicoKinematics:
    """The MICO's model from the shipped URDF, one per test module."""
    return MicoKinematics()


@pytest.fixture
def session_bag(tmp_path: Path) -> Path:
    """A recorded session with an input of every kind (:func:`.sessions.session_messages`)."""
    return write_bag(tmp_path / 'session', session_messages())


@pytest.fixture(scope='module')
def plan_step(tmp_path_factory: pytest.TempPathFactory) -> Step:
    """The step of that session whose input was answered by a plan."""
    return load_paired_session(write_bag(tmp_path_factory.mktemp('s') / 'plan', session_messages())).steps[1]


@pytest.fixture(scope='session')
def fixed_reference() -> Iterator[FixedReference]:
    """The scipy searches on fixed OpenBLAS kernels, in a child process: the same references on every x86-64 CPU."""
    searches = FixedReference()
    yield searches
    searches.close()
