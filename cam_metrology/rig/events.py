"""Measured valve events of a cycle-averaged rig run (docs/methods.md "Rig").

All on the lobe angle alpha [rad] (rise flank < 0), from the averaged lift of the bins:

* opening / closing: the lift crosses the checking height on the rise / fall flank
  (linear interpolation between bins);
* maximum lift and its angle;
* first seating: after the maximum, the lift falls to within the seat threshold
  (max(sigmas x the bin's standard error, separation_min)); seating velocity [m/s,
  > 0 downwards]: the vibrometer's averaged velocity there when the run has one, else
  omega times the slope of a line through the averaged lift over the last 0.5 mm before
  the seat;
* bounces: after the first seating, every stretch of bins that rises above the seat
  threshold again (count, largest height);
* separation from the cam: between the lift-off and the first seating, where the rigid
  lift k h(alpha) - x0 is positive, the valve measured above it by more than the
  threshold on two or more adjacent bins (first angle, largest excess).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: height span [m] above the seat of the line fitted for the seating velocity
SEAT_FIT_SPAN = 0.5e-3


@dataclass
class MeasuredEvents:
    """Events (angles [rad] on the lobe axis; None when the event does not occur)."""

    opening: float | None = None
    closing: float | None = None
    max_lift: float = 0.0
    max_lift_angle: float = 0.0
    seating: float | None = None
    seating_velocity: float | None = None
    bounce_count: int = 0
    bounce_height: float = 0.0
    separated: bool = False
    separation_angle: float | None = None
    separation_end: float | None = None
    separation_excess: float = 0.0
    notes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """JSON fields (deg, m, m/s)."""
        deg = (lambda a: None if a is None else math.degrees(a))
        return {'opening_deg': deg(self.opening), 'closing_deg': deg(self.closing),
                'max_lift_m': self.max_lift, 'max_lift_deg': math.degrees(self.max_lift_angle),
                'seating_deg': deg(self.seating),
                'seating_velocity_m_s': self.seating_velocity,
                'bounce_count': self.bounce_count, 'bounce_height_m': self.bounce_height,
                'separated': self.separated,
                'separation_angle_deg': deg(self.separation_angle),
                'separation_end_deg': deg(self.separation_end),
                'separation_excess_m': self.separation_excess}


def _cross(a: NDArray, y: NDArray, i: int, level: float) -> float:
    """Angle where y crosses ``level`` between bins i and i+1 (linear)."""
    y0, y1 = y[i], y[i + 1]
    t = 0.0 if y1 == y0 else (level - y0) / (y1 - y0)
    return float(a[i] + t * (a[i + 1] - a[i]))


def _stretches(flag: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """[start, end) index pairs of the True stretches of ``flag``."""
    d = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    return list(zip(np.nonzero(d == 1)[0].tolist(), np.nonzero(d == -1)[0].tolist()))


def measured_events(alpha: NDArray[np.float64], lift: NDArray[np.float64],
                    stderr: NDArray[np.float64], rigid: NDArray[np.float64],
                    omega: float, checking_height: float, sigmas: float, floor: float,
                    velocity: NDArray[np.float64] | None = None) -> MeasuredEvents:
    """Events of the averaged lift ``lift`` [m] on bins at lobe angles ``alpha`` [rad]
    (any order), with per-bin standard errors ``stderr`` [m], the rigid lift ``rigid``
    [m], the speed ``omega`` [rad/s] and the thresholds of the module docstring."""
    order = np.argsort(alpha)
    a, y, se, u = alpha[order], lift[order], stderr[order], rigid[order]
    vel = None if velocity is None else velocity[order]
    ok = np.isfinite(y)
    a, y, se, u = a[ok], y[ok], se[ok], u[ok]
    if vel is not None:
        vel = vel[ok]
    ev = MeasuredEvents()
    top = int(np.argmax(y))
    ev.max_lift, ev.max_lift_angle = float(y[top]), float(a[top])
    thr = np.maximum(sigmas * se, floor)
    # opening / closing at the checking height
    up = np.nonzero((y[:top] < checking_height) & (y[1:top + 1] >= checking_height))[0]
    if up.size:
        ev.opening = _cross(a, y, int(up[-1]), checking_height)
    down = np.nonzero((y[top:-1] >= checking_height) & (y[top + 1:] < checking_height))[0]
    if down.size:
        ev.closing = _cross(a, y, top + int(down[0]), checking_height)
    # first seating after the maximum
    seated = np.nonzero(y[top:] <= thr[top:])[0]
    lift_off_idx = np.nonzero(y[:top] <= thr[:top])[0]
    start = int(lift_off_idx[-1]) if lift_off_idx.size else 0
    if seated.size:
        j = top + int(seated[0])
        ev.seating = _cross(a, y, j - 1, float(thr[j])) if j > 0 else float(a[j])
        if vel is not None and np.all(np.isfinite(vel[max(0, j - 1):j + 1])):
            ev.seating_velocity = float(-np.interp(ev.seating, a[j - 1:j + 1], vel[j - 1:j + 1]))
        else:
            sel = np.arange(j - 1, top, -1)
            sel = sel[y[sel] <= y[j - 1] + SEAT_FIT_SPAN]
            stop = np.nonzero(np.diff(sel) != -1)[0]
            sel = sel[:stop[0] + 1] if stop.size else sel
            if sel.size >= 3:
                slope = np.polyfit(a[sel], y[sel], 1)[0]
                ev.seating_velocity = float(-slope * omega)
        after = y[j:] > thr[j:]
        bounces = [(s, e) for s, e in _stretches(after) if e - s >= 1]
        ev.bounce_count = len(bounces)
        ev.bounce_height = float(max((np.max(y[j + s:j + e]) for s, e in bounces),
                                     default=0.0))
        end = j
    else:
        ev.notes.append('the valve does not return to its seat within the revolution')
        end = y.size
    # separation from the cam: above the rigid lift while the rigid lift is positive
    excess = y - np.maximum(u, 0.0)
    sep = (excess > thr) & (u > 0)
    sep[:start] = False
    sep[end:] = False
    runs = [(s, e) for s, e in _stretches(sep) if e - s >= 2]
    if runs:
        s0, e0 = runs[0]
        ev.separated = True
        ev.separation_angle = float(a[s0])
        ev.separation_end = float(a[runs[-1][1] - 1])
        ev.separation_excess = float(max(np.max(excess[s:e]) for s, e in runs))
    return ev
