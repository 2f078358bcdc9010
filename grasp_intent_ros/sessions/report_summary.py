"""The session report's ``summary.md``: one chain's (or the session's), and a scene's list of its chains.

What each line counts: :mod:`grasp_intent_ros.sessions.report` (the figures it lists) and
:mod:`grasp_intent_ros.sessions.report_data` (what was read from the bag).
"""

from __future__ import annotations

import statistics
from collections import Counter
from pathlib import Path

from .report_data import ReportData

__all__ = ['write_summary', 'write_scene_summary']


def write_summary(session: ReportData, out: Path, figures: list[str], skipped: list[str]) -> None:
    """``out/summary.md`` of ``session`` (one chain's, with :attr:`ReportData.chain`: its topics alone).

    Messages per topic, intents, plans, clarifications, rejections, planning times, models, malformed messages,
    the ``figures`` written and the reasons ``skipped`` for those that were not, and the reader's notes.
    """
    duration = session.seconds(session.end_ns) if session.end_ns else 0.0
    topics = {topic: info for topic, info in session.topics.items()
              if session.chain is None or topic.startswith(f'{session.chain}/') or topic in session.roles.values()}
    total = sum(info.count for info in topics.values())
    title = session.path.name if session.chain is None else f'{session.path.name}, chain {session.chain}'
    lines = [f'# Session report: {title}', '',
             f'- bag: `{session.path}`',
             f'- duration: {duration:.1f} s, {total} messages on {len(topics)} topics', '',
             '## Messages per topic', '', '| topic | type | messages |', '|---|---|---:|']
    lines += [f'| {topic} | {info.msgtype} | {info.count} |' for topic, info in sorted(topics.items())]
    per_node = Counter(r.status for _, r in session.rejections)
    reasons = list(dict.fromkeys(r.reason or f'(level {r.level}, no reason given)' for _, r in session.rejections))
    times = session.planning_ms
    plans = len(session.features) or (session.topics[session.roles['posterior']].count
                                       if 'posterior' in session.roles else 0)
    lines += ['', '## Session', '',
              f'- intent messages (w): {len(session.w)}; target vectors (v): {len(session.v)}',
              f'- plans: {plans}',
              f'- clarifications: {len(session.clarifications)}']
    lines += [f'  - {session.seconds(t):.1f} s: {reason}' for t, reason in session.clarifications[:10]]
    lines.append(f'- rejections (from /diagnostics): {len(session.rejections)}')
    lines += [f'  - {name}: {n}' for name, n in sorted(per_node.items())]
    lines += [f'  - reason: {reason}' for reason in reasons[:10]]
    if times:
        lines.append(f'- planning time: {len(times)} plans reported, mean {statistics.fmean(times):.1f} ms, '
                     f'median {statistics.median(times):.1f} ms, max {max(times):.1f} ms')
    else:
        lines.append("- planning time: not in this bag (no planner status with 'last planning time [ms]')")
    if session.models:
        lines.append('- models: ' + ', '.join(f'{name} at {session.seconds(t):.1f} s ({len(m.zones)} zones)'
                                               for t, name, m in session.models))
    if session.malformed:
        lines.append('- malformed messages skipped: ' + ', '.join(
            f'{topic} {n}' for topic, n in sorted(session.malformed.items())))
    lines += ['', '## Figures', '']
    lines += [f'- [{name}]({name})' for name in figures] or ['- none']
    lines += [f'- skipped: {reason}' for reason in skipped]
    if session.notes:
        lines += ['', '## Notes', ''] + [f'- {note}' for note in session.notes]
    (out / 'summary.md').write_text('\n'.join(lines) + '\n')


def write_scene_summary(bag: Path, namespace: str, chains: dict[str, tuple[list[str], list[str]]], out: Path) -> None:
    """``out/summary.md`` of a scene: each chain (namespace -> its figures and skipped figures) linked to its report.

    Each chain's report is in ``out/<object>/`` (the chain namespace's last name); ``namespace`` is the arm's.
    """
    lines = [f'# Session report: {bag.name}', '', f'- bag: `{bag}`',
             f'- a scene of {len(chains)} objects, the arm\'s joint states in {namespace or "/"}: one report per chain',
             '', '## Chains', '']
    for chain, (figures, skipped) in chains.items():
        name = chain.rpartition('/')[2]
        lines.append(f'- [{chain}]({name}/summary.md): {len(figures)} figures'
                     + (f', {len(skipped)} skipped' if skipped else ''))
    (out / 'summary.md').write_text('\n'.join(lines) + '\n')
