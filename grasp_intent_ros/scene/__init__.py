"""What the viewer shows and how: the scene of the suite, built from its messages, drawn in a browser.

Modules
-------
geometry
    ROS-free: the MICO's visual model (Pinocchio, the URDF's boxes and cylinders) and the object's body as
    posed primitives; also drawn by the session report.
plan
    ROS-free: the tasks a planned grasp serves by its object's rules, the object pose a plan implies.
state
    :class:`~grasp_intent_ros.scene.state.SceneState`, the newest content of every topic the viewer follows,
    updated message by message (rclpy and rosbags messages alike); for a scene of several objects,
    :class:`~grasp_intent_ros.scene.state.ObjectsState`, one per object's chain and the arm once.
panel
    The side panel's HTML: w, v and P bars labelled with task and zone names, the plan's status.
page
    The viser server drawing a state (the optional ``viewer`` extra).

Used by the viewer node (:mod:`grasp_intent_ros.nodes.viewer`), the session playback
(:mod:`grasp_intent_ros.sessions.playback`) and the report. Imports nothing of :mod:`grasp_intent_ros.sessions.bag`.
"""
