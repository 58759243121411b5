"""The rig node's core (pure Python, no rclpy): rig runs live, in ``rig analyze``'s code.

Subscribes ``/bench/scene`` (the scene with its ``rig`` block), ``/rig/joint_states``
(joints ``camshaft``, ``valve``, further channels; ``frame_id`` = run) and the same
samples in blocks on ``/rig/joint_trajectory`` (JointTrajectory, decoded by the node
adapter with ``bagio.decode_joint_blocks`` and handed to ``handle_samples``; lost blocks
are counted per block and sample by the adapter, and a run that lost any is marked
partial). A run ends when
the next ``frame_id`` starts, when the stream is quiet for the scene's ``idle_timeout``,
or at the end; it is then analysed exactly as ``cam-bench rig analyze`` does
(``session.analyze``) and published (if samples of a run ended by the idle timeout
arrive later, the run continues and its status is published again: the last one
counts):

* ``/rig/result``: one DiagnosticStatus per run (name = run): speed, revolutions,
  measured separation and its angle, seating velocity, bounces, residual rms against
  the nominal train's prediction at the measured speed (WARN when the valve separates;
  ERROR with the one-line reason when the run cannot be analysed);
* ``/rig/valve_motion``: per run the table ``alpha_rad,measured_lift_m,scatter_m,
  predicted_lift_m`` (cycle-averaged, on the lobe angle), plotted on /plot/rig_motion.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from cam_design.errors import InputError
from cam_metrology.cores.contract import merged_parameters
from cam_metrology.cores.outputs import ERROR, OK, WARN, Output, Status, StatusOutput, TableOutput
from cam_metrology.wire.topics import (CAMSHAFT_JOINT, RIG_JOINT_STATES, RIG_JOINT_TRAJECTORY,
                                       RIG_MOTION, RIG_RESULT, SCENE, VALVE_JOINT)

MOTION_COLUMNS = ('alpha_rad', 'measured_lift_m', 'scatter_m', 'predicted_lift_m')


class RigCore:
    """Rig runs of a live stream (or a replayed bag)."""

    name = 'rig'
    subscriptions = {SCENE: 'std_msgs/msg/String',
                     RIG_JOINT_STATES: 'sensor_msgs/msg/JointState',
                     RIG_JOINT_TRAJECTORY: 'trajectory_msgs/msg/JointTrajectory'}
    #: (angle, lift) joints the adapter decodes from the blocks
    joints = (CAMSHAFT_JOINT, VALVE_JOINT)
    #: the adapter also decodes the blocks' valve velocity and further joints
    block_extras = True
    publications = {RIG_RESULT: 'diagnostic_msgs/msg/DiagnosticArray',
                    RIG_MOTION: 'std_msgs/msg/Float64MultiArray'}
    PARAMETERS: dict[str, tuple[Any, str]] = {
        'jump_speed': (False, 'also sweep the nominal jump speed per run (slower)'),
    }

    def __init__(self, params: dict[str, Any] | None = None) -> None:
        p = merged_parameters('rig', self.PARAMETERS, params)
        self.jump = bool(p['jump_speed'])
        self.scene: Any = None
        self.frame: str | None = None
        self.rows: list[Any] = []        # JointState messages of the current run
        self.blocks: list[Any] = []      # JointSamples of its blocks
        self.last_ns = 0
        self.results: dict[str, dict[str, Any]] = {}
        self.flushed: tuple[list[Any], list[Any]] = ([], [])   # the last run ended

    def handle(self, topic: str, msg: Any, stamp_ns: int) -> list[Output]:
        """Scene: keep it; sample: buffer it (a new frame_id ends the previous run)."""
        if topic == SCENE:
            from cam_metrology.scene.parse import parse_scene
            out = self._flush(stamp_ns)
            try:
                self.scene = parse_scene(str(msg.data), SCENE)
            except InputError as exc:
                self.scene = None
                out.append(self._status(Status('rig/scene', ERROR, f'invalid scene: {exc}'),
                                        stamp_ns))
            return out
        if topic != RIG_JOINT_STATES:
            return []
        out = self._start(str(msg.header.frame_id) or 'run', stamp_ns)
        self.rows.append(msg)
        self.last_ns = stamp_ns
        return out

    def handle_samples(self, frame_id: Any, stamp_ns: Any, theta: Any, s: Any,
                       rx_ns: int = 0, velocity: Any = None,
                       others: dict[str, Any] | None = None) -> list[Output]:
        """Samples decoded from blocks (``frame_id`` = run, stamps [ns], camshaft
        angle [rad], valve lift [m], valve ``velocity`` [m/s] or None, ``others``: the
        further joints by name): buffered like single samples."""
        from cam_metrology.bagio.joints import JointSamples

        frames = np.asarray(frame_id)
        out: list[Output] = []
        n = int(frames.size)
        if n == 0:
            return out
        cut = np.flatnonzero(frames[1:] != frames[:-1]) + 1
        for a, b in zip(np.concatenate(([0], cut)).tolist(),
                        np.concatenate((cut, [n])).tolist()):
            out += self._start(str(frames[a]) or 'run', rx_ns)
            self.blocks.append(JointSamples(
                np.asarray(frames[a:b]), np.asarray(stamp_ns[a:b]), np.asarray(stamp_ns[a:b]),
                np.asarray(theta[a:b]), np.asarray(s[a:b]),
                lift_velocity=None if velocity is None else np.asarray(velocity[a:b]),
                others={k: np.asarray(v[a:b]) for k, v in (others or {}).items()}))
        self.last_ns = rx_ns
        return out

    def _start(self, frame: str, stamp_ns: int) -> list[Output]:
        """Samples of run ``frame`` arrive: a new frame ends the buffered run."""
        out = self._flush(stamp_ns) if frame != self.frame and self._buffered() else []
        if frame == self.frame and not self._buffered() and any(self.flushed):
            # the stream resumed the run that an idle timeout had ended (a stall of the
            # sender or of this node): continue it; its status is published again
            self.rows, self.blocks = self.flushed
        self.frame = frame
        return out

    def _buffered(self) -> bool:
        return bool(self.rows or self.blocks)

    def tick(self, now_ns: int) -> list[Output]:
        """A run ends when the stream is quiet for the scene's idle_timeout."""
        idle = getattr(self.scene, 'idle_timeout', 1.0)
        if self._buffered() and now_ns - self.last_ns > idle * 1e9:
            return self._flush(now_ns)
        return []

    def finish(self) -> list[Output]:
        """End of the stream: the last run."""
        return self._flush(self.last_ns)

    def _flush(self, stamp_ns: int) -> list[Output]:
        if not self._buffered():
            return []
        rows, blocks, self.rows, self.blocks = self.rows, self.blocks, [], []
        self.flushed = (rows, blocks)
        name = self.frame or 'run'
        if self.scene is None:
            return [self._status(Status(name, ERROR, 'no scene on /bench/scene before the '
                                                     'run: cannot analyse it'), stamp_ns)]
        try:
            from cam_metrology.rig.runs import joined_extras, runs_of_messages, runs_of_samples
            from cam_metrology.rig.session import analyze

            runs = runs_of_messages(rows, RIG_JOINT_STATES) if rows else []
            if blocks:
                vel, others = joined_extras(blocks)
                stamps = np.concatenate([js.stamp_ns for js in blocks])
                runs += runs_of_samples(np.full(stamps.size, name), stamps,
                                        np.concatenate([js.theta for js in blocks]),
                                        np.concatenate([js.s for js in blocks]),
                                        RIG_JOINT_TRAJECTORY, vel, others)
            outcome = analyze(self.scene, runs, jump=self.jump)
        except InputError as exc:
            return [self._status(Status(name, ERROR, str(exc)), stamp_ns)]
        out: list[Output] = []
        statuses = []
        for r, c in zip(outcome.result['runs'], outcome.curves):
            self.results[r['name']] = r
            level = WARN if r['separated'] else OK
            msg = (f"separated at {r['separation_angle_deg']:.1f} deg" if r['separated']
                   else 'ok')
            values = {k: _text(r[k]) for k in (
                'rpm', 'speed_variation', 'revolutions', 'separated', 'separation_angle_deg',
                'seating_velocity_m_s', 'bounce_count', 'bounce_height_m', 'max_lift_m',
                'opening_deg', 'closing_deg', 'laser_noise_m')}
            values['residual_rms_m'] = _text(r['residual_rms_m']['nominal'])
            values['nose_angle_deg'] = _text(outcome.result['nose_angle_deg'])
            statuses.append(Status(r['name'], level, msg, values))
            nom = c['nominal']
            table = np.column_stack([np.radians(nom['alpha_deg']), nom['measured_m'],
                                     np.nan_to_num(nom['scatter_m']), nom['predicted_m']])
            table = table[np.all(np.isfinite(table), axis=1)]
            out.append(TableOutput(RIG_MOTION, r['name'], MOTION_COLUMNS, table))
        out.append(StatusOutput(RIG_RESULT, tuple(statuses), stamp_ns))
        return out

    @staticmethod
    def _status(status: Status, stamp_ns: int) -> StatusOutput:
        return StatusOutput(RIG_RESULT, (status,), stamp_ns)


def _text(v: Any) -> str:
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else 'nan'
    return str(v)


__all__ = ['RigCore', 'MOTION_COLUMNS']
