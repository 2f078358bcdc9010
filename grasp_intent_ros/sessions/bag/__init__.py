"""rosbag2 sessions: write, read, summarise.

Write with :class:`SessionWriter`, read with :func:`read_messages`, summarise with :func:`topics_info`,
repair a killed recording with :func:`reindex`; every module starts from :func:`jazzy_typestore`.

Bags are rosbag2 directories (metadata.yaml version 9, MCAP storage, CDR messages, ros2msg schemas,
offered QoS per topic), as ``ros2 bag info/play`` in ROS 2 Jazzy expects. This package imports
rosbags only, never rclpy.

Modules: writer (:class:`SessionWriter`), queued (:class:`QueuedWriter`, writes off the caller's thread),
recording (:class:`Recording`, a recorder's bag with its counts and first error), reader
(:func:`read_messages`, :func:`topics_info`), repair (:func:`reindex`), offered_qos (the QoS a topic was
offered with, the QoS to subscribe with), errors, types (:func:`jazzy_typestore`).
"""

from .errors import BagError, BagReadError, BagWriteError
from .offered_qos import Durability, QosSpec, Reliability, decode_qos, encode_qos, misses_offers, request_qos
from .queued import QueuedWriter
from .reader import BagMessage, TopicInfo, read_messages, topics_info
from .recording import Recording
from .repair import BROKEN_SUFFIX, ReindexResult, reindex
from .types import jazzy_typestore
from .writer import DEFAULT_FLUSH_PERIOD, SessionWriter

__all__ = [
    'BagError',
    'BagReadError',
    'BagWriteError',
    'Durability',
    'QosSpec',
    'Reliability',
    'decode_qos',
    'encode_qos',
    'request_qos',
    'misses_offers',
    'BagMessage',
    'TopicInfo',
    'read_messages',
    'topics_info',
    'SessionWriter',
    'QueuedWriter',
    'Recording',
    'DEFAULT_FLUSH_PERIOD',
    'ReindexResult',
    'reindex',
    'BROKEN_SUFFIX',
    'jazzy_typestore',
]
