"""The offline analysis of a bag: the cores of the registry, fed from the bag by
``replay.run_offline`` (the live code path), and the final report they leave.
Used by ``cam-bench analyze``, ``card``, ``golden``, ``batch`` and the pytest plugin.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cam_metrology.wire.topics import METROLOGY_REPORT as REPORT_TOPIC


def make_cores(params: dict[str, dict[str, Any]], only_metrology: bool,
               ) -> tuple[list[Any], list[dict[str, str]]]:
    """The metrology core first, then (unless ``only_metrology``) every other core of the
    registry; the second item (what was skipped) is empty: every core is in the tree."""
    from cam_metrology.offline.registry import CORES

    nodes = ['metrology'] + ([] if only_metrology else [n for n in CORES if n != 'metrology'])
    return [CORES[node](params.get(node)) for node in nodes], []


def replay(bag: str, cores: list[Any], *, keep_all: bool = True,
           out_bag: str | None = None) -> Any:
    """Run the bag through the cores with ``replay.run_offline`` (the live code path).
    ``keep_all=False``: of the tables of a feature measured more than once only the
    last is kept (memory bounded whatever the bag's length). ``out_bag``: a new bag
    with the input messages and every output, written during the replay
    (``replay.OutputBagWriter``: the outputs are not held for it)."""
    from cam_metrology.offline.replay import OutputBagWriter, regenerated_topics, run_offline

    if out_bag is None:
        return run_offline(bag, cores, superseded_tables=keep_all)
    writer = OutputBagWriter(bag, out_bag, regenerated_topics(bag, cores))
    try:
        result = run_offline(bag, cores, superseded_tables=keep_all, sink=writer.add)
    except BaseException:
        writer.abort()
        raise
    writer.close()
    return result


def final_report(outputs: list[tuple[int, Any]], metrology: Any) -> dict[str, Any]:
    """The last report the metrology core published (its final one), taken as data from
    the core when it is the final report (no JSON text read back)."""
    from cam_metrology.cores.outputs import TextOutput

    kept = getattr(metrology, 'final_report', None)
    if kept is not None:
        return kept
    texts = [o.text for _, o in outputs if isinstance(o, TextOutput) and o.topic == REPORT_TOPIC]
    if texts:
        return json.loads(texts[-1])
    if getattr(metrology, 'scene', None) is None:
        from cam_design.errors import CliError
        raise CliError('the bag has no /bench/scene message: nothing to analyse')
    return metrology.report(final=True)


def other_skips(outputs: list[tuple[int, Any]]) -> list[dict[str, str]]:
    """``skipped/<what>`` statuses of the other cores' result topics."""
    from cam_metrology.cores.outputs import StatusOutput

    out = []
    for _, o in outputs:
        if isinstance(o, StatusOutput) and not o.topic.startswith('/metrology/'):
            for st in o.statuses:
                if st.name.startswith('skipped/'):
                    out.append({'what': st.name[len('skipped/'):], 'why': st.message,
                                'node': o.topic.split('/')[1]})
    return out


def load_params(path: str | None) -> dict[str, dict[str, Any]]:
    """node -> parameters from a ROS parameter file (empty when no file).

    Raises InputError naming ``--params`` for an unreadable or malformed file, and
    ``params.<node>`` for a node name that matches no core (a mistyped section would
    otherwise be ignored without a word)."""
    if path is None:
        return {}
    from cam_design.errors import InputError
    from cam_metrology.inputs.params import load_params_doc, section_values
    from cam_metrology.offline.registry import CORES

    doc = load_params_doc(path)   # the reader `cam-bench run --params` uses
    for node in doc:
        if str(node).lstrip('/') not in CORES:
            raise InputError(f'params.{node}', node,
                             f'a node name: one of {", ".join(CORES)}')
    present = {str(node).lstrip('/') for node in doc}
    return {name: section_values(doc, path, name) for name in CORES if name in present}


def bag_warnings(bag: str) -> list[str]:
    """Checks of the bag before the replay (docs/contract.md §4): InputError for a
    damaged bag (naming the range), a bag without a scene or with an invalid scene
    (naming its bad key), a bag whose scenes name two camshafts (two parts: one report
    would attribute one part's features to the other); a warning line when the scene
    of the same camshaft changes during the bag (each feature is then analysed with the
    scene in force when it was measured)."""
    from cam_metrology.scene.recorded import require_scenes

    scenes = require_scenes(bag)
    if len(scenes) < 2:
        return []
    ids = [sc.scene.camshaft_id for sc in scenes]
    if len(set(ids)) > 1:   # two parts in one bag: one report would mix them
        from pathlib import Path

        from cam_design.errors import InputError
        first = next(sc for sc in scenes if sc.scene.camshaft_id != ids[0])
        raise InputError('bag', Path(bag), f'one camshaft per bag: its /bench/scene changes '
                         f'camshaft_id from {ids[0]!r} to {first.scene.camshaft_id!r} at '
                         f'log time {first.stamp_ns / 1e9:.6f} s (two parts: record or '
                         'split them into one bag each)')
    times = ', '.join(f'{sc.scene.camshaft_id or "(no id)"} from log time '
                      f'{sc.stamp_ns / 1e9:.6f} s' for sc in scenes)
    return [f'the bag holds {len(scenes)} different scenes ({times}): each feature is '
            'analysed with the scene in force when it was measured (report: scenes, '
            'features.*.scene_index)']


def add_cards_and_provenance(report: dict[str, Any], metrology: Any, bag: str,
                             params: str | None, heights: tuple[float, ...], *,
                             plot_tables: bool = True) -> dict[str, Any]:
    """Add ``features.<id>.cam_card`` {measured, nominal} and ``provenance`` to the
    report; returns the lift tables (feature id -> table) for the HTML plots, those of
    lobes referenced to the base circle as the verdict uses them ({} without
    ``plot_tables``: no referenced copies made, for a caller that draws nothing)."""
    from cam_metrology.offline.acceptance import both_crank_timings, lobe_cards
    from cam_metrology.metrology.lift_error import referenced_rows
    import numpy as np

    from cam_metrology.metrology.lobe_columns import card_rows, support_area
    from cam_metrology.metrology.spill import release, spill
    from cam_metrology.report.provenance import provenance

    results = getattr(metrology, 'results', {})
    tables = {f: r.table for f, r in results.items() if r.table is not None}
    scene = getattr(metrology, 'scene', None)
    if scene is not None:
        features = report.get('features', {})
        designs = getattr(metrology, '_design', {})
        cards: dict[str, dict[str, Any]] = {}
        for fid, table in tables.items():   # one lobe at a time, referenced once
            feature = features.get(fid) or {}
            card = designs.get(fid) is not None and feature.get('status') == 'ok'
            if results[fid].kind != 'lobe' or not (card or plot_tables):
                continue
            kept = referenced_rows(table, feature)   # the rows the verdict used
            release(table)
            # a long table: the rows around the peak and the events the card fits, and
            # its area summed a block at a time (memory)
            design = designs.get(fid)
            alpha, lift = card_rows(kept, design, heights)
            area = support_area(kept, design.support) if card and design is not None \
                and isinstance(kept, np.memmap) else None
            if plot_tables:
                tables[fid] = spill(kept)
            del kept   # the cards read two columns: the table is not kept alongside
            if card:
                cards[fid] = lobe_cards(scene, fid, alpha, lift, designs[fid], heights,
                                        area=area)
            del alpha, lift
        crank = both_crank_timings(scene, features, cards)
        if crank is not None:
            report['crank'] = crank
        for fid, card_ in cards.items():
            report['features'][fid]['cam_card'] = card_
    report['provenance'] = provenance(
        bag=bag, scene_text=scene.text if scene is not None else None,
        params=load_params(params) or None, command='analyze')
    return tables if plot_tables else {}


@dataclass
class Analysis:
    """What ``analyze_bag`` leaves: the JSON-ready report (cards and provenance added),
    the cores' outputs as (stamp ns, output), the replay result, the metrology core, the
    lift tables of the HTML plots, and the warnings (also in the report)."""

    report: dict[str, Any]
    outputs: list[tuple[int, Any]]
    result: Any
    metrology: Any
    tables: dict[str, Any]
    warnings: list[str] = field(default_factory=list)


def analyze_bag(bag: str, params: str | None = None, *, only_metrology: bool = False,
                keep_all: bool = False, heights: tuple[float, ...] | None = None,
                out_bag: str | None = None, plot_tables: bool = True) -> Analysis:
    """The analysis of ``cam-bench analyze BAG``: checks of the bag, the replay through
    the cores, the final report with the other cores' skips, warnings, cam cards and
    provenance. ``out_bag``: the bag of ``--out-bag``, written during the replay
    (``replay``). ``plot_tables``: keep the lift tables of the HTML plots
    (``Analysis.tables``; {} otherwise). Raises InputError for a bad bag or parameter
    file (the CLI's exit 2)."""
    from cam_design.cam_card import DEFAULT_HEIGHTS_M
    from cam_design.errors import InputError
    from cam_metrology.host.heap import bounded_heap
    from cam_metrology.wire.topics import JOINT_STATES

    bounded_heap()   # whole-feature arrays returned to the system when freed

    from cam_metrology.scene.parse import shared_parses

    cores, missing = make_cores(load_params(params), only_metrology)
    with shared_parses():   # the bag's scene parsed once, for the checks and every core
        warnings = bag_warnings(bag)   # damaged bag, no or invalid scene: InputError here
        result = replay(bag, cores, keep_all=keep_all, out_bag=out_bag)
    if result.samples == 0:
        raise InputError('bag', bag, f'{JOINT_STATES} samples (the bag has none: '
                         'nothing to measure)')
    for issue in result.joint_issues:
        if issue.count >= result.samples or not result.usable_samples:
            # not one usable sample: name the field
            raise issue.error(result.samples)
        warnings.append(f'{issue.text(result.samples)}: those samples are dropped and '
                        'counted (samples_nan_dropped)')
    outputs = [(o.stamp_ns, o.output) for o in result.outputs]
    metrology = next(c for c in cores if c.name == 'metrology')
    report = final_report(outputs, metrology)
    report['skipped'] = report.get('skipped', []) + other_skips(outputs) + missing
    if warnings:
        report['warnings'] = report.get('warnings', []) + warnings
    tables = add_cards_and_provenance(report, metrology, bag, params,
                                      DEFAULT_HEIGHTS_M if heights is None else heights,
                                      plot_tables=plot_tables)
    return Analysis(report, outputs, result, metrology, tables, warnings)


def analyze_report(bag: str | Path, params: str | None = None, *,
                   only_metrology: bool = False) -> dict[str, Any]:
    """The JSON report of ``cam-bench analyze BAG`` as a dict (the same code path, as
    written by ``--json``). Raises ``CliError`` with analyze's one-line message when the
    bag cannot be analysed (not a bag, no samples, bad scene ...)."""
    from pathlib import Path

    from cam_design.errors import CliError, InputError

    if not Path(bag).exists():
        raise CliError(str(InputError('bag', str(bag), 'an existing rosbag2 directory')))
    try:
        run = analyze_bag(str(bag), None if params is None else str(params),
                          only_metrology=only_metrology, plot_tables=False)
    except (InputError, CliError) as exc:
        raise CliError(str(exc)) from None
    return json.loads(json.dumps(run.report))
