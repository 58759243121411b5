"""Dynamics node core (pure Python; no rclpy): valve motion of every lobe per cam speed.

Subscribes ``/bench/scene`` (std_msgs/String, scene YAML) and
``/reconstruction/profile`` (Float64MultiArray, label ``<feature>/<method>``, columns
``alpha_rad,lift_m,velocity_m_per_rad,acceleration_m_per_rad2,jerk_m_per_rad3``, the
lift for the lobe's design follower). For each lobe and each speed of the scene's
``valve_train.cam_speed_rpm`` it runs the scene's model (``sdof``: docs/dynamics.md with
the penalty or hard seat; ``mdof``: §4.2) and publishes

* ``/dynamics/valve_motion``: one table per lobe and speed, label
  ``<feature>/<rpm>rpm``, columns ``alpha_rad,valve_lift_m,valve_velocity_m_per_s,
  contact_force_n,contact_stress_pa`` (cam-follower force k F_t and Hertz stress);
* ``/dynamics/result``: one DiagnosticStatus per lobe and speed (name
  ``<feature>/<rpm>rpm``, values: source, opening/closing angles, separations,
  seating velocity, bounce count/height, max force/stress, epsilon ...; WARN when the
  valve separates or bounces, ERROR with the reason when a run fails), and
  ``skipped/dynamics`` when the scene has no ``valve_train`` or ``compute`` omits
  ``dynamics``.

With a scene ``camshaft:`` block and ``source=design`` every lobe runs on the scene's
flexible camshaft (``cam_design.camshaft``, docs/camshaft.md): the coupled runs are
published as above, their events carry ``timing_shift_deg``, and ``camshaft_runs`` keeps
the shaft's figures (all speeds are computed when the scene arrives: seconds per speed
and lobe count). With measured profiles (``source`` auto or profile) the shaft waits for
every lobe's profile and then runs them together on the flexible shaft; at ``finish``
the lobes still without one take their design law (auto) or, with ``source=profile``,
the profiles received run on a rigid shaft (a shaft with lobes missing has no meaning).

Lift source (parameter ``source``): ``auto`` uses the reconstructed profile of a lobe
when one arrives and the design law for lobes without one at ``finish``; ``profile``
only profiles; ``design`` the scene's design laws as soon as the scene arrives.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from cam_design.errors import InputError, require_positive
from cam_design.lift_laws.jet_table import JetTableLift
from cam_design.train.run import TrainSpec, run_train, train_from_valve_train
from cam_design.valve_train.params import require_rpm, require_step_deg
from cam_design.valve_train.report import COLUMNS, ContactGeometry, Run
from cam_metrology.cores.contract import merged_parameters
from cam_metrology.cores.outputs import ERROR, OK, WARN, Output, Status, StatusOutput, TableOutput
from cam_metrology.wire.layouts import table_from_msg
from cam_metrology.wire.topics import (DYNAMICS_MOTION, DYNAMICS_RESULT, RECONSTRUCTION_PROFILE,
                                       SCENE)

PROFILE, MOTION, RESULT = RECONSTRUCTION_PROFILE, DYNAMICS_MOTION, DYNAMICS_RESULT
PROFILE_COLUMNS = ('alpha_rad', 'lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2',
                   'jerk_m_per_rad3')
SOURCES = ('auto', 'profile', 'design')
#: why a lobe's run uses the design law with source=auto (no measured profile arrived)
FALLBACK_NOTE = ('no measured profile for this lobe (no /reconstruction/profile): '
                 'design law used')
RIGID_NOTE = ('not every lobe of the camshaft was measured: this lobe runs on a rigid '
              'shaft')


def rpm_label(rpm: float) -> str:
    """'1500' for 1500.0, '1234.5' otherwise."""
    return f'{rpm:g}'


def _fmt(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, list):
        return repr([[round(x, 6) for x in v] if isinstance(v, list) else v for v in value])
    return str(value)


def law_from_profile(cols: tuple[str, ...], data: np.ndarray, key: str) -> JetTableLift:
    """The reconstructed lift as a law (Hermite on h, h', h'', h''')."""
    missing = [c for c in PROFILE_COLUMNS if c not in cols]
    if missing:
        raise InputError(f'{key}.columns', ','.join(cols), ','.join(PROFILE_COLUMNS))
    idx = [cols.index(c) for c in PROFILE_COLUMNS]
    from cam_design.lift_table.lobe_table import lobe_from_jets

    return lobe_from_jets(data[:, idx[0]], data[:, idx[1:]].T, key=key)


class DynamicsCore:
    """Valve-train dynamics of the scene's lobes (docs/dynamics.md)."""

    name = 'dynamics'
    subscriptions = {SCENE: 'std_msgs/msg/String',
                     PROFILE: 'std_msgs/msg/Float64MultiArray'}
    publications = {MOTION: 'std_msgs/msg/Float64MultiArray',
                    RESULT: 'diagnostic_msgs/msg/DiagnosticArray'}
    PARAMETERS: dict[str, tuple[Any, str]] = {
        'source': ('auto', 'lift source: auto (reconstructed profile, else design law at '
                           'finish) | profile | design'),
        'profile_method': ('', 'reconstruction method to use (label suffix, e.g. spline); '
                               'empty: the first profile received per lobe'),
        'step_deg': (0.1, 'output grid step [deg] of /dynamics/valve_motion'),
        'cam_speeds_rpm': ('', 'comma-separated camshaft speeds [rpm] overriding the '
                               "scene's valve_train.cam_speed_rpm; empty: the scene's"),
        'cam_width': (0.012, 'contact line width W [m] for the Hertz stress of lobes '
                             'without a scene lobes[].width'),
        'youngs_modulus': (2.06e11, 'Young modulus E [Pa] of cam and follower (mu = 0.3)'),
        'max_revolutions': (4, 'at most this many revolutions to reach the periodic state'),
        'model': ('', "sdof | mdof | hydraulic; empty: the scene's valve_train.model"),
    }

    def __init__(self, params: dict[str, Any] | None = None) -> None:
        p = merged_parameters('dynamics', self.PARAMETERS, params)
        if p['source'] not in SOURCES:
            raise InputError('dynamics.source', p['source'], ' | '.join(SOURCES))
        self.source = str(p['source'])
        self.profile_method = str(p['profile_method'] or '')
        self.step_deg = require_step_deg('dynamics.step_deg', p['step_deg'])
        self.speeds = parse_speeds(p['cam_speeds_rpm'], 'dynamics.cam_speeds_rpm')
        self.cam_width = require_positive('dynamics.cam_width', p['cam_width'])
        self.youngs = require_positive('dynamics.youngs_modulus', p['youngs_modulus'])
        self.max_revolutions = int(require_positive('dynamics.max_revolutions',
                                                    p['max_revolutions']))
        if p['model'] not in ('', 'sdof', 'mdof', 'hydraulic'):
            raise InputError('dynamics.model', p['model'],
                             "sdof | mdof | hydraulic (or '' for the scene's)")
        self.model = str(p['model'])
        self.scene: Any = None
        self.laws: dict[str, tuple[Any, str]] = {}
        self.active = False
        self.done: set[str] = set()
        self.runs: dict[str, list[Run]] = {}
        self.failures: dict[str, str] = {}
        self.notes: dict[str, str] = {}
        self.camshaft_runs: list[Any] = []        # cam_design.camshaft CamshaftRun
        self.camshaft_failures: dict[str, str] = {}
        #: measured lobes waiting for the others to run on the flexible shaft
        self.waiting: dict[str, tuple[Any, str, str]] = {}

    # -- protocol ------------------------------------------------------------------
    def handle(self, topic: str, msg: Any, stamp_ns: int) -> list[Output]:
        """Scene: set up (and, with source=design, compute); profile: compute a lobe."""
        if topic == SCENE:
            return self._scene(str(msg.data), stamp_ns)
        if topic == PROFILE:
            return self._profile(msg, stamp_ns)
        return []

    def tick(self, now_ns: int) -> list[Output]:
        """Nothing is time-driven."""
        return []

    def finish(self) -> list[Output]:
        """source=auto: lobes without a profile use their design law."""
        if self.active and self.scene.camshaft is not None and self.waiting:
            return self._finish_shaft()
        if not self.active or self.source != 'auto':
            return []
        out: list[Output] = []
        for lobe in self.scene.lobes:
            if lobe.id not in self.done:
                out += self._compute(lobe.id, lobe.lift, 'design', 0, note=FALLBACK_NOTE)
        return out

    # -- work --------------------------------------------------------------------
    def _scene(self, text: str, stamp_ns: int) -> list[Output]:
        from cam_metrology.scene.parse import parse_scene

        self.done.clear()
        self.laws.clear()
        self.runs.clear()
        self.failures.clear()
        self.notes.clear()
        self.camshaft_runs, self.camshaft_failures = [], {}
        self.waiting = {}
        self.active = False
        try:
            scene = parse_scene(text, SCENE)
        except InputError as exc:
            return [self._status(Status('skipped/dynamics', ERROR,
                                        f'invalid scene: {exc}'), stamp_ns)]
        self.scene = scene
        if scene.valve_train is None:
            return [self._skip('scene has no valve_train', stamp_ns)]
        if not scene.wants('dynamics'):
            return [self._skip('dynamics not in compute', stamp_ns)]
        self.active = True
        if self.source != 'design':
            return []
        if scene.camshaft is not None:
            return self._compute_camshaft(stamp_ns)
        out: list[Output] = []
        for lobe in scene.lobes:
            out += self._compute(lobe.id, lobe.lift, 'design', stamp_ns)
        return out

    def _profile(self, msg: Any, stamp_ns: int) -> list[Output]:
        if not self.active or self.source == 'design':
            return []
        try:
            label, cols, data = table_from_msg(msg)
        except InputError as exc:
            return [self._status(Status('dynamics/profile', ERROR, str(exc)), stamp_ns)]
        parts = label.split('/')
        if len(parts) != 2:          # '<feature>/<method>/probe' and others: not ours
            return []
        feature, method = parts
        if self.profile_method and method != self.profile_method:
            return []
        if feature in self.done:
            return []
        try:
            self.scene.lobe(feature)
        except KeyError:
            return []
        try:
            law = law_from_profile(cols, data, label)
        except InputError as exc:
            self.done.add(feature)
            return [self._status(Status(f'{feature}', ERROR, f'profile {label}: {exc}'),
                                 stamp_ns)]
        if self.scene.camshaft is not None:
            self.done.add(feature)
            self.waiting[feature] = (law, f'profile:{method}',
                                     f'{PROFILE} {feature}/{method}')
            if all(lb.id in self.waiting for lb in self.scene.lobes):
                return self._compute_camshaft(stamp_ns)
            return []
        return self._compute(feature, law, f'profile:{method}', stamp_ns)

    def _finish_shaft(self) -> list[Output]:
        """The measured lobes on the flexible shaft with the design law of the others
        (source auto), or on a rigid shaft when lobes are missing (source profile)."""
        if self.source == 'auto':
            for lobe in self.scene.lobes:
                if lobe.id not in self.waiting:
                    self.done.add(lobe.id)
                    self.notes[lobe.id] = FALLBACK_NOTE
                    self.waiting[lobe.id] = (lobe.lift, 'design',
                                             lobe_key(self.scene, lobe.id))
            return self._compute_camshaft(0)
        out: list[Output] = []
        waiting, self.waiting = self.waiting, {}
        for feature, (law, source, _) in waiting.items():
            out += self._compute(feature, law, source, 0, note=RIGID_NOTE)
        return out

    def _compute(self, feature: str, law: Any, source: str, stamp_ns: int,
                 note: str | None = None) -> list[Output]:
        self.done.add(feature)
        self.laws[feature] = (law, source)
        if note:
            self.notes[feature] = note
        vt = self.scene.valve_train
        lobe = self.scene.lobe(feature)
        speeds = self.speeds or tuple(vt.cam_speed_rpm)
        try:        # a refusal of the train fails each of its speeds (as it always did)
            train: TrainSpec | Exception = train_from_valve_train(vt, self.model or None)
        except (InputError, RuntimeError, ValueError) as exc:
            train = exc
        width, width_source = cam_width_of(lobe, self.cam_width)
        geom = ContactGeometry(base_radius=self.scene.base_circle_radius,
                               follower=lobe.follower.kind, radius=lobe.follower.radius,
                               width=width, youngs_modulus=self.youngs)
        out: list[Output] = []
        statuses: list[Any] = []
        key = (lobe_key(self.scene, feature) if source == 'design'
               else f'{PROFILE} {feature}/{source.split(":", 1)[-1]}')
        for rpm in speeds:
            name = f'{feature}/{rpm_label(rpm)}rpm'
            try:
                if isinstance(train, Exception):
                    raise train
                run = run_train(law, train, rpm, step_deg=self.step_deg, geometry=geom,
                                max_revolutions=self.max_revolutions, key=key)
            except (InputError, RuntimeError, ValueError) as exc:
                self._failed(name, str(exc), source, note, statuses)
                continue
            run.events['cam_width_source'] = width_source
            out += self._publish(feature, name, run, source, note, statuses)
        out.append(StatusOutput(RESULT, tuple(statuses), stamp_ns))
        return out

    def _failed(self, name: str, why: str, source: str, note: str | None,
                statuses: list[Status]) -> None:
        self.failures[name] = why
        statuses.append(Status(name, ERROR, f'dynamics failed: {why}',
                               {'source': source, **({'source_note': note}
                                                     if note else {})}))

    def _publish(self, feature: str, name: str, run: Run, source: str, note: str | None,
                 statuses: list[Status]) -> list[Output]:
        """Keep a run; its motion table(s) and its status (appended to ``statuses``)."""
        self.runs.setdefault(feature, []).append(run)
        out: list[Output] = [TableOutput(MOTION, name, COLUMNS, run.table())]
        if hasattr(run, 'pressure_table'):   # hydraulic model: chamber pressures
            from cam_design.hydraulic.run import PRESSURE_COLUMNS

            out.append(TableOutput(MOTION, f'{name}/pressure', PRESSURE_COLUMNS,
                                   run.pressure_table()))
        ev = run.events
        level = WARN if (ev.get('jump') or ev.get('bounce_count') or ev.get('left_cam')
                         or ev.get('settled') is False) else OK
        msg = ('valve leaves the cam' if ev.get('left_cam') else
               'not settled' if ev.get('settled') is False else
               'separation' if ev.get('jump') else
               'bounce' if ev.get('bounce_count') else 'ok')
        values = {'source': source, 'model': run.model}
        if note:
            values['source_note'] = note
        values.update({k: _fmt(v) for k, v in ev.items()})
        statuses.append(Status(name, level, msg, values))
        return out

    def _compute_camshaft(self, stamp_ns: int) -> list[Output]:
        """Every lobe on the scene's flexible camshaft (docs/camshaft.md): its measured
        profile when one is waiting, else its design law; the coupled runs per speed,
        published like single runs (their events carry the lobe's
        ``timing_shift_deg``); ``self.camshaft_runs`` keeps the shaft's results."""
        from cam_metrology.dynamics.camshaft import run_speeds

        scene = self.scene
        speeds = self.speeds or tuple(scene.valve_train.cam_speed_rpm)
        chosen = {lb.id: self.waiting.get(lb.id, (lb.lift, 'design',
                                                  lobe_key(scene, lb.id)))
                  for lb in scene.lobes}
        self.waiting = {}
        keys = {lid: c[2] for lid, c in chosen.items()}
        laws = {lid: c[0] for lid, c in chosen.items()}
        for lb in scene.lobes:
            self.done.add(lb.id)
            self.laws[lb.id] = (chosen[lb.id][0], chosen[lb.id][1])
        statuses: list[Status] = []
        out: list[Output] = []
        try:
            train = train_from_valve_train(scene.valve_train, self.model or None)
            runs, failures = run_speeds(scene, train, speeds, step_deg=self.step_deg,
                                        cam_width=self.cam_width, youngs=self.youngs,
                                        max_revolutions=self.max_revolutions, keys=keys,
                                        laws=laws)
        except (InputError, RuntimeError, ValueError) as exc:
            runs, failures = [], {f'{rpm_label(r)}rpm': str(exc) for r in speeds}
        self.camshaft_runs = runs
        self.camshaft_failures = failures
        for label, why in failures.items():
            for lb in scene.lobes:
                self._failed(f'{lb.id}/{label}', why, chosen[lb.id][1],
                             self.notes.get(lb.id), statuses)
        for cr in runs:
            for lb in scene.lobes:
                run = cr.runs[lb.id]
                run.events['timing_shift_deg'] = cr.extras[lb.id]['timing_shift_deg']
                run.events['cam_width_source'] = cam_width_of(lb, self.cam_width)[1]
                out += self._publish(lb.id, f'{lb.id}/{rpm_label(cr.rpm)}rpm', run,
                                     chosen[lb.id][1], self.notes.get(lb.id), statuses)
        out.append(StatusOutput(RESULT, tuple(statuses), stamp_ns))
        return out

    def _skip(self, why: str, stamp_ns: int) -> StatusOutput:
        return self._status(Status('skipped/dynamics', OK, why, {'why': why}), stamp_ns)

    @staticmethod
    def _status(status: Status, stamp_ns: int) -> StatusOutput:
        return StatusOutput(RESULT, (status,), stamp_ns)


def cam_width_of(lobe: Any, default: float) -> tuple[float, str]:
    """Hertz contact line length [m] of a lobe and where it comes from: the scene's
    ``lobes[].width`` when given, else ``default`` (the ``cam_width`` parameter)."""
    width = getattr(lobe, 'width', None)
    if width is not None:
        return float(width), 'scene lobes[].width'
    return float(default), 'parameter cam_width'


def parse_speeds(value: Any, key: str) -> tuple[float, ...]:
    """'1500, 3000' or [1500, 3000] -> (1500.0, 3000.0); '' -> ().

    Each speed must be in (0, 1e5] rpm (``valve_train.params.RPM_MAX``).
    """
    if value is None or value == '' or value == []:
        return ()
    items = value.split(',') if isinstance(value, str) else list(value)
    out = []
    for i, item in enumerate(items):
        try:
            speed = float(item)
        except (TypeError, ValueError):
            raise InputError(f'{key}[{i}]', item, 'a speed > 0 in rpm') from None
        out.append(require_rpm(f'{key}[{i}]', speed))
    return tuple(out)


def lobe_key(scene: Any, feature: str) -> str:
    """The scene key of a lobe's design lift: ``lobes[i].lift_law`` or ``lobes[i].lift``."""
    for i, lobe in enumerate(scene.lobes):
        if lobe.id == feature:
            spec = getattr(lobe, 'lift_spec', None)
            return f'lobes[{i}].lift_law' if spec is not None else f'lobes[{i}].lift'
    return 'lift'
