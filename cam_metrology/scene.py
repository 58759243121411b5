"""The scene: camshaft under test, probe, features and what to compute (docs/contract.md).

This module holds the typed result of parsing a scene. ``parse_scene(text)`` and
``load_scene(path)`` validate the whole schema before anything runs and raise
``cam_design.errors.InputError`` naming the key, the value and what was expected.
All quantities are SI (m, rad, kg, N, s).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from cam_design.follower import Follower
from cam_design.lift_laws import LiftLaw

__all__ = ['Follower', 'Lobe', 'DowelPin', 'Seat', 'ValveTrain', 'Scene', 'COMPUTE_ITEMS']
COMPUTE_ITEMS = ('nose', 'pin', 'asymmetry', 'reconstruction', 'dynamics')


@dataclass(frozen=True)
class Lobe:
    """One cam lobe: its design lift (for ``follower``) and nominal phase [rad]."""

    id: str
    follower: Follower
    lift: LiftLaw
    nominal_phase: float | None = None
    lift_spec: dict[str, Any] | None = None   # the scene's lift_law mapping, if any
    width: float | None = None                # m, cam width (Hertz contact line length)


@dataclass(frozen=True)
class DowelPin:
    """Dowel pin (Liu's geometry): radii in m; ``nominal_angle`` rad (optional)."""

    pin_radius: float
    circle_radius: float
    probe_radius: float
    nominal_angle: float | None = None


@dataclass(frozen=True)
class Seat:
    """Valve seat: penalty stiffness [N/m] and damping [N s/m]; ``restitution`` for the
    hard-seat variant (None: penalty seat)."""

    stiffness: float = 1.0e9
    damping: float = 2000.0
    restitution: float | None = None


@dataclass(frozen=True)
class ValveTrain:
    """Dynamics parameters at the valve side (docs/dynamics.md, docs/contract.md ``sdof``)."""

    model: str                      # 'sdof' | 'mdof'
    rocker_ratio: float             # k
    lash: float                     # x0 [m]
    mass: float                     # M [kg]
    stiffness: float                # c [N/m]
    damping: float                  # b_t [N s/m]
    spring_rate: float              # c' [N/m]
    spring_preload: float           # F0 [N]
    valve_damping: float = 0.0      # b_v [N s/m]
    seat: Seat = field(default_factory=Seat)
    cam_speed_rpm: tuple[float, ...] = (1500.0,)
    mdof: dict[str, Any] | None = None   # extra parameters of the 4+N1+N2 model
    spring: dict[str, Any] | None = None   # spring geometry (coil bind), docs/scene.md
    piston: dict[str, Any] | None = None   # crank-slider (dynamic valve-piston clearance)


@dataclass(frozen=True)
class Scene:
    """A validated scene. ``text`` is the YAML it came from (published on /bench/scene)."""

    camshaft_id: str
    direction: int
    probe: Follower
    base_circle_radius: float
    lobes: tuple[Lobe, ...]
    dowel_pin: DowelPin | None = None
    compute: frozenset[str] | None = None     # None: everything the data allows
    valve_train: ValveTrain | None = None
    idle_timeout: float = 1.0                 # s
    text: str = ''
    warnings: tuple[str, ...] = ()

    def wants(self, item: str) -> bool:
        """True if ``compute`` asks for ``item`` (or does not restrict)."""
        return self.compute is None or item in self.compute

    def lobe(self, lobe_id: str) -> Lobe:
        """The lobe with this id (KeyError if absent)."""
        for lobe in self.lobes:
            if lobe.id == lobe_id:
                return lobe
        raise KeyError(lobe_id)
