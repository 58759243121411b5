"""bench-sim (subprocess, `cam-bench run bench-sim`) -> RecorderNode (in-process) over
live rclpy in this session's isolated domain: the bag holds exactly what
``simulate()`` produced (theta, s, frame ids bit for bit; stamps shifted by one
constant onto the system clock, inside the run's wall time), the scene and truth,
one /bench/feature_done per feature after its last sample, in publication order; every
topic stored with the QoS of the wire table, as ``simulate`` stores it.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytestmark = pytest.mark.ros

CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'
SIM = {'rate': 4000.0, 'samples_per_rev': 1800, 'revolutions': 1.0, 'seed': 7,
       'probe_noise': 1.0e-6, 'encoder_noise': 1.0e-5, 'feature_gap': 0.02,
       'wrapped': True, 'start_theta': 1.0}


def short_scene(config_dir: Path, path: Path) -> Path:
    """The default scene with its first lobe and the dowel pin only."""
    doc = yaml.safe_load((config_dir / 'default_scene.yaml').read_text(encoding='utf-8'))
    doc['lobes'] = doc['lobes'][:1]
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding='utf-8')
    return path


def test_sim_to_recorder_bag_equals_simulation(ros_domain: int, tmp_path: Path,
                                               config_dir: Path) -> None:
    from cam_metrology import bagio
    from cam_metrology.nodes.bench_sim import truth_json
    from cam_metrology.nodes.recorder import RecorderNode
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, simulate

    scene_file = short_scene(config_dir, tmp_path / 'scene.yaml')
    params = tmp_path / 'sim.yaml'
    params.write_text(yaml.safe_dump({'bench_sim': {'ros__parameters': {
        **SIM, 'scene_file': str(scene_file), 'wait_subscribers': 1,
        'match_timeout': 30.0}}}), encoding='utf-8')
    bag = tmp_path / 'bag'
    import time
    t_before = time.time_ns()
    proc = RosProcess(handle_signals=False)
    sim = None
    try:
        rec = proc.add(RecorderNode(context=proc.context, output=bag))
        sim = subprocess.Popen([sys.executable, '-c', CLI, 'run', 'bench-sim', '--params',
                                str(params)], env=dict(os.environ), stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
        assert proc.spin_until(lambda: sim.poll() is not None, 60.0), 'bench-sim hung'
        log = sim.communicate()[0]
        assert sim.returncode == 0, log
        proc.drain(lambda: rec.callbacks_run)
        t_after = time.time_ns()
        rec.close()
    finally:
        if sim is not None and sim.poll() is None:
            sim.kill()
        proc.close()

    run = simulate(load_scene(scene_file), SimParams(**SIM))
    got = bagio.read_joint_states(bag)
    assert len(got) == run.sample_count == 2 * 1800
    assert np.array_equal(got.theta, np.concatenate([f.theta for f in run.features]))
    assert np.array_equal(got.s, np.concatenate([f.s for f in run.features]))
    # one time base: the simulated stamps shifted by one constant onto the system clock,
    # within the run's wall time (they are the times the samples were due)
    sim_stamps = np.concatenate([f.stamp_ns for f in run.features])
    offset = int(got.stamp_ns[0] - sim_stamps[0])
    assert np.array_equal(got.stamp_ns - offset, sim_stamps)
    assert t_before <= got.stamp_ns[0] and got.stamp_ns[-1] <= t_after
    assert f'stamps = simulated + {offset} ns (system clock)' in log
    assert list(got.features) == ['lobe_1', 'dowel_pin']
    assert list(got.frame_id[[0, 1799, 1800, -1]]) == ['lobe_1', 'lobe_1', 'dowel_pin',
                                                       'dowel_pin']
    assert got.names == (('camshaft', 'probe'),)
    msgs = list(bagio.iter_messages(bag, ['/bench/scene', '/bench/truth',
                                          '/bench/feature_done', '/bench/joint_states']))
    texts = {m.topic: m.msg.data for m in msgs if m.topic in ('/bench/scene', '/bench/truth')}
    assert texts['/bench/scene'] == scene_file.read_text(encoding='utf-8')
    assert json.loads(texts['/bench/truth']) == json.loads(truth_json(run))
    # publication order: scene and truth first, each feature_done after its samples
    order = [(m.topic, m.msg.data if m.topic == '/bench/feature_done' else
              m.msg.header.frame_id if m.topic == '/bench/joint_states' else '') for m in msgs]
    assert {order[0][0], order[1][0]} == {'/bench/scene', '/bench/truth'}
    done = [i for i, (t, _) in enumerate(order) if t == '/bench/feature_done']
    assert [order[i][1] for i in done] == ['lobe_1', 'dowel_pin']
    assert done[0] == 2 + 1800 and done[1] == len(order) - 1
    # one QoS per topic: the recorder stores what simulate and the bag writer store,
    # the wire table's (transient local scene and truth, keep last 1000 samples, ...)
    from cam_metrology.simulation.bench import write_sim_bag
    from cam_metrology.wire.topics import BENCH_TOPICS, qos_of
    write_sim_bag(tmp_path / 'offline', load_scene(scene_file), SimParams(**SIM))
    recorded, offline = bagio.topic_qos_yaml(bag), bagio.topic_qos_yaml(tmp_path / 'offline')
    for topic in BENCH_TOPICS:
        assert recorded[topic] == offline[topic] == qos_of(topic).bag_yaml(), topic
