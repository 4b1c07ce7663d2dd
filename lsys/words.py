"""Counts in messages: "1 branch", "2 branches", "1,234 leaves" (one place for plurals)."""

from __future__ import annotations

# nouns whose plural is not noun + "s"
IRREGULAR = {"branch": "branches", "leaf": "leaves", "original branch": "original branches",
             "branch-step": "branch-steps"}


def counted(n: int, noun: str) -> str:
    """``n`` with thousands separators and ``noun``, plural unless n is 1."""
    return f"{n:,} {noun if n == 1 else IRREGULAR.get(noun, noun + 's')}"
