"""The MICO hand against the table and the object: whether the robot takes a grasp without driving into them.

A grasp x (:mod:`grasp_intent_ros.method.features`, object frame) puts the end effector at
``features_to_obj_T_ee(x)``. The hand is the URDF's collision primitives fixed to link 6 (the wrist and palm,
``'palm'``) and to the three finger joints (each finger's proximal link and tip): pinocchio's geometry model of
``config/mico_3f.urdf``, its shapes coal's. The scene is the table, a plane (:class:`~.grasp_clearance.Table`: the
free side is ``normal . p >= offset``, object frame), and the object's body
(:class:`~grasp_intent_ros.method.body.ObjectBody`, its primitives, the cup's handle included).

:class:`HandCollision` answers, for one grasp (:meth:`HandCollision.clearance`), in metres:

- **the approach, fingers open**: the hand moves from the pre-grasp (the grasp moved back by ``standoff``
  along its approach axis, :data:`~.frames.PRE_GRASP_STANDOFF` as the assistance's) to the grasp with every finger at
  0. ``table_depth``: how deep the deepest hand part goes below the table on the way (a plane's depth is
  linear along a straight path, so the two ends decide it; exact, the support function of each primitive);
  ``palm_depth`` and ``finger_depth``: how deep the palm/wrist and the open fingers go into the object
  (coal's signed distance at poses ``SWEEP_STEP`` apart along the corridor, both ends included);
- **the closure**: each finger closes from 0 toward its planned closure in steps of ``CLOSURE_STEP`` and
  stops at the first step where it touches (signed distance <= 0) the object or the table; ``stops`` says
  where and on what (:class:`~.grasp_clearance.FingerStop`).

:meth:`HandCollision.open_hand_depth` gives the same two object depths at one hand pose (a path's, at each pose).

:data:`LIMITS` turn that into a verdict (:meth:`~.grasp_clearance.Clearance.fault`): a grasp is in collision when a
hand part goes more than ``table`` below the table, the palm/wrist more than ``palm`` into the object, or an open
finger more than ``finger`` into it. A finger that meets the table while closing stops there (a MICO's fingers take
position commands and stall at contact): reported, never a collision.

The object's part of a grasp's clearance (coal's, the costly part) does not depend on the table nor on the
object's pose: it is cached per body and grasp (keyed by the feature vector's bytes), and the whole clearance
per body, table and grasp, so a planner that asks about the same demonstrations again pays a dictionary look-up,
or, after the table moved in the object's frame, the table's part (a few array operations).

Every answer depends on its inputs alone, not on the coal queries the process ran before (which objects, which
episodes, in which order): importing this module pins the one state coal keeps from query to query
(:func:`_pin_box_support`).
"""

from __future__ import annotations

import math
import os
import threading
from collections import OrderedDict
from typing import Any

import coal  # type: ignore[import-untyped, unused-ignore]
import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import ArrayLike, NDArray

from ..errors import KinematicsError
from ..method.body import Box, Cylinder, ObjectBody
from ..method.features import FINGERS, MICO_3F
from .frames import PRE_GRASP_STANDOFF, check_transform, features_to_obj_T_ee, pre_grasp
from .grasp_clearance import Clearance, FingerStop, Table
from .kinematics import EE_FRAME, FINGER_JOINTS, default_urdf_path
from .limits import LIMITS, Limits, tracker_margin

__all__ = ['SWEEP_STEP', 'CLOSURE_STEP', 'Limits', 'LIMITS', 'tracker_margin', 'HandCollision', 'CollisionFree',
           'HAND_PARTS']

SWEEP_STEP = 0.005
"""Largest spacing (m) of the poses checked against the object along the approach corridor (below the
thinnest primitive of hand and object, 10 mm)."""
CLOSURE_STEP = 0.02
"""Step (rad) of a closing finger; it stops at the first step that touches the object or the table."""
HAND_PARTS = ('palm', 'finger_1', 'finger_tip_1', 'finger_2', 'finger_tip_2', 'finger_3', 'finger_tip_3')
"""The hand's collision parts, named in :attr:`~.grasp_clearance.Clearance.table_part`: link 6 (wrist and palm),
then each finger's proximal link and tip."""
_FINGER_OF_PART = (-1, 0, 0, 1, 1, 2, 2)
_JOINT_OF_PART = np.repeat(np.arange(3), 2)
"""The finger joint each finger part (links 1-6 of :data:`HAND_PARTS`) turns with."""
_MAX_CACHE = 8192
_CLOSED = float(MICO_3F.upper[FINGERS][0])
_FINGER_REACH = 0.12
"""Upper bound (m) on the distance of a finger's collision primitives from its joint axis (link and tip: 0.10)."""
_MAX_SCENES = 16


_STANDING = Table()  # the plane z = 0 of the object frame, the object's own (immutable: built once)
_OPEN = np.zeros(3)
_OPEN.setflags(write=False)
"""The open fingers' closures (rad): :meth:`HandCollision.open_hand_depth`'s, built once."""


def _pin_box_support() -> None:
    """Pin the state coal keeps across queries, so that each distance with a box depends on its inputs alone.

    coal's support function of a box (every GJK and EPA step on a box) moves the box's negative faces out by a
    factor ``inflate`` that is a function-local static: set by the first direction that function is given in the
    process, 1 + 1e-10 when that direction has a component exactly 0, else 1, and kept until the process ends
    (coal's API has no reset). Left to the process's first query with a box, every later distance with a box
    would depend, in its last digits, on which query came first: another object's, another episode's. This is
    that first query, a box at the identity as the first shape against a cylinder above it: GJK's first direction
    is then an axis of the box's frame, so it pins 1 + 1e-10 (the box's negative faces 1e-10 of their half-side
    further out than its positive ones), in every process. It runs at this module's import, before any query of
    the package's own; a process that asks coal about a box before importing this module keeps what that query
    pinned. Only the support function GJK and EPA use is pinned (coal's other one, with swept spheres, serves
    planes, half-spaces and contact patches, which this module never asks for).
    """
    coal.distance(coal.Box(0.01, 0.01, 0.01), coal.Transform3s(), coal.Cylinder(0.01, 0.01),
                  coal.Transform3s(np.eye(3), np.array([0.0, 0.0, 1.0])), coal.DistanceRequest(), coal.DistanceResult())


_pin_box_support()


def _rz(angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotations about z by ``angles`` (N,), shape (N, 4, 4)."""
    c, s = np.cos(angles), np.sin(angles)
    out = np.zeros((angles.size, 4, 4))
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = c, -s, s, c
    out[:, 2, 2] = out[:, 3, 3] = 1.0
    return out


def _tf(T: NDArray[np.float64]) -> Any:
    """A coal transform of a 4x4 matrix."""
    return coal.Transform3s(np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]))


class _Shape:
    """A primitive as the table's support function and coal take it: a box or a z-axis cylinder in its frame."""

    def __init__(self, geometry: Any) -> None:
        self.geometry = geometry
        if isinstance(geometry, coal.Box):
            self.half = np.asarray(geometry.halfSide, dtype=np.float64)
            self.radius = float(np.linalg.norm(self.half))
            self.cylinder: tuple[float, float] | None = None
        elif isinstance(geometry, coal.Cylinder):
            self.cylinder = (float(geometry.radius), float(geometry.halfLength))
            self.half = np.zeros(3)
            self.radius = math.hypot(*self.cylinder)
        else:
            raise KinematicsError(f'hand collision takes boxes and cylinders, got {type(geometry).__name__}')

    def lowest(self, T: NDArray[np.float64], normal: NDArray[np.float64]) -> NDArray[np.float64]:
        """``normal . p`` of the shape's lowest point along ``normal`` at poses T (..., 4, 4), shape (...)."""
        centre = T[..., :3, 3] @ normal
        along = np.einsum('...ij,i->...j', T[..., :3, :3], normal)  # the normal in the shape's axes
        if self.cylinder is None:
            out: NDArray[np.float64] = centre - np.abs(along) @ self.half
            return out
        radius, half_length = self.cylinder
        a = np.abs(along[..., 2])
        low: NDArray[np.float64] = centre - half_length * a - radius * np.sqrt(np.maximum(1.0 - a * a, 0.0))
        return low


class _Scene:
    """The object's primitives as coal shapes with their poses and bounding spheres (object frame)."""

    def __init__(self, body: ObjectBody) -> None:
        shapes, poses, centres, radii = [], [], [], []
        for prim in body.primitives:
            T = np.eye(4)
            T[:3, 3] = prim.centre
            if isinstance(prim, Cylinder):
                T[:3, 2], T[:3, 0] = prim.axis, prim.perpendicular
                T[:3, 1] = np.cross(prim.axis, prim.perpendicular)
                shapes.append(coal.Cylinder(prim.radius, prim.length))
            else:
                assert isinstance(prim, Box)
                shapes.append(coal.Box(*(2.0 * prim.half_extents).tolist()))
            radii.append(prim.bounding_radius)
            poses.append(_tf(T))
            centres.append(prim.centre)
        self.shapes, self.poses = shapes, poses
        self.centres, self.radii = np.array(centres), np.array(radii)

    def near(self, centres: NDArray[np.float64], radii: NDArray[np.float64], within: float) -> NDArray[np.bool_]:
        """Which primitives each sphere may come within ``within`` (m) of: shape (N, primitives), bool.

        Spheres ``centres`` (N, 3) with ``radii`` (N,), object frame: True where the centres' distance is at most
        the two bounding radii plus ``within`` (each row the same numbers as the one sphere's test alone).
        """
        distance = np.linalg.norm(self.centres[None, :, :] - centres[:, None, :], axis=2)
        near: NDArray[np.bool_] = distance <= self.radii[None, :] + radii[:, None] + within
        return near


class HandCollision:
    """The MICO hand's collision geometry (URDF) and its clearance from a table and an object body.

    Built once (like :class:`~.kinematics.MicoKinematics`); read-only after, and its caches are guarded by a
    lock, so one instance can serve several threads.

    Parameters
    ----------
    urdf_path : path-like, optional
        :func:`~.kinematics.default_urdf_path` when None.
    standoff : float
        The pre-grasp's distance behind the grasp (m), >= 0.

    Raises
    ------
    FileNotFoundError
        If the URDF does not exist.
    KinematicsError
        If it lacks the end effector, the finger joints or their collision primitives.
    """

    def __init__(self, urdf_path: str | os.PathLike[str] | None = None, *,
                 standoff: float = PRE_GRASP_STANDOFF) -> None:
        path = default_urdf_path() if urdf_path is None else os.fspath(urdf_path)
        if not os.path.isfile(path):
            raise FileNotFoundError(f'URDF not found: {path}')
        if not (math.isfinite(standoff) and standoff >= 0.0):
            raise KinematicsError(f'standoff must be finite and >= 0, got {standoff!r}')
        try:
            model = pin.buildModelFromUrdf(str(path))
            geom = pin.buildGeomFromUrdf(model, str(path), pin.COLLISION)
        except (RuntimeError, ValueError) as exc:
            raise KinematicsError(f'cannot build the hand from {path}: {exc}') from None
        if not model.existFrame(EE_FRAME) or not all(model.existJointName(j) for j in FINGER_JOINTS):
            raise KinematicsError(f'{path} lacks {EE_FRAME!r} or the finger joints {FINGER_JOINTS}')
        ee = model.frames[model.getFrameId(EE_FRAME)]
        wrist = ee.parentJoint
        ee_M_wrist = ee.placement.inverse()
        fingers = [model.getJointId(j) for j in FINGER_JOINTS]
        for jid in fingers:
            if model.parents[jid] != wrist or model.joints[jid].shortname() != 'JointModelRZ':
                raise KinematicsError(f'{model.names[jid]!r} must turn about its z axis, fixed to the wrist link')
        self.standoff = float(standoff)
        self.shapes: list[_Shape] = []
        fixed: list[NDArray[np.float64]] = []   # ee_T_part of the palm; joint_T_part of a finger's part
        finger_of: list[int] = []
        for obj in geom.geometryObjects:
            owner = fingers.index(obj.parentJoint) if obj.parentJoint in fingers else (-1 if obj.parentJoint == wrist
                                                                                         else None)
            if owner is None:
                continue
            self.shapes.append(_Shape(obj.geometry))
            finger_of.append(owner)
            fixed.append(np.array((ee_M_wrist * obj.placement).homogeneous) if owner < 0
                         else np.array(obj.placement.homogeneous))
        if tuple(finger_of) != _FINGER_OF_PART:
            raise KinematicsError(f'{path}: expected one collision primitive on the wrist link and two per finger '
                                  f'(proximal link, tip), found {finger_of}')
        self._fixed = np.array(fixed)
        self._radii = np.array([shape.radius for shape in self.shapes])
        self._rz_open = _rz(_OPEN)  # the open fingers' turns, the same numbers every call computed
        self._ee_T_joint = np.array([np.array((ee_M_wrist * model.jointPlacements[j]).homogeneous) for j in fingers])
        self._request = coal.DistanceRequest()
        self._lock = threading.Lock()
        self._scenes: dict[ObjectBody, _Scene] = {}
        self._cache: OrderedDict[tuple[ObjectBody | None, Table, bytes], Clearance] = OrderedDict()
        self._faults: dict[tuple[ObjectBody | None, Table, Limits, bytes], str | None] = {}
        self._object_cache: OrderedDict[tuple[ObjectBody, bytes], tuple[float, float, NDArray[np.float64]]] = \
            OrderedDict()

    # -- the hand's parts -----------------------------------------------------------------------------------

    def parts(self, obj_T_ee: NDArray[np.float64], closures: ArrayLike) -> NDArray[np.float64]:
        """Poses of :data:`HAND_PARTS` in the object frame for closures (rad, shape (3,)), shape (7, 4, 4)."""
        c = np.asarray(closures, dtype=np.float64)
        out = np.empty((len(HAND_PARTS), 4, 4))
        out[0] = obj_T_ee @ self._fixed[0]
        joints = obj_T_ee @ self._ee_T_joint @ (self._rz_open if c is _OPEN else _rz(c))        # (3, 4, 4)
        out[1:] = joints[_JOINT_OF_PART] @ self._fixed[1:]
        return out

    def _finger_sweep(self, obj_T_ee: NDArray[np.float64], finger: int,
                      closures: NDArray[np.float64]) -> NDArray[np.float64]:
        """Poses of a finger's two parts at each closure (N,), shape (N, 2, 4, 4)."""
        joint = obj_T_ee @ self._ee_T_joint[finger] @ _rz(closures)   # (N, 4, 4)
        parts = 1 + 2 * finger
        out: NDArray[np.float64] = joint[:, None] @ self._fixed[None, parts:parts + 2]
        return out

    # -- the clearance --------------------------------------------------------------------------------------

    def clearance(self, x: ArrayLike, body: ObjectBody | None, table: Table | None = None) -> Clearance:
        """The clearance of grasp x (MICO features, object frame) from ``table`` and ``body`` (module docstring).

        ``table`` None: the plane z = 0 of the object frame (the object stands on it). ``body`` None: no object.
        Answers are cached per (body, table, x).

        Raises
        ------
        InvalidFeaturesError
            If x is not a finite feature vector with a non-zero approach.
        """
        vec = np.asarray(x, dtype=np.float64)
        plane = table if table is not None else _STANDING
        key = (body, plane, vec.tobytes())
        with self._lock:
            hit = self._cache.get(key)
            if hit is not None:
                self._cache.move_to_end(key)
                return hit
        obj_T_ee = features_to_obj_T_ee(vec)
        closures = np.clip(vec[FINGERS], 0.0, _CLOSED)
        # the table: the lowest point of each part, fingers open, at the grasp and at the pre-grasp
        pre = pre_grasp(obj_T_ee, self.standoff)
        normal = np.asarray(plane.normal)
        open_parts = np.stack([self.parts(obj_T_ee, np.zeros(3)), self.parts(pre, np.zeros(3))], axis=1)  # (7, 2)
        depth = np.array([plane.offset - shape.lowest(T, normal).min() for shape, T in zip(self.shapes, open_parts)])
        deepest = int(np.argmax(depth))
        # each finger closing: its first step on the table (a grid shared by the fingers, cut at each closure)
        grid = np.arange(0.0, _CLOSED + CLOSURE_STEP, CLOSURE_STEP)
        joints = (obj_T_ee @ self._ee_T_joint)[:, None] @ _rz(grid)[None]          # (3, G, 4, 4)
        low = np.stack([np.minimum(self.shapes[1 + 2 * k].lowest(joints[k] @ self._fixed[1 + 2 * k], normal),
                                   self.shapes[2 + 2 * k].lowest(joints[k] @ self._fixed[2 + 2 * k], normal))
                        for k in range(3)])                                              # (3, G)
        palm_depth, finger_depth, object_stop = (-math.inf, -math.inf, closures) if body is None else \
            self._object_part(vec, obj_T_ee, closures, body)
        stops = []
        for k in range(3):
            touches = np.flatnonzero((low[k] <= plane.offset) & (grid < closures[k]))
            on_table = float(grid[touches[0]]) if touches.size else math.inf
            on_object = float(object_stop[k])
            if on_table < min(on_object, closures[k]):
                stops.append(FingerStop(on_table, 'table'))
            elif on_object < closures[k]:
                stops.append(FingerStop(on_object, 'object'))
            else:
                stops.append(FingerStop(float(closures[k]), ''))
        out = Clearance(float(depth[deepest]), HAND_PARTS[deepest], palm_depth, finger_depth,
                        (stops[0], stops[1], stops[2]))
        with self._lock:
            self._cache[key] = out
            while len(self._cache) > _MAX_CACHE:
                self._cache.popitem(last=False)
        return out

    def fault(self, key: bytes, x: NDArray[np.float64], body: ObjectBody | None, table: Table,
              limits: Limits) -> str | None:
        """:meth:`Clearance.fault` of grasp x (``key`` its bytes), cached: a planner asks it for each candidate."""
        entry = (body, table, limits, key)
        with self._lock:
            if entry in self._faults:
                return self._faults[entry]
        fault = self.clearance(x, body, table).fault(limits)
        with self._lock:
            self._faults[entry] = fault
            while len(self._faults) > _MAX_CACHE:
                del self._faults[next(iter(self._faults))]
        return fault

    def _object_part(self, x: NDArray[np.float64], obj_T_ee: NDArray[np.float64], closures: NDArray[np.float64],
                     body: ObjectBody) -> tuple[float, float, NDArray[np.float64]]:
        """(palm depth, open-finger depth, each finger's closure at its first touch of the object, or its closure).

        Along the corridor and along a finger's closure, a part at distance d > 0 from the object cannot touch
        it before it has moved d, so the next pose is that far on (conservative advancement; at most
        ``SWEEP_STEP`` apart where the part is in contact, so that the deepest pose is not skipped by more).
        Cached per (body, x): it does not depend on the table.
        """
        key = (body, x.tobytes())
        with self._lock:
            hit = self._object_cache.get(key)
            if hit is not None:
                self._object_cache.move_to_end(key)
                return hit
        scene = self._scene(body)
        approach = obj_T_ee[:3, 2]
        depth = np.full(len(HAND_PARTS), -math.inf)
        ee_T_part = self.parts(np.eye(4), np.zeros(3))
        for i, shape in enumerate(self.shapes):
            s = 0.0
            while True:
                T = obj_T_ee @ ee_T_part[i]
                T[:3, 3] -= s * approach
                d = -self._depth(shape, T, scene)
                depth[i] = max(depth[i], -d)
                if s >= self.standoff:
                    break
                s = min(self.standoff, s + max(SWEEP_STEP if d < SWEEP_STEP else d, 1e-4))
        stop = closures.copy()
        for k in range(3):
            c, end = 0.0, float(closures[k])
            while c < end:
                poses = self._finger_sweep(obj_T_ee, k, np.array([c]))[0]
                d = min(-self._depth(self.shapes[1 + 2 * k], poses[0], scene),
                        -self._depth(self.shapes[2 + 2 * k], poses[1], scene))
                if d <= 0.0:
                    stop[k] = c
                    break
                c += max(d / _FINGER_REACH, 1e-4)
        out = (float(depth[0]), float(depth[1:].max()), stop)
        with self._lock:
            self._object_cache[key] = out
            while len(self._object_cache) > _MAX_CACHE:
                self._object_cache.popitem(last=False)
        return out

    def open_hand_depth(self, obj_T_ee: ArrayLike, body: ObjectBody, *, within: float = 0.0) -> tuple[float, float]:
        """How deep the hand at one pose, fingers open, goes into ``body``: (palm/wrist, deepest open finger), m.

        ``obj_T_ee`` (4x4): the end effector in the object frame. :class:`Clearance`'s ``palm_depth`` and
        ``finger_depth`` at that pose alone (coal's signed distance; negative: clear; ``-inf``: a part whose bounding
        sphere lies farther than ``within`` (m, >= 0) from every primitive's), to compare with :data:`LIMITS`.

        Raises
        ------
        KinematicsError
            If ``obj_T_ee`` is not a rigid transform.
        """
        T, scene = check_transform(obj_T_ee, 'obj_T_ee'), self._scene(body)
        poses = self.parts(T, _OPEN)
        near = scene.near(poses[:, :3, 3], self._radii, within).tolist()  # every part's test in one array operation
        depth = [self._deepest(sh, pose, scene, row) for sh, pose, row in zip(self.shapes, poses, near)]
        return depth[0], max(depth[1:])

    def _scene(self, body: ObjectBody) -> _Scene:
        """The body's coal shapes, built once per body (at most ``_MAX_SCENES`` kept)."""
        with self._lock:
            scene = self._scenes.get(body)
            if scene is None:
                if len(self._scenes) >= _MAX_SCENES:
                    self._scenes.clear()
                scene = self._scenes[body] = _Scene(body)
        return scene

    def _depth(self, shape: _Shape, pose: NDArray[np.float64], scene: _Scene, within: float = 0.0) -> float:
        """How deep a part at ``pose`` goes in (m; < 0: clear; -inf: its bounding sphere ``within`` m clear of all)."""
        near = scene.near(pose[None, :3, 3], np.array([shape.radius]), within)[0].tolist()
        return self._deepest(shape, pose, scene, near)

    def _deepest(self, shape: _Shape, pose: NDArray[np.float64], scene: _Scene, near: list[bool]) -> float:
        """:meth:`_depth` of a part at ``pose`` given which primitives are ``near`` it (:meth:`_Scene.near`'s row)."""
        if not any(near):
            return -math.inf
        tf = _tf(pose)
        return max(-float(coal.distance(shape.geometry, tf, scene.shapes[j], scene.poses[j], self._request,
                                        coal.DistanceResult())) for j, hit in enumerate(near) if hit)



class CollisionFree:
    """The hand's clearance as a robot constraint for :func:`grasp_intent_ros.planning.planner.plan` (``accept=``).

    Grasp features x are taken when their :class:`Clearance` has no fault under ``limits``; every verdict is
    kept (``faults``, by ``x.tobytes()``) for the plan's diagnostics.

    Parameters
    ----------
    hand : HandCollision
    body : ObjectBody or None
        The object's body (a model's ``body``); None: the table alone.
    table : Table, optional
        The support in the object frame; None: the plane the object stands on (z = 0 of its frame).
    limits : Limits
    """

    def __init__(self, hand: HandCollision, body: ObjectBody | None, table: Table | None = None, *,
                 limits: Limits = LIMITS) -> None:
        self.hand, self.body, self.limits = hand, body, limits
        self.table = table if table is not None else _STANDING
        self.faults: dict[bytes, str] = {}
        """Why each grasp turned down is in collision."""

    def clearance(self, x: NDArray[np.float64]) -> Clearance:
        """The clearance of features x (cached by the hand)."""
        return self.hand.clearance(x, self.body, self.table)

    def __call__(self, x: NDArray[np.float64]) -> bool:
        """Whether the hand takes grasp x without collision."""
        key = np.asarray(x, dtype=np.float64).tobytes()
        fault = self.hand.fault(key, x, self.body, self.table, self.limits)
        if fault is not None:
            self.faults[key] = fault
        return fault is None
