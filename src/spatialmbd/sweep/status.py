"""The status of a sweep member ("success" or "failed") and the text of a member's failure."""
from __future__ import annotations

FAILED = "failed"
SUCCESS = "success"


def _describe(exc) -> str:
    text = str(exc).strip() or repr(exc)
    return f"{type(exc).__name__}: {text}"
