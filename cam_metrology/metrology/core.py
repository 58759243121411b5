"""Metrology node core (pure Python; the ROS adapter and the offline replay drive it).

Subscribes ``/bench/scene``, ``/bench/joint_states`` (one sample per message),
``/bench/joint_trajectory`` (blocks of samples), ``/bench/feature_done``. The joints
are looked up by the names of the parameters ``angle_joint`` and ``lift_joint``
(``camshaft``, ``probe`` by default); ``feature_id`` gives every sample one feature
when the bench's ``frame_id`` is not the feature (a ros2_control bench).
Publishes, per completed feature, a status on ``/metrology/result`` (name = feature
id; ERROR with the reason for a failed feature; ``skipped/<what>`` statuses for what
is not computed) and its aligned lift table on ``/metrology/lift``; the JSON report
(docs/contract.md) on ``/metrology/report`` when every expected feature is done, and
again at ``finish``. A feature is analysed as soon as it ends (next frame_id,
feature_done or idle timeout), so results follow the last sample within the
analysis time of one feature (tens of ms).
"""
from __future__ import annotations

import json
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from cam_design.dowel_pin import DowelPinGeometry
from cam_design.keyway import KeywayGeometry
from cam_design.errors import InputError, require_positive
from cam_metrology.cores.contract import merged_parameters
from cam_metrology.host.heap import trim
from cam_metrology.report.json_out import json_safe
from cam_metrology.scene.channels import joints_in_force
from cam_metrology.metrology.analysis import (FeatureFailed, FeatureResult, Settings,
                                              analyze_keyway, analyze_lobe, analyze_pin,
                                              seen_lift)
from cam_metrology.metrology.derivative_error import derivative_errors
from cam_metrology.metrology.feature_form import lobe_form
from cam_metrology.metrology.spill import release, spill
from cam_metrology.metrology.tracks import nose_lift_error_um, track_label
from cam_metrology.metrology.features import (FeatureAssembler, FeatureSamples,
                                              encoder_units_hint, probe_units_problem,
                                              joint_positions, sample_joints, stamp_of)
from cam_metrology.cores.outputs import (ERROR, OK, WARN, Output, Status, StatusOutput,
                                         TableOutput, TextOutput)
from cam_metrology.wire import topics as wt

RESULT, LIFT, REPORT = wt.METROLOGY_RESULT, wt.METROLOGY_LIFT, wt.METROLOGY_REPORT
SCENE, JOINTS, DONE = wt.SCENE, wt.JOINT_STATES, wt.FEATURE_DONE
BLOCKS = wt.JOINT_TRAJECTORY
PIN_ID = 'dowel_pin'
KEYWAY_ID = 'keyway'
DATUM_IDS = (PIN_ID, KEYWAY_ID)
#: after a feature of at least this many samples the C heap is trimmed (``heap.trim``:
#: 14 MB less at 2 M samples; below, the pages given back would be faulted in again)
TRIM_SAMPLES = 1_000_000
LIFT_COLUMNS = ('alpha_rad', 'lift_m', 'design_lift_m')


def wrap_deg(angle: float) -> float:
    """Angle [deg] wrapped to (-180, 180]."""
    out = (angle + 180.0) % 360.0 - 180.0
    return 180.0 if out == -180.0 else out


def _flat(values: dict[str, Any], prefix: str = '') -> dict[str, str]:
    """Nested report values as flat key/value strings for a DiagnosticStatus."""
    out: dict[str, str] = {}
    for key, val in values.items():
        name = f'{prefix}{key}'
        if isinstance(val, dict):
            out.update(_flat(val, name + '.'))
        elif isinstance(val, (list, tuple)):
            out[name] = ','.join(repr(float(v)) if isinstance(v, float) else str(v) for v in val)
        elif isinstance(val, (bool, np.bool_)):
            out[name] = str(bool(val))
        elif isinstance(val, (float, np.floating)):
            out[name] = repr(float(val))
        else:
            out[name] = str(val)
    return out


class MetrologyCore:
    """Nose angles, pin angle, phases, asymmetry and lift errors of a camshaft."""

    name = 'metrology'
    subscriptions = {SCENE: 'std_msgs/msg/String',
                     JOINTS: wt.JOINT_STATE,
                     BLOCKS: wt.JOINT_TRAJECTORY_TYPE,
                     DONE: 'std_msgs/msg/String'}
    publications = {RESULT: 'diagnostic_msgs/msg/DiagnosticArray',
                    LIFT: 'std_msgs/msg/Float64MultiArray',
                    REPORT: 'std_msgs/msg/String'}
    PARAMETERS: dict[str, tuple[Any, str]] = {
        'fit_runout': (True, 'fit a first-harmonic base-circle run-out with the angle '
                             '(when the samples cover the revolution); costs ~7 % in std, '
                             'removes the run-out bias'),
        'min_flank_samples': (20, 'minimum samples in each flank sensitive zone, else '
                                  'the feature fails'),
        'max_flank_gap_deg': (2.0, 'largest gap [deg] allowed in a flank sensitive zone'),
        'sp_half_window_deg': (1.0, 'half width [deg] of the local fit at a sensitive point'),
        'sp_fit_order': (1, 'polynomial order of the local deviation fit (0..3)'),
        'sp_pairs': (0, 'extra level pairs on each side of the sensitive points '
                        '(multi-pair variant; 0 = one pair)'),
        'sp_pair_spacing_deg': (0.5, 'angular spacing [deg] of the extra level pairs'),
        'pin_edge_margin_deg': (0.5, 'dowel pin: samples within this angle [deg] of the '
                                     'contact tangent point are excluded'),
        'validity_tol_um': (1.0, 'tolerance [um] of the h_m = h_n validity check '
                                 '(at least 3 sigma of the check is allowed)'),
        'asymmetry_knot_deg': (0.5, 'knot spacing [deg] of the regression spline used '
                                    'for the symmetry axis'),
        'max_shift_deg': (5.0, 'a fit moving the angle further than this [deg] from the '
                               'coarse estimate fails the feature'),
        'max_residual_rms_um': (50.0, 'a fit leaving a larger residual RMS [um] fails the '
                                      'feature (the lift does not match the design)'),
        'outlier_sigma': (5.0, 'samples whose fit residual exceeds this many robust sigmas '
                               '(1.4826 MAD) are rejected and counted (0: keep all)'),
        'idle_timeout': (0.0, 'seconds without samples that end a feature (0: the '
                              "scene's idle_timeout)"),
        'angle_joint': (wt.CAMSHAFT_JOINT, 'name of the joint whose position is the '
                                           'camshaft encoder angle [rad] (the default: '
                                           "the scene's channels.angle_joint if given)"),
        'lift_joint': (wt.PROBE_JOINT, 'name of the joint whose position is the probe '
                                       "lift [m] (the default: the scene's "
                                       'channels.lift_joint if given)'),
        'feature_id': ('', "the feature of every sample ('': the message's "
                           'header.frame_id); for a bench whose frame_id is not the '
                           'feature, e.g. a ros2_control joint_state_broadcaster'),
    }

    def __init__(self, params: dict[str, Any] | None = None) -> None:
        params = dict(params or {})
        merged_parameters('metrology', self.PARAMETERS, params)   # rejects unknown names
        self.settings = Settings.from_params(params)
        self.idle_timeout_param = require_positive('metrology.idle_timeout',
                                                   params.get('idle_timeout', 0.0),
                                                   allow_zero=True)
        #: the joint names of the parameters; ``joints``: those in force (the scene's
        #: ``channels`` when the parameters keep the defaults)
        self.joints_param = sample_joints(params)
        self.joints = self.joints_param
        self.feature_id = str(params.get('feature_id', '') or '')
        self.scene: Any = None
        self.assembler = FeatureAssembler()
        self.pending: list[FeatureSamples] = []
        self.results: dict[str, FeatureResult] = {}
        self.report_sent = False
        #: the final report as data (what ``finish`` publishes as JSON text), for offline use
        self.final_report: dict[str, Any] | None = None
        self._design: dict[str, Any] = {}
        #: every scene that came into force: (log time [ns], Scene)
        self.scenes: list[tuple[int, Any]] = []
        self._scene_of: dict[str, int] = {}   # feature id -> index in self.scenes

    # ------------------------------------------------------------------ inputs
    def set_scene(self, scene: Any, stamp_ns: int = 0) -> list[Output]:
        """Use a parsed ``Scene``; analyses features that were waiting for it.

        A different scene after features were measured does not discard them: the open
        feature is closed and analysed with the scene in force while it was measured,
        results keep the index of their scene (report: ``scenes``, ``scene_index``),
        and a feature measured again replaces its earlier result. A scene with another
        ``camshaft_id`` is another part: the final report of the part so far is
        published first (``_end_part``)."""
        if self.scene is not None and scene.text and scene.text == self.scene.text:
            return []
        out: list[Output] = []
        if self.scene is not None:
            out += self._complete_all(self.assembler.close(), stamp_ns)
            if scene.camshaft_id != self.scene.camshaft_id and self.results:
                out += self._end_part()
        self.scene = scene
        self.joints = joints_in_force(self.joints_param, scene)
        self.scenes.append((int(stamp_ns), scene))
        self.report_sent, self._design = False, {}
        waiting, self.pending = self.pending, []
        for fs in waiting:
            out += self._complete(fs, 0)
        return out

    def _end_part(self) -> list[Output]:
        """Another camshaft is on the bench (a scene with another ``camshaft_id``): the
        final report of the part measured so far, then a fresh start (its results are
        never reported under the new id, nor the new part's under the old one)."""
        out: list[Output] = [TextOutput(REPORT, json.dumps(self.report(final=True),
                                                           indent=1))]
        self.results, self.scenes, self._scene_of = {}, [], {}
        return out

    def handle(self, topic: str, msg: Any, stamp_ns: int) -> list[Output]:
        """Consume one message (scene, sample or feature_done)."""
        if topic == JOINTS:
            try:
                theta, s = joint_positions(msg, self.joints)
            except InputError:   # a message without the joints: a NaN sample, counted
                theta, s = float('nan'), float('nan')
            done = self.assembler.add(self.feature_id or msg.header.frame_id,
                                      stamp_of(msg, stamp_ns),
                                      theta, s, stamp_ns)
            return self._complete_all(done, stamp_ns)
        if topic == DONE:
            return self._complete_all(self.assembler.close(str(msg.data)), stamp_ns)
        if topic == SCENE:
            try:
                from cam_metrology.scene.parse import parse_scene
                scene = parse_scene(str(msg.data), source=SCENE)
            except ImportError:
                return [self._status(Status('scene', ERROR, 'scene parser not available'),
                                     stamp_ns)]
            except InputError as exc:
                return [self._status(Status('scene', ERROR, f'invalid scene: {exc}'), stamp_ns)]
            return self.set_scene(scene, stamp_ns)
        return []

    def handle_samples(self, frame_ids: Sequence[str] | ArrayLike, stamp_ns: ArrayLike,
                       theta: ArrayLike, s: ArrayLike, rx_ns: int | None = None,
                       ) -> list[Output]:
        """Bulk path of the offline replay: many JointState samples at once.

        ``frame_ids`` feature ids, ``stamp_ns`` acquisition stamps [ns], ``theta``
        [rad], ``s`` [m] (NaN where a message lacked the joint). ``rx_ns``: receive
        time of the last sample (default: its stamp).
        """
        st = np.asarray(stamp_ns, dtype=np.int64)
        rx = int(st[-1]) if rx_ns is None and st.size else int(rx_ns or 0)
        if self.feature_id:
            frame_ids = np.full(st.size, self.feature_id)
        return self._complete_all(self.assembler.add_bulk(frame_ids, st, theta, s, rx), rx)

    def tick(self, now_ns: int) -> list[Output]:
        """End the open feature after the idle timeout."""
        if self.assembler.current is None:
            return []
        timeout = self.idle_timeout_param or (self.scene.idle_timeout if self.scene else 1.0)
        if now_ns - self.assembler.last_rx_ns > timeout * 1e9:
            return self._complete_all(self.assembler.close(), now_ns)
        return []

    def finish(self) -> list[Output]:
        """End of stream: close the open feature; publish the final report."""
        out = self._complete_all(self.assembler.close(), 0)
        if self.scene is None:
            return out + [self._status(Status('scene', ERROR, 'no scene received: nothing '
                                              'measured'), 0)]
        self.final_report = self.report(final=True)
        out.append(TextOutput(REPORT, json.dumps(self.final_report, indent=1)))
        self.report_sent = True
        return out

    # --------------------------------------------------------------- analysis
    def _complete_all(self, done: list[FeatureSamples], stamp_ns: int) -> list[Output]:
        out: list[Output] = []
        while done:   # taken from the list: each feature's samples freed once analysed
            out += self._complete(done.pop(0), stamp_ns)
        return out

    def _complete(self, fs: FeatureSamples, stamp_ns: int) -> list[Output]:
        if self.scene is None:
            self.pending.append(fs)
            return []
        large = fs.theta.size >= TRIM_SAMPLES
        if large:
            trim()   # the assembly's chunks, freed
        result = self._analyze(fs)
        fid = fs.feature_id
        del fs   # the samples are not needed for the report (memory)
        result.table = spill(result.table)   # a large table: out of memory until read
        self.results[fid] = result
        if large:
            trim()   # the analysis' temporaries, freed
        self._scene_of[fid] = len(self.scenes) - 1
        out: list[Output] = [self._feature_status(result, stamp_ns)]
        if result.table is not None:
            out.append(TableOutput(LIFT, fid, LIFT_COLUMNS, result.table))
        if fid == self._datum_id() and self._pin_angle() is not None:
            # lobes measured before the pin: publish them again, now with their phase
            out += [self._feature_status(r, stamp_ns) for r in self.results.values()
                    if r.kind == 'lobe' and r.angle_rad is not None]
        if not self.report_sent and not self._missing():
            out.append(TextOutput(REPORT, json.dumps(self.report(final=False), indent=1)))
            self.report_sent = True
        return out

    def _analyze(self, fs: FeatureSamples) -> FeatureResult:
        scene = self.scene
        kind = fs.feature_id if fs.feature_id in DATUM_IDS else 'lobe'
        journal = scene.journal(fs.feature_id)
        if journal is not None:
            kind = 'journal'
        counts = {'samples_received': fs.received, 'samples_nan_dropped': fs.nan_dropped}
        try:
            if journal is not None:
                return self._journal(fs, journal, counts)
            units = probe_units_problem(fs)
            if units:
                raise FeatureFailed(units)
            if kind != 'lobe':
                if getattr(scene, kind, None) is None:
                    raise FeatureFailed(f'scene has no {kind}')
                if not scene.wants('pin'):
                    return FeatureResult(fs.feature_id, kind, {'kind': kind, **counts},
                                         skipped=[('pin', 'compute does not ask for pin')])
                if kind == KEYWAY_ID:
                    k = scene.keyway
                    kgeo = KeywayGeometry(k.width, k.shaft_radius, k.probe_radius, k.depth)
                    return analyze_keyway(fs, kgeo, scene.direction, self.settings)
                p = scene.dowel_pin
                geo = DowelPinGeometry(p.pin_radius, p.circle_radius, p.probe_radius)
                return analyze_pin(fs, geo, scene.direction, self.settings)
            track = track_label(fs.feature_id)   # lobe_1@-4: a track across the width
            try:
                lobe = scene.lobe(fs.feature_id if track is None else track[0])
            except KeyError:
                raise FeatureFailed(f'feature {fs.feature_id!r} is not in the scene') from None
            if not scene.wants('nose'):
                return FeatureResult(fs.feature_id, kind, {'kind': kind, **counts},
                                     skipped=[('nose', 'compute does not ask for nose')])
            if lobe.id not in self._design:
                self._design[lobe.id] = seen_lift(lobe, scene.probe, scene.base_circle_radius)
            result = analyze_lobe(fs, self._design[lobe.id], scene.direction, self.settings,
                                  asymmetry=scene.wants('asymmetry'))
            form = lobe_form(result.table, result.values, scene.direction, scene.form)
            result.values.update(form)
            if 'form_error' in form:
                result.skipped.append(('form', form['form_error']))
            if scene.form.derivative_errors or (lobe.tolerances is not None and
                                                lobe.tolerances.wants_derivatives()):
                zones = lobe.tolerances.derivative_error_zones if lobe.tolerances else ()
                result.values.update(derivative_errors(result.table, result.values,
                                                       self._design[lobe.id], zones))
            if track is not None:
                result.values.update({'track_of': track[0], 'track_mm': track[1],
                                      'nose_lift_error_um': nose_lift_error_um(
                                          result.table, result.values)})
            if lobe.axial_position is not None:
                result.values['axial_position_mm'] = lobe.axial_position * 1e3 + (
                    0.0 if track is None else track[1])
            return result
        except (FeatureFailed, InputError) as exc:
            return FeatureResult(fs.feature_id, kind, {'kind': kind, **counts},
                                 failed=str(exc) + encoder_units_hint(fs))
        except (np.linalg.LinAlgError, FloatingPointError) as exc:
            return FeatureResult(fs.feature_id, kind, {'kind': kind, **counts},
                                 failed=f'numerical failure of the fit ({exc}): check the '
                                 'samples (units: m and rad)' + encoder_units_hint(fs))

    def _journal(self, fs: FeatureSamples, journal: Any, counts: dict[str, Any],
                 ) -> FeatureResult:
        """A journal: diameter, run-out and form (``journals.analyze_journal``)."""
        from cam_metrology.metrology.journals import analyze_journal

        form = self.scene.form
        values = analyze_journal(fs.theta, fs.s, journal.radius, self.scene.probe_zero_radius,
                                 cutoff_upr=form.cutoff_upr, band=form.waviness_band_upr,
                                 key=fs.feature_id)
        values['axial_position_mm'] = journal.axial_position * 1e3
        skipped = [('form', values['form_error'])] if 'form_error' in values else []
        if values['diameter_deviation_um'] is None:
            skipped.append(('diameter', 'the scene gives no probe.zero_radius (the radius '
                                        'at which the probe reads 0)'))
        return FeatureResult(fs.feature_id, 'journal', {**values, **counts,
                                                        'samples_used': int(fs.theta.size)},
                             skipped=skipped)

    def _datum_id(self) -> str:
        """Feature id of the scene's angular datum (dowel_pin when it has none)."""
        return (self.scene.datum_id if self.scene is not None else None) or PIN_ID

    def _pin_angle(self) -> float | None:
        """Encoder angle [rad] of the measured datum (dowel pin or keyway centre)."""
        pin = self.results.get(self._datum_id())
        return pin.angle_rad if pin is not None and pin.failed is None else None

    def _phase(self, result: FeatureResult) -> dict[str, Any]:
        """phase_deg and phase_error_deg of a measured lobe (None when unavailable)."""
        pin = self._pin_angle()
        index = self._scene_of.get(result.feature_id, len(self.scenes) - 1)
        if result.angle_rad is None or pin is None or \
                index != self._scene_of.get(self._datum_id(), index):
            return {'phase_deg': None, 'phase_error_deg': None}
        phase = wrap_deg(np.degrees(result.angle_rad - pin))
        lobe_id = result.values.get('track_of') or result.feature_id
        nominal = self.scenes[index][1].lobe(lobe_id).nominal_phase \
            if self.scenes else self.scene.lobe(lobe_id).nominal_phase
        err = None if nominal is None else wrap_deg(phase - np.degrees(nominal))
        return {'phase_deg': phase, 'phase_error_deg': err}

    # ------------------------------------------------------------------ outputs
    def _status(self, status: Status, stamp_ns: int) -> StatusOutput:
        return StatusOutput(RESULT, (status,), stamp_ns)

    def _feature_status(self, result: FeatureResult, stamp_ns: int) -> StatusOutput:
        if result.failed is not None:
            main = Status(result.feature_id, ERROR, result.failed,
                          _flat(result.values), result.kind)
        else:
            values = dict(result.values)
            if result.kind == 'lobe' and result.angle_rad is not None:
                values.update({k: v for k, v in self._phase(result).items() if v is not None})
            valid = values.get('validity', {}).get('valid', True)
            level = OK if valid else WARN
            msg = 'measured' if valid else 'measured; sensitive-point validity check failed'
            if values.get('sensitive_point_error'):
                level, msg = WARN, f"measured; {values['sensitive_point_error']}"

            main = Status(result.feature_id, level, msg, _flat(values), result.kind)
        extra = tuple(Status(f'skipped/{what}/{result.feature_id}', OK, why)
                      for what, why in result.skipped)
        return StatusOutput(RESULT, (main,) + extra, stamp_ns)

    def _expected(self) -> list[str]:
        scene = self.scene
        ids = [lobe.id for lobe in scene.lobes] if scene.wants('nose') else []
        ids += [j.id for j in scene.journals]
        if scene.datum_id is not None and scene.wants('pin'):
            ids.append(scene.datum_id)
        return ids

    def _measured(self, feature_id: str) -> bool:
        """True if the feature, or a track of it (``<id>@<z mm>``), has a result."""
        return feature_id in self.results or any(
            f.startswith(feature_id + '@') for f in self.results)

    def _missing(self) -> list[str]:
        return [i for i in self._expected() if not self._measured(i)]

    def skipped(self) -> list[dict[str, str]]:
        """What the scene or the data do not allow, with the reason."""
        scene = self.scene
        out: list[dict[str, str]] = []
        if not scene.wants('nose'):
            out.append({'what': 'nose', 'why': 'compute does not ask for nose'})
        datum = scene.datum_id
        if datum is None:
            out.append({'what': 'pin', 'why': 'scene has no dowel_pin'})   # nor keyway
        elif not scene.wants('pin'):
            out.append({'what': 'pin', 'why': 'compute does not ask for pin'})
        elif datum not in self.results:
            out.append({'what': 'pin', 'why': f'no {datum} samples in the data'})
        elif self.results[datum].failed:
            out.append({'what': 'pin', 'why': f'{datum} failed: {self.results[datum].failed}'})
        if scene.wants('nose') and self._pin_angle() is None:
            out.append({'what': 'phase', 'why': f'no {(datum or "dowel_pin").replace("_", "-")} '
                                                'angle (see pin)'})
        if not scene.wants('asymmetry'):
            out.append({'what': 'asymmetry', 'why': 'compute does not ask for asymmetry'})
        for lobe in scene.lobes:
            if scene.wants('nose') and not self._measured(lobe.id):
                out.append({'what': lobe.id, 'why': 'no samples for this lobe in the data'})
            elif lobe.nominal_phase is None and self._pin_angle() is not None:
                out.append({'what': f'phase_error/{lobe.id}', 'why': 'lobe has no nominal_phase'})
        for res in self.results.values():
            out += [{'what': f'{what}/{res.feature_id}', 'why': why} for what, why in res.skipped]
            if res.kind == 'lobe' and self._pin_angle() is not None and \
                    self._scene_of.get(res.feature_id) != self._scene_of.get(self._datum_id()):
                out.append({'what': f'phase/{res.feature_id}',
                            'why': f'measured under another scene than the '
                                   f'{self._datum_id().replace("_", " ")}'})
        return out

    def report(self, final: bool = True) -> dict[str, Any]:
        """The JSON report of docs/contract.md (plus extra keys)."""
        scene = self.scene
        features: dict[str, Any] = {}
        for fid, res in self.results.items():
            entry: dict[str, Any] = {'kind': res.kind, 'angle_deg': None, 'angle_std_deg': None}
            if res.kind == 'lobe':
                entry.update({'phase_deg': None, 'phase_error_deg': None, 'asymmetry_deg': None})
            entry.update(res.values)
            if res.failed is not None:
                entry.update({'status': 'failed', 'reason': res.failed})
            elif res.skipped and res.angle_rad is None:
                entry['status'] = 'skipped'
            else:
                entry['status'] = 'ok'
                if res.kind == 'lobe':
                    entry.update(self._phase(res))
            if len(self.scenes) > 1:
                entry['scene_index'] = self._scene_of.get(fid)
            features[fid] = entry
        pin = self._pin_angle()
        extra: dict[str, Any] = {}
        if len(self.scenes) > 1:
            extra['scenes'] = [{'index': k, 'camshaft_id': sc.camshaft_id,
                                'from_log_time_ns': t}
                               for k, (t, sc) in enumerate(self.scenes)]
        if scene.study:
            extra['study'] = dict(scene.study)
        from cam_metrology.metrology.tolerances import judge_part
        tables = {f: r.table for f, r in self.results.items() if r.kind == 'lobe'}
        verdict = judge_part(scene, features, tables, self._design)
        release(tables.values())   # the spilled tables read by the verdict
        tracked = {f.get('track_of') for f in features.values()} - {None}
        if tracked:
            from cam_metrology.metrology.tolerances import judge_tracks
            from cam_metrology.metrology.tracks import taper_and_twist
            extra['lobe_tracks'] = {
                lobe: taper_and_twist({fid: f for fid, f in features.items()
                                       if f.get('track_of') == lobe}) or
                {'why': 'fewer than 2 tracks measured'} for lobe in sorted(tracked)}
            for lobe, entry in extra['lobe_tracks'].items():   # its checks, for the views
                tol = next((x.tolerances for x in scene.lobes if x.id == lobe), None)
                entry['verdict'] = judge_tracks(tol, lobe, features)
        if scene.journals or any(lobe.axial_position is not None for lobe in scene.lobes):
            from cam_metrology.metrology.journals import feature_positions, shaft_straightness
            extra['shaft'] = shaft_straightness(features, *feature_positions(scene, features))
        return json_safe({
            'camshaft_id': scene.camshaft_id,
            'verdict': verdict,
            'direction': scene.direction,
            'features': features,
            'skipped': self.skipped(),
            'complete': not self._missing(),
            'final': final,
            'dowel_pin_angle_deg': None if pin is None or self._datum_id() != PIN_ID
            else float(np.degrees(pin)),
            'datum': {'feature': scene.datum_id,
                      'angle_deg': None if pin is None else float(np.degrees(pin))},
            'units': {'angles': 'deg (encoder frame, [0, 360))', 'lift_error': 'um'},
            **extra,
        })
