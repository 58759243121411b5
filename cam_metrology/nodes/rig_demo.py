"""`cam-bench demo --rig`: the rig loop end to end, live over ROS 2.

1. simulate rig runs of the scene's ``rig.true_valve_train`` (``rig.simulate``: speed
   ripple, quantised encoder, laser noise with an arbitrary zero) at speeds around the
   nominal train's jump speed;
2. in an isolated ROS domain start the recorder and the rig node (`cam-bench run`
   subprocesses), publish the scene and the samples on ``/rig/joint_states`` (the rig
   simulator's publisher, keep all), wait (deadline) until the rig node has published
   a status per run, stop both (SIGINT);
3. calibrate stiffness and damping on the recorded bag (the code of ``rig calibrate``)
   and print the live statuses, the calibrated values against the simulator's truth
   and the jump speed predicted with the nominal and the calibrated train.
"""
from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, TextIO

from cam_metrology.nodes.demo import start_child, stop_child

#: speeds of the demo's runs [rpm] and their length
SPEEDS = (905.0, 1310.0, 1705.0, 2110.0)
REVOLUTIONS = 2.5
RATE = 20_000.0


def publish_runs(node: Any, scene_text: str) -> tuple[Any, Any]:
    """Publishers of the scene and the rig samples; publishes everything (keep all:
    held back while a subscriber is behind). Returns the publishers."""
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from cam_metrology.nodes.topics import profile
    from cam_metrology.wire.topics import RIG_JOINT_STATES, SCENE, TOPICS

    scene = node.create_publisher(String, SCENE, profile(TOPICS[SCENE][1]))
    samples = node.create_publisher(JointState, RIG_JOINT_STATES,
                                    profile(TOPICS[RIG_JOINT_STATES][1]))
    scene.publish(String(data=scene_text))
    return scene, samples


def send(samples: Any, runs: Any) -> int:
    """Publish every sample of ``runs`` (frame_id = run name); the count."""
    from sensor_msgs.msg import JointState

    from cam_metrology.wire.topics import CAMSHAFT_JOINT, VALVE_JOINT

    n = 0
    t0 = 10**9
    for r in runs:
        for k in range(r.time.size):
            msg = JointState(name=[CAMSHAFT_JOINT, VALVE_JOINT],
                             position=[float(r.angle[k]), float(r.lift[k])])
            msg.header.frame_id = r.name
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(
                t0 + int(round(r.time[k] * 1e9)), 10**9)
            samples.publish(msg)
            n += 1
        t0 += int(round(r.time[-1] * 1e9)) + 10**8
    return n


def run_rig_demo(scene_path: str | None, out: str | None, timeout: float,
                 stream: TextIO = sys.stdout) -> int:
    """The loop of the module docstring; exit code 0, or 1 with the reason."""
    from diagnostic_msgs.msg import DiagnosticArray

    from cam_metrology.host.isolation import claim_domain, isolated_env
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.host.paths import config_dir
    from cam_metrology.rig.simulate import RigNoise, simulate_scene_runs
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.wire.topics import RIG_RESULT, TOPICS

    t_start = time.monotonic()
    say = (lambda text: print(text, file=stream, flush=True))
    scene = load_scene(scene_path or config_dir() / 'rig_scene.yaml')
    runs, note = simulate_scene_runs(scene, SPEEDS, revolutions=REVOLUTIONS,
                                     noise=RigNoise(sample_rate=RATE))
    if note:
        say(f'note: {note}')
    bag = Path(out or Path('demo-out') / f"rig_{time.strftime('%Y%m%dT%H%M%S', time.gmtime())}")
    bag.parent.mkdir(parents=True, exist_ok=True)
    domain = claim_domain()
    logs = Path(tempfile.mkdtemp(prefix='cam_bench_rig_demo_'))
    env = isolated_env(domain, str(logs))
    import os
    os.environ.update({k: env[k] for k in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE',
                                           'ROS_LOG_DIR')})
    say(f'rig demo: ROS domain {domain}; {len(runs)} simulated runs at '
        + ', '.join(f'{r:g}' for r in SPEEDS) + ' rpm; recording to ' + str(bag))
    children = {'recorder': start_child('recorder', ['--ros-args', '-p', f'output:={bag}'],
                                        env, logs),
                'rig': start_child('rig', [], env, logs)}
    proc = RosProcess(domain_id=domain, handle_signals=False)
    got: dict[str, Any] = {}
    try:
        from rclpy.node import Node
        node = proc.add(Node('rig_demo_sim', context=proc.context))
        node.create_subscription(DiagnosticArray, RIG_RESULT,
                                 lambda m: got.update({s.name: s for s in m.status}),
                                 profile(TOPICS[RIG_RESULT][1]))
        _, samples = publish_runs(node, scene.text)
        if not proc.spin_until(lambda: samples.get_subscription_count() >= 2
                               or any(c.proc.poll() is not None for c in children.values()),
                               timeout):
            say('rig demo: the recorder and the rig node never subscribed (see ' + str(logs)
                + ')')
            return 1
        n = send(samples, runs)
        say(f'published {n} samples on /rig/joint_states')
        if not proc.spin_until(lambda: len(got) >= len(runs), timeout):
            say(f'rig demo: only {len(got)} of {len(runs)} run statuses within {timeout:g} s')
            return 1
        for name in [r.name for r in runs]:
            s = got[name]
            v = {x.key: x.value for x in s.values}
            say(f"live {name}: {float(v['rpm']):.1f} rpm, {s.message}, residual rms "
                f"{float(v['residual_rms_m']) * 1e6:.2f} um against the nominal train")
    finally:
        waiter = (lambda cond, s: proc.spin_until(cond, s))
        for name in ('rig', 'recorder'):
            stop_child(children[name], waiter=waiter)
        proc.close()
    from cam_metrology.rig.report import summary_lines
    from cam_metrology.rig.runs import read_bag_runs
    from cam_metrology.rig.session import calibrate_runs
    from cam_metrology.rig.simulate import true_train
    from cam_metrology.rig.spec import rig_of_scene

    bag_runs, _ = read_bag_runs(bag)
    outcome, fit = calibrate_runs(scene, bag_runs, ('stiffness', 'damping'))
    say('calibrated on the recorded bag:')
    for line in summary_lines(outcome.result):
        say('  ' + line)
    truth, _ = true_train(scene, rig_of_scene(scene))
    say(f'  simulator truth: stiffness {truth.stiffness:.6g} N/m, damping '
        f'{truth.damping:.6g} N s/m')
    say(f'rig demo done in {time.monotonic() - t_start:.1f} s (bag {bag})')
    shutil.rmtree(logs, ignore_errors=True)
    return 0
