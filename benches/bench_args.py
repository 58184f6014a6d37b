"""The benchmark scripts' command-line values: ``--flag VALUE`` read once, a flag given
without its value (or with one that does not convert) a one-line message and a non-zero exit code,
as the ``flextop`` command line answers a user's error."""

from __future__ import annotations

import sys
from typing import Callable, TypeVar

T = TypeVar("T")


def value(flag: str, default: T, convert: Callable[[str], T]) -> T:
    """The value given after ``flag`` on the command line, converted; ``default`` where the
    flag is not given."""
    if flag not in sys.argv[1:]:
        return default
    at = sys.argv.index(flag)
    given = sys.argv[at + 1] if at + 1 < len(sys.argv) else None
    if given is None or given.startswith("--"):
        sys.exit(f"{sys.argv[0]}: {flag} needs a value")
    try:
        return convert(given)
    except ValueError:
        sys.exit(f"{sys.argv[0]}: {flag} {given!r}: not a valid value")


def values(flag: str, count: int, convert: Callable[[str], T]) -> list[T] | None:
    """The ``count`` values given after ``flag``, converted; ``None`` where the flag is not
    given."""
    if flag not in sys.argv[1:]:
        return None
    at = sys.argv.index(flag)
    given = sys.argv[at + 1:at + 1 + count]
    if len(given) < count or any(g.startswith("--") for g in given):
        sys.exit(f"{sys.argv[0]}: {flag} needs {count} values")
    try:
        return [convert(g) for g in given]
    except ValueError:
        sys.exit(f"{sys.argv[0]}: {flag} {' '.join(given)}: not valid values")
