"""Cam-speed sweeps: separation (jump) speed and bounce onset speed, and plots.

The jump speed is the lowest cam speed with a separation (docs/contract.md event
definitions); the bounce onset the lowest with a bounce. Both are bracketed on the
sweep grid (first grid speed with the event, the previous one without) and refined by
bisection to ``tol_rpm``. A sweep reuses one CamInput (the cam polynomial does not
depend on speed) and simulates one revolution from rest per speed (enough for both
events: the valve is at rest before the lobe at any speed where it still seats), stopped
at the end of the first bounce (``simulate_cam(events_only=True)``).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_positive
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.cam_input import CamInput, build_cam_input
from cam_design.valve_train.params import SdofParams, require_rpm
from cam_design.valve_train.sdof import SdofResult, simulate_cam


@dataclass
class SweepResult:
    """Per-speed summary arrays and the refined event speeds (None: not reached).

    ``bounced``: the valve bounced at least once (the sweep stops at the end of the first
    bounce, so it does not count bounces: a full run's ``bounce_count`` does).
    """

    rpm: NDArray[np.float64]
    separated: NDArray[np.bool_]
    bounced: NDArray[np.bool_]
    seating_velocity: NDArray[np.float64]     # m/s (nan if the valve never seated)
    max_lift: NDArray[np.float64]             # m
    jump_speed_rpm: float | None
    bounce_onset_rpm: float | None
    seconds: float                            # wall time of the grid sweep

    def as_dict(self) -> dict[str, object]:
        """JSON-ready summary."""
        return {
            'sweep_rpm': self.rpm.tolist(), 'separated': self.separated.tolist(),
            'bounced': self.bounced.tolist(),
            'seating_velocity_m_s': [None if not math.isfinite(v) else v
                                     for v in self.seating_velocity.tolist()],
            'max_valve_lift_m': self.max_lift.tolist(),
            'jump_speed_rpm': self.jump_speed_rpm,
            'bounce_onset_rpm': self.bounce_onset_rpm,
            'sweep_seconds': self.seconds,
        }


def parse_range(text: str, key: str = '--sweep') -> NDArray[np.float64]:
    """'LO:HI:STEP' (rpm) -> speeds LO, LO+STEP, ... <= HI."""
    parts = str(text).split(':')
    if len(parts) != 3:
        raise InputError(key, text, 'LO:HI:STEP in rpm')
    try:
        lo, hi, st = (float(x) for x in parts)
    except ValueError:
        raise InputError(key, text, 'LO:HI:STEP with numbers') from None
    require_rpm(f'{key}.LO', lo)
    require_positive(f'{key}.STEP', st)
    if not math.isfinite(hi) or hi < lo:
        raise InputError(f'{key}.HI', hi, f'a speed >= LO ({lo})')
    require_rpm(f'{key}.HI', hi)
    n = int(math.floor((hi - lo) / st + 1e-9)) + 1
    if n > 100000:
        raise InputError(key, text, 'at most 100000 speeds')
    return lo + st * np.arange(n)


def _run(cam: CamInput, params: SdofParams, rpm: float) -> SdofResult:
    return simulate_cam(cam, params, rpm * math.pi / 30.0, events_only=True)


def _bisect(pred: Callable[[float], bool], lo: float, hi: float, tol: float) -> float:
    """Smallest speed in (lo, hi] with pred true, given pred(lo) false, pred(hi) true."""
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if pred(mid):
            hi = mid
        else:
            lo = mid
    return hi


def sweep(law: LiftLaw, params: SdofParams, rpms: Sequence[float], *,
          step_deg: float = 1.0, tol_rpm: float = 0.5, refine: bool = True) -> SweepResult:
    """Simulate every speed of ``rpms`` (increasing) and locate the event speeds."""
    speeds = np.asarray(rpms, dtype=float)
    if speeds.ndim != 1 or speeds.size == 0 or np.any(~np.isfinite(speeds)) or np.any(
            speeds <= 0) or np.any(np.diff(speeds) <= 0):
        raise InputError('cam_speed_rpm', rpms, 'increasing speeds > 0')
    require_positive('tol_rpm', tol_rpm)
    cam = build_cam_input(law, params.rocker_ratio, params.lash,
                          math.radians(require_positive('step_deg', step_deg)))
    t0 = time.perf_counter()
    sep = np.zeros(speeds.size, dtype=bool)
    bounce = np.zeros(speeds.size, dtype=bool)
    vseat = np.full(speeds.size, np.nan)
    ymax = np.zeros(speeds.size)
    for i, rpm in enumerate(speeds):
        res = _run(cam, params, float(rpm))
        sep[i] = bool(res.events.separations)
        bounce[i] = res.events.bounce_count > 0
        if res.events.seating_velocity is not None:
            vseat[i] = res.events.seating_velocity
        ymax[i] = float(np.nanmax(res.y))
    seconds = time.perf_counter() - t0

    def first(flags: NDArray[np.bool_], pred: Callable[[float], bool]) -> float | None:
        hits = np.nonzero(flags)[0]
        if hits.size == 0:
            return None
        i = int(hits[0])
        if i == 0 or not refine:
            return float(speeds[i])
        return _bisect(pred, float(speeds[i - 1]), float(speeds[i]), tol_rpm)

    jump = first(sep, lambda r: bool(_run(cam, params, r).events.separations))
    onset = first(bounce, lambda r: _run(cam, params, r).events.bounce_count > 0)
    return SweepResult(rpm=speeds, separated=sep, bounced=bounce, seating_velocity=vseat,
                       max_lift=ymax, jump_speed_rpm=jump, bounce_onset_rpm=onset,
                       seconds=seconds)


def plot_runs(runs: Sequence[object], path: str | Path, title: str = '') -> Path:
    """Valve lift and contact force over cam angle for several runs (report.Run)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out = Path(path)
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    for run in runs:
        a = np.degrees(run.alpha)
        ax1.plot(a, run.lift * 1e3, label=f'{run.rpm:g} rpm')
        ax2.plot(a, run.force, label=f'{run.rpm:g} rpm')
    ax1.set_ylabel('valve lift [mm]')
    ax2.set_ylabel('cam contact force [N]')
    ax2.set_xlabel('cam angle alpha [deg]')
    ax1.legend(loc='upper right', fontsize='small')
    if title:
        ax1.set_title(title)
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    import io
    import os

    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=110)
    plt.close(fig)
    tmp = out.with_name(f'.{out.name}.partial-{os.getpid()}')
    try:                          # all or nothing: a full disk leaves no half PNG
        tmp.write_bytes(buf.getvalue())
        os.replace(tmp, out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError('plot', str(out), f'a writable file ({exc.strerror})') from None
    return out
