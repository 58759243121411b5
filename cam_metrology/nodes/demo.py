"""`cam-bench demo`: the whole live pipeline in an isolated ROS domain.

Design (why subprocesses): every node runs as its own ``cam-bench run NODE`` process,
exactly as it would on a bench PC. That gives each node its own GIL (the simulator's
paced loop, the recorder and the metrology fits run on separate cores of this 2-core
machine), exercises the same command a user runs, and lets the demo stop nodes one by
one with SIGINT in data-flow order, which is what makes the shutdown lossless:

1. claim a ROS domain (1..100, flock), ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``,
   a temporary ``ROS_LOG_DIR``; children inherit them (``isolation.isolated_env``);
2. start the recorder, the core nodes (missing cores are reported, never faked) and
   the simulator at once (Python start-up and the simulation overlap); the simulator
   waits (deadline) until the recorder and the sample consumers matched its topics
   and the graph shows every downstream subscription (``wait_graph``: recorder,
   monitor, reconstruction on /metrology/lift, ...) before its first sample;
3. progress: features done, per-feature metrology results, other nodes' statuses;
4. completion: simulator exited 0 and the metrology report (transient local) arrived,
   or the simulator finished and the report deadline passed;
5. stop: SIGINT to metrology, reconstruction, dynamics in that order (each drains its
   queue, calls ``finish`` and waits until its outputs are acknowledged before it
   exits), then to the recorder (drains, closes the bag); SIGTERM then SIGKILL only
   after deadlines;
6. print the bag path, its topic counts and the per-feature report against
   /bench/truth. Exit code 0, or 1 with the reason.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, TextIO

from cam_metrology.nodes.topics import AdaptiveSubscriptions, profile
from cam_metrology.wire.topics import (DYNAMICS_RESULT, FEATURE_DONE, JOINT_STATES,
                                       METROLOGY_REPORT, METROLOGY_RESULT, OUTPUT_TOPICS,
                                       RECONSTRUCTION_RESULT, TOPICS, TRUTH)

STATUS_TOPICS = (METROLOGY_RESULT, RECONSTRUCTION_RESULT, DYNAMICS_RESULT)


@dataclass
class DemoOptions:
    """What ``cam-bench demo`` was asked to do."""

    scene: str | None = None
    out: str | None = None
    rate: float | None = None
    timeout: float = 0.0            # s, 0: default (600 s)
    json_out: str | None = None
    events_executor: bool = False   # recorder executor (see `cam-bench demo --help`)
    keep_logs: bool = False
    sim_params: list[str] = field(default_factory=list)   # 'name:=value' for bench-sim
    startup_timeout: float = 60.0   # s until every node is connected (bench-sim waits)
    report_timeout: float = 30.0    # s after the simulator finished
    stream: TextIO = field(default_factory=lambda: sys.stdout)


@dataclass
class Child:
    """A node subprocess with its log file."""

    name: str
    proc: subprocess.Popen[bytes]
    log: Path

    def tail(self, lines: int = 15) -> str:
        """The last lines of its log."""
        try:
            text = self.log.read_text(encoding='utf-8', errors='replace').splitlines()
        except OSError:
            return ''
        return '\n'.join('    ' + line for line in text[-lines:])


class DemoFailure(RuntimeError):
    """The demo could not complete; the message is the reason."""


def _die_with_parent() -> None:
    """In the child before exec: SIGTERM when the demo process dies (Linux prctl
    PR_SET_PDEATHSIG), so a killed demo never leaves nodes behind."""
    try:
        import ctypes
        ctypes.CDLL('libc.so.6', use_errno=True).prctl(1, int(signal.SIGTERM), 0, 0, 0)
    except (OSError, AttributeError):
        pass


def start_child(name: str, argv: list[str], env: dict[str, str], log_dir: Path) -> Child:
    """``cam-bench run NAME ...`` in its own session (a terminal Ctrl-C reaches only the
    demo, which then stops the children in order); SIGTERM if the demo dies."""
    log = log_dir / f'{name}.log'
    with open(log, 'wb') as handle:
        proc = subprocess.Popen([sys.executable, '-m', 'cam_metrology', 'run', name, *argv],
                                env=env, stdout=handle, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True,
                                preexec_fn=_die_with_parent)
    return Child(name, proc, log)


def stop_child(child: Child, sigint_wait: float = 20.0, term_wait: float = 5.0,
               waiter: Callable[[Callable[[], bool], float], Any] | None = None) -> int:
    """SIGINT, wait; SIGTERM, wait; SIGKILL. Returns the exit code. ``waiter(cond, s)``
    waits for ``cond`` (default: block on the process), e.g. while spinning a node."""
    for sig, wait in ((signal.SIGINT, sigint_wait), (signal.SIGTERM, term_wait),
                      (signal.SIGKILL, 5.0)):
        if child.proc.poll() is not None:
            break
        child.proc.send_signal(sig)
        if waiter is not None:
            waiter(lambda: child.proc.poll() is not None, wait)
            continue
        try:
            child.proc.wait(wait)
        except subprocess.TimeoutExpired:
            continue
    return child.proc.wait()


def truth_angle_deg(truth: dict[str, Any], fid: str) -> float | None:
    """The true encoder angle [deg, 0..360) of feature ``fid`` in the /bench/truth JSON
    (``features.<id>.angle_deg``, as ``simulate`` writes it), None if it has none."""
    feats = truth.get('features')
    entry = feats.get(fid) if isinstance(feats, dict) else None
    value = entry.get('angle_deg') if isinstance(entry, dict) else None
    return float(value) % 360.0 if isinstance(value, (int, float)) else None


def wrap180(deg: float) -> float:
    """Wrap an angle difference to (-180, 180]."""
    out = (deg + 180.0) % 360.0 - 180.0
    return 180.0 if out == -180.0 else out


def truth_phase_error_deg(truth: dict[str, Any], fid: str) -> float | None:
    """The true phase error [deg] of lobe ``fid`` in the /bench/truth JSON, if any."""
    feats = truth.get('features')
    entry = feats.get(fid) if isinstance(feats, dict) else None
    value = entry.get('phase_error_deg') if isinstance(entry, dict) else None
    return float(value) if isinstance(value, (int, float)) else None


def report_lines(report: dict[str, Any] | None, truth: dict[str, Any] | None) -> list[str]:
    """The per-feature table: measured angle, measured phase error and true angle [deg];
    the angle's std, the angle error (measured - true) and the phase error minus the
    true phase error in arc-seconds (the resolution the bench is about)."""
    if not report:
        return ['no metrology report']
    lines = [f'camshaft {report.get("camshaft_id", "?")}   (angles in degrees; _as: in '
             'arc-seconds; err = measured - /bench/truth)',
             f'{"feature":<12}{"angle":>11}{"std_as":>10}{"phase_err":>11}'
             f'{"true_angle":>12}{"angle_err_as":>14}{"phase_err_err_as":>18}']

    def num(value: Any, width: int, digits: int) -> str:
        return (f'{value:>{width}.{digits}f}' if isinstance(value, (int, float))
                else f'{"-":>{width}}')

    def arcsec(deg: Any) -> float | None:
        return deg * 3600.0 if isinstance(deg, (int, float)) else None

    def diff(a: Any, b: float | None) -> float | None:
        return wrap180(a - b) if isinstance(a, (int, float)) and b is not None else None

    for fid, feat in (report.get('features') or {}).items():
        feat = feat if isinstance(feat, dict) else {}
        angle, phase_err = feat.get('angle_deg'), feat.get('phase_error_deg')
        true = truth_angle_deg(truth or {}, fid)
        std = feat.get('angle_std_deg')
        err = diff(angle, true)
        perr = diff(phase_err, truth_phase_error_deg(truth or {}, fid))
        row = (f'{fid:<12}{num(angle, 11, 4)}{num(arcsec(std), 10, 2)}'
               f'{num(phase_err, 11, 4)}{num(true, 12, 4)}{num(arcsec(err), 14, 2)}'
               f'{num(arcsec(perr), 18, 2)}')
        if feat.get('error') or feat.get('reason'):
            row += f'  FAILED: {feat.get("error") or feat.get("reason")}'
        lines.append(row)
    for item in report.get('skipped') or []:
        if isinstance(item, dict):
            lines.append(f'skipped: {item.get("what")} ({item.get("why")})')
    from cam_metrology.metrology.tolerances import verdict_lines
    return verdict_lines(report) + lines


def _fmt(text: str, digits: int) -> str:
    """A number given as text, with ``digits`` decimals (unchanged if not a number)."""
    try:
        return f'{float(text):.{digits}f}'
    except ValueError:
        return text


def _fmt_arcsec(text: str) -> str:
    """An angle in degrees given as text, in arc-seconds with 2 decimals."""
    try:
        return f'{float(text) * 3600.0:.2f}'
    except ValueError:
        return text


class DemoMonitor:
    """In-process rclpy node that watches progress and collects report and truth."""

    def __init__(self, proc: Any, say: Callable[[str], None]) -> None:
        from rclpy.node import Node
        from std_msgs.msg import String

        self.node = proc.add(Node('demo_monitor', context=proc.context))
        self.say = say
        self.report: dict[str, Any] | None = None
        self.truth: dict[str, Any] | None = None
        self.features_done: list[str] = []
        self.statuses: dict[str, int] = {t: 0 for t in STATUS_TOPICS}
        self.callbacks_run = 0
        sub = self.node.create_subscription
        sub(String, FEATURE_DONE, self._on_done, profile(TOPICS[FEATURE_DONE][1]))
        sub(String, TRUTH, self._on_truth, profile(TOPICS[TRUTH][1]))
        sub(String, METROLOGY_REPORT, self._on_report, profile(TOPICS[METROLOGY_REPORT][1]))
        self._adaptive = AdaptiveSubscriptions(self.node, self._subscribe_status)
        for topic in STATUS_TOPICS:
            self._adaptive.add(topic, TOPICS[topic][0])

    def _subscribe_status(self, topic: str, _type: str, qos: Any) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        self.node.create_subscription(DiagnosticArray, topic,
                                      lambda m, t=topic: self._on_status(t, m), profile(qos))

    def _on_done(self, msg: Any) -> None:
        self.callbacks_run += 1
        self.features_done.append(msg.data)
        self.say(f'bench: feature {msg.data} done ({len(self.features_done)} so far)')

    def _on_truth(self, msg: Any) -> None:
        self.callbacks_run += 1
        try:
            self.truth = json.loads(msg.data)
        except ValueError:
            self.truth = {}

    def _on_report(self, msg: Any) -> None:
        self.callbacks_run += 1
        first = self.report is None
        try:
            self.report = json.loads(msg.data)
        except ValueError:
            self.report = {'unparsed': msg.data}
        if first:
            self.say('metrology: report received')

    def _on_status(self, topic: str, msg: Any) -> None:
        self.callbacks_run += 1
        self.statuses[topic] += 1
        node = topic.split('/')[1]
        for st in msg.status:
            values = {kv.key: kv.value for kv in st.values}
            level = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}.get(
                st.level[0] if isinstance(st.level, bytes) else int(st.level), '?')
            if st.name.startswith('skipped/'):
                what = st.name[len('skipped/'):].split('/')
                subject = what[-1] if len(what) > 1 else what[0]
                self.say(f'{node}: {subject} skipped'
                         + (f' ({st.message})' if st.message else ''))
                continue
            detail = ''
            if 'angle_deg' in values:
                detail = f' angle {_fmt(values["angle_deg"], 4)} deg'
                if 'angle_std_deg' in values:
                    detail += f' +- {_fmt_arcsec(values["angle_std_deg"])} arcsec'
            self.say(f'{node}: {st.name} {level}{detail}'
                     + (f' ({st.message})' if st.message and level != 'OK' else ''))


def downstream_subscriptions(core_classes: list[Any]) -> dict[str, int]:
    """Subscriptions the graph must show on each output topic of the cores that run,
    before the first sample: the recorder, this monitor (statuses, report) and every
    core that consumes another core's output (e.g. reconstruction on /metrology/lift).
    Output subscriptions appear once the subscriber has discovered the publisher
    (``topics.AdaptiveSubscriptions``), so this also waits for that discovery."""
    published = {t for cls in core_classes for t in getattr(cls, 'publications', {})}
    need = {topic: 1 for topic in OUTPUT_TOPICS if topic in published}
    for topic in STATUS_TOPICS + (METROLOGY_REPORT,):
        if topic in need:
            need[topic] += 1
    for cls in core_classes:
        for topic in getattr(cls, 'subscriptions', {}):
            if topic in need:
                need[topic] += 1
    return need


def run_demo(opts: DemoOptions) -> int:
    """Run the demo; returns the exit code (0 ok, 1 failure with the reason printed)."""
    from cam_metrology.host.isolation import claim_domain, isolated_env
    from cam_metrology.offline.registry import CORES
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.host.paths import default_scene_path

    t_start = time.monotonic()
    out = opts.stream

    def say(text: str) -> None:
        try:
            print(f'[{time.monotonic() - t_start:6.1f} s] {text}', file=out, flush=True)
        except OSError:   # a closed pipe (`| head`) must not skip stopping the nodes
            pass

    scene = Path(opts.scene) if opts.scene else default_scene_path()
    if not scene.is_file():
        raise FileNotFoundError(f'scene file {scene} does not exist')
    from cam_metrology.scene.parse import load_scene
    load_scene(scene)   # a bad scene: InputError now, before any node or bag directory
    bag = Path(opts.out) if opts.out else Path('demo-out') / time.strftime(
        'demo_%Y%m%dT%H%M%SZ', time.gmtime())
    if bag.exists():
        from cam_design.errors import InputError
        raise InputError('--out', str(bag), 'a path that does not exist yet')
    bag.parent.mkdir(parents=True, exist_ok=True)
    domain = claim_domain()
    log_dir = Path(tempfile.mkdtemp(prefix='cam_bench_demo_'))
    env = isolated_env(domain, str(log_dir / 'ros'))
    for key in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOG_DIR'):
        os.environ[key] = env[key]
    os.environ.pop('ROS_LOCALHOST_ONLY', None)
    say(f'ROS domain {domain} (localhost only), node logs in {log_dir}')

    cores: list[str] = []
    core_classes: list[Any] = []
    need_samples = 1   # the recorder
    for name, cls in CORES.items():
        cores.append(name)
        core_classes.append(cls)
        need_samples += JOINT_STATES in getattr(cls, 'subscriptions', {})
    children: dict[str, Child] = {}
    code, reason = 0, ''
    proc = RosProcess(domain_id=domain)
    monitor: DemoMonitor | None = None
    try:
        monitor = DemoMonitor(proc, say)
        rec_args = ['--ros-args', '-p', f'output:={bag.resolve()}']
        if opts.events_executor:
            rec_args = ['--events-executor'] + rec_args
        children['recorder'] = start_child('recorder', rec_args, env, log_dir)
        for name in cores:
            children[name] = start_child(name, [], env, log_dir)
        graph = ','.join(f'{t}={n}' for t, n in downstream_subscriptions(core_classes).items())
        sim_args = ['--ros-args', '-p', f'scene_file:={scene.resolve()}',
                    '-p', f'wait_subscribers:={need_samples}', '-p', f'wait_graph:={graph}',
                    '-p', f'match_timeout:={opts.startup_timeout}']
        if opts.rate is not None:
            sim_args += ['-p', f'rate:={float(opts.rate)}']
        for item in opts.sim_params:
            sim_args += ['-p', item]
        children['bench-sim'] = start_child('bench-sim', sim_args, env, log_dir)
        say(f'started recorder, {", ".join(cores) or "no core node"} and bench-sim '
            f'({scene.name}); bench-sim waits until they are all connected')
        deadline = t_start + (opts.timeout or 600.0)
        sim = children['bench-sim']
        proc.spin_until(lambda: sim.proc.poll() is not None
                        or _any_exited(children, skip=('bench-sim',)),
                        max(0.0, deadline - time.monotonic()))
        _check_children(children, say, skip=('bench-sim',))
        if proc.stopping:
            raise DemoFailure('interrupted')
        if sim.proc.poll() is None:
            raise DemoFailure(f'bench-sim still running at the deadline '
                              f'({opts.timeout or 600.0:.0f} s)')
        if sim.proc.returncode != 0:
            raise DemoFailure(f'bench-sim exited with code {sim.proc.returncode}:\n'
                              + sim.tail())
        say(f'bench-sim finished: {len(monitor.features_done)} features')
        if 'metrology' in cores:
            left = min(opts.report_timeout, max(0.0, deadline - time.monotonic()))
            if not proc.spin_until(lambda: monitor.report is not None, left):
                say(f'no metrology report {left:.0f} s after the last sample; stopping the '
                    'nodes (finish() flushes it)')
    except DemoFailure as exc:
        code, reason = 1, str(exc)
    finally:
        exits = _shutdown(children, proc, monitor, say)
        proc.close()
    report = monitor.report if monitor is not None else None
    if code == 0 and 'metrology' in cores and report is None:
        code, reason = 1, 'the metrology node published no report'
    lost = (report or {}).get('input', {}).get('samples_lost') if isinstance(report, dict) else 0
    if code == 0 and lost:
        code, reason = 1, (f'the metrology node lost {lost} samples on /bench/joint_states '
                           '(features marked partial in the report)')
    bad = {n: c for n, c in exits.items() if c not in (0, -signal.SIGINT)}
    if code == 0 and bad:
        code = 1
        reason = 'nodes failed: ' + ', '.join(f'{n} exit {c}' for n, c in bad.items())
        for name in bad:
            reason += f'\n  {name} log ({children[name].log}):\n{children[name].tail()}'
    counts = _bag_counts(bag)
    if counts is None:
        code, reason = 1, (reason + '\n' if reason else '') + f'bag {bag} is not readable'
    _print_summary(out, bag, counts, monitor, cores, time.monotonic() - t_start)
    if opts.json_out and report is not None:
        text = json.dumps(report, indent=2)
        if opts.json_out == '-':
            print(text, file=out)
        else:
            from cam_metrology.inputs.files import write_output
            write_output(opts.json_out, text + '\n', '--json')
    if code:
        print(f'cam-bench demo: FAILED: {reason}', file=sys.stderr, flush=True)
        print(f'node logs kept in {log_dir}', file=sys.stderr, flush=True)
    elif not opts.keep_logs:
        shutil.rmtree(log_dir, ignore_errors=True)
    return code


def _any_exited(children: dict[str, Child], skip: tuple[str, ...] = ()) -> bool:
    return any(c.proc.poll() is not None for n, c in children.items() if n not in skip)


def _check_children(children: dict[str, Child], say: Callable[[str], None],
                    skip: tuple[str, ...] = ()) -> None:
    for name, child in children.items():
        if name not in skip and child.proc.poll() is not None:
            raise DemoFailure(f'{name} exited early with code {child.proc.returncode}:\n'
                              + child.tail())


def _shutdown(children: dict[str, Child], proc: Any, monitor: Any,
              say: Callable[[str], None]) -> dict[str, int]:
    """Stop in data-flow order: cores upstream first, then the recorder."""
    exits: dict[str, int] = {}
    order = [n for n in ('bench-sim', 'metrology', 'reconstruction', 'dynamics', 'recorder')
             if n in children]
    for name in order:
        child = children[name]
        try:
            if name == 'recorder' and monitor is not None:
                proc.drain(lambda: monitor.callbacks_run, idle=0.3, limit=3.0)
        finally:   # whatever happens, every child is stopped
            already = child.proc.poll() is not None
            # the monitor keeps spinning meanwhile (progress lines stay in order)
            exits[name] = stop_child(child, waiter=_spin_waiter(proc))
        if not already:
            say(f'{name} stopped (exit {exits[name]})')
    return exits


def _spin_waiter(proc: Any) -> Callable[[Callable[[], bool], float], Any]:
    """A ``stop_child`` waiter that spins ``proc`` (ignoring a stop request: the demo
    is already stopping)."""
    def wait(condition: Callable[[], bool], timeout: float) -> None:
        end = time.monotonic() + timeout
        while not condition() and time.monotonic() < end:
            proc.spin_once(0.05)
    return wait


def _bag_counts(bag: Path) -> dict[str, tuple[str, int]] | None:
    from cam_metrology.bagio import bag_topics
    try:
        return bag_topics(bag)
    except Exception:  # noqa: BLE001 (reported as an unreadable bag)
        return None


def _print_summary(out: TextIO, bag: Path, counts: dict[str, tuple[str, int]] | None,
                   monitor: Any, cores: list[str], seconds: float) -> None:
    print('', file=out)
    if counts is not None:
        total = sum(n for _, n in counts.values())
        print(f'bag: {bag} ({total} messages)', file=out)
        for topic, (_, n) in counts.items():
            if n:
                print(f'  {topic:<28}{n:>8}', file=out)
    if monitor is not None:
        for line in report_lines(monitor.report, monitor.truth):
            print(line, file=out)
    missing = [n for n in ('metrology', 'reconstruction', 'dynamics') if n not in cores]
    if missing:
        print(f'missing cores (not run): {", ".join(missing)}', file=out)
    print(f'demo took {seconds:.1f} s', file=out, flush=True)
