"""`did you mean ...?` for misspelt ids, names and options (difflib's closest match).

Why: `OpenDS/LaneChangTest-v0`, `--agent rnadom` or `polcy_hz=20` should be answered with
the name that was meant, from the CLI and from `gym.make` alike.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def closest(word: str, choices: Iterable[str], cutoff: float = 0.6) -> str | None:
    """The choice most like `word` (case-insensitive), or None when none is close."""
    by_lower: dict[str, str] = {}
    for c in choices:
        by_lower.setdefault(c.lower(), c)
    match = difflib.get_close_matches(word.lower(), list(by_lower), n=1, cutoff=cutoff)
    return by_lower[match[0]] if match else None


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`"; did you mean X?"` for the closest choice, or `""` when none is close."""
    match = closest(word, choices)
    return f"; did you mean {match}?" if match is not None else ""


def meant(word: str, choices: Iterable[str]) -> str:
    """`" (did you mean X?)"` for the middle of a sentence, or `""`."""
    match = closest(word, choices)
    return f" (did you mean {match}?)" if match is not None else ""
