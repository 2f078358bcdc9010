"""An independent judge of a planned grasp's collisions: MuJoCo's geometry on the project's URDF.

The planner's check (``grasp_intent_ros.mico.collision``) poses the hand from the grasp features with its own
frames and asks coal. This judge takes what a robot would execute instead, the plan's joint targets (IK's
answer), and lets MuJoCo (its URDF import, forward kinematics and ``mj_geomDistance``) place the whole arm and
measure the hand's geoms against a table plane and the object's primitives, posed from the object's body of
the rules (``objects.demos.OBJECTS``, the judge's own knowledge of the object). No code is shared with the
planner's check but the URDF.

Per grasp (:meth:`PhysicsJudge.judge`), in metres (positive: into):

- ``table``: the deepest hand geom (link 6, finger links and tips) below the table, fingers open, at the grasp;
- ``palm``: the wrist/palm geom (link 6) into the object, fingers open;
- ``finger_on_table``: closing the fingers together from open to the planned closures in 0.02 rad steps, a
  finger touches the table before it touches the object.

Needs the ``bench`` extra (``pip install '.[bench]'``: MuJoCo from PyPI).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from grasp_intent_ros.method.body import Box, ObjectBody
from grasp_intent_ros.mico.kinematics import default_urdf_path

__all__ = ['PhysicsJudge', 'Verdict', 'TABLE_LIMIT', 'PALM_LIMIT']

TABLE_LIMIT = 0.005
"""A hand part deeper than this below the table (m) is a collision (the collision row's target in the README)."""
PALM_LIMIT = 0.002
"""The wrist/palm deeper than this into the object (m) is a collision."""
_HAND_BODIES = ('m1n6s300_link_6', 'm1n6s300_link_finger_1', 'm1n6s300_link_finger_2', 'm1n6s300_link_finger_3',
                'm1n6s300_link_finger_tip_1', 'm1n6s300_link_finger_tip_2', 'm1n6s300_link_finger_tip_3')
_STEP = 0.02
_FAR = 0.5


@dataclass(frozen=True)
class Verdict:
    """One grasp judged (module docstring); depths in m, positive into."""

    table: float
    palm: float
    finger_on_table: int

    @property
    def collides(self) -> bool:
        """A hand part more than TABLE_LIMIT below the table, or the palm more than PALM_LIMIT into the object."""
        return self.table > TABLE_LIMIT or self.palm > PALM_LIMIT


def _quat(R: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.empty(4)
    mujoco.mju_mat2Quat(out, np.ascontiguousarray(R).ravel())
    return out


class PhysicsJudge:
    """MuJoCo's model of the URDF with a table plane and an object body at ``base_T_obj``.

    Parameters
    ----------
    body : ObjectBody
        The object's primitives in its frame.
    base_T_obj : ndarray, shape (4, 4)
        The object in the arm's base frame; the table is the plane z = 0 of the object frame.
    """

    def __init__(self, body: ObjectBody, base_T_obj: NDArray[np.float64]) -> None:
        spec = mujoco.MjSpec.from_file(str(default_urdf_path()))
        world = spec.worldbody
        world.add_geom(name='table', type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2.0, 2.0, 0.01],
                       pos=base_T_obj[:3, 3], quat=_quat(base_T_obj[:3, :3]))
        for i, prim in enumerate(body.primitives):
            pose = base_T_obj.copy()
            pose[:3, 3] = base_T_obj[:3, :3] @ prim.centre + base_T_obj[:3, 3]
            if isinstance(prim, Box):
                world.add_geom(name=f'object_{i}', type=mujoco.mjtGeom.mjGEOM_BOX, size=prim.half_extents,
                               pos=pose[:3, 3], quat=_quat(base_T_obj[:3, :3]))
            else:
                z = prim.axis
                x = prim.perpendicular
                R = base_T_obj[:3, :3] @ np.column_stack([x, np.cross(z, x), z])
                world.add_geom(name=f'object_{i}', type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                               size=[prim.radius, 0.5 * prim.length, 0.0], pos=pose[:3, 3], quat=_quat(R))
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._table = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, 'table')
        self._object = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f'object_{i}')
                        for i in range(len(body.primitives))]
        bodies = {mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name) for name in _HAND_BODIES} - {-1}
        self._hand = [g for g in range(m.ngeom) if int(m.geom_bodyid[g]) in bodies]
        self._palm = [g for g in self._hand if m.body(int(m.geom_bodyid[g])).name == 'm1n6s300_link_6']
        self._fingers = [[g for g in self._hand if m.body(int(m.geom_bodyid[g])).name.endswith(f'finger_{k}')
                          or m.body(int(m.geom_bodyid[g])).name.endswith(f'finger_tip_{k}')] for k in (1, 2, 3)]
        self._arm_q = [m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f'm1n6s300_joint_{i}')]
                       for i in range(1, 7)]
        self._finger_q = [m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f'm1n6s300_joint_finger_{k}')]
                          for k in (1, 2, 3)]

    def _distance(self, a: int, b: int) -> float:
        return float(mujoco.mj_geomDistance(self.model, self.data, a, b, _FAR, None))

    def _pose(self, q_arm: NDArray[np.float64], fingers: NDArray[np.float64]) -> None:
        self.data.qpos[:] = 0.0
        self.data.qpos[self._arm_q] = q_arm
        self.data.qpos[self._finger_q] = fingers
        mujoco.mj_kinematics(self.model, self.data)

    def judge(self, positions: NDArray[np.float64]) -> Verdict:
        """Judge joint targets ``positions`` (6 arm joints, then the 3 finger closures; rad)."""
        q_arm, closures = positions[:6], positions[6:9]
        self._pose(q_arm, np.zeros(3))
        table = max(-self._distance(g, self._table) for g in self._hand)
        palm = max(-self._distance(g, o) for g in self._palm for o in self._object)
        on_table = 0
        touched = [False, False, False]
        steps = int(np.ceil(float(closures.max()) / _STEP)) if closures.max() > 0.0 else 0
        for s in range(1, steps + 1):
            self._pose(q_arm, np.minimum(closures, s * _STEP))
            for k in range(3):
                if touched[k]:
                    continue
                if min(self._distance(g, o) for g in self._fingers[k] for o in self._object) <= 0.0:
                    touched[k] = True
                elif min(self._distance(g, self._table) for g in self._fingers[k]) <= 0.0:
                    touched[k] = True
                    on_table += 1
        return Verdict(table, palm, on_table)
