"""Following ``model/active`` without stalling a node: a new model is read off the executor, then swapped in.

Reading a model document (the size check, the hash, the YAML, the model's own checks) takes tens of
milliseconds. In a subscription callback it would hold back every other callback of the node (and, in
the planner, the answers to intent/v). :class:`ModelFollower` only stores the newest document in the
callback; a latest-only thread of its own reads it and hands the complete
:class:`~grasp_intent_ros.wire.model_document.ModelDocument` to the node, which swaps it in with one assignment. Until
then the node keeps serving with the model it has; a document that fails to read changes nothing. Documents
that arrive while one is being read replace each other (only the newest model matters): the diagnostics
count them as ``model documents superseded`` and show the ``last model read time [ms]``.

A valid model the node cannot serve (:func:`served_models`: another robot's features, tasks other than the
node's ``task_names``) is refused by its declaration, before its arrays are parsed or anything is built: the
node keeps the model it has. While it has none because a document was refused, the suite cannot serve an
intent: :attr:`ModelFollower.refused` says why, the node asks for clarification with that reason, and the
diagnostics component is at ERROR. A refusal that leaves the node serving its previous model is a rejected
input (WARN until the next input is processed); the status value :data:`KEY_REFUSED` keeps the reason and the
model still served until a document is accepted. :meth:`ModelFollower.recheck` reads the newest document
again when the requirements change.

A thread of its own is not enough under the GIL. Reading a document allocates some 100,000 objects,
enough to set off a full garbage collection, which in a process with numba, scipy and pinocchio loaded
holds the GIL for a few hundred milliseconds; and a planning thread that releases the GIL in every numpy
and LAPACK call waits up to the switch interval (5 ms by default) to get it back, each time. So while a
document is read the cyclic garbage collector is off (what the reading allocates is freed by reference
counting) and the switch interval is 0.5 ms, which keeps the planner's answers flowing during a read
(docs/measurements.md, "Model switches"). Both are process-wide settings; one lock
serialises the reads of all followers in a process, so each restores what it found.
"""

from __future__ import annotations

import gc
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

from rclpy.node import Node
from std_msgs.msg import String

from ..errors import GraspIntentError
from ..method.features import MICO_3F
from ..method.model import ModelRequirements
from ..wire.diagnostics import ERROR, OK
from ..wire.model_document import ModelDocument, read_model_document
from ..wire.topics import MODEL_ACTIVE
from .diagnostics import NodeDiagnostics
from .inputs import subscribe_input
from .qos import latched_qos
from .run import release_free_memory
from .worker import LatestOnlyWorker

__all__ = ['ModelFollower', 'KEY_REFUSED', 'READ_SWITCH_INTERVAL', 'served_models', 'yielding_reader']

READ_SWITCH_INTERVAL = 5e-4
"""The GIL switch interval while a document is read, s (Python's default: 5e-3)."""

_reading = threading.Lock()

KEY_REFUSED = 'model document refused'
"""Status value: why the newest ``model/active`` document was refused, and the model still served ('' if none was)."""


def served_models(task_names: Sequence[str]) -> ModelRequirements:
    """The models the suite serves: the MICO 3-finger features (the planner maps them to a pose) and ``task_names``.

    One rule for every node, so that the model server publishes, and the interpreter and the planner
    activate, the same models.
    """
    return ModelRequirements(task_names=tuple(task_names), feature_names=MICO_3F.names)


@contextmanager
def yielding_reader() -> Iterator[None]:
    """While in it: no cyclic garbage collection and a GIL switch interval of :data:`READ_SWITCH_INTERVAL`.

    Both are restored on exit. One reader at a time per process (the settings are process-wide).
    """
    with _reading:
        interval, collecting = sys.getswitchinterval(), gc.isenabled()
        gc.disable()
        sys.setswitchinterval(READ_SWITCH_INTERVAL)
        try:
            yield
        finally:
            sys.setswitchinterval(interval)
            if collecting:
                gc.enable()


class ModelFollower:
    """Subscribes to ``model/active`` (latched) and hands each new model to ``use`` from a thread of its own.

    Parameters
    ----------
    node : Node
        Owner of the subscription.
    diagnostics : NodeDiagnostics
        Counts the documents read and rejected (oversized, malformed, or refused by ``use``).
    use : callable
        ``use(document)``, called in the follower's thread with each new document read completely; it
        raises a GraspIntentError to refuse the model (then the node keeps its current one). With
        ``None`` when a document is refused and the node has no model it serves (:attr:`refused` says why).
    requires : callable
        ``requires()``: the node's :class:`~grasp_intent_ros.method.model.ModelRequirements` now (e.g.
        :func:`served_models` of its ``task_names``), read for every document.
    name : str
        Name of the thread.
    namespace : str
        A relative namespace whose ``model/active`` to follow (e.g. ``'cup'``, one object's of a scene that the node
        serves with a follower per object). Then the node's state is the node's own: the follower sets no state,
        its diagnostics values are named ``<namespace>: <key>``, and ``use(None)`` is the node's cue to say that
        the object cannot be served (:attr:`refused` says why).
    """

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, use: Callable[[ModelDocument | None], object], *,
                 requires: Callable[[], ModelRequirements], name: str, namespace: str = '') -> None:
        self._diagnostics, self._use, self._requires = diagnostics, use, requires
        self.topic = f'{namespace}/{MODEL_ACTIVE}' if namespace else MODEL_ACTIVE
        """The topic followed."""
        self._prefix = f'{namespace}: ' if namespace else ''
        self.current: ModelDocument | None = None
        """The last document ``use`` accepted (None after :meth:`recheck` refused it)."""
        self.refused = ''
        """Why the newest document was refused ('' if it was not): while :attr:`current` is None, why the
        node cannot serve."""
        self._worker: LatestOnlyWorker[str | None] = LatestOnlyWorker(
            None, diagnostics.guard(self._read, counts_received=False), ready=lambda text: text is not None,
            name=name)
        node.context.on_shutdown(self._worker.stop_soon)
        # counted and size-checked on arrival (subscribe_input); a document that fails to read is a rejection
        self.subscription = subscribe_input(node, MODEL_ACTIVE, self._on_document, latched_qos(), diagnostics,
                                            namespace=namespace)

    def _on_document(self, msg: String) -> None:
        text = msg.data  # stored as is: the executor thread does no work on a document
        self._worker.update(lambda _: text)

    def recheck(self) -> None:
        """Read the newest document again (in the follower's thread): the node's requirements changed.

        A current model they refuse is dropped (``use(None)``); a refused document they accept is used.
        """
        self._worker.update(lambda text: text)

    def _read(self, text: str | None) -> None:
        assert text is not None  # ready() holds back the initial None
        self._diagnostics.set_value(f'{self._prefix}model documents superseded', self._worker.superseded)
        start = time.perf_counter()
        try:
            with yielding_reader():  # the size first, then the header, the declaration, the arrays
                doc = read_model_document(text, previous=self.current, requires=self._requires())
            self._use(doc)
        except GraspIntentError as exc:
            self._refuse(str(exc))
            if self._prefix:  # one of several: the rejection names the topic
                raise GraspIntentError(self.refused) from None
            raise
        finally:
            self._diagnostics.set_value(f'{self._prefix}last model read time [ms]',
                                        f'{1e3 * (time.perf_counter() - start):.1f}')
        self.current, self.refused = doc, ''
        self._set_state(OK, '')
        self._diagnostics.set_value(f'{self._prefix}{KEY_REFUSED}', '')
        release_free_memory()  # what the reading freed (see release_free_memory)

    def _refuse(self, reason: str) -> None:
        """The newest document is refused: keep the current model while the requirements (maybe changed) serve it."""
        if self.current is not None:
            try:
                self._requires().check(self.current.model.task_names, self.current.model.feature_names)
            except GraspIntentError:
                self.current = None
        self.refused = f'{self.topic}: {reason}'
        if self.current is None:
            self._set_state(ERROR, f'cannot serve: {self.refused}')
            self._diagnostics.set_value(f'{self._prefix}{KEY_REFUSED}', self.refused)
            self._use(None)
        else:
            self._diagnostics.set_value(f'{self._prefix}{KEY_REFUSED}',
                                        f'{self.refused}; still serving with model {self.current.name!r}')

    def _set_state(self, level: int, message: str) -> None:
        """The node's state, unless the follower is one of several (``namespace``)."""
        if not self._prefix:
            self._diagnostics.set_state(level, message)

    def check(self, requires: ModelRequirements) -> None:
        """Whether the node still serves after its requirements become ``requires``: for a parameter check.

        A change is refused when the model in use would be refused and the newest document is that model
        (a node that serves would stop serving). While the newest document is refused, or none has come,
        any requirements pass: the node cannot serve it anyway, and new requirements may let it
        (:meth:`recheck` then reads it again).

        Raises
        ------
        GraspIntentError
            (a ValueError) Naming the model in use and why ``requires`` would refuse it.
        """
        current = self.current
        if current is None or self.refused:
            return
        try:
            requires.check(current.model.task_names, current.model.feature_names)
        except GraspIntentError as exc:
            raise GraspIntentError(f'the suite could not serve its active model {current.name!r}: {exc}') from None

    def stop(self) -> None:
        """Stop the reading thread; its current document (and ``use``) is waited for at most ``FINISH_WAIT`` s.

        :data:`grasp_intent_ros.latest_only.FINISH_WAIT`: e.g. a planner's precompute of a new model goes on, and
        ends with the process.
        """
        self._worker.stop()
