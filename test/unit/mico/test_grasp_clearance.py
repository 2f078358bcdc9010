"""grasp_intent_ros.mico.grasp_clearance: the table as the hand's collision check takes it."""

from __future__ import annotations

import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import KinematicsError
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.grasp_clearance import Table


def test_a_table_of_the_base_frame_in_the_object_frame() -> None:
    base_T_obj = pose_to_matrix((0.3, -0.3, 0.1), (0.0, 0.0, 1.0, 0.0))  # the object 10 cm above the base's plane
    table = Table.in_object_frame((0.0, 0.0, 2.0, 0.0), base_T_obj)
    assert_allclose(table.normal, (0.0, 0.0, 1.0), atol=1e-15)
    assert table.offset == pytest.approx(-0.1)
    with pytest.raises(KinematicsError, match='4 finite numbers'):
        Table.in_object_frame((0.0, 0.0, 1.0), base_T_obj)
    with pytest.raises(KinematicsError, match='non-zero normal'):
        Table.in_object_frame((0.0, 0.0, 0.0, 1.0), base_T_obj)
