"""Cam-speed sweeps: separation (jump) speed and bounce onset speed, and plots.

Every speed of a sweep is a full single run (``simulate_cam``, the same solver, the same
cam polynomial and step as ``cam-bench dynamics --rpm``): the periodic state is reached
by shooting, separations are the solver's exact contact-loss events (the contact force
is bounded between sub-nodes, not sampled at the output nodes). A speed is ``clean``
(settled, no separation), ``separated`` (settled with a separation, or the valve left
the cam) or ``unsettled`` (no periodic state found: counted as failing, never clean).

The jump speed is the lowest speed that is not clean: bracketed on the grid by the last
clean speed and the first failing one, refined by bisection to ``tol_rpm`` and
cross-checked by single runs (``simulate`` from the lift law) at both ends of the
refined bracket. ``jump_bracket_rpm`` = [last_clean, first_failing], None for an open
end: [None, LO] when the lowest speed already fails (the jump speed is below the range),
[HI, None] when no speed fails (above the range); ``jump_speed_rpm`` is then None.
The bounce onset is bracketed and refined the same way (bounce_count > 0 in the
periodic state, or unsettled).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_positive
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.cam_input import CamInput, build_cam_input, with_gas
from cam_design.valve_train.mdof import MdofParams, MdofRunner, simulate_mdof
from cam_design.valve_train.params import SdofParams, require_rpm, require_step_deg
from cam_design.valve_train.sdof import SdofResult, simulate, simulate_cam

CLEAN, SEPARATED, UNSETTLED = 'clean', 'separated', 'unsettled'


@dataclass
class Bracket:
    """A refined event speed: ``speed`` (None unless bracketed inside the range) and
    ``bracket`` [last_ok, first_failing] (None for an open end); ``checked``: the single
    runs at both ends agree (None when not checked)."""

    speed: float | None
    bracket: list[float | None]
    checked: bool | None = None

    def text(self, lo: float, hi: float) -> str:
        """Human wording: 'N rpm', 'below the sweep range (< LO rpm)', 'above ...'."""
        if self.speed is not None:
            return f'{self.speed:.1f} rpm (between {self.bracket[0]:.1f} and ' \
                   f'{self.bracket[1]:.1f} rpm)'
        if self.bracket[0] is None:
            return f'below the sweep range (< {lo:g} rpm)'
        return f'above the sweep range (> {hi:g} rpm)'


@dataclass
class SweepResult:
    """Per-speed summary arrays and the refined event speeds.

    ``status`` per speed: clean | separated | unsettled; ``bounced``: bounce_count > 0
    in the periodic state.
    """

    rpm: NDArray[np.float64]
    separated: NDArray[np.bool_]
    bounced: NDArray[np.bool_]
    settled: NDArray[np.bool_]
    left_cam: NDArray[np.bool_]
    status: list[str]
    residual: NDArray[np.float64]
    seating_velocity: NDArray[np.float64]     # m/s (nan if the valve never seated)
    max_lift: NDArray[np.float64]             # m
    jump: Bracket
    bounce: Bracket
    seconds: float                            # wall time of the grid sweep
    step_deg: float = 0.1
    notes: list[str] = field(default_factory=list)
    #: N, force the train must overcome at the valve's lift-off: preload F0 plus the gas
    #: force there (nan: the valve never opened)
    opening_force: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    @property
    def jump_speed_rpm(self) -> float | None:
        return self.jump.speed

    @property
    def bounce_onset_rpm(self) -> float | None:
        return self.bounce.speed

    def as_dict(self) -> dict[str, object]:
        """JSON-ready summary."""
        return {
            'sweep_rpm': self.rpm.tolist(), 'status': list(self.status),
            'separated': self.separated.tolist(), 'bounced': self.bounced.tolist(),
            'settled': self.settled.tolist(), 'left_cam': self.left_cam.tolist(),
            'periodic_residual_m': self.residual.tolist(),
            'seating_velocity_m_s': [None if not math.isfinite(v) else v
                                     for v in self.seating_velocity.tolist()],
            'max_valve_lift_m': self.max_lift.tolist(),
            'opening_force_n': [None if not math.isfinite(v) else v
                                for v in self.opening_force.tolist()],
            'jump_speed_rpm': self.jump.speed, 'jump_bracket_rpm': self.jump.bracket,
            'jump_checked': self.jump.checked,
            'bounce_onset_rpm': self.bounce.speed,
            'bounce_bracket_rpm': self.bounce.bracket,
            'bounce_checked': self.bounce.checked,
            'step_deg': self.step_deg, 'sweep_seconds': self.seconds,
            'notes': list(self.notes),
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
    return lo + st * np.arange(n, dtype=np.float64)


def require_speeds(rpms: Sequence[float]) -> NDArray[np.float64]:
    """The speeds of a sweep [rpm] as an array: one-dimensional, finite, > 0, increasing."""
    speeds = np.asarray(rpms, dtype=float)
    if speeds.ndim != 1 or speeds.size == 0 or np.any(~np.isfinite(speeds)) or np.any(
            speeds <= 0) or np.any(np.diff(speeds) <= 0):
        raise InputError('cam_speed_rpm', rpms, 'increasing speeds > 0')
    return speeds


def classify(res: SdofResult) -> str:
    """clean | separated | unsettled of one run."""
    if res.left_cam or res.events.separations:
        return SEPARATED
    if not res.settled:
        return UNSETTLED
    return CLEAN


@dataclass
class _Outcome:
    """What a sweep keeps of one run (SDOF or MDOF)."""

    status: str
    bounced: bool
    settled: bool
    left_cam: bool
    residual: float
    seating_velocity: float | None
    max_lift: float
    opening: float | None = None      # rad, the valve's lift-off (None: never opened)


def _sdof_outcome(res: SdofResult) -> _Outcome:
    return _Outcome(classify(res), res.events.bounce_count > 0, res.settled, res.left_cam,
                    res.periodic_residual, res.events.seating_velocity,
                    float(np.nanmax(res.y)), res.events.opening)


def _mdof_outcome(res: Any) -> _Outcome:
    """The MDOF run's events: a separation at the cam, a valve toss at the rocker or the
    valve leaving the cam make it separated (``jump``), else not settled -> unsettled."""
    ev = res.events
    if ev['jump']:
        status = SEPARATED
    elif not ev['settled']:
        status = UNSETTLED
    else:
        status = CLEAN
    return _Outcome(status, ev['bounce_count'] > 0, bool(ev['settled']),
                    bool(ev['valve_leaves_cam']), float(ev['periodic_residual_m']),
                    ev['seating_velocity_m_s'], float(np.nanmax(res.y)),
                    None if ev['opening_deg'] is None else math.radians(ev['opening_deg']))


def _run(cam: CamInput, params: SdofParams, rpm: float) -> SdofResult:
    return simulate_cam(cam, params, rpm * math.pi / 30.0)


def bisect_speed(pred: Callable[[float], bool], lo: float, hi: float,
                 tol: float) -> tuple[float, float]:
    """Refined [lo, hi] [rpm] (pred(lo) false, pred(hi) true) with hi - lo <= tol."""
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if pred(mid):
            hi = mid
        else:
            lo = mid
    return lo, hi


def runners(law: LiftLaw, params: Any, step_deg: float, key: str = 'lift',
            gas: Any = None
            ) -> tuple[Callable[[float], _Outcome], Callable[[float], _Outcome]]:
    """(run at rpm on a cam prepared once, single run from the law as ``dynamics --rpm``
    does it) for ``SdofParams`` or ``MdofParams``; ``gas(alpha)`` [N]: the cylinder-gas
    force of ``simulate`` (SDOF only)."""
    if isinstance(params, MdofParams):
        if gas is not None:
            raise InputError('valve_train.gas', 'with model mdof',
                             'model sdof (the MDOF model does not take a gas force yet)')
        runner = MdofRunner(law, params, step_deg=step_deg)

        def run_at(rpm: float) -> _Outcome:
            return _mdof_outcome(runner(rpm))

        def single(rpm: float) -> _Outcome:
            return _mdof_outcome(simulate_mdof(law, params, rpm, step_deg=step_deg))
    elif isinstance(params, SdofParams):
        cam = build_cam_input(law, params.rocker_ratio, params.lash,
                              math.radians(step_deg), key=key)
        if gas is not None:
            cam = with_gas(cam, gas)

        def run_at(rpm: float) -> _Outcome:
            return _sdof_outcome(_run(cam, params, rpm))

        def single(rpm: float) -> _Outcome:
            return _sdof_outcome(simulate(law, params, rpm, step_deg=step_deg, key=key,
                                          gas=gas))
    else:
        raise InputError('valve_train', type(params).__name__,
                         'SdofParams or MdofParams (model sdof | mdof)')
    return run_at, single


def sweep(law: LiftLaw, params: Any, rpms: Sequence[float], *,
          step_deg: float = 0.1, tol_rpm: float = 0.5, refine: bool = True,
          key: str = 'lift', check: bool = True, gas: Any = None) -> SweepResult:
    """Simulate every speed of ``rpms`` (increasing) to its periodic state and locate
    the event speeds (module docstring). ``params``: ``SdofParams`` (the SDOF model) or
    ``MdofParams`` (the exact 4+N1+N2 model, ``simulate_mdof``'s runs); ``gas``: the
    cylinder-gas force of the single runs (SDOF)."""
    speeds = require_speeds(rpms)
    require_positive('tol_rpm', tol_rpm)
    step_deg = require_step_deg('step_deg', step_deg)
    run_at, single = runners(law, params, step_deg, key, gas)
    t0 = time.perf_counter()
    n = speeds.size
    status: list[str] = []
    bounce = np.zeros(n, dtype=bool)
    settled = np.zeros(n, dtype=bool)
    left = np.zeros(n, dtype=bool)
    resid = np.zeros(n)
    vseat = np.full(n, np.nan)
    ymax = np.zeros(n)
    f_open = np.full(n, np.nan)
    preload = (params.base if isinstance(params, MdofParams) else params).spring_preload
    for i, rpm in enumerate(speeds):
        res = run_at(float(rpm))
        status.append(res.status)
        bounce[i] = res.bounced
        settled[i] = res.settled
        left[i] = res.left_cam
        resid[i] = res.residual
        if res.seating_velocity is not None:
            vseat[i] = res.seating_velocity
        ymax[i] = res.max_lift
        if res.opening is not None:
            f_open[i] = preload + (float(gas(res.opening)) if gas is not None else 0.0)
    seconds = time.perf_counter() - t0
    sep = np.array([s == SEPARATED for s in status], dtype=bool)
    fails = np.array([s != CLEAN for s in status], dtype=bool)
    notes = []
    if not np.all(settled):
        bad = speeds[~settled]
        notes.append(f'{bad.size} speed(s) without a periodic state (counted as failing): '
                     + ', '.join(f'{v:g}' for v in bad[:10]) + ' rpm')
    if np.any(left):
        notes.append(f'the valve leaves the cam from {speeds[np.argmax(left)]:g} rpm '
                     '(no longer follows it)')

    def locate(flags: NDArray[np.bool_], failing: Callable[[_Outcome], bool],
               what: str) -> Bracket:
        hits = np.nonzero(flags)[0]
        if hits.size == 0:
            return Bracket(None, [float(speeds[-1]), None])
        i = int(hits[0])
        if i == 0:
            return Bracket(None, [None, float(speeds[0])])
        lo, hi = float(speeds[i - 1]), float(speeds[i])
        if refine:
            lo, hi = bisect_speed(lambda r: failing(run_at(r)), lo, hi, tol_rpm)
        checked = None
        if check:       # single runs from the law, as `dynamics --rpm` does them
            checked = (not failing(single(lo))) and failing(single(hi))
            if not checked:
                notes.append(f'{what}: the single runs at {lo:g} and {hi:g} rpm do not '
                             'confirm the bracket')
        return Bracket(hi, [lo, hi], checked)

    jump = locate(fails, lambda r: r.status != CLEAN, 'jump speed')
    bfail = bounce | ~settled
    onset = locate(bfail, lambda r: r.bounced or not r.settled, 'bounce onset')
    return SweepResult(rpm=speeds, separated=sep, bounced=bounce, settled=settled,
                       left_cam=left, status=status, residual=resid,
                       seating_velocity=vseat, max_lift=ymax, jump=jump, bounce=onset,
                       seconds=seconds, step_deg=step_deg, notes=notes,
                       opening_force=f_open)


def seating_window(alpha: NDArray[np.float64], lift: NDArray[np.float64],
                   level: float = 1e-6) -> tuple[float, float] | None:
    """(first seating, end of the last bounce) [rad]: after the peak, the first angle
    where the valve lift falls to ``level`` [m] and the last angle where it is above
    ``level / 10`` (the bounces); None if the valve never seats in the run."""
    k = int(np.argmax(lift))
    after = np.nonzero(lift[k:] <= level)[0]
    if after.size == 0:
        return None
    seat = k + int(after[0])
    up = np.nonzero(lift[seat:] > 0.1 * level)[0]
    end = seat + int(up[-1]) if up.size else seat
    return float(alpha[seat]), float(alpha[end])


def _seating_inset(ax: Any, runs: Sequence[Any]) -> None:
    """A zoom of the valve lift around seating, in um on a symmetric-log axis (linear
    below 1 um), so that a bounce of a few um shows beside one of hundreds."""
    windows = [w for w in (seating_window(r.alpha, r.lift) for r in runs) if w]
    if not windows:
        return
    lo = np.degrees(min(w[0] for w in windows)) - 3.0
    hi = np.degrees(max(w[1] for w in windows)) + 3.0
    hi = max(hi, lo + 10.0)
    ins = ax.inset_axes([0.58, 0.42, 0.4, 0.52])
    top = 1.0
    for run in runs:
        a = np.degrees(run.alpha)
        sel = (a >= lo) & (a <= hi)
        ins.plot(a[sel], run.lift[sel] * 1e6, lw=0.9)
        if np.any(sel):
            top = max(top, float(np.max(run.lift[sel])) * 1e6)
    ins.set_yscale('symlog', linthresh=1.0)
    ins.set_ylim(-1.0, top * 1.5)
    ins.set_xlim(lo, hi)
    ins.axhline(0.0, color='0.5', lw=0.6)
    ins.set_title('seating (zoom, µm, log above 1 µm)', fontsize=7)
    ins.tick_params(labelsize=7)
    ins.grid(True, alpha=0.3)


def runs_figure(runs: Sequence[Any], title: str = '') -> Any:
    """Valve lift and contact force over cam angle for several runs (report.Run): a
    matplotlib figure (the caller saves and closes it)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    for run in runs:
        a = np.degrees(run.alpha)
        ax1.plot(a, run.lift * 1e3, label=f'{run.rpm:g} rpm')
        ax2.plot(a, run.force, label=f'{run.rpm:g} rpm')
    ax1.set_ylabel('valve lift [mm]')
    ax2.set_ylabel('cam contact force [N]')
    ax2.set_xlabel('cam angle alpha [deg]')
    ax1.legend(loc='upper left', fontsize='small')
    _seating_inset(ax1, runs)
    if title:
        ax1.set_title(title)
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig
