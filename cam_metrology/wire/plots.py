"""Plot views of the node outputs: what Foxglove and PlotJuggler plot with no set-up.

The node cores publish tables (``Float64MultiArray``, thousands of doubles row by
row), statuses on their own topics and a JSON report: right for programs, awkward in
a plotting tool (PlotJuggler clamps arrays to 500 elements by default; a row-major
table is a sawtooth in Foxglove). Every output is therefore also published as:

* **curves**, one ``sensor_msgs/JointState`` per point (``/plot/lift``,
  ``/plot/profile``, ``/plot/valve_motion``): ``header.frame_id`` = the table's
  label (``lobe_1``, ``lobe_1/spline``, ``lobe_1/3000rpm``), ``name[i]`` =
  ``<label>/<quantity>`` with the unit in the name, ``position[i]`` its value. The
  x-axis is ``<label>/alpha_deg`` (cam angle from the lobe centreline). At most
  ``MAX_POINTS`` points per curve (every k-th row; the full table stays on its own
  topic). Points are stamped ``POINT_SPACING_NS`` apart from the output's time.
  PlotJuggler names the series ``/plot/lift/lobe_1/alpha_deg/position`` (one series
  per feature: an XY curve with no array at all); Foxglove plots
  ``/plot/lift{header.frame_id=="lobe_1"}.position[3]`` against ``.position[0]``.
* **values** (``/metrology/values``), at each final report one ``sensor_msgs/JointState``
  per feature (``header.frame_id`` = the feature id) and one for the part (``part``):
  ``name[i]`` = ``<feature>/<quantity>`` in the fixed order of ``VALUE_NAMES``
  (nose/pin angle, its standard uncertainty, phase, phase error, asymmetry, lift
  errors, ok, verdict; NaN where a quantity does not apply or was not checked): time
  series across parts. Foxglove: ``/metrology/values{header.frame_id=="lobe_1"}
  .position[0]``; PlotJuggler: ``/metrology/values/lobe_1/angle_deg/position``.
* **statuses on /diagnostics**: each result status again, named ``<node>: <name>``
  (the ROS convention: rqt_runtime_monitor, Foxglove's Diagnostics panel and
  PlotJuggler's diagnostic parser read ``/diagnostics``).

Units are in the names (``_deg``, ``_mm``, ``_um``, ``_mpa``): plot topics are for
people; the SI tables stay on the output topics.
"""
from __future__ import annotations

import json
import math
from typing import Any, NamedTuple

import numpy as np

from cam_metrology.cores.outputs import Output, Status, StatusOutput, TableOutput, TextOutput
from cam_metrology.wire.cdr import encode_named_values
from cam_metrology.wire.form_values import SHAFT_VALUES, feature_form_values, form_value_names
from cam_metrology.wire.layouts import encode_statuses
from cam_metrology.wire.topics import (DIAGNOSTICS, DYNAMICS_MOTION, DYNAMICS_RESULT,
                                       JOINT_STATE, METROLOGY_LIFT, METROLOGY_REPORT,
                                       METROLOGY_RESULT, METROLOGY_VALUES, PLOT_LIFT,
                                       PLOT_MOTION, PLOT_PROFILE, RECONSTRUCTION_PROFILE,
                                       PLOT_RIG, RECONSTRUCTION_RESULT, RIG_MOTION,
                                       RIG_RESULT, STATUS)

__all__ = ['PlotMessage', 'plot_messages', 'view_topics', 'curve_columns', 'report_values',
           'MAX_POINTS', 'POINT_SPACING_NS', 'CURVE_TOPICS', 'VALUE_NAMES', 'PART_NAMES']

#: points per curve at most (every k-th row of the table)
MAX_POINTS = 720
#: stamps of successive points of a curve [ns]: 10 us stays distinct in a double of
#: seconds since 1970 (PlotJuggler's time axis), 720 points span 7.2 ms
POINT_SPACING_NS = 10_000
#: table topic -> its curve topic
CURVE_TOPICS = {METROLOGY_LIFT: PLOT_LIFT, RECONSTRUCTION_PROFILE: PLOT_PROFILE,
                DYNAMICS_MOTION: PLOT_MOTION, RIG_MOTION: PLOT_RIG}
#: result topic -> node name of its statuses on /diagnostics
STATUS_NODES = {METROLOGY_RESULT: 'metrology', RECONSTRUCTION_RESULT: 'reconstruction',
                DYNAMICS_RESULT: 'dynamics', RIG_RESULT: 'rig'}

_DEG = math.pi / 180.0
#: column suffix -> (plot suffix, factor): SI column -> unit people read
_UNITS = (
    ('_m_per_rad3', '_mm_per_deg3', 1e3 * _DEG ** 3),
    ('_m_per_rad2', '_mm_per_deg2', 1e3 * _DEG ** 2),
    ('_m_per_rad', '_mm_per_deg', 1e3 * _DEG),
    ('_rad', '_deg', 1.0 / _DEG),
    ('_pa', '_mpa', 1e-6),
    ('_m', '_mm', 1e3),
)


class PlotMessage(NamedTuple):
    """One plot message: topic, ROS type, log time [ns], CDR bytes."""

    topic: str
    msgtype: str
    stamp_ns: int
    cdr: bytes


def _plot_name(column: str) -> tuple[str, float]:
    for suffix, new, factor in _UNITS:
        if column.endswith(suffix):
            return column[:-len(suffix)] + new, factor
    return column, 1.0


def curve_columns(columns: tuple[str, ...], data: Any) -> tuple[list[str], np.ndarray]:
    """(quantity names, values rows x names) of a table in the units of the plots:
    angles deg, lifts mm, derivatives per deg, stresses MPa; a lift table also gets
    ``lift_error_um`` = measured - design."""
    arr = np.asarray(data, dtype=np.float64)
    names, cols = [], []
    for k, column in enumerate(columns):
        name, factor = _plot_name(column)
        names.append(name)
        cols.append(arr[:, k] * factor)
    if 'lift_m' in columns and 'design_lift_m' in columns:
        names.append('lift_error_um')
        cols.append((arr[:, columns.index('lift_m')] - arr[:, columns.index('design_lift_m')])
                    * 1e6)
    return names, (np.column_stack(cols) if cols else np.zeros((arr.shape[0], 0)))


def _curve(topic: str, out: TableOutput, stamp_ns: int) -> list[PlotMessage]:
    names, values = curve_columns(out.columns, out.data)
    if not len(values) or not names:
        return []
    if names[0] == 'alpha_deg':   # a curve against angle: in angle order
        values = values[np.argsort(values[:, 0], kind='stable')]
    step = max(1, math.ceil(len(values) / MAX_POINTS))
    values = values[::step]
    stamps = stamp_ns + POINT_SPACING_NS * np.arange(len(values), dtype=np.int64)
    cdrs = encode_named_values(out.label, stamps, [f'{out.label}/{n}' for n in names], values)
    return [PlotMessage(topic, JOINT_STATE, int(t), c) for t, c in zip(stamps.tolist(), cdrs)]


#: quantities of a feature on /metrology/values, in this order (NaN where they do not
#: apply: a pin has no phase); ``ok`` 1 for a measured feature, 0 for a failed one;
#: ``verdict`` 1 pass, 0 fail, NaN not checked; ``partial`` 1 when the feature was
#: computed on partial data (lost samples, live), 0 otherwise; then the form, journal and
#: track numbers and their verdicts (``form_values``: appended, so earlier indices stay)
VALUE_NAMES = ('angle_deg', 'angle_std_arcsec', 'phase_deg', 'phase_error_deg',
               'asymmetry_deg', 'lift_error_max_plus_um', 'lift_error_max_minus_um',
               'lift_error_rms_um', 'ok', 'verdict', 'partial') + form_value_names()
#: frame of the part's own values (``part/verdict``, ``part/complete``, the shaft's
#: straightness and bow [um])
PART = 'part'
PART_NAMES = ('verdict', 'complete') + SHAFT_VALUES


def _number(value: Any, factor: float = 1.0) -> float:
    if isinstance(value, (int, float)) and not isinstance(value, bool) \
            and math.isfinite(float(value)):
        return float(value) * factor
    return math.nan


def _verdict_value(verdict: Any) -> float:
    result = verdict.get('result') if isinstance(verdict, dict) else None
    return {'pass': 1.0, 'fail': 0.0}.get(result, math.nan) if isinstance(result, str) \
        else math.nan


def report_values(report: dict[str, Any]) -> list[tuple[str, list[float]]]:
    """[(frame, values in the order of VALUE_NAMES (PART_NAMES for the part))] of a
    report: the numbers a user plots across parts, one record per feature."""
    out = []
    features = report.get('features') or {}
    tracks = report.get('lobe_tracks') if isinstance(report.get('lobe_tracks'), dict) else {}
    # a lobe measured on tracks only: its taper and twist on a record of its own
    records = {fid: f for fid, f in features.items() if isinstance(f, dict)}
    records.update({lobe: {} for lobe in tracks if lobe not in records})
    for fid in sorted(records):
        f = records[fid]
        err = f.get('lift_error_um') if isinstance(f.get('lift_error_um'), dict) else {}
        base = [
            _number(f.get('angle_deg')), _number(f.get('angle_std_deg'), 3600.0),
            _number(f.get('phase_deg')), _number(f.get('phase_error_deg')),
            _number(f.get('asymmetry_deg')), _number(err.get('max_plus')),
            _number(err.get('max_minus')), _number(err.get('rms')),
            1.0 if f.get('status') == 'ok' else (math.nan if not f else 0.0),
            _verdict_value(f.get('verdict')), 1.0 if f.get('partial') else 0.0]
        form = feature_form_values(f, tracks.get(fid))
        base += [_number(value) for _, value, _ in form]
        base += [_verdict_value({'result': verdict}) for v, _, verdict in form
                 if v.quantity is not None]
        out.append((str(fid), base))
    shaft = report.get('shaft') if isinstance(report.get('shaft'), dict) else {}
    out.append((PART, [_verdict_value(report.get('verdict')),
                       1.0 if report.get('complete') else 0.0] +
                [_number(shaft.get(k)) for k in SHAFT_VALUES]))
    return out


def view_topics(topic: str) -> dict[str, str]:
    """{plot topic: ROS type} of the views derived from outputs on ``topic`` (a node
    creates these publishers with its own, so that subscribers match them before the
    first view is published)."""
    if topic in CURVE_TOPICS:
        return {CURVE_TOPICS[topic]: JOINT_STATE}
    if topic in STATUS_NODES:
        return {DIAGNOSTICS: STATUS}
    if topic == METROLOGY_REPORT:
        return {METROLOGY_VALUES: JOINT_STATE}
    return {}


def plot_messages(output: Output, stamp_ns: int) -> list[PlotMessage]:
    """The plot messages derived from one core output published at ``stamp_ns``."""
    if isinstance(output, TableOutput) and output.topic in CURVE_TOPICS:
        return _curve(CURVE_TOPICS[output.topic], output, stamp_ns)
    if isinstance(output, StatusOutput) and output.topic in STATUS_NODES:
        node = STATUS_NODES[output.topic]
        statuses = [Status(f'{node}: {s.name}', s.level, s.message, dict(s.values),
                           s.hardware_id) for s in output.statuses]
        return [PlotMessage(DIAGNOSTICS, STATUS, stamp_ns,
                            encode_statuses(statuses, output.stamp_ns or stamp_ns))]
    if isinstance(output, TextOutput) and output.topic == METROLOGY_REPORT:
        try:
            report = json.loads(output.text)
        except ValueError:
            return []
        if not isinstance(report, dict) or report.get('final') is False:
            return []
        out = []
        for frame, values in report_values(report):
            names = PART_NAMES if frame == PART else VALUE_NAMES
            cdr = encode_named_values(frame, stamp_ns, [f'{frame}/{n}' for n in names],
                                      np.asarray([values]))[0]
            out.append(PlotMessage(METROLOGY_VALUES, JOINT_STATE, stamp_ns, cdr))
        return out
    return []
