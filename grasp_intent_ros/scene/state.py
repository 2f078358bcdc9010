"""What the viewer shows, as one immutable value updated message by message (live and from a bag alike).

:class:`SceneState` holds the newest content of every topic the viewer follows (:data:`VIEWER_TOPICS`);
:func:`apply` returns the state after one message. Messages are read through their fields only
(the readers of :mod:`grasp_intent_ros.wire`), so an rclpy message of the live
viewer and a rosbags-decoded one of a session's playback give the same state. A message that cannot be
read raises a :class:`~grasp_intent_ros.errors.GraspIntentError` and leaves the state as it was.

The object's pose is the newest ``object/pose``; before one arrives (the planner then plans at its
``object_*`` parameters) it is the pose the newest plan implies: ``grasp/pose`` composed with the inverse
of the grasp in the object frame (``grasp/features``), when both carry the same stamp.

The tasks a planned grasp serves are judged by the rules of the object
(:data:`grasp_intent_ros.objects.demos.OBJECTS`) when the active model is known to be of that object:
its name is the object's name or starts with ``<object>_`` (``cup_7zone``), and its task names are the
rules' (:func:`~grasp_intent_ros.scene.plan.served_tasks`).

A scene of several objects (docs/several_objects.md: one planning chain per object in ``<namespace>/<object>``,
one arm) is an :class:`ObjectsState`: one :class:`SceneState` per chain, each updated by :func:`apply` with its
chain's :data:`CHAIN_TOPICS` and its own planner's status, the arm's :data:`ARM_TOPICS` once, the
intent estimator's P(o) (:data:`SCENE_TOPICS`: ``intent/objects``, a value per object labelled with the object
names; objects whose goals are not ready are not in it) and the object whose grasp the assistance follows
(``assistance/object``, latched) (:func:`apply_objects`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from ..errors import GraspIntentError
from ..mico.kinematics import ARM_JOINTS, BASE_FRAME, FINGER_JOINTS
from ..wire import topics
from ..wire.arrays import (
    Posterior,
    Stamp,
    msg_labels,
    msg_to_array,
    read_features,
    read_object_probabilities,
    read_posterior,
)
from ..wire.diagnostics import KEY_PLAN_STATUS, status_values
from ..wire.model_document import ModelDocument, read_model_document
from ..wire.robot_state import joint_positions, named_positions, pose_msg_to_matrix
from .plan import plan_object_pose, served_tasks

__all__ = ['VIEWER_TOPICS', 'ARM_TOPICS', 'CHAIN_TOPICS',
           'SCENE_TOPICS',
           'SceneState', 'ObjectsState', 'followed_topics', 'apply', 'apply_objects', 'apply_to', 'plan_status']

VIEWER_TOPICS: Final[Mapping[str, str]] = {
    t: topics.MSGTYPES[t] for t in (topics.JOINT_STATES, topics.GRASP_JOINT_TARGETS, topics.OBJECT_POSE,
                                    topics.MODEL_ACTIVE, topics.GRASP_POSE, topics.GRASP_FEATURES,
                                    topics.GRASP_POSTERIOR, topics.INTENT_W, topics.INTENT_V,
                                    topics.INTENT_CLARIFICATION, topics.DIAGNOSTICS, topics.OPERATOR_TWIST,
                                    topics.ASSISTANCE_TWIST, topics.ASSISTANCE_ALPHA)
}
"""Every topic the viewer follows (relative names; ``/diagnostics`` absolute) and its message type."""
ARM_TOPICS: Final = (topics.JOINT_STATES, topics.OPERATOR_TWIST, topics.ASSISTANCE_TWIST, topics.ASSISTANCE_ALPHA)
"""The viewer topics of the arm: in a scene of several objects, once, in the suite's namespace."""
CHAIN_TOPICS: Final = tuple(t for t in VIEWER_TOPICS if t not in ARM_TOPICS and t != topics.DIAGNOSTICS)
"""The viewer topics of a planning chain: in a scene of several objects, one set per object in its namespace."""
SCENE_TOPICS: Final[Mapping[str, str]] = {t: topics.MSGTYPES[t] for t in (topics.INTENT_OBJECTS,
                                                                           topics.ASSISTANCE_OBJECT)}
"""The viewer topics of a scene of several objects itself, in the suite's namespace, and their message types."""


def followed_topics(objects: Sequence[str]) -> tuple[tuple[str | None, str], ...]:
    """The (chain, topic) pairs the viewer follows, live or played back from a bag.

    With no ``objects`` (one chain): each of :data:`VIEWER_TOPICS`, chain None. For a scene of several
    ``objects``: the :data:`ARM_TOPICS`, the :data:`SCENE_TOPICS` and ``/diagnostics`` once (chain None), then
    each object's :data:`CHAIN_TOPICS`, in the order of ``objects``. The topics are relative to the suite's
    namespace (chain None) or to the object's chain; ``/diagnostics`` is absolute.
    """
    if not objects:
        return tuple((None, topic) for topic in VIEWER_TOPICS)
    return (*((None, topic) for topic in (*ARM_TOPICS, *SCENE_TOPICS, topics.DIAGNOSTICS)),
            *((chain, topic) for chain in objects for topic in CHAIN_TOPICS))


@dataclass(frozen=True)
class SceneState:
    """The newest content of each viewer topic; None (or '') until it arrives.

    Attributes
    ----------
    q_live, fingers_live : ndarray, shape (6,) and (3,)
        ``joint_states``: arm joint angles and finger closures (rad), each joint's latest position from whichever
        message named it last (the arm and the fingers may come from separate publishers, a message may name some
        joints only); each once all its joints have been named (no staleness: the newest known is shown).
    live_positions : mapping of str to float
        Every arm and finger joint named so far in ``joint_states``, its latest position (rad).
    q_target, fingers_target, targets_stamp : ndarray, shape (6,) and (3,), Stamp
        ``grasp/joint_targets`` of the newest plan, and its stamp.
    base_T_obj : ndarray, shape (4, 4)
        The newest ``object/pose``, in the base frame.
    plan_T_obj : ndarray, shape (4, 4)
        The object pose the newest plan implies (module docstring).
    model : ModelDocument
        ``model/active``.
    base_T_ee, ee_stamp : ndarray, shape (4, 4), Stamp
        ``grasp/pose`` and its stamp.
    x, x_stamp : ndarray, shape (d,), Stamp
        ``grasp/features`` (in :data:`~grasp_intent_ros.method.features.MICO_3F` order) and its stamp.
    posterior : Posterior
        ``grasp/posterior``: P over the model's zones and the w reconstructed from it.
    w, v, v_labels
        ``intent/w``; ``intent/v`` and its zone labels.
    clarification : str
        The newest ``intent/clarification``; cleared by the next plan.
    plan_status : str
        The planner's ``last plan status`` (``/diagnostics``).
    operator_twist, assistance_twist : ndarray, shape (6,)
        (vx, vy, vz, wx, wy, wz) in m/s and rad/s.
    alpha : float
        ``assistance/alpha``.
    """

    q_live: NDArray[np.float64] | None = None
    fingers_live: NDArray[np.float64] | None = None
    live_positions: Mapping[str, float] = field(default_factory=dict)
    q_target: NDArray[np.float64] | None = None
    fingers_target: NDArray[np.float64] | None = None
    targets_stamp: Stamp | None = None
    base_T_obj: NDArray[np.float64] | None = None
    plan_T_obj: NDArray[np.float64] | None = None
    model: ModelDocument | None = None
    base_T_ee: NDArray[np.float64] | None = None
    ee_stamp: Stamp | None = None
    x: NDArray[np.float64] | None = None
    x_stamp: Stamp | None = None
    posterior: Posterior[Stamp | None] | None = None
    w: NDArray[np.float64] | None = None
    v: NDArray[np.float64] | None = None
    v_labels: tuple[str, ...] = ()
    clarification: str = ''
    plan_status: str = ''
    operator_twist: NDArray[np.float64] | None = None
    assistance_twist: NDArray[np.float64] | None = None
    alpha: float | None = None

    @property
    def object_pose(self) -> NDArray[np.float64] | None:
        """``base_T_obj`` when one arrived, else ``plan_T_obj``."""
        return self.base_T_obj if self.base_T_obj is not None else self.plan_T_obj

    @property
    def plan_stamp(self) -> Stamp | None:
        """The stamp of the newest plan once its pose, joint targets, features and posterior have all arrived."""
        stamp = self.ee_stamp
        complete = stamp is not None and self.posterior is not None and \
            stamp == self.targets_stamp == self.x_stamp == self.posterior.stamp
        return stamp if complete else None

    @property
    def served(self) -> tuple[str, ...] | None:
        """The tasks the planned grasp serves by its object's rules; None when they are not known."""
        if self.x is None or self.model is None:
            return None
        return served_tasks(self.model.model, self.x)


def plan_status(msg: Any, namespace: str | None = None) -> str | None:
    """The planner's ``last plan status`` in a DiagnosticArray, else None.

    A planner's status is named ``<its node's full name>: planning``; with ``namespace`` ('' the root, else e.g.
    ``/cup``) only a planner node in that namespace counts, else any planner.
    """
    for status in msg.status:
        node, _, component = str(status.name).rpartition(': ')
        if component == 'planning' and (namespace is None or node.rpartition('/')[0] == namespace):
            value = status_values(status).get(KEY_PLAN_STATUS)
            if value is not None:
                return value
    return None


def _stamp(header: Any) -> Stamp:
    return Stamp(int(header.stamp.sec), int(header.stamp.nanosec))


def _twist(msg: Any) -> NDArray[np.float64]:
    lin, ang = msg.twist.linear, msg.twist.angular
    values = np.array([lin.x, lin.y, lin.z, ang.x, ang.y, ang.z], dtype=np.float64)
    if not np.all(np.isfinite(values)):
        raise GraspIntentError(f'twist must be finite, got {values.tolist()}')
    return values


def _with_plan_object(state: SceneState) -> SceneState:
    """``plan_T_obj`` from a pose and features of the same plan (same stamp)."""
    if state.base_T_ee is None or state.x is None or state.ee_stamp != state.x_stamp:
        return state
    return replace(state, plan_T_obj=plan_object_pose(state.base_T_ee, state.x))


def apply(state: SceneState, topic: str, msg: Any, *, namespace: str | None = None) -> SceneState:
    """The state after ``msg`` on ``topic`` (a key of :data:`VIEWER_TOPICS`); unchanged for another topic.

    ``namespace`` is the chain's: its planner's status alone is read from ``/diagnostics``
    (:func:`plan_status`; None: any planner's).

    Raises
    ------
    GraspIntentError
        For a message that cannot be read (its reason); ``state`` is then still the valid one.
    """
    if topic == topics.JOINT_STATES:
        named = named_positions(msg, (*ARM_JOINTS, *FINGER_JOINTS))
        if not named:
            return state
        live = {**state.live_positions, **named}
        q, fingers = (np.array([live[n] for n in names]) if all(n in live for n in names) else None
                      for names in (ARM_JOINTS, FINGER_JOINTS))
        return replace(state, live_positions=live, q_live=state.q_live if q is None else q,
                       fingers_live=state.fingers_live if fingers is None else fingers)
    if topic == topics.GRASP_JOINT_TARGETS:
        q, fingers = joint_positions(msg, ARM_JOINTS), joint_positions(msg, FINGER_JOINTS)
        if q is None:
            raise GraspIntentError(f'{topic} lacks the arm joints {ARM_JOINTS}')
        return replace(state, q_target=q, fingers_target=fingers, targets_stamp=_stamp(msg.header))
    if topic == topics.OBJECT_POSE:
        return replace(state, base_T_obj=pose_msg_to_matrix(msg, frame_id=BASE_FRAME))
    if topic == topics.MODEL_ACTIVE:
        return replace(state, model=read_model_document(str(msg.data), previous=state.model))
    if topic == topics.GRASP_POSE:
        pose = pose_msg_to_matrix(msg, frame_id=BASE_FRAME)
        return _with_plan_object(replace(state, base_T_ee=pose, ee_stamp=_stamp(msg.header), clarification=''))
    if topic == topics.GRASP_FEATURES:
        x, stamp = read_features(msg)
        return _with_plan_object(replace(state, x=x, x_stamp=stamp))
    if topic == topics.GRASP_POSTERIOR:
        return replace(state, posterior=read_posterior(msg))
    if topic == topics.INTENT_W:
        return replace(state, w=msg_to_array(msg, what='w'))
    if topic == topics.INTENT_V:
        v = msg_to_array(msg, what='v')
        labels = msg_labels(msg)
        return replace(state, v=v, v_labels=labels[0] if labels and len(labels[0]) == v.size else ())
    if topic == topics.INTENT_CLARIFICATION:
        return replace(state, clarification=str(msg.data))
    if topic == topics.DIAGNOSTICS:
        status = plan_status(msg, namespace)
        return state if status is None else replace(state, plan_status=status)
    if topic == topics.OPERATOR_TWIST:
        return replace(state, operator_twist=_twist(msg))
    if topic == topics.ASSISTANCE_TWIST:
        return replace(state, assistance_twist=_twist(msg))
    if topic == topics.ASSISTANCE_ALPHA:
        alpha = float(msg.data)
        if not np.isfinite(alpha):
            raise GraspIntentError(f'{topics.ASSISTANCE_ALPHA} must be finite, got {alpha}')
        return replace(state, alpha=alpha)
    return state


@dataclass(frozen=True)
class ObjectsState:
    """What the viewer shows of a scene of several objects: the arm once, each object's planning chain.

    Attributes
    ----------
    namespace : str
        The suite's namespace ('' for the root, else absolute, e.g. ``/robot1``): the arm's; object ``name``'s
        chain is in ``<namespace>/<name>`` (:meth:`chain_namespace`).
    arm : SceneState
        Of :data:`ARM_TOPICS` only: the live arm, the operator's and the blended twists, alpha.
    chains : mapping of str to SceneState
        Per object name, in the scene's order: each of its chain's :data:`CHAIN_TOPICS` and its planner's status.
    object_probabilities : mapping of str to float
        P(o) of the newest ``intent/objects``, for the objects it names (empty before one arrives).
    followed : str
        The object whose grasp the assistance follows (the newest ``assistance/object``; '' before one).
    """

    namespace: str
    arm: SceneState
    chains: Mapping[str, SceneState]
    object_probabilities: Mapping[str, float] = field(default_factory=dict)
    followed: str = ''

    @classmethod
    def empty(cls, names: Sequence[str], namespace: str = '') -> ObjectsState:
        """Nothing received yet, for the objects ``names`` (in this order) of the scene at ``namespace``."""
        return cls(namespace, SceneState(), {name: SceneState() for name in names})

    def chain_namespace(self, name: str) -> str:
        """The namespace of object ``name``'s chain."""
        return f'{self.namespace}/{name}'

    def with_chain(self, name: str, change: Callable[[SceneState], SceneState]) -> ObjectsState:
        """This state with object ``name``'s chain replaced by ``change(its state)``. KeyError for another name."""
        return replace(self, chains={**self.chains, name: change(self.chains[name])})


def apply_objects(state: ObjectsState, chain: str | None, topic: str, msg: Any) -> ObjectsState:
    """The scene after ``msg`` on ``topic`` of object ``chain``'s chain (None: the arm's, or ``/diagnostics``).

    ``topic`` is relative to the chain (one of :data:`CHAIN_TOPICS`) or, with ``chain`` None, one of
    :data:`ARM_TOPICS`, :data:`SCENE_TOPICS` or ``/diagnostics``, which updates each chain's planner status from its
    own planner (:func:`apply` with the chain's namespace). Another topic, or a ``/diagnostics`` without a chain's
    planner status, returns ``state`` itself; an unknown ``chain`` raises KeyError.

    Raises
    ------
    GraspIntentError
        For a message that cannot be read (as :func:`apply`; an ``intent/objects`` that is not one value in
        [0, 1] per label, or that names an object not in the scene; an ``assistance/object`` that names none of
        the scene's); ``state`` is then still the valid one, every chain as it was.
    """
    if chain is not None:
        return state.with_chain(chain, lambda s: apply(s, topic, msg)) if topic in CHAIN_TOPICS else state
    if topic == topics.INTENT_OBJECTS:
        return replace(state, object_probabilities=read_object_probabilities(msg, tuple(state.chains)))
    if topic == topics.ASSISTANCE_OBJECT:
        if (name := str(msg.data)) not in state.chains:
            raise GraspIntentError(f'{name!r} is not one of the objects {list(state.chains)}')
        return replace(state, followed=name)
    if topic == topics.DIAGNOSTICS:
        chains = {name: apply(s, topic, msg, namespace=state.chain_namespace(name)) for name, s in state.chains.items()}
        return state if all(chains[name] is s for name, s in state.chains.items()) else replace(state, chains=chains)
    return replace(state, arm=apply(state.arm, topic, msg)) if topic in ARM_TOPICS else state


def apply_to(state: SceneState | ObjectsState, chain: str | None, topic: str, msg: Any) -> SceneState | ObjectsState:
    """The state after ``msg`` on ``topic`` of ``chain``, one of the :func:`followed_topics`.

    :func:`apply_objects` for a scene of several objects, :func:`apply` for one chain (``chain`` is then None);
    raises as they do.
    """
    if isinstance(state, ObjectsState):
        return apply_objects(state, chain, topic, msg)
    return apply(state, topic, msg)

