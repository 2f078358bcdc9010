"""The message types every bag module starts from: ROS 2 Jazzy's, as rosbags knows them."""

from __future__ import annotations

from typing import TYPE_CHECKING

from rosbags.typesys import Stores, get_typestore

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ['jazzy_typestore']


def jazzy_typestore() -> Typestore:
    """A new rosbags typestore of the ROS 2 Jazzy message types.

    New on every call: reading a bag registers into its store the types the bag defines and Jazzy lacks,
    so one store shared by every reader would carry one bag's definitions into the next bag's reading.
    """
    return get_typestore(Stores.ROS2_JAZZY)
