"""The one error type for bad input data (exit code 3)."""

from __future__ import annotations

import contextlib
import contextvars
import warnings


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
        return printable(": ".join(str(p) for p in parts))


def printable(text: str) -> str:
    """One line of text whatever the input held: line breaks become spaces, other control
    characters and undecodable bytes (surrogates) their escapes."""
    text = text.replace("\r\n", " ").replace("\n", " ")
    out = []
    for ch in text:
        code = ord(ch)
        if code < 0x20 or code == 0x7f or 0x80 <= code < 0xa0 or ch in "\u2028\u2029\x1c\x1d\x1e\x85" \
                or 0xd800 <= code < 0xe000:
            out.append(f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}")
        else:
            out.append(ch)
    return "".join(out)


class SetupWarning(UserWarning):
    """Valid input that is probably a mistake (a y-up mesh read as z-up, a trajectory beside the
    terrain, an obstacle placed away from it). The command line prints it as one line on stderr;
    ``--strict`` makes it bad input (exit 3) before anything is written."""

    def __init__(self, source: str | None, what: str):
        self.source = source
        self.what = what
        super().__init__(printable(f"{source}: {what}" if source else what))

    def one_line(self) -> str:
        return str(self)


def warn(source: str | None, what: str) -> None:
    """Raise a :class:`SetupWarning` through Python's warnings (the caller decides what it does),
    first recorded by every ``collected_warnings`` block it is raised in."""
    warning = SetupWarning(source, what)
    for seen in _COLLECTING.get():
        seen.add(warning.one_line())
    warnings.warn(warning, stacklevel=2)


class CollectedWarnings(list):
    """The one-line texts of the set-up warnings raised while a ``collected_warnings`` block ran, in
    the order first raised, each once (a list of str)."""

    def add(self, text: str) -> None:
        if text not in self:
            self.append(text)


_COLLECTING: contextvars.ContextVar = contextvars.ContextVar("tankcd_collected_warnings", default=())


def collected_warnings():
    """A context manager that records every set-up warning raised inside it (``CollectedWarnings``),
    whatever the warnings filters then do with it: shown (the command line prints it, ``-q`` does
    not), ignored, or raised as an error (``--strict``). So a summary built from it carries every
    warning of its run. Blocks nest: a warning is recorded by each block it is raised in."""
    @contextlib.contextmanager
    def block():
        seen = CollectedWarnings()
        token = _COLLECTING.set(_COLLECTING.get() + (seen,))
        try:
            yield seen
        finally:
            _COLLECTING.reset(token)

    return block()
