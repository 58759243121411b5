"""Lift laws of the seeds as composable segments (see base.LiftLaw for the interface).

``from_spec(spec, key)`` builds a law from a scene's ``lift_law`` mapping; it is
implemented in ``registry`` (families and parameters: docs/lift_laws.md). Laws built
by the families are ``PiecewiseLaw`` objects (``segments``) with a ``junction_report``.
"""
from cam_design.lift_laws.base import LiftLaw, TabulatedLift
from cam_design.lift_laws.registry import FAMILIES, PRESETS, from_spec
from cam_design.lift_laws.segments import PiecewiseLaw

__all__ = ['FAMILIES', 'PRESETS', 'LiftLaw', 'PiecewiseLaw', 'TabulatedLift', 'from_spec']
