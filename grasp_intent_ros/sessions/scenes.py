"""Sessions of several objects: one planning chain per object, the arm's ``joint_states`` above them (ROS-free).

``suite --object cup=... --object flashlight=...`` (docs/several_objects.md) runs one chain per object in
``<namespace>/<object>`` and the arm's ``joint_states`` in ``<namespace>``, read by every chain. A bag of such
a session is a *scene* (:func:`detect_scene`); each chain is paired by its namespace as a one-chain session is
(:class:`~.pairing.ChainPairing`: its own inputs and the arm's joint states, its outputs, the rejections of its
own nodes), and the inputs of all chains are put in their receive order once each (:class:`SceneInput`: the
arm's joint state is a step of every chain), which is how a replay sends them (:func:`load_paired_scene`). A
one-chain session is a scene of one chain, paired as :func:`~.pairing.load_paired_session` pairs it.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from ..wire.topics import INPUT_TOPICS, JOINT_STATES
from .bag.reader import read_messages, topics_info
from .outputs import SessionError
from .pairing import ChainPairing, PairedSession, Step, send_order, session_topics

__all__ = ['Scene', 'detect_scene', 'SceneInput', 'PairedScene', 'load_paired_scene']


@dataclass(frozen=True)
class Scene:
    """Where a session's planning chains are (the module docstring).

    Attributes
    ----------
    namespace
        The suite's namespace ('' for the root), where the arm's ``joint_states`` is.
    chains
        Each chain's namespace, sorted: ``(namespace,)`` for a one-chain session, else ``<namespace>/<object>``.
    """

    namespace: str
    chains: tuple[str, ...]

    @property
    def one_chain(self) -> bool:
        """Whether this is a one-chain session (every session topic in :attr:`namespace`)."""
        return self.chains == (self.namespace,)


def detect_scene(topics: Iterable[str]) -> Scene:
    """The chains of the session topics among ``topics``: one namespace, or a scene of several objects.

    Session topics in one namespace are a one-chain session there (as :func:`~.pairing.detect_namespace`). In several,
    they are a scene when exactly one namespace holds ``joint_states`` (the arm's), and no other session topic,
    and every other one is a namespace directly below it (a chain: ``/cup`` below the root).

    Raises
    ------
    SessionError
        No session topic; several namespaces and not one ``joint_states`` among them (no arm, or one per
        namespace: several robots); or a scene with topics that belong to no chain, naming them.
    """
    found = session_topics(topics)
    if len(found) == 1:
        namespace = next(iter(found))
        return Scene(namespace, (namespace,))
    arms = [ns for ns, names in found.items() if f'{ns}/{JOINT_STATES}' in names]
    if len(arms) != 1:
        raise SessionError(
            f'session topics in several namespaces {sorted(found)}, {len(arms)} of them with {JOINT_STATES}: neither '
            f'one chain nor a scene (one chain per object in <namespace>/<object>, all reading the arm\'s '
            f'<namespace>/{JOINT_STATES}: docs/several_objects.md)')
    arm = arms[0]
    chains = tuple(sorted(ns for ns in found if ns != arm))
    stray = [t for t in found[arm] if t != f'{arm}/{JOINT_STATES}']
    stray += [t for ns in chains if ns.rpartition('/')[0] != arm for t in found[ns]]
    if stray:
        raise SessionError(
            f'topics that belong to no chain of the scene in {arm or "/"} (a chain is a namespace directly below '
            f'it, reading the arm\'s {arm}/{JOINT_STATES}): {", ".join(stray)}')
    return Scene(arm, chains)


@dataclass(frozen=True)
class SceneInput:
    """One input of a scene, as a replay sends it: once, opening a step in each chain it feeds.

    Attributes
    ----------
    index
        Input number in the scene, 1-based, in receive order.
    steps
        (index into :attr:`PairedScene.chains`, the step it opens there): one chain for a chain's own input,
        every chain for the arm's ``joint_states``.
    """

    index: int
    steps: tuple[tuple[int, Step], ...]


@dataclass(frozen=True)
class PairedScene:
    """A session bag's chains, each paired by its namespace, and their inputs in receive order.

    Attributes
    ----------
    path
        The bag directory.
    scene
        Where the chains are.
    chains
        One :class:`PairedSession` per chain of :attr:`scene` (in its order); for a one-chain session the
        session as :func:`load_paired_session` reads it.
    inputs
        Every chain's inputs once each, in receive order.
    """

    path: Path
    scene: Scene
    chains: tuple[PairedSession, ...]
    inputs: tuple[SceneInput, ...]

    @property
    def n_outputs(self) -> int:
        """Number of outputs paired with an input, over every chain."""
        return sum(chain.n_outputs for chain in self.chains)


def load_paired_scene(path: str | os.PathLike[str]) -> PairedScene:
    """Read a session bag of one chain or of a scene (:func:`detect_scene`) and pair each chain by its namespace.

    Raises
    ------
    BagReadError
        The bag cannot be read.
    SessionError
        As :func:`detect_scene`; the bag holds no inputs; a model document is malformed.
    """
    bag = Path(path)
    scene = detect_scene(topics_info(bag))
    arm = None if scene.one_chain else scene.namespace
    pairings = [ChainPairing(chain, arm) for chain in scene.chains]
    opened: list[tuple[tuple[int, Step], ...]] = []
    for msg in send_order(read_messages(bag)):
        fed = tuple((i, step) for i, pairing in enumerate(pairings) if (step := pairing.take(msg)) is not None)
        if fed:
            opened.append(fed)
    chains = []
    for namespace, pairing in zip(scene.chains, pairings):
        initial, steps, unpaired = pairing.finish()
        chains.append(PairedSession(bag, namespace, initial, steps, unpaired, arm))
    if not opened:
        raise SessionError(f'bag {bag} holds no inputs ({", ".join(INPUT_TOPICS)} or model switches)')
    closed = [{step.index: step for step in chain.steps} for chain in chains]  # the steps with their outputs
    inputs = tuple(SceneInput(k, tuple((i, closed[i][step.index]) for i, step in fed))
                   for k, fed in enumerate(opened, start=1))
    return PairedScene(bag, scene, tuple(chains), inputs)
