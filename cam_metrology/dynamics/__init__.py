"""Dynamics node core: valve motion per lobe and cam speed (methods.md §4)."""
