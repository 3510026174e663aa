"""What the conservative gates skipped: a gate is a proof, from bounds, that a piece of exact work
can find nothing (docs/formats.md, "Replay summary": ``gates``). The exact work runs wherever a
gate cannot prove it; with the gates off (``GateTally(enabled=False)``) it runs everywhere, and
every answer is the same."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class GateTally:
    """Each gate's work items: how many it was asked about (``checked``) and how many of those it
    proved need no exact work (``skipped``), by the gate's name. ``enabled`` False: no gate runs
    (for tests and the trade-off report: the answers must not change)."""

    enabled: bool = True
    checked: dict = field(default_factory=dict)
    skipped: dict = field(default_factory=dict)

    def add(self, name: str, checked: int, skipped: int) -> None:
        self.checked[name] = self.checked.get(name, 0) + int(checked)
        self.skipped[name] = self.skipped.get(name, 0) + int(skipped)

    def merge(self, other: "GateTally") -> None:
        for name in other.checked:
            self.add(name, other.checked[name], other.skipped.get(name, 0))

    def as_dict(self) -> dict:
        """By gate: checked, skipped and the share skipped (0 when none was checked)."""
        return {name: {"checked": n, "skipped": self.skipped.get(name, 0),
                       "share_skipped": round(self.skipped.get(name, 0) / n, 4) if n else 0.0}
                for name, n in sorted(self.checked.items())}

    @staticmethod
    def of_dict(d: dict) -> "GateTally":
        """The tally ``as_dict`` gave (a summary's ``gates``)."""
        tally = GateTally()
        for name, v in (d or {}).items():
            tally.add(name, v.get("checked", 0), v.get("skipped", 0))
        return tally
