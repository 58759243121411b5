"""Rig runs as a bag: the scene on ``/bench/scene`` and every sample on
``/rig/joint_states`` (joints ``camshaft``, ``valve`` and the run's further channels;
``frame_id`` = the run's name; the valve velocity when the run has one)."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from cam_metrology.rig.runs import CAMSHAFT, RIG_TOPIC, VALVE, RigRun

#: s between the end of one run and the start of the next in the bag's time line
GAP_S = 0.1


def write_rig_bag(path: str | Path, scene_text: str, runs: Sequence[RigRun],
                  t0_ns: int = 1_000_000_000) -> None:
    """Write a new bag (never over an existing path) with the scene and the runs."""
    from cam_metrology.bagio import BagWriter
    from cam_metrology.wire.cdr import encode_joint_state_positions, encode_string
    from cam_metrology.wire.topics import SCENE, TOPIC_TYPES, qos_of

    with BagWriter(path) as bag:
        bag.add_topic(SCENE, TOPIC_TYPES[SCENE])
        bag.add_topic(RIG_TOPIC, TOPIC_TYPES[RIG_TOPIC], qos_of(RIG_TOPIC).bag_yaml())
        bag.write(SCENE, t0_ns, encode_string(scene_text))
        start = t0_ns + 1_000_000
        for run in runs:
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
