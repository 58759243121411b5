"""Blocks of samples: encode and decode cost of a JointTrajectory block, against rosbags
and rclpy, and the cost of the alternatives.

    .venv/bin/python -m benchmarks.bench_blocks [--samples 2000000] [--per 1000]

Measured (CPU time of this process, user + system, best of 3; the load average is
printed with every table because other jobs share the machine):

* encode one block: ``wire.cdr.encode_joint_trajectory`` (numpy, what bench-sim
  publishes) against building an rclpy ``trajectory_msgs/JointTrajectory`` with one
  ``JointTrajectoryPoint`` per sample and ``rclpy.serialization.serialize_message``;
  and a ``Float64MultiArray`` of the same samples (the layout platform probes used);
* decode one block: ``bagio.decode_joint_blocks`` (numpy views, what the nodes and
  ``analyze`` use) against ``rclpy.serialization.deserialize_message`` (what a non-raw
  rclpy subscription does) and rosbags' ``deserialize_cdr``;
* read a bag: ``bagio.iter_joint_states`` of a bag of blocks against rosbags'
  ``AnyReader`` + ``deserialize_cdr`` of every block, and against the same samples
  as one JointState each (``iter_joint_states``).
Writes ``benchmarks/results/blocks.md``.
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

RESULTS = Path(__file__).resolve().parent / 'results' / 'blocks.md'


def _cpu(fn: Callable[[], Any], repeat: int = 3) -> float:
    """Best CPU time (user + system) of ``fn()`` over ``repeat`` runs [s]."""
    best = float('inf')
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def _block(per: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1)
    pos = np.column_stack((np.linspace(0, 2 * np.pi, per), rng.normal(0, 1e-3, per)))
    return pos, np.arange(per, dtype=np.int64) * 5000


def message_costs(per: int) -> list[tuple[str, float]]:
    """(what, us per sample) of encoding and decoding one block."""
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import Float64MultiArray
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from cam_metrology.bagio import decode_joint_blocks
    from cam_metrology.wire.cdr import (decode, encode_float64_array,
                                        encode_joint_trajectory)
    pos, off = _block(per)
    names = ['camshaft', 'probe']
    n_rep = 50
    rows: list[tuple[str, float]] = []

    def ours() -> bytes:
        return encode_joint_trajectory('lobe_1', 10**18, names, pos, off)
    t = _cpu(lambda: [ours() for _ in range(n_rep)])
    rows.append(('encode: wire.cdr.encode_joint_trajectory (numpy)', t / n_rep / per * 1e6))

    def rclpy_msg() -> bytes:
        msg = JointTrajectory()
        msg.header.frame_id = 'lobe_1'
        msg.joint_names = names
        pts = []
        for (th, s), o in zip(pos.tolist(), off.tolist()):
            p = JointTrajectoryPoint()
            p.positions = [th, s]
            p.time_from_start.nanosec = o
            pts.append(p)
        msg.points = pts
        return serialize_message(msg)
    t = _cpu(lambda: [rclpy_msg() for _ in range(5)])
    rows.append(('encode: rclpy JointTrajectory (a point object per sample) + '
                 'serialize_message', t / 5 / per * 1e6))
    t = _cpu(lambda: [encode_float64_array([('sample', per, 2 * per), ('channel', 2, 2)],
                                           pos) for _ in range(n_rep)])
    rows.append(('encode: Float64MultiArray (no stamps, frame or names)', t / n_rep / per * 1e6))
    cdr = ours()
    t = _cpu(lambda: [decode_joint_blocks([cdr]) for _ in range(n_rep)])
    rows.append(('decode: bagio.decode_joint_blocks (numpy views)', t / n_rep / per * 1e6))
    t = _cpu(lambda: [deserialize_message(cdr, JointTrajectory) for _ in range(5)])
    rows.append(('decode: rclpy deserialize_message (a non-raw subscription)',
                 t / 5 / per * 1e6))
    t = _cpu(lambda: [decode(cdr, 'trajectory_msgs/msg/JointTrajectory')
                      for _ in range(5)])
    rows.append(('decode: rosbags deserialize_cdr', t / 5 / per * 1e6))
    fcdr = encode_float64_array([('sample', per, 2 * per), ('channel', 2, 2)], pos)
    t = _cpu(lambda: [deserialize_message(fcdr, Float64MultiArray) for _ in range(n_rep)])
    rows.append(('decode: rclpy deserialize_message of the Float64MultiArray',
                 t / n_rep / per * 1e6))
    return rows


def bag_rates(work: Path, samples: int, per: int) -> list[tuple[str, float, float]]:
    """(what, samples/s, CPU s) of reading a bag of ``samples`` samples."""
    from rosbags.highlevel import AnyReader

    from cam_metrology import bagio
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.host.paths import default_scene_path
    from cam_metrology.simulation.bench import SimParams, write_sim_bag
    from cam_metrology.wire.cdr import typestore
    scene = load_scene(default_scene_path())
    revs = samples / (5 * 3600)
    params = SimParams(samples_per_rev=3600, revolutions=revs, probe_noise=1e-6)
    write_sim_bag(work / 'blocks', scene, params, samples_per_message=per)
    write_sim_bag(work / 'single', scene, params)
    n = params.samples_per_rev * revs * 5
    rows = []

    def read(bag: Path) -> int:
        return sum(len(b) for b in bagio.iter_joint_states(bag))
    for what, bag in (('bagio.iter_joint_states, blocks of %d' % per, work / 'blocks'),
                      ('bagio.iter_joint_states, one JointState a sample', work / 'single')):
        t = _cpu(lambda: read(bag), 2)
        rows.append((what, n / t, t))
    ts = typestore()

    def rosbags_read() -> int:
        k = 0
        with AnyReader([work / 'blocks'], default_typestore=ts) as r:
            conns = [c for c in r.connections if c.topic == bagio.JOINT_TRAJECTORY]
            for conn, _, raw in r.messages(connections=conns):
                msg = ts.deserialize_cdr(raw, conn.msgtype)
                k += len(msg.points)
        return k
    t = _cpu(rosbags_read, 1)
    rows.append((f'rosbags AnyReader + deserialize_cdr, blocks of {per}', n / t, t))
    return rows


def main(argv: list[str] | None = None) -> None:
    """Measure and write the results table."""
    from benchmarks.machine import describe, save_results

    parser = argparse.ArgumentParser(prog='python -m benchmarks.bench_blocks')
    parser.add_argument('--samples', type=int, default=2_000_000)
    parser.add_argument('--per', type=int, default=1000)
    args = parser.parse_args(argv if argv is not None else sys.argv[1:])
    load0 = open('/proc/loadavg', encoding='ascii').read().split()[0]
    msg = message_costs(args.per)
    work = Path(tempfile.mkdtemp(prefix='bench_blocks_'))
    try:
        bag = bag_rates(work, args.samples, args.per)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    load1 = open('/proc/loadavg', encoding='ascii').read().split()[0]
    lines = ['# Blocks of samples: encode and decode cost (`python -m benchmarks.bench_blocks`)',
             '', f'Machine: {describe()} (1-min load {load0} when measuring started); '
             f'load average {load1} at the end. CPU time (user + system) of this '
             f'process, best of several runs; a block = {args.per} samples of '
             '(camshaft, probe).', '',
             '| per block | CPU per sample [us] |', '|---|---:|']
    lines += [f'| {w} | {c:.3f} |' for w, c in msg]
    lines += ['', f'Reading a bag of {args.samples:,} samples (5 features of the default '
              'scene):', '', '| reader | samples/s | CPU [s] |', '|---|---:|---:|']
    lines += [f'| {w} | {r:,.0f} | {t:.2f} |' for w, r, t in bag]
    text = '\n'.join(lines) + '\n'
    print(text)
    save_results(RESULTS, text)


if __name__ == '__main__':
    os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')
    main()
