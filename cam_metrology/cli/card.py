"""`cam-bench card INPUT`: the cam card of a design, a lift table or a measured bag.

INPUT is a scene file (.yaml/.yml: the design card of each lobe, for its design
follower), a lift table (CSV with alpha_*/lift_* columns, or a gauge nominal-profile
file), or a bag (each measured lobe: the measured card beside the nominal card of the
design as seen by the same probe). Definitions: docs/cam_card.md.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from cam_design.cam_card import DEFAULT_HEIGHTS_M
from cam_metrology.cli.conventions import add_table_units, table_units
from cam_metrology.offline.acceptance import both_crank_timings, crank_timing, measured_cards


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``card`` subcommand."""
    p = subparsers.add_parser(
        'card', help='cam card: durations at checking heights, max lift, centreline, LSA',
        description='The cam card of a scene (design), a lift table (CSV or gauge '
                    'nominal-profile file) or a bag (measured vs nominal). Angles in cam '
                    'degrees from the lobe centreline (rise negative), crank = 2 x cam.')
    p.add_argument('input', metavar='SCENE|TABLE|BAG',
                   help='scene .yaml, lift table (CSV or gauge file) or bag')
    add_table_units(p, 'a gauge-file input')
    p.add_argument('--json', metavar='FILE|-',
                   help='write the cards as JSON (- for standard output)')
    p.add_argument('--nominal', metavar='FILE', help='write the lobe (--lobe, or the only '
                   'one) as a gauge nominal-profile file: a scene lobe as seen by the scene '
                   'probe every 0.5 deg, a table as read, a bag lobe as measured (referenced '
                   'to its base circle)')
    p.add_argument('--heights-mm', metavar='LIST', default=None,
                   help='checking heights [mm], comma-separated (default 1,1.27,0.1)')
    p.add_argument('--lobe', metavar='ID', help='only this lobe (scene or bag)')
    p.add_argument('--pair', metavar='INTAKE,EXHAUST',
                   help='lobe ids of an intake/exhaust pair: lobe separation angle (from the '
                        'nominal phases of a scene, the measured phases of a bag)')
    p.add_argument('--intake-centreline-deg', type=float, metavar='DEG',
                   help='with --pair: intake centreline in crank deg ATDC; gives the valve '
                        'events of both lobes in crank degrees (BTDC/ABDC, BBDC/ATDC)')
    return p


def heights_from(args: argparse.Namespace) -> tuple[float, ...]:
    """The checking heights [m] of ``--heights-mm`` (default 1 mm, 0.050 in, 0.1 mm)."""
    from cam_design.cam_card import parse_heights_mm

    return DEFAULT_HEIGHTS_M if args.heights_mm is None else parse_heights_mm(args.heights_mm)


def _wrap180(x: float) -> float:
    y = (x + 180.0) % 360.0 - 180.0
    return 180.0 if y == -180.0 else y


def _lsa(phases: dict[str, float | None], pair: str, cards: dict[str, Any],
         intake_cl: float | None) -> dict[str, Any]:
    """Lobe separation of an intake/exhaust pair from their phases [deg]; with the intake
    centreline [crank deg ATDC], the exhaust centreline and both lobes' crank events."""
    from cam_design.cam_card import crank_events
    from cam_design.errors import InputError

    ids = [p.strip() for p in pair.split(',')]
    if len(ids) != 2:
        raise InputError('--pair', pair, 'two lobe ids INTAKE,EXHAUST')
    known: dict[str, float] = {}
    for i in ids:
        if i not in phases:
            raise InputError('--pair', pair, f'lobe ids of the input (no {i!r}; have '
                             f'{", ".join(phases)})')
        phase = phases[i]
        if phase is None:
            raise InputError('--pair', pair, f'lobes with a phase ({i} has none: no '
                             'nominal_phase in the scene, or no dowel pin measured)')
        known[i] = phase
    lsa = abs(_wrap180(known[ids[1]] - known[ids[0]]))
    out: dict[str, Any] = {'intake': ids[0], 'exhaust': ids[1], 'lobe_separation_deg': lsa}
    if intake_cl is not None:
        ecl = 2.0 * lsa - intake_cl
        out.update({'intake_centreline_atdc_deg': intake_cl,
                    'exhaust_centreline_btdc_deg': ecl})
        for lobe, role, cl in ((ids[0], 'intake', intake_cl), (ids[1], 'exhaust', ecl)):
            cards[lobe]['crank'] = crank_events(cards[lobe], role, cl)
    return out


def crank_text(doc: dict[str, Any] | None, label: str = '') -> list[str]:
    """Human lines of ``crank_timing``'s pairs."""
    if not doc:
        return []
    lines = [f"crank{label}: cylinder {p['cylinder']} {p['intake']}/{p['exhaust']}: intake "
             f"centreline {p['intake_centreline_atdc_deg']:.2f} ATDC, exhaust "
             f"{p['exhaust_centreline_btdc_deg']:.2f} BTDC, lobe separation "
             f"{p['lobe_separation_deg']:.3f} cam deg" for p in doc['pairs']]
    lines += [f"crank{label}: {m['lobe']} not placed: {m['why']}" for m in doc['not_placed']]
    return lines


def scene_cards(path: str, heights: tuple[float, ...], lobe: str | None
                ) -> tuple[dict[str, Any], dict[str, float | None]]:
    """Design cards of a scene's lobes (design follower) and their nominal phases [deg]."""
    from cam_design.cam_card import card_from_law
    from cam_design.errors import InputError
    from cam_metrology.scene.parse import load_scene

    scene = load_scene(path)
    ids = [lb.id for lb in scene.lobes]
    if lobe is not None and lobe not in ids:
        raise InputError('--lobe', lobe, 'one of ' + ', '.join(ids))
    rocker = scene.valve_train.rocker_ratio if scene.valve_train else None
    cards, phases = {}, {}
    for lb in scene.lobes:
        phases[lb.id] = None if lb.nominal_phase is None else math.degrees(lb.nominal_phase)
        if lobe is None or lb.id == lobe:
            cards[lb.id] = card_from_law(lb.lift, heights, rocker_ratio=rocker,
                                         key='--heights-mm')
            cards[lb.id]['follower'] = lb.follower.kind
    _CRANK['doc'] = crank_timing(scene, cards, phases)
    return cards, phases


def bag_cards(bag: str, heights: tuple[float, ...], lobe: str | None
              ) -> tuple[dict[str, Any], dict[str, float | None]]:
    """Measured vs nominal cards of a bag (metrology core only) and measured phases."""
    from cam_metrology.offline.analyze import final_report, make_cores, replay

    cores, _ = make_cores({}, True)
    result = replay(bag, cores)
    metrology = cores[0]
    outputs = [(o.stamp_ns, o.output) for o in result.outputs]
    report = final_report(outputs, metrology)
    tables = {f: r.table for f, r in metrology.results.items() if r.kind == 'lobe'}
    if lobe is not None:
        tables = {f: t for f, t in tables.items() if f == lobe}
    cards = measured_cards(metrology.scene, report['features'], tables,
                           metrology._design, heights, referenced=_NOMINAL_DATA)
    phases = {f: v.get('phase_deg') for f, v in report['features'].items()
              if v.get('kind') == 'lobe'}
    _CRANK['doc'] = both_crank_timings(metrology.scene, report['features'], cards)
    return cards, phases


#: the crank timing of the last scene_cards / bag_cards call (for run)
_CRANK: dict[str, Any] = {}


def write_nominal(args: argparse.Namespace, kind: str, cards: dict[str, Any]) -> None:
    """``card --nominal FILE`` (see the option's help)."""
    import numpy as np

    from cam_design.errors import InputError
    from cam_metrology.inputs.files import write_output
    from cam_metrology.report.nominal_file import gauge_text, law_gauge_text
    from cam_design.lift_table.samples import clean_samples

    ids = list(cards)
    lobe = args.lobe or (ids[0] if len(ids) == 1 else None)
    if lobe is None or lobe not in ids:
        raise InputError('--lobe', args.lobe, 'the lobe to write with --nominal: one of '
                         + ', '.join(ids))
    note = [f'from {args.input} ({kind}), lobe {lobe}; deg and mm']
    if kind == 'scene':
        from cam_metrology.metrology.analysis import seen_lift
        from cam_metrology.scene.parse import load_scene

        scene = load_scene(args.input)
        law = seen_lift(scene.lobe(lobe), scene.probe, scene.base_circle_radius,
                        tabulate_step=None)
        radius = scene.probe.radius if scene.probe.kind == 'roller' else 0.0
        text = law_gauge_text(law, 0.5, radius, note + ['as seen by the scene probe'])
    else:
        alpha, lift, radius = _NOMINAL_DATA[lobe]
        data = clean_samples(alpha, lift, key=lobe)
        text = gauge_text(np.degrees(data.alpha), data.lift, radius, note)
    write_output(args.nominal, text, '--nominal')


def table_card(alpha: Any, lift: Any, heights: tuple[float, ...], name: str
               ) -> dict[str, Any]:
    """The card of a lift table [rad, m]: that of its lobe law
    (``cam_design.lift_table.lobe_table.lobe_law``, the same lobe every route reads from the
    rows, its angles in the lobe law's frame: the lobe in the turn of the first row),
    with ``source`` and ``note`` saying how the rows became the lobe and ``warning``
    what they could not tell."""
    from cam_design.cam_card import card_from_law
    from cam_design.lift_table.lobe_table import lobe_law

    law = lobe_law(alpha, lift, key=name, allow_steps=True)
    card = card_from_law(law, heights, key='--heights-mm', floor=law.lobe.level,
                         joins=law_joins(law))
    card['source'] = f'table ({law.lobe.method})'
    card['note'] = law.lobe.note()
    said = [w for w in law.lobe.warnings if w]
    if said:
        card['warning'] = '; '.join(said)
    return card


def law_joins(law: Any) -> list[tuple[float, float, float]]:
    """(start, end [rad], lift at the lobe end [m]) of each mid-lobe join of a table's
    lobe law: below that lift the events are the join's, not the table's."""
    info = getattr(law, 'lobe', None)
    if info is None:
        return []
    out = []
    for side in info.mid_lobe:
        lo, hi = info.joins[0] if side == 'start' else info.joins[1]
        at = (hi if side == 'start' else lo) + info.law_offset
        out.append((lo + info.law_offset, hi + info.law_offset, float(law(at))))
    return out


#: lobe -> (alpha [rad], lift [m], probe radius [m]) of tables and bags, for --nominal
_NOMINAL_DATA: dict[str, tuple[Any, Any, float]] = {}


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench card``."""
    from cam_design.cam_card import card_text
    from cam_design.errors import InputError

    heights = heights_from(args)
    _NOMINAL_DATA.clear()
    _CRANK.clear()
    path = Path(args.input)
    if not path.exists():
        raise InputError('input', args.input, 'an existing scene, lift table or bag')
    phases: dict[str, float | None] = {}
    is_table = not (path.is_dir() or path.suffix in ('.mcap', '.yaml', '.yml'))
    for unit in ('angle_unit', 'length_unit'):
        if getattr(args, unit) is not None and not is_table:
            raise InputError('--' + unit.replace('_', '-'), getattr(args, unit),
                             'a lift TABLE input (gauge file; a scene or a bag has SI '
                             'units)')
    if path.is_dir() or path.suffix == '.mcap':
        kind = 'bag'
        cards, phases = bag_cards(args.input, heights, args.lobe)
        flat = {}
        for fid, both in cards.items():
            if 'error' in both:
                flat[fid] = both
                continue
            flat[f'{fid} measured'] = both['measured']
            flat[f'{fid} nominal'] = both['nominal']
    elif path.suffix in ('.yaml', '.yml'):
        kind = 'scene'
        cards, phases = scene_cards(args.input, heights, args.lobe)
        flat = cards
    else:
        from cam_metrology.inputs.lift_tables import read_table_file
        kind = 'table'
        table = read_table_file(path, **table_units(args))
        cards = {table.feature: table_card(table.alpha, table.lift, heights, path.name)}
        _NOMINAL_DATA[table.feature] = (table.alpha, table.lift,
                                        table.follower[1] if table.follower else 0.0)
        flat = cards
    if args.nominal:
        write_nominal(args, kind, cards)
    doc: dict[str, Any] = {'input': str(path), 'kind': kind,
                           'heights_m': list(heights), 'cards': cards}
    if _CRANK.get('doc'):
        doc['crank'] = _CRANK['doc']
    if args.pair:
        target = cards if kind != 'bag' else {k: v.get('measured') for k, v in cards.items()}
        doc['lobe_separation'] = _lsa(phases, args.pair, target, args.intake_centreline_deg)
    elif args.intake_centreline_deg is not None:
        raise InputError('--intake-centreline-deg', args.intake_centreline_deg,
                         'also --pair INTAKE,EXHAUST (the lobes it applies to)')
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, doc, '--json')
        return 0
    errors = {k: v['error'] for k, v in flat.items() if 'error' in v}
    print(card_text({k: v for k, v in flat.items() if 'error' not in v}))
    for k, e in errors.items():
        print(f'{k}: card not computed: {e}')
    crank = doc.get('crank') or {}
    if 'measured' in crank:
        for label in ('measured', 'nominal'):
            print('\n'.join(crank_text(crank[label], ' ' + label)))
    elif crank:
        print('\n'.join(crank_text(crank)))
    if 'lobe_separation' in doc:
        s = doc['lobe_separation']
        print(f"lobe separation {s['intake']}/{s['exhaust']}: "
              f"{s['lobe_separation_deg']:.3f} cam deg"
              + (f", intake centreline {s['intake_centreline_atdc_deg']:.2f} ATDC, exhaust "
                 f"{s['exhaust_centreline_btdc_deg']:.2f} BTDC"
                 if 'intake_centreline_atdc_deg' in s else ''))
    return 1 if errors else 0
