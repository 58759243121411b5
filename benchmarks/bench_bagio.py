"""Bag I/O speed: encode, write of pre-serialized JointState, decode of a 200k-sample bag.

    .venv/bin/python -m benchmarks.bench_bagio [--samples N]

Decoders compared on the same bag (default scene simulated with 1 um noise): rosbags
``AnyReader`` + ``deserialize`` of every message (what the analysis would do naively),
``mcap`` + ``mcap_ros2`` decoded iteration, and ``bagio.read_joint_states`` (direct
MCAP chunk read, and through AnyReader's raw iteration). The error column compares
the decoded theta and s with the simulated arrays (must be exactly 0).
Writes benchmarks/results/bagio.md.
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from benchmarks.machine import describe, save_results
from cam_metrology import bagio
from cam_metrology.host.paths import default_scene_path
from cam_metrology.scene.parse import load_scene
from cam_metrology.simulation.bench import SimParams, simulate, write_sim_bag

RESULTS = Path(__file__).resolve().parent / 'results' / 'bagio.md'


def _best(func: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    """Best wall time [s] of ``repeat`` runs and the last result."""
    best, out = float('inf'), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = func()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _anyreader(bag: Path) -> tuple[np.ndarray, np.ndarray]:
    from rosbags.highlevel import AnyReader

    theta, s = [], []
    with AnyReader([bag], default_typestore=bagio.typestore()) as reader:
        conns = [c for c in reader.connections if c.topic == bagio.JOINT_STATES]
        for conn, _, raw in reader.messages(connections=conns):
            msg: Any = reader.deserialize(raw, conn.msgtype)
            names = list(msg.name)
            theta.append(msg.position[names.index('camshaft')])
            s.append(msg.position[names.index('probe')])
    return np.array(theta), np.array(s)


def _mcap_ros2(bag: Path) -> tuple[np.ndarray, np.ndarray]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    theta, s = [], []
    (path,) = bag.glob('*.mcap')
    with open(path, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, _, _, msg in reader.iter_decoded_messages(topics=[bagio.JOINT_STATES]):
            names = list(msg.name)
            theta.append(msg.position[names.index('camshaft')])
            s.append(msg.position[names.index('probe')])
    return np.array(theta), np.array(s)


def run(samples: int, repeat: int) -> str:
    """Run every measurement; return the Markdown report."""
    machine = describe()
    scene = load_scene(default_scene_path())
    n_features = len(scene.lobes) + (scene.dowel_pin is not None)
    per_rev = max(8, samples // n_features)
    params = SimParams(samples_per_rev=per_rev, probe_noise=1e-6, seed=1)
    run_ = simulate(scene, params)
    theta_ref = np.concatenate([f.theta for f in run_.features])
    s_ref = np.concatenate([f.s for f in run_.features])
    n = theta_ref.size
    rows: list[tuple[str, float, float, str]] = []
    tmp = Path(tempfile.mkdtemp(prefix='bench_bagio_'))
    try:
        # encoders
        msgs = list(_stream(run_))
        t_struct, cdrs = _best(lambda: [bagio.encode_joint_state(fid, st, th, v)
                                        for st, fid, th, v in msgs], repeat)
        rows.append(('encode JointState, bagio struct encoder', n / t_struct, t_struct,
                     'byte-identical to typestore (test_bagio)'))

        def vectorised() -> list[bytes]:
            out: list[bytes] = []
            for f in run_.features:
                out += bagio.encode_joint_states(f.id, f.stamp_ns, f.theta, f.s)
            return out
        t_vec, vec = _best(vectorised, repeat)
        rows.append(('encode JointState, bagio vectorised encoder (per feature)', n / t_vec,
                     t_vec, 'same bytes' if vec == cdrs else 'DIFFERENT BYTES!'))
        ts = bagio.typestore()
        sub = msgs[: max(1, n // 10)]

        def typestore_encode() -> list[bytes]:
            js = ts.types['sensor_msgs/msg/JointState']
            hdr = ts.types['std_msgs/msg/Header']
            tm = ts.types['builtin_interfaces/msg/Time']
            out = []
            for st, fid, th, v in sub:
                sec, nsec = divmod(st, 10**9)
                msg = js(header=hdr(stamp=tm(sec=sec, nanosec=nsec), frame_id=fid),
                         name=['camshaft', 'probe'], position=np.array([th, v]),
                         velocity=np.zeros(0), effort=np.zeros(0))
                out.append(bytes(ts.serialize_cdr(msg, 'sensor_msgs/msg/JointState')))
            return out
        t_ts, _ = _best(typestore_encode, 1)
        rows.append((f'encode JointState, rosbags objects + serialize_cdr ({len(sub)} msgs)',
                     len(sub) / t_ts, t_ts * n / len(sub), 'reference'))

        # writes of pre-serialized bytes
        for compression in (False, True):
            k = [0]

            def write() -> Path:
                k[0] += 1
                path = tmp / f'w{int(compression)}_{k[0]}'
                with bagio.BagWriter(path, compression=compression) as w:
                    w.add_topic(bagio.JOINT_STATES, 'sensor_msgs/msg/JointState')
                    for (st, _, _, _), cdr in zip(msgs, cdrs):
                        w.write(bagio.JOINT_STATES, st, cdr)
                return path
            t_w, path = _best(write, repeat)
            size = sum(p.stat().st_size for p in path.iterdir()) / 1e6
            rows.append((f'write pre-serialized JointState (BagWriter'
                         f'{", zstd" if compression else ""})', n / t_w, t_w,
                         f'{size:.1f} MB'))
        t_sim, _ = _best(lambda: write_sim_bag(tmp / f'sim{time.perf_counter_ns()}', scene,
                                               params), 1)
        rows.append(('write_sim_bag (simulate + encode + write, 4 topics)', n / t_sim, t_sim,
                     ''))

        # decoders on one bag
        bag = tmp / 'decode'
        write_sim_bag(bag, scene, params)

        def err(theta: np.ndarray, s: np.ndarray) -> str:
            if theta.size != n:
                return f'{theta.size} of {n} samples!'
            return (f'max abs dtheta {np.max(np.abs(theta - theta_ref)):.1e} rad, '
                    f'max abs ds {np.max(np.abs(s - s_ref)):.1e} m')
        t_any, (th, sv) = _best(lambda: _anyreader(bag), 1)
        rows.append(('decode: rosbags AnyReader + deserialize', n / t_any, t_any, err(th, sv)))
        t_mcap, (th, sv) = _best(lambda: _mcap_ros2(bag), 1)
        rows.append(('decode: mcap + mcap_ros2 iter_decoded_messages', n / t_mcap, t_mcap,
                     err(th, sv)))
        t_fb, js = _best(lambda: bagio.read_joint_states(bag, direct=False), repeat)
        rows.append(('decode: bagio.read_joint_states via AnyReader raw', n / t_fb, t_fb,
                     err(js.theta, js.s)))
        t_fast, js = _best(lambda: bagio.read_joint_states(bag), repeat)
        rows.append(('decode: bagio.read_joint_states (direct MCAP)', n / t_fast, t_fast,
                     err(js.theta, js.s)))

        # integrity: chunk walk + decompression + CRC-32 (cached per file after the first)
        from cam_metrology.bagio import check as bagcheck

        zbag = tmp / 'decode_zstd'
        write_sim_bag(zbag, scene, params, compression=True)
        for label, path in (('uncompressed', bag), ('zstd', zbag)):
            def check(path: Path = path) -> list[Any]:
                bagcheck.clear_cache()
                return bagcheck.check_bag(path)
            t_chk, damaged = _best(check, repeat)
            crcs = sum(s.crc_chunks for s in bagcheck.scan_bag(path))
            rows.append((f'integrity check, {label} (bagcheck.check_bag, uncached)',
                         n / t_chk, t_chk, f'{crcs} chunks with CRC-32, '
                         f'{len(damaged)} damaged'))

        def first_read() -> Any:
            bagcheck.clear_cache()
            return bagio.read_joint_states(bag)
        t_first, js = _best(first_read, repeat)
        rows.append(('decode: read_joint_states, first read of the bag (check included)',
                     n / t_first, t_first, err(js.theta, js.s)))
        k_rec = [0]

        def recover() -> Any:
            k_rec[0] += 1
            return bagio.recover_bag(zbag, tmp / f'rec{k_rec[0]}')
        t_rec, counts = _best(recover, 1)
        rows.append(('bag recover of the zstd bag (walk, check, copy)', n / t_rec, t_rec,
                     f'{counts[bagio.JOINT_STATES]} of {n} samples kept'))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    lines = [
        '# bagio benchmark (`benchmarks/bench_bagio.py`)',
        '',
        f'Machine: {machine}.',
        f'{n} JointState samples (default scene, 5 features, 1 um noise); best of '
        f'{repeat} runs where marked in the code (rosbags/mcap decoders: 1 run).',
        '',
        '| step | msgs/s | time [s] for all samples | error / note |',
        '|---|---:|---:|---|',
    ]
    for name, rate, seconds, note in rows:
        lines.append(f'| {name} | {rate:,.0f} | {seconds:.3f} | {note} |')
    lines += ['', f'Fast path vs rosbags AnyReader + deserialize: x{t_any / t_fast:.1f}; '
              f'vs mcap_ros2: x{t_mcap / t_fast:.1f}.', '']
    return '\n'.join(lines)


def _stream(run_: Any) -> Any:
    from cam_metrology.simulation.bench import iter_joint_state_messages

    return iter_joint_state_messages(run_)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--samples', type=int, default=200_000)
    parser.add_argument('--repeat', type=int, default=3)
    parser.add_argument('--no-write', action='store_true', help='do not write results')
    args = parser.parse_args(argv or [])
    text = run(args.samples, args.repeat)
    print(text)
    if not args.no_write:
        save_results(RESULTS, text)


if __name__ == '__main__':
    import sys

    main(sys.argv[1:])
