"""The one lift-off rule of the exact SDOF and MDOF runs (``propagate.reopen``): the first
lift-off is the opening, a later one a bounce only when its free-flight height bound
m v^2 / (2 F0) reaches BOUNCE_TOL, or when forced (hard seat releasing a held valve)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import pytest

from cam_design.valve_train.propagate import BOUNCE_TOL, free_flight_height, reopen


@dataclass
class _Events:
    opening: float | None = None
    bounce_count: int = 0


@dataclass
class _Run:
    ev: _Events = field(default_factory=_Events)
    peak: float = 0.0
    lift_off: float | None = None
    start_open: bool = False
    seated_once: bool = False
    opened: bool = False
    next_cycle: list[list[float]] | None = None


def test_free_flight_height_is_the_energy_bound() -> None:
    """m v^2 / (2 F0): 0.05 kg at 0.2 m/s against 200 N rises at most 5 um; no preload:
    no bound."""
    assert free_flight_height(0.05, 0.2, 200.0) == pytest.approx(5e-6, rel=1e-12)
    assert free_flight_height(0.05, 0.2, 0.0) == math.inf


def test_first_lift_off_opens_later_ones_bounce_above_the_tolerance() -> None:
    run = _Run(peak=3e-3)
    reopen(run, -1.0, free_flight_height(0.05, 0.2, 200.0))
    assert (run.opened, run.ev.opening, run.lift_off, run.peak) == (True, -1.0, -1.0, 0.0)
    assert run.ev.bounce_count == 0             # the opening is no bounce
    reopen(run, 0.5, 1.0)                       # open again before the first seating
    assert run.ev.bounce_count == 0 and run.ev.opening == -1.0
    run.seated_once = True
    tiny = free_flight_height(0.05, 1e-4, 200.0)          # 1.25e-12 m
    assert tiny < BOUNCE_TOL
    reopen(run, 1.0, tiny)
    assert run.ev.bounce_count == 0             # a crawl-speed reopening is not a bounce
    reopen(run, 1.1, tiny, forced=True)
    assert run.ev.bounce_count == 1             # a held valve released: counted
    reopen(run, 1.2, free_flight_height(0.05, 0.2, 200.0))
    assert run.ev.bounce_count == 2 and run.lift_off == 1.2


def test_a_revolution_that_started_open_collects_the_next_cycle() -> None:
    run = _Run(start_open=True, seated_once=True, opened=True)
    reopen(run, 2.0, 0.0)
    assert run.next_cycle == []
    run2 = _Run(start_open=True, opened=True)   # not seated yet: nothing collected
    reopen(run2, 2.0, 0.0)
    assert run2.next_cycle is None
