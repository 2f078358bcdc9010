"""The package's own exception types; every error a user can cause derives from GraspIntentError."""

__all__ = [
    'GraspIntentError',
    'InvalidIntentError',
    'InvalidFeaturesError',
    'ModelError',
    'ModelFormatError',
    'DataError',
    'PlanningError',
    'KinematicsError',
    'CommandError',
]


class GraspIntentError(ValueError):
    """Base class: a problem with input given to grasp_intent_ros."""


class InvalidIntentError(GraspIntentError):
    """An intent vector w (or a target vector v) is malformed: wrong length, non-finite, out of [0, 1]."""


class InvalidFeaturesError(GraspIntentError):
    """A grasp feature vector x has the wrong shape or non-finite values."""


class ModelError(GraspIntentError):
    """A grasp model cannot be built or used as asked (unknown zone, too little data, ...)."""


class ModelFormatError(ModelError):
    """A saved model document is malformed (missing field, wrong shape, non-positive-definite covariance).

    ``reason`` is the project's own name for what stopped a document's reader, whichever layer stopped it
    (libyaml's parser or this package): one of ``method.safe_yaml.DOCUMENT_REASONS``, which the message also
    contains; None for a problem with a field of a parsed document (the message names the field).
    """

    def __init__(self, message: str, *, reason: str | None = None) -> None:
        super().__init__(message)
        self.reason = reason


class DataError(GraspIntentError):
    """A demonstration data set is malformed (bad CSV header, non-0/1 task column, empty task set)."""


class PlanningError(GraspIntentError):
    """The planner was called with inputs it cannot plan for (e.g. v does not match the model's zones)."""


class KinematicsError(GraspIntentError):
    """A kinematic query cannot be answered (unknown frame, bad joint vector, unreachable target)."""


class CommandError(GraspIntentError):
    """A command to the arm (a joint trajectory, a twist) that a controller rejects."""
