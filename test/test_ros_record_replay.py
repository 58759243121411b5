"""`cam-bench record` and `cam-bench replay` as subprocesses, against live rclpy.

* record: a latched scene published *before* the recorder starts is still recorded
  (transient local); 600 JointState samples and an extra typed topic are recorded
  byte-exact; SIGINT or SIGTERM leaves a closed bag (metadata.yaml) that rosbags and
  mcap read.
* replay: a fixture bag (written here with bagio) republished at rate 4 reaches a
  subscriber complete, in order per topic, scene first, and no faster than the scaled
  timing.
Every wait has a deadline; the domain is the session's isolated one (conftest).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytestmark = pytest.mark.ros

CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'


def cam_bench(*args: str) -> subprocess.Popen[str]:
    """``cam-bench ARGS`` in a subprocess with this session's ROS environment."""
    return subprocess.Popen([sys.executable, '-c', CLI, *args], env=dict(os.environ),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def joint_state(k: int) -> Any:
    from sensor_msgs.msg import JointState
    msg = JointState(name=['camshaft', 'probe'], position=[0.01 * k, 1e-6 * k * k])
    msg.header.frame_id = 'lobe_1' if k < 300 else 'dowel_pin'
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1000 + k // 1000, (k % 1000) * 1_000_000
    return msg


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_record_stop_signal_leaves_complete_bag(ros_domain: int, tmp_path: Path,
                                                stop: signal.Signals) -> None:
    from rclpy.duration import Duration
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from cam_metrology import bagio
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.wire.topics import TOPICS

    out = tmp_path / 'rec'
    proc = RosProcess(handle_signals=False)
    rec = None
    try:
        node = proc.add(Node('record_test', context=proc.context))
        scene = node.create_publisher(String, '/bench/scene', profile(TOPICS['/bench/scene'][1]))
        samples = node.create_publisher(JointState, '/bench/joint_states',
                                        profile(TOPICS['/bench/joint_states'][1]))
        extra = node.create_publisher(String, '/extra/notes', 10)
        scene.publish(String(data='camshaft_id: rec-test\n'))   # before the recorder exists
        rec = cam_bench('record', str(out), '--topics', '/extra/notes:std_msgs/msg/String')
        assert proc.spin_until(lambda: samples.get_subscription_count() >= 1
                               and extra.get_subscription_count() >= 1
                               and scene.get_subscription_count() >= 1
                               or rec.poll() is not None, 30.0), 'recorder never matched'
        assert rec.poll() is None, rec.communicate()[0]
        for k in range(600):   # fewer than the keep-last depth of 1000: none overwritten
            samples.publish(joint_state(k))
        extra.publish(String(data='note'))
        # acknowledged = in the recorder's reader history (Fast DDS acks on its 3 s
        # heartbeat, so this takes up to 3 s); the recorder drains it on SIGINT
        for pub in (scene, samples, extra):
            assert pub.wait_for_all_acked(Duration(seconds=10))
        rec.send_signal(stop)
        text, _ = rec.communicate(timeout=30)
        assert rec.returncode == 0, text
    finally:
        if rec is not None and rec.poll() is None:
            rec.kill()
        proc.close()
    assert (out / 'metadata.yaml').is_file()
    topics = bagio.bag_topics(out)
    assert topics['/bench/scene'] == ('std_msgs/msg/String', 1)
    assert topics['/bench/joint_states'] == ('sensor_msgs/msg/JointState', 600)
    assert topics['/extra/notes'] == ('std_msgs/msg/String', 1)
    got = bagio.read_joint_states(out)
    k = np.arange(600)
    assert np.array_equal(got.theta, 0.01 * k) and np.array_equal(got.s, 1e-6 * k * k)
    assert list(got.features) == ['lobe_1', 'dowel_pin']
    assert np.array_equal(got.stamp_ns, (1000 + k // 1000) * 10**9 + (k % 1000) * 10**6)
    assert np.all(np.diff(got.log_ns) >= 0)
    # the mcap library reads it without this package
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    mcap_file = next(out.glob('*.mcap'))
    with open(mcap_file, 'rb') as f:
        decoded = [(c.topic, m) for _, c, _, m in make_reader(
            f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()]
    assert [m.data for t, m in decoded if t == '/bench/scene'] == ['camshaft_id: rec-test\n']
    assert sum(t == '/bench/joint_states' for t, _ in decoded) == 600


def test_record_stops_promptly_while_samples_keep_coming(
        ros_domain: int, tmp_path: Path) -> None:
    """Ctrl-C while a publisher keeps sending: the recorder stops within its drain limit
    (1 s, plus start-up slack) and the bag it leaves is complete and readable."""
    import time

    from rclpy.node import Node
    from sensor_msgs.msg import JointState

    from cam_metrology import bagio
    from cam_metrology.nodes.recorder import STOP_DRAIN_S
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.wire.topics import TOPICS

    out = tmp_path / 'rec'
    proc = RosProcess(handle_signals=False)
    rec = None
    try:
        node = proc.add(Node('record_flood', context=proc.context))
        samples = node.create_publisher(JointState, '/bench/joint_states',
                                        profile(TOPICS['/bench/joint_states'][1]))
        rec = cam_bench('record', str(out))
        assert proc.spin_until(lambda: samples.get_subscription_count() >= 1
                               or rec.poll() is not None, 30.0), 'recorder never matched'
        k = 0
        signalled = stopped = None
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and stopped is None:   # never stop sending
            for _ in range(50):
                samples.publish(joint_state(k))
                k += 1
            if signalled is None and k >= 3000:
                rec.send_signal(signal.SIGINT)
                signalled = time.monotonic()
            if rec.poll() is not None:
                stopped = time.monotonic()
        assert stopped is not None and signalled is not None, 'recorder did not stop'
        text, _ = rec.communicate(timeout=10)
        # a flood may overrun the queue: then it says so and exits 1, never silently 0
        assert rec.returncode == 0 or (rec.returncode == 1 and 'lost' in text), text
        assert stopped - signalled < STOP_DRAIN_S + 4.0, (stopped - signalled, text)
    finally:
        if rec is not None and rec.poll() is None:
            rec.kill()
        proc.close()
    got = bagio.read_joint_states(out)   # closed bag, metadata agrees with the file
    n = bagio.bag_topics(out)['/bench/joint_states'][1]
    assert 0 < n == got.theta.size <= k
    idx = np.rint(got.theta / 0.01)   # samples as sent, in order (a flood may drop some)
    assert np.allclose(got.theta, 0.01 * idx, rtol=0, atol=1e-12)
    assert np.all(np.diff(idx) > 0) and idx[-1] < k


def write_fixture_bag(path: Path, n: int = 400, period_ns: int = 1_000_000) -> int:
    """Scene + n JointState samples 1 ms apart + feature_done; returns the span [ns]."""
    from cam_metrology import bagio
    t0 = 1_700_000_000_000_000_000
    with bagio.BagWriter(path) as w:
        for topic, (msgtype, qos) in (('/bench/scene', ('std_msgs/msg/String', True)),
                                      ('/bench/joint_states', ('sensor_msgs/msg/JointState',
                                                               False)),
                                      ('/bench/feature_done', ('std_msgs/msg/String', False))):
            w.add_topic(topic, msgtype, bagio.default_qos_yaml(topic))
        w.write('/bench/scene', t0, bagio.encode_string('camshaft_id: replay-test\n'))
        for k in range(n):
            w.write('/bench/joint_states', t0 + (k + 1) * period_ns,
                    bagio.encode_joint_state('lobe_1', t0 + k, 0.001 * k, 2e-6 * k))
        w.write('/bench/feature_done', t0 + (n + 1) * period_ns, bagio.encode_string('lobe_1'))
    return (n + 1) * period_ns


def test_replay_delivers_everything_in_order_with_scaled_timing(ros_domain: int,
                                                                tmp_path: Path) -> None:
    from rclpy.node import Node
    from rclpy.qos import HistoryPolicy, QoSProfile
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.wire.topics import TOPICS

    bag = tmp_path / 'fixture'
    span_ns = write_fixture_bag(bag)
    rate = 4.0
    events: list[tuple[str, float, Any]] = []
    proc = RosProcess(handle_signals=False)
    player = None
    try:
        node = proc.add(Node('replay_test', context=proc.context))
        keep_all = QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL)
        node.create_subscription(String, '/bench/scene',
                                 lambda m: events.append(('scene', time.monotonic(), m.data)),
                                 profile(TOPICS['/bench/scene'][1]))
        node.create_subscription(JointState, '/bench/joint_states',
                                 lambda m: events.append(('js', time.monotonic(), m)), keep_all)
        node.create_subscription(String, '/bench/feature_done',
                                 lambda m: events.append(('done', time.monotonic(), m.data)),
                                 keep_all)
        player = cam_bench('replay', str(bag), '--rate', str(rate), '--match-timeout', '30',
                           '--expect', 'replay_test')
        assert proc.spin_until(lambda: len(events) == 402 or player.poll() is not None, 60.0)
        proc.spin_until(lambda: player.poll() is not None, 30.0)
        text, _ = player.communicate(timeout=30)
        assert player.returncode == 0, text
        proc.drain(lambda: len(events))
    finally:
        if player is not None and player.poll() is None:
            player.kill()
        proc.close()
    # order holds per topic (ROS does not order across topics); the scene came first
    kinds = [e[0] for e in events]
    assert kinds[0] == 'scene' and events[0][2] == 'camshaft_id: replay-test\n'
    assert kinds.count('js') == 400 and kinds.count('done') == 1 and len(kinds) == 402
    samples = [e for e in events if e[0] == 'js']
    theta = np.array([e[2].position[0] for e in samples])
    assert np.array_equal(theta, 0.001 * np.arange(400))
    assert [e[2].header.stamp.nanosec for e in samples[:3]] == [0, 1, 2]
    # the player sleeps until each message is due: a lower bound on the elapsed time
    elapsed = samples[-1][1] - samples[0][1]
    assert elapsed >= 0.9 * (span_ns - 2_000_000) * 1e-9 / rate


def test_replay_waits_for_every_expected_subscriber(ros_domain: int, tmp_path: Path) -> None:
    """Default-style wait: the player announces whom it waits for and sends no sample
    before a late subscriber (created only after that line) is there; that subscriber
    then gets every sample. A subscriber that never comes: exit 4, named, nothing
    streamed."""
    from rclpy.node import Node
    from rclpy.qos import HistoryPolicy, QoSProfile
    from sensor_msgs.msg import JointState

    from cam_metrology.nodes.runtime import RosProcess

    bag = tmp_path / 'fixture'
    write_fixture_bag(bag, n=300)
    got: list[Any] = []
    proc = RosProcess(handle_signals=False)
    player = ghost = None
    try:
        early = proc.add(Node('early_sub', context=proc.context))
        early.create_subscription(JointState, '/bench/joint_states', got.append,
                                  QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL))
        player = cam_bench('replay', str(bag), '--rate', '0', '--match-timeout', '60',
                           '--expect', 'early_sub', 'late_sub')
        assert player.stdout is not None
        line = player.stdout.readline()   # 'replaying ...', then the wait (or EOF)
        if line.startswith('replaying'):
            line = player.stdout.readline()
        assert line.startswith('waiting for early_sub on /bench/joint_states, late_sub on '
                               '/bench/joint_states'), line
        assert proc.spin_until(lambda: early.count_subscribers('/bench/joint_states') >= 1
                               and early.count_publishers('/bench/joint_states') == 1, 30.0)
        # a sample must not come while late_sub is missing (1 s deadline for a bug)
        assert not proc.spin_until(lambda: bool(got) or player.poll() is not None, 1.0)
        late = proc.add(Node('late_sub', context=proc.context))
        late_got: list[Any] = []
        late.create_subscription(JointState, '/bench/joint_states', late_got.append,
                                 QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL))
        assert proc.spin_until(lambda: len(got) == len(late_got) == 300, 60.0), \
            (len(got), len(late_got))
        text, _ = player.communicate(timeout=30)
        assert player.returncode == 0, text
        ghost = cam_bench('replay', str(bag), '--rate', '0', '--match-timeout', '2',
                          '--expect', 'ghost', '--wait-subscribers', '0')
        text, _ = ghost.communicate(timeout=60)
        # a sample sent by mistake would arrive within this deadline
        proc.spin_until(lambda: len(late_got) > 300, 1.0)
    finally:
        for p in (player, ghost):
            if p is not None and p.poll() is None:
                p.kill()
        proc.close()
    assert ghost.returncode == 4, text
    assert ('cam-bench replay: expected subscribers missing after 2 s: ghost on '
            '/bench/joint_states; nothing replayed') in text
    assert len(late_got) == 300   # the refused replay sent no sample
