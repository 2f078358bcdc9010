"""Every recorded session in bags/ replayed with ``--check`` against the current code.

And a perturbed model caught by the check (what CI runs: scripts/test.sh).

Each replay is the real command, ``python -m grasp_intent_ros replay BAG --check --fast --start-suite``: it
starts the three nodes as processes on this test's domain id (LOCALHOST discovery) and stops them by PID.
A replay takes about 10 s on 2 cores (about 7 s of it for the suite to start and its nodes to meet).
A closed-loop session (operator twists: bags/shared_control_cup) is replayed at its recorded pace into the
suite with the assistance and the mock arm (no ``--fast``), as recorded and with its operator twists and w
perturbed at the last bits (1e-12 relative), which shows its check does not depend on the machine. A
closed-loop session recorded with the intent estimator (bags/shared_control_cup_estimated) is replayed on its
recorded hand into the live estimator (its operator twists and joint states, perturbed the same way), whose
last w is compared.
"""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_copies import edited_copy
from processes import replay

from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.kinematics import MicoKinematics
from grasp_intent_ros.sessions.closed_loop import is_closed_loop, load_closed_loop, outcome
from grasp_intent_ros.sessions.pairing import load_paired_session

REPO = Path(__file__).resolve().parents[2]
BAGS = REPO / 'bags'
REQUIRED = ('bad_inputs', 'cup_paper_cases', 'flashlight', 'model_ambiguity', 'moving_object', 'shared_control_cup',
            'shared_control_cup_estimated')
"""The sessions bags/ must hold (scripts/record_sessions.py records them; the closed-loop shared_control_cup and
shared_control_cup_estimated are recorded by ``benchmarks/bench_shared_control.py --record``)."""


def bag_dirs(*, closed_loop: bool | None = None) -> list[Path]:
    """The session bags; only the closed-loop ones (True) or only the others (False)."""
    bags = sorted(p for p in BAGS.iterdir() if (p / 'metadata.yaml').is_file()) if BAGS.is_dir() else []
    return [p for p in bags if closed_loop is None or is_closed_loop(p) == closed_loop]


def test_bags_hold_the_required_sessions() -> None:
    names = [p.name for p in bag_dirs()]
    assert set(REQUIRED) <= set(names), f'bags/ lacks {sorted(set(REQUIRED) - set(names))}'
    for bag in bag_dirs():
        session = load_paired_session(bag)
        size = sum(f.stat().st_size for f in bag.iterdir())
        assert session.steps and session.initial_model is not None
        assert size < 512 * 1024, f'{bag.name} is {size / 1024:.0f} KiB'


@pytest.mark.parametrize('bag', bag_dirs(closed_loop=False), ids=lambda p: p.name)
def test_replay_of_each_bag_passes_the_check(bag: Path, domain_id: int) -> None:
    result = replay(bag, domain_id)
    assert result.returncode == 0, f'{result.stdout}\n{result.stderr}'
    summary = result.stdout.strip().splitlines()[-1]
    n_inputs = len(load_paired_session(bag).steps)
    assert summary.startswith(f'replay --check OK: {bag}: {n_inputs} inputs'), result.stdout
    assert 'Traceback' not in result.stderr, result.stderr


def perturbed_copy(bag: Path, out: Path, relative: float = 1e-12) -> Path:
    """``bag`` with every operator twist, w and joint position scaled by 1 + N(0, relative) (seeded); else unchanged."""
    rng = np.random.default_rng(0)

    def scaled(values: np.ndarray) -> np.ndarray:
        return values * (1.0 + relative * rng.standard_normal(values.size))

    def perturb(topic: str, msg: Any) -> bool:
        if topic.endswith('/operator/twist'):
            for part in (msg.twist.linear, msg.twist.angular):
                part.x, part.y, part.z = scaled(np.array([part.x, part.y, part.z]))
        elif topic.endswith('/intent/w'):
            msg.data = scaled(msg.data)
        elif topic.endswith('/joint_states'):
            msg.position = scaled(msg.position)
        else:
            return False
        return True
    return edited_copy(bag, out, perturb)


@pytest.mark.wall_clock
@pytest.mark.parametrize('perturbed', [False, True], ids=['as recorded', 'inputs perturbed by 1e-12'])
@pytest.mark.parametrize('bag', bag_dirs(closed_loop=True), ids=lambda p: p.name)
def test_a_closed_loop_session_replayed_plans_the_recorded_grasp_and_ends_there(
        bag: Path, perturbed: bool, domain_id: int, tmp_path: Path) -> None:
    session = load_closed_loop(bag)
    assert outcome(session.trace, MicoKinematics()).ends_at_grasp  # else the check would only compare the grasp
    played = perturbed_copy(bag, tmp_path / bag.name) if perturbed else bag
    result = replay(played, domain_id, fast=False)
    assert result.returncode == 0, f'{result.stdout}\n{result.stderr}'
    summary = result.stdout.strip().splitlines()[-1]
    assert summary.startswith(f'replay --check OK: {played}: closed loop, {len(session.sends)} inputs'), result.stdout
    assert ('the live intent estimator ended on the recorded w' in summary) == session.estimated, summary
    assert 'Traceback' not in result.stderr, result.stderr


def test_a_closed_loop_session_is_refused_at_another_pace(domain_id: int) -> None:
    bag = bag_dirs(closed_loop=True)[0]
    result = replay(bag, domain_id)  # --fast
    assert result.returncode == 2 and 'closed-loop session' in result.stderr, result.stderr


def test_a_perturbed_model_fails_the_check_and_names_the_first_differing_message(
        domain_id: int, tmp_path: Path) -> None:
    models_dir = tmp_path / 'models'
    shutil.copytree(REPO / 'config' / 'models', models_dir)
    model = GraspModel.load(models_dir / 'cup_7zone.yaml')
    means = model.means.copy()
    means[0, 0] += 0.02  # zone U: palm_x 2 cm further out (about two standard deviations)
    dataclasses.replace(model, means=means).save(models_dir / 'cup_7zone.yaml')

    bag = BAGS / 'cup_paper_cases'
    result = replay(bag, domain_id, '--models-dir', str(models_dir), '--max-failed-inputs', '1')

    assert result.returncode == 1, f'{result.stdout}\n{result.stderr}'
    lines = result.stdout.splitlines()
    # the model's content differs under the same name: a note, not the failure
    assert any(line.startswith('note: input #0 (initial model): model/active model content') for line in lines)
    # input #1 sets the joint state (no answer); from #2 on each w is planned on the moved zone: the first
    # grasp whose posterior (or choice) the move changes beyond the tolerances is named. (With the planner
    # node's default, planning for the execution noise, #2's usage-only grasp lies deep inside zone U, its
    # P(U | x) within 1e-4 of 1 with either model; #3, w = (0.9, 0.9, 0.1), is then the first.)
    header = next(line for line in lines if line.startswith('replay --check FAILED'))
    first_message = header.rpartition('first differing message: ')[2]
    index, _, topic = first_message.partition(', ')
    assert index in ('input #2', 'input #3') and topic in ('grasp/posterior', 'grasp/pose'), result.stdout
    first = next(line for line in lines if line.startswith('  input #'))
    assert first.startswith(f'  {index} (intent/w [') and f'): {topic} ' in first, result.stdout
    assert ': recorded ' in first and ', live ' in first
