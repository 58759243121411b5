"""`cam-bench design optimize SPEC.yaml`: the best lift law of a family under constraints.

SPEC keys: ``family``, ``fixed``, ``free``, ``objective``, ``constraints`` (and, where a
constraint needs them, ``valve_train``, ``cam_speed_rpm``, ``base_radius``, ``width``,
``follower``); see docs/optimization.md. Output: the optimal parameters, a scene
``lift_law`` block to paste, the lift table, the objective, every constraint's value,
slack and whether it is active, and the gain over the start design.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``design optimize``."""
    p = sub.add_parser(
        'optimize', help='optimise a lift law under design constraints (fullness, ...)',
        description='Find the lift law of a family that maximises fullness (or minimises '
                    'peak acceleration or jerk, or maximises the jump speed, or a weighted '
                    'sum) while meeting acceleration, jerk, curvature, Hertz stress, spring '
                    'margin and jump-speed limits. SPEC is a YAML file with the keys family, '
                    'fixed, free, objective, constraints (docs/optimization.md). Exit 0 '
                    'with an optimum, 1 when the SPEC is infeasible, 2 for a bad SPEC.')
    p.add_argument('spec', metavar='SPEC', help='optimisation spec (YAML)')
    p.add_argument('--json', metavar='FILE|-', help='write the full result as JSON '
                   '(- for standard output) instead of the summary')
    p.add_argument('--plot', metavar='DIR', help='PNG of the start and optimal h, h\'\' '
                   '(and the Pareto front with --pareto)')
    p.add_argument('--pareto', metavar='A,B', help='trace the trade-off between two '
                   'objective metrics (e.g. fullness,peak_jerk)')
    p.add_argument('--points', type=int, default=7, help='points on the Pareto front '
                   '(default 7)')
    return p


def _summary(res: Any) -> str:
    lines = [f'status: {res.status}' + (f' ({res.message})' if res.message else ''),
             f'method: {res.method}; {res.evaluations} evaluations in {res.seconds:.2f} s']
    lines.append('parameters: ' + ', '.join(f'{k} = {v:.6g}' for k, v in
                                            res.parameters.items()))
    for name, value in res.objective['metrics'].items():
        lines.append(f'objective {name}: {value:.6g}')
    if 'improvement' in res.start:
        lines.append(f'start objective {res.start["objective"]:.6g} '
                     f'({"feasible" if res.start["feasible"] else "infeasible"} start); '
                     f'gain {res.start["improvement"]:+.6g}')
    for name, c in res.constraints.items():
        flag = 'ACTIVE' if c['active'] else ('ok' if c['satisfied'] else 'VIOLATED')
        lines.append(f'  {name:<28} value {c["value"]:.6g}  limit {c["limit"]:.6g} '
                     f'{c["unit"]}  slack {c["slack"]:.3g}  {flag}')
    import yaml
    lines.append('lift_law block for a scene lobe:')
    lines += ['  ' + line for line in
              yaml.safe_dump({'lift_law': res.lift_law}, sort_keys=False).splitlines()]
    return '\n'.join(lines)


def _plot(folder: Path, res: Any, start_spec: dict[str, Any] | None,
          front: list[dict[str, Any]] | None, names: tuple[str, str] | None) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    from cam_design.lift_laws import from_spec

    from cam_metrology.inputs.files import output_dir, save_figure
    folder = output_dir(folder, '--plot')
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.5))
    laws = [('optimum', from_spec(res.lift_law, 'optimum'), '-')]
    if start_spec is not None:
        try:
            laws.append(('start', from_spec(start_spec, 'start'), '--'))
        except Exception:   # noqa: BLE001 -- an invalid start is simply not drawn
            pass
    for label, law, style in laws:
        a = np.linspace(*law.support, 2001)
        ax1.plot(np.degrees(a), law(a, 0) * 1e3, style, label=label)
        ax2.plot(np.degrees(a), law(a, 2) * 1e3, style, label=label)
    for name, c in res.constraints.items():
        if name == 'max_positive_acceleration':
            ax2.axhline(c['limit'] * 1e3, color='r', lw=0.7, ls=':', label='limits')
        if name == 'max_negative_acceleration':
            ax2.axhline(-c['limit'] * 1e3, color='r', lw=0.7, ls=':')
    ax1.set_ylabel('lift h [mm]')
    ax2.set_ylabel("h'' [mm/rad²]")
    ax2.set_xlabel('cam angle from the nose [deg]')
    ax1.legend(loc='upper right')
    ax2.legend(loc='lower right')
    shown = ', '.join(f'{k}={v:.4g}' for k, v in res.objective['metrics'].items())
    fig.suptitle(f'optimum: {shown}')
    fig.tight_layout()
    save_figure(fig, folder / 'optimum.png', '--plot', dpi=110)
    plt.close(fig)
    if front and names:
        fig, ax = plt.subplots(figsize=(6, 4.5))
        ax.plot([p[names[1]] for p in front], [p[names[0]] for p in front], 'o-')
        from cam_design.optimize import OBJECTIVES
        ax.set_xlabel(f'{names[1]} [{OBJECTIVES[names[1]][1]}]')
        ax.set_ylabel(f'{names[0]} [{OBJECTIVES[names[0]][1]}]')
        ax.set_title('Pareto front')
        fig.tight_layout()
        save_figure(fig, folder / 'pareto.png', '--plot', dpi=110)
        plt.close(fig)


def run(args: argparse.Namespace) -> int:
    """Handler of ``design optimize``."""
    from cam_design.errors import InputError
    from cam_design.optimize import candidate_spec, optimize, pareto, parse_spec
    from cam_metrology.cli.law_input import load_yaml

    spec = parse_spec(load_yaml(args.spec), 'spec')
    names = None
    if args.pareto is not None:
        parts = [p.strip() for p in args.pareto.split(',')]
        if len(parts) != 2:
            raise InputError('--pareto', args.pareto, 'two metric names, e.g. '
                             'fullness,peak_jerk')
        names = (parts[0], parts[1])
        if not 2 <= args.points <= 50:
            raise InputError('--points', args.points, 'an integer in [2, 50]')
    res = optimize(spec, progress=lambda m: print(f'  {m}', file=sys.stderr))
    front = pareto(spec, names[0], names[1], args.points) if names else None
    out = res.as_dict()
    if front is not None and names is not None:
        out['pareto'] = {'metrics': list(names), 'points': front}
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, out, '--json')
        if args.json != '-':
            print(f'cam-bench design optimize: wrote {args.json} ({res.status})')
    else:
        print(_summary(res))
        if front is not None and names is not None:
            print(f'Pareto front ({names[0]} vs {names[1]}):')
            for point in front:
                print(f'  {names[1]} {point[names[1]]:.6g}  ->  {names[0]} '
                      f'{point[names[0]]:.6g}')
    if args.plot:
        import numpy as np
        start = None
        try:
            start = candidate_spec(spec, np.array(list(res.start['parameters'].values())))
        except InputError:
            pass
        _plot(Path(args.plot), res, start, front, names)
    return 0 if res.status == 'optimal' else 1
