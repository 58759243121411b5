"""Valve-train dynamics (docs/dynamics.md): single-DOF penalty/hard-seat model with an
exact piecewise-linear propagator, the 4+N1+N2 multi-DOF model, the epsilon criterion
and cam-speed sweeps. Pure numerics: no messages, no ROS."""
from cam_design.valve_train.params import SdofParams
from cam_design.valve_train.sdof import SdofResult, simulate

__all__ = ['SdofParams', 'SdofResult', 'simulate']
