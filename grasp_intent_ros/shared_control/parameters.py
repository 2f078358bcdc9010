"""The shared-control nodes' parameters: the assistance's, the estimator's, the scripted operator's; the twist's input.

Each table is a tuple of :class:`~grasp_intent_ros.parameters.ParamSpec`, declared on a node by
:func:`grasp_intent_ros.ros.params.declare_parameters`; the defaults of the maths' settings are those of
:class:`~.assistance_config.AssistanceConfig` and :class:`~.estimator.EstimatorConfig`, which the nodes build from
the values of the same names (:func:`~grasp_intent_ros.parameters.config_from`). config/<node>.yaml
documents each parameter with its description (test/ros/test_config_files.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..method.parameters import TASK_NAMES
from ..mico.kinematics import BASE_FRAME, EE_FRAME
from ..mico.parameters import OBJECT_POSE, URDF_PATH, check_object_pose
from ..parameters import ParamSpec, config_from, one_of
from .arbitration import ARBITRATIONS
from .assistance_config import AssistanceConfig
from .calibration import model_calibration
from .estimator import EstimatorConfig
from .operator_loop import EXECUTE_TIMEOUT
from .operators import DEVICES
from .scene_target import FollowRule

__all__ = ['OPERATOR_INPUT', 'APPROACH', 'ASSISTANCE', 'ESTIMATOR', 'estimator_config', 'default_estimator_config',
           'check_estimator', 'OPERATOR_INTENTS', 'SCRIPTED_OPERATOR', 'check_scripted_operator', 'episodes_settings']

OPERATOR_INPUT = (
    ParamSpec('operator_message_type', 'TwistStamped', 'Type on operator/twist: TwistStamped or Twist.',
              validator=one_of(('TwistStamped', 'Twist')), read_only=True),
    ParamSpec('operator_frame', BASE_FRAME, 'Frame of a plain Twist or of a TwistStamped with an empty frame_id.',
              validator=one_of((BASE_FRAME, EE_FRAME))),
)
"""How the operator's twist on ``operator/twist`` is read (assistance and intent estimator)."""

_ASSIST = AssistanceConfig()
_POSITIVE = (1e-6, 100.0)
APPROACH = (
    ParamSpec('standoff', _ASSIST.standoff, 'Pre-grasp distance behind the grasp along its approach axis, m.',
              range=(0.0, 0.5)),
    ParamSpec('corridor_radius', _ASSIST.corridor_radius, 'Approach corridor radius, m.', range=_POSITIVE),
    ParamSpec('corridor_angle', _ASSIST.corridor_angle, 'Approach corridor orientation tolerance, rad.',
              range=(0.0, 3.2)),
)
"""The approach to a grasp via its pre-grasp (:mod:`.approach`): the assistance's and the estimator's operator's."""

_FOLLOW = FollowRule()
ASSISTANCE = (
    ParamSpec('objects', [], 'Names of the objects of a scene (suite --object ... --shared-control sets it): assist '
              'toward the grasp of one of them at a time from the suite\'s namespace, reading each <object>/grasp/*, '
              '<object>/intent/v, intent/clarification, model/active and object/pose, and P(o) on intent/objects; '
              'the object followed on assistance/object. Empty: one object, in this namespace.',
              item_type=str, read_only=True, constraints='unique ROS name tokens, none a folder of the suite\'s topics '
              '(checked by the node: wire.topics.check_object_names)'),
    ParamSpec('follow_margin', _FOLLOW.margin, 'objects: the lead in score (P(o) P(grasp serves T) agreement, in '
              '[0, 1]) another object needs over the followed one to be followed instead.', range=(0.0, 1.0)),
    ParamSpec('follow_hold_time', _FOLLOW.hold_time, 'objects: seconds that lead must last.', range=(0.0, 10.0)),
    ParamSpec('arbitration', _ASSIST.arbitration, "alpha's rule: 'confidence' (the probability that the grasp "
              "serves the operator's task, times the operator's agreement), 'blend' (alpha_max when v's top zone "
              "leads by margin) or 'none' (alpha = 0).",
              validator=one_of(ARBITRATIONS), constraints=f'one of {", ".join(ARBITRATIONS)}'),
    ParamSpec('alpha_max', _ASSIST.alpha_max, 'Largest alpha (the operator keeps 1 - alpha_max).',
              range=(0.0, 1.0)),
    ParamSpec('margin', _ASSIST.margin, "'blend': lead of v's top zone over the second (of the total).",
              range=(0.0, 1.0)),
    *APPROACH,
    ParamSpec('gain_linear', _ASSIST.gain_linear, "Robot twist's position gain, 1/s.", range=_POSITIVE),
    ParamSpec('gain_angular', _ASSIST.gain_angular, "Robot twist's orientation gain, 1/s.", range=_POSITIVE),
    ParamSpec('robot_max_linear', _ASSIST.robot_max_linear, "Robot twist's speed limit, m/s.", range=_POSITIVE),
    ParamSpec('robot_max_angular', _ASSIST.robot_max_angular, "Robot twist's angular speed limit, rad/s.",
              range=_POSITIVE),
    ParamSpec('gain_joint', _ASSIST.gain_joint, "Robot twist's joint-space gain toward the target's IK, 1/s.",
              range=_POSITIVE),
    ParamSpec('deadband_linear', _ASSIST.deadband_linear, "'confidence': operator speed (m/s) from which an "
              'operator steering away from the grasp (the agreement is measured against the grasp\'s approach '
              "target, its pre-grasp then itself, not the robot's twist) lowers alpha.", range=(0.0, 10.0)),
    ParamSpec('deadband_angular', _ASSIST.deadband_angular, "'confidence': the same for the operator's angular "
              'speed, rad/s.', range=(0.0, 10.0)),
    ParamSpec('yield_time', _ASSIST.yield_time, "'confidence': seconds of sustained opposition after which the "
              'robot yields (alpha 0), and of heading back to the grasp after which it assists again.',
              range=(0.0, 10.0)),
    ParamSpec('assist_without_input', _ASSIST.assist_without_input, "Whether the robot's twist moves the hand "
              'while the operator gives no input (both parts within their deadbands).'),
    ParamSpec('keep_pace', _ASSIST.keep_pace, "Whether the robot's twist, before blending, goes at least the "
              "operator's speed along the operator's direction in each part the operator moves (the blend never "
              "slows the operator's own motion; the robot adds what lies across it)."),
    ParamSpec('robot_agreement', _ASSIST.robot_agreement, "Whether alpha is also multiplied by the operator's "
              "agreement with the robot's own twist (per part max(cos, 0), faded out below the deadbands; the "
              "smaller part's): where the robot's twist runs against the operator's, the operator moves alone."),
    ParamSpec('assist_idle_part', _ASSIST.assist_idle_part, "Whether the robot's share in a part (linear, angular) "
              'the operator leaves idle (within its deadband) while moving the other is alpha_max rather than alpha '
              '(a two-mode device: the robot turns the hand while the operator translates).'),
    ParamSpec('keep_joint_line', _ASSIST.keep_joint_line, "Whether the joint-space robot twist is scaled into "
              'robot_max_linear and robot_max_angular by one factor (its joint image stays on the straight joint line '
              'to its target) rather than each part to its own limit.'),
    ParamSpec('operator_timeout', _ASSIST.operator_timeout, 'Operator twist age (s) from which the output is '
              'the zero twist (MoveIt Servo: incoming_command_timeout).', range=(0.001, 10.0)),
    ParamSpec('clearance_margin', _ASSIST.clearance_margin, "m: how far beyond the planner's collision limits the "
              "robot's joint path keeps the open hand from the object (its body in the active model, at the "
              'object pose).', range=(0.0, 0.5)),
    ParamSpec('max_linear', 0.2, 'Output speed limit, m/s.', range=_POSITIVE),
    ParamSpec('max_angular', 1.0, 'Output angular speed limit, rad/s.', range=_POSITIVE),
    ParamSpec('max_linear_acceleration', 1.0, 'Output acceleration limit, m/s^2.', range=_POSITIVE),
    ParamSpec('max_angular_acceleration', 5.0, 'Output angular acceleration limit, rad/s^2.', range=_POSITIVE),
    ParamSpec('publish_period', 0.01, 'Longest time between two outputs, s (MoveIt Servo: publish_period).',
              range=(0.001, 1.0), read_only=True),
    ParamSpec('thread_priority', 0, 'Real-time priority (Linux SCHED_FIFO, 1-99) of the node process\'s threads, set '
              'once its warm-up is done and its path search has started (that process stays at the normal '
              'priority); 0: the normal priority. Needs the privilege (CAP_SYS_NICE or RLIMIT_RTPRIO); without it '
              'a WARN and the node runs on (ros2_control and MoveIt Servo: thread_priority).', range=(0, 99),
              read_only=True),
    *OBJECT_POSE,
    *OPERATOR_INPUT,
    URDF_PATH,
)
"""The assistance node's parameters (:mod:`grasp_intent_ros.nodes.assistance`)."""

_ESTIMATE = EstimatorConfig()
_SCALE = (1e-6, 1e6)
ESTIMATOR = (
    ParamSpec('objects', [], 'Names of the objects of a scene (suite --object): estimate over all of their goals from '
              'the suite\'s namespace, reading each <object>/object/pose, model/active, grasp/pose and intent/prior, '
              'publishing each <object>/intent/w and P(o) on intent/objects. Empty: one object, in this namespace.',
              item_type=str, read_only=True, constraints='unique ROS name tokens, none a folder of the suite\'s topics '
              '(checked by the node: wire.topics.check_object_names)'),
    ParamSpec('rationality', _ESTIMATE.rationality, 'beta, 1/m: log-likelihood per metre of progress toward a '
              'goal.', range=_SCALE),
    ParamSpec('memory', _ESTIMATE.memory, 'L, m of the hand\'s pose motion over which the evidence fades by e.',
              range=_SCALE),
    ParamSpec('rotation_length', _ESTIMATE.rotation_length, 'rho, m per rad: the weight of the hand\'s rotation.',
              range=_SCALE),
    ParamSpec('position_scale', _ESTIMATE.position_scale, 'delta_p, m: progress toward a goal fades within it.',
              range=_SCALE),
    ParamSpec('angle_scale', _ESTIMATE.angle_scale, 'delta_theta, rad: the same for the orientation.',
              range=(1e-6, 3.14159)),
    ParamSpec('w_floor', _ESTIMATE.w_floor, 'w is kept within [w_floor, 1 - w_floor].', range=(1e-6, 0.49)),
    ParamSpec('max_dt', _ESTIMATE.max_dt, 'Longest time one operator twist is taken to act, s.', range=(1e-3, 10.0)),
    ParamSpec('proposal_radius', _ESTIMATE.proposal_radius, 'm: goals within it (and proposal_angle) of the shown '
              'grasp are credited with the progress toward it; within position_scale and angle_scale of it motion '
              'that does not move away from it is no evidence (0: the shown grasp is ignored).', range=(0.0, 10.0)),
    ParamSpec('proposal_angle', _ESTIMATE.proposal_angle, 'rad: the same for the orientation.', range=(0.0, 3.15)),
    *APPROACH,
    ParamSpec('calibration_models', [], 'Models whose task marginals are mapped to sigmoid(a logit(w) + b) (a map '
              'fitted on training reaches of that model); another model\'s w is not mapped.', item_type=str),
    ParamSpec('calibration_slopes', [], 'a (> 0) of the map of each of calibration_models.', item_type=float),
    ParamSpec('calibration_offsets', [], 'b of the map of each of calibration_models.', item_type=float),
    ParamSpec('publish_period', 0.04, 'Time between two w while the operator moves, s.', range=(0.001, 1.0),
              read_only=True),
    ParamSpec('operator_timeout', 0.1, 'Operator twist age (s) after which the operator counts as still (no w '
              'published).', range=(0.001, 10.0)),
    *OBJECT_POSE[:2],
    ParamSpec('object_tolerance', 0.01, 'An object that moves farther (m) restarts the estimate with new goals.',
              range=(0.0, 1.0)),
    ParamSpec('angle_tolerance', 0.05, 'An object that turns farther (rad) restarts the estimate with new goals.',
              range=(0.0, 3.2)),
    OBJECT_POSE[2],
    ParamSpec('ik_restarts', 2, 'Random IK restarts when a goal is checked for reachability.', range=(0, 100)),
    *OPERATOR_INPUT,
    URDF_PATH,
    TASK_NAMES,
)
"""The intent estimator node's parameters (:mod:`grasp_intent_ros.nodes.intent_estimator`)."""


def estimator_config(values: Mapping[str, Any], model_name: str | None) -> EstimatorConfig:
    """The EstimatorConfig of :data:`ESTIMATOR`'s values, with the calibration map listed for ``model_name``.

    Raises InvalidIntentError for invalid settings or calibration lists (:func:`.calibration.model_calibration`).
    """
    slope, offset = model_calibration(model_name, values['calibration_models'], values['calibration_slopes'],
                                      values['calibration_offsets'])
    return config_from(EstimatorConfig, {**values, 'calibration_slope': slope, 'calibration_offset': offset})


def default_estimator_config(model_name: str | None) -> EstimatorConfig:
    """The intent estimator node's settings for ``model_name`` when no parameter is set: :data:`ESTIMATOR`'s defaults.

    Those defaults' calibration lists name the models that are mapped by default, so this is EstimatorConfig's
    defaults with that model's map, if one is listed. The benchmarks' "defaults" are these (one definition with the
    node's). Raises InvalidIntentError as :func:`estimator_config`.
    """
    return estimator_config({spec.name: spec.default for spec in ESTIMATOR}, model_name)


def check_estimator(values: Mapping[str, Any]) -> None:
    """The rules over :data:`ESTIMATOR`'s values: valid settings and calibration lists, the object in the workspace."""
    estimator_config(values, None)
    check_object_pose(values)


OPERATOR_INTENTS = ('held', 'none')
"""Whether the scripted operator publishes w: ``held`` (:class:`~.operators.PersistentIntent`) or ``none``."""


def _probabilities(value: Any) -> None:
    if not value or not all(math.isfinite(v) and 0.0 <= v <= 1.0 for v in value):
        raise ValueError(f'must be probabilities in [0, 1], one per task of the model; got {list(value)}')


def _task_names(value: Any) -> None:
    if not value or len(set(value)) != len(value):
        raise ValueError(f'must name one task or more, each once; got {list(value)}')


SCRIPTED_OPERATOR = (
    ParamSpec('object', '', "The object of a scene it reaches for (suite --object ... --with scripted_operator sets "
              "it): it reads that object's chain, <object>/grasp/pose, grasp/trajectory, object/pose and model/active, "
              "and publishes a held w on <object>/intent/w; the arm's joint_states, operator/twist and the arm's "
              "services stay in its namespace. Empty: one object, in its namespace.", read_only=True,
              constraints='empty, or a ROS name token that is not a folder of the suite\'s topics (checked by the '
              'node: wire.topics.check_object_names)'),
    ParamSpec('device', 'spacemouse', "The device model: 'spacemouse' (six axes at once) or 'joystick' (translation "
              'or rotation, 0.5 s to switch).', validator=one_of(DEVICES), constraints=f'one of {", ".join(DEVICES)}',
              read_only=True),
    ParamSpec('task_set', ['usage', 'transfer'], "The tasks the operator truly wants (of the active model's): its own "
              'grasp is the planner\'s for the certain w of this set.', validator=_task_names),
    ParamSpec('seed', 0, "Seed of the device's noise and of the held w's noise.", range=(0, 2**31 - 1),
              read_only=True),
    ParamSpec('publish_period', 0.01, 'Time between two operator twists, s.', range=(0.001, 1.0), read_only=True),
    ParamSpec('start_delay', 1.0, 'Seconds from the moment the hand and its own grasp are known to the reach, in '
              'each episode.', range=(0.0, 3600.0)),
    ParamSpec('intent', 'held', "'held': publish w on intent/w (the w parameter with N(0, w_noise^2) per task, "
              "clipped to [0.02, 0.98], every w_period s); 'none': another source gives w (the intent estimator, "
              'ros2 topic pub).', validator=one_of(OPERATOR_INTENTS),
              constraints=f'one of {", ".join(OPERATOR_INTENTS)}'),
    ParamSpec('w', [0.9, 0.9, 0.1], "With intent 'held': the w held, one probability per task of the model.",
              validator=_probabilities),
    ParamSpec('w_noise', 0.05, "With intent 'held': the standard deviation of each task's noise.",
              range=(0.0, 1.0)),
    ParamSpec('w_period', 0.1, "With intent 'held': time between two w, s.", range=(0.01, 10.0), read_only=True),
    ParamSpec('close_on_reach', True, 'Whether the operator calls grasp/close (std_srvs/Trigger) once the hand it '
              'sees is at the grasp it pursues (else it only stops there).'),
    ParamSpec('execute_shown', True, 'With close_on_reach: whether a close on the shown grasp executes it first, as '
              'the suite\'s grasp command: zero twists until the hand is at rest, grasp/execute (the arm follows the '
              'planner\'s latest grasp/trajectory), zero twists until that trajectory has had its time (its last '
              'time_from_start), then grasp/close; a refused execute closes where the hand is. On its own grasp the '
              'hand always closes where it is.'),
    ParamSpec('execute_timeout', EXECUTE_TIMEOUT, 'The longest wait (s) from grasp/execute to grasp/close (no '
              'answer, or no grasp/trajectory received).', range=(0.1, 600.0)),
    ParamSpec('episodes', 1, 'How many reaches: after each but the last the operator holds still for hold s, resets '
              'the arm (mock_arm/reset) and reaches again; 0: without end. Raised after the last (or set to 0), '
              'the operator goes on.', range=(0, 1000000)),
    ParamSpec('hold', 2.0, 'Seconds the operator holds still after a close.', range=(0.0, 3600.0)),
    *OBJECT_POSE,
    URDF_PATH,
)
"""The scripted operator node's parameters (:mod:`grasp_intent_ros.nodes.scripted_operator`)."""


def check_scripted_operator(values: Mapping[str, Any]) -> None:
    """The rules over :data:`SCRIPTED_OPERATOR`'s values: the object in the workspace."""
    check_object_pose(values)


def episodes_settings(values: Mapping[str, Any]) -> dict[str, Any]:
    """:class:`~.operator_loop.OperatorEpisodes`' settings from :data:`SCRIPTED_OPERATOR`'s values (its fields').

    A close on the shown grasp executes it first only when the operator closes at all (``close_on_reach``).
    """
    return {'start_delay': values['start_delay'], 'hold': values['hold'], 'episodes': values['episodes'],
            'execute_shown': values['execute_shown'] and values['close_on_reach'],
            'execute_timeout': values['execute_timeout']}
