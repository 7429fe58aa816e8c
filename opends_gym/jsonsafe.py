"""JSON that other tools can read: NaN and infinities become null.

Why: Python's `json` writes `NaN` and `Infinity`, which are not JSON; metrics are often
NaN (no reaction, no lead car) or infinite (no closing speed), and `--json` outputs and
`metrics.json` files are read by other programs.
"""

from __future__ import annotations

import json
import math
from typing import IO, Any


def json_safe(o: Any) -> Any:
    """A copy of `o` with non-finite floats as None and unknown objects as strings."""
    if isinstance(o, bool) or o is None or isinstance(o, (int, str)):
        return o
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {str(k): json_safe(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [json_safe(v) for v in o]
    if hasattr(o, "item"):  # numpy scalars
        return json_safe(o.item())
    return str(o)


def dump_json(o: Any, stream: IO[str], indent: int | None = None) -> None:
    """Write `o` as strict JSON (allow_nan=False) and a newline."""
    json.dump(json_safe(o), stream, indent=indent, allow_nan=False)
    stream.write("\n")
