"""grasp_intent_ros.ros.markers: the RViz markers of a planned grasp."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from numpy.testing import assert_allclose
from visualization_msgs.msg import Marker

from grasp_intent_ros.mico.frames import features_to_obj_T_ee, finger_segments
from grasp_intent_ros.ros.markers import grasp_markers, zone_summary


def test_markers_draw_object_approach_the_shared_fingers_and_text() -> None:
    x = np.array([0.05, 0.0, 0.06, -1.0, 0.0, 0.0, 0.0, 0.4, 0.8, 1.2])
    base_T_obj = np.eye(4)
    base_T_obj[:3, 3] = (0.3, -0.3, 0.0)
    base_T_ee = base_T_obj @ features_to_obj_T_ee(x)
    markers = grasp_markers(base_T_obj, base_T_ee, x[7:], 'cup\nUT  0.62', frame_id='base',
                            stamp=Time(sec=1), object_size=(0.08, 0.1)).markers
    assert [(m.id, m.type) for m in markers] == [(0, Marker.CYLINDER), (1, Marker.ARROW), (2, Marker.LINE_LIST),
                                                 (3, Marker.TEXT_VIEW_FACING)]
    assert all(m.header.frame_id == 'base' and m.header.stamp == Time(sec=1) for m in markers)
    assert_allclose([markers[0].scale.x, markers[0].scale.z], [0.08, 0.1])
    assert_allclose([markers[0].pose.position.x, markers[0].pose.position.z], [0.3, 0.05])
    tip = markers[1].points[1]
    assert_allclose([tip.x, tip.y, tip.z], base_T_ee[:3, 3], atol=1e-12)  # the arrow ends at the palm
    lines = np.array([[p.x, p.y, p.z] for p in markers[2].points]).reshape(3, 2, 3)
    ee_segments = finger_segments(x[7:])
    assert_allclose(lines, ee_segments @ base_T_ee[:3, :3].T + base_T_ee[:3, 3], atol=1e-12)
    assert markers[3].text == 'cup\nUT  0.62'


def test_zone_summary_lists_the_most_likely_zones() -> None:
    assert zone_summary(('U', 'T', 'UT'), [0.2, 0.1, 0.7], top=2) == 'UT  0.70\nU  0.20'
