"""Live blocks and the bench's own names, with processes started as a user starts them.

1. `cam-bench run metrology` + `cam-bench run recorder` (default parameter files) and
   `cam-bench run bench-sim` with ``samples_per_message: 1000`` at 100 000 samples/s
   (ten times the per-message ceiling of one Python subscriber, docs/ros.md): nothing
   lost, counted independently of the nodes (the samples behind the report, the
   samples in the bag) and as the nodes say it.
2. A joint_state_broadcaster-style stream (every joint in one JointState, other joint
   names, frame_id a link, on /joint_states) connected with
   ``config/ros2_control_bench.yaml`` and a ``--ros-args -r`` remap, no code: the
   lobe's nose angle comes out right, and the recorder (remapped the same way) stores
   the stream under /bench/joint_states.
Deadlines everywhere, no fixed sleeps (platform.md: discovery takes up to seconds on a
loaded machine; keep-all back-pressure slows the stream instead of losing samples).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from cli_processes import start_cli, stop_cli

pytestmark = pytest.mark.ros


def _short_scene(config_dir: Path, path: Path) -> Path:
    doc = yaml.safe_load((config_dir / 'default_scene.yaml').read_text(encoding='utf-8'))
    doc['lobes'] = doc['lobes'][:1]   # lobe_1 and the dowel pin
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding='utf-8')
    return path


def test_blocks_far_above_the_per_message_ceiling_lose_nothing(
        ros_domain: int, tmp_path: Path, config_dir: Path) -> None:
    from std_msgs.msg import String

    from cam_metrology import bagio
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, simulate
    from cam_metrology.wire.topics import METROLOGY_REPORT, qos_of

    sim_values = {'rate': 100000.0, 'samples_per_rev': 3600, 'revolutions': 10.0,
                  'seed': 3, 'probe_noise': 5e-7, 'feature_gap': 0.0,
                  'samples_per_message': 1000}
    scene_file = _short_scene(config_dir, tmp_path / 'scene.yaml')
    sim_yaml = tmp_path / 'sim.yaml'
    sim_yaml.write_text(yaml.safe_dump({'bench_sim': {'ros__parameters': {
        **sim_values, 'scene_file': str(scene_file), 'wait_subscribers': 2,
        'match_timeout': 60.0, 'ack_timeout': 60.0}}}), encoding='utf-8')
    bag = tmp_path / 'bag'
    reports: list[dict[str, Any]] = []
    proc = RosProcess(handle_signals=False)
    met = start_cli(['run', 'metrology'], tmp_path / 'met.log')
    rec = start_cli(['run', 'recorder', '--ros-args', '-p', f'output:={bag}'],
                    tmp_path / 'rec.log')
    sim = None
    try:
        from rclpy.node import Node
        node = proc.add(Node('blocks_test', context=proc.context))
        node.create_subscription(String, METROLOGY_REPORT,
                                 lambda m: reports.append(json.loads(m.data)),
                                 profile(qos_of(METROLOGY_REPORT)))
        sim = start_cli(['run', 'bench-sim', '--params', str(sim_yaml)], tmp_path / 'sim.log')
        assert proc.spin_until(lambda: sim.poll() is not None, 300.0), 'bench-sim hung'
        assert sim.returncode == 0, (tmp_path / 'sim.log').read_text()
        # the report of every feature (the node sends it once all are measured)
        assert proc.spin_until(lambda: any(len(r.get('features', {})) == 2
                                           for r in reports), 120.0), \
            (tmp_path / 'met.log').read_text()[-3000:]
    finally:
        stop_cli([met, rec])
        if sim is not None and sim.poll() is None:
            sim.kill()
        proc.close()
    assert met.returncode == 0, (tmp_path / 'met.log').read_text()[-3000:]
    run = simulate(load_scene(scene_file), SimParams(**{k: v for k, v in sim_values.items()
                                                        if k != 'samples_per_message'}))
    total = run.sample_count
    assert total == 2 * 36000
    sim_log = (tmp_path / 'sim.log').read_text()
    assert f'sent {total} samples' in sim_log
    # counted independently of the nodes: the samples behind each feature's result ...
    report = reports[-1]
    received = {f: v['samples_received'] for f, v in report['features'].items()}
    assert received == {f.id: f.theta.size for f in run.features}
    # ... and the samples in the recorder's bag (decoded from the bag itself)
    got = list(bagio.iter_joint_states(bag))
    theta = np.concatenate([b.theta for b in got])
    np.testing.assert_allclose(theta, np.concatenate([f.theta for f in run.features]),
                               rtol=0, atol=1e-12)
    # and as the nodes say it: no loss, per block and per sample
    topic = report['input']['topics']['/bench/joint_trajectory']
    assert topic['lost'] == 0 and topic['samples_lost'] == 0
    assert topic['received'] == sum(-(-f.theta.size // 1000) for f in run.features)
    assert topic['samples_received'] == total
    assert report['input']['samples_lost'] == 0
    # the recorder's own loss record (its last status, written into the bag)
    said = {}
    for m in bagio.iter_messages(bag, ['/diagnostics']):
        for st in bagio.statuses_from_msg(m.msg):
            said.update(st.get('values', {}))
    assert said['lost/bench/joint_trajectory'] == '0'
    assert said['samples_lost/bench/joint_trajectory'] == '0'
    assert said['samples_received/bench/joint_trajectory'] == str(total)
    for fid, v in report['features'].items():
        truth = run.truth['features'][fid]['angle_deg']
        err = (v['angle_deg'] - truth + 180.0) % 360.0 - 180.0
        assert abs(err) < 5 * v['angle_std_deg'] + 1e-4, (fid, err)


def test_a_ros2_control_stream_is_connected_by_a_parameter_file(
        ros_domain: int, tmp_path: Path, config_dir: Path) -> None:
    """joint_state_broadcaster-style: all joints in one JointState, the bench's names in
    another order, frame_id 'base_link', on /joint_states."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from cam_metrology.nodes.runtime import RosProcess, publish_retrying
    from cam_metrology.nodes.topics import keep_all_profile, profile
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, simulate
    from cam_metrology.wire.cdr import encode_named_values
    from cam_metrology.wire.topics import (FEATURE_DONE, METROLOGY_RESULT, SCENE,
                                           qos_of)

    scene_file = config_dir / 'default_scene.yaml'
    run = simulate(load_scene(scene_file), SimParams(probe_noise=5e-7, seed=9,
                                                     samples_per_rev=1800))
    lobe = run.features[0]
    assert lobe.id == 'lobe_1'
    names = ['spindle', 'lvdt_1', 'tailstock', 'cam_encoder']   # the bench's own
    rows = np.column_stack((np.zeros(lobe.theta.size), lobe.s, np.ones(lobe.theta.size),
                            lobe.theta))
    frames = encode_named_values('base_link', lobe.stamp_ns, names, rows)
    results: dict[str, dict[str, str]] = {}

    def on_result(msg: Any) -> None:
        for st in msg.status:
            if st.name == 'lobe_1':
                results['lobe_1'] = {kv.key: kv.value for kv in st.values}

    met = start_cli(['run', 'metrology', '--params', str(config_dir / 'ros2_control_bench.yaml'),
                     '--ros-args', '-r', '/bench/joint_states:=/joint_states'],
                    tmp_path / 'met.log')
    bag = tmp_path / 'bag'
    rec = start_cli(['run', 'recorder', '--ros-args', '-r', '/bench/joint_states:=/joint_states',
                     '-p', f'output:={bag}'], tmp_path / 'rec.log')
    proc = RosProcess(handle_signals=False)
    try:
        node = proc.add(Node('broadcaster', context=proc.context))
        scene_pub = node.create_publisher(String, SCENE, profile(qos_of(SCENE)))
        done_pub = node.create_publisher(String, FEATURE_DONE, profile(qos_of(FEATURE_DONE)))
        js_pub = node.create_publisher(JointState, '/joint_states', keep_all_profile())
        node.create_subscription(DiagnosticArray, METROLOGY_RESULT, on_result,
                                 profile(qos_of(METROLOGY_RESULT)))
        scene_pub.publish(String(data=scene_file.read_text(encoding='utf-8')))
        assert proc.spin_until(lambda: js_pub.get_subscription_count() > 1 and
                               scene_pub.get_subscription_count() > 0 and
                               done_pub.get_subscription_count() > 0, 60.0), \
            (tmp_path / 'met.log').read_text()
        from rclpy.duration import Duration
        assert scene_pub.wait_for_all_acked(Duration(seconds=30))
        for cdr in frames:
            publish_retrying(js_pub, cdr, 30.0)
        assert js_pub.wait_for_all_acked(Duration(seconds=60))
        done_pub.publish(String(data='lobe_1'))
        assert proc.spin_until(lambda: 'lobe_1' in results, 120.0), \
            (tmp_path / 'met.log').read_text()[-3000:]
    finally:
        stop_cli([met, rec])
        proc.close()
    # the recorder, remapped the same way, stored the stream under the contract's name
    from cam_metrology import bagio
    recorded = bagio.read_joint_states(bag, joints=('cam_encoder', 'lvdt_1'))
    assert len(recorded) == lobe.theta.size
    np.testing.assert_allclose(recorded.theta, lobe.theta, rtol=0, atol=1e-12)
    got = results['lobe_1']
    truth = run.truth['features']['lobe_1']['angle_deg']
    err = (float(got['angle_deg']) - truth + 180.0) % 360.0 - 180.0
    assert abs(err) < 5 * float(got['angle_std_deg']) + 1e-4, (got, truth)
    assert int(got['samples_received']) == lobe.theta.size
