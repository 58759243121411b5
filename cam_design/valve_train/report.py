"""One dynamics run as report data: arrays on the output grid, events, stress, epsilon.

``run_sdof`` / ``run_model`` return a ``Run`` whose ``as_dict()`` is the JSON object of
``cam-bench dynamics`` (``features.<id>.runs[]``) and whose ``table()`` is the
/dynamics/valve_motion table. Angles of events are on the lobe's alpha axis [deg].
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_positive
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.epsilon import assess
from cam_design.valve_train import physics
from cam_design.valve_train.params import SdofParams, omega_of_rpm
from cam_design.valve_train.physics import TrainChecks
from cam_design.valve_train.sdof import SdofResult, simulate

COLUMNS = ('alpha_rad', 'valve_lift_m', 'valve_velocity_m_per_s', 'contact_force_n',
           'contact_stress_pa')


@dataclass(frozen=True)
class ContactGeometry:
    """Cam-follower contact for the Hertz stress (docs/dynamics.md, checks 2.5/2.11).

    follower: 'flat' | 'roller' | 'knife'; radius [m] of a roller; base_radius R0 [m];
    width W [m] of the contact line; youngs_modulus E [Pa] of both bodies (mu = 0.3).
    """

    base_radius: float
    follower: str = 'flat'
    radius: float = 0.0
    width: float = 0.012
    youngs_modulus: float = 2.06e11

    def __post_init__(self) -> None:
        require_positive('base_circle_radius', self.base_radius)
        require_positive('cam_width', self.width)
        require_positive('youngs_modulus', self.youngs_modulus)
        if self.follower not in ('flat', 'roller', 'knife'):
            raise InputError('follower', self.follower, 'flat | roller | knife')


def contact_stress(law: LiftLaw, alpha: NDArray[np.float64], force: NDArray[np.float64],
                   geom: ContactGeometry) -> NDArray[np.float64]:
    """Hertz line-contact stress [Pa] at the cam for the cam-side force ``force`` [N].

    Flat tappet: rho1 = R0 + h + h'' against a flat face; where rho1 <= 0 the profile is
    undercut (not realisable) and the stress is NaN there (reported as undercut, no
    maximum). Roller: the cam radius is signed (< 0 on a concave flank) and passed
    second, so a concave flank gets 1/r - 1/|rho| (as in ``checks.run_checks``).
    """
    from cam_design import checks

    if geom.follower == 'flat':
        rho1 = checks.flat_tappet_curvature(law(alpha), law(alpha, 2), geom.base_radius)
        ok = rho1 > 0
        sig = np.full(alpha.shape, np.nan)
        if np.any(ok):
            sig[ok] = checks.hertz_stress_steel(force[ok], geom.width, rho1[ok], math.inf,
                                                e1=geom.youngs_modulus)
        return sig
    from cam_design.cam_profile import roller_profile

    rho = roller_profile(law, geom.base_radius, geom.radius, alpha).rho
    rho = np.where(np.abs(rho) < 1e-9, 1e-9, rho)
    if geom.radius > 0:
        return checks.hertz_stress_steel(force, geom.width, geom.radius, rho,
                                         e1=geom.youngs_modulus)
    return checks.hertz_stress_steel(force, geom.width, rho, math.inf, e1=geom.youngs_modulus)


@dataclass
class Run:
    """A run at one speed on the uniform output grid (SI arrays)."""

    rpm: float
    model: str
    alpha: NDArray[np.float64]
    lift: NDArray[np.float64]
    velocity: NDArray[np.float64]
    force: NDArray[np.float64]          # cam-follower contact force [N]
    stress: NDArray[np.float64]
    events: dict[str, Any] = field(default_factory=dict)
    #: torque [N m] the shaft delivers to this lobe (contact force x lever arm, plus the
    #: friction torque), against alpha; set by ``cam_design.train.run.run_train``
    drive_torque: NDArray[np.float64] | None = None
    #: friction torque [N m] of the cam-follower contact against alpha (0 without friction)
    friction_torque: NDArray[np.float64] | None = None
    #: angles [rad] where the contact force or a derivative of it jumps (the train's
    #: regime switches: contact onset and loss, seat impact and lift-off); None: not
    #: known for this model
    breaks: NDArray[np.float64] | None = None

    def table(self) -> NDArray[np.float64]:
        """(rows, 5) in COLUMNS order."""
        return np.column_stack([self.alpha, self.lift, self.velocity, self.force,
                                self.stress])

    def as_dict(self, arrays: bool = True) -> dict[str, Any]:
        """JSON-ready dict: speed, arrays (deg / SI), then the events."""
        out: dict[str, Any] = {'cam_speed_rpm': self.rpm, 'model': self.model}
        if arrays:
            out.update({
                'alpha_deg': np.round(np.degrees(self.alpha), 10).tolist(),
                'valve_lift_m': self.lift.tolist(),
                'valve_velocity_m_s': self.velocity.tolist(),
                'contact_force_n': self.force.tolist(),
                'contact_stress_pa': self.stress.tolist(),
            })
            if self.drive_torque is not None:
                out['drive_torque_nm'] = self.drive_torque.tolist()
            if self.friction_torque is not None:
                out['friction_torque_nm'] = self.friction_torque.tolist()
        out.update(self.events)
        return out


def _deg(x: float | None) -> float | None:
    return None if x is None else math.degrees(x)


def sdof_events(res: SdofResult) -> dict[str, Any]:
    """Event fields of a run (angles in deg on the lobe's alpha axis)."""
    ev = res.events
    return {
        'opening_deg': _deg(ev.opening),
        'closing_deg': _deg(ev.closing),
        'separations': [[math.degrees(a), math.degrees(b)] for a, b in ev.separations],
        'recontact_velocities_m_s': list(ev.recontact_velocities),
        'jump': bool(ev.separations),
        'seating_velocity_m_s': ev.seating_velocity,
        'bounce_count': int(ev.bounce_count),
        'bounce_height_m': float(ev.bounce_height),
        'revolutions': int(res.revolutions),
        'periodic_residual_m': float(res.periodic_residual),
        'settled': bool(res.settled),
        'left_cam': bool(res.left_cam),
        'unstable_orbit': bool(res.unstable),
        'shooting_iterations': int(res.shooting_iterations),
        'switches': int(ev.count),
    }


def run_sdof(law: LiftLaw, params: SdofParams, rpm: float, *, step_deg: float = 0.1,
             geometry: ContactGeometry | None = None, max_revolutions: int = 4,
             train_checks: TrainChecks | None = None, key: str = 'lift',
             gas: Any = None) -> Run:
    """SDOF run at ``rpm`` with arrays every ``step_deg`` and all report fields
    (``key``: the scene key of the lobe's lift, named in refusals; ``gas(alpha)`` [N]:
    cylinder-gas force pushing the valve shut)."""
    res = simulate(law, params, rpm, step_deg=step_deg, max_revolutions=max_revolutions,
                   key=key, gas=gas)
    sel = res.uniform
    alpha = res.alpha[sel]
    force = res.cam_force[sel]
    events = sdof_events(res)
    if gas is not None:
        g = np.array([float(gas(float(x))) for x in alpha])
        i = int(np.argmax(g))
        events.update({'gas_force_max_n': float(g[i]),
                       'gas_force_max_deg': math.degrees(float(alpha[i])),
                       'gas_force_at_opening_n': None if res.events.opening is None
                       else float(gas(res.events.opening))})
    run = finish_run(law, params, rpm, 'sdof', alpha, res.y[sel], res.v[sel], force,
                     events, geometry, train_checks)
    run.breaks = np.asarray(res.events.switch_angles, dtype=float)
    return run


def events_note(events: dict[str, Any], rpm: float | None = None) -> str | None:
    """What a reader must know about a run (None when nothing): the valve leaves the
    cam, no periodic state, or no opening/closing event, said with its reason."""
    at = f' at {rpm:g} rpm' if rpm is not None else ''
    res, revs = events.get('periodic_residual_m'), events.get('revolutions')
    state = (f'residual {res:.3g} m after {revs} revolutions'
             if res is not None and revs is not None else '')
    if events.get('left_cam'):
        return (f'the valve leaves the cam{at}: it rises to '
                f"{events.get('max_valve_lift_m', math.nan) * 1e3:.3f} mm (rigid lift "
                f"{events.get('rigid_max_lift_m', math.nan) * 1e3:.3f} mm) or is still in "
                'free flight at the end of the revolution; the valve train no longer '
                'follows this cam' + ('' if events.get('settled') else
                                      f' (no periodic state: {state})'))
    if events.get('settled') is False:
        why = ('an unstable periodic orbit only' if events.get('unstable_orbit')
               else 'no periodic state')
        return (f'not settled{at} ({why}: {state}): the events are those of the last '
                'revolution simulated, not of a steady state')
    if events.get('opening_deg') is not None and events.get('closing_deg') is not None:
        return None
    if events.get('opening_deg') is None and events.get('max_valve_lift_m', 0.0) <= 1e-9:
        return 'the valve never lifts off the seat (train force below the preload)'
    if events.get('settled'):
        return ('periodic state reached, but the valve does not '
                + ('lift off the seat' if events.get('opening_deg') is None and
                   events.get('closing_deg') is not None else
                   'return to the seat' if events.get('opening_deg') is not None else
                   'touch the seat')
                + ' within the revolution (e.g. a lobe over the whole revolution with '
                  'no lash): opening/closing/seating events are undefined')
    return ('the valve does not return to the seat within a revolution'
            + (f' ({state})' if state else '')
            + ', so opening/closing/seating events are undefined: the speed is far above '
              'what this valve train follows')


def stress_and_undercut(law: LiftLaw, alpha: NDArray, force: NDArray,
                        geometry: ContactGeometry | None) -> tuple[NDArray, bool]:
    """Hertz stress [Pa] along a run (zeros without ``geometry``) and whether the
    profile is undercut somewhere (stress undefined there: NaN)."""
    if geometry is None:
        return np.zeros_like(force), False
    stress = contact_stress(law, alpha, force, geometry)
    return stress, bool(np.any(np.isnan(stress)))


def finish_run(law: LiftLaw, params: SdofParams, rpm: float, model: str,
               alpha: NDArray, lift: NDArray, velocity: NDArray, force: NDArray,
               events: dict[str, Any], geometry: ContactGeometry | None,
               train_checks: TrainChecks | None = None) -> Run:
    """Add stress, maxima, epsilon, the spring margin and (with ``train_checks``) coil
    bind and the dynamic valve-piston clearance to a run."""
    stress, undercut = stress_and_undercut(law, alpha, force, geometry)
    have_stress = geometry is not None and not undercut
    i_s = int(np.argmax(stress)) if have_stress else 0
    i_f = int(np.argmax(force))
    eps = assess(law, params, rpm)
    events = dict(events)
    events.update({
        'max_contact_force_n': float(force[i_f]),
        'max_contact_force_deg': math.degrees(float(alpha[i_f])),
        'max_contact_stress_pa': float(stress[i_s]) if have_stress else None,
        'max_contact_stress_deg': math.degrees(float(alpha[i_s])) if have_stress else None,
        'profile_undercut': undercut,
        'max_valve_lift_m': float(np.nanmax(lift)),
        'rigid_max_lift_m': float(params.rocker_ratio * law.max_lift(4001) - params.lash),
        'epsilon': eps.eps,
        'epsilon_c': eps.eps_book_c,
        'epsilon_predicted_amplitude_m': eps.predicted_amplitude_m,
        'epsilon_recommendation': eps.recommendation,
        'cam_width_m': geometry.width if geometry is not None else None,
    })
    events.update(physics.run_checks(law, params, omega_of_rpm(rpm), alpha, lift,
                                     train_checks))
    if events.get('valve_leaves_cam') and not events.get('left_cam'):
        events['left_cam'] = True       # the MDOF model's flag: one note for both models
    note = events_note(events, rpm)
    if note:
        events['note'] = note
    return Run(rpm=float(rpm), model=model, alpha=alpha, lift=lift, velocity=velocity,
               force=force, stress=stress, events=events)
