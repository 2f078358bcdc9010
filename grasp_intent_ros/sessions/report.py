"""Session report: PNG figures and a markdown summary of a recorded session bag.

Run: ``python -m grasp_intent_ros report BAG --out DIR``

Reads the bag with :mod:`grasp_intent_ros.sessions.bag` (no rclpy, matplotlib's Agg renderer) and writes to DIR:

``intent_cases[_k].png``
    Per intent message, the target v over all zones (``intent/v``) next to the posterior P(zone | x) of
    the grasp planned for it (``grasp/posterior``): the paper's Tables II/IV as bars, one subplot per case.
``w_over_time.png``
    Input w (``intent/w``) and the w reconstructed from each planned grasp's posterior, per task, over
    the session time (s).
``kl_matrices.png``
    KL(task i || task j) of every model activated during the session (``model/active``, else
    ``model/ambiguity``), as annotated heat maps.
``grasps_3d.png``
    Each planned grasp (``grasp/features``, object frame): palm centre, approach arrow, the three fingers
    closed as planned, next to the object drawn as a cylinder.
``grasp_scene_<k>.png``
    Each planned grasp (plan k of the session; at most :data:`MAX_GRASPS`, spread over the session) in the
    scene the viewer shows: the arm at ``grasp/joint_targets``, the active model's body at the object pose
    the plan implies, the grasp frame and fingers, the top zone and the tasks the grasp serves by the
    object's rules.
``shared_control.png`` (a session with any of its topics)
    The shared-control loop: speeds (linear, angular) of the operator's twist (``operator/twist``) and the
    blended twist (``assistance/twist``), and the arbitration weight alpha (``assistance/alpha``), over the
    session time (s).
``summary.md``
    Messages per topic, plans, clarifications, rejections (from ``/diagnostics``), planning time, the
    figures written and those skipped for lack of data.

Topics are found in the session's namespace (``/robot1/intent/v`` is ``intent/v``), so namespaced sessions work.
A scene of several objects (a bag :func:`~grasp_intent_ros.sessions.scenes.detect_scene` reads as one, recorded
beside ``suite --object ...``) gets one such report per chain, in ``DIR/<object>/`` (its topics, its nodes'
rejections and planning times), and a ``summary.md`` in DIR listing the chains.
Exit code 2 with a one-line message when the bag is missing or unreadable.

What is read from the bag: :mod:`grasp_intent_ros.sessions.report_data`; the summaries:
:mod:`grasp_intent_ros.sessions.report_summary`. One module: one short function per figure above.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from numpy.typing import NDArray

from ..method import ambiguity
from ..method.features import FINGER_CLOSED, FINGERS, ROLL
from ..method.intent import zone_label
from ..method.model import GraspModel
from ..mico.frames import features_to_obj_T_ee, finger_segments
from ..scene.geometry import ArmModel, Shape, body_shapes
from ..scene.plan import plan_object_pose, served_tasks
from ..wire.arrays import Posterior, Stamp
from .bag import BagError, topics_info
from .outputs import SessionError
from .report_data import ReportData, load_report_data
from .report_summary import write_scene_summary, write_summary
from .scenes import detect_scene

__all__ = ['write_report', 'main',
           'OBJECT_RADIUS', 'OBJECT_HEIGHT', 'CASES_PER_FIGURE', 'MAX_CASE_FIGURES', 'MAX_GRASPS']

OBJECT_RADIUS = 0.04
"""Radius of the cylinder drawn for the object (m); the bag does not carry the object's shape."""
OBJECT_HEIGHT = 0.10
"""Height of that cylinder (m), standing on the object frame's origin along +z."""
CASES_PER_FIGURE = 12
MAX_CASE_FIGURES = 4
MAX_GRASPS = 12
"""At most this many grasps are drawn in 3-D (spread evenly over the session)."""
_APPROACH_ARROW = 0.06  # m
_WRIST = 0.08  # m, drawn wrist stub behind the palm
_V_COLOR, _P_COLOR = 'tab:blue', 'tab:orange'

def _tasks_legend(tasks: Sequence[str]) -> str:
    return ', '.join(f'{zone_label(1 << i, tasks)} = {t}' for i, t in enumerate(tasks))


def _grid(n: int, cols: int = 3) -> tuple[int, int]:
    cols = min(cols, n)
    return math.ceil(n / cols), cols


def _answer(session: ReportData, stamp: int, until: int | None) -> Posterior[Stamp | None] | None:
    """The first posterior received after ``stamp`` and before ``until``: the plan answering a v."""
    for t, post in session.posteriors:
        if t >= stamp and (until is None or t < until):
            return post
    return None


def _input_w(session: ReportData, stamp: int) -> NDArray[np.float64] | None:
    """The last w received at or before ``stamp``."""
    found = None
    for t, w in session.w:
        if t > stamp:
            break
        found = w
    return found


def plot_intent_cases(session: ReportData, out: Path) -> list[str]:
    """Figures (a); returns the file names written."""
    cases = session.v[:CASES_PER_FIGURE * MAX_CASE_FIGURES]
    if len(session.v) > len(cases):
        session.notes.append(f'intent cases: the first {len(cases)} of {len(session.v)} are drawn')
    written = []
    for start in range(0, len(cases), CASES_PER_FIGURE):
        chunk = cases[start:start + CASES_PER_FIGURE]
        rows, cols = _grid(len(chunk))
        fig = Figure(figsize=(max(10.0, 5.2 * cols), 3.6 * rows + 1.2), layout='constrained')
        m = None
        for i, (stamp, v, zones) in enumerate(chunk):
            index = start + i
            until = session.v[index + 1][0] if index + 1 < len(session.v) else None
            post = _answer(session, stamp, until)
            m = int(round(math.log2(v.size + 1)))
            zones = zones or tuple(str(k + 1) for k in range(v.size))
            ax = fig.add_subplot(rows, cols, i + 1)
            x = np.arange(v.size)
            ax.bar(x - 0.2, v, 0.4, color=_V_COLOR)
            if post is not None:
                p_by_zone = dict(zip(post.zone_labels, post.p))
                p = np.array([p_by_zone.get(z, np.nan) for z in zones])
                ax.bar(x + 0.2, np.nan_to_num(p), 0.4, color=_P_COLOR)
                for k in np.flatnonzero(np.isnan(p)):
                    ax.text(x[k] + 0.2, 0.02, 'not in\nmodel', ha='center', va='bottom', fontsize=6,
                            rotation=90, color='0.4')
            ax.set_xticks(x, zones)
            ax.set_ylim(0.0, 1.05)
            ax.set_xlabel('zone')
            ax.set_ylabel('probability')
            w = _input_w(session, stamp)
            w_text = 'w = (' + ', '.join(f'{val:.2f}' for val in w) + ')' if w is not None else 'w not recorded'
            plan_text = '' if post is not None else ' (no plan recorded)'
            ax.set_title(f'case {index + 1} at {session.seconds(stamp):.1f} s: {w_text}{plan_text}', fontsize=9)
            ax.grid(axis='y', alpha=0.3)
        fig.legend(handles=[Patch(color=_V_COLOR, label='target v (intent/v)'),
                            Patch(color=_P_COLOR,
                                  label='posterior P(zone | x) of the planned grasp (grasp/posterior)')],
                   loc='outside lower center', ncols=2, fontsize=9, frameon=False)
        tasks = session.task_names(m or 1)
        fig.suptitle('Target v from the intent interpreter vs posterior P of the planned grasp, per intent '
                     f'message\nzones: {_tasks_legend(tasks)}', fontsize=11)
        name = 'intent_cases.png' if start == 0 else f'intent_cases_{start // CASES_PER_FIGURE + 1}.png'
        fig.savefig(out / name, dpi=100)
        written.append(name)
    return written


def plot_w_over_time(session: ReportData, out: Path) -> list[str]:
    """Figure (b)."""
    m_values = {w.size for _, w in session.w} | {post.w.size for _, post in session.posteriors}
    m = max(m_values)
    tasks = session.task_names(m)
    fig = Figure(figsize=(12, 4.8), layout='constrained')
    ax = fig.add_subplot()
    colors = [f'C{i}' for i in range(m)]
    for i, task in enumerate(tasks):
        inputs = [(session.seconds(t), w[i]) for t, w in session.w if w.size == m]
        recon = [(session.seconds(t), post.w[i]) for t, post in session.posteriors if post.w.size == m]
        if inputs:
            ax.plot(*zip(*inputs), 'o-', color=colors[i], drawstyle='steps-post', markersize=4,
                    label=f'{task}: input w')
        if recon:
            ax.plot(*zip(*recon), 'x', color=colors[i], markersize=8, markeredgewidth=2,
                    label=f'{task}: reconstructed w (one per plan)')
    for k, (t, _) in enumerate(session.clarifications):
        ax.axvline(session.seconds(t), color='0.5', linestyle=':',
                   label='clarification requested (no plan)' if k == 0 else None)
    ax.set_xlabel('session time (s)')
    ax.set_ylabel('task probability')
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc='upper left', bbox_to_anchor=(1.01, 1.0))
    ax.set_title('Input task probabilities w (intent/w) and w reconstructed from each planned grasp '
                 '(grasp/posterior)', fontsize=10)
    fig.savefig(out / 'w_over_time.png', dpi=100)
    return ['w_over_time.png']


def plot_shared_control(session: ReportData, out: Path) -> list[str]:
    """The shared-control figure: the operator's and the blended twist's speeds, and alpha, over time."""
    fig = Figure(figsize=(12, 5.5), layout='constrained')
    speed, weight = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    for role, color, name in (('operator', 'C0', 'operator (operator/twist)'),
                              ('blended', 'C3', 'blended (assistance/twist)')):
        samples = session.twists[role]
        if samples:
            t = [session.seconds(stamp) for stamp, _ in samples]
            speed.plot(t, [float(np.linalg.norm(x[:3])) for _, x in samples], color=color,
                       label=f'{name}: |linear| m/s')
            speed.plot(t, [float(np.linalg.norm(x[3:])) for _, x in samples], color=color, linestyle=':',
                       label=f'{name}: |angular| rad/s')
    speed.set_ylabel('speed')
    speed.grid(alpha=0.3)
    speed.legend(fontsize=8, loc='upper left', bbox_to_anchor=(1.01, 1.0))
    speed.set_title('Shared control: the operator\'s and the blended twist, and the arbitration weight alpha',
                    fontsize=10)
    if session.alpha:
        weight.plot([session.seconds(stamp) for stamp, _ in session.alpha], [a for _, a in session.alpha], color='C2',
                    drawstyle='steps-post', label='alpha (assistance/alpha)')
    for k, (t, _) in enumerate(session.clarifications):
        weight.axvline(session.seconds(t), color='0.5', linestyle=':',
                       label='clarification requested' if k == 0 else None)
    weight.set_ylim(-0.03, 1.03)
    weight.set_ylabel('alpha')
    weight.set_xlabel('session time (s)')
    weight.grid(alpha=0.3)
    weight.legend(fontsize=8, loc='upper left', bbox_to_anchor=(1.01, 1.0))
    fig.savefig(out / 'shared_control.png', dpi=100)
    return ['shared_control.png']


def plot_kl(session: ReportData, out: Path) -> list[str]:
    """Figure (c): one heat map per distinct model (model/active), else per model/ambiguity matrix."""
    if session.models:
        mats = [(name, f'{len(model.zones)} zones', model.task_names, ambiguity.kl_matrix(model))
                for _, name, model in session.models]
    else:
        mats = [(name, 'from model/ambiguity', tasks, kl) for _, name, tasks, kl in session.kl]
    if len(mats) > 6:
        session.notes.append(f'KL matrices: the first 6 of {len(mats)} models are drawn')
        mats = mats[:6]
    rows, cols = _grid(len(mats))
    fig = Figure(figsize=(max(5.6, 4.8 * cols), 4.2 * rows + 0.8), layout='constrained')
    for i, (name, detail, tasks, kl) in enumerate(mats):
        ax = fig.add_subplot(rows, cols, i + 1)
        image = ax.imshow(kl, cmap='viridis')
        high = float(np.nanmax(kl)) if kl.size else 0.0
        for r in range(kl.shape[0]):
            for c in range(kl.shape[1]):
                ax.text(c, r, f'{kl[r, c]:.2f}', ha='center', va='center', fontsize=9,
                        color='black' if kl[r, c] > 0.6 * high else 'white')
        ax.set_xticks(range(len(tasks)), tasks)
        ax.set_yticks(range(len(tasks)), tasks)
        ax.set_xlabel('task j (compared population)')
        ax.set_ylabel('task i (true population)')
        ax.set_title(f'{name}, {detail}', fontsize=10)
        fig.colorbar(image, ax=ax, shrink=0.8, label='KL(i ‖ j) (nats)')
    fig.suptitle('Task ambiguity of the active model(s):\nKL divergence between principal-task grasp '
                 'distributions', fontsize=11)
    fig.savefig(out / 'kl_matrices.png', dpi=100)
    return ['kl_matrices.png']


def _draw_grasp(ax: Any, x: NDArray[np.float64]) -> None:
    """The object cylinder and the hand of grasp ``x`` (object frame, m).

    Posed by :func:`~grasp_intent_ros.mico.frames.features_to_obj_T_ee`: EE origin at the palm centre, EE z =
    approach, and the fingers of :func:`~grasp_intent_ros.mico.frames.finger_segments` (as the RViz
    markers draw them).
    """
    obj_T_ee = features_to_obj_T_ee(x)
    palm, ee_z = obj_T_ee[:3, 3], obj_T_ee[:3, 2]
    theta, height = np.meshgrid(np.linspace(0, 2 * math.pi, 40), np.array([0.0, OBJECT_HEIGHT]))
    ax.plot_surface(OBJECT_RADIUS * np.cos(theta), OBJECT_RADIUS * np.sin(theta), height, color='0.6',
                    alpha=0.35, linewidth=0)
    ax.scatter(*palm, color='tab:red', s=30, label='palm centre')
    ax.plot(*np.c_[palm - _WRIST * ee_z, palm], color='0.3', linewidth=4, label='wrist')
    ax.quiver(*palm, *(_APPROACH_ARROW * ee_z), color='tab:red', arrow_length_ratio=0.25, label='approach')
    for k, (base_ee, tip_ee) in enumerate(finger_segments(x[FINGERS])):
        base, tip = (obj_T_ee[:3, :3] @ p + palm for p in (base_ee, tip_ee))
        ax.plot(*np.c_[palm, base, tip], color='tab:blue', linewidth=2,
                label='fingers (closed as planned)' if k == 0 else None)
        ax.text(*tip, str(k + 1), fontsize=7, color='tab:blue')


def plot_grasps(session: ReportData, out: Path) -> list[str]:
    """Figure (d)."""
    n = len(session.features)
    picks = np.unique(np.linspace(0, n - 1, min(n, MAX_GRASPS)).round().astype(int))
    if n > len(picks):
        session.notes.append(f'3-D grasps: {len(picks)} of {n} plans are drawn, spread over the session')
    rows, cols = _grid(len(picks))
    # 3-D axes do not take part in constrained layout: margins in inches, set by hand
    width, height = 4.6 * cols, 4.6 * rows + 1.0
    fig = Figure(figsize=(width, height))
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.7 / height, top=1.0 - 1.0 / height, wspace=0.05,
                        hspace=0.25)
    for i, index in enumerate(picks):
        stamp, x = session.features[index]
        ax = fig.add_subplot(rows, cols, i + 1, projection='3d')
        _draw_grasp(ax, x)
        post = _nearest_posterior(session, stamp)
        top = ''
        if post is not None:
            k = int(np.argmax(post.p))
            top = f'\ntop zone {post.zone_labels[k]} (P = {post.p[k]:.2f})'
        fingers = ', '.join(f'{c:.2f}' for c in x[FINGERS])
        ax.set_title(f'plan {index + 1} at {session.seconds(stamp):.1f} s{top}\n'
                     f'roll {x[ROLL]:.2f} rad, fingers {fingers} rad', fontsize=8)
        span = 0.13
        centre = np.array([0.0, 0.0, OBJECT_HEIGHT / 2])
        for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
            setter(c - span, c + span)
        ax.set_box_aspect((1, 1, 1), zoom=0.92)
        ax.set_xlabel('x (m)', fontsize=7)
        ax.set_ylabel('y (m)', fontsize=7)
        ax.set_zlabel('z (m)', fontsize=7)
        ax.tick_params(labelsize=6)
        if i == 0:
            fig.legend(*ax.get_legend_handles_labels(), loc='lower center', ncols=5, fontsize=8,
                       frameon=False)
    fig.suptitle('Planned grasps in the object frame (grasp/features)\nobject drawn as a '
                 f'{100 * OBJECT_RADIUS:.0f} cm radius, {100 * OBJECT_HEIGHT:.0f} cm tall cylinder on the '
                 f'frame origin; finger closure 0 = open, {FINGER_CLOSED} rad = closed', fontsize=10,
                 y=1.0 - 0.1 / height, va='top')
    fig.savefig(out / 'grasps_3d.png', dpi=100)
    return ['grasps_3d.png']


def _draw_shape(ax: Any, shape: Shape, *, alpha: float = 1.0, color: Any = None) -> None:
    """A posed box or cylinder (:class:`~grasp_intent_ros.scene.geometry.Shape`) on 3-D axes."""
    base_T = shape.base_T_shape
    face = color if color is not None else shape.rgba[:3]
    if shape.kind == 'cylinder':
        r, _, length = shape.size
        theta, h = np.meshgrid(np.linspace(0.0, 2.0 * math.pi, 16), np.array([-0.5, 0.5]) * length)
        local = np.stack([r * np.cos(theta), r * np.sin(theta), h])
        pts = np.einsum('ij,jkl->ikl', base_T[:3, :3], local) + base_T[:3, 3, None, None]
        ax.plot_surface(pts[0], pts[1], pts[2], color=face, alpha=alpha, linewidth=0, shade=True)
        return
    half = np.array(shape.size) / 2.0
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    world = corners @ base_T[:3, :3].T + base_T[:3, 3]
    faces = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]]
    ax.add_collection3d(Poly3DCollection([world[f] for f in faces], facecolor=face, alpha=alpha, linewidth=0))


def _scene_model(session: ReportData, received: int) -> tuple[str, GraspModel] | None:
    """The model active when a plan was received (the last one activated before it)."""
    active = [(name, model) for t, name, model in session.models if t <= received]
    return (active[-1][1].name or active[-1][0], active[-1][1]) if active else None


def plot_grasp_scenes(session: ReportData, out: Path) -> list[str]:
    """Figure (e): one image per planned grasp, the scene the viewer shows.

    The arm at the plan's joint targets (the URDF's visual model), the object's body (the active model's) at
    the pose the plan implies (:func:`~grasp_intent_ros.scene.plan.plan_object_pose`), the grasp frame and the
    fingers, titled with the top zone and the tasks the grasp serves by the object's rules.
    """
    plans = [(stamp, r) for stamp, r in session.plans.items() if {'base_T_ee', 'q', 'x'} <= set(r)]
    picks = np.unique(np.linspace(0, len(plans) - 1, min(len(plans), MAX_GRASPS)).round().astype(int))
    if len(plans) > len(picks):
        session.notes.append(f'grasp scenes: {len(picks)} of {len(plans)} plans are drawn, spread over the session')
    arm = ArmModel()
    names = []
    for index in picks:
        stamp, record = plans[index]
        base_T_ee, q, x = record['base_T_ee'], record['q'], record['x']
        fig = Figure(figsize=(6.4, 5.6))
        ax = fig.add_subplot(projection='3d')
        for shape in arm.shapes(q[:6], q[6:]):
            _draw_shape(ax, shape, alpha=0.9)
        base_T_obj = plan_object_pose(base_T_ee, x)
        found = _scene_model(session, record['received'])
        served = None
        if found is not None and found[1].body is not None:
            for shape in body_shapes(found[1].body, base_T_obj):
                _draw_shape(ax, shape, alpha=0.5)
            served = served_tasks(found[1], x)
        for k, axis in enumerate(('tab:red', 'tab:green', 'tab:blue')):
            ax.plot(*np.c_[base_T_ee[:3, 3], base_T_ee[:3, 3] + 0.06 * base_T_ee[:3, k]], color=axis, linewidth=2)
        for base_ee, tip_ee in finger_segments(q[6:]):
            ax.plot(*np.c_[base_T_ee[:3, :3] @ base_ee + base_T_ee[:3, 3], base_T_ee[:3, :3] @ tip_ee
                           + base_T_ee[:3, 3]], color='tab:orange', linewidth=3)
        centre = 0.5 * (base_T_obj[:3, 3] + np.array([0.0, 0.0, 0.3]))
        for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
            setter(c - 0.4, c + 0.4)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=25, azim=-50)
        ax.set_xlabel('x (m)', fontsize=7)
        ax.set_ylabel('y (m)', fontsize=7)
        ax.set_zlabel('z (m)', fontsize=7)
        ax.tick_params(labelsize=6)
        post = record.get('posterior')
        top = ''
        if post is not None:
            k = int(np.argmax(post.p))
            top = f', top zone {post.zone_labels[k]} (P = {post.p[k]:.2f})'
        serves = 'not known (no rules for this model\'s object)' if served is None else ', '.join(served) or 'none'
        model_name = found[0] if found is not None else 'no model/active'
        ax.set_title(f'plan {index + 1} at {session.seconds(record["received"]):.1f} s, {model_name}{top}\n'
                     f'serves (object rules): {serves}\nstamp {stamp.sec}.{stamp.nanosec:09d}', fontsize=9)
        name = f'grasp_scene_{index + 1:02d}.png'
        fig.savefig(out / name, dpi=90)
        names.append(name)
    return names


def _nearest_posterior(session: ReportData, stamp: int,
                       tolerance_ns: int = 1_000_000_000) -> Posterior[Stamp | None] | None:
    best = min(session.posteriors, key=lambda tp: abs(tp[0] - stamp), default=None)
    return best[1] if best is not None and abs(best[0] - stamp) <= tolerance_ns else None


def write_report(bag: Path, out: Path) -> tuple[list[str], list[str]]:
    """Write the figures and summary.md for ``bag`` into ``out`` (created); for a scene, one report per chain.

    Returns
    -------
        (figure file names written, relative to ``out``; reasons for figures skipped, a scene's prefixed with
        the chain's object).

    Raises
    ------
    BagError
        The bag is missing or cannot be read.
    OSError
        ``out`` cannot be created or written.
    """
    try:
        scene = detect_scene(topics_info(bag))
    except SessionError:  # no session's namespace: the one-chain report says so in its notes
        scene = None
    if scene is None or scene.one_chain:
        return _write_chain(bag, out, None)
    figures: list[str] = []
    skipped: list[str] = []
    chains = {}
    for chain in scene.chains:
        name = chain.rpartition('/')[2]
        chains[chain] = _write_chain(bag, out / name, chain)
        figures += [f'{name}/{figure}' for figure in chains[chain][0]]
        skipped += [f'{name}: {reason}' for reason in chains[chain][1]]
    write_scene_summary(bag, scene.namespace, chains, out)
    return figures, skipped


def _write_chain(bag: Path, out: Path, chain: str | None) -> tuple[list[str], list[str]]:
    """:func:`write_report` for the session's one chain (``chain`` None) or a scene's chain (its namespace)."""
    session = load_report_data(bag, chain=chain)
    out.mkdir(parents=True, exist_ok=True)
    figures: list[str] = []
    skipped: list[str] = []
    plots = [
        ('intent cases (v and P bars)', bool(session.v), 'no intent/v messages', plot_intent_cases),
        ('w over time', bool(session.w or session.posteriors), 'no intent/w or grasp/posterior messages',
         plot_w_over_time),
        ('KL heat maps', bool(session.models or session.kl), 'no model/active or model/ambiguity messages',
         plot_kl),
        ('3-D grasps', bool(session.features), 'no grasp/features messages', plot_grasps),
        ('grasp scenes', any({'base_T_ee', 'q', 'x'} <= set(r) for r in session.plans.values()),
         'no plan with grasp/pose, grasp/joint_targets and grasp/features of one stamp', plot_grasp_scenes),
    ]
    if {'operator', 'blended', 'alpha'} & set(session.roles):  # a session of the shared-control loop
        plots.append(('shared control', bool(session.alpha or session.twists['operator'] or session.twists['blended']),
                      'no operator/twist, assistance/twist or assistance/alpha messages', plot_shared_control))
    for title, available, reason, plot in plots:
        if available:
            figures += plot(session, out)
        else:
            skipped.append(f'{title}: {reason}')
    if session.v and not session.posteriors:
        skipped.append('P bars in the intent cases: no grasp/posterior messages')
    write_summary(session, out, figures, skipped)
    return figures, skipped


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code (0, or 2 for a missing/invalid bag or unwritable output)."""
    parser = argparse.ArgumentParser(description='Figures and a markdown summary of a recorded session bag.')
    parser.add_argument('bag', type=Path, help='rosbag2 directory (with metadata.yaml) written by the recorder')
    parser.add_argument('--out', type=Path, required=True, help='output directory (created)')
    options = parser.parse_args(argv)
    if not options.bag.is_dir() or not (options.bag / 'metadata.yaml').is_file():
        print(f'report: error: {options.bag} is not a rosbag2 directory (no metadata.yaml)', file=sys.stderr)
        return 2
    try:
        figures, skipped = write_report(options.bag, options.out)
    except BagError as exc:
        print(f'report: error: invalid bag {options.bag}: {exc}', file=sys.stderr)
        return 2
    except OSError as exc:
        print(f'report: error: cannot write the report to {options.out}: {exc}', file=sys.stderr)
        return 2
    print(f'report: {len(figures)} figures and summary.md in {options.out}'
          + (f' ({len(skipped)} skipped, see summary.md)' if skipped else ''))
    return 0


if __name__ == '__main__':
    sys.exit(main())
