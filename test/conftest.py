"""Shared test fixtures.

Network safety: DDS discovery is restricted to the loopback interface before anything can import
rclpy, and every test that talks ROS gets its own ROS domain id (claimed with a lock file, so parallel
pytest runs on one machine never share a domain).

rclpy is imported lazily inside the fixtures: test/unit never imports it.
"""

from __future__ import annotations

import fcntl
import hashlib
import itertools
import os
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from grasp_intent_ros.launch.suite import TEST_DOMAIN_IDS, use_loopback_discovery

use_loopback_discovery()  # before rclpy is imported anywhere

DOMAIN_IDS = TEST_DOMAIN_IDS
"""Domain ids tests may use (1..90 of the safe range 0..101; 91..101 stay free for other runs)."""

_DOMAIN_LOCK_DIR = Path(tempfile.gettempdir()) / 'grasp_intent_ros_test_domains'
_domain_counter = itertools.count()


@contextmanager
def claim_domain_id() -> Iterator[int]:
    """Hold a ROS domain id no other test on this machine holds (derived from pid + a counter).

    The claim is an exclusive ``flock`` on ``<tmp>/grasp_intent_ros_test_domains/<id>.lock``, released
    when the context exits (or the process dies).
    """
    _DOMAIN_LOCK_DIR.mkdir(exist_ok=True)
    start = os.getpid() * 31 + next(_domain_counter)
    for k in range(len(DOMAIN_IDS)):
        domain_id = DOMAIN_IDS[(start + k) % len(DOMAIN_IDS)]
        lock = open(_DOMAIN_LOCK_DIR / f'{domain_id}.lock', 'w')
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            continue
        try:
            yield domain_id
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
            lock.close()
        return
    raise RuntimeError(f'no free ROS domain id in {DOMAIN_IDS}')


@pytest.fixture
def domain_id() -> Iterator[int]:
    """A ROS domain id for this test alone."""
    with claim_domain_id() as claimed:
        yield claimed


class RosHarness:
    """A private rclpy Context on the test's domain, one executor, and a probe node for the test side.

    Nodes under test are built with ``context=ros.context`` and added with :meth:`add`; everything
    runs in the test's thread when :meth:`wait_for` spins.
    """

    def __init__(self, domain_id: int) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.domain_id = domain_id
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.executor = SingleThreadedExecutor(context=self.context)
        self._nodes: list[Any] = []
        self.node = self.add(rclpy.create_node('test_probe', context=self.context))

    def add(self, node: Any) -> Any:
        """Spin ``node`` in this harness's executor; destroyed at teardown. Returns it."""
        self.executor.add_node(node)
        self._nodes.append(node)
        return node

    def remove(self, node: Any) -> None:
        """Stop spinning ``node`` and destroy it now."""
        self.executor.remove_node(node)
        self._nodes.remove(node)
        node.destroy_node()

    def wait_for(self, predicate: Callable[[], object], timeout: float = 5.0) -> bool:
        """Spin until ``predicate()`` is true or ``timeout`` seconds pass; returns the last verdict."""
        deadline = time.monotonic() + timeout
        while not predicate():
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                return bool(predicate())
            self.executor.spin_once(timeout_sec=min(remaining, 0.05))
        return True

    def subscribe(self, msg_type: Any, topic: str, qos: Any = None) -> list[Any]:
        """A list that receives every message on ``topic`` (probe node; default: input QoS)."""
        from grasp_intent_ros.ros.qos import input_qos

        received: list[Any] = []
        self.node.create_subscription(msg_type, topic, received.append, qos or input_qos())
        return received

    def publisher(self, msg_type: Any, topic: str, qos: Any = None) -> Any:
        """A publisher on the probe node (default: output QoS)."""
        from grasp_intent_ros.ros.qos import output_qos

        return self.node.create_publisher(msg_type, topic, qos or output_qos())

    def publish_until(self, publisher: Any, msg: Any, predicate: Callable[[], object],
                      timeout: float = 5.0, period: float = 0.2) -> bool:
        """Publish ``msg`` every ``period`` s until ``predicate()`` holds or ``timeout`` passes.

        Republishing covers the first message after discovery, which DDS may drop.
        """
        deadline = time.monotonic() + timeout
        while True:
            publisher.publish(msg)
            if self.wait_for(predicate, min(period, max(0.0, deadline - time.monotonic()))):
                return True
            if time.monotonic() >= deadline:
                return False

    def diagnostics(self) -> list[Any]:
        """All DiagnosticStatus entries received on /diagnostics from now on (a live list)."""
        from diagnostic_msgs.msg import DiagnosticArray

        statuses: list[Any] = []
        self.node.create_subscription(DiagnosticArray, '/diagnostics',
                                      lambda msg: statuses.extend(msg.status), 50)
        return statuses

    def close(self) -> None:
        import rclpy

        for node in reversed(self._nodes):
            self.executor.remove_node(node)
            node.destroy_node()
        self._nodes.clear()
        self.executor.shutdown()
        rclpy.try_shutdown(context=self.context)


@pytest.fixture
def ros(domain_id: int) -> Iterator[RosHarness]:
    """An in-process ROS harness: private Context (LOCALHOST, own domain id), executor, probe node."""
    harness = RosHarness(domain_id)
    try:
        yield harness
    finally:
        harness.close()


def find_status(statuses: list[Any], name_suffix: str, *, level: bytes | None = None,
                text: str = '') -> Any:
    """The last status named ``*name_suffix``, at ``level`` if given, with ``text`` in its message; or None."""
    for status in reversed(statuses):
        if (status.name.endswith(name_suffix) and (level is None or status.level == level)
                and text in status.message):
            return status
    return None


@pytest.fixture
def status_finder() -> Callable[..., Any]:
    """:func:`find_status` as a fixture (conftest helpers are not importable)."""
    return find_status


# ---------------------------------------------------------------- tiny trained models
TASKS = ('usage', 'transfer', 'handover')


def train_tiny_models(directory: Path, *, seed: int = 7, per_set: int = 12) -> dict[str, Any]:
    """Tiny trained models in ``directory``, returned by name.

    Seeded Gaussian demonstrations around a different mean per task set; fits a 7-zone and a 5-zone
    model saved as ``cup_7zone.yaml`` and ``cup_5zone.yaml`` in ``directory`` (tiny stand-ins for the
    real models), plus ``broken.yaml`` (not a model). Returns the models by name.
    """
    from grasp_intent_ros.method.data import Demonstrations
    from grasp_intent_ros.method.features import APPROACH, MICO_3F
    from grasp_intent_ros.method.model import GraspModel, structure_zones

    rng = np.random.default_rng(seed)
    span = MICO_3F.upper - MICO_3F.lower
    centre = 0.5 * (MICO_3F.upper + MICO_3F.lower)
    rows, sets = [], []
    for task_set in range(1, 1 << len(TASKS)):
        mean = centre + rng.uniform(-0.3, 0.3, size=span.shape) * span
        x = mean + 0.03 * span * rng.standard_normal((per_set, span.size))
        x[:, APPROACH] /= np.linalg.norm(x[:, APPROACH], axis=1, keepdims=True)
        rows.append(np.clip(x, MICO_3F.lower, MICO_3F.upper))
        sets.append(np.full(per_set, task_set))
    demos = Demonstrations(np.vstack(rows), np.concatenate(sets), TASKS)
    models = {f'cup_{s}': GraspModel.fit(demos, structure_zones(s, TASKS), name=f'cup_{s}')
              for s in ('7zone', '5zone')}
    directory.mkdir(parents=True, exist_ok=True)
    for name, model in models.items():
        model.save(directory / f'{name}.yaml')
    (directory / 'broken.yaml').write_text('format_version: 1\nname: broken\n')
    return models


@pytest.fixture(scope='session')
def tiny_models(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    """(models_dir, {name: GraspModel}) with cup_7zone, cup_5zone and a malformed broken.yaml."""
    directory = tmp_path_factory.mktemp('models')
    return directory, train_tiny_models(directory)


@pytest.fixture(scope='session')
def weaponised_model_documents() -> Callable[..., dict[str, tuple[str, str]]]:
    """``make(model, name='cup_7zone', version=2)``: documents built to stall or crash a reader, by kind.

    Each is (document text with a valid header and hash, the reason a reader rejects it with:
    ``ModelFormatError.reason``, which the diagnostic's message contains); ``model``
    (a GraspModel) makes the rest of the document valid.
    """
    return _weaponised_model_documents


def _weaponised_model_documents(model: Any, *, name: str = 'cup_7zone', version: int = 2
                                ) -> dict[str, tuple[str, str]]:
    from grasp_intent_ros.method.safe_yaml import ALIAS, MAX_DOCUMENT_CHARS, OVERSIZED, TOO_DEEP

    def document(body: str) -> str:
        sha = hashlib.sha256(body.encode()).hexdigest()
        return f'# model_name: {name}\n# model_version: {version}\n# model_sha256: {sha}\n{body}'

    # "billion laughs": 10^9 strings once expanded, as the data_hash of an otherwise valid model
    laughs = ''.join(f'\nl{i}: &l{i} [{", ".join([f"*l{i - 1}"] * 10)}]' for i in range(1, 10))
    bomb = model.to_yaml().replace('\nzones:', f'\nl0: &l0 [{", ".join(["lol"] * 10)}]{laughs}\nzones:', 1)
    return {
        'alias bomb': (document(bomb.replace('data_hash:', 'data_hash: *l9\nx:', 1)), ALIAS),
        'nested too deeply': (document('[' * 100_000), TOO_DEEP),
        'oversized': (document(model.to_yaml() + '#' * MAX_DOCUMENT_CHARS), OVERSIZED),
    }
