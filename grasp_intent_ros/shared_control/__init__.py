"""Shared control, closed loop without ROS: scripted operators and a simulated-clock loop (docs/shared_control.md)."""
