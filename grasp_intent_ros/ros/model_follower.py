"""Following ``model/active`` without stalling a node: a new model is read off the executor, then swapped in.

Reading a model document (the size check, the hash, the YAML, the model's own checks) takes tens of
milliseconds. In a subscription callback it would hold back every other callback of the node (and, in
the planner, the answers to intent/v). :class:`ModelFollower` only stores the newest document in the
callback; a latest-only thread of its own reads it and hands the complete
:class:`~grasp_intent_ros.protocol.ModelDocument` to the node, which swaps it in with one assignment. Until
then the node keeps serving with the model it has; a document that fails to read changes nothing. Documents
that arrive while one is being read replace each other (only the newest model matters): the diagnostics
count them as ``model documents superseded`` and show the ``last model read time [ms]``.

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
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rclpy.node import Node
from std_msgs.msg import String

from ..protocol import MODEL_ACTIVE, ModelDocument, read_model_document
from .diagnostics import NodeDiagnostics
from .inputs import subscribe_input
from .qos import latched_qos
from .run import release_free_memory
from .worker import LatestOnlyWorker

__all__ = ['ModelFollower', 'READ_SWITCH_INTERVAL', 'yielding_reader']

READ_SWITCH_INTERVAL = 5e-4
"""The GIL switch interval while a document is read, s (Python's default: 5e-3)."""

_reading = threading.Lock()


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
        raises a GraspIntentError to refuse the model (then the node keeps its current one).
    name : str
        Name of the thread.
    """

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, use: Callable[[ModelDocument], object], *,
                 name: str) -> None:
        self._diagnostics, self._use = diagnostics, use
        self.current: ModelDocument | None = None
        """The last document ``use`` accepted."""
        self._worker: LatestOnlyWorker[str | None] = LatestOnlyWorker(
            None, diagnostics.guard(self._read, counts_received=False), ready=lambda text: text is not None,
            name=name)
        node.context.on_shutdown(self._worker.stop_soon)
        # counted and size-checked on arrival (subscribe_input); a document that fails to read is a rejection
        self.subscription = subscribe_input(node, MODEL_ACTIVE, self._on_document, latched_qos(), diagnostics)

    def _on_document(self, msg: String) -> None:
        text = msg.data  # stored as is: the executor thread does no work on a document
        self._worker.update(lambda _: text)

    def _read(self, text: str | None) -> None:
        assert text is not None  # ready() holds back the initial None
        self._diagnostics.set_value('model documents superseded', self._worker.superseded)
        start = time.perf_counter()
        with yielding_reader():
            doc = read_model_document(text, previous=self.current)  # checks the size first
        self._diagnostics.set_value('last model read time [ms]', f'{1e3 * (time.perf_counter() - start):.1f}')
        self._use(doc)
        self.current = doc
        release_free_memory()  # what the reading freed (see release_free_memory)

    def stop(self) -> None:
        """Stop the reading thread (after the document it is reading)."""
        self._worker.stop()
