"""Rig runs as a bag: the scene on ``/bench/scene`` and every sample on
``/rig/joint_states`` (joints ``camshaft``, ``valve`` and the run's further channels;
``frame_id`` = the run's name; the valve velocity when the run has one), or, with
``block`` > 1, the samples in blocks of that many on ``/rig/joint_trajectory``
(JointTrajectory: joints ``camshaft``, ``valve`` and the further channels, the valve
velocity in the points' ``velocities`` when the run has one; ``rig_blocks``)."""
from __future__ import annotations

from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from cam_metrology.rig.runs import CAMSHAFT, RIG_TOPIC, VALVE, RigRun

#: s between the end of one run and the start of the next in the bag's time line
GAP_S = 0.1


def rig_blocks(run: RigRun, start_ns: int, block: int) -> Iterator[tuple[int, bytes]]:
    """(stamp of the block's last sample [ns], JointTrajectory CDR) of ``run`` in blocks
    of ``block`` samples (joints ``camshaft``, ``valve`` and the run's channels, the
    valve velocity when the run has one, as one JointState sample carries them;
    ``frame_id`` = run name; ``header.stamp`` = first sample, each point's
    ``time_from_start`` from it)."""
    from cam_metrology.wire.cdr import encode_sample_blocks

    stamps = start_ns + np.round(run.time * 1e9).astype(np.int64)
    yield from encode_sample_blocks(run.name, stamps, run.angle, run.lift, block,
                                    (CAMSHAFT, VALVE, *run.channels),
                                    more=tuple(run.channels.values()),
                                    velocity=run.velocity)


def write_rig_bag(path: str | Path, scene_text: str, runs: Sequence[RigRun],
                  t0_ns: int = 1_000_000_000, block: int = 1) -> None:
    """Write a new bag (never over an existing path) with the scene and the runs: one
    sample per JointState message, or blocks of ``block`` samples (> 1)."""
    from cam_metrology.bagio import BagWriter
    from cam_metrology.wire.cdr import encode_joint_state_positions, encode_string
    from cam_metrology.wire.topics import RIG_JOINT_TRAJECTORY, SCENE, TOPIC_TYPES, qos_of

    topic = RIG_JOINT_TRAJECTORY if block > 1 else RIG_TOPIC
    with BagWriter(path) as bag:
        bag.add_topic(SCENE, TOPIC_TYPES[SCENE])
        bag.add_topic(topic, TOPIC_TYPES[topic], qos_of(topic).bag_yaml())
        bag.write(SCENE, t0_ns, encode_string(scene_text))
        start = t0_ns + 1_000_000
        for run in runs:
            if block > 1:
                for stamp, data in rig_blocks(run, start, block):
                    bag.write(topic, stamp, data)
                start = stamp + int(GAP_S * 1e9)
                continue
            names = [CAMSHAFT, VALVE] + list(run.channels)
            pos = np.column_stack([run.angle, run.lift] + list(run.channels.values()))
            stamps = start + np.round(run.time * 1e9).astype(np.int64)
            vel = None
            if run.velocity is not None:
                vel = np.zeros_like(pos)
                vel[:, 1] = run.velocity
            for k in range(stamps.size):
                data = encode_joint_state_positions(
                    run.name, int(stamps[k]), names, pos[k],
                    () if vel is None else vel[k])
                bag.write(RIG_TOPIC, int(stamps[k]), data)
            start = int(stamps[-1]) + int(GAP_S * 1e9)
