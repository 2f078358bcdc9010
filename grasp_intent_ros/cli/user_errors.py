"""The command-line tools' common error handling: a user's mistake is one line on stderr, exit code 2."""

from __future__ import annotations

import sys
from collections.abc import Callable

from ..errors import GraspIntentError

__all__ = ['USER_ERRORS', 'report_user_errors']

USER_ERRORS: tuple[type[Exception], ...] = (GraspIntentError, OSError)
"""What a user can cause: bad input files or values (the package's own errors) and file-system errors."""


def report_user_errors(body: Callable[[], object], *, prog: str = '',
                       errors: tuple[type[Exception], ...] = USER_ERRORS) -> int:
    """Run ``body``; 0, or 2 after ``[prog: ]error: <message>`` on stderr when it raises one of ``errors``.

    Any other exception (a bug) propagates with its traceback.
    """
    try:
        body()
    except errors as exc:
        print(f'{prog + ": " if prog else ""}error: {exc}', file=sys.stderr)
        return 2
    return 0
