"""The scipy answers as references that are the same on every x86-64 CPU: the 60-start search, SLSQP, trust-constr.

SLSQP runs through scipy's OpenBLAS, whose kernels are chosen for the CPU and sum in orders of their own; its
iterations amplify those last bits, so the same search ends in other local minima on other kernels (the
flashlight's w #58 of bench_planner: 1.863e-6 with AVX-512 kernels, 1.937e-6 with Haswell's, 1.942e-6 with
Prescott's); trust-constr, through LAPACK, likewise. A margin against such a reference passes on one CPU
and fails on another.

:class:`FixedReference` therefore runs the search in a child process whose OpenBLAS takes the Prescott kernels
(SSE3, which every x86-64 CPU runs) on one thread: the same sums in the same order on every x86-64 machine.
v is passed to the child bit for bit. The planner itself does not depend on the kernels
(test_machine_independence.py), so the comparison is the same on every machine.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np

FIXED_KERNELS = {'OPENBLAS_CORETYPE': 'Prescott', 'OPENBLAS_NUM_THREADS': '1'}
"""The child's OpenBLAS: the SSE3 kernels, one thread (a threaded sum would split in an order of its own)."""

_CHILD = r'''
import json, sys
import numpy as np
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.planning import planner, scipy_methods
from grasp_intent_ros.resources import config_dir
models = {}
for line in sys.stdin:
    ask = json.loads(line)
    name = ask['model']
    model = models.setdefault(name, GraspModel.load(config_dir() / 'models' / f'{name}.yaml'))
    v = np.array([float.fromhex(h) for h in ask['v']])
    if ask['method'] == 'reference_search':
        f = scipy_methods.reference_search(model, v, n_starts=60)
    else:
        f = planner.plan(model, v, method=ask['method']).objective
    print(json.dumps(f.hex()), flush=True)
'''


class FixedReference:
    """A child process answering scipy's searches for a shipped model under :data:`FIXED_KERNELS`."""

    def __init__(self) -> None:
        env = {**os.environ, **FIXED_KERNELS}
        self._child = subprocess.Popen([sys.executable, '-c', _CHILD], env=env, stdin=subprocess.PIPE,
                                       stdout=subprocess.PIPE, text=True)

    def search(self, model_name: str, v: np.ndarray) -> float:
        """The lowest objective of the 60-start search for the shipped model ``model_name`` and exactly ``v``."""
        return self._ask(model_name, v, 'reference_search')

    def plan_objective(self, model_name: str, v: np.ndarray, method: str) -> float:
        """The objective of ``planner.plan(model, v, method=method)`` (scipy's methods run through BLAS too)."""
        return self._ask(model_name, v, method)

    def _ask(self, model_name: str, v: np.ndarray, method: str) -> float:
        assert self._child.stdin is not None and self._child.stdout is not None
        ask = {'model': model_name, 'v': [float(x).hex() for x in v], 'method': method}
        self._child.stdin.write(json.dumps(ask) + '\n')
        self._child.stdin.flush()
        answer = self._child.stdout.readline()
        assert answer, f'the reference search process ended (exit code {self._child.wait()})'
        return float.fromhex(json.loads(answer))

    def close(self) -> None:
        """End the child: it leaves its loop when its input closes."""
        assert self._child.stdin is not None
        self._child.stdin.close()
        try:
            self._child.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self._child.kill()
            self._child.wait()
