"""Rig runs: the samples of one steady-speed run on the time clock, read from a CSV file
or from ``/rig/joint_states`` in a bag (docs/contract.md "Valve-train rig").

A run holds time [s], encoder angle [rad] (wrapped or unwrapped), valve lift [m] with an
arbitrary laser zero, the valve velocity [m/s] when a vibrometer measures it, and every
further channel by name (spring force, HLA pressure, ...: kept, not used by the fit).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError

from cam_metrology.wire.topics import CAMSHAFT_JOINT as CAMSHAFT
from cam_metrology.wire.topics import RIG_JOINT_STATES as RIG_TOPIC
from cam_metrology.wire.topics import VALVE_JOINT as VALVE
CSV_REQUIRED = ('time_s', 'cam_angle_rad', 'valve_lift_m')
CSV_VELOCITY = 'valve_velocity_m_per_s'
CSV_HEADER = 'time_s,cam_angle_rad,valve_lift_m[,valve_velocity_m_per_s,...]'
#: fewest samples of a run (a few revolutions at a few hundred samples each)
MIN_SAMPLES = 200


@dataclass
class RigRun:
    """One run: ``time`` [s] strictly increasing, ``angle`` [rad] encoder, ``lift`` [m]
    (arbitrary zero), ``velocity`` [m/s] or None, ``channels`` name -> array."""

    name: str
    time: NDArray[np.float64]
    angle: NDArray[np.float64]
    lift: NDArray[np.float64]
    velocity: NDArray[np.float64] | None = None
    channels: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    #: what the input lost or refused on the way (one line each; reported with the run)
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        n = self.time.size
        if n < MIN_SAMPLES:
            raise InputError(f'run {self.name}', f'{n} samples',
                             f'at least {MIN_SAMPLES} samples (a few revolutions)')
        for what, arr in (('cam angle', self.angle), ('valve lift', self.lift)):
            if arr.size != n:
                raise InputError(f'run {self.name} {what}', f'{arr.size} values',
                                 f'one per time stamp ({n})')
        bad = np.nonzero(np.diff(self.time) <= 0)[0]
        if bad.size:
            i = int(bad[0]) + 1
            raise InputError(f'run {self.name} sample {i} time', float(self.time[i]),
                             f'a time after the previous sample ({self.time[i - 1]!r} s): '
                             'samples in acquisition order')


def _float_rows(lines: list[str], ncol: int, path: Path, header: list[str]) -> NDArray:
    """The numeric rows of a CSV body; InputError naming the first bad row and column."""
    try:
        data = np.loadtxt(lines, delimiter=',', dtype=float, ndmin=2)
        if data.shape[1] == ncol and np.all(np.isfinite(data)):
            return data
    except ValueError:
        pass
    for r, line in enumerate(lines):
        cells = line.split(',')
        if len(cells) != ncol:
            raise InputError(f'{path} row {r + 2}', line.strip()[:80],
                             f'{ncol} comma-separated values ({",".join(header)})')
        for c, cell in enumerate(cells):
            try:
                v = float(cell)
            except ValueError:
                v = math.nan
            if not math.isfinite(v):
                raise InputError(f'{path} row {r + 2} column {header[c]}', cell.strip(),
                                 'a finite number (SI units)')
    raise InputError(str(path), 'unreadable rows', f'numbers under the header {CSV_HEADER}')


def read_csv_run(path: str | Path) -> RigRun:
    """A run from a CSV file with the header ``time_s,cam_angle_rad,valve_lift_m``
    (optional ``valve_velocity_m_per_s``, further columns kept as channels)."""
    from cam_metrology.inputs.files import read_text_file

    p = Path(path)
    text = read_text_file(p, 'rig run CSV file')
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith('#')]
    if not lines:
        raise InputError(str(p), 'an empty file', f'a CSV with the header {CSV_HEADER}')
    header = [h.strip() for h in lines[0].split(',')]
    missing = [c for c in CSV_REQUIRED if c not in header]
    if missing:
        what = {'cam_angle_rad': 'the encoder channel', 'valve_lift_m': 'the valve channel',
                'time_s': 'the time stamps'}[missing[0]]
        raise InputError(f'{p} header', ','.join(header)[:80],
                         f'a column {missing[0]} ({what}): {CSV_HEADER}')
    if len(set(header)) != len(header):
        raise InputError(f'{p} header', ','.join(header)[:80], 'distinct column names')
    data = _float_rows(lines[1:], len(header), p, header)
    col = {h: data[:, j] for j, h in enumerate(header)}
    extra = {h: col[h] for h in header if h not in CSV_REQUIRED and h != CSV_VELOCITY}
    return RigRun(name=p.stem, time=col['time_s'], angle=col['cam_angle_rad'],
                  lift=col['valve_lift_m'], velocity=col.get(CSV_VELOCITY), channels=extra)


def runs_of_messages(messages: Iterable[Any], bag: str) -> list[RigRun]:
    """Runs from JointState messages (grouped by contiguous ``header.frame_id``);
    ``bag`` names their source in refusals."""
    groups: list[tuple[str, list[Any]]] = []
    for i, msg in enumerate(messages):
        frame = str(msg.header.frame_id) or 'run'
        names = list(msg.name)
        pos = np.asarray(msg.position, dtype=float)
        for joint, what in ((CAMSHAFT, 'the encoder'), (VALVE, 'the valve lift')):
            if joint not in names:
                raise InputError(f'{bag} {RIG_TOPIC}[{i}].name', names[:6],
                                 f'a joint named {joint!r} ({what}); joints are looked up '
                                 'by name')
        if pos.size != len(names):
            raise InputError(f'{bag} {RIG_TOPIC}[{i}].position', f'{pos.size} values',
                             f'one position per joint name ({len(names)})')
        vel = np.asarray(msg.velocity, dtype=float)
        stamp = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        row = (stamp, names, pos, vel if vel.size == len(names) else None)
        if not groups or groups[-1][0] != frame:
            groups.append((frame, []))
        groups[-1][1].append(row)
    runs = []
    seen: dict[str, int] = {}
    for frame, rows in groups:
        seen[frame] = seen.get(frame, 0) + 1
        name = frame if seen[frame] == 1 else f'{frame}#{seen[frame]}'
        names0 = rows[0][1]
        t = np.array([r[0] for r in rows])
        get = {j: np.array([r[2][r[1].index(j)] if j in r[1] else math.nan for r in rows])
               for j in names0}
        valve_vel: NDArray[np.float64] | None = None
        if all(r[3] is not None for r in rows):
            valve_vel = np.array([r[3][r[1].index(VALVE)] for r in rows])
            if not np.all(np.isfinite(valve_vel)):
                valve_vel = None
        channels = {j: a for j, a in get.items() if j not in (CAMSHAFT, VALVE)}
        runs.append(RigRun(name=name, time=t - t[0], angle=get[CAMSHAFT], lift=get[VALVE],
                           velocity=valve_vel, channels=channels))
    return runs


def runs_of_samples(frame_id: Any, stamp_ns: NDArray[np.int64], theta: NDArray[np.float64],
                    lift: NDArray[np.float64], source: str,
                    velocity: NDArray[np.float64] | None = None,
                    others: dict[str, NDArray[np.float64]] | None = None) -> list[RigRun]:
    """Runs from decoded samples (``bagio.decode_joint_blocks`` of the rig's blocks:
    ``camshaft`` as ``theta``, ``valve`` as ``lift``; stamps [ns]), one per contiguous
    ``frame_id``; ``velocity`` the valve's [m/s] (a run's is kept when every sample of
    it has one, as for JointState samples), ``others`` the further joints (channels).
    Samples without a value (a damaged block: NaN) are dropped and counted in the
    run's ``notes``; ``source`` names the input in them."""
    frames = np.asarray(frame_id)
    n = int(frames.size)
    runs: list[RigRun] = []
    if n == 0:
        return runs
    cut = np.flatnonzero(frames[1:] != frames[:-1]) + 1
    seen: dict[str, int] = {}
    for a, b in zip(np.concatenate(([0], cut)).tolist(), np.concatenate((cut, [n])).tolist()):
        frame = str(frames[a]) or 'run'
        seen[frame] = seen.get(frame, 0) + 1
        name = frame if seen[frame] == 1 else f'{frame}#{seen[frame]}'
        t = np.asarray(stamp_ns[a:b], dtype=np.int64)
        th, y = np.asarray(theta[a:b], dtype=float), np.asarray(lift[a:b], dtype=float)
        ok = np.isfinite(th) & np.isfinite(y)
        notes = []
        if not np.all(ok):
            notes.append(f'{source}: {int(np.sum(~ok))} of {b - a} samples of run {name} '
                         'without a camshaft or valve value (damaged blocks): not used')
        t, th, y = t[ok], th[ok], y[ok]
        if t.size == 0:
            raise InputError(f'{source} run {name}', f'{b - a} samples without values',
                             "blocks with joints 'camshaft' and 'valve' (joints are looked "
                             'up by name)')
        vel = None if velocity is None else np.asarray(velocity[a:b], dtype=float)[ok]
        if vel is not None and not np.all(np.isfinite(vel)):
            vel = None
        channels = {j: np.asarray(c[a:b], dtype=float)[ok] for j, c in (others or {}).items()
                    if np.any(np.isfinite(c[a:b]))}
        runs.append(RigRun(name=name, time=(t - t[0]) * 1e-9, angle=th, lift=y,
                           velocity=vel, channels=channels, notes=notes))
    return runs


def read_bag_block_runs(path: str | Path) -> list[RigRun]:
    """The runs of the rig's blocks (``/rig/joint_trajectory``: the valve velocity and
    further joints as a JointState sample gives them), merged in log time with any
    ``/rig/joint_states`` samples (then positions of camshaft and valve only); damaged
    blocks are named and counted in the runs' notes."""
    from cam_metrology.bagio import JointSummary, iter_joint_states
    from cam_metrology.wire.topics import RIG_JOINT_TRAJECTORY

    parts = list(iter_joint_states(path, RIG_TOPIC, joints=(CAMSHAFT, VALVE),
                                   blocks_topic=RIG_JOINT_TRAJECTORY, extras=True))
    summary = JointSummary()
    for js in parts:
        summary.add(js)
    if summary.issues and not summary.usable:
        raise summary.issues[0].error(summary.count)
    if not summary.count:
        raise InputError(str(path), f'no samples on {RIG_JOINT_TRAJECTORY}',
                         "blocks with joints 'camshaft' and 'valve' (trajectory_msgs/"
                         'JointTrajectory, one point per sample)')
    vel, others = joined_extras(parts)
    runs = runs_of_samples(np.concatenate([js.frame_id for js in parts]),
                           np.concatenate([js.stamp_ns for js in parts]),
                           np.concatenate([js.theta for js in parts]),
                           np.concatenate([js.s for js in parts]), str(path), vel, others)
    issues = [f'{path}: {i.text(summary.count)}' for i in summary.issues]
    for r in runs:
        r.notes += issues
    return runs


def joined_extras(parts: Sequence[Any],
                  ) -> tuple[NDArray[np.float64] | None, dict[str, NDArray[np.float64]]]:
    """The valve velocity (None when no part has one) and the further joints of
    consecutive ``JointSamples`` parts, NaN where a part lacks them."""
    def column(get: Any) -> NDArray[np.float64]:
        return np.concatenate([np.full(len(js), np.nan) if get(js) is None else get(js)
                               for js in parts])

    vel = column(lambda js: js.lift_velocity) \
        if any(js.lift_velocity is not None for js in parts) else None
    names = dict.fromkeys(k for js in parts for k in js.others)
    return vel, {k: column(lambda js, k=k: js.others.get(k)) for k in names}


def read_bag_runs(path: str | Path) -> tuple[list[RigRun], str | None]:
    """The runs of ``/rig/joint_states`` in a bag (one per contiguous ``frame_id``), or
    of ``/rig/joint_trajectory`` when the bag has the rig's blocks
    (``read_bag_block_runs``), and the last ``/bench/scene`` text of the bag (None when
    it has none)."""
    from cam_metrology.bagio import iter_messages
    from cam_metrology.wire.topics import SCENE

    from cam_metrology.bagio import bag_topics
    from cam_metrology.wire.topics import RIG_JOINT_TRAJECTORY

    blocks = RIG_JOINT_TRAJECTORY in bag_topics(path)
    scene_text = None
    msgs = []
    for m in iter_messages(path, [SCENE] if blocks else [RIG_TOPIC, SCENE]):
        if m.topic == SCENE:
            scene_text = str(m.msg.data)
        else:
            msgs.append(m.msg)
    if blocks:
        return read_bag_block_runs(path), scene_text
    if not msgs:
        raise InputError(str(path), f'no {RIG_TOPIC} messages',
                         f'a bag with rig samples on {RIG_TOPIC} (sensor_msgs/JointState, '
                         "joints 'camshaft' and 'valve')")
    return runs_of_messages(msgs, str(path)), scene_text


def read_runs(paths: Iterable[str | Path]) -> tuple[list[RigRun], str | None]:
    """Runs from CSV files and bags, in the order given (bag scenes: the last one)."""
    from cam_metrology.bagio import looks_like_bag

    runs: list[RigRun] = []
    scene_text = None
    for path in paths:
        p = Path(path)
        if not p.exists():
            raise InputError('RUN', str(p), 'an existing CSV file or bag')
        if looks_like_bag(p):
            more, text = read_bag_runs(p)
            runs += more
            scene_text = text or scene_text
        else:
            runs.append(read_csv_run(p))
    names = [r.name for r in runs]
    for i, r in enumerate(runs):        # distinct names: the report is keyed by them
        if names.count(r.name) > 1:
            r.name = f'{r.name}#{i + 1}'
    return runs, scene_text


def write_csv_run(run: RigRun, path: str | Path) -> None:
    """Write a run as the rig CSV (full float precision)."""
    from cam_metrology.inputs.files import write_output

    cols = [run.time, run.angle, run.lift]
    header = list(CSV_REQUIRED)
    if run.velocity is not None:
        cols.append(run.velocity)
        header.append(CSV_VELOCITY)
    for name, arr in run.channels.items():
        cols.append(arr)
        header.append(name)
    import io
    buf = io.StringIO()
    np.savetxt(buf, np.column_stack(cols), delimiter=',', fmt='%.17g',
               header=','.join(header), comments='')
    write_output(path, buf.getvalue(), str(path))
