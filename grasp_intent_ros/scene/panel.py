"""The viewer's side panel as HTML: intent w, target v and posterior P as labelled bars, and the plan's status.

:func:`panel_html` is a pure function of a :class:`~grasp_intent_ros.scene.state.SceneState` (or, for several
objects, of an :class:`~grasp_intent_ros.scene.state.ObjectsState`: the same per object, under its name); every number
it shows is also text (``0.62``), so the page can be checked by its text. Zones are rows labelled with the
model's zone labels (``UT``); tasks with the model's task names.
"""

from __future__ import annotations

import html
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from .state import ObjectsState, SceneState

__all__ = ['panel_html']

_V_COLOUR, _P_COLOUR, _W_COLOUR = '#4c78a8', '#e45756', '#54a24b'


def _bar(value: float | None, colour: str) -> str:
    """A horizontal bar of ``value`` in 0..1 with its value as text ('–' when unknown)."""
    if value is None:
        return '<td class="gv">–</td><td></td>'
    width = 100.0 * min(max(value, 0.0), 1.0)
    return (f'<td class="gv">{value:.2f}</td><td style="width:90px"><div style="background:{colour};'
            f'height:9px;width:{width:.0f}%"></div></td>')


def _table(title: str, labels: Sequence[str], columns: Sequence[tuple[str, NDArray[np.float64] | None, str]]
           ) -> str:
    head = ''.join(f'<th colspan="2">{html.escape(name)}</th>' for name, _, _ in columns)
    rows = []
    for i, label in enumerate(labels):
        cells = ''.join(_bar(None if values is None or i >= values.size else float(values[i]), colour)
                        for _, values, colour in columns)
        rows.append(f'<tr><td class="gl">{html.escape(label)}</td>{cells}</tr>')
    return (f'<div class="gt">{html.escape(title)}</div><table class="gb"><tr><th></th>{head}</tr>'
            f'{"".join(rows)}</table>')


def _twist(name: str, twist: NDArray[np.float64] | None) -> str:
    if twist is None:
        return ''
    lin, ang = twist[:3], twist[3:]
    return (f'<div>{html.escape(name)}: v = ({", ".join(f"{c:+.3f}" for c in lin)}) m/s, '
            f'ω = ({", ".join(f"{c:+.2f}" for c in ang)}) rad/s</div>')


_STYLE = ('<style>.gb{border-collapse:collapse;font-size:12px;margin-bottom:6px}.gb td,.gb th{padding:1px 4px}'
          '.gl{font-weight:600}.gv{text-align:right;font-family:monospace}.gt{font-weight:600;margin-top:4px}'
          '.gs{font-size:12px}.go{font-weight:600;margin-top:8px;border-top:1px solid #ccc}</style>')


def _chain_parts(state: SceneState) -> list[str]:
    """A chain's model, v and P per zone, w and w(P) per task, the tasks served, the plan's status, clarification."""
    parts = []
    model = state.model
    if model is not None:
        parts.append(f'<div>model <b>{html.escape(model.name)}</b> (version {model.version})</div>')
    post = state.posterior
    zones = post.zone_labels if post is not None else model.model.zone_labels if model is not None else ()
    tasks = post.task_names if post is not None else model.model.task_names if model is not None else ()
    v = state.v if state.v is not None and (not state.v_labels or state.v_labels == zones) else None
    if zones:
        parts.append(_table('zones: target v and grasp P(zone | x)', zones,
                            [('v', v, _V_COLOUR), ('P', None if post is None else post.p, _P_COLOUR)]))
    if tasks:
        w_in = state.w if state.w is not None and state.w.size == len(tasks) else None
        parts.append(_table('tasks: intent w and w from P', tasks,
                            [('w', w_in, _W_COLOUR), ('w(P)', None if post is None else post.w, _P_COLOUR)]))
    served = state.served
    if served is not None:
        text = ', '.join(served) if served else 'none'
        parts.append(f'<div>grasp serves (rules of the object): <b>{html.escape(text)}</b></div>')
    elif state.x is not None:
        parts.append('<div>grasp serves: not known (no rules for this model\'s object)</div>')
    if state.plan_status:
        parts.append(f'<div>plan: {html.escape(state.plan_status)}</div>')
    if state.clarification:
        parts.append(f'<div style="color:#b35806">clarification: {html.escape(state.clarification)}</div>')
    return parts


def _arm_parts(state: SceneState) -> list[str]:
    """The operator's and the blended twists and alpha."""
    parts = [t for t in (_twist('operator', state.operator_twist), _twist('assisted', state.assistance_twist)) if t]
    if state.alpha is not None:
        parts.append(f'<div>assistance α = {state.alpha:.2f}</div>')
    return parts


def panel_html(state: SceneState | ObjectsState, *, time_text: str = '') -> str:
    """The panel for ``state``; ``time_text`` (e.g. a playback's session time) is shown first.

    For a scene of several objects, each object in the scene's order under its name, then the arm's part.
    """
    parts = [_STYLE, '<div class="gs">']
    if time_text:
        parts.append(f'<div><b>{html.escape(time_text)}</b></div>')
    if isinstance(state, ObjectsState):
        arm, planned = state.arm, False  # no planned arm is drawn (docs/viewer.md)
        chains = {name: _chain_parts(chain) for name, chain in state.chains.items()}
        for name, chain_parts in chains.items() if any(chains.values()) else ():  # else the suite is waited for
            where = html.escape(state.chain_namespace(name))
            p_o = state.object_probabilities.get(name)
            wanted = '' if p_o is None else f', P(o) = {p_o:.2f}'
            followed = ' ◀ the assistance follows it' if name == state.followed else ''
            parts.append(f'<div class="go">object <b>{html.escape(name)}</b> ({where}{wanted}){followed}</div>')
            parts += chain_parts or ['<div>no model, intent or plan yet</div>']
    else:
        arm, planned = state, state.q_target is not None
        parts += _chain_parts(state)
    parts += _arm_parts(arm)
    if arm.q_live is None and len(parts) > 2:
        ghost = ' (the green ghost is the plan)' if planned else ''
        parts.append(f'<div>live arm: no joint_states yet{ghost}</div>')
    if len(parts) == 2:
        parts.append('<div>waiting for the suite: no model, intent or plan yet</div>')
    parts.append('</div>')
    return ''.join(parts)
