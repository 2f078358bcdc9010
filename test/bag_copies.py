"""A recorded session copied with some of its messages edited: for replays of altered or perturbed inputs."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from grasp_intent_ros.sessions.bag import QosSpec, SessionWriter, jazzy_typestore, read_messages, topics_info


def edited_copy(bag: Path, out: Path, edit: Callable[[str, Any], bool]) -> Path:
    """``bag`` written to ``out``: every topic with its type and QoS, every message at its receive time.

    ``edit(topic, msg)`` gets each message deserialised; it returns True after changing ``msg`` in place (the
    message is then serialised again) and False to keep the recorded bytes.
    """
    store = jazzy_typestore()
    with SessionWriter(out) as writer:
        for topic, info in topics_info(bag).items():
            writer.add_topic(topic, info.msgtype, qos=info.qos[0] if info.qos else QosSpec())
        for msg in read_messages(bag):
            cdr = bytes(msg.cdr)
            decoded = store.deserialize_cdr(cdr, msg.msgtype)
            if edit(msg.topic, decoded):
                cdr = bytes(store.serialize_cdr(decoded, msg.msgtype))
            writer.write(msg.topic, msg.timestamp_ns, cdr)
    return out
