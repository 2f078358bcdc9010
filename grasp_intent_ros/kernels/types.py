"""The arrays the compiled kernels share, each set as one typed tuple (numba compiles NamedTuples as structs).

The public functions of :mod:`grasp_intent_ros.kernels` take the planner's arrays as they are and build
these; the compiled functions pass them on whole instead of as a dozen positional arguments.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ['Body', 'Mixture']


class Body(NamedTuple):
    """The object's body as a union of primitives (object frame, m), and the palm's margin to it.

    No primitive at all (every array of length 0) means no body.
    """

    kinds: NDArray[np.int64]
    """(M,): 0 a cylinder, 1 a box."""
    centres: NDArray[np.float64]
    """(M, 3)."""
    axes: NDArray[np.float64]
    """(M, 3): a cylinder's unit axis (zero for a box)."""
    perps: NDArray[np.float64]
    """(M, 3): a unit vector perpendicular to a cylinder's axis (zero for a box)."""
    radii: NDArray[np.float64]
    """(M,): a cylinder's radius."""
    lengths: NDArray[np.float64]
    """(M,): a cylinder's length."""
    halfs: NDArray[np.float64]
    """(M, 3): a box's half extents (zero for a cylinder)."""
    margin: float
    """The least distance (m) of a feasible palm from the body's surface."""


class Mixture(NamedTuple):
    """The model's K Gaussians over grasps x (d,).

    log(pi_k N_k(x)) = log_norm[k] - 1/2 (x - mu_k)^T prec[k] (x - mu_k).
    """

    means: NDArray[np.float64]
    """(K, d): mu_k."""
    prec: NDArray[np.float64]
    """(K, d, d): the precision matrices Sigma_k^-1."""
    log_norm: NDArray[np.float64]
    """(K,): log(pi_k) plus the Gaussian's log normaliser."""
