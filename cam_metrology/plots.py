"""Figures of measured lifts (matplotlib): measured against design lift and their
difference, as ``analyze --plot`` and the HTML report draw them."""
from __future__ import annotations

from typing import Any


def lift_figure(label: str, table: Any, feature: dict[str, Any]) -> Any:
    """The figure of one ``/metrology/lift`` table (columns alpha [rad], measured and
    design lift [m]): lift [mm] on top, measured - design [um] below. The legend sits
    outside the axes (above them), so it never hides data; the x axis is named after the
    reference of alpha: the fitted nose (lobe) or the fitted pin centre (dowel pin)."""
    import matplotlib.pyplot as plt
    import numpy as np

    alpha = np.degrees(table[:, 0])
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.5))
    ax1.plot(alpha, table[:, 1] * 1e3, '.', ms=1.5, label='measured')
    ax1.plot(alpha, table[:, 2] * 1e3, '-', lw=0.8, label='design (as seen by the probe)')
    ax1.set_ylabel('lift [mm]')
    ax1.legend(loc='lower center', bbox_to_anchor=(0.5, 1.0), ncol=2, frameon=False,
               markerscale=6)
    angle = feature.get('angle_deg')
    fig.suptitle(f'{label}: angle {angle:.5f} deg' if angle is not None else label)
    ax2.plot(alpha, (table[:, 1] - table[:, 2]) * 1e6, '.', ms=1.5)
    pin = feature.get('kind') == 'dowel_pin' or (not feature and label == 'dowel_pin')
    ax2.set_ylabel('measured - design [µm]' if pin or feature.get('kind') != 'lobe'
                   else 'lift error, from the base circle [µm]')
    ax2.set_xlabel('alpha from the fitted pin centre [deg]' if pin
                   else 'alpha from the fitted nose [deg]')
    fig.tight_layout()
    return fig
