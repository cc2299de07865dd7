"""Close-match suggestions for messages about unknown names (closest match first)."""
from __future__ import annotations

import difflib


def closest_first(word, choices) -> list:
    """``choices`` (as strings) ordered by similarity to ``word``, closest first."""
    word = str(word).lower()
    items = [str(c) for c in choices]
    return sorted(items, key=lambda c: (-difflib.SequenceMatcher(None, word, c.lower()).ratio(),
                                        items.index(c)))


def suggest(word, choices) -> str:
    """' (did you mean 'x'?)' for a close match, else ''."""
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def unknown(kind: str, word, choices) -> str:
    """"unknown <kind> 'word' (did you mean ...?); valid names: closest, ..., others"."""
    shown = repr(word) if isinstance(word, str) else f"{word!r} ({type(word).__name__})"
    order = closest_first(word, choices) if isinstance(word, str) else \
        [str(c) for c in choices]
    return (f"unknown {kind} {shown}{suggest(word, choices) if isinstance(word, str) else ''}"
            f"; valid names: {', '.join(order) or 'none'}")
