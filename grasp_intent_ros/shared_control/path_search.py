"""The robot twist's joint path toward its target, sought from a snapshot: the search, and the process it runs in.

:class:`~.assistance.Assistance` needs, once per target (the grasp or its pre-grasp) and generation (every grasp
and object set, a repeated one too, asks for it again from the joints of that moment), the joint path its robot
twist follows (its module docstring). It hands the search a :class:`PathRequest`, a snapshot of everything the
search reads: the joints q at that moment, the target, the grasp, the bound's reference and slack, the object as
perceived (a :class:`~.clearance.PathClearance`) and the clear way this proposal had. :func:`seek_path` is the
search, one definition, wherever it runs:

- :class:`PathSearch` answers at once, in the caller's thread (the simulator, the tests, the node's warm-up):
  the closed loop on a simulated clock stays synchronous and deterministic, every path sought from the joints
  of the first output after the grasp or object was set.
- :class:`PathWorker` answers in a process of its own (the assistance node), so that a search (milliseconds,
  tens at worst) never delays an output: not by its time, and not by sharing the caller's interpreter lock, for
  which an output computed while a search ran in a thread of the same process waited (the node's docstring,
  "Threads"). The caller's thread owns the :class:`~.assistance.Assistance` and all its state; the process
  builds its own kinematics and hand model from the URDF, and receives each request (the object's body, pose,
  limits and margin in place of the caller's :class:`~.clearance.PathClearance`, which it rebuilds on its own
  models) over a pipe; the answer comes back over the pipe, taken by the caller on its next output. One request
  is sought at a time, and requests are newest-only: one asked for while another is sought waits, replaced by
  any newer, and is handed over when that answer is taken, so no input is lost, only superseded, and the pipe
  never holds more than one request (a hung process never blocks the caller). An answer for an older request
  of the same grasp, object and phase is still taken (the assistance's class docstring says what it uses while
  a search runs). The process ends when asked (:meth:`PathWorker.stop`) or when the caller's end of the pipe
  closes (the caller's process ended, however).

ROS-free.
"""

from __future__ import annotations

import functools
import os
import signal
import socket
import subprocess
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, replace
from multiprocessing.connection import Connection
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..method.body import Cylinder, ObjectBody
from ..mico.collision import HandCollision
from ..mico.kinematics import HOME_Q, MicoKinematics
from .clearance import PathClearance, clear_path
from .joint_path import joint_path, line_turns, near_grasp

__all__ = ['PathRequest', 'PathAnswer', 'seek_path', 'PathSource', 'PathSearch', 'PathWorker', 'STOP_TIMEOUT', 'serve',
           'warm_up_scene']


@dataclass(frozen=True)
class PathRequest:
    """What a path search reads, taken at one moment (nobody changes its arrays afterwards).

    Attributes
    ----------
    key : tuple of (int, int, str)
        The assistance's epoch (its grasp and object), generation (its request) and the phase (``'grasp'`` or
        ``'pre-grasp'``) the path is for.
    q : ndarray, shape (6,)
        The joints (rad) the path starts from.
    base_T_target, base_T_grasp : ndarray, shape (4, 4)
        The target (the grasp or its pre-grasp) and the grasp, base frame.
    slack, reference : float
        m: :func:`~.joint_path.joint_path`'s and :func:`~.joint_path.near_grasp`'s.
    clearance : PathClearance or None
        The object as perceived (None: no check).
    previous : tuple of ndarray, shape (6,)
        The clear way that replaced this proposal's path for this phase, its points still ahead (empty: none).
    """

    key: tuple[int, int, str]
    q: NDArray[np.float64]
    base_T_target: NDArray[np.float64]
    base_T_grasp: NDArray[np.float64]
    slack: float
    reference: float
    clearance: PathClearance | None
    previous: tuple[NDArray[np.float64], ...] = ()


@dataclass(frozen=True)
class PathAnswer:
    """A search's answer for ``key``: ``path``, its points after q (rad; None: no joint path).

    ``cleared``: the path is :func:`~.clearance.clear_path`'s replacement of the assistance's own.
    """

    key: tuple[int, int, str]
    path: list[NDArray[np.float64]] | None
    cleared: bool


def seek_path(kin: MicoKinematics, request: PathRequest) -> PathAnswer:
    """The joint path toward ``request.base_T_target`` from ``request.q`` (:class:`~.assistance.Assistance`).

    The IK (no restarts) from q, ``[q_t]`` with the wrist's 2 pi branch that turns the hand the short way
    (:func:`~.joint_path.line_turns`), or when it fails :func:`~.joint_path.joint_path`; then, with a
    clearance, :func:`~.clearance.clear_path` (admissible: :func:`~.joint_path.near_grasp`, the same bound).
    ``kin`` must be the calling thread's own, and ``request.clearance`` built on it.
    """
    q, target, grasp = request.q, request.base_T_target, request.base_T_grasp
    ik = kin.ik(target, q, restarts=0)  # the solution the joints descend to
    path: list[NDArray[np.float64]] | None
    if ik.success:
        path = [line_turns(kin, q, ik.q, target, grasp, slack=request.slack, reference=request.reference)]
    else:
        path = joint_path(kin, q, target, grasp, slack=request.slack, reference=request.reference)
    if path is not None and request.clearance is not None:
        near = functools.partial(near_grasp, kin, q, base_T_grasp=grasp, slack=request.slack,
                                 reference=request.reference)
        cleared = clear_path(request.clearance, q, path, target, list(request.previous) or None, near)
        if cleared is not path:
            return PathAnswer(request.key, cleared, True)
    return PathAnswer(request.key, path, False)


class PathSource(Protocol):
    """Where the assistance's path searches run."""

    def seek(self, request: PathRequest) -> PathAnswer | None:
        """The newest answer for ``request``'s epoch and phase (its generation may be older), or None."""


class PathSearch:
    """Seeks at once in the caller's thread, with ``kin`` (the assistance's own)."""

    def __init__(self, kin: MicoKinematics) -> None:
        self.kin = kin

    def seek(self, request: PathRequest) -> PathAnswer:
        return seek_path(self.kin, request)


STOP_TIMEOUT = 1.0
"""Seconds :meth:`PathWorker.stop` waits for the process to end before it kills it.

Well within the node's shutdown grace (:data:`grasp_intent_ros.ros.run.SHUTDOWN_GRACE`, 5 s), which the node's other
stops share: a process still warming up (it reads the stop only once ready) or searching under a heavy load is
killed rather than leaving the node to the watchdog; a search has no effect outside the process, so nothing is lost."""


class PathWorker:
    """Seeks in a process of its own (module docstring); :meth:`stop` ends it.

    Parameters
    ----------
    urdf_path : str or None
        The URDF the process builds its kinematics and hand model from (None: the package's).
    name : str
        The worker's name in its messages (the node's: ``<node>_paths``).
    on_error : callable
        ``on_error(text)``, called in the caller's thread (in :meth:`seek`) with the traceback of a search
        that raised (its answer: None, no joint path) or the reason the process ended; it must not raise.
    search : callable, optional
        ``search(kin, request) -> PathAnswer``, run in the process (picklable: a module-level function);
        default :func:`seek_path`.
    """

    def __init__(self, urdf_path: str | None = None, *, name: str, on_error: Callable[[str], object],
                 search: Callable[[MicoKinematics, PathRequest], PathAnswer] | None = None) -> None:
        # a new interpreter (never a fork of a process that runs threads: rclpy's, DDS's), which imports this
        # module, not the caller's main module (as multiprocessing's spawn would), on the caller's import path
        ours, theirs = socket.socketpair()
        path = os.pathsep.join(entry or os.getcwd() for entry in sys.path)
        code = f'from {__name__} import serve; serve({theirs.fileno()})'
        self._process = subprocess.Popen([sys.executable, '-c', code], pass_fds=(theirs.fileno(),),
                                         stdin=subprocess.DEVNULL, env={**os.environ, 'PYTHONPATH': path})
        theirs.close()
        self.name = name
        self._conn = Connection(ours.detach())
        self._conn.send((urdf_path, seek_path if search is None else search))
        self._on_error = on_error
        self._asked: tuple[int, int, str] | None = None  # the key last asked for
        self._waiting: PathRequest | None = None  # the newest request not handed over (one is being sought)
        self._seeking = False  # a request handed over, its answer not yet taken
        self._answer: PathAnswer | None = None
        self._ended = False
        self._ready = False

    def wait_ready(self, timeout: float) -> bool:
        """Wait until the process has built its models and run its warm-up (at most ``timeout`` s); whether it has.

        Requests handed over before then wait in the pipe, so this is for a caller that must not run without the
        search's answers (the node's warm-up: no answer waits for the process's start).
        """
        deadline = time.monotonic() + timeout
        while not self._ready and not self._ended and self._conn.poll(max(0.0, deadline - time.monotonic())):
            self._take()
            if time.monotonic() >= deadline:
                break
        return self._ready

    @property
    def pid(self) -> int:
        """The process's id."""
        return self._process.pid

    @property
    def returncode(self) -> int | None:
        """The process's exit code (None while it runs; negative: ended by that signal)."""
        return self._process.poll()

    def seek(self, request: PathRequest) -> PathAnswer | None:
        """The newest answer for ``request``'s epoch and phase, None for none; hands ``request`` over unless it was.

        Takes the answers that arrived, then hands over the newest request not yet sought when the process is
        free. The answer may be for an older generation while ``request`` is sought (the caller tells by its key).
        """
        if self._asked != request.key:
            self._asked, self._waiting = request.key, request
        self._take()
        if self._waiting is not None and not self._seeking and not self._ended:
            clearance = self._waiting.clearance
            spec = None if clearance is None else (clearance.body, clearance.base_T_obj, clearance.limits,
                                                   clearance.margin)
            try:
                self._conn.send((replace(self._waiting, clearance=None), spec))
            except OSError:
                self._end()
            else:
                self._waiting, self._seeking = None, True
        answer = self._answer
        if answer is not None and answer.key[0] == request.key[0] and answer.key[2] == request.key[2]:
            return answer
        return None

    def stop(self, timeout: float | None = None) -> None:
        """Ask the process to stop after its current search and wait for it (``timeout`` s, then kill it).

        ``timeout``: None for :data:`STOP_TIMEOUT` as it is at the call, the node's; a caller that must see the
        process end by the request (its exit code 0), even on a loaded machine, gives more.
        """
        if not self._ended:
            try:
                self._conn.send(None)
            except OSError:
                pass
        try:
            self._process.wait(STOP_TIMEOUT if timeout is None else timeout)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._ended = True
        self._conn.close()

    def _take(self) -> None:
        """The answers that arrived (the newest kept); an ended process noted once."""
        try:
            while not self._ended and self._conn.poll():
                item = self._conn.recv()
                if item == _READY:
                    self._ready = True
                    continue
                answer, error = item
                self._answer, self._seeking = answer, False
                if error is not None:
                    self._on_error(error)
        except (EOFError, OSError):
            self._end()

    def _end(self) -> None:
        self._ended, self._seeking = True, False
        try:
            code: int | None = self._process.wait(0.1)
        except subprocess.TimeoutExpired:
            code = None
        self._on_error(f'the path search process {self.name} ended (exit code {code}): no joint path from now')


_READY = 'ready'
"""The process's first message: its models built and its warm-up run."""


def serve(fd: int) -> None:
    """The process of a :class:`PathWorker` (its end of the pipe: ``fd``): answer each request until None or EOF.

    The first message is the URDF's path and the search; the process answers ``'ready'`` after its warm-up; then
    requests, each answered with ``(answer, None)``, or ``(no path, traceback)`` when the search raised.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a terminal's Ctrl-C reaches both: the caller stops this one
    conn = Connection(fd)
    try:
        urdf_path, search = conn.recv()
    except EOFError:
        return
    kin, hand = MicoKinematics(urdf_path), HandCollision(urdf_path)
    _warm_up(kin, hand)
    conn.send(_READY)
    while True:
        try:
            item = conn.recv()
        except EOFError:
            return
        if item is None:
            return
        request, spec = item
        own = replace(request, clearance=None if spec is None else PathClearance(kin, hand, *spec))
        try:
            reply: tuple[PathAnswer, str | None] = (search(kin, own), None)
        except Exception:  # noqa: BLE001 - reported by the caller; the process serves on
            reply = (PathAnswer(request.key, None, False), traceback.format_exc())
        conn.send(reply)


def warm_up_scene(kin: MicoKinematics) -> tuple[NDArray[np.float64], NDArray[np.float64], ObjectBody]:
    """A scene whose path search runs every part of it: ``(base_T_target, base_T_obj, body)``, base frame.

    The target 7 cm from the hand at Home (5 cm along the base's x, 5 cm down); a cup (a cylinder) 20 cm below it,
    within the hand's reach.
    """
    target = kin.fk(np.asarray(HOME_Q, dtype=np.float64))
    target[:3, 3] += (0.05, 0.0, -0.05)
    base_T_obj = np.eye(4)
    base_T_obj[:3, 3] = target[:3, 3] + (0.0, 0.0, -0.2)
    return target, base_T_obj, ObjectBody((Cylinder(np.array([0.0, 0.0, 0.05]), np.array([0.0, 0.0, 1.0]), 0.04,
                                                    0.1),))


def _warm_up(kin: MicoKinematics, hand: HandCollision) -> None:
    """One search of :func:`warm_up_scene` from Home (the IK, the line, the clearance): no answer loads a kernel."""
    target, base_T_obj, body = warm_up_scene(kin)
    seek_path(kin, PathRequest((-1, 0, 'grasp'), np.asarray(HOME_Q, dtype=np.float64), target, target, 0.05, 0.07,
                               PathClearance(kin, hand, body, base_T_obj)))
