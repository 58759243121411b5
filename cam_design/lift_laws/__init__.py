"""Lift laws of the seeds as composable segments (see base.LiftLaw for the interface).

``from_spec(spec, key)`` builds a law from a scene's ``lift_law`` mapping; it is
implemented in ``registry`` by the lift-law module owner.
"""
from cam_design.lift_laws.base import LiftLaw, TabulatedLift

__all__ = ['LiftLaw', 'TabulatedLift']
