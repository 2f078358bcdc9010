"""The ROS 2 nodes: one Node subclass and its ``main`` per module (``python -m grasp_intent_ros.nodes.<name>``).

Each converts messages, calls the ROS-free core and publishes; the rclpy plumbing they share is
:mod:`grasp_intent_ros.ros`.

Modules
-------
intent_interpreter
    w -> v (or a clarification request).
model_server
    The active model (latched), its ambiguity, posterior queries.
grasp_planner
    v + model + object pose -> a MICO grasp.
assistance
    The operator's twist blended toward the grasp (shared control); over several objects, one object's at a time.
assistance_inputs, assistance_scene
    Parts of ``assistance``, no nodes of their own: one chain's inputs (``ChainInputs``), and the node's work over
    several objects (``SceneInputs``).
mock_arm
    A simulated MICO taking trajectories and twists.
arm_plans
    A part of ``mock_arm``: the plan ``grasp/close`` closes to and ``grasp/execute`` runs (``ArmPlans``).
intent_estimator
    w from the operator's own twist (optional); over several objects each object's w and P(o).
estimator_goals, estimator_scene
    Parts of ``intent_estimator``, no nodes of their own: one object's goals followed in its namespace
    (``ObjectGoals``), and the node's work over several objects (``SceneIntent``).
scripted_operator
    A scripted operator driving the loop without a device: its twists, a held w, the grasp command (optional).
viewer
    The scene in a browser (the ``viewer`` extra).
recorder
    A session recorded into a rosbag2 bag.

Imports nothing of :mod:`~grasp_intent_ros.sessions` but its bags, nor the data set
(:mod:`~grasp_intent_ros.objects`), nor the command lines.
"""
