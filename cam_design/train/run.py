"""One valve-train run: the model chosen once from the scene, the gas force, the hydraulic
lash adjuster and the hydraulic gear behind one function (docs/dynamics.md).

``train_from_valve_train(vt)`` turns a validated scene ``valve_train`` block (duck-typed:
``model``, the SDOF keys, ``mdof``, ``hla``, ``gas``, ``hydraulic``, ``spring``,
``piston``) into a :class:`TrainSpec`; ``run_train(law, train, rpm, ...)`` runs it at one
camshaft speed and returns a ``Run`` (``cam_design.valve_train.report``) whose events
hold every report field, with the drive torque ``T = F h'(alpha)`` [N m] of the contact
force F [N] on the lift law's lever arm h' [m/rad] (rigid, frictionless shaft; the
camshaft model adds twist and friction, ``cam_design.camshaft``).

Model dispatch (one place):

* ``hydraulic``: the lost-motion hydraulic gear (``cam_design.hydraulic.run``);
* ``hla`` given: the SDOF or MDOF train with the coupled lash adjuster (ODE);
* ``gas`` given and model ``mdof`` or a hard seat: the gas-loaded ODE train;
* ``mdof``: the exact 4+N1+N2 solver; otherwise the exact SDOF solver.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.mdof import MdofParams, mdof_from_mapping
from cam_design.valve_train.params import SdofParams
from cam_design.valve_train.physics import TrainChecks, train_checks_from
from cam_design.valve_train.report import ContactGeometry, Run

MODELS = ('sdof', 'mdof', 'hydraulic')


@dataclass(frozen=True)
class GasSpec:
    """Cylinder pressure against crank angle (``valve_train.gas``): crank angles [deg],
    gauge pressures [Pa], valve head diameter [m], port back pressure [Pa] and the crank
    angle [deg] at which the lobe's first angle is under the follower."""

    crank_deg: tuple[float, ...]
    pressure_pa: tuple[float, ...]
    head_diameter: float
    back_pressure_pa: float
    lobe_start_crank_deg: float

    def force_on(self, law: LiftLaw) -> Callable[[float], float]:
        """The gas force on the valve [N] as a function of the lobe's cam angle [rad]
        (anchored on the law's ``lobe_start`` [rad] when it has one, e.g. a lobe seen
        through the shaft's twist, else on its support's start)."""
        from cam_design.hydraulic.gas import gas_force, on_cam_angle

        start = getattr(law, 'lobe_start', None)
        return on_cam_angle(gas_force(self.crank_deg, self.pressure_pa, self.head_diameter,
                                      self.back_pressure_pa),
                            self.lobe_start_crank_deg,
                            float(law.support[0] if start is None else start))


@dataclass(frozen=True)
class TrainSpec:
    """A valve train ready to run: ``model`` (sdof | mdof | hydraulic) and its
    parameters, built once from the scene (``train_from_valve_train``).

    ``sdof``: the SDOF parameters (also the base of the MDOF and HLA trains; None for
    the hydraulic gear); ``mdof``: the MDOF parameters (model mdof); ``hydraulic``: the
    gear's parameters (model hydraulic); ``hla``: the scene's ``valve_train.hla``
    mapping or None; ``gas``: the cylinder gas or None; ``checks``: spring and piston
    geometry for the coil-bind and clearance checks."""

    model: str
    sdof: SdofParams | None = None
    mdof: MdofParams | None = None
    hydraulic: Any = None
    hla: Mapping[str, Any] | None = None
    gas: GasSpec | None = None
    checks: TrainChecks | None = None

    def sweep_params(self, key: str = '--sweep', value: Any = None) -> SdofParams | MdofParams:
        """The parameters a speed sweep runs (SDOF or MDOF); refused for the other
        trains (``key`` and ``value`` name the option in the refusal)."""
        if self.hla is not None:
            raise InputError(key, 'with valve_train.hla',
                             'single speeds (--rpm) for a train with a hydraulic lash '
                             'adjuster; the sweep does not take it yet')
        if self.model == 'mdof' and self.mdof is not None:
            return self.mdof
        if self.model != 'sdof' or self.sdof is None:
            raise InputError(key, value, f'model sdof or mdof (model {self.model} has '
                             'no sweep; use --rpm)')
        return self.sdof

    def gas_on(self, law: LiftLaw) -> Callable[[float], float] | None:
        """The gas force on the valve against cam angle [N], or None."""
        return None if self.gas is None else self.gas.force_on(law)


def gas_spec_of(block: Mapping[str, Any] | None) -> GasSpec | None:
    """GasSpec of a validated ``valve_train.gas`` mapping (None: no gas)."""
    if block is None:
        return None
    return GasSpec(crank_deg=tuple(float(x) for x in block['crank_deg']),
                   pressure_pa=tuple(float(x) for x in block['pressure_pa']),
                   head_diameter=float(block['head_diameter']),
                   back_pressure_pa=float(block.get('back_pressure_pa', 0.0)),
                   lobe_start_crank_deg=float(block['lobe_start_crank_deg']))


def train_from_valve_train(vt: Any, model: str | None = None) -> TrainSpec:
    """The TrainSpec of a validated scene ``valve_train`` block; ``model`` overrides the
    block's (``--model``). Refusals name the scene key."""
    chosen = model or getattr(vt, 'model', None) or 'sdof'
    if chosen not in MODELS:
        raise InputError('valve_train.model', chosen, ' | '.join(MODELS))
    gas = gas_spec_of(getattr(vt, 'gas', None))
    if chosen == 'hydraulic':
        from cam_design.hydraulic.run import hydraulic_from_valve_train

        return TrainSpec(model=chosen, hydraulic=hydraulic_from_valve_train(vt), gas=gas)
    base = SdofParams.from_valve_train(vt)
    checks = train_checks_from(getattr(vt, 'spring', None), getattr(vt, 'piston', None))
    mdof = mdof_from_mapping(getattr(vt, 'mdof', None), base) if chosen == 'mdof' else None
    return TrainSpec(model=chosen, sdof=base, mdof=mdof, hla=getattr(vt, 'hla', None),
                     gas=gas, checks=checks)


def lever_arm(law: LiftLaw, alpha: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lever arm [m] of the cam-follower contact force about the cam axis: h'(alpha)
    [m/rad] of the lift law (virtual work; for the flat follower it is the contact
    offset from the follower axis, for the in-line roller (R0 + r + h) tan(pressure
    angle))."""
    return np.asarray(law(np.asarray(alpha, dtype=float), 1), dtype=float)


def run_train(law: LiftLaw, train: TrainSpec, rpm: float, *, step_deg: float = 0.1,
              geometry: ContactGeometry | None = None, max_revolutions: int = 4,
              key: str = 'lift') -> Run:
    """The valve train ``train`` driven by ``law`` at ``rpm`` (camshaft, rigid, constant
    speed) on a grid of ``step_deg`` [deg]; ``geometry``: contact geometry for the Hertz
    stress (None: no stress); ``max_revolutions``: SDOF revolutions to the periodic
    state; ``key`` names the lobe's lift in refusals. The Run's ``drive_torque`` [N m] is
    the contact force times ``lever_arm`` and ``friction_torque`` is zero."""
    run = _dispatch(law, train, rpm, step_deg, geometry, max_revolutions, key)
    run.drive_torque = run.force * lever_arm(law, run.alpha)
    run.friction_torque = np.zeros_like(run.force)
    return run


def train_force(law: LiftLaw, train: TrainSpec, rpm: float, *, step_deg: float = 0.1,
                max_revolutions: int = 4, key: str = 'lift',
                geometry: ContactGeometry | None = None
                ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                           NDArray[np.float64] | None, Run | None]:
    """The contact force alone: (alpha [rad], cam-follower force [N] on the uniform
    grid, the angles [rad] where it or a derivative jumps or None when the model does
    not say, the full Run when one was made). The plain SDOF train skips the report
    fields (the inner loop of the coupled camshaft); the other trains run in full."""
    sdof = train.sdof
    if (train.model == 'sdof' and train.hla is None and sdof is not None
            and not (train.gas is not None and sdof.hard_seat)):
        from cam_design.valve_train.sdof import simulate

        res = simulate(law, sdof, rpm, step_deg=step_deg, max_revolutions=max_revolutions,
                       key=key, gas=train.gas_on(law))
        sel = res.uniform
        return (res.alpha[sel], res.cam_force[sel],
                np.asarray(res.events.switch_angles, dtype=float), None)
    run = run_train(law, train, rpm, step_deg=step_deg, max_revolutions=max_revolutions,
                    key=key, geometry=geometry)
    return run.alpha, run.force, run.breaks, run


def _dispatch(law: LiftLaw, train: TrainSpec, rpm: float, step_deg: float,
              geom: ContactGeometry | None, max_revolutions: int, key: str) -> Run:
    gas = train.gas_on(law)
    if train.model == 'hydraulic':
        from cam_design.hydraulic.run import run_hydraulic

        return run_hydraulic(law, train.hydraulic, rpm, geom, gas=gas)
    params = train.sdof
    assert params is not None            # built for every mechanical train
    mdof = train.mdof if train.model == 'mdof' else None
    if train.hla is not None:
        from cam_design.hydraulic.hla_coupled import run_with_hla

        return run_with_hla(law, params, train.hla, rpm, mdof=mdof, step_deg=step_deg,
                            gas=gas, geometry=geom, train_checks=train.checks)
    if gas is not None and (mdof is not None or params.hard_seat):
        from cam_design.hydraulic.hla_coupled import run_gas_ode

        return run_gas_ode(law, params, mdof, rpm, gas=gas, step_deg=step_deg,
                           geometry=geom, train_checks=train.checks)
    if mdof is not None:
        from cam_design.valve_train.mdof import simulate_mdof
        from cam_design.valve_train.report import finish_run

        res = simulate_mdof(law, mdof, rpm, step_deg=step_deg)
        events = dict(res.events)
        events['natural_frequencies_hz'] = [float(f) for f in res.natural_frequencies_hz[:6]]
        events['spring_surge_hz'] = [float(s[0]) for s in res.surge_hz]
        return finish_run(law, params, rpm, 'mdof', res.alpha, res.y, res.v, res.cam_force,
                          events, geom, train.checks)
    from cam_design.valve_train.report import run_sdof

    return run_sdof(law, params, rpm, step_deg=step_deg, geometry=geom, gas=gas,
                    max_revolutions=max_revolutions, train_checks=train.checks, key=key)


def sweep_train(law: LiftLaw, train: TrainSpec, speeds: Any, *, step_deg: float = 0.1,
                key: str = 'lift') -> Any:
    """Speed sweep of ``train`` over ``speeds`` [rpm]: ``SweepResult``
    (``cam_design.valve_train.sweep``) for the SDOF/MDOF trains, ``HydraulicSweep``
    (``cam_design.hydraulic.speed_limit``) for the hydraulic gear; refused with the
    lash adjuster."""
    if train.model == 'hydraulic':
        from cam_design.hydraulic.speed_limit import hydraulic_sweep

        return hydraulic_sweep(law, train.hydraulic, speeds, gas=train.gas_on(law))
    from cam_design.valve_train.sweep import sweep

    return sweep(law, train.sweep_params(), speeds, step_deg=step_deg, key=key,
                 gas=train.gas_on(law))
