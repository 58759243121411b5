"""`cam-bench scene check FILE`: validate a scene file, print a summary and its warnings.

Offline (no ROS graph): the whole scene is validated (exit 2 with a message naming the
key, the value and what was expected); the summary lists the lobes, datum, crank,
valve train and tolerances.
"""
from __future__ import annotations

import argparse
import math
from typing import Any

from cam_metrology.cli.scene_input import load_scene_arg


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``check`` to the ``scene`` group."""
    p = sub.add_parser(
        'check', help='validate a scene file and print a summary',
        description='Validate the whole scene (exit 2 with a message naming the key, the '
                    'value and what was expected); print a summary and the warnings for '
                    'unknown keys.')
    p.add_argument('file', metavar='FILE', help='scene YAML file ("-" for stdin)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench scene check``: validate a scene file; print the summary and
    the warnings (0; 2 for an invalid scene)."""
    scene = load_scene_arg(args.file)
    print(f'{args.file}: valid scene')
    for line in scene_summary(scene):
        print(f'  {line}')
    for warning in scene.warnings:
        print(f'warning: {warning}')
    return 0


def scene_summary(scene: Any) -> list[str]:
    """Human-readable lines describing a validated scene."""
    deg = 180.0 / math.pi
    probe = scene.probe
    lines = [
        f'camshaft_id: {scene.camshaft_id or "(none)"}',
        f'direction: {scene.direction:+d}',
        f'probe: {probe.kind}' + (f' r={probe.radius * 1e3:g} mm' if probe.radius else ''),
        f'base circle radius: {scene.base_circle_radius * 1e3:g} mm',
        f'lobes: {len(scene.lobes)}',
    ]
    for lobe in scene.lobes:
        lo, hi = lobe.lift.support
        source = (f'lift_law {lobe.lift_spec.get("family")}' if lobe.lift_spec
                  else f'nominal file {lobe.nominal_file}' if lobe.nominal_file
                  else 'table')
        phase = ('-' if lobe.nominal_phase is None
                 else f'{lobe.nominal_phase * deg:.3f} deg')
        follower = lobe.follower.kind + (f' r={lobe.follower.radius * 1e3:g} mm'
                                         if lobe.follower.radius else '')
        lines.append(f'  {lobe.id}: {source}, design follower {follower}, '
                     f'max lift {lobe.lift.max_lift() * 1e3:.4f} mm, '
                     f'support [{lo * deg:.2f}, {hi * deg:.2f}] deg, nominal phase {phase}')
        tol = getattr(lobe, 'tolerances', None)
        lines.append(f'    tolerances: {tolerance_text(tol)}')
    pin, kw = scene.dowel_pin, getattr(scene, 'keyway', None)
    if kw is not None:
        depth = 'ball wider than the slot' if kw.depth is None else \
            f'depth {kw.depth * 1e3:g} mm'
        lines.append(f'keyway: width {kw.width * 1e3:g} mm, shaft r={kw.shaft_radius * 1e3:g} '
                     f'mm, ball r={kw.probe_radius * 1e3:g} mm, {depth}')
    elif pin is None:
        lines.append('dowel_pin: none')
    else:
        lines.append(f'dowel_pin: pin r={pin.pin_radius * 1e3:g} mm, circle '
                     f'r={pin.circle_radius * 1e3:g} mm, ball r={pin.probe_radius * 1e3:g} mm')
    crank = getattr(scene, 'crank', None)
    if crank is not None:
        roles = ', '.join(f'{lb.id} {lb.role} cyl {lb.cylinder}' for lb in scene.lobes
                          if lb.role) or 'no lobe has a role'
        lines.append(f'crank: cylinder 1 TDC {crank.tdc_deg:g} cam deg from the '
                     f'{scene.datum_id.replace("_", " ")}; {roles}')
    compute = 'all the data allows' if scene.compute is None else ', '.join(
        sorted(scene.compute))
    lines.append(f'compute: {compute}')
    vt = scene.valve_train
    if vt is None:
        lines.append('valve_train: none')
    else:
        speeds = ', '.join(f'{v:g}' for v in vt.cam_speed_rpm)
        lines.append(f'valve_train: {vt.model}, rocker ratio {vt.rocker_ratio:g}, '
                     f'lash {vt.lash * 1e3:g} mm, cam speeds {speeds} rpm')
    datum = getattr(scene, 'datum_tolerance_deg', None)
    if datum is not None:
        centre = 'keyway' if getattr(scene, 'keyway', None) is not None else 'pin'
        lines.append(f'datum: {centre} centre {_band(datum, "deg")}')
    lines.append(f'idle_timeout: {scene.idle_timeout:g} s')
    return lines


def _band(band: Any, unit: str) -> str:
    """'+-10 um' for a symmetric band (lower, upper), else '[-5, +10] um'."""
    lo, hi = band
    if lo == -hi:
        return f'+-{hi:g} {unit}'
    return f'[{lo:+g}, {hi:+g}] {unit}'


def tolerance_text(tol: Any) -> str:
    """The limits of one lobe in one line ('none' when it has none)."""
    if tol is None or not tol.any():
        return 'none (no verdict for this lobe)'
    parts = []
    if tol.lift_error_um is not None:
        parts.append(f'lift error {_band(tol.lift_error_um, "µm")}')
    for z in tol.lift_error_zones:
        parts.append(f'lift error {_band(z.band_um, "µm")} over {z.from_deg:g}..{z.to_deg:g} deg')
    if tol.max_lift_um is not None:
        parts.append(f'max lift {_band(tol.max_lift_um, "µm")}')
    if tol.centreline_deg is not None:
        parts.append(f'centreline {_band(tol.centreline_deg, "deg")} at '
                     f'{tol.checking_height_mm:g} mm')
    if tol.duration_deg is not None:
        parts.append(f'duration {_band(tol.duration_deg, "deg")} at '
                     f'{tol.checking_height_mm:g} mm')
    if tol.phase_deg is not None:
        parts.append(f'phase {_band(tol.phase_deg, "deg")}')
    if tol.runout_max_um is not None:
        parts.append(f'base-circle run-out <= {tol.runout_max_um:g} µm')
    for name, limit, unit in (('velocity', tol.velocity_error_max_mm_per_rad, 'mm/rad'),
                              ('acceleration', tol.acceleration_error_max_mm_per_rad2,
                               'mm/rad²')):
        if limit is not None:
            parts.append(f'{name} error <= {limit:g} {unit}')
    for z in tol.derivative_error_zones:
        limits = [f'{name} error <= {v:g} {unit}' for name, v, unit in (
            ('velocity', z.velocity_max_mm_per_rad, 'mm/rad'),
            ('acceleration', z.acceleration_max_mm_per_rad2, 'mm/rad²')) if v is not None]
        parts.append(f'{" and ".join(limits)} over {z.from_deg:g}..{z.to_deg:g} deg')
    return '; '.join(parts)
