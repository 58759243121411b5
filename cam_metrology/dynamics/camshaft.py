"""Scene glue of the camshaft model (``cam_design.camshaft``): the scene's lobes placed
on the shaft with their valve trains, the coupled run at each speed (docs/camshaft.md).

A lobe's place on the shaft comes from its ``nominal_phase`` (the nose angle from the
datum) and the scene's ``direction``; it is rounded to the output step grid, on which
the shaft and every run share their samples.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from cam_design.camshaft.coupled import CamshaftRun, LobeOnShaft, run_camshaft
from cam_design.camshaft.torsion import assemble
from cam_design.train.run import TrainSpec
from cam_design.valve_train.report import ContactGeometry


def nose_angle(law: Any) -> float:
    """Angle [rad] of the law's largest lift (its nose), on 20 001 samples."""
    lo, hi = (float(v) for v in law.support)
    grid = np.linspace(lo, hi, 20001)
    return float(grid[int(np.argmax(law(grid)))])


def lobes_on_shaft(scene: Any, train: TrainSpec, step_deg: float, cam_width: float,
                   youngs: float, keys: dict[str, str],
                   laws: dict[str, Any] | None = None) -> list[LobeOnShaft]:
    """Every lobe of ``scene`` with its train: lobe angle a = alpha + shift, the nose at
    shaft angle direction x nominal_phase, shift rounded to the ``step_deg`` grid;
    ``laws``: a lobe's lift law by id in place of its design law (a measured profile,
    on its own angle axis: its nose is placed where the design nose is)."""
    step = math.radians(step_deg)
    out = []
    for lobe in scene.lobes:
        law = (laws or {}).get(lobe.id, lobe.lift)
        shift = nose_angle(law) - scene.direction * float(lobe.nominal_phase)
        shift = round(shift / step) * step
        width = float(lobe.width) if getattr(lobe, 'width', None) else cam_width
        geom = ContactGeometry(base_radius=scene.base_circle_radius,
                               follower=lobe.follower.kind, radius=lobe.follower.radius,
                               width=width, youngs_modulus=youngs)
        out.append(LobeOnShaft(id=lobe.id, law=law, shift=shift, train=train,
                               base_radius=scene.base_circle_radius,
                               follower=lobe.follower.kind,
                               roller_radius=lobe.follower.radius, geometry=geom,
                               key=keys.get(lobe.id, 'lift')))
    return out


def run_speeds(scene: Any, train: TrainSpec, speeds: Any, *, step_deg: float,
               cam_width: float, youngs: float, max_revolutions: int,
               keys: dict[str, str], laws: dict[str, Any] | None = None
               ) -> tuple[list[CamshaftRun], dict[str, str]]:
    """The coupled camshaft at each speed [rpm]; failures by '<rpm>rpm' with the reason
    (a speed that fails is left out of the runs); ``laws``: measured lift laws by lobe
    id in place of the design laws."""
    from cam_design.errors import InputError

    lobes = lobes_on_shaft(scene, train, step_deg, cam_width, youngs, keys, laws)
    shaft = assemble(scene.camshaft)
    runs: list[CamshaftRun] = []
    failures = {}
    for rpm in speeds:
        # each speed starts from the last converged one's response (a sweep's speeds are
        # neighbours: far fewer coupling iterations than from the rigid shaft)
        start = next((r.response for r in reversed(runs) if r.converged), None)
        try:
            runs.append(run_camshaft(lobes, scene.camshaft, float(rpm), step_deg=step_deg,
                                     max_revolutions=max_revolutions, shaft=shaft,
                                     start=start))
        except (InputError, RuntimeError, ValueError) as exc:
            failures[f'{float(rpm):g}rpm'] = str(exc)
    return runs, failures
