"""``python -m grasp_intent_ros <command> [arguments]``: run one of the package's commands.

The commands are :data:`grasp_intent_ros.commands.COMMANDS`; ``grasp-intent-ros <command>`` (pip) and
``ros2 run grasp_intent_ros <command>`` (colcon) run the same ``main``.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence
from pathlib import Path

from .commands import COMMANDS, SCRIPT

__all__ = ['main']


def _usage(prog: str) -> str:
    width = max(map(len, COMMANDS))
    lines = '\n'.join(f'  {name:{width}}  python -m grasp_intent_ros.{module}' for name, module in COMMANDS.items())
    return f'usage: {prog} COMMAND [ARGUMENTS ...]   (COMMAND --help for its own)\n\ncommands:\n{lines}'


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``argv[0]``'s command with the rest as its arguments (default ``sys.argv[1:]``); its exit code.

    Returns 2 with the usage on stderr for a missing or unknown command, 0 with it on stdout for --help.
    """
    args = list(sys.argv[1:] if argv is None else argv)
    prog = 'python -m grasp_intent_ros' if Path(sys.argv[0]).name == '__main__.py' else SCRIPT
    if args and args[0] in ('-h', '--help'):
        print(_usage(prog))
        return 0
    if not args or args[0] not in COMMANDS:
        problem = f'unknown command {args[0]!r}' if args else 'a command is required'
        print(f'{_usage(prog)}\n{prog}: error: {problem}', file=sys.stderr)
        return 2
    module = importlib.import_module(f'grasp_intent_ros.{COMMANDS[args[0]]}')
    sys.argv = [f'{prog} {args[0]}', *args[1:]]  # argparse's prog and rclpy's arguments
    code = module.main()
    return code if isinstance(code, int) else 0


if __name__ == '__main__':
    sys.exit(main())
