"""Following ``model/active`` without stalling a node: a new model is read off the executor, then swapped in.

Reading a model document (the size check, the hash, the YAML, the model's own checks) takes tens of
milliseconds. In a subscription callback it would hold back every other callback of the node (and, in
the planner, the answers to intent/v). :class:`ModelFollower` only stores the newest document in the
callback; a latest-only thread of its own reads it and hands the complete
:class:`~grasp_intent_ros.protocol.ModelDocument` to the node, which swaps it in with one assignment. Until
then the node keeps serving with the model it has; a document that fails to read changes nothing. Documents
that arrive while one is being read replace each other (only the newest model matters): the diagnostics
count them as ``model documents superseded``.
"""

from __future__ import annotations

from collections.abc import Callable

from rclpy.node import Node
from std_msgs.msg import String

from ..protocol import MODEL_ACTIVE, ModelDocument, read_model_document
from .diagnostics import NodeDiagnostics
from .qos import latched_qos
from .worker import LatestOnlyWorker

__all__ = ['ModelFollower']


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
            None, diagnostics.guard(self._read), ready=lambda text: text is not None, name=name)
        node.context.on_shutdown(self._worker.stop_soon)
        self.subscription = node.create_subscription(String, MODEL_ACTIVE, self._on_document, latched_qos())

    def _on_document(self, msg: String) -> None:
        text = msg.data  # stored as is: the executor thread does no work on a document
        self._worker.update(lambda _: text)

    def _read(self, text: str | None) -> None:
        assert text is not None  # ready() holds back the initial None
        self._diagnostics.set_value('model documents superseded', self._worker.superseded)
        doc = read_model_document(text, previous=self.current)  # checks the size first
        self._use(doc)
        self.current = doc

    def stop(self) -> None:
        """Stop the reading thread (after the document it is reading)."""
        self._worker.stop()
