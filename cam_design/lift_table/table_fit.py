"""How a lift table became its lobe law, for a replica of the table to be fitted the
same way (``lobe_table.lobe_law(..., fit=law.lobe.fit)``): the jump-speed band of a
table (``cam_metrology.dynamics.tables.jump_uncertainty``) draws copies of its rows with
a fresh draw of their noise, and each copy must go through the rule the table went
through, or the band measures another smoother than the one that gave the answer
(docs/methods.md, "One table, one lobe", rule 5)."""
from __future__ import annotations

from dataclasses import dataclass

#: the smoothing criterion of a smoothed table (``spline.CRITERIA``): generalised
#: cross-validation, modified (gamma 1.4) as the reconstruction spline decides for noisy
#: rows, the same for the table and for the noisy replicas of its jump-speed band
LEVEL_CRITERION = 'gcv'


@dataclass(frozen=True)
class TableFit:
    """How a table became its lobe law, for a replica of the table (the same rows with a
    fresh draw of their noise) to be fitted the same way: ``method`` 'interpolated' or
    'smoothed'; ``criterion`` the smoothing criterion (``LEVEL_CRITERION``; None when
    interpolated); ``known`` [m] the noise the smoothing spline was given (the
    rounding's q/sqrt(12), or the base circle's spread of noise the rows share), None
    where it estimated the noise from the rows; ``correlated``: that noise is shared by
    neighbouring rows (``noise.base_circle_noise``)."""

    method: str
    criterion: str | None = None
    known: float | None = None
    correlated: bool = False

    def text(self) -> str:
        """What the fit was, in a few words (for a note)."""
        if self.method != 'smoothed':
            return 'interpolated'
        return (f'smoothed by {self.criterion}, noise '
                + ('estimated from the rows' if self.known is None else
                   f'{self.known * 1e6:.3g} um '
                   + ('(shared by neighbouring rows)' if self.correlated else '(the rounding)')))
