"""`cam-bench rig analyze|calibrate|simulate`: the valve-train test rig
(docs/contract.md "Valve-train rig", docs/methods.md "Valve-train rig"). One module per
sub-command; the run inputs and outputs that ``analyze`` and ``calibrate`` share live in
``runs_io``.

RUN: a CSV file (header ``time_s,cam_angle_rad,valve_lift_m[,valve_velocity_m_per_s,
...]``) or a bag with ``/rig/joint_states`` or ``/rig/joint_trajectory`` (one run per
``frame_id``).
"""
from __future__ import annotations

import argparse

from cam_metrology.cli.groups import add_group


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``rig`` group."""
    return add_group(
        sub, 'rig', 'valve-train test rig: analyse runs, calibrate the dynamics, simulate',
        'Measured valve motion of a motored rig (encoder + laser on a time clock) against '
        'the valve-train dynamics: analyse, calibrate, simulate.')
