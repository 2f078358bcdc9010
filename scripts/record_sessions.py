#!/usr/bin/env python3
"""Regenerate the input-by-input session bags in bags/ (:mod:`grasp_intent_ros.sessions.fixtures`).

All but the closed-loop bags/shared_control_cup*, which ``benchmarks/bench_shared_control.py --record``
records (its scripted operator lives there).

    .venv/bin/python scripts/record_sessions.py [--out bags] [--only NAME ...] [--models-dir DIR]

Takes about a minute for the five sessions on 2 cores.
"""

from __future__ import annotations

import sys
from pathlib import Path

from grasp_intent_ros.sessions.fixtures import main

if __name__ == '__main__':
    sys.exit(main(sys.argv[1:], bags=Path(__file__).resolve().parents[1] / 'bags'))
