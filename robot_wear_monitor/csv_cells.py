"""
Text cells of the CSV files the monitor writes, safe to open in a spreadsheet.

A spreadsheet runs a cell that starts with ``=``, ``+``, ``-`` or ``@`` (and, in several of
them, their full-width forms, a tab or a carriage return) as a formula: a robot name, a user
name or a note such as ``=HYPERLINK(...)`` would become a live link or a command.  Text cells
get a leading apostrophe (OWASP's advice on CSV injection); numbers are written by the caller
as numbers and never pass through here, so ``-0.5`` stays a number.
"""

from robot_wear_monitor.text import escaped

#: First characters that make a spreadsheet read a cell as a formula.
FORMULA_STARTS = frozenset('=+-@\t\r\uff1d\uff0b\uff0d\uff20')


def spreadsheet_text(text: str) -> str:
    """Return ``text`` with a leading apostrophe when a spreadsheet would run it as a formula."""
    return "'" + text if text[:1] in FORMULA_STARTS else text


def csv_text(text: str, *, terminal: bool = False) -> str:
    """
    Return a text cell of a CSV the command line writes: :func:`spreadsheet_text`.

    ``terminal``: the CSV goes to a terminal (stdout is one): control characters are escaped
    first (:func:`~robot_wear_monitor.text.escaped`), as in every other text output, so a
    robot's or joint's name with an escape sequence or a newline cannot forge a line there.  A
    file or a pipe gets the text as stored (the CSV quotes it), as JSON does.
    """
    return spreadsheet_text(escaped(text) if terminal else text)
