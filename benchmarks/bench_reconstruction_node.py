"""The reconstruction node's cost per measured lift table, and what its lobe law adds.

One /metrology/lift table of lobe_1 of the default scene as the 12.5 mm roller probe
sees it (0.5 um Gaussian noise, 2 spikes, seed 21) at 360, 1800 and 3600 samples per
turn, through ``ReconstructionCore.handle`` (spline + harmonic, converted to the flat
design follower): CPU time (user + sys of this process, best of 3) as the node runs it,
with the lobe law of the rows (its warnings, the fit's frame), and with the lobe law
left out (the node before it published the lobe law's warnings); the spline's RMS lift
error against the design lift seen by the probe. Run:
``python -m benchmarks reconstruction_node``.
"""
from __future__ import annotations

import math
import os
import time
import types
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.machine import report

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / 'benchmarks' / 'results' / 'reconstruction_node.md'
REPEATS = 3


def _msg(data: np.ndarray) -> Any:
    """A duck-typed Float64MultiArray of the table (label lobe_1)."""
    dims = [types.SimpleNamespace(label='lobe_1', size=data.shape[0], stride=data.size),
            types.SimpleNamespace(label='alpha_rad,lift_m,design_lift_m',
                                  size=data.shape[1], stride=data.shape[1])]
    return types.SimpleNamespace(layout=types.SimpleNamespace(dim=dims, data_offset=0),
                                 data=data.ravel().tolist())


def _run(text: str, msg: Any) -> tuple[float, float]:
    """(best CPU [s] of one table through the core, spline RMS lift error [m])."""
    from cam_metrology.reconstruction.core import ReconstructionCore

    best, err = math.inf, math.nan
    for _ in range(REPEATS):
        core = ReconstructionCore({'methods': 'spline,harmonic'})
        core.handle('/bench/scene', types.SimpleNamespace(data=text), 1)
        c0 = time.process_time()
        core.handle('/metrology/lift', msg, 2)
        best = min(best, time.process_time() - c0)
        err = core.results['lobe_1']['spline'].design_errors['rms_error_lift_m']
    return best, err


def main() -> None:
    """Run and write benchmarks/results/reconstruction_node.md."""
    import cam_design.lift_table.lobe_routes as routes
    from cam_design.follower import convert_lift
    from cam_metrology.reconstruction.synthetic import simulate
    from cam_metrology.scene.parse import parse_scene

    text = (ROOT / 'config' / 'default_scene.yaml').read_text(encoding='utf-8')
    scene = parse_scene(text)
    lobe = scene.lobe('lobe_1')
    seen = convert_lift(lobe.lift, scene.base_circle_radius, lobe.follower, scene.probe)
    rows = ['| samples/turn | CPU with the lobe law [ms] | CPU without [ms] | '
            'spline RMS lift error [um] |', '|---:|---:|---:|---:|']
    real = routes.lobe_warnings
    for n in (360, 1800, 3600):
        a, h = simulate(seen, n, 0.5e-6, seed=21, outliers=2)
        msg = _msg(np.column_stack([a, h, seen(a)]))
        with_law, err = _run(text, msg)
        routes.lobe_warnings = lambda *args, **kw: (None, [])   # type: ignore[assignment]
        try:
            without, _ = _run(text, msg)
        finally:
            routes.lobe_warnings = real
        rows.append(f'| {n} | {with_law * 1e3:.0f} | {without * 1e3:.0f} | '
                    f'{err * 1e6:.3f} |')
    rows += ['', f'load average at the end: {os.getloadavg()[0]:.2f}']
    report('Reconstruction node: one lift table, with and without its lobe law', __doc__,
           rows, OUT)


if __name__ == '__main__':
    main()
