"""`cam-bench record` onto a disk that fills up while it records (live rclpy).

The recorder writes to a 1.6 MiB tmpfs with chunk compression off: its first chunk
(1 MiB of JointState records) fits, the second cannot be written: it must stop, exit
non-zero, name OUT, the path and the full disk, say how many samples it had written,
and leave them readable: `bag recover` (onto another disk) keeps exactly that many,
the samples as published, in order. Waits have deadlines; the domain is isolated.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ros

CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'


def test_record_onto_a_full_disk_says_what_it_kept(ros_domain: int, tmp_path: Path,
                                                   small_disk) -> None:  # noqa: ANN001
    from rclpy.node import Node
    from sensor_msgs.msg import JointState

    from cam_metrology import bagio
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.wire.topics import TOPICS

    disk = small_disk(1600)
    out = disk / 'rec'
    proc = RosProcess(handle_signals=False)
    rec = None
    sent = 0
    try:
        node = proc.add(Node('record_full_disk', context=proc.context))
        samples = node.create_publisher(JointState, '/bench/joint_states',
                                        profile(TOPICS['/bench/joint_states'][1]))
        rec = subprocess.Popen([sys.executable, '-c', CLI, 'record', str(out),
                                '--no-compression'], env=dict(os.environ),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert proc.spin_until(lambda: samples.get_subscription_count() >= 1
                               or rec.poll() is not None, 30.0), 'recorder never matched'
        msg = JointState(name=['camshaft', 'probe'], position=[0.0, 0.0])
        msg.header.frame_id = 'lobe_1'
        deadline = time.monotonic() + 120
        # 1 MiB of records per chunk at ~104 B each: the disk is full before 30 000
        while rec.poll() is None and sent < 30_000 and time.monotonic() < deadline:
            for _ in range(100):
                msg.position = [0.001 * sent, 1e-9 * sent]
                samples.publish(msg)
                sent += 1
            proc.spin_once(0.0)
        assert proc.spin_until(lambda: rec.poll() is not None, 30.0), \
            f'recorder still running after {sent} samples on a full disk'
        stdout, stderr = rec.communicate(timeout=10)
    finally:
        if rec is not None and rec.poll() is None:
            rec.kill()
        proc.close()
    assert rec.returncode == 2, (stdout, stderr)
    assert 'Traceback' not in stderr
    lines = [ln for ln in stderr.splitlines() if ln.startswith('cam-bench')]
    assert len(lines) == 1, stderr
    line = lines[0]
    assert "OUT: got '" + str(out) + "'" in line and 'the disk is full' in line, line
    found = re.search(r'(\d+) of the (\d+) samples received were written', line)
    assert found, line
    kept, received = int(found.group(1)), int(found.group(2))
    assert 0 < kept <= received <= sent, (line.split(";")[1:], sent)
    # what it says it kept is what a recovery (onto another disk) gives, in order
    fixed = tmp_path / 'fixed'
    counts = bagio.recover_bag(out, fixed)
    assert counts['/bench/joint_states'] == kept
    got = bagio.read_joint_states(fixed)
    k = np.arange(kept)
    assert np.allclose(got.theta, 0.001 * k, rtol=0, atol=1e-12)
    assert np.allclose(got.s, 1e-9 * k, rtol=0, atol=1e-18)
