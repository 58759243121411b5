"""The message layouts of cam-bench: one encoder and one decoder each.

* **Table** (``std_msgs/Float64MultiArray``, the outputs ``/metrology/lift``,
  ``/reconstruction/profile``, ``/dynamics/valve_motion``): ``layout.dim[0] =
  (label, rows, rows*cols)``, ``layout.dim[1] = (column names joined by ',', cols,
  cols)``, ``data`` row-major. ``encode_table`` / ``table_from_msg``.
* **Statuses** (``diagnostic_msgs/DiagnosticArray``): one ``DiagnosticStatus`` per
  ``outputs.Status``, values as key/value strings. ``encode_statuses`` /
  ``statuses_from_msg``.
* **Named values** (``sensor_msgs/JointState`` used as a record of named numbers, the
  plot topics of ``plots.py``): ``name[i]`` is a quantity with its unit in the name,
  ``position[i]`` its value, ``header.frame_id`` what it belongs to.
  ``encode_values`` / ``values_from_msg``.
* **Text** (``std_msgs/String``): ``cdr.encode_string`` / ``msg.data``.

Messages to decode are duck-typed: a rosbags object and an rclpy message have the same
fields.
"""
from __future__ import annotations

from typing import Any, Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_metrology.cores.outputs import Output, StatusOutput, TableOutput, TextOutput
from cam_metrology.wire.cdr import (encode_float64_array, encode_named_values,
                                    encode_string, typestore)
from cam_metrology.wire.topics import STATUS, STRING, TABLE

__all__ = ['encode_table', 'table_from_msg', 'encode_statuses', 'statuses_from_msg',
           'encode_values', 'values_from_msg', 'encode_output', 'msgtype_of']

#: ROS type of each neutral core output
MSGTYPE = {TableOutput: TABLE, StatusOutput: STATUS, TextOutput: STRING}


def encode_table(label: str, columns: Sequence[str], data: Any) -> bytes:
    """CDR of a table: ``data`` float64 of shape (rows, len(columns))."""
    arr = np.ascontiguousarray(data, dtype=np.float64)
    cols = len(columns)
    if arr.ndim != 2 or arr.shape[1] != cols:
        raise InputError(f'table {label}.data', arr.shape, f'shape (rows, {cols})')
    rows = arr.shape[0]
    return encode_float64_array(
        [(label, rows, rows * cols), (','.join(columns), cols, cols)], arr)


def table_from_msg(msg: Any) -> tuple[str, tuple[str, ...], NDArray[np.float64]]:
    """(label, columns, data rows x cols) of a table message; InputError naming the
    label when the sizes, the column names and the data disagree."""
    dims = list(msg.layout.dim)
    if len(dims) != 2:
        raise InputError('layout.dim', len(dims), '2 dimensions (rows, columns)')
    label = str(dims[0].label)
    columns = tuple(c for c in str(dims[1].label).split(',') if c)
    rows, cols = int(dims[0].size), int(dims[1].size)
    data = np.asarray(msg.data, dtype=np.float64)
    offset = int(getattr(msg.layout, 'data_offset', 0) or 0)
    if cols != len(columns) or data.size < offset + rows * cols:
        raise InputError(f'{label}.data', f'{data.size} values, {len(columns)} names',
                         f'{rows} x {cols} values with {cols} column names')
    return label, columns, data[offset:offset + rows * cols].reshape(rows, cols)


def encode_statuses(statuses: Iterable[Any], stamp_ns: int = 0) -> bytes:
    """CDR of a DiagnosticArray of ``outputs.Status`` objects, header stamp ``stamp_ns``."""
    store = typestore()
    status_t = store.types['diagnostic_msgs/msg/DiagnosticStatus']
    kv_t = store.types['diagnostic_msgs/msg/KeyValue']
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    header = store.types['std_msgs/msg/Header'](
        stamp=store.types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec),
        frame_id='')
    msg = store.types['diagnostic_msgs/msg/DiagnosticArray'](header=header, status=[
        status_t(level=int(st.level), name=st.name, message=st.message,
                 hardware_id=st.hardware_id,
                 values=[kv_t(key=str(k), value=str(v)) for k, v in st.values.items()])
        for st in statuses])
    return bytes(store.serialize_cdr(msg, 'diagnostic_msgs/msg/DiagnosticArray'))


def statuses_from_msg(msg: Any) -> list[dict[str, Any]]:
    """The statuses of a DiagnosticArray as dicts (name, level, message, values)."""
    def level(value: Any) -> int:
        return value[0] if isinstance(value, (bytes, bytearray)) else int(value)

    return [{'name': st.name, 'level': level(st.level), 'message': st.message,
             'hardware_id': st.hardware_id,
             'values': {kv.key: kv.value for kv in st.values}} for st in msg.status]


def encode_values(frame_id: str, stamp_ns: Any, names: Sequence[str], rows: Any) -> list[bytes]:
    """One named-values message per row of ``rows`` (n x len(names))."""
    return encode_named_values(frame_id, stamp_ns, names, rows)


def values_from_msg(msg: Any) -> tuple[str, dict[str, float]]:
    """(frame_id, {name: value}) of a named-values message."""
    names, values = list(msg.name), list(msg.position)
    if len(names) != len(values):
        raise InputError(f'{msg.header.frame_id}.position', len(values),
                         f'{len(names)} values, one per name')
    return str(msg.header.frame_id), {n: float(v) for n, v in zip(names, values)}


def encode_output(output: Output, stamp_ns: int | None = None) -> bytes:
    """CDR of a neutral core output (TableOutput, StatusOutput, TextOutput).

    A StatusOutput's header stamp is its own ``stamp_ns`` when it has one, else
    ``stamp_ns``.
    """
    if isinstance(output, TableOutput):
        return encode_table(output.label, output.columns, output.data)
    if isinstance(output, StatusOutput):
        stamp = output.stamp_ns if stamp_ns is None or output.stamp_ns else stamp_ns
        return encode_statuses(output.statuses, stamp)
    if isinstance(output, TextOutput):
        return encode_string(output.text)
    raise InputError('output', type(output).__name__,
                     'TableOutput, StatusOutput or TextOutput')


def msgtype_of(output: Output) -> str:
    """ROS 2 type name (``pkg/msg/Type``) of a neutral core output."""
    return MSGTYPE[type(output)]
