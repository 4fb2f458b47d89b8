"""Exception types shared by the core: a user-facing input error, and how it echoes values."""

from typing import Any

#: The most characters of a value an error message echoes.
ECHO_LIMIT = 80


class InputError(ValueError):
    """
    Bad user input (file, value, bag, table); the message is one line that names what is wrong.

    The CLI prints it and exits with code 2; the nodes log it and keep running.
    """


def shorten(value: Any, limit: int = ECHO_LIMIT) -> str:
    """Return ``repr``-free text of ``value`` cut to ``limit`` characters with an ellipsis."""
    text = str(value)
    text = ''.join(c if c.isprintable() else repr(c)[1:-1] for c in text[:limit + 1])
    return text if len(text) <= limit else text[:limit - 1] + '\u2026'
