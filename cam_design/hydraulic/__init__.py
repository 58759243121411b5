"""Hydraulic valve gear: oil properties, the high-pressure pipe (method of
characteristics), cam-driven hydraulic valve actuation, the hydraulic lash adjuster and
the cylinder-gas force. Pure numerics, SI units (Pa, m, m^3/s, kg, s); see
docs/hydraulic.md for every equation and its source.
"""
