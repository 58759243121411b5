"""Reconstruction node core (pure Python; no rclpy).

Subscribes ``/bench/scene`` (std_msgs/String, scene YAML) and ``/metrology/lift``
(Float64MultiArray per feature: label = feature id, columns
``alpha_rad,lift_m,design_lift_m``). For every lobe table it runs the configured
methods (docs/reconstruction.md spline, §5.2 N-harmonic) and publishes:

* ``/reconstruction/profile``: one table per feature and method, label
  ``<feature>/<method>``, columns ``alpha_rad,lift_m,velocity_m_per_rad,
  acceleration_m_per_rad2,jerk_m_per_rad3`` on a uniform grid. The lift is for the
  lobe's *design* follower (converted from the probe with ``convert_lift`` when they
  differ); the probe's own version is then also published as
  ``<feature>/<method>/probe``.
* ``/reconstruction/result``: one DiagnosticStatus per feature and method (name
  ``<feature>/<method>``): ``order`` or ``smoothing`` and ``why``, ``rms_residual_m``,
  ``noise_sigma_m``, outliers, and errors against the design lift seen by the probe
  (``rms_error_lift_m``, ``max_error_velocity_m_per_rad``, ...); ERROR with the
  reason for a failed method; ``skipped/reconstruction/<feature>`` for a feature
  that is not reconstructed (scene ``compute`` without ``reconstruction``, the dowel
  pin, a table for an unknown lobe).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from cam_design.errors import InputError, require_positive
from cam_design.lift_table.samples import LiftTable
from cam_design.lift_table.spline import SplineOptions
from cam_metrology.cores.contract import merged_parameters
from cam_metrology.cores.outputs import ERROR, OK, WARN, Output, Status, StatusOutput, TableOutput
from cam_metrology.reconstruction.harmonic import MIN_ORDER, ORDER_EXPECTED, HarmonicOptions
from cam_metrology.reconstruction.profile import (Conversion, MethodOutcome, check_options,
                                                  reconstruct_table)
from cam_metrology.wire import topics as wire_topics
from cam_metrology.wire.layouts import table_from_msg

SCENE, LIFT = wire_topics.SCENE, wire_topics.METROLOGY_LIFT
PROFILE, RESULT = wire_topics.RECONSTRUCTION_PROFILE, wire_topics.RECONSTRUCTION_RESULT
PROFILE_COLUMNS = ('alpha_rad', 'lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2',
                   'jerk_m_per_rad3')
PIN_ID = 'dowel_pin'
DATUM_IDS = (PIN_ID, 'keyway')
#: allowed step [deg] of the uniform output grid: 10 deg still resolves a lobe of 60 deg
#: and more; 1e-3 deg is 360 000 points per revolution (far below any measured step)
STEP_DEG_RANGE = (1e-3, 10.0)


def check_step_deg(key: str, value: Any) -> float:
    """The output grid step [deg] as a float in ``STEP_DEG_RANGE``, else InputError."""
    lo, hi = STEP_DEG_RANGE
    try:
        step = float(value)
    except (TypeError, ValueError):
        raise InputError(key, value, f'a step in [{lo:g}, {hi:g}] deg') from None
    if isinstance(value, bool) or not (math.isfinite(step) and lo <= step <= hi):
        raise InputError(key, value, f'a step in [{lo:g}, {hi:g}] deg')
    return step


def _same_follower(a: Any, b: Any) -> bool:
    return a.kind == b.kind and (a.kind == 'flat' or abs(a.radius - b.radius) <= 1e-12)


def _fmt(value: Any) -> str:
    """A diagnostic value as text: floats with repr precision, others with str."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


class ReconstructionCore:
    """Smoothing-spline and N-harmonic reconstruction of measured lobe lifts."""

    name = 'reconstruction'
    subscriptions = {SCENE: 'std_msgs/msg/String', LIFT: 'std_msgs/msg/Float64MultiArray'}
    publications = {PROFILE: 'std_msgs/msg/Float64MultiArray',
                    RESULT: 'diagnostic_msgs/msg/DiagnosticArray'}
    PARAMETERS: dict[str, tuple[Any, str]] = {
        'methods': ('spline,harmonic', 'comma-separated methods: spline, harmonic'),
        'step_deg': (0.1, 'step [deg] of the uniform output grid'),
        'smoothing': (-1.0, 'spline smoothing level lam [rad^5] (weight of the integral '
                            "of h'''^2); < 0: automatic"),
        'smoothing_criterion': ('gcv', 'automatic spline smoothing: gcv | risk '
                                       '(estimated acceleration error)'),
        'rebound_threshold': (4.5, 'rebound tolerance in robust standard deviations of r'),
        'rebound_cap': (3.0, 'largest cumulative rebound move of a kept point, in noise '
                             'standard deviations (beyond: outlier, removed)'),
        'rebound_gain': (1.0, 'fraction lambda of the rebound applied per move (0, 1]'),
        'sign_changes': (2, "expected significant sign changes of h'' per lobe "
                            '(< 0: no check)'),
        'harmonics': (-1, 'harmonic order N; < 0: automatic'),
        'harmonic_basis': ('section', 'section (working-section cosine/sine basis) | '
                                      'full (rFFT over the revolution)'),
        'harmonic_criterion': ('', "automatic N: cp | bic | risk (full only); '' = bic "
                                   '(section), cp (full)'),
        'harmonic_continuity': (1, 'section basis: derivatives 0..k forced to 0 at the '
                                   'section ends (-1: none)'),
        'cam_speed_rpm': (0.0, 'cam speed for per-second values in the status; 0: the '
                               "scene's first valve_train speed, if any"),
    }

    def __init__(self, params: dict[str, Any] | None = None) -> None:
        p = merged_parameters('reconstruction', self.PARAMETERS, params)
        methods = tuple(m.strip() for m in str(p['methods']).split(',') if m.strip())
        for m in methods:
            if m not in ('spline', 'harmonic'):
                raise InputError('reconstruction.methods', p['methods'],
                                 'a comma-separated list of spline, harmonic')
        if not methods:
            raise InputError('reconstruction.methods', p['methods'], 'at least one method')
        self.methods = methods
        step = math.radians(check_step_deg('reconstruction.step_deg', p['step_deg']))
        smoothing = float(p['smoothing'])
        sign = int(p['sign_changes'])
        self.spline_options = SplineOptions(
            smoothing=None if smoothing < 0 else smoothing,
            criterion=str(p['smoothing_criterion']),
            threshold=float(p['rebound_threshold']), gain=float(p['rebound_gain']),
            cap=float(p['rebound_cap']), expected_sign_changes=None if sign < 0 else sign,
            step=step)
        order = int(p['harmonics'])
        if 0 <= order < MIN_ORDER:
            raise InputError('reconstruction.harmonics', p['harmonics'],
                             ORDER_EXPECTED.replace('omit it', '< 0'))
        self.harmonic_options = HarmonicOptions(
            basis=str(p['harmonic_basis']), order=None if order < 0 else order,
            criterion=str(p['harmonic_criterion']) or None, step=step,
            continuity=int(p['harmonic_continuity']))
        check_options(self.spline_options, self.harmonic_options)
        self.rpm = require_positive('reconstruction.cam_speed_rpm', p['cam_speed_rpm'],
                                    allow_zero=True)
        self.scene: Any = None
        self.pending: list[LiftTable] = []
        self.results: dict[str, dict[str, MethodOutcome]] = {}
        self.tables: dict[str, LiftTable] = {}
        self.skipped: dict[str, str] = {}

    # -- NodeCore protocol ---------------------------------------------------------------
    def handle(self, topic: str, msg: Any, stamp_ns: int) -> list[Output]:
        """Scene or lift table in; profiles and statuses out."""
        if topic == SCENE:
            return self._on_scene(str(msg.data), stamp_ns)
        if topic == LIFT:
            try:
                table = lift_table_from_message(msg)
            except InputError as exc:
                return [StatusOutput(RESULT, (Status('lift_table', ERROR, str(exc)),),
                                     stamp_ns)]
            if self.scene is None:
                self.pending.append(table)
                return []
            return self.process_table(table, stamp_ns)
        return []

    def tick(self, now_ns: int) -> list[Output]:
        """Nothing is time-driven here."""
        return []

    def finish(self) -> list[Output]:
        """Tables that arrived with no scene are reconstructed without design data."""
        out: list[Output] = []
        pending, self.pending = self.pending, []
        for table in pending:
            out += self.process_table(table, 0, note='no scene received: no design comparison')
        return out

    # -- internals -----------------------------------------------------------------------
    def _on_scene(self, text: str, stamp_ns: int) -> list[Output]:
        from cam_metrology.scene.parse import parse_scene

        try:
            self.scene = parse_scene(text, SCENE)
        except InputError as exc:
            return [StatusOutput(RESULT, (Status('scene', ERROR, str(exc)),), stamp_ns)]
        out: list[Output] = []
        pending, self.pending = self.pending, []
        for table in pending:
            out += self.process_table(table, stamp_ns)
        return out

    def _skip(self, feature: str, why: str, stamp_ns: int) -> list[Output]:
        self.skipped[feature] = why
        return [StatusOutput(RESULT, (Status(f'skipped/reconstruction/{feature}', OK, why),),
                             stamp_ns)]

    def cam_speed(self) -> float | None:
        """Cam speed [rpm] for per-second values: the parameter, else the scene's first
        valve-train speed, else None."""
        if self.rpm > 0:
            return self.rpm
        vt = getattr(self.scene, 'valve_train', None)
        if vt is not None and vt.cam_speed_rpm:
            return float(vt.cam_speed_rpm[0])
        return None

    def _design(self, feature: str) -> tuple[Any, Conversion | None, str]:
        """(design law seen by the probe or None, conversion or None, note)."""
        scene = self.scene
        lobe = scene.lobe(feature)
        probe = scene.probe
        if _same_follower(lobe.follower, probe):
            return lobe.lift, None, ''
        conv = Conversion(probe, lobe.follower, scene.base_circle_radius, lobe.lift)
        try:
            from cam_design.follower import convert_lift
            law = convert_lift(lobe.lift, scene.base_circle_radius, lobe.follower, probe,
                               key=f'lobes.{feature}.lift')
        except (ImportError, InputError) as exc:
            return None, conv, f'design not converted to the probe ({exc}); the ' \
                               'design_lift_m column is used'
        return law, conv, ''

    def process_table(self, table: LiftTable, stamp_ns: int, note: str = '') -> list[Output]:
        """Reconstruct one lift table (skips and failures become statuses); the
        outcomes are kept in ``results[feature]`` and the table in ``tables``."""
        feature = table.feature
        design = conv = None
        extra = note
        if self.scene is not None:
            if not self.scene.wants('reconstruction'):
                return self._skip(feature, 'compute does not ask for reconstruction',
                                  stamp_ns)
            if feature in DATUM_IDS:
                return self._skip(feature, f'the {feature.replace("_", " ")} is not a cam '
                                  'lobe to reconstruct', stamp_ns)
            try:
                design, conv, extra = self._design(feature)
            except KeyError:
                return self._skip(feature, 'no lobe with this id in the scene', stamp_ns)
        elif feature in DATUM_IDS:
            return self._skip(feature, f'the {feature.replace("_", " ")} is not a cam lobe '
                              'to reconstruct', stamp_ns)
        try:
            outcomes = reconstruct_table(table, methods=self.methods,
                                         spline=self.spline_options,
                                         harmonic=self.harmonic_options,
                                         design=design, conversion=conv)
        except InputError as exc:
            return [StatusOutput(RESULT, (Status(feature, ERROR, str(exc)),), stamp_ns)]
        self.results[feature] = outcomes
        self.tables[feature] = table
        out: list[Output] = []
        statuses = []
        for method, outcome in outcomes.items():
            label = f'{feature}/{method}'
            rec = outcome.reconstruction
            if rec is None:
                statuses.append(Status(label, ERROR, outcome.error))
                continue
            probe = rec.derivatives()
            main = outcome.engine if outcome.engine is not None else probe
            out.append(TableOutput(PROFILE, label, PROFILE_COLUMNS,
                                   np.column_stack([rec.alpha, *main])))
            if outcome.engine is not None:
                out.append(TableOutput(PROFILE, f'{label}/probe', PROFILE_COLUMNS,
                                       np.column_stack([rec.alpha, *probe])))
            statuses.append(self._status(label, outcome, extra))
        out.append(StatusOutput(RESULT, tuple(statuses), stamp_ns))
        return out

    def _status(self, label: str, outcome: MethodOutcome, note: str) -> Status:
        rec = outcome.reconstruction
        assert rec is not None
        values: dict[str, str] = {}
        key = 'order' if rec.method == 'harmonic' else 'smoothing'
        values[key] = _fmt(rec.parameter[key])
        for k, v in rec.parameter.items():
            if k != key:
                values[k] = _fmt(v)
        values['why'] = rec.why
        values['rms_residual_m'] = repr(rec.rms_residual)
        values['max_residual_m'] = repr(rec.max_residual)
        values['noise_sigma_m'] = repr(rec.sigma)
        values['outliers_deg'] = ','.join(f'{math.degrees(a):.4f}' for a in rec.outliers_alpha)
        values['max_lift_m'] = repr(float(np.max(rec.lift)))
        for k, v in outcome.design_errors.items():
            values[k] = repr(v)
        for k, v in outcome.engine_errors.items():
            values[f'engine_{k}'] = repr(v)
        rpm = self.cam_speed()
        if rpm:
            omega = rpm * math.pi / 30.0
            values['cam_speed_rpm'] = repr(rpm)
            values['max_velocity_m_per_s'] = repr(omega * float(np.max(np.abs(rec.velocity))))
            values['max_acceleration_m_per_s2'] = repr(
                omega ** 2 * float(np.max(np.abs(rec.acceleration))))
        if rec.spectrum is not None:
            orders, amps = rec.spectrum
            upto = min(int(rec.parameter.get('order', 0)), 60) + 1
            values['spectrum_amplitude_m'] = ','.join(repr(float(v)) for v in amps[:upto])
        follower = outcome.engine_note or note
        if follower:
            values['follower'] = follower
        warnings = list(rec.warnings)
        if outcome.engine_note and outcome.engine is None:
            warnings.append(outcome.engine_note)
        if not outcome.design_errors:
            values['design'] = 'unknown: no errors against the design'
        level = WARN if warnings else OK
        message = '; '.join(warnings) if warnings else rec.why
        if warnings:
            values['warnings'] = ' | '.join(warnings)
        values['notes'] = ' | '.join(rec.notes)
        return Status(label, level, message, values)


def lift_table_from_message(msg: Any) -> LiftTable:
    """A /metrology/lift table as a LiftTable (feature = the label)."""
    label, columns, data = table_from_msg(msg)
    index = {c: i for i, c in enumerate(columns)}
    for need in ('alpha_rad', 'lift_m'):
        if need not in index:
            raise InputError(f'{label}.columns', ','.join(columns), 'alpha_rad,lift_m[,...]')
    design = data[:, index['design_lift_m']].copy() if 'design_lift_m' in index else None
    return LiftTable(label, data[:, index['alpha_rad']].copy(),
                     data[:, index['lift_m']].copy(), design, None, LIFT)
