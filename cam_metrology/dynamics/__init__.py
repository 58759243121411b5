"""Dynamics node core: valve motion per lobe and cam speed (docs/dynamics.md)."""
