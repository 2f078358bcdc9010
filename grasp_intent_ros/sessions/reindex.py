"""Repair session bags left by a killed recorder: ``python -m grasp_intent_ros reindex BAG [BAG ...]``.

What ``ros2 bag reindex`` does, for this package's MCAP bags (:func:`grasp_intent_ros.sessions.bag.reindex`): every
complete chunk of the .mcap file is kept, the rest (at most the recorder's last flush period) is
dropped, and the bag gets a complete MCAP file and a metadata.yaml again. The original file is kept
next to it as ``<file>.mcap.broken``. A complete bag is left as it is.

Prints one line per bag; exit code 0, or 2 after ``reindex: error: ...`` for a bag that cannot be
repaired (not a bag directory, no MCAP header, ...); the other bags are still repaired.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ..cli.user_errors import USER_ERRORS, report_user_errors
from .bag import BagWriteError, reindex

__all__ = ['main']


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code (0, or 2 if any bag could not be repaired)."""
    parser = argparse.ArgumentParser(
        description='Rebuild the MCAP summary and metadata.yaml of bags whose recorder was killed '
                    '(the original .mcap is kept as .mcap.broken).')
    parser.add_argument('bags', type=Path, nargs='+', metavar='BAG', help='rosbag2 directory with one .mcap file')
    options = parser.parse_args(argv)
    codes = [report_user_errors(lambda bag=bag: print(f'reindex: {reindex(bag).summary()}', flush=True),
                                prog='reindex', errors=(*USER_ERRORS, BagWriteError))
             for bag in options.bags]
    return max(codes)


if __name__ == '__main__':
    sys.exit(main())
