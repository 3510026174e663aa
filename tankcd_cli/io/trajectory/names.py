"""Entity ids (docs/formats.md, "Trajectory CSV", "Entities"): the one rule of what an id may hold,
the ids made from names that break it (a file's stem, a GPX track's name), and the code table
a reader gives names as they appear.

An id is non-empty text without double or single quotes, commas or control characters (it
becomes a CSV cell of every output). The compiled CSV pass (``_csv_kernels.pyx``) holds the same
bytes back for the careful reader, which asks ``entity_id_fault``.
"""

from __future__ import annotations

import os
import re

_FORBIDDEN = re.compile(r"[,\"'\x00-\x1f\x7f]")
_QUOTES = re.compile(r"[\"']")


def entity_id_fault(text: str) -> str | None:
    """What keeps ``text`` (blanks around it already taken off) from being an entity id: "empty",
    "quote", "comma" or "control" (a control character), asked in that order; None for an id."""
    if not text:
        return "empty"
    if _FORBIDDEN.search(text) is None:
        return None
    if _QUOTES.search(text):
        return "quote"
    if "," in text:
        return "comma"
    return "control"


def entity_id_from(name: str) -> str:
    """``name`` with every character an id may not hold replaced by '_'."""
    return _FORBIDDEN.sub("_", name)


def stem_name(path: str) -> str:
    """The entity name of a file without an entity column: its stem ('stdin' for '-'), without the
    characters an entity id may not hold ('_' instead); a compressed file's without its ``.gz`` too
    (``run.csv.gz``: ``run``)."""
    if path == "-":
        return "stdin"
    base = os.path.basename(path)
    if base.lower().endswith(".gz"):
        base = base[:-3]
    stem = os.path.splitext(base)[0] or "trajectory"
    return entity_id_from(stem)


class EntityNames:
    """Entity names in code order, each code fixed once given.

    list : the names by code; index : name -> code."""

    def __init__(self, names=()):
        self.list: list = []
        self.index: dict = {}
        self._tuple: tuple = ()
        for name in names:
            self.add(name)

    def add(self, name: str) -> int:
        """The code of ``name``, a new one (the next) the first time it is seen."""
        code = self.index.get(name)
        if code is None:
            code = self.index[name] = len(self.list)
            self.list.append(name)
        return code

    def tuple(self) -> tuple:
        """The names by code (the same tuple while no name is added)."""
        if len(self._tuple) != len(self.list):
            self._tuple = tuple(self.list)
        return self._tuple
