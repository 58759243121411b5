"""The offline analysis of a bag: the cores of the registry, fed from the bag by
``replay.run_offline`` (the live code path), and the final report they leave.
Used by ``cam-bench analyze``, ``card``, ``golden``, ``batch`` and the pytest plugin.
"""
from __future__ import annotations

import json
from typing import Any

from cam_metrology.wire.topics import METROLOGY_REPORT as REPORT_TOPIC


def make_cores(params: dict[str, dict[str, Any]], only_metrology: bool,
               ) -> tuple[list[Any], list[dict[str, str]]]:
    """The metrology core first, then (unless ``only_metrology``) every other core of the
    registry; the second item (what was skipped) is empty: every core is in the tree."""
    from cam_metrology.registry import CORES

    nodes = ['metrology'] + ([] if only_metrology else [n for n in CORES if n != 'metrology'])
    return [CORES[node](params.get(node)) for node in nodes], []


def replay(bag: str, cores: list[Any], *, keep_all: bool = True) -> Any:
    """Run the bag through the cores with ``replay.run_offline`` (the live code path).
    ``keep_all=False``: of the tables of a feature measured more than once only the
    last is kept (memory bounded whatever the bag's length; not for ``--out-bag``)."""
    from cam_metrology.replay import run_offline

    return run_offline(bag, cores, superseded_tables=keep_all)


def final_report(outputs: list[tuple[int, Any]], metrology: Any) -> dict[str, Any]:
    """The last report the metrology core published (its final one)."""
    from cam_metrology.outputs import TextOutput

    texts = [o.text for _, o in outputs if isinstance(o, TextOutput) and o.topic == REPORT_TOPIC]
    if texts:
        return json.loads(texts[-1])
    if getattr(metrology, 'scene', None) is None:
        from cam_design.errors import CliError
        raise CliError('the bag has no /bench/scene message: nothing to analyse')
    return metrology.report(final=True)


def other_skips(outputs: list[tuple[int, Any]]) -> list[dict[str, str]]:
    """``skipped/<what>`` statuses of the other cores' result topics."""
    from cam_metrology.outputs import StatusOutput

    out = []
    for _, o in outputs:
        if isinstance(o, StatusOutput) and not o.topic.startswith('/metrology/'):
            for st in o.statuses:
                if st.name.startswith('skipped/'):
                    out.append({'what': st.name[len('skipped/'):], 'why': st.message,
                                'node': o.topic.split('/')[1]})
    return out
