"""The planner's answers do not depend on the CPU: the same bits under another CPU's OpenBLAS kernels and numba target.

numpy's matrix products and factorisations run OpenBLAS kernels chosen for the CPU, and they sum in
orders of their own. The model's precisions and normalisers, the planner's screens and its kernels are
written out with every sum in a fixed order, so a plan is a function of its input bit for bit. The tests
run the same plans, and the MICO grasps made of them, in processes whose OpenBLAS takes the kernels of
another CPU (``OPENBLAS_CORETYPE``), or whose numba compiles for a generic x86-64 CPU (``NUMBA_CPU_NAME``),
and compare the bits: both methods ('task' and 'lm'), fresh and warm-started, the robustness estimate of the
7-zone models at the 1x execution noise, and the MICO's pose, joint targets and trajectory duration of
:func:`~grasp_intent_ros.mico.grasp.plan_grasp`.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = r'''
import hashlib
import numpy as np
from grasp_intent_ros.method import intent
from grasp_intent_ros.planning import planner
from grasp_intent_ros.planning.robustness import ExecutionNoise, retention
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.grasp import Grasp, plan_grasp
from grasp_intent_ros.mico.kinematics import MicoKinematics
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.resources import config_dir

plans, blas = hashlib.sha256(), hashlib.sha256()
kin, base_T_obj = MicoKinematics(), pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
rng = np.random.default_rng(3)
for name in ('cup_7zone', 'flashlight_7zone', 'cup_5zone', 'cup_4zone'):
    model = GraspModel.load(config_dir() / 'models' / f'{name}.yaml')
    pool = model.start_pool
    for array in (model.precisions, model.log_norm, pool.log_joint_t, pool.posterior, model.feature_scale):
        plans.update(np.ascontiguousarray(array).tobytes())
    blas.update((np.linalg.inv(model.covariances) @ model.covariances).tobytes())  # numpy's own BLAS
    if name.endswith('7zone'):  # the robustness estimate the planner node plans with (its default noise)
        plans.update(retention(model, ExecutionNoise()).tobytes())
    previous = None
    for w in rng.uniform(0.0, 1.0, (30, 3)):  # fresh plans, then each warm-started from the one before
        v = intent.interpret(w, model.zones).v
        if v is not None:
            plans.update(planner.plan(model, v).x.tobytes() + planner.plan(model, v, method='lm').x.tobytes())
            previous = planner.plan(model, v, warm_start=previous).x
            plans.update(previous.tobytes())
    for w in rng.uniform(0.0, 1.0, (6, 3)):  # what a bag records: the MICO's pose and joint targets
        v = intent.interpret(w).v
        for method in ('task', 'lm'):
            grasp = None if v is None else plan_grasp(model, v, intent.all_zones(3), base_T_obj, kin, name=name,
                                                      method=method)
            if isinstance(grasp, Grasp):
                plans.update(grasp.base_T_ee.tobytes() + grasp.positions.tobytes()
                             + repr(grasp.duration_s).encode())
print(plans.hexdigest(), blas.hexdigest())
'''


def _run_probe(coretype: str | None, cpu_name: str | None = None) -> tuple[str, str]:
    env = dict(os.environ)
    env.pop('OPENBLAS_CORETYPE', None)
    env.pop('NUMBA_CPU_NAME', None)
    if coretype is not None:
        env['OPENBLAS_CORETYPE'] = coretype
    if cpu_name is not None:
        env['NUMBA_CPU_NAME'] = cpu_name
    done = subprocess.run([sys.executable, '-c', PROBE], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    plans, blas = done.stdout.split()
    return plans, blas


@pytest.fixture(scope='module')
def own() -> tuple[str, str]:
    """The probe's hashes with the host's OpenBLAS kernels and numba compiling for the host."""
    return _run_probe(None)


def test_plans_have_the_same_bits_under_another_cpus_blas_kernels(own: tuple[str, str]) -> None:
    other, other_blas = _run_probe('Prescott')  # the SSE3 kernels: run on every x86-64 CPU
    if own[1] == other_blas:
        pytest.skip("OPENBLAS_CORETYPE changed nothing in numpy's own BLAS here: nothing to compare")
    assert other == own[0]


def test_plans_have_the_same_bits_with_numba_compiling_for_a_generic_cpu(own: tuple[str, str]) -> None:
    """The kernels compiled by numba for a baseline x86-64 CPU (no AVX, no FMA) instead of the host's."""
    assert _run_probe(None, 'generic')[0] == own[0]
