"""Follower geometry: cam profile coordinates, curvature, pressure angle, undercut, and
lift conversion between follower kinds through the cam profile (methods.md §2).

Conventions: alpha [rad] is the cam angle from the lobe centreline (see
``cam_design.lift_laws.base``); ``base_radius`` R0 [m] is the radius of the cam's base
circle (the profile itself, not the roller pitch circle).
"""
from __future__ import annotations

from dataclasses import dataclass

from cam_design.errors import InputError, require_positive

FOLLOWER_KINDS = ('flat', 'roller', 'knife')


@dataclass(frozen=True)
class Follower:
    """A translating follower or probe: ``kind`` flat | roller | knife; ``radius`` [m].

    A ball probe is a roller in the plane of measurement; a knife (point) follower
    is a roller of radius 0; ``radius`` is ignored for flat followers.
    """

    kind: str
    radius: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in FOLLOWER_KINDS:
            raise InputError('follower.kind', self.kind, ' | '.join(FOLLOWER_KINDS))
        require_positive('follower.radius', self.radius, allow_zero=True)
        if self.kind == 'roller' and self.radius == 0.0:
            raise InputError('follower.radius', self.radius,
                             'a roller radius > 0 (use kind: knife for a point follower)')
