"""The acceptance layer of an analysed part, shared by `cam-bench analyze`, `card`, the
batch and the pytest plugin: the measured and nominal cam cards of each lobe (both as
seen by the probe, docs/cam_card.md) and, with a crank datum in the scene, the valve
events in crank degrees and the lobe separation of each cylinder.
"""
from __future__ import annotations

import math
from typing import Any


def crank_timing(scene: Any, cards: dict[str, dict[str, Any]],
                 phases: dict[str, float | None]) -> dict[str, Any] | None:
    """With a crank datum in the scene (docs/scene.md ``crank``): ``card['crank']`` for
    every lobe card whose lobe has a ``role`` and a phase [deg] (valve events in crank
    degrees around its centreline, ``crank_events``), and the lobe separation of each
    cylinder's intake/exhaust pair (in scene order). None without a crank datum."""
    from cam_design.cam_card import centreline_crank_atdc, crank_events, lobe_separation_deg

    crank = getattr(scene, 'crank', None)
    if crank is None:
        return None
    placed: dict[str, tuple[str, str, float]] = {}
    missing = []
    for lobe in scene.lobes:
        card, phase = cards.get(lobe.id), phases.get(lobe.id)
        if not lobe.role or card is None:
            continue
        if 'error' in card or phase is None or card.get('centreline_deg') is None:
            missing.append({'lobe': lobe.id, 'why': 'no phase (datum not measured or no '
                            'nominal_phase)' if phase is None else 'no card'})
            continue
        atdc = centreline_crank_atdc(phase, card['centreline_deg'], scene.direction,
                                     crank.tdc_deg, crank.cylinder_tdc_deg[lobe.cylinder])
        centre = atdc if lobe.role == 'intake' else -atdc
        card['crank'] = {**crank_events(card, lobe.role, centre), 'cylinder': lobe.cylinder}
        placed[lobe.id] = (lobe.role, lobe.cylinder, centre)
    pairs = []
    for cyl in crank.cylinder_tdc_deg:
        ins = [k for k, (r, c, _) in placed.items() if r == 'intake' and c == cyl]
        exs = [k for k, (r, c, _) in placed.items() if r == 'exhaust' and c == cyl]
        for i, e in zip(ins, exs):
            pairs.append({'cylinder': cyl, 'intake': i, 'exhaust': e,
                          'intake_centreline_atdc_deg': placed[i][2],
                          'exhaust_centreline_btdc_deg': placed[e][2],
                          'lobe_separation_deg': lobe_separation_deg(placed[i][2],
                                                                     placed[e][2])})
    return {'tdc_deg': crank.tdc_deg, 'cylinder_tdc_deg': dict(crank.cylinder_tdc_deg),
            'pairs': pairs, 'not_placed': missing}


def measured_cards(scene: Any, features: dict[str, Any], tables: dict[str, Any],
                   designs: dict[str, Any], heights: tuple[float, ...],
                   referenced: dict[str, Any] | None = None
                   ) -> dict[str, dict[str, Any]]:
    """lobe id -> {measured, nominal} cards (both as seen by the probe), or {error}.
    ``referenced``: filled with lobe id -> (alpha [rad], lift [m], probe radius [m]) of
    the measured tables referenced to the base circle (for a nominal-profile file)."""
    out: dict[str, dict[str, Any]] = {}
    for fid, table in tables.items():
        design = designs.get(fid)
        if table is None or design is None or (features.get(fid) or {}).get('status') != 'ok':
            continue
        from cam_metrology.metrology.lift_error import referenced_rows
        rows = referenced_rows(table, features[fid])
        # the two columns the card reads, contiguous
        alpha, lift = rows[:, 0].copy(), rows[:, 1].copy()
        del rows
        if referenced is not None:
            referenced[fid] = (alpha, lift,
                               scene.probe.radius if scene.probe.kind == 'roller' else 0.0)
        out[fid] = lobe_cards(scene, fid, alpha, lift, design, heights)
    return out


def lobe_cards(scene: Any, fid: str, alpha: Any, lift: Any, design: Any,
               heights: tuple[float, ...], area: float | None = None) -> dict[str, Any]:
    """{measured, nominal, follower} cards of one lobe (both as seen by the probe) from its
    base-referenced samples: ``alpha`` [rad], ``lift`` [m] (``area``: the measured lift
    area [m rad] when only the rows around the peak and events are given,
    ``lobe_columns.card_rows``); or {error} naming the problem."""
    from cam_design.cam_card import card_from_law, card_from_table
    from cam_design.errors import InputError

    rocker = scene.valve_train.rocker_ratio if scene.valve_train else None
    try:
        return {
            'measured': card_from_table(alpha, lift, heights, design, area=area,
                                        rocker_ratio=rocker, key='--heights-mm'),
            'nominal': card_from_law(design, heights, rocker_ratio=rocker,
                                     key='--heights-mm', derivatives=exact_seen(
                                         scene, fid, design), derivative_points=3601),
            'follower': 'the probe (' + scene.probe.kind + ')'}
    except InputError as exc:
        return {'error': str(exc)}


def exact_seen(scene: Any, fid: str, fallback: Any) -> Any:
    """The exact design lift as seen by the probe (not its tabulation), for h'''."""
    from cam_metrology.metrology.analysis import seen_lift

    try:
        return seen_lift(scene.lobe(fid), scene.probe, scene.base_circle_radius,
                         tabulate_step=None)
    except Exception:   # noqa: BLE001 - the tabulated law is then the best available
        return fallback


def both_crank_timings(scene: Any, features: dict[str, Any], cards: dict[str, Any]
                       ) -> dict[str, Any] | None:
    """``crank_timing`` of the measured cards (measured phases) and of the nominal cards
    (nominal phases): {tdc_deg, measured, nominal} or None without a crank datum."""
    if getattr(scene, 'crank', None) is None:
        return None
    measured = crank_timing(scene, {f: c['measured'] for f, c in cards.items()
                                    if 'measured' in c},
                            {f: (features.get(f) or {}).get('phase_deg') for f in cards})
    nominal = crank_timing(scene, {f: c['nominal'] for f, c in cards.items()
                                   if 'nominal' in c},
                           {lb.id: None if lb.nominal_phase is None else
                            math.degrees(lb.nominal_phase) for lb in scene.lobes})
    return {'tdc_deg': scene.crank.tdc_deg, 'measured': measured, 'nominal': nominal}
