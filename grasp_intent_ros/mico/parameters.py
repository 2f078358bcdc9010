"""The parameters of the nodes that drive the MICO: the grasp planner's and the mock arm's, and those shared.

Each table is a tuple of :class:`~grasp_intent_ros.parameters.ParamSpec`, declared on a node by
:func:`grasp_intent_ros.ros.params.declare_parameters`; config/<node>.yaml documents each parameter with its
description (test/ros/test_config_files.py) and docs/nodes.md's table lists them
(test/unit/test_parameter_docs.py).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..method.intent import all_zones, match_zones, single_task_v
from ..method.parameters import TASK_NAMES
from ..parameters import ParamSpec, finite_vector, one_of
from ..planning.options import DEFAULT_METHOD, METHODS, NODE_EXECUTION_NOISE, noise_from
from .frames import DEFAULT_OBJECT_ORIENTATION, DEFAULT_OBJECT_POSITION, check_unit_quaternion, pose_to_matrix
from .grasp import JOINT_NAMES, check_workspace
from .grasp_clearance import Table
from .kinematics import HOME_Q
from .mock_arm import FINGER_VELOCITY_LIMIT, TWIST_JOINT_LIMITS

__all__ = ['URDF_PATH', 'OBJECT_POSE', 'check_object_pose', 'object_pose', 'check_table_plane', 'PLAN_FOR',
           'planned_target', 'GRASP_PLANNER', 'TRAJECTORY_EXECUTIONS', 'MOCK_ARM']

URDF_PATH = ParamSpec('urdf_path', '', "MICO URDF; '' means the package's config/mico_3f.urdf.", read_only=True)
"""The robot's description, read once at start (every node that has the kinematics)."""

OBJECT_POSE = (
    ParamSpec('object_position', DEFAULT_OBJECT_POSITION,
              'Object pose until one arrives on object/pose (and whenever set): position (x, y, z) of the '
              'object frame in m1n6s300_link_base, m.', validator=finite_vector(3, 'x, y, z in m')),
    ParamSpec('object_orientation', DEFAULT_OBJECT_ORIENTATION,
              'Object pose orientation: unit quaternion (x, y, z, w) in m1n6s300_link_base. The default '
              'turns the cup handle (+x of the object) towards the arm.', validator=check_unit_quaternion,
              constraints='unit norm within 1e-3'),
    ParamSpec('workspace_radius', 1.5,
              'Largest distance (m) of an object position from the m1n6s300_link_base origin: a pose on '
              'object/pose or object_position farther away is rejected (the arm reaches about 1 m).',
              range=(0.1, 100.0)),
)
"""The object's pose until one arrives on ``object/pose``, and the workspace (planner and intent estimator)."""


def check_object_pose(values: Mapping[str, Any]) -> None:
    """The rule of :data:`OBJECT_POSE` over its values: the position within ``workspace_radius`` (KinematicsError)."""
    check_workspace(values['object_position'], values['workspace_radius'], what='object_position')


def object_pose(values: Mapping[str, Any]) -> NDArray[np.float64]:
    """``base_T_obj``, shape (4, 4), of the :data:`OBJECT_POSE` values."""
    return pose_to_matrix(values['object_position'], values['object_orientation'])


def check_table_plane(value: Any) -> None:
    """Validate ``table_plane``: all zeros, or 4 finite numbers with a non-zero normal (raises ValueError)."""
    if any(value):
        Table.in_object_frame(value, np.eye(4))


PLAN_FOR = ('v', 'most_likely_task')
"""What the planner node plans for: the target vector v as received, or v on the single most likely task's zone."""


def planned_target(plan_for: str, v: NDArray[np.float64], v_labels: Sequence[str] | None,
                   task_names: Sequence[str]) -> tuple[NDArray[np.float64], tuple[int, ...]]:
    """The target vector and its zones (over ``task_names``) the planner plans for under ``plan_for``.

    ``v`` as received, its zones read from ``v_labels`` (:func:`~grasp_intent_ros.method.intent.match_zones`, whose
    errors it raises). ``'v'``: ``v`` over those zones. ``'most_likely_task'``: v on the zone of the single most
    likely task alone, over all zones of the tasks (:func:`~grasp_intent_ros.method.intent.single_task_v`, ties to
    the first task); a v that gives no zone any probability is kept (the plan asks for clarification, as for the
    intent-aware target). Raises InvalidIntentError for a v that is not finite and non-negative
    (``'most_likely_task'``).
    """
    zones = match_zones(v.size, v_labels, task_names)
    single = single_task_v(v, zones, len(task_names)) if plan_for == 'most_likely_task' else None
    return (v, zones) if single is None else (single, all_zones(len(task_names)))


GRASP_PLANNER = (
    ParamSpec('method', DEFAULT_METHOD, "Planner method: 'task' (default: the demonstration that serves the "
              "likely tasks, docs/planner.md), or the paper's 'lm' (P = v by log-odds projection, else least "
              "squares), 'slsqp' (SQP) or 'trust-constr' (interior point).", validator=one_of(METHODS),
              constraints=f'one of {", ".join(METHODS)}'),
    ParamSpec('execution_noise', NODE_EXECUTION_NOISE,
              "Where the arm lands around a plan, as standard deviations: palm per axis (m), approach tilt about "
              "each of two axes orthogonal to it (rad), wrist roll (rad), each finger closure (rad). Method 'task' "
              "picks the grasp with the highest expected success as executed (docs/planner.md). The default is "
              "the documented 1x level: 5 mm, 3 degrees, 3 degrees, 0.1 rad. All zero: an exact landing. The "
              "estimate is made when a model is read, before its first plan (about a second of CPU per model).",
              validator=noise_from, constraints='4 finite numbers >= 0'),
    ParamSpec('n_starts', 3, 'Demonstrations the planner starts from (plus the warm start).', range=(1, 20)),
    ParamSpec('ik_restarts', 8, 'Random IK restarts after the seeded attempt fails.', range=(0, 100)),
    *OBJECT_POSE,
    ParamSpec('object_marker_size', (0.08, 0.10), 'Diameter and height of the object marker, m.',
              validator=finite_vector(2, 'diameter, height in m', positive=True)),
    ParamSpec('min_replan_period', 0.0, 'Least time between the starts of two plans, s (0: plan at once).',
              range=(0.0, 10.0)),
    ParamSpec('markers_period', 0.1, 'Least time between two grasp/markers messages, s (0: with every plan). '
              'Markers are for RViz and cost as much to build as the other outputs together.',
              range=(0.0, 10.0)),
    URDF_PATH,
    ParamSpec('collision_check', True, 'Turn down grasps whose hand goes into the table or the object on the '
              'approach (fingers open, from the pre-grasp 0.08 m behind), as unreachable ones are '
              '(docs/planner.md, "The hand\'s clearance"); false: publish them.'),
    ParamSpec('object_margin', 0.0, 'With collision_check: how much shallower (m) than the check\'s limits the palm '
              'and the open fingers should stay in the object, for the error of the object\'s pose (e.g. '
              'collision.tracker_margin of the tracker\'s position and angle RMS): preferred, the limits alone when '
              'no grasp keeps it (docs/planner.md, "The hand\'s clearance"); 0: the limits alone.',
              range=(0.0, 0.05)),
    ParamSpec('table_plane', (0.0, 0.0, 0.0, 0.0), 'The table in m1n6s300_link_base: (nx, ny, nz, d), points '
              'with n . p >= d above it, m; all zeros: the plane the object stands on (z = 0 of its frame).',
              validator=check_table_plane),
    ParamSpec('plan_for', 'v', "'v' (default): the target vector as received, the intent-aware grasp; "
              "'most_likely_task': the grasp separate per-task classifiers would choose, v on the zone of the single "
              "most likely task alone (a task's probability: v's sum over the zones holding it; probabilities within "
              '1e-12 of each other tie, the first task wins), a baseline for benchmarks. The other nodes keep v as '
              'received.',
              validator=one_of(PLAN_FOR), constraints=f'one of {", ".join(PLAN_FOR)}'),
    TASK_NAMES,
)
"""The grasp planner node's parameters (:mod:`grasp_intent_ros.nodes.grasp_planner`, docs/nodes.md)."""

TRAJECTORY_EXECUTIONS = ('on_arrival', 'on_request')
"""When the mock arm follows a trajectory (:mod:`grasp_intent_ros.nodes.mock_arm`)."""

MOCK_ARM = (
    ParamSpec('objects', [], 'Names of the objects of a scene (suite --object ... --shared-control sets it): '
              'grasp/close closes to the newest <object>/grasp/joint_targets and grasp/execute runs the newest '
              '<object>/grasp/trajectory of the object the assistance follows (assistance/object); needs '
              'trajectory_execution on_request. Empty: grasp/joint_targets and arm_controller/joint_trajectory.',
              item_type=str, read_only=True,
              constraints='unique ROS name tokens, none a folder of the suite\'s topics (checked by the node: '
              'wire.topics.check_object_names)'),
    ParamSpec('initial_positions', (*HOME_Q.tolist(), 0.0, 0.0, 0.0),
              f'Start (and reset) positions, rad, of {", ".join(JOINT_NAMES)}; default Home, fingers open.',
              validator=finite_vector(len(JOINT_NAMES), 'rad')),
    ParamSpec('period', 0.01, 'Time step and joint_states period, s.', range=(0.001, 1.0), read_only=True),
    ParamSpec('command_timeout', 0.1, 'A twist older than this (s) stops the arm (MoveIt Servo: '
              'incoming_command_timeout).', range=(0.001, 10.0)),
    ParamSpec('ik_damping', 0.05, 'Largest damping lambda of the differential IK of twists (at a singularity).',
              range=(1e-6, 10.0)),
    ParamSpec('singular_threshold', 0.05, 'Smallest singular value of the Jacobian below which the IK is damped.',
              range=(1e-6, 10.0)),
    ParamSpec('trajectory_execution', 'on_arrival', "When a trajectory is followed: 'on_arrival' (a "
              "joint_trajectory_controller) or 'on_request' (kept until grasp/execute: the twist stream owns the "
              'arm, as under shared control).',
              validator=one_of(TRAJECTORY_EXECUTIONS), constraints=f'one of {", ".join(TRAJECTORY_EXECUTIONS)}'),
    ParamSpec('allow_partial_joints_goal', False, 'Accept trajectories for some of the joints (the '
              "joint_trajectory_controller's parameter)."),
    ParamSpec('twist_joint_limit', 'clip', "What a twist does at a joint limit: 'clip' each joint on its own (the "
              "others go on, so the hand may leave the commanded direction) or 'stop' the arm as a whole where a "
              'joint reaches its limit (MoveIt Servo halts all joints; a twist moving that joint inward moves the '
              'arm again). Trajectories and fingers: clipped per joint either way.',
              validator=one_of(TWIST_JOINT_LIMITS), constraints=f'one of {", ".join(TWIST_JOINT_LIMITS)}'),
    ParamSpec('finger_velocity_limit', FINGER_VELOCITY_LIMIT, 'Finger speed limit, rad/s.', range=(1e-3, 10.0)),
    ParamSpec('closure_error', 0.05, "Standard deviation (rad) of each finger's closure error on grasp/close.",
              range=(0.0, 1.0)),
    ParamSpec('closure_seed', 0, 'Seed of the closure errors, one draw per grasp/close. A set at run time (even to '
              'the current value) restarts their sequence, so the closes after two sets to one value draw the '
              'same errors.', range=(0, 2**31 - 1)),
    URDF_PATH,
)
"""The mock arm node's parameters (:mod:`grasp_intent_ros.nodes.mock_arm`)."""
