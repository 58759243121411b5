"""Sustained live load: bench-sim -> metrology node + recorder, nothing lost?

Run: ``.venv/bin/python -m benchmarks.bench_ros_sustained [RATE ...]`` (default rates
5000 10000 20000 30000 samples/s; about 1 minute per rate); writes
``benchmarks/results/ros_sustained.md``. Blocks of samples:
``.venv/bin/python -m benchmarks.bench_ros_sustained --blocks 1000 [--seconds 8]
[RATE ...]`` (default rates 50 000 100 000 200 000 400 000): bench-sim publishes
JointTrajectory blocks of 1000 samples on /bench/joint_trajectory, each feature long
enough for the stream to last about ``--seconds``; writes
``benchmarks/results/ros_sustained_blocks.md``.

Per rate, in an isolated ROS domain (claimed 1..100, localhost discovery), exactly the
demo's arrangement on this machine: ``cam-bench run metrology``, ``cam-bench run
recorder`` and ``cam-bench run bench-sim`` as subprocesses; the simulator streams the
default scene (four lobes and the dowel pin) with 6 revolutions of 3600 samples per
feature (108 000 samples) at the rate, no pause between features. Measured:

* achieved rate: samples / streaming time, from the simulator's own log line;
* lost per node, counted independently of the nodes: metrology = samples sent minus
  the sum of ``samples_received`` of its per-feature results; recorder = samples sent
  minus the /bench/joint_states messages in its bag. Beside it, what each node says it
  lost (its report / its bag's loss record): they must agree;
* CPU per node: utime + stime from /proc over the streaming window, in % of one core;
* end-of-feature-to-result latency: this process receives every /bench/feature_done
  and /metrology/result; per feature the time from the first to the second (median
  and max over the features).
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import yaml

CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'
RESULTS = Path(__file__).resolve().parent / 'results' / 'ros_sustained.md'
RATES = (5000.0, 10000.0, 20000.0, 30000.0)
BLOCK_RATES = (50000.0, 100000.0, 200000.0, 400000.0)
BLOCK_RESULTS = RESULTS.with_name('ros_sustained_blocks.md')
REVOLUTIONS = 6.0            # per feature: 5 features x 6 x 3600 = 108 000 samples
TICK = os.sysconf('SC_CLK_TCK')


def _cam_bench(args: list[str], env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    handle = open(log, 'wb')  # noqa: SIM115 (closed by the child's exit)
    return subprocess.Popen([sys.executable, '-c', CLI, *args], env=env, stdout=handle,
                            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)


def _cpu_s(pid: int) -> float:
    """utime + stime of a process [s] (NaN once it is gone)."""
    try:
        with open(f'/proc/{pid}/stat', encoding='ascii') as f:
            fields = f.read().rsplit(')', 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / TICK
    except (OSError, IndexError, ValueError):
        return float('nan')


class CpuSampler(threading.Thread):
    """Samples the CPU time of some processes every 0.2 s."""

    def __init__(self, pids: dict[str, int]) -> None:
        super().__init__(daemon=True)
        self.pids = pids
        self.samples: list[tuple[float, dict[str, float]]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            self.samples.append((time.monotonic(),
                                 {k: _cpu_s(p) for k, p in self.pids.items()}))
            self.stop.wait(0.2)

    def percent(self, name: str, t0: float, t1: float) -> float:
        """CPU of ``name`` over [t0, t1] in % of one core (nearest samples)."""
        inside = [(t, c[name]) for t, c in self.samples if t0 <= t <= t1 and c[name] == c[name]]
        if len(inside) < 2:
            return float('nan')
        (ta, ca), (tb, cb) = inside[0], inside[-1]
        return 100.0 * (cb - ca) / max(tb - ta, 1e-9)


def _sim_params(work: Path, rate: float, need: int, per_message: int = 1,
                revolutions: float = REVOLUTIONS) -> Path:
    path = work / f'sim_{int(rate)}.yaml'
    path.write_text(yaml.safe_dump({'bench_sim': {'ros__parameters': {
        'rate': float(rate), 'samples_per_rev': 3600, 'revolutions': float(revolutions),
        'feature_gap': 0.0, 'wait_subscribers': need, 'match_timeout': 60.0,
        'ack_timeout': 30.0, 'samples_per_message': int(per_message)}}}),
        encoding='utf-8')
    return path


def _sim_stats(log: Path) -> tuple[int, float]:
    text = log.read_text(encoding='utf-8', errors='replace')
    m = re.search(r'sent (\d+) samples in ([\d.]+) s', text)
    if not m:
        raise RuntimeError(f'bench-sim failed:\n{text[-2000:]}')
    return int(m.group(1)), int(m.group(1)) / max(float(m.group(2)), 1e-9)


def _recorder_loss(bag: Path, blocks: bool = False) -> int | None:
    """What the recorder says it lost on /bench/joint_states (samples), or on
    /bench/joint_trajectory (``blocks``: its samples estimate), from its loss record in
    the bag."""
    from cam_metrology import bagio
    if '/diagnostics' not in bagio.bag_topics(bag):
        return None
    key = 'samples_lost/bench/joint_trajectory' if blocks else 'lost/bench/joint_states'
    lost = None
    for m in bagio.iter_messages(bag, ['/diagnostics']):
        for st in bagio.statuses_from_msg(m.msg):
            values = st.get('values', {})
            if key in values:
                lost = int(values[key])
    return lost


def _bag_samples(bag: Path) -> int:
    """Samples in a bag (both sample topics), decoded from the bag itself."""
    from cam_metrology import bagio
    summary = bagio.JointSummary()
    for block in bagio.iter_joint_states(bag):
        summary.add(block)
    return summary.count


def one_rate(work: Path, env: dict[str, str], rate: float, per_message: int = 1,
             seconds: float = 0.0) -> dict[str, Any]:
    """One sustained run at ``rate``; see the module doc. ``per_message`` > 1: blocks;
    ``seconds`` > 0: revolutions per feature for a stream of about that long."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.node import Node
    from std_msgs.msg import String

    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.wire.topics import qos_of

    tag = f'{int(rate)}'
    bag = work / f'bag_{tag}'
    done: dict[str, float] = {}
    results: dict[str, tuple[float, dict[str, str]]] = {}
    reports: list[dict[str, Any]] = []

    def on_result(msg: Any) -> None:
        now = time.monotonic()
        for st in msg.status:
            if st.hardware_id in ('lobe', 'dowel_pin') and st.name not in results:
                results[st.name] = (now, {kv.key: kv.value for kv in st.values})

    proc = RosProcess(handle_signals=False)
    met = _cam_bench(['run', 'metrology'], env, work / f'met_{tag}.log')
    rec = _cam_bench(['run', 'recorder', '--ros-args', '-p', f'output:={bag}'], env,
                     work / f'rec_{tag}.log')
    sim = None
    try:
        node = proc.add(Node('sustained_bench', context=proc.context))
        node.create_subscription(String, '/bench/feature_done',
                                 lambda m: done.setdefault(m.data, time.monotonic()),
                                 profile(qos_of('/bench/feature_done')))
        node.create_subscription(DiagnosticArray, '/metrology/result', on_result,
                                 profile(qos_of('/metrology/result')))
        node.create_subscription(String, '/metrology/report',
                                 lambda m: reports.append(json.loads(m.data)),
                                 profile(qos_of('/metrology/report')))
        sim_log = work / f'sim_{tag}.log'
        revs = max(1.0, round(rate * seconds / (5 * 3600))) if seconds > 0 else REVOLUTIONS
        sim = _cam_bench(['run', 'bench-sim', '--params',
                          str(_sim_params(work, rate, 2, per_message, revs))], env, sim_log)
        cpu = CpuSampler({'metrology': met.pid, 'recorder': rec.pid, 'bench-sim': sim.pid})
        cpu.start()
        proc.spin_until(lambda: sim.poll() is not None, 600.0)
        t_end = max(done.values()) if done else time.monotonic()
        proc.spin_until(lambda: len(results) >= len(done) > 0 and bool(reports), 60.0)
        sent, achieved = _sim_stats(sim_log)
        t_start = t_end - sent / achieved
    finally:
        for child in (met, rec):
            child.send_signal(2)
        for child in (met, rec):
            try:
                child.wait(60)
            except subprocess.TimeoutExpired:
                child.kill()
        if sim is not None and sim.poll() is None:
            sim.kill()
        proc.close()
    cpu.stop.set()
    report = reports[-1] if reports else {}
    feats = report.get('features', {})
    # independent: the samples behind each feature's final result (a feature split by a
    # pause shows up here too: only its last part is in the result)
    received = sum(int(f.get('samples_received') or 0) for f in feats.values())
    said_report = report.get('input', {}).get('samples_lost')
    split = sorted(f for f, v in feats.items() if 'parts' in str(v.get('partial_reason', '')))
    recorded = _bag_samples(bag)
    lat = sorted(results[f][0] - t for f, t in done.items() if f in results)
    return {
        'rate': rate, 'sent': sent, 'achieved': achieved,
        'met_lost': sent - received, 'met_said': said_report, 'split': split,
        'rec_lost': sent - recorded, 'rec_said': _recorder_loss(bag, per_message > 1),
        'loadavg': open('/proc/loadavg', encoding='ascii').read().split()[0],
        'cpu': {k: cpu.percent(k, t_start, t_end)
                for k in ('bench-sim', 'metrology', 'recorder')},
        'lat_med': lat[len(lat) // 2] if lat else float('nan'),
        'lat_max': lat[-1] if lat else float('nan'),
        'features': f'{len(results)}/{len(done)}',
        'partial': sorted(f for f, v in feats.items() if v.get('partial')),
    }


def main(argv: list[str] | None = None) -> None:
    """Run every rate and write the results table."""
    from benchmarks.machine import describe, save_results
    from cam_metrology.host.isolation import claim_domain, isolated_env

    import argparse
    parser = argparse.ArgumentParser(prog='python -m benchmarks.bench_ros_sustained')
    parser.add_argument('rates', nargs='*', type=float, help='samples/s asked')
    parser.add_argument('--blocks', type=int, default=1, metavar='N',
                        help='samples per message (N > 1: JointTrajectory blocks)')
    parser.add_argument('--seconds', type=float, default=8.0, metavar='S',
                        help='blocks: stream length per rate [s] (default 8)')
    args = parser.parse_args(argv if argv is not None else sys.argv[1:])
    blocks = args.blocks > 1
    rates = args.rates or list(BLOCK_RATES if blocks else RATES)
    machine = describe()
    t0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix='bench_sustained_'))
    env = isolated_env(claim_domain(), str(work / 'ros_log'))
    for key in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOG_DIR'):
        os.environ[key] = env[key]
    rows = []
    for rate in rates:
        r = one_rate(work, env, rate, args.blocks, args.seconds if blocks else 0.0)
        print(f'  {rate:7.0f}/s: {r}', flush=True)
        rows.append(r)
    what = (f'blocks of {args.blocks} samples (JointTrajectory on /bench/joint_trajectory'
            f'), each rate streamed for about {args.seconds:g} s' if blocks else
            'one JointState per sample, 5 features x 21 600 samples = 108 000 samples per '
            'rate')
    lines = [f'# Sustained live load (`python -m benchmarks.bench_ros_sustained'
             f'{" --blocks " + str(args.blocks) if blocks else ""}`)', '',
             f'Machine: {machine}; load average {os.getloadavg()[0]:.2f} at the end; '
             f'total {time.perf_counter() - t0:.0f} s. bench-sim, the metrology node and '
             'the recorder run as separate processes on these cores (the demo\'s '
             f'arrangement), {what}, no pause between features.', '',
             '| asked [samples/s] | achieved [samples/s] | metrology lost (says) | '
             'recorder lost (says) | CPU sim / metrology / recorder [% of a core] | '
             'CPU per sample sim / metrology / recorder [us] | '
             'feature end -> result median / max [s] | features (partial) | '
             'load average (1 min) |',
             '|---|---|---|---|---|---|---|---|---|']
    for r in rows:
        c = r['cpu']
        lines.append(f'| {r["rate"]:.0f} | {r["achieved"]:.0f} | {r["met_lost"]} '
                     f'({r["met_said"]}) | {r["rec_lost"]} ({r["rec_said"]}) | '
                     f'{c["bench-sim"]:.0f} / {c["metrology"]:.0f} / {c["recorder"]:.0f} | '
                     + ' / '.join(f'{c[k] * 1e4 / r["achieved"]:.{1 if blocks else 0}f}'
                                  for k in ('bench-sim', 'metrology', 'recorder')) + ' | '
                     f'{r["lat_med"]:.2f} / {r["lat_max"]:.2f} | {r["features"]} '
                     f'({", ".join(r["partial"]) or "none"}) | {r["loadavg"]} |')
    lines += ['', 'Lost = samples sent minus samples the node got (metrology: the sum of '
              '`samples_received` of the features of its final report, so a feature split '
              'by a pause counts its missing parts here and is listed as partial; '
              'recorder: the samples decoded from its bag, both sample topics), '
              'counted here independently of the node; in '
              'brackets what the node itself reported (`input.samples_lost` of the '
              'metrology report, the recorder\'s loss record in its bag). Latency: from '
              'this process receiving a feature\'s /bench/feature_done to receiving its '
              '/metrology/result. CPU per sample = CPU time of the process over the '
              'streaming window / samples: what a node costs whatever the load, so '
              'the cores a given rate needs are rate x cost (20 000/s at 50 us = one '
              'core). Asked for more than the consumers take, the keep-all stream '
              'is held back (bench-sim\'s publish blocks, 100 ms each time): the '
              'achieved rate drops, nothing is lost.']
    text = '\n'.join(lines) + '\n'
    print(text)
    save_results(BLOCK_RESULTS if blocks else RESULTS, text)


if __name__ == '__main__':
    main()
