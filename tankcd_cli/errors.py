"""The one error type for bad input data (exit code 3)."""

from __future__ import annotations


class InputError(Exception):
    """Bad input data: unreadable, empty, non-finite, malformed file or row.

    The message is rendered as one line: ``FILE: WHERE: WHAT`` (``WHERE`` is
    optional: a line number, a row, an element, a key).
    """

    def __init__(self, source: str | None, what: str, where: str | None = None):
        self.source = source
        self.where = where
        self.what = what
        super().__init__(self.one_line())

    def one_line(self) -> str:
        parts = [p for p in (self.source, self.where) if p]
        parts.append(self.what)
        return ": ".join(str(p) for p in parts).replace("\n", " ")
