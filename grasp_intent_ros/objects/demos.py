"""Rule-based demonstration generators for a cup and a flashlight (the paper's data is not public).

A demonstration is a MICO grasp feature vector x (see :mod:`grasp_intent_ros.method.features`) labelled
with the set of principal tasks it satisfies. The label is never assigned by hand: every task has a
documented rule, a conjunction of small named conditions on x, and a demonstration's task set is the
set of rules it satisfies (paper Table I, the object-ambiguity section, and Table II's inclusive
labeling). Demonstrations are sampled the way a person moving the arm would produce them: for each
task set a prototype grasp (aim point on the object, side and elevation of the approach, standoff,
wrist roll, finger closures) plus human-like noise; the rules then decide the label, so a sample meant
for "usage and transfer" that drifts past a threshold is kept as what it really is.

Frames and geometry
-------------------
Cup (:class:`Cup`): frame ``obj`` at the centre of the cup's base, +z up, the handle on +x.
Body: a cylinder of radius 0.04 m and height 0.10 m. Handle: a loop in the xz-plane attached between
z = 0.025 m and z = 0.075 m, reaching 0.03 m beyond the body (outer edge at x = 0.07 m).

Flashlight (:class:`Flashlight`): lying on the table; frame ``obj`` on the table directly below the
centre of mass, +x along the axis towards the head (lens), +z up. Body: a cylinder of radius 0.02 m
(axis at z = 0.02 m) from x = -0.10 m (tail) to x = +0.10 m (head). The switch sits on the +y side of
the body at x = +0.04 m, so a grasp from above presses it with the thumb.

Angles used by the rules
------------------------
- Elevation of the approach: angle of the palm approach direction below the horizontal (rad);
  0 = parallel to the table, pi/2 = straight down from above.
- Azimuth of the palm: atan2(palm_y, palm_x) (rad); 0 = the cup's handle side.
- Roll: the feature itself, compared with 0 (usual grasp) or pi (wrist turned by 180 degrees) modulo
  2 pi. The thumb (finger 1) points along the end effector's x axis of
  :func:`grasp_intent_ros.mico.frames.features_to_obj_T_ee` (:func:`thumb_direction`).
- A finger is *closed* when its closure is at least :data:`CLOSED` rad.

Rules (one line each; the thresholds are fields of :class:`Cup` / :class:`Flashlight`)
-------------------------------------------------------------------------------------
Cup usage (drinking): rim clear (palm_z <= 0.08) AND approach roughly parallel to the table
(elevation <= 50 deg) AND hand on the handle side (|azimuth| <= 45 deg) AND >= 2 fingers closed.
Cup transfer: bottom clear (palm_z >= 0.05) AND approach roughly perpendicular to the table
(elevation >= 35 deg) AND palm contact (palm to body <= 0.035 m) AND firm closure (>= 2 fingers
closed and mean closure >= 0.9 rad).
Cup handover: handle space left for the receiver (<= 2 fingers closed) AND wrist turned
(|roll - pi| <= 0.8 rad) AND finger-dominant (palm to body >= 0.015 m).
Flashlight usage (shining): from above (elevation >= 50 deg) AND palm over the switch
(|palm_x - 0.04| <= 0.035 m) AND thumb at the switch (thumb direction . +y >= 0.5, thumb closed).
Flashlight transfer: balanced (|palm_x - 0| <= 0.035 m) AND palm contact (palm to body <= 0.03 m)
AND firm closure.
Flashlight handover: tail end left free for the receiver (palm_x >= 0.015 m) AND wrist turned
AND finger-dominant (palm to body >= 0.015 m).

The bands between the thresholds (elevation 35..50 deg, palm height 0.05..0.08 m, palm distance
0.015..0.035 m, exactly 2 closed fingers, palm_x 0.015..0.035 m ...) are where common poses live, so
all seven task sets U, T, H, UT, UH, TH, UTH are reachable for both objects.

Prototypes and noise
--------------------
:data:`CUP_PROTOTYPES` and :data:`FLASHLIGHT_PROTOTYPES` give one or more prototype grasps (styles)
per task set; a demonstration draws a style uniformly, then perturbs every parameter with
:class:`Noise` (aim 6 mm, azimuth 10 deg, elevation 5 deg, standoff 5 mm, roll 0.3 rad, closures
0.12 rad). The grasps that serve two tasks sit in the threshold bands between the single-task ones. This
keeps the zones of a model distinguishable but overlapping, which is what lets the planner blend them
(paper Tables II-VI).

Every demonstration is one a MICO can take (:func:`generate` drops the others): the open hand clear of the
table and the object along its 8 cm approach (:mod:`grasp_intent_ros.mico.collision`), and, with the object at
its default pose (:func:`~grasp_intent_ros.mico.frames.default_base_T_obj`), a grasp the arm reaches from home:
IK converges, the approach corridor is followed, and a proportional Cartesian servo from home brings the hand to
the pre-grasp and the grasp, and to the grasp straight, without crossing the wrist singularity or stopping at a
joint limit
(:class:`~grasp_intent_ros.mico.reach.ArmReach`). The open hand reaches some 5.5 cm ahead of the palm centre
and spreads 8-9 cm to each side, and at the default pose the arm stands on the cup's handle side, a little to its
-y; so the prototypes are shaped by both: the cup's low side grasps at the handle hold the thumb sideways (thumb
up or down puts fingers or thumb under the table) and come from either side of the handle (:func:`_both_sides`);
its handover grasps come high (over the rim's height) from the arm's side; its grasps that serve usage with
transfer or handover come from the arm's side of the handle root (a wrist turned at the handle, the thumb level,
needs the hand along the cup's side: the mirror image, from +y, is out of reach, and a hand between the arm and
the cup folds the arm against its joint limits); every flashlight grasp comes from above with the palm 2.5-3 cm
over the body, the thumb across it. The bands the rules leave for the cup's usage with transfer or handover are
narrow for such a hand and arm, so fewer of their draws are kept.

One module: the objects' geometry, their rules and the prototypes sampled against them are one
specification (the paper's Table I), read together.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import DataError, InvalidFeaturesError
from ..method.body import Box, Cylinder, ObjectBody
from ..method.data import Demonstrations
from ..method.features import APPROACH, FINGERS, MICO_3F, PALM, ROLL, FeatureSpace
from ..method.intent import DEFAULT_TASKS, all_zones, zone_label
from ..method.model import GraspModel
from ..mico.collision import HandCollision
from ..mico.frames import default_base_T_obj, features_to_obj_T_ee
from ..mico.kinematics import MicoKinematics
from ..mico.reach import ArmReach

__all__ = [
    'CLOSED',
    'FIRM_MEAN_CLOSURE',
    'Cup',
    'Flashlight',
    'CUP',
    'FLASHLIGHT',
    'Condition',
    'TaskRule',
    'Prototype',
    'Noise',
    'ObjectRules',
    'DEMO_NOISE',
    'CUP_PROTOTYPES',
    'FLASHLIGHT_PROTOTYPES',
    'CUP_RULES',
    'FLASHLIGHT_RULES',
    'OBJECTS',
    'object_of',
    'DEFAULT_COUNT',
    'TURNED_ROLL_TOLERANCE',
    'cup_rules',
    'flashlight_rules',
    'approach_elevation',
    'palm_azimuth',
    'closed_fingers',
    'mean_closure',
    'roll_offset',
    'thumb_direction',
    'firm_closure',
    'wrist_turned',
    'grasp_features',
    'sample_grasp',
    'taken',
    'generate',
]

CLOSED = 0.8
"""A finger counts as closed at this closure or more (rad; fully closed is 1.51)."""

FIRM_MEAN_CLOSURE = 0.9
"""Mean finger closure (rad) of a firm grasp."""

TURNED_ROLL_TOLERANCE = 0.8
"""How far (rad) the roll may be from pi for the wrist to count as turned by about 180 degrees."""

DEFAULT_COUNT = 80
"""Default number of demonstrations per task set."""


def _csv_precision(x: NDArray[np.float64]) -> NDArray[np.float64]:
    # data.save_csv writes '%.6f': label the values the CSV will hold, so a reloaded set keeps its labels
    return np.array([float(f'{v:.6f}') for v in x])


# ---------------------------------------------------------------------------------------- helpers
def _features(x: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(x, dtype=np.float64)
    if arr.shape != (MICO_3F.dim,) or not np.all(np.isfinite(arr)):
        raise InvalidFeaturesError(f'x must be a finite vector of shape ({MICO_3F.dim},), got {arr.shape}')
    return arr


def approach_elevation(x: ArrayLike) -> float:
    """Angle of the palm approach direction below the horizontal (rad), in [-pi/2, pi/2].

    0: approach parallel to the table; pi/2: straight down from above; negative: from below.
    """
    a = _features(x)[APPROACH]
    norm = float(np.linalg.norm(a))
    if norm == 0.0:
        raise InvalidFeaturesError('the approach direction is the zero vector')
    return math.asin(max(-1.0, min(1.0, -float(a[2]) / norm)))


def palm_azimuth(x: ArrayLike) -> float:
    """Azimuth of the palm centre about the object's z axis, atan2(y, x) (rad, in (-pi, pi])."""
    p = _features(x)[PALM]
    return math.atan2(float(p[1]), float(p[0]))


def closed_fingers(x: ArrayLike, threshold: float = CLOSED) -> int:
    """Number of fingers whose closure is at least ``threshold`` (rad)."""
    return int(np.count_nonzero(_features(x)[FINGERS] >= threshold))


def mean_closure(x: ArrayLike) -> float:
    """Mean closure of the three fingers (rad)."""
    return float(np.mean(_features(x)[FINGERS]))


def roll_offset(x: ArrayLike, target: float) -> float:
    """Roll minus ``target``, wrapped to [-pi, pi) (rad)."""
    diff = float(_features(x)[ROLL]) - target
    return (diff + math.pi) % (2.0 * math.pi) - math.pi


def thumb_direction(x: ArrayLike) -> NDArray[np.float64]:
    """Unit direction of the thumb (finger 1) in the object frame, shape (3,).

    The end effector's x axis of :func:`grasp_intent_ros.mico.frames.features_to_obj_T_ee`, so that the rules judge
    the hand the robot will actually form. For an approach from above, roll is then the thumb's heading in the
    table plane: roll 0 points it along +x, pi/2 along +y.
    """
    out: NDArray[np.float64] = features_to_obj_T_ee(_features(x))[:3, 0].copy()
    return out


def firm_closure(x: ArrayLike) -> bool:
    """At least two fingers closed and a mean closure of at least :data:`FIRM_MEAN_CLOSURE`."""
    return closed_fingers(x) >= 2 and mean_closure(x) >= FIRM_MEAN_CLOSURE


def wrist_turned(x: ArrayLike, tolerance: float = TURNED_ROLL_TOLERANCE) -> bool:
    """Wrist turned by about 180 degrees: |roll - pi| <= tolerance (rad, modulo 2 pi)."""
    return abs(roll_offset(x, math.pi)) <= tolerance


# ---------------------------------------------------------------------------------------- objects
@dataclass(frozen=True)
class Cup:
    """A cup with a handle on +x; lengths in m, angles in rad. Frame: centre of the base, +z up.

    The fields after the geometry are the thresholds of the cup's rules (see the module docstring).
    """

    radius: float = 0.04
    height: float = 0.10
    handle_z: tuple[float, float] = (0.025, 0.075)
    handle_reach: float = 0.03
    handle_bar: tuple[float, float] = (0.008, 0.012)
    """Thickness in the loop's plane and width across it (m) of the handle's three bars."""
    rim_palm_z_max: float = 0.08
    """Usage: the palm centre at most this high leaves the rim clear for drinking."""
    bottom_palm_z_min: float = 0.05
    """Transfer: the hand reaches ~4.5 cm below the palm centre; this high leaves the bottom clear."""
    usage_max_elevation: float = math.radians(50.0)
    transfer_min_elevation: float = math.radians(35.0)
    handle_side_half_angle: float = math.radians(45.0)
    contact_distance: float = 0.035
    """Transfer: palm centre at most this far from the body counts as palm contact."""
    finger_dominant_distance: float = 0.015
    """Handover: palm centre at least this far from the body leaves a finger-dominant grasp."""
    turned_roll_tolerance: float = TURNED_ROLL_TOLERANCE
    """Handover: |roll - pi| at most this counts as the wrist turned by about 180 degrees."""

    def body(self) -> ObjectBody:
        """The cup's solid parts: the cylinder, and the handle loop as three bars (top, outer, bottom).

        The bars leave the loop's opening free (where the usage rule wants the fingers); the top and bottom
        bars reach half a bar into the wall, so the loop is attached.
        """
        thick, width = self.handle_bar
        (z_low, z_high), outer = self.handle_z, self.radius + self.handle_reach
        inner = self.radius - 0.5 * thick
        half_bar = 0.5 * (outer - thick - inner)
        bars = (Box(centre=np.array([inner + half_bar, 0.0, z_high - 0.5 * thick]),
                    half_extents=np.array([half_bar, 0.5 * width, 0.5 * thick])),
                Box(centre=np.array([outer - 0.5 * thick, 0.0, 0.5 * (z_low + z_high)]),
                    half_extents=np.array([0.5 * thick, 0.5 * width, 0.5 * (z_high - z_low)])),
                Box(centre=np.array([inner + half_bar, 0.0, z_low + 0.5 * thick]),
                    half_extents=np.array([half_bar, 0.5 * width, 0.5 * thick])))
        return ObjectBody((Cylinder(centre=np.array([0.0, 0.0, 0.5 * self.height]), axis=np.array([0.0, 0.0, 1.0]),
                                    radius=self.radius, length=self.height), *bars))

    def palm_to_body(self, x: ArrayLike) -> float:
        """Distance (m) from the palm centre to the cup's body (solid cylinder, handle excluded)."""
        p = _features(x)[PALM]
        radial = max(math.hypot(float(p[0]), float(p[1])) - self.radius, 0.0)
        vertical = max(float(p[2]) - self.height, -float(p[2]), 0.0)
        return math.hypot(radial, vertical)

    # usage (drinking)
    def rim_clear(self, x: ArrayLike) -> bool:
        """Palm low enough to leave the rim clear: palm_z <= rim_palm_z_max."""
        return float(_features(x)[2]) <= self.rim_palm_z_max

    def parallel_to_table(self, x: ArrayLike) -> bool:
        """Palm direction roughly parallel to the table: elevation <= usage_max_elevation."""
        return approach_elevation(x) <= self.usage_max_elevation

    def on_handle_side(self, x: ArrayLike) -> bool:
        """Hand on the handle side: |palm azimuth| <= handle_side_half_angle."""
        return abs(palm_azimuth(x)) <= self.handle_side_half_angle

    def fingers_on_handle(self, x: ArrayLike) -> bool:
        """At least two fingers closed (on the handle)."""
        return closed_fingers(x) >= 2

    # transfer
    def bottom_clear(self, x: ArrayLike) -> bool:
        """Palm high enough to leave the bottom clear: palm_z >= bottom_palm_z_min."""
        return float(_features(x)[2]) >= self.bottom_palm_z_min

    def perpendicular_to_table(self, x: ArrayLike) -> bool:
        """Palm roughly perpendicular to the table (from above): elevation >= transfer_min_elevation."""
        return approach_elevation(x) >= self.transfer_min_elevation

    def palm_contact(self, x: ArrayLike) -> bool:
        """Palm centre close to the body: palm_to_body <= contact_distance."""
        return self.palm_to_body(x) <= self.contact_distance

    # handover
    def wrist_turned(self, x: ArrayLike) -> bool:
        """Wrist turned by about 180 degrees: |roll - pi| <= turned_roll_tolerance."""
        return wrist_turned(x, self.turned_roll_tolerance)

    def handle_left_free(self, x: ArrayLike) -> bool:
        """Few fingers in the handle, room for the receiver: at most two fingers closed."""
        return closed_fingers(x) <= 2

    def finger_dominant(self, x: ArrayLike) -> bool:
        """Palm away from the body: palm_to_body >= finger_dominant_distance."""
        return self.palm_to_body(x) >= self.finger_dominant_distance


@dataclass(frozen=True)
class Flashlight:
    """A flashlight lying on the table along x, head (lens) at +x; lengths in m, angles in rad.

    Frame: on the table directly below the centre of mass, +z up. The switch is on the +y side.
    """

    radius: float = 0.02
    length: float = 0.20
    switch_x: float = 0.04
    switch_half_extents: tuple[float, float, float] = (0.008, 0.003, 0.005)
    """The switch, a box on the +y side at x = switch_x, axis height (m); it stands 4 mm proud of the body."""
    centre_of_mass_x: float = 0.0
    usage_min_elevation: float = math.radians(50.0)
    switch_reach: float = 0.035
    """Usage: |palm_x - switch_x| at most this puts the hand over the switch."""
    thumb_alignment: float = 0.5
    """Usage: the thumb direction's +y component (towards the switch) at least this (cos 60 deg)."""
    balance_reach: float = 0.035
    """Transfer: |palm_x - centre_of_mass_x| at most this is a balanced grasp."""
    contact_distance: float = 0.03
    finger_dominant_distance: float = 0.015
    free_end_palm_x_min: float = 0.015
    """Handover: palm_x at least this leaves the tail half free for the receiver."""
    turned_roll_tolerance: float = TURNED_ROLL_TOLERANCE
    """Handover: |roll - pi| at most this counts as the wrist turned by about 180 degrees."""

    def body(self) -> ObjectBody:
        """The flashlight's solid parts: the cylinder and the switch on its +y side."""
        half = np.array(self.switch_half_extents)
        proud = 0.004
        return ObjectBody((Cylinder(centre=np.array([0.0, 0.0, self.radius]), axis=np.array([1.0, 0.0, 0.0]),
                                    radius=self.radius, length=self.length),
                           Box(centre=np.array([self.switch_x, self.radius + proud - half[1], self.radius]),
                               half_extents=half)))

    def palm_to_body(self, x: ArrayLike) -> float:
        """Distance (m) from the palm centre to the body (solid cylinder along x, axis at z = radius)."""
        p = _features(x)[PALM]
        radial = max(math.hypot(float(p[1]), float(p[2]) - self.radius) - self.radius, 0.0)
        axial = max(abs(float(p[0])) - 0.5 * self.length, 0.0)
        return math.hypot(radial, axial)

    # usage (shining light on a workspace)
    def from_above(self, x: ArrayLike) -> bool:
        """Grasp from above, perpendicular to the table: elevation >= usage_min_elevation."""
        return approach_elevation(x) >= self.usage_min_elevation

    def over_switch(self, x: ArrayLike) -> bool:
        """Palm over the switch: |palm_x - switch_x| <= switch_reach."""
        return abs(float(_features(x)[0]) - self.switch_x) <= self.switch_reach

    def thumb_at_switch(self, x: ArrayLike) -> bool:
        """Thumb towards the switch side (+y component >= thumb_alignment) and closed on it."""
        arr = _features(x)
        return bool(thumb_direction(arr)[1] >= self.thumb_alignment and arr[FINGERS][0] >= CLOSED)

    # transfer
    def balanced(self, x: ArrayLike) -> bool:
        """Grasp near the centre of mass: |palm_x - centre_of_mass_x| <= balance_reach."""
        return abs(float(_features(x)[0]) - self.centre_of_mass_x) <= self.balance_reach

    def palm_contact(self, x: ArrayLike) -> bool:
        """Palm centre close to the body: palm_to_body <= contact_distance."""
        return self.palm_to_body(x) <= self.contact_distance

    # handover
    def wrist_turned(self, x: ArrayLike) -> bool:
        """Wrist turned by about 180 degrees: |roll - pi| <= turned_roll_tolerance."""
        return wrist_turned(x, self.turned_roll_tolerance)

    def end_left_free(self, x: ArrayLike) -> bool:
        """Hand towards the head, tail end free for the receiver: palm_x >= free_end_palm_x_min."""
        return float(_features(x)[0]) >= self.free_end_palm_x_min

    def finger_dominant(self, x: ArrayLike) -> bool:
        """Palm away from the body: palm_to_body >= finger_dominant_distance."""
        return self.palm_to_body(x) >= self.finger_dominant_distance


CUP = Cup()
FLASHLIGHT = Flashlight()


# ---------------------------------------------------------------------------------------- rules
Condition = Callable[[ArrayLike], bool]


@dataclass(frozen=True)
class TaskRule:
    """A task's rule: satisfied when every named condition holds."""

    task: str
    conditions: tuple[tuple[str, Condition], ...]

    def __call__(self, x: ArrayLike) -> bool:
        """True when x satisfies every condition."""
        return all(cond(x) for _, cond in self.conditions)

    def check(self, x: ArrayLike) -> dict[str, bool]:
        """Each condition's verdict, by name."""
        return {name: bool(cond(x)) for name, cond in self.conditions}


@dataclass(frozen=True)
class Prototype:
    """A person's intended grasp for one task set, in the object frame.

    Attributes
    ----------
    aim : tuple of 3 float
        Point on the object the approach points at (m).
    azimuth : float
        Side the hand comes from, about the object's z axis (rad; 0 = +x).
    elevation : float
        Approach angle below the horizontal (rad; pi/2 = from straight above).
    standoff : float
        Palm centre to the aim point, along the approach (m).
    roll : float
        Wrist roll (rad).
    closures : tuple of 3 float
        Finger closures (rad).
    """

    aim: tuple[float, float, float]
    azimuth: float
    elevation: float
    standoff: float
    roll: float
    closures: tuple[float, float, float]


@dataclass(frozen=True)
class Noise:
    """Standard deviations of a person's deviation from a prototype (m, rad)."""

    aim: float = 0.006
    azimuth: float = math.radians(10.0)
    elevation: float = math.radians(5.0)
    standoff: float = 0.005
    roll: float = 0.3
    closure: float = 0.12


@dataclass(frozen=True)
class ObjectRules:
    """Everything needed to generate and label demonstrations for one object.

    Attributes
    ----------
    name : str
        The object, e.g. 'cup'; the data set's file stem.
    task_names : tuple of str, length m
    rules : tuple of TaskRule, length m
        One rule per task, in task order.
    prototypes : mapping int -> tuple of Prototype
        Prototype grasps per task set (bitmask), one per demonstration style (people demonstrate the
        same task set in different ways); every non-empty task set has at least one.
    noise : Noise
    body : ObjectBody or None
        The object's solid body, stored with the models trained on these demonstrations.
    """

    name: str
    task_names: tuple[str, ...]
    rules: tuple[TaskRule, ...]
    prototypes: Mapping[int, tuple[Prototype, ...]]
    noise: Noise = field(default_factory=Noise)
    body: ObjectBody | None = None

    def label(self, x: ArrayLike) -> int:
        """Bitmask of the tasks whose rule x satisfies (0: none)."""
        arr = _features(x)
        return sum(1 << i for i, rule in enumerate(self.rules) if rule(arr))

    def explain(self, x: ArrayLike) -> dict[str, dict[str, bool]]:
        """Every condition's verdict, by task and condition name."""
        arr = _features(x)
        return {rule.task: rule.check(arr) for rule in self.rules}


_DEG = math.pi / 180.0
_U, _T, _H = 1, 2, 4

DEMO_NOISE = Noise()
"""Noise of a person moving the arm to a prototype grasp (used for both objects)."""


def cup_rules(cup: Cup = CUP) -> tuple[TaskRule, TaskRule, TaskRule]:
    """The cup's usage (drinking), transfer and handover rules (paper Table I)."""
    return (
        TaskRule('usage', (('rim clear', cup.rim_clear),
                           ('palm parallel to the table', cup.parallel_to_table),
                           ('hand on the handle side', cup.on_handle_side),
                           ('>= 2 fingers on the handle', cup.fingers_on_handle))),
        TaskRule('transfer', (('bottom clear', cup.bottom_clear),
                              ('palm perpendicular to the table', cup.perpendicular_to_table),
                              ('palm contact', cup.palm_contact),
                              ('firm closure', firm_closure))),
        TaskRule('handover', (('handle left free', cup.handle_left_free),
                              ('wrist turned', cup.wrist_turned),
                              ('finger-dominant', cup.finger_dominant))),
    )


def flashlight_rules(light: Flashlight = FLASHLIGHT) -> tuple[TaskRule, TaskRule, TaskRule]:
    """The flashlight's usage (shining light on a workspace), transfer and handover rules."""
    return (
        TaskRule('usage', (('from above', light.from_above),
                           ('over the switch', light.over_switch),
                           ('thumb at the switch', light.thumb_at_switch))),
        TaskRule('transfer', (('balanced', light.balanced),
                              ('palm contact', light.palm_contact),
                              ('firm closure', firm_closure))),
        TaskRule('handover', (('tail end left free', light.end_left_free),
                              ('wrist turned', light.wrist_turned),
                              ('finger-dominant', light.finger_dominant))),
    )


def _one_open(closed: float, opened: float) -> tuple[tuple[float, float, float], ...]:
    """Closures with exactly one finger left open, each finger in turn."""
    return ((opened, closed, closed), (closed, opened, closed), (closed, closed, opened))


# Cup aim points (object frame, m): lower part of the handle, centre of the rim.
_HANDLE_LOW = (0.055, 0.0, 0.040)
_RIM = (0.0, 0.0, 0.100)
_CUP_CLOSED = (1.20, 1.20, 1.05)  # the third finger rests a little more open, under the handle
_TURNED = (math.pi - 0.35, math.pi + 0.35)
_THUMB_SIDEWAYS = 1.8
"""Roll of a low side grasp that keeps every open finger above the table: the thumb sideways, tilted up a little
(the open hand spans some 17 cm across the thumb; thumb up or down would put fingers or thumb under the table)."""



def _both_sides(*styles: Prototype) -> tuple[Prototype, ...]:
    """Each style, then its mirror image across the object's xz-plane.

    The mirror negates the aim's y, the azimuth and the roll (taken in [0, 2 pi)): the hand is symmetric about
    the plane of its thumb and approach, and so are the rules.
    """
    return styles + tuple(Prototype((p.aim[0], -p.aim[1], p.aim[2]), -p.azimuth, p.elevation, p.standoff,
                                    2.0 * math.pi - p.roll, p.closures) for p in styles)


CUP_PROTOTYPES: dict[int, tuple[Prototype, ...]] = {
    # Usage: on the lower handle from the side (a little from one side of it), fingers wrapped round it, the
    # thumb sideways: a hand low at the handle with the thumb up or down puts open fingers under the table.
    _U: _both_sides(Prototype(_HANDLE_LOW, 20 * _DEG, 25 * _DEG, 0.065, _THUMB_SIDEWAYS, _CUP_CLOSED),
                    Prototype((0.050, 0.0, 0.050), 20 * _DEG, 25 * _DEG, 0.050, _THUMB_SIDEWAYS, _CUP_CLOSED)),
    # Transfer: from above onto the rim, palm on the cup; the roll is free from above.
    _T: (Prototype(_RIM, 0.0, 80 * _DEG, 0.015, 0.0, _CUP_CLOSED),
         Prototype(_RIM, 0.0, 80 * _DEG, 0.015, math.pi, _CUP_CLOSED)),
    # Handover: high over the handle, above the rim's height (not low enough to drink), tilted from the arm's
    # side, wrist turned, two fingers closed: the handle is left free.
    _H: (Prototype((0.063, -0.040, 0.119), -29 * _DEG, 45 * _DEG, 0.017, 3.19, (1.20, 1.20, 0.60)),
         Prototype((0.072, 0.026, 0.104), -4 * _DEG, 57 * _DEG, 0.036, 2.92, (1.20, 1.20, 0.60))),
    # Usage and transfer: tilted (about 40-47 deg) onto the arm's side of the handle root, palm touching the cup,
    # all fingers closed, the thumb sideways and up: the narrow pose where the open hand clears the table, the
    # handle and the wall at once and the arm's wrist keeps its side.
    _U | _T: tuple(Prototype(aim, az * _DEG, el * _DEG, standoff, roll, _CUP_CLOSED)
                   for aim, az, el, standoff, roll in (((0.051, -0.023, 0.062), -29, 42, 0.025, 4.55),
                                                       ((0.049, -0.025, 0.057), -24, 47, 0.025, 4.25),
                                                       ((0.051, -0.026, 0.065), -18, 39, 0.020, 4.65),
                                                       ((0.046, -0.027, 0.060), -30, 43, 0.025, 4.46))),
    # Usage and handover: low in front of the handle, coming along the cup's side from the arm's side (the
    # thumb level, so no open finger goes under the table), palm off the cup, wrist turned, two fingers in
    # the handle.
    _U | _H: (Prototype((0.089, -0.050, 0.061), -85 * _DEG, 3 * _DEG, 0.036, 3.38, (1.20, 0.60, 1.20)),
              Prototype((0.086, -0.060, 0.055), -86 * _DEG, 18 * _DEG, 0.026, 3.25, (1.20, 0.60, 1.20)),
              Prototype((0.075, -0.054, 0.068), -89 * _DEG, 19 * _DEG, 0.021, 3.20, (1.20, 1.20, 0.60))),
    # Transfer and handover: from above a little off the rim, wrist turned (less precisely than at
    # the handle), two fingers firmly closed, whichever finger is left open.
    _T | _H: tuple(Prototype(_RIM, 0.0, 80 * _DEG, 0.025, roll, closures)
                   for closures in _one_open(1.25, 0.60) for roll in _TURNED),
    # All: tilted (about 43 deg) onto the arm's side of the handle root along the cup's side, palm near the cup,
    # wrist turned (the thumb level), two fingers firmly closed, whichever finger is left open.
    _U | _T | _H: tuple(Prototype((0.054, -0.034, 0.060), -88 * _DEG, 43 * _DEG, 0.021, 3.44, closures)
                        for closures in _one_open(1.25, 0.60)),
}
"""Cup prototype grasps per task set: (aim, azimuth, elevation, standoff, roll, closures)."""

# Flashlight: every grasp from (nearly) straight above, the palm centre 2.5-3 cm above the body's top
# (z = 0.04): the open fingers reach some 5.5 cm below the palm and spread 8-9 cm to the sides, so a lower or
# a side grasp of a body 4 cm tall puts them under the table.
_F_CLOSED = (1.20, 1.20, 1.20)
_F_TOP = 0.040
_F_ELEVATION = 88 * _DEG
_F_STANDOFF = 0.027
_FROM_MINUS_Y, _FROM_PLUS_Y = -90 * _DEG, 90 * _DEG
_THUMB_Y = math.pi / 2
"""Roll that heads the thumb along +y (onto the switch) for a grasp from above."""
_THUMB_Y_TURNED = 2.45
"""Roll inside both the thumb-at-the-switch band (thumb . y = 0.64 >= 0.5) and the wrist-turned band
(|roll - pi| = 0.69 <= 0.8): usage and handover at once."""
_THUMB_MINUS_Y_TURNED = 2.0 * math.pi - _THUMB_Y_TURNED
"""The wrist turned the other way (thumb . y = -0.64): turned, the thumb away from the switch and across the body
(a thumb along the body, roll pi, drives the open fingers into it)."""


def _from_above(palm_x: float, roll: float, *, azimuth: float = _FROM_MINUS_Y, extra: float = 0.0) -> Prototype:
    """A flashlight grasp from above at ``palm_x`` (m), ``extra`` (m) higher than the usual standoff."""
    return Prototype((palm_x, 0.0, _F_TOP), azimuth, _F_ELEVATION, _F_STANDOFF + extra, roll, _F_CLOSED)


FLASHLIGHT_PROTOTYPES: dict[int, tuple[Prototype, ...]] = {
    # Usage: from above over the switch, the thumb heading +y onto it.
    _U: (_from_above(0.060, _THUMB_Y),),
    # Transfer: from above just behind the centre of mass, palm near the body; the thumb across it.
    _T: (_from_above(-0.010, _THUMB_Y), _from_above(-0.010, 1.2, azimuth=_FROM_PLUS_Y)),
    # Handover: from above at the head, wrist turned, palm off the body; the tail is left free.
    _H: (_from_above(0.075, _THUMB_MINUS_Y_TURNED, extra=0.004),),
    # Usage and transfer: from above between switch and centre of mass, the thumb onto the switch.
    _U | _T: (_from_above(0.020, _THUMB_Y),),
    # Usage and handover: from above over the switch, wrist turned with the thumb still at it, palm off the body.
    _U | _H: (_from_above(0.060, _THUMB_Y_TURNED, extra=0.004),),
    # Transfer and handover: from above just ahead of the centre of mass, wrist turned.
    _T | _H: (_from_above(0.025, _THUMB_MINUS_Y_TURNED),),
    # All: from above just ahead of the centre of mass, wrist turned with the thumb at the switch.
    _U | _T | _H: (_from_above(0.025, _THUMB_Y_TURNED),),
}
"""Flashlight prototype grasps per task set."""

CUP_RULES = ObjectRules(name='cup', task_names=DEFAULT_TASKS, rules=cup_rules(CUP),
                        prototypes=CUP_PROTOTYPES, noise=DEMO_NOISE, body=CUP.body())
"""Cup rules and prototypes (tasks usage = drinking, transfer, handover)."""

FLASHLIGHT_RULES = ObjectRules(name='flashlight', task_names=DEFAULT_TASKS,
                               rules=flashlight_rules(FLASHLIGHT), prototypes=FLASHLIGHT_PROTOTYPES,
                               noise=DEMO_NOISE, body=FLASHLIGHT.body())
"""Flashlight rules and prototypes (tasks usage = shining light on a workspace, transfer, handover)."""

OBJECTS: dict[str, ObjectRules] = {'cup': CUP_RULES, 'flashlight': FLASHLIGHT_RULES}
"""The objects this module can generate demonstrations for, by name."""


def object_of(model: GraspModel) -> ObjectRules | None:
    """The rules of the object a model's document names (``object``); None if unknown.

    None for a model that names no object, or one this module does not know. The one rule for every reader (the
    viewer's scene, the session report, the benchmarks, the tests).
    """
    return OBJECTS.get(model.object_name) if model.object_name else None


# ---------------------------------------------------------------------------------------- sampling
def grasp_features(aim: ArrayLike, azimuth: float, elevation: float, standoff: float, roll: float,
                   closures: ArrayLike) -> NDArray[np.float64]:
    """Feature vector of a grasp that approaches ``aim`` from (azimuth, elevation) at ``standoff``.

    approach = -(cos e cos az, cos e sin az, sin e) (unit, pointing at the object);
    palm = aim - standoff * approach. Shape (10,).
    """
    ce, se = math.cos(elevation), math.sin(elevation)
    approach = -np.array([ce * math.cos(azimuth), ce * math.sin(azimuth), se])
    palm = np.asarray(aim, dtype=np.float64) - standoff * approach
    return np.concatenate([palm, approach, [roll], np.asarray(closures, dtype=np.float64)])


def sample_grasp(proto: Prototype, noise: Noise, rng: np.random.Generator) -> NDArray[np.float64]:
    """One demonstration near ``proto``: every prototype parameter perturbed by Gaussian noise."""
    aim = np.asarray(proto.aim) + rng.normal(0.0, noise.aim, 3)
    azimuth = proto.azimuth + rng.normal(0.0, noise.azimuth)
    elevation = proto.elevation + rng.normal(0.0, noise.elevation)
    standoff = max(0.0, proto.standoff + rng.normal(0.0, noise.standoff))
    roll = proto.roll + rng.normal(0.0, noise.roll)
    closures = np.asarray(proto.closures) + rng.normal(0.0, noise.closure, 3)
    return grasp_features(aim, azimuth, elevation, standoff, roll, closures)


def _in_bounds(x: NDArray[np.float64], features: FeatureSpace) -> bool:
    return bool(np.all(x >= features.lower) and np.all(x <= features.upper))


def taken(rules: ObjectRules, x: NDArray[np.float64], *, hand: HandCollision | None = None,
          arm: ArmReach | None = None) -> bool:
    """Whether the MICO takes grasp x of ``rules``' object: what :func:`generate` asks of a demonstration.

    The open hand clear of the table and ``rules.body`` along the approach
    (:meth:`~grasp_intent_ros.mico.grasp_clearance.Clearance.fault`), and the arm reaches it from home with the object
    at its default pose (:meth:`~grasp_intent_ros.mico.reach.ArmReach.fault`). ``hand`` and ``arm``: as
    :func:`generate`'s.
    """
    robot = hand if hand is not None else _default_hand()
    reach = arm if arm is not None else _default_arm()
    return robot.clearance(x, rules.body).fault() is None and reach.fault(x) is None


@functools.cache
def _default_hand() -> HandCollision:
    """The hand of the default URDF; one per process."""
    return HandCollision()


@functools.cache
def _default_arm() -> ArmReach:
    """The MICO of the default URDF at home, the object at its default pose; one per process (its verdicts kept)."""
    return ArmReach(MicoKinematics(), default_base_T_obj())


def generate(rules: ObjectRules, count: int = DEFAULT_COUNT, *, seed: int = 0, hand: HandCollision | None = None,
             arm: ArmReach | None = None, max_draws_per_demo: int = 200) -> Demonstrations:
    """Sample and label demonstrations a MICO can take until every task set has exactly ``count`` of them.

    Sampling cycles over the task sets that are still short, draws a grasp near that set's prototype,
    rounds it to the CSV precision, drops it when it leaves the feature bounds, labels it by the rules
    and keeps it when its (possibly different) task set is still short, the hand takes it and the arm reaches it:
    the open hand clear of the table (the plane the object stands on, z = 0) and of ``rules.body`` along the
    approach (:meth:`~grasp_intent_ros.mico.grasp_clearance.Clearance.fault` under the planner's
    :data:`~grasp_intent_ros.mico.collision.LIMITS`; a closing finger that stops on the table or the object
    is kept), and the arm at home takes the grasp with the object at its default pose
    (:meth:`~grasp_intent_ros.mico.reach.ArmReach.fault`: IK from home, the approach corridor, and a Cartesian
    servo from home to the pre-grasp and the grasp, and one to the grasp straight, that converge; 0.2-0.4 s a
    kept grasp). Rows are
    ordered by task set (core zone order), then by draw. Fully determined by ``seed``.

    Parameters
    ----------
    rules : ObjectRules
    count : int >= 1
        Demonstrations per task set.
    seed : int
        Seed of the numpy Generator.
    hand : HandCollision, optional
        The hand that must take every demonstration; None: the MICO of the default URDF.
    arm : ArmReach, optional
        The arm that must reach every demonstration; None: the MICO of the default URDF at
        :data:`~grasp_intent_ros.mico.kinematics.HOME_Q`, the object at
        :func:`~grasp_intent_ros.mico.frames.default_base_T_obj`.
    max_draws_per_demo : int
        Give up after ``max_draws_per_demo * count * n_sets`` draws.

    Returns
    -------
    Demonstrations
        ``count * (2^m - 1)`` rows, features in ``MICO_3F`` bounds, unit approach (to 1e-5).

    Raises
    ------
    DataError
        If count < 1, a task set has no prototype, or some task set cannot be filled with grasps the hand takes
        and the arm reaches.
    """
    if not isinstance(count, (int, np.integer)) or count < 1:
        raise DataError(f'count must be a positive integer, got {count!r}')
    sets = all_zones(len(rules.task_names))
    missing = [zone_label(z, rules.task_names) for z in sets if not rules.prototypes.get(z)]
    if missing:
        raise DataError(f'{rules.name}: no prototype for task sets {missing}')
    rng = np.random.default_rng(seed)
    kept: dict[int, list[NDArray[np.float64]]] = {z: [] for z in sets}
    budget = max_draws_per_demo * count * len(sets)
    draws = 0
    while True:
        short = [z for z in sets if len(kept[z]) < count]
        if not short:
            break
        for intended in short:
            draws += 1
            if draws > budget:
                have = {zone_label(z, rules.task_names): len(kept[z]) for z in sets}
                raise DataError(f'{rules.name}: gave up after {budget} draws; demonstrations per task '
                                f'set: {have}')
            styles = rules.prototypes[intended]
            proto = styles[int(rng.integers(len(styles)))] if len(styles) > 1 else styles[0]
            x = _csv_precision(sample_grasp(proto, rules.noise, rng))
            if not _in_bounds(x, MICO_3F):
                continue
            label = rules.label(x)
            if label and len(kept[label]) < count and taken(rules, x, hand=hand, arm=arm):
                kept[label].append(x)
    x_all = np.array([x for z in sets for x in kept[z]])
    labels = np.array([z for z in sets for _ in kept[z]], dtype=np.int64)
    return Demonstrations(x_all, labels, rules.task_names, MICO_3F)
