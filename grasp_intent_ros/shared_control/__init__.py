"""Shared control: the operator's twist blended with assistance toward the planned grasp.

ROS-free. Modules
-----------------
approach
    The approach to a grasp via its pre-grasp: the pose a hand steers to (assistance, operators, estimator).
assistance
    The operator's twist blended with the robot's, within the limits: the core that composes the three below.
arbitration
    How much the robot gets, alpha: the probability that the grasp serves the task, the operator's agreement.
robot_twist
    The robot's twist toward the grasp (via its pre-grasp): in joint space or Cartesian; raised to the operator's pace.
assistance_config
    The assistance's settings (the node's parameters).
joint_path
    The robot twist's joint-space target for a pose with no IK from the arm's joints (the line IK).
clearance
    The robot's joint path clear of the object as perceived (tracked pose, model's body): checked, and replaced.
path_search
    The robot's joint path sought from a snapshot: the search (one definition), at once or in a process of its own.
limits
    The output twist's speed and acceleration limits; norms without overflow.
output_cadence
    When the assistance publishes: one output per period, at the operator's cadence when its source streams.
barrier
    The command kept out of the object as perceived: the twist nearest the blend that nears it no faster than a barrier.
goals
    The intent estimator's goals: the model's demonstrations placed at the object, the reachable ones, their prior.
estimator
    The intent estimator: the operator's twist -> a posterior over the model's demonstrated grasps -> w.
scene_estimator
    The intent estimator over several objects: one posterior over every object's goals -> P(o) and each object's w.
scene_target
    Which object's grasp the assistance over several objects follows: the scores and the hysteresis.
scene_assistance
    The assistance of one arm over several objects: the followed object's inputs fed to one ``Assistance``.
task_prior
    A prior over task sets from independent task probabilities: a classifier's w as the estimator's prior.
calibration
    An optional monotone map of the estimator's task marginals, w -> sigmoid(a logit(w) + b), and its log-loss fit.
stamped_inputs
    The estimator's inputs paired by header stamps: each operator twist with the hand and the grasp shown at its stamp.
operators
    Scripted teleoperators and their intents (a device model, a goal choice without the rules, an intent script).
operator_loop
    A scripted operator on a wall clock, in episodes, against what it perceives late (the scripted operator node's).
operator_calls
    That operator's service calls in sequence (the grasp command's execute and close, the arm's reset): the node's.
ada
    ADA's shared autonomy as published (goals of one or more targets): the simulated closed loops' baseline.
simulator
    The closed loop on a simulated clock with the nodes' core functions (planner policy, assistance, mock arm).
loop_steps
    The steps both simulated loops take: the plan fed, the grasp command (execute, close), the episode's record.
scene_simulator
    That loop over several objects: each chain's plans, the assistance over several objects, the operator's object.
sweep
    The judge's measure the loop lacks a contact model for: how deep the open hand's path goes into the object.
parameters (ROS-free tables)
    The assistance node's, the intent estimator node's and the scripted operator node's parameter tables; how the
    operator's twist is read.

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.method`,
:mod:`~grasp_intent_ros.planning` and :mod:`~grasp_intent_ros.mico`.
"""
