"""The operator's twist as the node tests send it, and a received twist as an array (one definition for every test)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from geometry_msgs.msg import TwistStamped

from grasp_intent_ros.mico.kinematics import BASE_FRAME


def twist_msg(linear: Sequence[float] = (0.0, 0.0, 0.0), angular: Sequence[float] = (0.0, 0.0, 0.0),
              frame: str = BASE_FRAME) -> TwistStamped:
    """A twist of ``linear`` (m/s) and ``angular`` (rad/s) in ``frame``, its stamp zero (nodes judge arrival)."""
    msg = TwistStamped()
    msg.header.frame_id = frame
    msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = (float(v) for v in linear)
    msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z = (float(v) for v in angular)
    return msg


def as_array(msg: TwistStamped) -> np.ndarray:
    """(vx, vy, vz, wx, wy, wz) of ``msg``."""
    t = msg.twist
    return np.array([t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z])
