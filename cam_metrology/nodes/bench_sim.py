"""The bench simulator node: a camshaft measurement played live on ROS 2.

From a scene file it runs ``simulate.simulate(scene, SimParams(...))`` and publishes:
1. ``/bench/scene`` (the scene YAML) and ``/bench/truth`` (JSON of the run's truth),
   both transient local depth 1;
2. waits (deadline ``match_timeout``) until ``wait_subscribers`` subscriptions have
   matched on /bench/joint_states, /bench/scene and /bench/feature_done and the graph
   shows the ``wait_graph`` subscriptions on other topics, then until the scene is
   acknowledged (Fast DDS acknowledges on its heartbeat: up to 3 s);
3. ``/bench/joint_states``, one sample per message (name = camshaft, probe; position =
   theta [rad], s [m]; header.stamp = the simulated acquisition time; header.frame_id
   = feature id), paced by a loop on the simulated stamps (``rate`` samples/s of
   SimParams, with its ``feature_gap`` between features): each sample goes out when
   its stamp is due on the wall clock; when the OS sleeps late the loop catches up in
   bursts of at most ``max_burst`` back to back, up to ``max_lag`` s behind (further
   behind, e.g. held back by subscribers, its schedule restarts from now);
   ``/bench/feature_done`` (feature id) after the last sample of each feature;
4. waits until every subscriber acknowledged everything, then exits (or idles until
   SIGINT if ``exit_when_done`` is false, keeping the latched scene available).

With ``samples_per_message`` N > 1 the samples go out in blocks of N (at most; a block
never holds two features) on ``/bench/joint_trajectory`` (trajectory_msgs/
JointTrajectory: header.stamp = the first sample's time, frame_id = feature,
joint_names = (angle_joint, lift_joint), one point per sample with time_from_start =
its offset), each block when its last sample is due. The joint names are the
parameters ``angle_joint`` and ``lift_joint``.

Rig mode (``mode: rig``): valve-train rig runs instead of a camshaft measurement. The
scene (default ``config/rig_scene.yaml``) needs a ``rig`` block; its
``rig.true_valve_train`` moves the valve (``rig.simulate``: the dynamics' periodic motion
at each run's mean speed, a speed ripple, a quantised encoder, laser noise with an
arbitrary zero; parameters ``rig_*``). One run per speed of ``rig_rpm``, ``frame_id`` =
run name, joints ``camshaft`` and ``valve``: on ``/rig/joint_states`` one sample per
message, or in blocks of ``samples_per_message`` on ``/rig/joint_trajectory``; paced on
their stamps like the bench's samples; no /bench/feature_done (a rig run ends at the
next frame_id or when the stream goes quiet); /bench/truth holds the rig's truth.

ROS parameters: every field of ``simulate.SimParams``, the rig mode's
``rig.simulate.RIG_SIM_PARAMETERS``, plus those of ``PARAMETERS``.
"""
from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Any, Iterator, Sequence

import numpy as np
from rclpy.duration import Duration
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory

from cam_metrology.nodes.adapter import declare_parameters
from cam_metrology.nodes.runtime import publish_retrying, wait_all_acked
from cam_metrology.nodes.topics import keep_all_profile, profile
from cam_metrology.wire.topics import (CAMSHAFT_JOINT, FEATURE_DONE, JOINT_STATES,
                                       JOINT_TRAJECTORY, PROBE_JOINT, RIG_JOINT_STATES,
                                       RIG_JOINT_TRAJECTORY, SCENE, TOPICS, TRUTH,
                                       VALVE_JOINT)

SAMPLES_WRITER = keep_all_profile()

PARAMETERS: dict[str, tuple[Any, str]] = {
    'mode': ('bench', 'bench: a camshaft measurement on /bench/*; rig: valve-train rig runs '
                      'of the scene\'s rig block on /rig/joint_states (/rig/joint_trajectory '
                      'in blocks)'),
    'scene_file': ('', 'scene YAML to simulate; empty: the embedded default scene (rig mode: '
                       'config/rig_scene.yaml)'),
    'wait_subscribers': (1, 'subscriptions that must match /bench/joint_states, '
                            '/bench/scene and /bench/feature_done before the first sample'),
    'wait_graph': ('', 'also wait until the graph shows this many subscriptions on other '
                       'topics, e.g. "/metrology/lift=2,/metrology/result=2" (downstream '
                       'nodes that must be up before results flow)'),
    'match_timeout': (10.0, 's to wait for those subscriptions (then exit 4)'),
    'ack_timeout': (10.0, 's to wait at the end until subscribers acknowledged everything'),
    'max_burst': (200, 'most messages (samples, or blocks) published back to back when '
                       'catching up'),
    'max_lag': (1.0, 's of lateness the stream catches up (in bursts of max_burst); '
                     'further behind (subscribers holding it back) its schedule restarts '
                     'from now and the achieved rate is logged'),
    'angle_joint': (CAMSHAFT_JOINT, 'joint name of the encoder angle [rad] in the samples'),
    'lift_joint': (PROBE_JOINT, 'joint name of the probe lift [m] in the samples'),
    'exit_when_done': (True, 'exit after the last feature; false: idle until SIGINT'),
}


def sim_param_table() -> dict[str, tuple[Any, str]]:
    """{name: (default, description)} of the fields of ``simulate.SimParams``."""
    from cam_metrology.simulation.bench import SimParams

    table: dict[str, tuple[Any, str]] = {}
    for f in dataclasses.fields(SimParams):
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
            default = f.default_factory()  # type: ignore[misc]
        else:
            continue
        if isinstance(default, np.generic):
            default = default.item()
        if default is None:
            continue   # 'not set' fields keep the dataclass default (ROS has no None)
        table[f.name] = (default, str(f.metadata.get('doc', f.metadata.get('help', ''))))
    return table


def make_sim_params(values: dict[str, Any]) -> Any:
    """SimParams from ROS parameter values (lists back to tuples where needed)."""
    from cam_metrology.simulation.bench import SimParams

    kwargs = {}
    for f in dataclasses.fields(SimParams):
        if f.name in values:
            value = values[f.name]
            if isinstance(value, list):
                value = tuple(value)
            kwargs[f.name] = value
    return SimParams(**kwargs)


def _field(obj: Any, name: str) -> Any:
    return obj[name] if isinstance(obj, dict) else getattr(obj, name)


def iter_samples(run: Any) -> Iterator[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    """(feature id, theta [rad], s [m], stamp_ns) arrays of each feature of a BenchRun."""
    for feat in _field(run, 'features'):
        yield (str(_field(feat, 'id')), np.asarray(_field(feat, 'theta'), dtype=float),
               np.asarray(_field(feat, 's'), dtype=float),
               np.asarray(_field(feat, 'stamp_ns'), dtype=np.int64))


def parse_graph_counts(text: str) -> dict[str, int]:
    """``'/a=2, /b=1'`` -> {'/a': 2, '/b': 1} (InputError on a malformed item)."""
    from cam_design.errors import InputError
    out: dict[str, int] = {}
    for item in text.replace(' ', '').split(','):
        if not item:
            continue
        topic, sep, count = item.partition('=')
        if not sep or not topic.startswith('/') or not count.isdigit():
            raise InputError('bench_sim.wait_graph', item, '/topic=COUNT')
        out[topic] = int(count)
    return out


def truth_json(run: Any) -> str:
    """The run's truth dict as JSON (numpy scalars and arrays converted)."""
    def default(obj: Any) -> Any:
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        if isinstance(obj, np.generic):
            return obj.item()
        if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
            return dataclasses.asdict(obj)
        return str(obj)
    return json.dumps(_field(run, 'truth'), default=default, sort_keys=True)


class BenchSimNode(Node):
    """Publishes a simulated measurement; ``run()`` does the paced publishing."""

    def __init__(self, *, context: Any = None, node_name: str = 'bench_sim',
                 overrides: dict[str, Any] | None = None) -> None:
        super().__init__(node_name, context=context)
        from cam_metrology.rig.simulate import RIG_SIM_PARAMETERS

        table = dict(PARAMETERS)
        table.update(sim_param_table())
        table.update(RIG_SIM_PARAMETERS)
        for name, value in (overrides or {}).items():
            table[name] = (value, table.get(name, (None, ''))[1])
        self.params = declare_parameters(self, table)
        self.rig = _mode(self.params['mode']) == 'rig'
        from cam_metrology.host.paths import config_dir, default_scene_path
        from cam_metrology.scene.parse import load_scene

        scene_path = Path(self.params['scene_file'] or (
            config_dir() / 'rig_scene.yaml' if self.rig else default_scene_path()))
        self.scene = load_scene(scene_path)
        self.scene_text = self.scene.text or scene_path.read_text(encoding='utf-8')
        if self.rig:
            from cam_metrology.rig.simulate import rig_sim_runs, stream_runs

            runs, _, truth = rig_sim_runs(self.scene, self.params)
            self.run_data: Any = {'truth': truth, 'features': []}
            self.features = stream_runs(runs)
            self.rate = float(self.params['rig_sample_rate'])
        else:
            from cam_metrology.simulation.bench import simulate

            self.run_data = simulate(self.scene, make_sim_params(self.params))
            self.features = list(iter_samples(self.run_data))
            self.rate = float(self.params.get('rate', 1000.0))
        # samples: reliable KEEP_ALL (lossless back-pressure: a subscriber that cannot
        # keep up slows the stream down instead of losing samples; the achieved rate is
        # logged). A deep keep-last writer history was measured to cost 100-300 us per
        # publish once full (Fast DDS drops its oldest sample from the front of a
        # vector); keep-all holds only the unacknowledged samples (heartbeat 0.1 s).
        self.per_message = int(self.params['samples_per_message'])
        if self.per_message < 1:
            from cam_design.errors import InputError
            raise InputError('bench_sim.samples_per_message', self.per_message,
                             'an integer >= 1')
        single, blocks = ((RIG_JOINT_STATES, RIG_JOINT_TRAJECTORY) if self.rig
                          else (JOINT_STATES, JOINT_TRAJECTORY))
        self.samples_topic = single if self.per_message == 1 else blocks
        self.joint_names = ((CAMSHAFT_JOINT, VALVE_JOINT) if self.rig else
                            (str(self.params['angle_joint']), str(self.params['lift_joint'])))
        sample_cls = JointState if self.per_message == 1 else JointTrajectory
        #: the topics whose subscriptions are awaited before the first sample
        self.awaited = (self.samples_topic, SCENE) + (() if self.rig else (FEATURE_DONE,))
        self.pub = {topic: self.create_publisher(
            cls, topic,
            (SAMPLES_WRITER if topic == self.samples_topic else profile(TOPICS[topic][1])))
            for topic, cls in ((SCENE, String), (TRUTH, String),
                               (self.samples_topic, sample_cls), (FEATURE_DONE, String))
            if topic != FEATURE_DONE or not self.rig}
        self.sent = 0
        self.publish_errors = 0
        self.stamp_offset_ns = 0

    @property
    def total_samples(self) -> int:
        """Samples of all features."""
        return sum(int(f[1].size) for f in self.features)

    def publish_latched(self) -> None:
        """Scene YAML then truth JSON (transient local: late joiners get them)."""
        self.pub[SCENE].publish(String(data=self.scene_text))
        self.pub[TRUTH].publish(String(data=truth_json(self.run_data)))

    def matched(self) -> tuple[int, ...]:
        """Matched subscriptions on the samples topic (/bench/joint_states or
        /bench/joint_trajectory; the rig's in rig mode), /bench/scene and (not in rig
        mode) /bench/feature_done."""
        return tuple(self.pub[t].get_subscription_count() for t in self.awaited)

    def messages(self, fid: str, theta: Any, s: Any, stamp: Any,
                 ) -> tuple[list[bytes], Any, Any]:
        """One feature's sample messages: (CDR per message, the stamp [ns] each is due
        (its last sample), samples per message), stamps on the system clock."""
        from cam_metrology.wire.cdr import (encode_joint_states, encode_named_values,
                                            encode_sample_blocks)
        st = stamp + self.stamp_offset_ns
        if self.per_message == 1:
            if self.joint_names == (CAMSHAFT_JOINT, PROBE_JOINT):
                frames = encode_joint_states(fid, st, theta, s)
            else:
                frames = encode_named_values(fid, st, self.joint_names,
                                             np.column_stack((theta, s)))
            return frames, stamp, np.ones(stamp.size, dtype=np.int64)
        blocks = encode_sample_blocks(fid, st, theta, s, self.per_message, self.joint_names)
        due = np.array([b[0] for b in blocks], dtype=np.int64) - self.stamp_offset_ns
        sizes = np.diff(np.append(np.arange(0, stamp.size, self.per_message), stamp.size))
        return [b[1] for b in blocks], due, sizes

    def wait_for_subscribers(self, need: int, timeout: float) -> bool:
        """Wait (deadline) for ``need`` matches on samples and scene, and for the scene to
        be acknowledged by them, so every node knows the scene before the first sample."""
        deadline = time.monotonic() + timeout
        graph = parse_graph_counts(str(self.params.get('wait_graph', '')))
        while min(self.matched()) < need or any(
                self.count_subscribers(t) < n for t, n in graph.items()):
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.01)
        left = max(0.1, deadline - time.monotonic())
        return bool(self.pub[SCENE].wait_for_all_acked(Duration(seconds=left)))

    def _publish(self, topic: str, msg: Any) -> None:
        """Publish, retrying on RCLError (a blocked reliable writer) for up to 5 s."""
        self.publish_errors += publish_retrying(self.pub[topic], msg, 5.0)

    def run(self, max_burst: int = 200, should_stop: Any = None, max_lag: float = 1.0,
            block_timeout: float = 30.0) -> int:
        """Publish every sample when its stamp is due; returns the samples sent.

        Time base: the samples are re-stamped on the system clock (the clock of every
        other stamp in the graph: ROS time, DDS source timestamps, bag log times):
        ``stamp = wall clock at the start of the stream + (simulated stamp - first
        simulated stamp)``, so each sample is stamped with the time it is due and
        published within the loop's lateness of it. ``self.stamp_offset_ns`` is the
        shift applied to ``simulate()``'s stamps.

        Pacing: every pass publishes all messages already due (at most ``max_burst``
        back to back; a block is due when its last sample is), then sleeps until the
        next one is due (at least 0.5 ms, so a 20 000/s stream costs ~2000 sleeps per
        second, not 20 000). A reliable
        keep-all writer that is full (a subscriber not keeping up) raises RCLError:
        retried until ``block_timeout`` s, counted in ``publish_errors``.
        """
        from rclpy._rclpy_pybind11 import RCLError

        if not self.features:
            return 0
        stamp0 = int(self.features[0][3][0]) if self.features[0][3].size else 0
        self.stamp_offset_ns = time.time_ns() - stamp0
        t0 = time.monotonic()
        rate = self.rate
        # lateness caught up: at least max_lag s, so that a process descheduled for a
        # few ms on a loaded machine does not lose its schedule (it did: with the window
        # at max_burst samples, 10 ms at 20 000/s, a load of 12 held 20 000/s asked to
        # 1 700/s with every process below 16 % CPU)
        burst_s = max(float(max_lag), max(1, max_burst) * self.per_message / rate)
        burst = max(1, int(max_burst))
        pub = self.pub[self.samples_topic]
        handle = pub.handle
        k = 0
        for fid, theta, s, stamp in self.features:
            # pre-serialised CDR (the same bytes rclpy would send): publishing bytes
            # skips per-sample message construction and the position setter's checks
            frames, due_ns, sizes = self.messages(fid, theta, s, stamp)
            due = (due_ns - stamp0) * 1e-9
            ends = np.cumsum(sizes)
            i, n = 0, len(frames)
            while i < n:
                now = time.monotonic() - t0
                if due[i] > now:
                    time.sleep(max(due[i] - now, 0.0005))
                    continue
                if now - due[i] > burst_s:   # late: never catch up more than burst_s
                    t0 += now - due[i] - burst_s
                    now = time.monotonic() - t0
                j = min(n, i + burst, int(np.searchsorted(due, now, side='right')))
                j = max(j, i + 1)
                with handle:
                    for frame in frames[i:j]:
                        try:
                            handle.publish_raw(frame)
                        except RCLError:
                            self.publish_errors += publish_retrying(
                                pub, frame, block_timeout) + 1
                k += int(ends[j - 1] - (ends[i - 1] if i else 0))
                i = j
                if should_stop is not None and should_stop():
                    self.sent = k
                    return k
            if not self.rig:
                self._publish(FEATURE_DONE, String(data=fid))
            self.get_logger().info(f'{"run" if self.rig else "feature"} {fid} done '
                                   f'({theta.size} samples)')
        self.sent = k
        return k

    def wait_acked(self, timeout: float) -> bool:
        """Wait (deadline) until all subscribers acknowledged everything published."""
        return wait_all_acked(self.pub.values(), timeout)


def _mode(value: Any) -> str:
    """The ``mode`` parameter checked: bench or rig (InputError otherwise)."""
    if value not in ('bench', 'rig'):
        from cam_design.errors import InputError
        raise InputError('bench_sim.mode', value, 'bench or rig')
    return str(value)


def run_bench_sim(args: Sequence[str] | None = None,
                  overrides: dict[str, Any] | None = None) -> int:
    """Run the simulator node. Exit 0 done, 4 if the subscribers never matched."""
    from cam_metrology.nodes.runtime import RosProcess

    proc = RosProcess(args)
    try:
        node = proc.add(BenchSimNode(context=proc.context, overrides=overrides))
        p = node.params
        rate = node.rate
        log = node.get_logger()
        log.info(f'{len(node.features)} features, {node.total_samples} samples at '
                 f'{rate:g}/s; waiting for {p["wait_subscribers"]} subscriber(s)')
        node.publish_latched()
        if not node.wait_for_subscribers(int(p['wait_subscribers']), float(p['match_timeout'])):
            graph = {t: node.count_subscribers(t)
                     for t in parse_graph_counts(str(p['wait_graph']))}
            log.error(f'graph subscriptions {graph} (wanted {p["wait_graph"]}); '
                      f'only {node.matched()} of {p["wait_subscribers"]} subscriptions matched '
                      f'({", ".join(node.awaited)}) within '
                      f'{p["match_timeout"]} s')
            return 4
        t0 = time.monotonic()
        sent = node.run(int(p['max_burst']), lambda: proc.stopping, float(p['max_lag']))
        dt = time.monotonic() - t0
        acked = node.wait_acked(float(p['ack_timeout']))
        achieved = sent / max(dt, 1e-9)
        log.info(f'sent {sent} samples in {dt:.2f} s ({achieved:.0f}/s); '
                 f'acknowledged: {acked}; publish retries: {node.publish_errors}; '
                 f'stamps = simulated + {node.stamp_offset_ns} ns (system clock)')
        if sent and achieved < 0.97 * rate:
            log.warning(f'could not keep {rate:g} samples/s: achieved {achieved:.0f}/s '
                        f'({node.publish_errors} publishes blocked by subscribers that '
                        'were not keeping up; no sample was dropped)')
        if not p['exit_when_done']:
            proc.spin_until()
        return 0 if sent == node.total_samples else 1
    finally:
        proc.close()
