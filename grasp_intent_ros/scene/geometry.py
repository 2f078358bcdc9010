"""What the viewer and the report draw, as posed primitives: the MICO's visual model and the object's body.

A :class:`Shape` is a box or a capped cylinder (its axis along its own +z, as in URDF and Pinocchio) with a
colour; :func:`arm_shapes` poses the URDF's visual geometry (Pinocchio's ``VISUAL`` geometry model of
``config/mico_3f.urdf``: the arm's cylinders and the fingers' boxes) for arm joint angles and finger
closures, :func:`body_shapes` the primitives of an :class:`~grasp_intent_ros.method.body.ObjectBody` for an
object pose. Every pose is ``base_T_shape`` (4x4, metres, in ``m1n6s300_link_base``), so a drawing needs no
kinematics of its own: three.js through viser in the viewer, matplotlib in the report.

No mesh loader: the URDF holds primitives only, and a mesh in it is refused (:class:`ArmModel`).
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import ArrayLike, NDArray

from ..errors import KinematicsError
from ..method.body import Box, Cylinder, ObjectBody
from ..mico.frames import check_transform, check_vector
from ..mico.kinematics import ARM_JOINTS, BASE_FRAME, EE_FRAME, FINGER_JOINTS, default_urdf_path

__all__ = ['Shape', 'ArmModel', 'body_shapes', 'BODY_RGBA']

BODY_RGBA = (0.62, 0.66, 0.74, 0.85)
"""Colour of the object's body (RGBA, 0..1)."""


@dataclass(frozen=True)
class Shape:
    """A posed primitive.

    Attributes
    ----------
    name : str
        Unique within one drawing (the URDF geometry's name, or ``body_<i>``).
    kind : {'box', 'cylinder'}
    size : tuple of 3 float
        Box: the full edge lengths along its x, y, z (m). Cylinder: (radius, radius, length) (m), the axis
        along its z.
    base_T_shape : ndarray, shape (4, 4)
        Pose of the shape's centre in the base frame.
    rgba : tuple of 4 float
        Colour, 0..1.
    """

    name: str
    kind: Literal['box', 'cylinder']
    size: tuple[float, float, float]
    base_T_shape: NDArray[np.float64]
    rgba: tuple[float, float, float, float]


class ArmModel:
    """The MICO's visual geometry, posed by Pinocchio's forward kinematics (arm and finger joints).

    The model is built once and never modified; each thread gets its own ``pinocchio.Data``.

    Parameters
    ----------
    urdf_path : path-like, optional
        Default :func:`~grasp_intent_ros.mico.kinematics.default_urdf_path`.

    Raises
    ------
    FileNotFoundError
        If the URDF does not exist.
    KinematicsError
        If it cannot be read, lacks the arm or finger joints, or draws anything but boxes and cylinders.
    """

    def __init__(self, urdf_path: str | os.PathLike[str] | None = None) -> None:
        path = default_urdf_path() if urdf_path is None else os.fspath(urdf_path)
        if not os.path.isfile(path):
            raise FileNotFoundError(f'URDF not found: {path}')
        try:
            self.model = pin.buildModelFromUrdf(str(path))
            self.visual = pin.buildGeomFromUrdf(self.model, str(path), pin.GeometryType.VISUAL)
        except (RuntimeError, ValueError) as exc:
            raise KinematicsError(f'cannot build the visual model of {path}: {exc}') from None
        missing = [n for n in (*ARM_JOINTS, *FINGER_JOINTS) if not self.model.existJointName(n)]
        if missing:
            raise KinematicsError(f'{path} lacks the joints {missing}')
        self._q_index = np.array([self.model.joints[self.model.getJointId(n)].idx_q
                                  for n in (*ARM_JOINTS, *FINGER_JOINTS)])
        base = self.model.frames[self.model.getFrameId(BASE_FRAME)]
        self._base_M_world = base.placement.inverse()
        self._ee_frame = self.model.getFrameId(EE_FRAME)
        self._templates: list[tuple[str, Literal['box', 'cylinder'], tuple[float, float, float], int, object,
                                    tuple[float, float, float, float]]] = []
        for obj in self.visual.geometryObjects:
            geometry = obj.geometry
            kind = type(geometry).__name__
            if kind == 'Cylinder':
                r, half = float(geometry.radius), float(geometry.halfLength)
                size: tuple[float, float, float] = (r, r, 2.0 * half)
                shape_kind: Literal['box', 'cylinder'] = 'cylinder'
            elif kind == 'Box':
                hx, hy, hz = (float(v) for v in geometry.halfSide)
                size, shape_kind = (2.0 * hx, 2.0 * hy, 2.0 * hz), 'box'
            else:
                raise KinematicsError(f'{path}: visual {obj.name!r} is a {kind}; only boxes and cylinders are drawn')
            rgba = tuple(float(c) for c in obj.meshColor)
            self._templates.append((obj.name, shape_kind, size, int(obj.parentJoint), obj.placement,
                                    (rgba[0], rgba[1], rgba[2], rgba[3])))
        self._data = threading.local()

    def _posed(self, q_arm: ArrayLike, fingers: ArrayLike | None) -> object:
        """This thread's ``pinocchio.Data`` after forward kinematics at ``q_arm``, ``fingers``."""
        q = pin.neutral(self.model)
        closures = np.zeros(3) if fingers is None else check_vector(fingers, 3, 'fingers')
        q[self._q_index] = np.concatenate([check_vector(q_arm, 6, 'q_arm'), closures])
        data = getattr(self._data, 'data', None)
        if data is None:
            data = self._data.data = self.model.createData()
        pin.forwardKinematics(self.model, data, q)
        return data

    def ee_pose(self, q_arm: ArrayLike) -> NDArray[np.float64]:
        """``base_T_ee`` (4x4) of the end-effector frame at ``q_arm``. Raises KinematicsError as :meth:`shapes`."""
        data: Any = self._posed(q_arm, None)
        world_M_ee = pin.updateFramePlacement(self.model, data, self._ee_frame)
        return np.array((self._base_M_world * world_M_ee).homogeneous)

    @property
    def names(self) -> tuple[str, ...]:
        """The shapes' names, in the order :meth:`shapes` returns them."""
        return tuple(t[0] for t in self._templates)

    def shapes(self, q_arm: ArrayLike, fingers: ArrayLike | None = None) -> list[Shape]:
        """Every visual shape of the arm at ``q_arm``.

        Parameters
        ----------
        q_arm : array_like, shape (6,)
            Arm joint angles (rad), :data:`~grasp_intent_ros.mico.kinematics.ARM_JOINTS` order.
        fingers : array_like, shape (3,), optional
            Finger closures (rad, 0 open .. 1.51 closed); open when None.

        Raises
        ------
        KinematicsError
            If ``q_arm`` or ``fingers`` is not a finite vector of its shape.
        """
        data: Any = self._posed(q_arm, fingers)
        out = []
        for name, kind, size, joint, placement, rgba in self._templates:
            base_M_shape = self._base_M_world * data.oMi[joint] * placement
            out.append(Shape(name, kind, size, np.array(base_M_shape.homogeneous), rgba))
        return out


def _z_to(axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """A rotation taking +z to the unit vector ``axis`` (the smallest one; about x for -z)."""
    return np.array(pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), axis).toRotationMatrix())


def body_shapes(body: ObjectBody, base_T_obj: ArrayLike, *,
                rgba: tuple[float, float, float, float] = BODY_RGBA) -> list[Shape]:
    """The primitives of ``body`` posed at ``base_T_obj`` (4x4, the object frame in the base frame).

    Raises
    ------
    KinematicsError
        If ``base_T_obj`` is not a rigid transform.
    """
    base_T = check_transform(base_T_obj, 'base_T_obj')
    out = []
    for i, primitive in enumerate(body.primitives):
        obj_T_shape = np.eye(4)
        obj_T_shape[:3, 3] = primitive.centre
        if isinstance(primitive, Cylinder):
            obj_T_shape[:3, :3] = _z_to(primitive.axis)
            size = (primitive.radius, primitive.radius, primitive.length)
            out.append(Shape(f'body_{i}', 'cylinder', size, base_T @ obj_T_shape, rgba))
        elif isinstance(primitive, Box):
            hx, hy, hz = (2.0 * float(v) for v in primitive.half_extents)
            out.append(Shape(f'body_{i}', 'box', (hx, hy, hz), base_T @ obj_T_shape, rgba))
    return out
