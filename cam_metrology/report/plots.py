"""Figures of measured lifts (matplotlib): measured against design lift and their
difference with the tolerance band, as ``analyze --plot`` and the HTML report draw
them."""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

#: colours: measured points drawn over the design line, limits in red
MEASURED, DESIGN, LIMIT = 'tab:blue', 'black', 'tab:red'


Zone = tuple[float, float, float, float]


def tolerance_bands(feature: Mapping[str, Any]
                    ) -> tuple[tuple[float, float] | None, list[Zone]]:
    """The lift-error band of a feature's verdict (lower, upper) [um] on the whole lobe,
    and its zones (from_deg, to_deg, lower, upper); (None, []) without tolerances."""
    band, zones = None, []
    for c in (feature.get('verdict') or {}).get('checks', []):
        q = c['quantity']
        if q == 'lift_error_max_plus_um':
            band = (c['lower'], c['upper'])
        elif q.startswith('lift_error_um[') and q.endswith('.max_plus'):
            a0, a1 = (float(v) for v in q[len('lift_error_um['):q.index(' deg]')].split('..'))
            zones.append((a0, a1, c['lower'], c['upper']))
    return band, zones


def _outside(alpha: np.ndarray, err: np.ndarray, design: np.ndarray,
             band: tuple[float, float] | None,
             zones: list[Zone]) -> np.ndarray:
    """Samples [alpha deg, err um] outside the band that applies to them (a zone's band
    inside the zone, the lobe band on the rest of the lobe, design lift > 0)."""
    out = np.zeros(alpha.size, bool)
    in_zone = np.zeros(alpha.size, bool)
    for a0, a1, lo, hi in zones:
        z = (alpha >= a0) & (alpha <= a1)
        in_zone |= z
        out |= z & ((err < lo) | (err > hi))
    if band is not None:
        rest = ~in_zone & (design > 0)
        out |= rest & ((err < band[0]) | (err > band[1]))
    return out


def lift_figure(label: str, table: Any, feature: Mapping[str, Any]) -> Any:
    """The figure of one ``/metrology/lift`` table (columns alpha [rad], measured and
    design lift [m]): lift [mm] on top (the design line under the measured points),
    measured - design [um] below with the tolerance band of the feature's verdict (dashed
    red lines on the lobe, shaded zones with their own band) and the samples outside
    their band in red; the error axis spans the data and the band (at least +-0.5 um).
    For a lobe, ``table`` is the base-referenced table the verdict uses. The legend sits
    above the axes, so it never hides data; the x axis is named after the reference of
    alpha: the fitted nose (lobe), pin centre or keyway centre."""
    import matplotlib.pyplot as plt

    alpha = np.degrees(table[:, 0])
    err = (table[:, 1] - table[:, 2]) * 1e6
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.5))
    ax1.plot(alpha, table[:, 2] * 1e3, '-', lw=0.8, color=DESIGN, zorder=1,
             label='design (as seen by the probe)')
    ax1.plot(alpha, table[:, 1] * 1e3, 'o', ms=1.6, mew=0, color=MEASURED, alpha=0.8,
             zorder=3, label='measured')
    ax1.set_ylabel('lift [mm]')
    ax1.legend(loc='lower center', bbox_to_anchor=(0.5, 1.0), ncol=2, frameon=False,
               markerscale=4)
    angle = feature.get('angle_deg')
    fig.suptitle(f'{label}: angle {angle:.5f} deg' if angle is not None else label)
    band, zones = tolerance_bands(feature)
    bad = _outside(alpha, err, table[:, 2], band, zones)
    ax2.plot(alpha[~bad], err[~bad], 'o', ms=1.6, mew=0, color=MEASURED, zorder=3)
    if np.any(bad):
        ax2.plot(alpha[bad], err[bad], 'o', ms=3, mew=0, color=LIMIT, zorder=4,
                 label=f'{int(np.count_nonzero(bad))} outside the band')
    span = [float(np.min(err)), float(np.max(err))] if err.size else [0.0, 0.0]
    if band is not None:
        on = table[:, 2] > 0
        lo_a, hi_a = (float(alpha[on].min()), float(alpha[on].max())) if np.any(on) \
            else (float(alpha.min()), float(alpha.max()))
        for y in band:
            ax2.hlines(y, lo_a, hi_a, color=LIMIT, lw=1.0, ls='--', zorder=2)
        span += list(band)
        ax2.text(0.01, 0.97, f'tolerance {band[0]:g} .. {band[1]:g} µm on the lobe',
                 color=LIMIT, transform=ax2.transAxes, va='top', fontsize=8)
    for a0, a1, lo, hi in zones:
        ax2.fill_between([a0, a1], lo, hi, color=LIMIT, alpha=0.12, lw=0, zorder=1)
        ax2.text(0.5 * (a0 + a1), hi, f'{lo:g}..{hi:g} µm', color=LIMIT, fontsize=7,
                 ha='center', va='bottom')
        span += [lo, hi]
    mid = 0.5 * (max(span) + min(span))
    half = max(0.5 * (max(span) - min(span)) * 1.15, 0.5)
    ax2.set_ylim(mid - half, mid + half)
    if np.any(bad):
        ax2.legend(loc='lower right', fontsize=8, frameon=False)
    kind = feature.get('kind') or ('dowel_pin' if label == 'dowel_pin' else
                                   'keyway' if label == 'keyway' else 'lobe')
    ax2.set_ylabel('lift error, from the base circle [µm]' if kind == 'lobe'
                   else 'measured - design [µm]')
    ax2.set_xlabel({'dowel_pin': 'alpha from the fitted pin centre [deg]',
                    'keyway': 'alpha from the fitted keyway centre [deg]'}.get(
                        kind, 'alpha from the fitted nose [deg]'))
    fig.tight_layout()
    return fig


def scale_to_curve(ax: Any, values: Any, what: str = 'the reconstruction') -> None:
    """Y limits of ``ax`` from ``values`` (a measured or reconstructed curve, 10 %
    margin), so that a design's derivative spikes at its junctions (jumps of h'' give
    jerk spikes) do not squash the curve; says so on the axes when it clips."""
    lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
    pad = 0.1 * max(hi - lo, 1e-12)
    y0, y1 = ax.get_ylim()
    ax.set_ylim(lo - pad, hi + pad)
    if y0 < lo - pad or y1 > hi + pad:
        ax.text(0.99, 0.03, f'scaled to {what}; design spikes clipped',
                transform=ax.transAxes, ha='right', va='bottom', fontsize=7, color='0.3')


def derivative_figure(label: str, columns: Any, data: Any, design: Any = None) -> Any:
    """Velocity [mm/deg] and acceleration [mm/deg^2] of a ``/reconstruction/profile``
    table (columns alpha_rad, lift_m, velocity_m_per_rad, acceleration_m_per_rad2, ...)
    with the design's (``design(alpha, nu)`` as seen by the probe, dashed) beneath;
    the axes are scaled to the reconstruction."""
    import matplotlib.pyplot as plt

    cols = list(columns)
    alpha = np.asarray(data[:, cols.index('alpha_rad')])
    deg = np.pi / 180.0
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
    for ax, (name, nu, unit) in zip(axes, (('velocity_m_per_rad', 1, 'mm/deg'),
                                           ('acceleration_m_per_rad2', 2, 'mm/deg²'))):
        values = np.asarray(data[:, cols.index(name)]) * 1e3 * deg ** nu
        if design is not None:
            ax.plot(np.degrees(alpha), np.asarray(design(alpha, nu)) * 1e3 * deg ** nu, '--',
                    lw=0.8, color=DESIGN, zorder=1, label='design (as seen by the probe)')
        ax.plot(np.degrees(alpha), values, '-', lw=1.0, color=MEASURED, zorder=3,
                label='measured (reconstructed)')
        ax.set_ylabel(f'{name.split("_")[0]} [{unit}]')
        ax.grid(True, alpha=0.3)
        scale_to_curve(ax, values)
    axes[0].legend(loc='lower center', bbox_to_anchor=(0.5, 1.0), ncol=2, frameon=False)
    axes[1].set_xlabel('alpha from the fitted nose [deg]')
    fig.suptitle(f'{label}: velocity and acceleration')
    fig.tight_layout()
    return fig
