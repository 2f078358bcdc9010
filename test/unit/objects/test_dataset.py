"""Rule-based demonstration generators (objects/demos.py) and the generate_data / train CLIs."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose, assert_array_equal

from grasp_intent_ros.errors import DataError, InvalidFeaturesError
from grasp_intent_ros.method.data import Demonstrations, load_csv, save_csv
from grasp_intent_ros.method.features import MICO_3F
from grasp_intent_ros.method.intent import all_zones, parse_zones
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.method.safe_yaml import MAX_DOCUMENT_CHARS
from grasp_intent_ros.mico.collision import HandCollision
from grasp_intent_ros.mico.frames import default_base_T_obj
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.mico.reach import ArmReach
from grasp_intent_ros.objects import demos, generate_data, train
from grasp_intent_ros.resources import config_dir

DEG = math.pi / 180.0
CUP, LIGHT = demos.CUP, demos.FLASHLIGHT
F_CLOSED = (1.2, 1.2, 1.2)


def grasp(aim: tuple[float, float, float], azimuth_deg: float, elevation_deg: float, standoff: float,
          roll: float, closures: tuple[float, float, float]) -> np.ndarray:
    return demos.grasp_features(aim, azimuth_deg * DEG, elevation_deg * DEG, standoff, roll, closures)


def with_approach(x: np.ndarray, azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """X with only the approach direction replaced."""
    y = x.copy()
    y[3:6] = demos.grasp_features((0, 0, 0), azimuth_deg * DEG, elevation_deg * DEG, 0.0, 0.0, (0, 0, 0))[3:6]
    return y


def with_values(x: np.ndarray, **changes: float | tuple[float, ...]) -> np.ndarray:
    """X with named features (or groups 'palm', 'fingers') replaced."""
    y = x.copy()
    for name, value in changes.items():
        if name == 'palm':
            y[0:3] = value
        elif name == 'fingers':
            y[7:10] = value
        else:
            y[MICO_3F.names.index(name)] = value
    return y


# ------------------------------------------------------------------------------------ helpers
def test_approach_elevation() -> None:
    assert_allclose(demos.approach_elevation(grasp((0, 0, 0), 30, 0, 0.05, 0, F_CLOSED)), 0.0, atol=1e-12)
    assert_allclose(demos.approach_elevation(grasp((0, 0, 0), 0, 90, 0.05, 0, F_CLOSED)), math.pi / 2)
    assert_allclose(demos.approach_elevation(grasp((0, 0, 0), 0, 40, 0.05, 0, F_CLOSED)), 40 * DEG)
    x = with_values(grasp((0, 0, 0), 0, 0, 0.05, 0, F_CLOSED), approach_x=0.0, approach_z=1.0)
    assert_allclose(demos.approach_elevation(x), -math.pi / 2)  # from below
    with pytest.raises(InvalidFeaturesError):
        demos.approach_elevation(with_values(x, approach_z=0.0))
    with pytest.raises(InvalidFeaturesError):
        demos.approach_elevation(np.zeros(9))


def test_grasp_features_points_at_aim() -> None:
    x = grasp((0.01, 0.02, 0.03), 60, 35, 0.04, 0.5, (0.1, 0.2, 0.3))
    assert_allclose(np.linalg.norm(x[3:6]), 1.0)
    assert_allclose(x[0:3] + 0.04 * x[3:6], (0.01, 0.02, 0.03), atol=1e-12)
    assert_allclose(demos.palm_azimuth(with_values(x, palm=tuple(x[0:3] - (0.01, 0.02, 0)))), 60 * DEG)
    assert_allclose(x[6:], (0.5, 0.1, 0.2, 0.3))


def test_finger_helpers() -> None:
    x = grasp((0, 0, 0), 0, 0, 0.05, 0, (1.2, demos.CLOSED, 0.79))
    assert demos.closed_fingers(x) == 2
    assert demos.closed_fingers(x, threshold=1.0) == 1
    assert_allclose(demos.mean_closure(x), (1.2 + 0.8 + 0.79) / 3)
    assert demos.firm_closure(with_values(x, fingers=(1.2, 1.2, 0.4)))        # 2 closed, mean 0.93
    assert not demos.firm_closure(with_values(x, fingers=(1.2, 0.5, 0.5)))    # 1 closed
    assert not demos.firm_closure(with_values(x, fingers=(0.85, 0.85, 0.85)))  # 3 closed, mean < 0.9


def test_roll_helpers() -> None:
    x = grasp((0, 0, 0), 0, 10, 0.05, 0.0, F_CLOSED)
    assert_allclose(demos.roll_offset(with_values(x, roll=3 * math.pi / 2), 0.0), -math.pi / 2)
    assert_allclose(demos.roll_offset(with_values(x, roll=-0.5), math.pi), math.pi - 0.5)
    assert demos.wrist_turned(with_values(x, roll=math.pi + 0.7))
    assert demos.wrist_turned(with_values(x, roll=math.pi - 0.7))
    assert not demos.wrist_turned(with_values(x, roll=math.pi - 0.9))
    assert not demos.wrist_turned(x)
    assert demos.wrist_turned(with_values(x, roll=math.pi - 0.9), tolerance=1.0)


def test_thumb_direction_is_the_end_effector_x_axis() -> None:
    from grasp_intent_ros.mico.frames import features_to_obj_T_ee
    side = grasp((0, 0, 0), 0, 0, 0.05, 0.0, F_CLOSED)  # horizontal approach along -x
    for roll in np.linspace(-math.pi / 2, 3 * math.pi / 2, 9):
        x = with_values(side, roll=roll)
        assert_allclose(demos.thumb_direction(x), features_to_obj_T_ee(x)[:3, 0], atol=1e-12)
        assert abs(demos.thumb_direction(x) @ x[3:6]) < 1e-12  # at right angles to the approach
    # kinematics: a horizontal approach (ax, ay, 0) at roll 0 has the thumb along (ay^2, -ax ay, ax)
    assert_allclose(demos.thumb_direction(side), (0, 0, -1), atol=1e-12)
    vertical = with_values(side, approach_x=0.0, approach_z=-1.0)  # from above: roll is the heading
    assert_allclose(demos.thumb_direction(vertical), (1, 0, 0), atol=1e-12)
    assert_allclose(demos.thumb_direction(with_values(vertical, roll=math.pi / 2)), (0, 1, 0), atol=1e-12)
    tilted = grasp((0, 0, 0), -90, 75, 0.05, math.pi / 2, F_CLOSED)  # from above, tilted from -y
    assert demos.thumb_direction(tilted)[1] > 0.9


def test_palm_to_body() -> None:
    assert_allclose(CUP.palm_to_body(with_values(np.zeros(10), palm=(0.07, 0, 0.05))), 0.03)
    assert_allclose(CUP.palm_to_body(with_values(np.zeros(10), palm=(0, 0, 0.12))), 0.02)
    assert_allclose(CUP.palm_to_body(with_values(np.zeros(10), palm=(0.07, 0, 0.14))), 0.05)
    assert CUP.palm_to_body(with_values(np.zeros(10), palm=(0.01, 0, 0.05))) == 0.0  # inside
    assert_allclose(LIGHT.palm_to_body(with_values(np.zeros(10), palm=(0.0, 0, 0.07))), 0.03)
    assert_allclose(LIGHT.palm_to_body(with_values(np.zeros(10), palm=(0.0, -0.05, 0.02))), 0.03)
    assert_allclose(LIGHT.palm_to_body(with_values(np.zeros(10), palm=(0.13, 0, 0.02))), 0.03)


# ------------------------------------------------------------------------------------ rules
Change = Callable[[np.ndarray], np.ndarray]

CUP_USAGE = grasp((0.055, 0, 0.04), 0, 20, 0.03, 0.0, F_CLOSED)
CUP_TRANSFER = grasp((0, 0, 0.10), 0, 80, 0.015, 0.0, F_CLOSED)
CUP_HANDOVER = grasp((0.055, 0, 0.04), 0, 25, 0.03, math.pi, (1.2, 1.2, 0.6))
LIGHT_USAGE = grasp((0.05, 0, 0.04), -90, 75, 0.03, math.pi / 2, F_CLOSED)  # thumb heading +y
LIGHT_TRANSFER = grasp((-0.01, -0.02, 0.02), -90, 20, 0.02, 0.0, F_CLOSED)
LIGHT_HANDOVER = grasp((0.085, -0.02, 0.02), -90, 20, 0.035, math.pi, F_CLOSED)

# (object rules, task index, a vector satisfying the rule, {condition: change violating only it})
RULE_CASES: list[tuple[demos.ObjectRules, int, np.ndarray, dict[str, Change]]] = [
    (demos.CUP_RULES, 0, CUP_USAGE, {
        'rim clear': lambda x: with_values(x, palm_z=0.09),
        'palm parallel to the table': lambda x: with_approach(x, 0, 60),
        'hand on the handle side': lambda x: with_values(x, palm=(0.0, 0.09, 0.05)),
        '>= 2 fingers on the handle': lambda x: with_values(x, fingers=(1.2, 0.3, 0.3)),
    }),
    (demos.CUP_RULES, 1, CUP_TRANSFER, {
        'bottom clear': lambda x: with_values(x, palm=(0.06, 0, 0.04)),
        'palm perpendicular to the table': lambda x: with_approach(x, 0, 10),
        'palm contact': lambda x: with_values(x, palm_z=0.16),
        'firm closure': lambda x: with_values(x, fingers=(1.2, 0.5, 0.5)),
    }),
    (demos.CUP_RULES, 2, CUP_HANDOVER, {
        'handle left free': lambda x: with_values(x, fingers=F_CLOSED),
        'wrist turned': lambda x: with_values(x, roll=0.0),
        'finger-dominant': lambda x: with_values(x, palm=(0.045, 0, 0.05)),
    }),
    (demos.FLASHLIGHT_RULES, 0, LIGHT_USAGE, {
        'from above': lambda x: with_approach(x, -90, 40),
        'over the switch': lambda x: with_values(x, palm_x=0.09),
        'thumb at the switch': lambda x: with_values(x, roll=-math.pi / 2),  # thumb heading -y
    }),
    (demos.FLASHLIGHT_RULES, 1, LIGHT_TRANSFER, {
        'balanced': lambda x: with_values(x, palm_x=0.06),
        'palm contact': lambda x: with_values(x, palm_y=-0.08),
        'firm closure': lambda x: with_values(x, fingers=(0.5, 0.5, 1.2)),
    }),
    (demos.FLASHLIGHT_RULES, 2, LIGHT_HANDOVER, {
        'tail end left free': lambda x: with_values(x, palm_x=-0.05),
        'wrist turned': lambda x: with_values(x, roll=0.0),
        'finger-dominant': lambda x: with_values(x, palm=(0.085, -0.025, 0.02)),
    }),
]


@pytest.mark.parametrize('rules, task, x, changes', RULE_CASES,
                         ids=[f'{r.name}-{r.task_names[t]}' for r, t, _, _ in RULE_CASES])
def test_rule_satisfied_and_each_condition_violated(rules: demos.ObjectRules, task: int, x: np.ndarray,
                                                    changes: dict[str, Change]) -> None:
    rule = rules.rules[task]
    assert set(changes) == {name for name, _ in rule.conditions}, 'every condition is exercised'
    assert all(rule.check(x).values()), rule.check(x)
    assert rule(x)
    for name, change in changes.items():
        verdicts = rule.check(change(x))
        assert not verdicts[name], f'{name} should fail'
        assert all(v for n, v in verdicts.items() if n != name), f'only {name} should fail: {verdicts}'
        assert not rule(change(x))
        assert not rules.label(change(x)) >> task & 1


def test_thumb_open_is_not_at_the_switch() -> None:
    assert LIGHT.thumb_at_switch(LIGHT_USAGE)
    assert not LIGHT.thumb_at_switch(with_values(LIGHT_USAGE, finger_1=0.3))


def test_label_is_the_set_of_satisfied_rules() -> None:
    x = CUP_HANDOVER
    assert demos.CUP_RULES.label(x) == sum(1 << i for i, r in enumerate(demos.CUP_RULES.rules) if r(x))
    explained = demos.CUP_RULES.explain(x)
    assert list(explained) == list(demos.CUP_RULES.task_names)
    assert all(explained['handover'].values())


@pytest.mark.parametrize('rules', demos.OBJECTS.values(), ids=list(demos.OBJECTS))
def test_every_task_set_is_reachable_by_its_prototypes(rules: demos.ObjectRules) -> None:
    """The threshold bands leave room for all 7 task sets: each noise-free prototype gets its set."""
    assert set(rules.prototypes) == set(all_zones(3))
    for zone, styles in rules.prototypes.items():
        for p in styles:
            x = demos.grasp_features(p.aim, p.azimuth, p.elevation, p.standoff, p.roll, p.closures)
            assert rules.label(x) == zone, (zone, p, rules.explain(x))


# ------------------------------------------------------------------------------------ generation
GENERATION_TIMEOUT = pytest.mark.timeout(900)
"""For a test that may be the first to ask for an object's generated set: one object's generation runs ArmReach's
servos for some thousand draws (about 1.5 min on an idle 2-core machine, several under load)."""


@pytest.fixture(scope='module')
def generated_dir(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Path]:
    """The directory of ``generate_data --object NAME --train`` with its defaults, run at NAME's first request.

    It holds NAME.csv, models/NAME_*.yaml and NAME.out (what the command printed); one run per NAME and module.
    """
    out = tmp_path_factory.mktemp('generated')

    def written(name: str) -> Path:
        if not (out / f'{name}.out').exists():
            printed = io.StringIO()
            with contextlib.redirect_stdout(printed):
                assert generate_data.main(['--object', name, '--out', str(out), '--train',
                                           '--models-out', str(out / 'models')]) == 0
            (out / f'{name}.out').write_text(printed.getvalue())
        return out
    return written


@pytest.fixture(scope='module')
def generated(generated_dir: Callable[[str], Path]) -> Callable[[str], Demonstrations]:
    return lambda name: load_csv(generated_dir(name) / f'{name}.csv')


@GENERATION_TIMEOUT
@pytest.mark.parametrize('name', list(demos.OBJECTS))
def test_generated_counts_bounds_and_unit_approach(generated: Callable[[str], Demonstrations], name: str) -> None:
    d = generated(name)
    assert d.counts() == {z: demos.DEFAULT_COUNT for z in all_zones(3)}
    assert d.task_names == ('usage', 'transfer', 'handover')
    assert np.all(d.x >= MICO_3F.lower) and np.all(d.x <= MICO_3F.upper)
    assert_allclose(np.linalg.norm(d.x[:, 3:6], axis=1), 1.0, atol=1e-5)
    assert list(d.task_sets) == sorted(d.task_sets, key=all_zones(3).index), 'rows grouped by task set'


@pytest.mark.parametrize('name', list(demos.OBJECTS))
def test_every_label_equals_the_rules(generated: Callable[[str], Demonstrations], name: str) -> None:
    d, rules = generated(name), demos.OBJECTS[name]
    assert [rules.label(x) for x in d.x] == d.task_sets.tolist()


@pytest.mark.parametrize('name', list(demos.OBJECTS))
def test_csv_round_trip_keeps_features_and_labels(name: str, tmp_path: Path) -> None:
    d = demos.generate(demos.OBJECTS[name], 3, seed=1)
    save_csv(d, tmp_path / 'd.csv')
    back = load_csv(tmp_path / 'd.csv')
    assert_array_equal(back.x, d.x)  # generation already rounds to the CSV's 6 decimals
    assert_array_equal(back.task_sets, d.task_sets)
    assert back.sha256() == d.sha256()
    assert [demos.OBJECTS[name].label(x) for x in back.x] == back.task_sets.tolist()
    save_csv(back, tmp_path / 'again.csv')
    assert (tmp_path / 'again.csv').read_bytes() == (tmp_path / 'd.csv').read_bytes()


@pytest.mark.parametrize('name', list(demos.OBJECTS))
def test_every_demonstration_is_one_the_hand_takes(generated: Callable[[str], Demonstrations], name: str) -> None:
    """Open along its approach, the hand stays clear of the table (z = 0) and the object's body (handle included)."""
    hand, body = HandCollision(), demos.OBJECTS[name].body
    faults = [(x.tolist(), hand.clearance(x, body).fault()) for x in generated(name).x]
    assert [f for f in faults if f[1] is not None] == []


def test_samples_in_collision_are_dropped() -> None:
    """A style whose every draw collides gives no demonstration.

    The cup's usage demonstrated low at the handle thumb up (its former prototype): the rules hold, but two open
    fingers go under the table on every draw, so a generator with only that style keeps none.
    """
    thumb_up = demos.Prototype((0.055, 0.0, 0.040), 0.0, math.radians(22.0), 0.030, 0.0, (1.2, 1.2, 1.05))
    x = demos.grasp_features(thumb_up.aim, thumb_up.azimuth, thumb_up.elevation, thumb_up.standoff, thumb_up.roll,
                             thumb_up.closures)
    assert demos.CUP_RULES.label(x) == 0b001
    assert HandCollision().clearance(x, demos.CUP_RULES.body).table_depth > 0.02
    rules = dataclasses.replace(demos.CUP_RULES, prototypes={z: (thumb_up,) for z in all_zones(3)})
    with pytest.raises(DataError, match="gave up.*'U': 0"):
        demos.generate(rules, 2, max_draws_per_demo=10)


def test_samples_the_arm_does_not_reach_from_home_are_dropped() -> None:
    """A clear style whose grasp the arm reaches only past its wrist singularity gives no demonstration.

    The cup's usage with handover low beside the handle, from the arm's side (the former prototype's mirror image),
    drawn without noise: the rules hold and the open hand is clear; IK converges, on the wrist's other branch
    (q5 < 0, home has q5 > 0), and the approach is followed; a servo from home does not get there.
    """
    beside = demos.Prototype((0.067, -0.042, 0.066), -68 * DEG, 30 * DEG, 0.020, 2.0 * math.pi - 2.56,
                             (1.20, 1.20, 0.60))
    x = demos.grasp_features(beside.aim, beside.azimuth, beside.elevation, beside.standoff, beside.roll,
                             beside.closures)
    assert demos.CUP_RULES.label(x) == 0b101
    assert HandCollision().clearance(x, demos.CUP_RULES.body).fault() is None
    arm = ArmReach(MicoKinematics(), default_base_T_obj())
    assert arm.reach(x) and arm.reach.answer(x).q[4] < 0.0 < HOME_Q[4]
    assert arm.approach(x)
    assert 'servo' in (arm.fault(x) or '')
    still = demos.Noise(aim=0.0, azimuth=0.0, elevation=0.0, standoff=0.0, roll=0.0, closure=0.0)
    rules = dataclasses.replace(demos.CUP_RULES, prototypes={z: (beside,) for z in all_zones(3)}, noise=still)
    with pytest.raises(DataError, match="gave up.*'UH': 0"):
        demos.generate(rules, 1, arm=arm, max_draws_per_demo=2)


def test_generation_is_reproducible(tmp_path: Path) -> None:
    for i, seed in enumerate((7, 7, 4)):
        save_csv(demos.generate(demos.FLASHLIGHT_RULES, 2, seed=seed), tmp_path / f'{i}.csv')
    assert (tmp_path / '0.csv').read_bytes() == (tmp_path / '1.csv').read_bytes()
    assert (tmp_path / '0.csv').read_bytes() != (tmp_path / '2.csv').read_bytes()


def test_generate_rejects_bad_requests() -> None:
    with pytest.raises(DataError, match='count'):
        demos.generate(demos.CUP_RULES, 0)
    partial = dict(demos.CUP_RULES.prototypes)
    del partial[7]
    with pytest.raises(DataError, match='no prototype'):
        demos.generate(dataclasses.replace(demos.CUP_RULES, prototypes=partial), 5)
    far = demos.Prototype((0.0, 0.15, 0.0), math.pi / 2, 0.0, 0.02, 0.0, (0.1, 0.1, 0.1))  # satisfies no rule
    hopeless = dataclasses.replace(demos.CUP_RULES, prototypes={**demos.CUP_RULES.prototypes, 4: (far,)})
    hopeless = dataclasses.replace(hopeless, prototypes={**hopeless.prototypes, 7: (far,)})
    with pytest.raises(DataError, match='gave up'):
        demos.generate(hopeless, 2, max_draws_per_demo=5)


@GENERATION_TIMEOUT
@pytest.mark.parametrize('name', list(demos.OBJECTS))
def test_shipped_data_is_what_generate_data_writes_and_the_models_fit_it(
        generated_dir: Callable[[str], Path], name: str) -> None:
    out = generated_dir(name)
    shipped = config_dir() / 'data' / f'{name}.csv'
    same = shipped.read_bytes() == (out / f'{name}.csv').read_bytes()  # a bool: no diff of 100 kB of text
    assert same, f'regenerate {shipped}'
    models = sorted(p.name for p in (out / 'models').glob(f'{name}_*.yaml'))
    assert models == sorted(f'{name}_{s}.yaml' for s in generate_data.SHIPPED_MODELS[name])
    data = load_csv(shipped)
    for model in models:
        # trained on the data: the same demonstrations (a fit's covariances differ at the last bits between CPUs'
        # BLAS kernels, so the documents are not compared byte for byte)
        written, ours = GraspModel.load(out / 'models' / model), GraspModel.load(config_dir() / 'models' / model)
        kept = data.select(np.isin(data.task_sets, ours.zones))
        assert written.data_hash == ours.data_hash == kept.sha256(), f'retrain {model}'
        assert written.name == ours.name == model.removesuffix('.yaml')
        assert written.zones == ours.zones


# ------------------------------------------------------------------------------------ CLIs
@GENERATION_TIMEOUT
def test_generate_data_prints_the_counts_and_the_models(generated_dir: Callable[[str], Path]) -> None:
    printed = (generated_dir('cup') / 'cup.out').read_text()
    assert 'cup.csv: 560 demonstrations (seed 0; U 80, T 80, H 80, UT 80, UH 80, TH 80, UTH 80)' in printed
    assert all(f'wrote {generated_dir("cup") / "models" / f"cup_{s}.yaml"}' in printed
               for s in generate_data.SHIPPED_MODELS['cup'])


def test_generate_data_rejects_a_count_out_of_range(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exc:
        generate_data.main(['--count', '10', '--out', str(tmp_path)])
    assert exc.value.code == 2
    assert not list(tmp_path.iterdir())


def test_generate_data_passes_count_and_seed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[str, int, int]] = []
    tiny = demos.generate(demos.FLASHLIGHT_RULES, 1, seed=3)

    def spy(rules: demos.ObjectRules, count: int, *, seed: int) -> Demonstrations:
        calls.append((rules.name, count, seed))
        return tiny

    monkeypatch.setattr(demos, 'generate', spy)
    assert generate_data.main(['--object', 'flashlight', '--count', '40', '--seed', '7', '--out', str(tmp_path)]) == 0
    assert calls == [('flashlight', 40, 7)]
    assert load_csv(tmp_path / 'flashlight.csv').sha256() == tiny.sha256()


@pytest.fixture()
def tiny_csv(tmp_path: Path) -> Path:
    path = tmp_path / 'mine.csv'
    save_csv(demos.generate(demos.CUP_RULES, 3, seed=1), path)
    return path


def test_train_cli_on_a_tiny_csv(tiny_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'm.yaml'
    assert train.main([str(tiny_csv), '--zones', '7zone', '--out', str(out), '--ridge', '0.01']) == 0
    text = capsys.readouterr().out
    model = GraspModel.load(out)
    assert model.name == 'mine_7zone'
    assert model.zone_labels == ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH')
    assert model.counts.tolist() == [12, 12, 12, 6, 6, 6, 3]
    assert model.ridge == 0.01
    assert model.data_hash in text and 'UTH' in text
    assert train.main([str(tiny_csv), '--zones', 'U, H,UT,TH', '--name', 'custom', '--out', str(out)]) == 0
    model = GraspModel.load(out)
    assert (model.name, model.zones) == ('custom', parse_zones(['U', 'H', 'UT', 'TH'], model.task_names))
    assert 'left out' in capsys.readouterr().out


def test_train_cli_default_output_is_the_config_models_dir(tiny_csv: Path, tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / 'config').mkdir()
    monkeypatch.setenv('GRASP_INTENT_ROS_CONFIG', str(tmp_path / 'config'))
    assert train.main([str(tiny_csv), '--zones', '5zone']) == 0
    assert GraspModel.load(tmp_path / 'config' / 'models' / 'mine_5zone.yaml').zone_labels == (
        'U', 'T', 'UT', 'TH', 'UTH')


@pytest.mark.parametrize('content, zones, message', [
    ('palm_x,palm_y\n0.1,0.2\n', '7zone', 'first 10 columns'),
    (None, 'U,X', "unknown zone 'X'"),
    (None, '', 'zones must be'),
    ('ONLY_U', '7zone', 'has no demonstration'),
], ids=['bad-header', 'unknown-zone', 'empty-zones', 'zone-without-data'])
def test_train_cli_errors(tiny_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                          content: str | None, zones: str, message: str) -> None:
    path = tiny_csv
    if content == 'ONLY_U':
        d = load_csv(tiny_csv)
        save_csv(d.select(d.task_sets == 1), path)
    elif content is not None:
        path.write_text(content)
    assert train.main([str(path), '--zones', zones, '--out', str(tmp_path / 'm.yaml')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('error: ') and message in err
    assert not (tmp_path / 'm.yaml').exists()


def test_train_cli_missing_or_binary_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert train.main([str(tmp_path / 'nope.csv'), '--zones', '7zone']) == 2
    assert 'nope.csv' in capsys.readouterr().err
    (tmp_path / 'bin.csv').write_bytes(b'\xff\xfe\x00\x81')
    assert train.main([str(tmp_path / 'bin.csv'), '--zones', '7zone']) == 2
    assert capsys.readouterr().err.startswith('error: ')


def test_train_cli_body_is_read_like_a_model_document(tiny_csv: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    body = CUP.body()
    good = tmp_path / 'body.yaml'
    good.write_text(yaml.safe_dump({'body': body.to_document()}))
    out = tmp_path / 'm.yaml'
    assert train.main([str(tiny_csv), '--zones', '7zone', '--out', str(out), '--body', str(good)]) == 0
    loaded = GraspModel.load(out).body
    assert loaded is not None and loaded.to_document() == body.to_document()
    bomb = tmp_path / 'bomb.yaml'
    bomb.write_text('a: &a [x, x]\nb: &b [*a, *a]\nbody: [*b, *b]\n')
    huge = tmp_path / 'huge.yaml'
    huge.write_text('#' * (MAX_DOCUMENT_CHARS + 10))
    for path, message in ((bomb, 'aliases'), (huge, 'oversized')):
        capsys.readouterr()
        assert train.main([str(tiny_csv), '--zones', '7zone', '--out', str(tmp_path / 'x.yaml'),
                           '--body', str(path)]) == 2
        err = capsys.readouterr().err
        assert err.startswith('error: ') and str(path) in err and message in err
        assert not (tmp_path / 'x.yaml').exists()
