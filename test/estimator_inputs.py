"""What the intent estimator's node tests send it: the operator's twist, and the task prior they expect back."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import TwistStamped

from grasp_intent_ros.mico.kinematics import BASE_FRAME

PRIOR = 4 / 7
"""Each task's prior probability: uniform over the seven task sets, four of which contain it."""


def twist_msg(linear: np.ndarray) -> TwistStamped:
    """The operator's twist: ``linear`` (m/s) in the arm's base frame, no rotation, unstamped."""
    msg = TwistStamped()
    msg.header.frame_id = BASE_FRAME
    msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = (float(v) for v in linear)
    return msg
