"""The checks of a table's lobe law: warnings on what the rows could not tell (a table
starting mid-lobe, a lobe wide enough to be in crank degrees, other lobes, noise the rows
share) and refusals of a lobe no cam can have (a max lift above every row, a peak
acceleration far above what the lobe's lift and duration allow, naming the row that
stands off its neighbours). Called by ``lobe_table`` on every law it builds; angles
[rad], lengths [m].
"""
from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.lift_table.noise import BaseNoise
from cam_design.lift_table.samples import other_lobes_warning, wrap_pi


class LobeFacts(Protocol):
    """What the checks read of a law's ``LobeInfo`` (``lobe_table``): angles [rad],
    lengths [m]."""

    key: str
    step: float
    sigma: float
    quantum: float
    periodic: bool
    offset: float
    level: float
    base: float
    mid_lobe: tuple[str, ...]
    joins: list[tuple[float, float] | None]
    base_noise: BaseNoise | None

    @property
    def law_offset(self) -> float: ...


#: a lobe law whose peak |h''| exceeds this many times 2 H / (half-duration)^2 (what a
#: constant-acceleration rise of the same lift and duration needs) is refused
ACC_PLAUSIBLE = 100.0
#: a cam-angle lobe wider than this [deg] seat to seat is probably in crank degrees
CRANK_SUSPECT_DEG = 200.0


def odd_row(b: NDArray[np.float64], h: NDArray[np.float64], info: LobeFacts) -> str:
    """'; the row at A deg (H mm) stands D mm off its neighbours' for the row farthest
    from the median of its six neighbours, when that is more than a tenth of the lift
    range (a typo, a spike); '' otherwise. Angles in the table's frame."""
    if h.size < 7:
        return ''
    pad = np.concatenate([h[-3:], h, h[:3]]) if info.periodic else np.pad(h, 3, mode='edge')
    near = np.stack([pad[3 + k:3 + k + h.size] for k in (-3, -2, -1, 1, 2, 3)])
    off = h - np.median(near, axis=0)
    j = int(np.argmax(np.abs(off)))
    if abs(float(off[j])) <= 0.1 * float(np.ptp(h)):
        return ''
    at = math.degrees(float(wrap_pi(b[j] + info.offset)))
    return (f'; the row at {at:.6g} deg ({(h[j] + info.base) * 1e3:.6g} mm) stands '
            f'{abs(float(off[j])) * 1e3:.4g} mm off its neighbours: a typo?')


def law_checks(law: LiftLaw, b: NDArray[np.float64], h: NDArray[np.float64],
               info: LobeFacts, sampled: tuple[NDArray[np.float64], NDArray[np.float64]]
               ) -> list[str]:
    """Warnings on the law; InputError for a lobe no cam can have. ``sampled``: the
    law's lift [m] on 8001 points over its support [rad] (``_build`` has them)."""
    out: list[str] = []
    grid, lift = sampled
    top = float(np.max(lift))
    # between rows a lobe rises above its highest row by up to |h''| (step/2)^2 / 2
    acc = float(np.max(np.abs(law(grid, 2))))
    rise = 0.125 * acc * info.step ** 2
    allowed = float(np.max(h)) + 2.0 * rise + max(3.0 * info.sigma, info.quantum, 1e-6)
    if top > allowed:
        raise InputError(info.key, f'max lift {top * 1e3:.4f} mm from rows up to '
                         f'{float(np.max(h)) * 1e3:.4f} mm',
                         'rows that define the lobe (the curve leaves the rows\' range: '
                         'a gap in the table?): tabulate the whole lobe')
    if float(np.min(lift)) < -max(3.0 * info.sigma, info.quantum, 1e-6):
        out.append(f'the lobe law dips to {float(np.min(lift)) * 1e6:.3g} um below the base '
                   'circle: the rows are too coarse for their shape')
    on = np.flatnonzero(lift > 0.01 * top)
    half = 0.5 * float(grid[on[-1]] - grid[on[0]]) if on.size > 1 else math.pi
    plausible = ACC_PLAUSIBLE * 2.0 * top / max(half, 1e-6) ** 2
    if acc > plausible:
        raise InputError(info.key, f"peak acceleration {acc:.3g} m/rad^2",
                         f'a lobe its lift ({top * 1e3:.3g} mm) and duration '
                         f'({math.degrees(2 * half):.0f} deg) allow (at most '
                         f'{plausible:.3g} m/rad^2): the rows are noisier than they look'
                         f'{odd_row(b, h, info)}; smooth or re-measure the table')
    for side in info.mid_lobe:
        j = info.joins[0] if side == 'start' else info.joins[1]
        assert j is not None   # a mid-lobe end is always joined
        at = j[1] if side == 'start' else j[0]
        level = float(law(np.array([at + info.law_offset]), 0)[0])
        out.append(f'the table {side}s mid-lobe ({level * 1e3:.4g} mm, '
                   f'{level / top * 100:.2g} % of the max lift, no base-circle row): joined '
                   f'to the base circle over {math.degrees(j[1] - j[0]):.2f} deg; events '
                   f'below {level * 1e3:.4g} mm are the join\'s, not the cam\'s')
    seat = np.flatnonzero(lift > max(info.level, 1e-4 * top))   # seat to seat
    width = math.degrees(float(grid[seat[-1]] - grid[seat[0]])) if seat.size > 1 else 0.0
    if not info.periodic and width > CRANK_SUSPECT_DEG:
        out.append(f'the lobe is {width:.0f} cam deg wide seat to seat (more than '
                   f'{CRANK_SUSPECT_DEG:.0f}): are the angles crank degrees? name the '
                   'column crank_deg (or halve the angles)')
    other = other_lobes_warning(wrap_pi(b + info.offset), h)   # in the table frame
    if other:
        out.append(other)
    if info.base_noise is not None:
        out.append(info.base_noise.warning())
    return out
