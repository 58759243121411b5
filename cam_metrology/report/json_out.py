"""The one JSON writer of every command: plain JSON types, no NaN, UTF-8 files.

Every ``--json`` (and the golden file) goes through ``write_json``: numpy scalars and
arrays become plain numbers and lists, tuples lists, non-finite floats ``null`` (JSON
has no NaN or Infinity), then ``json.dumps(..., allow_nan=False)`` with one space of
indent; the file is written all or nothing (``inputs.files.write_output``), ``-`` is
standard output.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np


def json_safe(obj: Any) -> Any:
    """Plain JSON types (numpy scalars -> float/int, arrays -> lists, non-finite -> None)."""
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def json_text(doc: Any, *, sort_keys: bool = False) -> str:
    """The JSON text of ``doc`` as every command writes it (ends with a newline)."""
    return json.dumps(json_safe(doc), indent=1, sort_keys=sort_keys, allow_nan=False) + '\n'


def write_json(target: str | Path, doc: Any, key: str, *, sort_keys: bool = False) -> None:
    """Write ``doc`` as JSON to the file ``target`` ('-': standard output); a failure is
    InputError naming the option ``key``."""
    from cam_metrology.inputs.files import write_output

    write_output(target, json_text(doc, sort_keys=sort_keys), key)
