"""Live: a bench publishing its own joint names connects to the whole chain (metrology,
reconstruction, dynamics) with no code, every node started as a user starts it
(``cam-bench run NODE``, default parameter files) and moved onto the bench's topics by
``--ros-args -r`` remaps only.

The bench: a joint_state_broadcaster-style stream (every joint in one JointState, the
bench's names in its own order, frame_id a link) on /joint_states; the joint names come
from the scene's ``channels`` (no parameter file), the feature from ``-p feature_id``.
The lift table goes to /gauge/lift, the profile to /gauge/profile, the results to
/gauge/*: the reconstruction and dynamics nodes only answer if their remaps took.
Truth: the simulated lobe's nose angle. Deadlines, no fixed sleeps (platform.md).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from cli_processes import start_cli, stop_cli

pytestmark = pytest.mark.ros

NAMES = ['spindle', 'lvdt_1', 'tailstock', 'cam_encoder']   # the bench's own, its order


def _logs(tmp_path: Path) -> str:
    return '\n'.join(f'--- {p.name}\n' + p.read_text(errors='replace')[-2000:]
                     for p in sorted(tmp_path.glob('*.log')))


def test_reconstruction_and_dynamics_follow_remapped_topics_of_a_bench(
        ros_domain: int, tmp_path: Path, config_dir: Path) -> None:
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.duration import Duration
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from cam_metrology.nodes.runtime import RosProcess, publish_retrying
    from cam_metrology.nodes.topics import keep_all_profile, profile
    from cam_metrology.scene.parse import parse_scene
    from cam_metrology.simulation.bench import SimParams, simulate
    from cam_metrology.wire.cdr import encode_named_values
    from cam_metrology.wire.topics import (DYNAMICS_RESULT, FEATURE_DONE,
                                           METROLOGY_RESULT, RECONSTRUCTION_RESULT,
                                           SCENE, qos_of)

    doc = yaml.safe_load((config_dir / 'default_scene.yaml').read_text(encoding='utf-8'))
    doc['lobes'] = doc['lobes'][:1]
    doc['channels'] = {'angle_joint': 'cam_encoder', 'lift_joint': 'lvdt_1'}
    text = yaml.safe_dump(doc, sort_keys=False)
    run = simulate(parse_scene(text), SimParams(probe_noise=5e-7, seed=5,
                                                samples_per_rev=1800))
    lobe = run.features[0]
    assert lobe.id == 'lobe_1'
    rows = np.column_stack((np.zeros(lobe.theta.size), lobe.s, np.ones(lobe.theta.size),
                            lobe.theta))
    frames = encode_named_values('base_link', lobe.stamp_ns, NAMES, rows)
    got: dict[str, dict[str, dict[str, str]]] = {'met': {}, 'rec': {}, 'dyn': {}}

    def keep(where: str) -> Any:
        def on(msg: Any) -> None:
            for st in msg.status:
                got[where][st.name] = {kv.key: kv.value for kv in st.values}
        return on

    ros = ['--ros-args']
    met = start_cli(['run', 'metrology', *ros, '-r', '/bench/joint_states:=/joint_states',
                     '-r', '/metrology/lift:=/gauge/lift',
                     '-r', '/metrology/result:=/gauge/result', '-p', 'feature_id:=lobe_1'],
                    tmp_path / 'met.log')
    rec = start_cli(['run', 'reconstruction', *ros, '-r', '/metrology/lift:=/gauge/lift',
                     '-r', '/reconstruction/profile:=/gauge/profile',
                     '-r', '/reconstruction/result:=/gauge/reconstruction'], tmp_path / 'rec.log')
    dyn = start_cli(['run', 'dynamics', *ros, '-r', '/reconstruction/profile:=/gauge/profile',
                     '-r', '/dynamics/result:=/gauge/dynamics', '-p', 'source:=profile'],
                    tmp_path / 'dyn.log')
    proc = RosProcess(handle_signals=False)
    try:
        node = proc.add(Node('bench', context=proc.context))
        scene_pub = node.create_publisher(String, SCENE, profile(qos_of(SCENE)))
        done_pub = node.create_publisher(String, FEATURE_DONE, profile(qos_of(FEATURE_DONE)))
        js_pub = node.create_publisher(JointState, '/joint_states', keep_all_profile())
        for topic, where, contract in (('/gauge/result', 'met', METROLOGY_RESULT),
                                       ('/gauge/reconstruction', 'rec', RECONSTRUCTION_RESULT),
                                       ('/gauge/dynamics', 'dyn', DYNAMICS_RESULT)):
            node.create_subscription(DiagnosticArray, topic, keep(where),
                                     profile(qos_of(contract)))
        scene_pub.publish(String(data=text))
        assert proc.spin_until(lambda: js_pub.get_subscription_count() > 0 and
                               scene_pub.get_subscription_count() > 2 and
                               done_pub.get_subscription_count() > 0, 90.0), _logs(tmp_path)
        assert scene_pub.wait_for_all_acked(Duration(seconds=30))
        for cdr in frames:
            publish_retrying(js_pub, cdr, 30.0)
        assert js_pub.wait_for_all_acked(Duration(seconds=60))
        done_pub.publish(String(data='lobe_1'))
        assert proc.spin_until(lambda: 'lobe_1' in got['met'] and
                               any(n.startswith('lobe_1') for n in got['dyn']), 240.0), \
            (got, _logs(tmp_path)[-6000:])
    finally:
        stop_cli([met, rec, dyn])
        proc.close()
    measured = got['met']['lobe_1']
    truth = run.truth['features']['lobe_1']['angle_deg']
    err = (float(measured['angle_deg']) - truth + 180.0) % 360.0 - 180.0
    assert abs(err) < 5 * float(measured['angle_std_deg']) + 1e-4, (measured, truth)
    assert int(measured['samples_received']) == lobe.theta.size
    assert any(n.startswith('lobe_1/') for n in got['rec']), got['rec']
    dyn_lobe = [v for n, v in got['dyn'].items() if n.startswith('lobe_1')]
    assert dyn_lobe and all(v.get('source', '').startswith('profile') for v in dyn_lobe), \
        got['dyn']   # the reconstructed profile, received on the remapped topic
