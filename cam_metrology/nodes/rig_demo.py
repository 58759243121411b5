"""`cam-bench demo --rig`: the rig loop end to end, live over ROS 2.

1. in an isolated ROS domain start the recorder, the rig node and the bench simulator
   in its rig mode (`cam-bench run bench-sim -p mode:=rig`, three subprocesses, like
   the metrology demo): bench-sim simulates rig runs of the scene's
   ``rig.true_valve_train`` (speed ripple, quantised encoder, laser noise with an
   arbitrary zero; its ``rig_*`` parameters, config/bench_sim.yaml) and publishes the
   scene and the samples in blocks on ``/rig/joint_trajectory`` once the recorder and
   the rig node have subscribed;
2. wait (deadline) until the rig node has published a status per run named in
   ``/bench/truth`` and the recorder subscribes to it, stop the rig node and the
   recorder (SIGINT);
3. calibrate stiffness and damping on the recorded bag (the code of ``rig calibrate``)
   and print the live statuses, the calibrated values against the simulator's truth
   and the jump speed predicted with the nominal and the calibrated train.
"""
from __future__ import annotations

import json
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, TextIO

from cam_metrology.nodes.demo import Child, start_child, stop_child
from cam_metrology.wire.topics import RIG_RESULT, TRUTH

#: samples per JointTrajectory block that bench-sim publishes in the demo
BLOCK = 500


def sim_arguments(scene: Path, timeout: float) -> list[str]:
    """ROS arguments of bench-sim in the demo's rig mode (the rest from
    config/bench_sim.yaml): the recorder and the rig node subscribe to the samples
    first, and the demo and the recorder to /bench/truth and /rig/result (bench-sim
    exits when done: its latched truth must have reached the demo)."""
    return ['--ros-args', '-p', 'mode:=rig', '-p', f'scene_file:={scene.resolve()}',
            '-p', f'samples_per_message:={BLOCK}', '-p', 'wait_subscribers:=2',
            '-p', f'wait_graph:={TRUTH}=2,{RIG_RESULT}=2',
            '-p', f'match_timeout:={float(timeout)}']


def run_rig_demo(scene_path: str | None, out: str | None, timeout: float,
                 stream: TextIO = sys.stdout) -> int:
    """The loop of the module docstring; exit code 0, or 1 with the reason."""
    import os

    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.node import Node
    from std_msgs.msg import String

    from cam_metrology.host.isolation import claim_domain, isolated_env
    from cam_metrology.host.paths import config_dir
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.wire.topics import TOPICS

    t_start = time.monotonic()
    say = (lambda text: print(text, file=stream, flush=True))
    scene_file = Path(scene_path or config_dir() / 'rig_scene.yaml')
    scene = load_scene(scene_file)        # a bad scene: one line before ROS starts
    bag = Path(out or Path('demo-out') / f"rig_{time.strftime('%Y%m%dT%H%M%S', time.gmtime())}")
    bag.parent.mkdir(parents=True, exist_ok=True)
    domain = claim_domain()
    logs = Path(tempfile.mkdtemp(prefix='cam_bench_rig_demo_'))
    env = isolated_env(domain, str(logs))
    os.environ.update({k: env[k] for k in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE',
                                           'ROS_LOG_DIR')})
    say(f'rig demo: ROS domain {domain}; bench-sim (rig mode) publishes the runs of '
        f'{scene_file} in blocks of {BLOCK}; recording to {bag}')
    children: dict[str, Child] = {
        'recorder': start_child('recorder', ['--ros-args', '-p', f'output:={bag}'], env, logs),
        'rig': start_child('rig', [], env, logs)}
    children['bench-sim'] = start_child('bench-sim', sim_arguments(scene_file, timeout),
                                        env, logs)
    proc = RosProcess(domain_id=domain, handle_signals=False)
    got: dict[str, Any] = {}
    truth: dict[str, Any] = {}
    try:
        node = proc.add(Node('rig_demo', context=proc.context))
        node.create_subscription(DiagnosticArray, RIG_RESULT,
                                 lambda m: got.update({s.name: s for s in m.status}),
                                 profile(TOPICS[RIG_RESULT][1]))
        node.create_subscription(String, TRUTH,
                                 lambda m: truth.update(json.loads(m.data).get('rig') or {}),
                                 profile(TOPICS[TRUTH][1]))
        names: list[str] = []

        def done() -> bool:
            names[:] = list(truth.get('runs', ()))
            return bool(names) and all(n in got for n in names)

        def failed() -> bool:
            return any(c.proc.poll() not in (None, 0) for c in children.values()) or \
                children['rig'].proc.poll() is not None
        if not proc.spin_until(lambda: done() or failed(), timeout) or not done():
            say(f'rig demo: {len(got)} of {len(names) or "?"} run statuses within '
                f'{timeout:g} s (node logs in {logs})')
            for c in children.values():
                say(f'  {c.name}: exit {c.proc.poll()}\n{c.tail(5)}')
            return 1
        # the recorder subscribes to the rig node's outputs once it sees them in the
        # graph; the rig node, stopped, waits for every matched subscriber to have them
        # all: so stop it only when the recorder has matched (deadline)
        if not proc.spin_until(lambda: node.count_subscribers(RIG_RESULT) >= 2, timeout):
            say(f'rig demo: the recorder never subscribed to {RIG_RESULT} within '
                f'{timeout:g} s (node logs in {logs})')
            return 1
        for name in names:
            s = got[name]
            v = {x.key: x.value for x in s.values}
            say(f"live {name}: {float(v['rpm']):.1f} rpm, {s.message}, residual rms "
                f"{float(v['residual_rms_m']) * 1e6:.2f} um against the nominal train")
    finally:
        waiter = (lambda cond, s: proc.spin_until(cond, s))
        for name in ('bench-sim', 'rig', 'recorder'):
            stop_child(children[name], waiter=waiter)
        proc.close()
    return _calibrate(scene, bag, say, t_start, logs)


def _calibrate(scene: Any, bag: Path, say: Any, t_start: float, logs: Path) -> int:
    """Calibrate on the recorded bag and print the result against the simulator's truth."""
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
