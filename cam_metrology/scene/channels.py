"""The bench's channel names carried by the scene (``channels:``, docs/contract.md).

A scene may name the joints of the bench's sample stream: ``angle_joint`` (the joint
whose position is the camshaft encoder angle [rad]) and ``lift_joint`` (the probe lift
[m]). The metrology node's parameters of the same names win when they are set to other
names than the defaults (``camshaft``, ``probe``); otherwise the scene's names are used,
so a bench whose scene travels with its bags needs no parameter file.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping

from cam_design.errors import InputError
from cam_metrology.wire.topics import CAMSHAFT_JOINT, PROBE_JOINT

CHANNEL_KEYS = ('angle_joint', 'lift_joint')
DEFAULT_JOINTS = (CAMSHAFT_JOINT, PROBE_JOINT)


@dataclass(frozen=True)
class Channels:
    """Joint names of the bench's samples: encoder angle and probe lift."""

    angle_joint: str = CAMSHAFT_JOINT
    lift_joint: str = PROBE_JOINT

    @property
    def joints(self) -> tuple[str, str]:
        """(angle joint, lift joint)."""
        return self.angle_joint, self.lift_joint


def parse_channels(block: Any,
                   mapping: Callable[[str, Any, tuple[str, ...]], Mapping[str, Any]],
                   ) -> Channels | None:
    """``channels:`` of a scene (None when absent); InputError naming
    ``channels.<key>`` for a name that is not a non-empty string, or the same joint
    twice. ``mapping`` checks the block's keys (the scene parser's)."""
    if block is None:
        return None
    given = mapping('channels', block, CHANNEL_KEYS)
    names = []
    for key, default in zip(CHANNEL_KEYS, DEFAULT_JOINTS):
        name = given.get(key, default)
        if not isinstance(name, str) or not name.strip():
            raise InputError(f'channels.{key}', name, 'a joint name (non-empty string)')
        names.append(name)
    if names[0] == names[1]:
        raise InputError('channels.lift_joint', names[1],
                         f'a joint other than the angle joint {names[0]!r}')
    return Channels(names[0], names[1])


def joints_in_force(params_joints: tuple[str, str], scene: Any) -> tuple[str, str]:
    """The (angle, lift) joint names a core uses: its parameters when they are not the
    defaults, else the scene's ``channels`` when it has them, else the defaults."""
    if tuple(params_joints) != DEFAULT_JOINTS:
        return params_joints
    channels = getattr(scene, 'channels', None)
    return channels.joints if channels is not None else DEFAULT_JOINTS
