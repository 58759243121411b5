"""Sustained live load: bench-sim -> metrology node + recorder, nothing lost?

Run: ``.venv/bin/python -m benchmarks.bench_ros_sustained [RATE ...]`` (default rates
5000 10000 20000 30000 samples/s; about 1 minute per rate); writes
``benchmarks/results/ros_sustained.md``.

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


def _sim_params(work: Path, rate: float, need: int) -> Path:
    path = work / f'sim_{int(rate)}.yaml'
    path.write_text(yaml.safe_dump({'bench_sim': {'ros__parameters': {
        'rate': float(rate), 'samples_per_rev': 3600, 'revolutions': REVOLUTIONS,
        'feature_gap': 0.0, 'wait_subscribers': need, 'match_timeout': 60.0,
        'ack_timeout': 30.0}}}), encoding='utf-8')
    return path


def _sim_stats(log: Path) -> tuple[int, float]:
    text = log.read_text(encoding='utf-8', errors='replace')
    m = re.search(r'sent (\d+) samples in ([\d.]+) s', text)
    if not m:
        raise RuntimeError(f'bench-sim failed:\n{text[-2000:]}')
    return int(m.group(1)), int(m.group(1)) / max(float(m.group(2)), 1e-9)


def _recorder_loss(bag: Path) -> int | None:
    """What the recorder says it lost on /bench/joint_states (its loss record in the bag)."""
    from cam_metrology import bagio
    if '/diagnostics' not in bagio.bag_topics(bag):
        return None
    lost = None
    for m in bagio.iter_messages(bag, ['/diagnostics']):
        for st in bagio.statuses_from_msg(m.msg):
            values = st.get('values', {})
            if 'lost/bench/joint_states' in values:
                lost = int(values['lost/bench/joint_states'])
    return lost


def one_rate(work: Path, env: dict[str, str], rate: float) -> dict[str, Any]:
    """One sustained run at ``rate``; see the module doc."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.node import Node
    from std_msgs.msg import String

    from cam_metrology import bagio
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
        sim = _cam_bench(['run', 'bench-sim', '--params', str(_sim_params(work, rate, 2))],
                         env, sim_log)
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
    recorded = bagio.bag_topics(bag).get('/bench/joint_states', ('', 0))[1]
    lat = sorted(results[f][0] - t for f, t in done.items() if f in results)
    return {
        'rate': rate, 'sent': sent, 'achieved': achieved,
        'met_lost': sent - received, 'met_said': said_report, 'split': split,
        'rec_lost': sent - recorded, 'rec_said': _recorder_loss(bag),
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

    rates = [float(a) for a in (argv if argv is not None else sys.argv[1:])] or list(RATES)
    machine = describe()
    t0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix='bench_sustained_'))
    env = isolated_env(claim_domain(), str(work / 'ros_log'))
    for key in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOG_DIR'):
        os.environ[key] = env[key]
    rows = []
    for rate in rates:
        r = one_rate(work, env, rate)
        print(f'  {rate:7.0f}/s: {r}', flush=True)
        rows.append(r)
    lines = ['# Sustained live load (`python -m benchmarks.bench_ros_sustained`)', '',
             f'Machine: {machine}; load average {os.getloadavg()[0]:.2f} at the end; '
             f'total {time.perf_counter() - t0:.0f} s. bench-sim, the metrology node and '
             'the recorder run as separate processes on these cores (the demo\'s '
             'arrangement), 5 features x 21 600 samples = 108 000 samples per rate, '
             'no pause between features.', '',
             '| asked [samples/s] | achieved [samples/s] | metrology lost (says) | '
             'recorder lost (says) | CPU sim / metrology / recorder [% of a core] | '
             'CPU per sample sim / metrology / recorder [us] | '
             'feature end -> result median / max [s] | features (partial) |',
             '|---|---|---|---|---|---|---|---|']
    for r in rows:
        c = r['cpu']
        lines.append(f'| {r["rate"]:.0f} | {r["achieved"]:.0f} | {r["met_lost"]} '
                     f'({r["met_said"]}) | {r["rec_lost"]} ({r["rec_said"]}) | '
                     f'{c["bench-sim"]:.0f} / {c["metrology"]:.0f} / {c["recorder"]:.0f} | '
                     + ' / '.join(f'{c[k] * 1e4 / r["achieved"]:.0f}'
                                  for k in ('bench-sim', 'metrology', 'recorder')) + ' | '
                     f'{r["lat_med"]:.2f} / {r["lat_max"]:.2f} | {r["features"]} '
                     f'({", ".join(r["partial"]) or "none"}) |')
    lines += ['', 'Lost = samples sent minus samples the node got (metrology: the sum of '
              '`samples_received` of the features of its final report, so a feature split '
              'by a pause counts its missing parts here and is listed as partial; '
              'recorder: the bag\'s '
              '/bench/joint_states count), counted here independently of the node; in '
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
    save_results(RESULTS, text)


if __name__ == '__main__':
    main()
