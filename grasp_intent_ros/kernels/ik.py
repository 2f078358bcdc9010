"""Inverse kinematics of a serial chain of revolute joints: the MICO's (MicoKinematics.ik).

The forward kinematics, the pose error as a 6-vector (position, rotation's log) and its Jacobian, and
the bounded damped descent to a target pose. 3-vectors and 3x3 products are written out (a BLAS call, or
a temporary array, costs more than the arithmetic at this size).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .linalg import _cholesky_solve

__all__ = ['ik_descent']


@njit(cache=True, nogil=True)
def _compose(A, B, out):
    """Fills out with A B for 3x3 matrices (out is neither)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(cache=True, nogil=True)
def _axis_rotation(axis, angle, out):
    """Fills out with the rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    s, c = math.sin(angle), math.cos(angle)
    x, y, z = axis[0], axis[1], axis[2]
    t = 1.0 - c
    out[0, 0], out[0, 1], out[0, 2] = c + t * x * x, t * x * y - s * z, t * x * z + s * y
    out[1, 0], out[1, 1], out[1, 2] = t * x * y + s * z, c + t * y * y, t * y * z - s * x
    out[2, 0], out[2, 1], out[2, 2] = t * x * z - s * y, t * y * z + s * x, c + t * z * z


@njit(cache=True, nogil=True)
def _chain_fk(q, rots, trans, axes, tip_rot, tip_trans, origins, zs):
    """World pose (R, p) of the tip; fills each joint's world origin and axis into ``origins``, ``zs``.

    Joint i sits at placement (rots[i], trans[i]) in joint i - 1's frame (the world for i = 0) and turns
    by q[i] about ``axes[i]`` (its own frame); the tip sits at (tip_rot, tip_trans) in the last joint's frame.
    """
    R = np.eye(3)
    p = np.zeros(3)
    M, T = np.empty((3, 3)), np.empty((3, 3))
    for i in range(q.size):
        for r in range(3):
            p[r] += R[r, 0] * trans[i, 0] + R[r, 1] * trans[i, 1] + R[r, 2] * trans[i, 2]
        _compose(R, rots[i], M)
        origins[i] = p
        for r in range(3):
            zs[i, r] = M[r, 0] * axes[i, 0] + M[r, 1] * axes[i, 1] + M[r, 2] * axes[i, 2]
        _axis_rotation(axes[i], q[i], T)
        _compose(M, T, R)
    for r in range(3):
        p[r] += R[r, 0] * tip_trans[0] + R[r, 1] * tip_trans[1] + R[r, 2] * tip_trans[2]
    _compose(R, tip_rot, M)
    return M, p


@njit(cache=True, nogil=True)
def _log3(E):
    """Rotation vector phi of a rotation matrix E (exp([phi]x) = E, |phi| <= pi), accurate near 0 and pi."""
    w = 0.5 * np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])  # sin(theta) n
    s = math.sqrt(np.sum(w * w))
    c = 0.5 * (E[0, 0] + E[1, 1] + E[2, 2] - 1.0)
    theta = math.atan2(s, c)
    if theta < 1e-8:
        return w
    if math.pi - theta > 1e-3:
        return w * (theta / s)
    # near pi: the axis from the symmetric part, n n^T = (sym(E) - c I) / (1 - c); its sign from w
    k = 0
    for i in range(1, 3):
        if E[i, i] > E[k, k]:
            k = i
    n = np.empty(3)
    for i in range(3):
        n[i] = 0.5 * (E[i, k] + E[k, i]) - (c if i == k else 0.0)
    n /= math.sqrt(np.sum(n * n))
    if np.sum(n * w) < 0.0:
        n = -n
    return theta * n


@njit(cache=True, nogil=True)
def _ik_residual(q, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, origins, zs):
    """Error e = (R^T (p_t - p), log3(R^T R_t)) of the tip pose (R, p) against the target, in the tip frame."""
    R, p = _chain_fk(q, rots, trans, axes, tip_rot, tip_trans, origins, zs)
    e = np.empty(6)
    d0, d1, d2 = p_t[0] - p[0], p_t[1] - p[1], p_t[2] - p[2]
    E = np.empty((3, 3))
    for i in range(3):
        e[i] = R[0, i] * d0 + R[1, i] * d1 + R[2, i] * d2
        for j in range(3):
            E[i, j] = R[0, i] * R_t[0, j] + R[1, i] * R_t[1, j] + R[2, i] * R_t[2, j]
    e[3:] = _log3(E)
    return e, R, p


@njit(cache=True, nogil=True)
def _ik_jacobian(e, R, p, origins, zs):
    """de/dq, with joint i's twist in the tip frame (v_i, w_i): -(w_i x e_p) - v_i and -Jl^-1(phi) w_i.

    A turn dq of joint i moves the tip by R (v_i, w_i) dq, so R^T changes by -[w_i]x R^T dq: e_p by
    -(w_i x e_p + v_i) dq and R^T R_t by exp(-[w_i]x dq) from the left, i.e. phi by -Jl^-1(phi) w_i dq with
    Jl^-1(phi) = I - [phi]x / 2 + (1 / theta^2 - cot(theta / 2) / (2 theta)) [phi]x^2, the inverse left
    Jacobian of SO(3).
    """
    n = zs.shape[0]
    e0, e1, e2, f0, f1, f2 = e[0], e[1], e[2], e[3], e[4], e[5]  # f = phi
    theta = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    if theta < 1e-4:
        c2 = 1.0 / 12.0 + theta * theta / 720.0
    else:
        c2 = 1.0 / (theta * theta) - math.cos(0.5 * theta) / (2.0 * theta * math.sin(0.5 * theta))
    J = np.empty((6, n))
    for i in range(n):
        z0, z1, z2 = zs[i, 0], zs[i, 1], zs[i, 2]
        w0 = R[0, 0] * z0 + R[1, 0] * z1 + R[2, 0] * z2  # w = R^T z
        w1 = R[0, 1] * z0 + R[1, 1] * z1 + R[2, 1] * z2
        w2 = R[0, 2] * z0 + R[1, 2] * z1 + R[2, 2] * z2
        r0, r1, r2 = p[0] - origins[i, 0], p[1] - origins[i, 1], p[2] - origins[i, 2]
        c0, c1, c2_ = z1 * r2 - z2 * r1, z2 * r0 - z0 * r2, z0 * r1 - z1 * r0  # z x (p - o)
        J[0, i] = -(w1 * e2 - w2 * e1) - (R[0, 0] * c0 + R[1, 0] * c1 + R[2, 0] * c2_)
        J[1, i] = -(w2 * e0 - w0 * e2) - (R[0, 1] * c0 + R[1, 1] * c1 + R[2, 1] * c2_)
        J[2, i] = -(w0 * e1 - w1 * e0) - (R[0, 2] * c0 + R[1, 2] * c1 + R[2, 2] * c2_)
        pw0, pw1, pw2 = f1 * w2 - f2 * w1, f2 * w0 - f0 * w2, f0 * w1 - f1 * w0  # phi x w
        J[3, i] = -(w0 - 0.5 * pw0 + c2 * (f1 * pw2 - f2 * pw1))
        J[4, i] = -(w1 - 0.5 * pw1 + c2 * (f2 * pw0 - f0 * pw2))
        J[5, i] = -(w2 - 0.5 * pw2 + c2 * (f0 * pw1 - f1 * pw0))
    return J


_IK_SOLVED = 1e-10
"""Position (m) and rotation (rad) errors below which an IK descent has reached its solution."""


@njit(cache=True, nogil=True)
def _ik_descent(q, lower, upper, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, max_iter):
    """One Levenberg-Marquardt descent of the tip onto the target pose (R_t, p_t) from q, within the limits.

    Minimises |e(q)|^2 (:func:`_ik_residual`): each iteration solves (J^T J + lam I) s = -J^T e, shortens s
    to a largest joint step of 0.5 rad, clips q + s to the limits and takes it when |e|^2 falls (lam / 5,
    at least 1e-9), else lam * 10. It stops at the solution (both errors below 1e-10 m and 1e-10 rad, so
    that the answer is the solution this path reaches, not wherever the errors first fell within the
    caller's tolerances: about one more iteration, the convergence being quadratic there), after
    ``max_iter`` iterations, or when lam passes 1e6 (no descent left: a local minimum, a joint limit, or
    errors at rounding level). Returns (q, position error |e_p| (m), rotation error |phi| (rad), iterations).
    """
    n = q.size
    q = q.copy()  # the iterate (its buffer swaps with q_try's): the caller's q is left as it is
    origins, zs = np.empty((n, 3)), np.empty((n, 3))
    q_try, step = np.empty(n), np.empty(n)
    system, low = np.empty((n, n)), np.empty((n, n))
    e, R, p = _ik_residual(q, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, origins, zs)
    cost = np.sum(e * e)
    J = _ik_jacobian(e, R, p, origins, zs)
    damping = 1e-3
    iterations = 0
    while True:
        pos_err = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        rot_err = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        if (pos_err <= _IK_SOLVED and rot_err <= _IK_SOLVED) or iterations >= max_iter:
            return q, pos_err, rot_err, iterations
        iterations += 1
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for k in range(6):
                    acc += J[k, i] * J[k, j]
                system[i, j] = acc
            system[i, i] += damping
            acc = 0.0
            for k in range(6):
                acc += J[k, i] * e[k]
            step[i] = -acc  # -J^T e
        _cholesky_solve(system, step, step, low)  # (should rounding make it indefinite, the step stays -J^T e)
        longest = 0.0
        for i in range(n):
            if abs(step[i]) > longest or step[i] != step[i]:  # NaN propagates, as in np.max
                longest = abs(step[i])
        if longest > 0.5:
            shorten = 0.5 / longest
            for i in range(n):
                step[i] *= shorten
        for i in range(n):
            q_try[i] = min(max(q[i] + step[i], lower[i]), upper[i])
        e_try, R_try, p_try = _ik_residual(q_try, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, origins, zs)
        cost_try = np.sum(e_try * e_try)
        if cost_try < cost:
            q, q_try = q_try, q
            e, cost = e_try, cost_try
            J = _ik_jacobian(e, R_try, p_try, origins, zs)
            damping = max(damping * 0.2, 1e-9)
        else:
            damping *= 10.0
            if damping > 1e6:
                return q, pos_err, rot_err, iterations


def ik_descent(q: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64],
               chain: tuple[NDArray[np.float64], ...], R_t: NDArray[np.float64], p_t: NDArray[np.float64],
               max_iter: int) -> tuple[NDArray[np.float64], float, float, int]:
    """:func:`_ik_descent` on ``chain`` = (rots, trans, axes, tip_rot, tip_trans) (:func:`_chain_fk`)."""
    out: tuple[NDArray[np.float64], float, float, int] = _ik_descent(
        np.ascontiguousarray(q, dtype=np.float64), lower, upper, *chain, R_t, p_t, max_iter)  # type: ignore[call-arg]
    return out
