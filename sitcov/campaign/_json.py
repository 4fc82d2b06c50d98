"""Stored JSON that every reader accepts, non-finite numbers included.

Python's ``json`` writes ``inf`` and ``nan`` as the bare tokens ``Infinity`` and ``NaN``,
which are not JSON: SQLite's JSON functions (``json_extract``, used by the summary's SQL)
reject the whole cell as malformed, and so do strict readers of exports. A situation whose
pair never conflicts has ``ego_gap_at_switch = inf``, so healthy campaigns hold such values.

The stored form: a non-finite float is the JSON *string* ``"Infinity"``, ``"-Infinity"``
or ``"NaN"``; :func:`loads` turns exactly these three strings back into floats (a stored
string value equal to one of them reads back as the float: no sitcov field holds such a
text). Finite numbers are written as before, so files written before stay byte-identical.
"""

from __future__ import annotations

import json
import math
from typing import Any

#: The stored string of each non-finite float.
NON_FINITE: dict[str, float] = {"Infinity": math.inf, "-Infinity": -math.inf, "NaN": math.nan}
_MARKERS = tuple(f'"{k}"' for k in NON_FINITE)


def _finite(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by its stored string."""
    if isinstance(obj, float):
        if math.isfinite(obj):
            return obj
        return "NaN" if math.isnan(obj) else ("Infinity" if obj > 0 else "-Infinity")
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    return obj


def dumps(obj: Any, **kwargs: Any) -> str:
    """Strict JSON text of ``obj`` (keyword arguments as for :func:`json.dumps`).

    The fast path is ``json.dumps`` with ``allow_nan=False``; only a value that holds a
    non-finite float is walked and rewritten.
    """
    try:
        return json.dumps(obj, allow_nan=False, **kwargs)
    except ValueError:
        return json.dumps(_finite(obj), allow_nan=False, **kwargs)


def _restore(obj: Any) -> Any:
    if isinstance(obj, str):
        return NON_FINITE.get(obj, obj)
    if isinstance(obj, dict):
        return {k: _restore(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_restore(v) for v in obj]
    return obj


def loads(text: str | bytes) -> Any:
    """Decode stored JSON: the three non-finite strings become floats again. Bare
    ``Infinity``/``NaN`` tokens (files written by sitcov before this form) are read too."""
    data = json.loads(text)
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    if any(marker in text for marker in _MARKERS):
        return _restore(data)
    return data


def is_strict(text: str) -> bool:
    """True when ``text`` is JSON without the bare non-finite tokens."""
    try:
        json.loads(text, parse_constant=_refuse)
    except ValueError:
        return False
    return True


def _refuse(token: str) -> Any:
    raise ValueError(f"non-finite token {token}")
