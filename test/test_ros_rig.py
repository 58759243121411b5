"""The rig live: `cam-bench run rig` and `cam-bench record` as subprocesses, rig samples
published over ROS 2, then `rig analyze` of the recorded bag. One live test; every wait
has a deadline; the domain is the session's isolated one (conftest)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'
ROOT = Path(__file__).resolve().parents[1]


def cam_bench(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, '-c', CLI, *args], env=dict(os.environ),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def test_rig_live_recorded_and_analysed(ros_domain: int, tmp_path: Path) -> None:
    from rclpy.duration import Duration
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import String

    from cam_metrology import bagio
    from cam_metrology.cli import main
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.rig.simulate import RigNoise, simulate_scene_runs
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.wire.topics import RIG_JOINT_STATES, RIG_RESULT, SCENE, TOPICS

    scene = load_scene(ROOT / 'config' / 'rig_scene.yaml')
    runs, _ = simulate_scene_runs(scene, [1010, 1790], revolutions=2.5,
                                  noise=RigNoise(sample_rate=20_000.0))
    out = tmp_path / 'rec'
    proc = RosProcess(handle_signals=False)
    rec = rig = None
    try:
        node = proc.add(Node('rig_test', context=proc.context))
        pub_scene = node.create_publisher(String, SCENE, profile(TOPICS[SCENE][1]))
        samples = node.create_publisher(JointState, RIG_JOINT_STATES,
                                        profile(TOPICS[RIG_JOINT_STATES][1]))
        pub_scene.publish(String(data=scene.text))
        got: list[str] = []
        node.create_subscription(DiagnosticArray, RIG_RESULT,
                                 lambda m: got.extend(s.name for s in m.status),
                                 profile(TOPICS[RIG_RESULT][1]))
        rec = cam_bench('record', str(out))
        rig = cam_bench('run', 'rig')
        assert proc.spin_until(lambda: samples.get_subscription_count() >= 2
                               or rec.poll() is not None or rig.poll() is not None,
                               60.0), 'recorder and rig node never matched'
        assert rec.poll() is None and rig.poll() is None
        for r in runs:
            for k in range(r.time.size):
                msg = JointState(name=['camshaft', 'valve'],
                                 position=[float(r.angle[k]), float(r.lift[k])])
                msg.header.frame_id = r.name
                ns = 10**9 + int(round(r.time[k] * 1e9)) + (0 if r is runs[0] else 10**9)
                msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 10**9)
                samples.publish(msg)
        assert samples.wait_for_all_acked(Duration(seconds=30))
        # the node ends a run at the next frame_id, the last one when the stream has
        # been quiet for the scene's idle_timeout: wait for both statuses
        assert proc.spin_until(lambda: len(set(got)) >= 2 or rig.poll() is not None,
                               120.0), got
        rig.send_signal(signal.SIGINT)
        rig_text, _ = rig.communicate(timeout=60)
        assert rig.returncode == 0, rig_text
        rec.send_signal(signal.SIGINT)
        text, _ = rec.communicate(timeout=60)
        assert rec.returncode == 0, text
    finally:
        for p in (rig, rec):
            if p is not None and p.poll() is None:
                p.kill()
        proc.close()
    topics = bagio.bag_topics(out)
    n = sum(r.time.size for r in runs)
    assert topics[RIG_JOINT_STATES] == ('sensor_msgs/msg/JointState', n)
    statuses = [s for m in bagio.iter_messages(out, [RIG_RESULT]) for s in m.msg.status]
    # a run the idle timeout ended early (a stalled machine) is published again: the
    # last status of a run counts
    assert list(dict.fromkeys(s.name for s in statuses)) == ['run_1010rpm', 'run_1790rpm']
    assert 'no loss' in rig_text
    live = {s.name: {v.key: v.value for v in s.values} for s in statuses}
    res = tmp_path / 'res.json'
    assert main(['rig', 'analyze', str(out), '--json', str(res), '--no-jump']) == 0
    offline = json.loads(res.read_text())['runs']
    for r in offline:
        assert float(live[r['name']]['rpm']) == pytest.approx(r['rpm'], abs=1e-9)
        assert abs(r['rpm'] - float(r['name'][4:-3])) < 2.0


def test_rig_demo_bench_sim_in_blocks(tmp_path: Path) -> None:
    """`cam-bench demo --rig`: bench-sim (rig mode, its own process) publishes the runs
    in blocks on /rig/joint_trajectory; the rig node analyses them live (no loss), the
    recorder keeps every block, and the calibration on the bag recovers the simulator's
    true train within 4 reported standard uncertainties."""
    from cam_metrology import bagio
    from cam_metrology.rig.runs import read_bag_runs
    from cam_metrology.rig.session import calibrate_runs
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.wire.topics import RIG_JOINT_STATES, RIG_JOINT_TRAJECTORY, RIG_RESULT

    bag = tmp_path / 'rig_demo'
    env = dict(os.environ)
    env.pop('ROS_DOMAIN_ID', None)   # the demo claims a domain of its own
    proc = subprocess.run([sys.executable, '-c', CLI, 'demo', '--rig', '--out', str(bag),
                           '--timeout', '150'], env=env, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.count('live run_') == 4
    rpms = (905.0, 1310.0, 1705.0, 2110.0)        # config/bench_sim.yaml rig_rpm
    sizes = [int(2.5 * 60.0 / r * 20_000.0) for r in rpms]
    topics = bagio.bag_topics(bag)
    assert topics[RIG_JOINT_TRAJECTORY][1] == sum(-(-n // 500) for n in sizes)
    assert topics.get(RIG_JOINT_STATES, ('', 0))[1] == 0
    statuses = {s.name: {v.key: v.value for v in s.values}
                for m in bagio.iter_messages(bag, [RIG_RESULT]) for s in m.msg.status}
    assert sorted(statuses) == sorted(f'run_{r:g}rpm' for r in rpms)
    assert all(v['samples_lost'] == '0' and v['partial'] == 'False'
               for v in statuses.values())
    runs, text = read_bag_runs(bag)
    assert [r.time.size for r in runs] == sizes
    _, fit = calibrate_runs(load_scene(ROOT / 'config' / 'rig_scene.yaml'), runs,
                            ('stiffness', 'damping'), jump=False)
    for name, truth in (('stiffness', 1.0e7), ('damping', 90.0)):   # rig.true_valve_train
        assert abs(fit.value[name] - truth) < 4 * fit.std[name], (name, fit.value, fit.std)
