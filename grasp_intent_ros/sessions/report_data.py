"""A session bag loaded for the report: what each topic of the suite says, by role (ROS-free).

Topics are found in the session's namespace (:func:`~grasp_intent_ros.sessions.pairing.detect_namespace`), so
namespaced sessions work; or in one chain's namespace of a scene of several objects (``chain``, e.g. ``/cup``:
its topics, and of ``/diagnostics`` only its own nodes' statuses). A message that cannot be read is counted as
malformed, never raised.

Message layouts read (as the nodes publish them)
------------------------------------------------
``intent/v``        1-D, ``dim[0].label`` = comma-joined zone labels ("U,T,H,UT,UH,TH,UTH").
``grasp/posterior`` shape (1, K + m), the stamp axis then "<zones>|<tasks>": P over the model's K zones,
                    then the reconstructed w (:func:`grasp_intent_ros.wire.arrays.read_posterior`).
``grasp/features``  shape (1, d), the same stamp axis, dim[1] labelled with the feature names
                    (:data:`~grasp_intent_ros.method.features.MICO_3F`); 1-D or unlabelled: by position.
``model/active``    std_msgs/String, the model document (header lines, then GraspModel YAML).
``model/ambiguity`` 2-D (m, m) KL matrix, both dims labelled with the task names.
``grasp/pose``, ``grasp/joint_targets``: with ``grasp/features`` and ``grasp/posterior``, gathered by their
                    stamp into :attr:`ReportData.plans` (one record per plan: ``base_T_ee``, ``q`` (arm then
                    finger positions), ``x``, ``posterior``, and ``received``: the last receive time).
``operator/twist``, ``assistance/twist`` (geometry_msgs/TwistStamped), ``assistance/alpha`` (std_msgs/Float64):
                    the shared-control loop, as (linear x, y, z, angular x, y, z) and alpha.
``/diagnostics``    rejections: :class:`grasp_intent_ros.sessions.outputs.RejectionTracker`; planning time: the
                    planner's 'last planning time [ms]' whenever its 'plans' count grew.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GraspIntentError
from ..method.intent import default_task_names
from ..method.model import GraspModel
from ..mico.kinematics import ARM_JOINTS, BASE_FRAME, FINGER_JOINTS
from ..wire import topics
from ..wire.arrays import Posterior, Stamp, msg_labels, msg_to_array, read_features, read_posterior
from ..wire.diagnostics import KEY_PLANNING_TIME, KEY_PLANS, status_values
from ..wire.model_document import read_model_document
from ..wire.robot_state import joint_positions, pose_msg_to_matrix
from .bag import BagError, TopicInfo, read_messages, topics_info
from .outputs import Rejection, RejectionTracker, SessionError, status_namespace
from .pairing import detect_namespace

__all__ = ['ROLES', 'ReportData', 'load_report_data']

ROLES = {'w': topics.INTENT_W, 'v': topics.INTENT_V, 'clarification': topics.INTENT_CLARIFICATION,
         'model': topics.MODEL_ACTIVE, 'ambiguity': topics.MODEL_AMBIGUITY, 'posterior': topics.GRASP_POSTERIOR,
         'features': topics.GRASP_FEATURES, 'diagnostics': topics.DIAGNOSTICS, 'pose': topics.GRASP_POSE,
         'joint_targets': topics.GRASP_JOINT_TARGETS,
         'operator': topics.OPERATOR_TWIST, 'blended': topics.ASSISTANCE_TWIST, 'alpha': topics.ASSISTANCE_ALPHA}
"""Topics the report reads, by role."""


@dataclass
class ReportData:
    """What the report needs from one bag; times are ns since the epoch (receive time)."""

    path: Path
    topics: dict[str, TopicInfo]
    roles: dict[str, str]  # role -> topic name found in the bag
    chain: str | None = None  # a scene's chain the report is of (its namespace), None: the session's one
    start_ns: int = 0
    end_ns: int = 0
    w: list[tuple[int, NDArray[np.float64]]] = field(default_factory=list)
    v: list[tuple[int, NDArray[np.float64], tuple[str, ...]]] = field(default_factory=list)
    clarifications: list[tuple[int, str]] = field(default_factory=list)
    posteriors: list[tuple[int, Posterior[Stamp | None]]] = field(default_factory=list)
    features: list[tuple[int, NDArray[np.float64]]] = field(default_factory=list)
    plans: dict[Stamp, dict[str, Any]] = field(default_factory=dict)
    models: list[tuple[int, str, GraspModel]] = field(default_factory=list)
    kl: list[tuple[int, str, tuple[str, ...], NDArray[np.float64]]] = field(default_factory=list)
    rejections: list[tuple[int, Rejection]] = field(default_factory=list)
    planning_ms: list[float] = field(default_factory=list)
    twists: dict[str, list[tuple[int, NDArray[np.float64]]]] = field(
        default_factory=lambda: {'operator': [], 'blended': []})
    alpha: list[tuple[int, float]] = field(default_factory=list)
    tracker: RejectionTracker = field(default_factory=RejectionTracker)
    plan_counts: dict[str, str] = field(default_factory=dict)  # status name -> last 'plans' value
    malformed: Counter[str] = field(default_factory=Counter)
    notes: list[str] = field(default_factory=list)

    def seconds(self, stamp_ns: int) -> float:
        """Session time (s) of a receive time."""
        return (stamp_ns - self.start_ns) * 1e-9

    def task_names(self, m: int) -> tuple[str, ...]:
        """Names of m tasks: from a posterior's w labels, else the last model, else the defaults."""
        for _, post in self.posteriors:
            if len(post.task_names) == m:
                return post.task_names
        for _, _, model in reversed(self.models):
            if len(model.task_names) == m:
                return model.task_names
        return default_task_names(m)


def _find_topics(topics: dict[str, TopicInfo], chain: str | None) -> tuple[dict[str, str], list[str]]:
    """Role -> topic name in ``chain``, or else the session's namespace (:func:`~.pairing.detect_namespace`)."""
    notes = []
    if chain is not None:
        namespace = chain
    else:
        try:
            namespace = detect_namespace(topics)
        except SessionError as exc:
            namespace = ''
            notes.append(f'session namespace not detected ({exc}); the root namespace is reported')
    roles = {}
    for role, relative in ROLES.items():
        name = relative if relative.startswith('/') else f'{namespace}/{relative}'
        if name in topics:
            roles[role] = name
    return roles, notes


def load_report_data(path: Path, *, chain: str | None = None) -> ReportData:
    """Read the messages the report uses: the session's, or with ``chain`` (a namespace) that chain's of a scene.

    Raises
    ------
    BagError
        The bag is missing or cannot be read.
    """
    topics = topics_info(path)
    roles, notes = _find_topics(topics, chain)
    session = ReportData(path=path, topics=topics, roles=roles, chain=chain, notes=notes,
                         tracker=RejectionTracker(nodes_in=chain))
    by_topic = {topic: role for role, topic in roles.items()}
    first = None
    last = 0
    for message in read_messages(path):
        first = message.timestamp_ns if first is None else first
        last = message.timestamp_ns
        role = by_topic.get(message.topic)
        if role is None:
            continue
        try:
            _take(session, role, message.timestamp_ns, message.decode())
        except (GraspIntentError, BagError, ValueError, IndexError, AttributeError):
            session.malformed[message.topic] += 1
    session.start_ns, session.end_ns = first or 0, last
    return session


def _take(session: ReportData, role: str, stamp: int, msg: Any) -> None:
    """File one decoded message; raises for a malformed one."""
    if role == 'w':
        session.w.append((stamp, msg_to_array(msg, what='w')))
    elif role == 'v':
        labels = msg_labels(msg)
        values = msg_to_array(msg, what='v')
        zones = labels[0] if labels and len(labels[0]) == values.size else ()
        session.v.append((stamp, values, zones))
    elif role == 'clarification':
        session.clarifications.append((stamp, str(msg.data)))
    elif role == 'posterior':
        post = read_posterior(msg)
        session.posteriors.append((stamp, post))
        _plan_part(session, post.stamp, stamp, 'posterior', post)
    elif role == 'features':
        x, plan = read_features(msg)
        session.features.append((stamp, x))
        _plan_part(session, plan, stamp, 'x', x)
    elif role == 'pose':
        _plan_part(session, _header_stamp(msg), stamp, 'base_T_ee', pose_msg_to_matrix(msg, frame_id=BASE_FRAME))
    elif role == 'joint_targets':
        q = joint_positions(msg, (*ARM_JOINTS, *FINGER_JOINTS))
        if q is None:
            raise GraspIntentError('grasp/joint_targets lacks a joint of the MICO')
        _plan_part(session, _header_stamp(msg), stamp, 'q', q)
    elif role == 'model':
        try:
            doc = read_model_document(msg.data)
            name, model = f'{doc.name} (version {doc.version})', doc.model
        except GraspIntentError:  # no (or another) header: the YAML alone
            model = GraspModel.from_yaml(msg.data)
            name = model.name or 'model'
        if not session.models or session.models[-1][2].to_yaml() != model.to_yaml():
            session.models.append((stamp, name, model))
    elif role == 'ambiguity':
        kl = msg_to_array(msg, ndim=2, what='model/ambiguity')
        labels = msg_labels(msg)
        tasks = labels[0] if labels and len(labels[0]) == kl.shape[0] else default_task_names(kl.shape[0])
        if not session.kl or not np.array_equal(session.kl[-1][3], kl):
            session.kl.append((stamp, f'model/ambiguity #{len(session.kl) + 1}', tuple(tasks), kl))
    elif role in ('operator', 'blended'):
        t = msg.twist
        session.twists[role].append((stamp, np.array([t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y,
                                                      t.angular.z], dtype=np.float64)))
    elif role == 'alpha':
        session.alpha.append((stamp, float(msg.data)))
    elif role == 'diagnostics':
        session.rejections.extend((stamp, r) for r in session.tracker.update(msg))
        for status in msg.status:
            if session.chain is None or status_namespace(str(status.name)) == session.chain:
                _sample_planning_time(session, status)


def _header_stamp(msg: Any) -> Stamp:
    return Stamp(int(msg.header.stamp.sec), int(msg.header.stamp.nanosec))


def _plan_part(session: ReportData, plan: Stamp | None, received: int, part: str, value: Any) -> None:
    """File one output of the plan stamped ``plan`` (outputs without a stamp belong to no plan)."""
    if plan is not None:
        record = session.plans.setdefault(plan, {})
        record[part] = value
        record['received'] = max(received, record.get('received', received))


def _sample_planning_time(session: ReportData, status: Any) -> None:
    """Record the planner's 'last planning time [ms]' each time a status shows a new 'plans' count."""
    values = status_values(status)
    plans, value = values.get(KEY_PLANS), values.get(KEY_PLANNING_TIME)
    if plans is None or not value or session.plan_counts.get(status.name) == plans:
        return
    session.plan_counts[status.name] = plans
    try:
        session.planning_ms.append(float(value))
    except ValueError:
        pass
