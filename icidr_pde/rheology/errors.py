"""The error of a law that cannot be used, raised wherever that is found: the law's checks
(:mod:`.base`, :mod:`.cidr`) and the kernel printers (:mod:`.codegen`), which the laws import."""

from __future__ import annotations

__all__ = ["LawError"]


class LawError(ValueError):
    """A law that cannot be used: names the condition and a state where it fails."""

    def __init__(self, law: str, condition: str, state: dict | None = None, detail: str = ""):
        self.law, self.condition, self.state = law, condition, state
        where = "" if state is None else " at " + ", ".join(f"{k} = {v:.6g}" for k, v in state.items())
        super().__init__(f"law {law!r}: {condition}{where}" + (f" ({detail})" if detail else ""))
