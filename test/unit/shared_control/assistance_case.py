"""The assistance's hand-built case: a grasp with its approach straight down, the arbitration's settings, task bits."""

from __future__ import annotations

from grasp_intent_ros.mico.frames import pose_to_matrix

GRASP = pose_to_matrix((0.3, -0.3, 0.05), (1.0, 0.0, 0.0, 0.0))  # approach (EE z) straight down
ARGS = dict(alpha_max=0.9, margin=0.2)
U, T, H = 1, 2, 4
