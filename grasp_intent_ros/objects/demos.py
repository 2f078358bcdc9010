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
0.12 rad). Usage and transfer do not constrain the wrist roll, so those task sets are demonstrated both
thumb-up and with the wrist turned (only the handover rule asks for the turn); the grasps that serve
two tasks sit in the threshold bands between the single-task ones. This keeps the zones of a model
distinguishable but overlapping, which is what lets the planner blend them (paper Tables II-VI).

One module: the objects' geometry, their rules and the prototypes sampled against them are one
specification (the paper's Table I), read together.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import DataError, InvalidFeaturesError
from ..method.body import Cylinder, ObjectBody
from ..method.data import Demonstrations
from ..method.features import APPROACH, FINGERS, MICO_3F, PALM, ROLL, FeatureSpace
from ..method.intent import DEFAULT_TASKS, all_zones, zone_label
from ..mico.frames import features_to_obj_T_ee

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
        """The solid body the planner keeps the palm centre out of (the handle is a loop, not solid)."""
        return ObjectBody((Cylinder(centre=np.array([0.0, 0.0, 0.5 * self.height]), axis=np.array([0.0, 0.0, 1.0]),
                                    radius=self.radius, length=self.height),))

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
        """The solid body the planner keeps the palm centre out of."""
        return ObjectBody((Cylinder(centre=np.array([0.0, 0.0, self.radius]), axis=np.array([1.0, 0.0, 0.0]),
                                    radius=self.radius, length=self.length),))

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


# Cup aim points (object frame, m): lower part of the handle, handle root, centre of the rim.
_HANDLE_LOW = (0.055, 0.0, 0.040)
_HANDLE_ROOT = (0.045, 0.0, 0.050)
_RIM = (0.0, 0.0, 0.100)
_CUP_CLOSED = (1.20, 1.20, 1.05)  # the third finger rests a little more open, under the handle
_TURNED = (math.pi - 0.35, math.pi + 0.35)

CUP_PROTOTYPES: dict[int, tuple[Prototype, ...]] = {
    # Usage: on the lower handle from the side, fingers wrapped round it; thumb up, or the wrist
    # turned with all three fingers still in the handle (usage does not constrain the roll).
    _U: (Prototype(_HANDLE_LOW, 0.0, 22 * _DEG, 0.030, 0.0, _CUP_CLOSED),
         Prototype(_HANDLE_LOW, 0.0, 30 * _DEG, 0.030, math.pi, _CUP_CLOSED)),
    # Transfer: from above onto the rim, palm on the cup; the roll is free from above.
    _T: (Prototype(_RIM, 0.0, 80 * _DEG, 0.015, 0.0, _CUP_CLOSED),
         Prototype(_RIM, 0.0, 80 * _DEG, 0.015, math.pi, _CUP_CLOSED)),
    # Handover: low at the handle, wrist turned, only the thumb closed: the handle is left free.
    _H: (Prototype(_HANDLE_LOW, 0.0, 25 * _DEG, 0.030, math.pi, (1.20, 0.60, 0.60)),),
    # Usage and transfer: tilted onto the handle root, palm touching the cup, all fingers closed.
    _U | _T: (Prototype(_HANDLE_ROOT, 0.0, 42 * _DEG, 0.025, math.pi, _CUP_CLOSED),),
    # Usage and handover: low at the handle, wrist turned, two fingers in the handle.
    _U | _H: (Prototype(_HANDLE_LOW, 0.0, 25 * _DEG, 0.030, math.pi, (1.20, 1.20, 0.60)),),
    # Transfer and handover: from above a little off the rim, wrist turned (less precisely than at
    # the handle), two fingers firmly closed, whichever finger is left open.
    _T | _H: tuple(Prototype(_RIM, 0.0, 80 * _DEG, 0.025, roll, closures)
                   for closures in _one_open(1.25, 0.60) for roll in _TURNED),
    # All: tilted onto the handle root off the body, wrist turned, two fingers firmly closed.
    _U | _T | _H: tuple(Prototype(_HANDLE_ROOT, 0.0, 42 * _DEG, 0.030, roll, closures)
                        for closures in _one_open(1.25, 0.60) for roll in _TURNED),
}
"""Cup prototype grasps per task set: (aim, azimuth, elevation, standoff, roll, closures)."""

# Flashlight aim points: top of the body (z = 0.04) and its -y side (y = -0.02, z = 0.02).
_F_CLOSED = (1.20, 1.20, 1.20)
_FROM_MINUS_Y, _FROM_PLUS_Y = -90 * _DEG, 90 * _DEG
_THUMB_Y = math.pi / 2
"""Roll that heads the thumb along +y (onto the switch) for a grasp from above."""
_THUMB_Y_TURNED = 2.45
"""Roll inside both the thumb-at-the-switch band (thumb . y = 0.64 >= 0.5) and the wrist-turned band
(|roll - pi| = 0.69 <= 0.8): usage and handover at once."""

FLASHLIGHT_PROTOTYPES: dict[int, tuple[Prototype, ...]] = {
    # Usage: from above over the switch, the thumb heading +y onto it (roll pi/2): tilted from -y, or
    # from +y with the palm pressed on the body.
    _U: (Prototype((0.050, 0.0, 0.040), _FROM_MINUS_Y, 75 * _DEG, 0.030, _THUMB_Y, _F_CLOSED),
         Prototype((0.045, 0.0, 0.040), _FROM_PLUS_Y, 75 * _DEG, 0.010, _THUMB_Y, _F_CLOSED)),
    # Transfer: from the side just behind the centre of mass, palm on the body; roll free.
    _T: (Prototype((-0.015, -0.020, 0.020), _FROM_MINUS_Y, 20 * _DEG, 0.020, 0.0, _F_CLOSED),
         Prototype((-0.015, -0.020, 0.020), _FROM_MINUS_Y, 20 * _DEG, 0.020, math.pi, _F_CLOSED)),
    # Handover: from the side at the head, wrist turned, palm off the body; the tail is left free.
    _H: (Prototype((0.085, -0.020, 0.020), _FROM_MINUS_Y, 20 * _DEG, 0.035, math.pi, _F_CLOSED),),
    # Usage and transfer: from above between switch and centre of mass, palm pressed on the body.
    _U | _T: (Prototype((0.020, 0.0, 0.040), _FROM_PLUS_Y, 75 * _DEG, 0.010, _THUMB_Y, _F_CLOSED),),
    # Usage and handover: from above over the switch, wrist turned, palm off the body.
    _U | _H: (Prototype((0.050, 0.0, 0.040), _FROM_PLUS_Y, 75 * _DEG, 0.030, _THUMB_Y_TURNED, _F_CLOSED),),
    # Transfer and handover: from the side just ahead of the centre of mass, wrist turned.
    _T | _H: (Prototype((0.025, -0.020, 0.020), _FROM_MINUS_Y, 20 * _DEG, 0.022, math.pi, _F_CLOSED),),
    # All: from above just ahead of the centre of mass, wrist turned, palm lightly on the body.
    _U | _T | _H: (Prototype((0.025, 0.0, 0.040), _FROM_PLUS_Y, 75 * _DEG, 0.022, _THUMB_Y_TURNED,
                             _F_CLOSED),),
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


def generate(rules: ObjectRules, count: int = DEFAULT_COUNT, *, seed: int = 0,
             max_draws_per_demo: int = 200) -> Demonstrations:
    """Sample and label demonstrations until every task set has exactly ``count`` of them.

    Sampling cycles over the task sets that are still short, draws a grasp near that set's prototype,
    rounds it to the CSV precision, drops it when it leaves the feature bounds, labels it by the rules
    and keeps it when its (possibly different) task set is still short. Rows are ordered by task set
    (core zone order), then by draw. Fully determined by ``seed``.

    Parameters
    ----------
    rules : ObjectRules
    count : int >= 1
        Demonstrations per task set.
    seed : int
        Seed of the numpy Generator.
    max_draws_per_demo : int
        Give up after ``max_draws_per_demo * count * n_sets`` draws.

    Returns
    -------
    Demonstrations
        ``count * (2^m - 1)`` rows, features in ``MICO_3F`` bounds, unit approach (to 1e-5).

    Raises
    ------
    DataError
        If count < 1, a task set has no prototype, or some task set cannot be filled.
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
            if label and len(kept[label]) < count:
                kept[label].append(x)
    x_all = np.array([x for z in sets for x in kept[z]])
    labels = np.array([z for z in sets for _ in kept[z]], dtype=np.int64)
    return Demonstrations(x_all, labels, rules.task_names, MICO_3F)
