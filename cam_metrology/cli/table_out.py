"""``--csv`` and ``--json`` of the commands that print a table of columns (design law,
design profile, grind): one CSV layout, the JSON through the one writer."""
from __future__ import annotations

from typing import Any, Sequence


def csv_text(names: Sequence[str], rows: Any, digits: int = 12) -> str:
    """A header row of ``names`` and one row per table row, ``digits`` significant
    digits (an infinite radius is written ``inf``)."""
    lines = [','.join(names)] + [','.join(f'{float(v):.{digits}g}' for v in row)
                                 for row in rows]
    return '\n'.join(lines) + '\n'


def write_table(csv: str | None, json: str | None, names: Sequence[str], table: Any,
                summary: dict[str, Any], *, digits: int = 12) -> bool:
    """Write ``table`` (rows x ``names``) as CSV to ``csv`` and/or as JSON (``summary``
    plus ``columns`` and ``rows``) to ``json`` ('-': standard output); True if anything
    was written. Errors name ``--csv`` / ``--json``."""
    from cam_metrology.inputs.files import write_output
    from cam_metrology.report.json_out import write_json

    if csv:
        write_output(csv, csv_text(names, table, digits), '--csv')
    if json:
        write_json(json, dict(summary, columns=list(names), rows=table), '--json')
    return bool(csv or json)
