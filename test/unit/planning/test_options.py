"""The planner's typed options: one class per method, and an option a method does not use is an error."""

from __future__ import annotations

import numpy as np
import pytest

from grasp_intent_ros.errors import PlanningError
from grasp_intent_ros.method import intent
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.planning import planner
from grasp_intent_ros.planning.options import (
    METHODS,
    OPTIONS,
    LmOptions,
    ScipyOptions,
    TaskOptions,
    check_options,
    node_options,
    options_for,
)
from grasp_intent_ros.resources import config_dir


@pytest.fixture(scope='module')
def cup() -> GraspModel:
    return GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')


def test_every_method_has_one_options_class_and_none_means_its_defaults() -> None:
    assert set(OPTIONS) == set(METHODS)
    for method in METHODS:
        assert check_options(method, None) == OPTIONS[method]()


@pytest.mark.parametrize(('method', 'options'), [('task', LmOptions()), ('task', ScipyOptions()),
                                                 ('lm', TaskOptions()), ('lm', ScipyOptions()),
                                                 ('slsqp', LmOptions()), ('trust-constr', TaskOptions())])
def test_another_methods_options_raise(cup: GraspModel, method: str, options: object) -> None:
    v = intent.interpret((0.9, 0.9, 0.1), cup.zones).v
    with pytest.raises(PlanningError, match=f"method '{method}' takes {OPTIONS[method].__name__}"):  # type: ignore[index]
        planner.plan(cup, v, method=method, options=options)  # type: ignore[arg-type]


@pytest.mark.parametrize(('method', 'values', 'unused'), [('task', {'n_starts': 3}, 'n_starts'),
                                                          ('task', {'gradient': '2-point'}, 'gradient'),
                                                          ('lm', {'tau': 0.3}, 'tau'),
                                                          ('lm', {'gradient': '2-point'}, 'gradient'),
                                                          ('slsqp', {'faithful': 'reading'}, 'faithful')])
def test_an_option_the_method_does_not_use_raises(method: str, values: dict[str, object], unused: str) -> None:
    with pytest.raises(PlanningError, match=f"method '{method}' does not use {unused}"):
        options_for(method, **values)


@pytest.mark.parametrize('options', [TaskOptions(tau=1.5), TaskOptions(hysteresis=-0.1),
                                     TaskOptions(faithful='both'),  # type: ignore[arg-type]
                                     LmOptions(n_starts=0), LmOptions(top_zones=0),
                                     ScipyOptions(gradient='3-point')])  # type: ignore[arg-type]
def test_values_out_of_range_raise(options: TaskOptions | LmOptions | ScipyOptions) -> None:
    method = {TaskOptions: 'task', LmOptions: 'lm', ScipyOptions: 'slsqp'}[type(options)]
    with pytest.raises(PlanningError):
        check_options(method, options)


def test_an_unknown_method_raises() -> None:
    with pytest.raises(PlanningError, match="method must be one of 'task', 'lm'"):
        check_options('newton', None)


def test_the_node_gives_starts_only_to_the_methods_that_take_them() -> None:
    assert node_options('task', 5) == TaskOptions()
    assert node_options('lm', 5) == LmOptions(n_starts=5)
    assert node_options('trust-constr', 5) == ScipyOptions(n_starts=5)


def test_a_task_candidate_names_its_demonstration_and_its_rank(cup: GraspModel) -> None:
    res = planner.plan(cup, intent.interpret((0.9, 0.9, 0.1), cup.zones).v)
    assert [c.start_index for c in res.candidates] == list(range(len(res.candidates)))
    for cand in res.candidates:
        assert cand.demonstration is not None and 0 <= cand.demonstration < len(cup.demo_sets)
        assert cand.message.startswith(f'demonstration {cand.demonstration} ')
        assert np.array_equal(cand.x, cand.start)
    lm = planner.plan(cup, intent.interpret((0.9, 0.9, 0.1), cup.zones).v, method='lm')
    assert all(c.demonstration is None for c in lm.candidates)
