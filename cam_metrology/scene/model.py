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
from cam_metrology.scene.channels import Channels

__all__ = ['Follower', 'FormSettings', 'Journal', 'Lobe', 'DowelPin', 'Keyway', 'Crank',
           'Seat', 'ValveTrain', 'Scene', 'COMPUTE_ITEMS', 'Band', 'ToleranceZone', 'Tolerances',
           'DerivativeZone']
COMPUTE_ITEMS = ('nose', 'pin', 'asymmetry', 'reconstruction', 'dynamics')


#: a tolerance band (lower, upper) around the nominal, in the unit of its key; lower <= 0 <= upper
Band = tuple[float, float]


@dataclass(frozen=True)
class ToleranceZone:
    """A lift-error band [um] over the cam angles ``from_deg``..``to_deg`` (from the
    lobe centreline, rise flank negative)."""

    from_deg: float
    to_deg: float
    band_um: Band


@dataclass(frozen=True)
class DerivativeZone:
    """Velocity and acceleration error maxima (None: the lobe's own maximum applies)
    over the cam angles ``from_deg``..``to_deg`` (from the lobe centreline, rise flank
    negative)."""

    from_deg: float
    to_deg: float
    velocity_max_mm_per_rad: float | None = None
    acceleration_max_mm_per_rad2: float | None = None


@dataclass(frozen=True)
class Tolerances:
    """Acceptance limits of one lobe (docs/scene.md "tolerances"); None: not toleranced.

    Units are in the names: lift error, max lift and run-out in um, angles in cam deg,
    the checking height of the duration in mm."""

    lift_error_um: Band | None = None
    lift_error_zones: tuple[ToleranceZone, ...] = ()
    centreline_deg: Band | None = None
    phase_deg: Band | None = None
    max_lift_um: Band | None = None
    runout_max_um: float | None = None
    duration_deg: Band | None = None
    checking_height_mm: float = 1.0
    roundness_max_um: float | None = None      # base-circle roundness (LSCI), a maximum
    waviness_max_um: float | None = None       # largest harmonic in the waviness band
    taper_max_um_per_mm: float | None = None   # |nose lift slope across the tracks|
    twist_max_deg: float | None = None         # |nose-angle difference, outer tracks|
    velocity_error_max_mm_per_rad: float | None = None        # |h' measured - design|
    acceleration_error_max_mm_per_rad2: float | None = None   # |h'' measured - design|
    derivative_error_zones: tuple[DerivativeZone, ...] = ()   # their limits by angle zone

    def any(self) -> bool:
        """True if at least one limit is set."""
        limits = (self.lift_error_um, self.centreline_deg, self.phase_deg,
                  self.max_lift_um, self.runout_max_um, self.duration_deg,
                  self.roundness_max_um, self.waviness_max_um, self.taper_max_um_per_mm,
                  self.twist_max_deg, self.velocity_error_max_mm_per_rad,
                  self.acceleration_error_max_mm_per_rad2)
        return any(v is not None for v in limits) or bool(self.lift_error_zones) or \
            bool(self.derivative_error_zones)

    def wants_derivatives(self) -> bool:
        """True if a velocity or acceleration error limit is set."""
        return self.velocity_error_max_mm_per_rad is not None or \
            self.acceleration_error_max_mm_per_rad2 is not None or \
            bool(self.derivative_error_zones)


@dataclass(frozen=True)
class FormSettings:
    """Harmonic and form analysis of every feature (docs/scene.md ``form``): the Gaussian
    filter's cut-off [UPR] and the waviness band [UPR] (None: 15 UPR to the cut-off)."""

    cutoff_upr: int = 50
    waviness_band_upr: tuple[int, int] | None = None
    derivative_errors: bool = False   # velocity/acceleration errors of every lobe


@dataclass(frozen=True)
class Lobe:
    """One cam lobe: its design lift (for ``follower``) and nominal phase [rad]."""

    id: str
    follower: Follower
    lift: LiftLaw
    nominal_phase: float | None = None
    lift_spec: dict[str, Any] | None = None   # the scene's lift_law mapping, if any
    width: float | None = None                # m, cam width (Hertz contact line length)
    tolerances: Tolerances | None = None      # defaults merged with the lobe's own
    role: str | None = None                   # 'intake' | 'exhaust' (crank events)
    cylinder: str = '1'                       # cylinder the lobe serves (crank datum)
    nominal_file: str | None = None           # gauge file the design came from (resolved)
    axial_position: float | None = None       # m along the shaft (journals' origin)


@dataclass(frozen=True)
class Journal:
    """A journal (bearing seat) measured as a feature: nominal radius and axial position
    along the shaft [m]; its form and run-out tolerances (µm, keys as a lobe's)."""

    id: str
    radius: float
    axial_position: float
    tolerances: Tolerances | None = None
    diameter_um: Band | None = None           # diameter deviation band [um]


@dataclass(frozen=True)
class DowelPin:
    """Dowel pin (Liu's geometry): radii in m; ``nominal_angle`` rad (optional)."""

    pin_radius: float
    circle_radius: float
    probe_radius: float
    nominal_angle: float | None = None


@dataclass(frozen=True)
class Keyway:
    """Keyway datum (a slot in the shaft, cam_design.keyway): slot width, shaft radius,
    probe ball radius, slot depth (None: the ball is wider than the slot) in m;
    ``nominal_angle`` rad (optional)."""

    width: float
    shaft_radius: float
    probe_radius: float
    depth: float | None = None
    nominal_angle: float | None = None


@dataclass(frozen=True)
class Crank:
    """Crank datum: ``tdc_deg`` cam degrees from the angular datum (pin or keyway
    centre) to cylinder 1's TDC of the overlap, measured like a phase (encoder frame);
    ``cylinder_tdc_deg`` cylinder -> crank degrees of its TDC after cylinder 1's."""

    tdc_deg: float
    cylinder_tdc_deg: dict[str, float] = field(default_factory=lambda: {'1': 0.0})


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

    model: str                      # 'sdof' | 'mdof' | 'hydraulic'
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
    hydraulic: dict[str, Any] | None = None   # block of the hydraulic model
    gas: dict[str, Any] | None = None   # cylinder-gas force on the valve (sdof)
    hla: dict[str, Any] | None = None   # hydraulic lash adjuster (sdof, mdof)
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
    datum_tolerance_deg: Band | None = None   # datum centre angle vs its nominal_angle
    warnings: tuple[str, ...] = ()
    keyway: Keyway | None = None              # the other datum (never with a dowel_pin)
    crank: Crank | None = None                # crank datum (needs a pin or keyway)
    study: dict[str, str] = field(default_factory=dict)   # part_id, operator, trial
    camshaft: Any = None                      # cam_design.camshaft.spec.CamshaftSpec
    form: FormSettings = field(default_factory=FormSettings)
    journals: tuple[Journal, ...] = ()
    probe_zero_radius: float | None = None    # m, radius at which the probe reads 0
    channels: Channels | None = None          # the bench's joint names (scene.channels)

    def journal(self, journal_id: str) -> Journal | None:
        """The journal with this id, or None."""
        return next((j for j in self.journals if j.id == journal_id), None)

    @property
    def datum_id(self) -> str | None:
        """Feature id of the angular datum: 'dowel_pin', 'keyway' or None."""
        if self.dowel_pin is not None:
            return 'dowel_pin'
        return 'keyway' if self.keyway is not None else None

    @property
    def datum(self) -> DowelPin | Keyway | None:
        """The datum feature's scene entry (dowel pin or keyway), or None."""
        return self.dowel_pin if self.dowel_pin is not None else self.keyway

    def wants(self, item: str) -> bool:
        """True if ``compute`` asks for ``item`` (or does not restrict)."""
        return self.compute is None or item in self.compute

    def lobe(self, lobe_id: str) -> Lobe:
        """The lobe with this id (KeyError if absent)."""
        for lobe in self.lobes:
            if lobe.id == lobe_id:
                return lobe
        raise KeyError(lobe_id)
