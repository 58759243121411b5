"""One lift table -> one lobe law, and the smoothing engine behind it (pure numerics).

``lobe_table.lobe_law`` turns rows (alpha [rad], lift [m]) into a ``TableLobe``;
``spline`` (with ``junctions`` and ``noise``) is the smoothing engine it calls;
``samples`` holds the rows and their checks; ``result`` a reconstruction's record.
"""
