"""Counts in messages: "1 branch", "2 branches", "1,234 leaves" (one place for plurals)."""

from __future__ import annotations

# nouns whose plural is not noun + "s"
IRREGULAR = {"branch": "branches", "leaf": "leaves", "original branch": "original branches",
             "branch-step": "branch-steps"}


def counted(n: int, noun: str, grouped: bool = True) -> str:
    """``n`` and ``noun``, plural unless n is 1; ``grouped``: with thousands separators."""
    number = f"{n:,}" if grouped else str(n)
    return f"{number} {noun if n == 1 else IRREGULAR.get(noun, noun + 's')}"
