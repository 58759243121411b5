"""Neutral core outputs (``cam_metrology.outputs``) -> rclpy messages.

``TableOutput`` -> Float64MultiArray (data filled through ``array.array('d', ...)``,
the fast path of docs/ros.md: 2.3 µs instead of ~300 µs for a numpy array),
``StatusOutput`` -> DiagnosticArray, ``TextOutput`` -> String.
"""
from __future__ import annotations

import array
import time
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from cam_metrology.outputs import Output, StatusOutput, TableOutput, TextOutput


def table_message(out: TableOutput) -> Float64MultiArray:
    """Float64MultiArray with dim[0] = (label, rows, rows*cols), dim[1] = (cols, cols, cols)."""
    data = np.ascontiguousarray(out.data, dtype=np.float64)
    cols = len(out.columns)
    if data.ndim != 2 or data.shape[1] != cols:
        raise ValueError(f'table {out.label!r}: data shape {data.shape} does not match '
                         f'{cols} columns')
    rows = data.shape[0]
    msg = Float64MultiArray()
    msg.layout.dim = [
        MultiArrayDimension(label=out.label, size=rows, stride=rows * cols),
        MultiArrayDimension(label=','.join(out.columns), size=cols, stride=cols),
    ]
    msg.data = array.array('d', data.tobytes())
    return msg


def status_message(out: StatusOutput, now_ns: int | None = None) -> DiagnosticArray:
    """DiagnosticArray with one DiagnosticStatus per status; stamp = out.stamp_ns or now."""
    stamp_ns = out.stamp_ns or (time.time_ns() if now_ns is None else now_ns)
    msg = DiagnosticArray()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
    msg.status = [
        DiagnosticStatus(level=bytes([int(s.level)]), name=s.name, message=s.message,
                         hardware_id=s.hardware_id,
                         values=[KeyValue(key=str(k), value=str(v)) for k, v in s.values.items()])
        for s in out.statuses]
    return msg


def text_message(out: TextOutput) -> String:
    """std_msgs/String with the text."""
    return String(data=out.text)


def to_message(out: Output, now_ns: int | None = None) -> Any:
    """The rclpy message of any core output."""
    if isinstance(out, TableOutput):
        return table_message(out)
    if isinstance(out, StatusOutput):
        return status_message(out, now_ns)
    if isinstance(out, TextOutput):
        return text_message(out)
    raise TypeError(f'unknown core output {type(out).__name__}')
