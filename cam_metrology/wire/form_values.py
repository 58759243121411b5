"""The form, journal and track numbers of a report as named scalars: one list that
``/metrology/values`` (``wire.plots.report_values``) and the HTML report's form table
both read (docs/contract.md "Values"). No rclpy.

Each ``FormValue`` takes one number out of a feature's report entry (the lobe's
``lobe_tracks`` entry for the track results) and names the verdict quantity that judges
it, if any: its verdict is ``fail`` when any check of that quantity (or of its zones,
``<quantity>[a..b deg]``) failed, ``pass`` when all passed, None when none was made.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping

__all__ = ['FormValue', 'FORM_VALUES', 'SHAFT_VALUES', 'form_value_names', 'quantity_checks',
           'quantity_verdict', 'feature_form_values']

Entry = Mapping[str, Any]


def _at(*path: str | int) -> Callable[[Entry], Any]:
    """Getter of ``entry[path[0]][path[1]]...`` (None where a step is missing)."""
    def get(entry: Entry) -> Any:
        value: Any = entry
        for step in path:
            if isinstance(step, int):
                value = value[step] if isinstance(value, list) and len(value) > step else None
            else:
                value = value.get(step) if isinstance(value, Mapping) else None
            if value is None:
                return None
        return value
    return get


@dataclass(frozen=True)
class FormValue:
    """A named number (unit in the name) of a feature: ``get`` reads it from the
    feature's entry (``tracks``: from the lobe's ``lobe_tracks`` entry); ``quantity`` is
    the verdict's check that judges it (None: not judged); ``label`` the HTML heading."""

    name: str
    get: Callable[[Entry], Any]
    quantity: str | None
    label: str
    tracks: bool = False


#: the per-feature numbers, in the order they follow VALUE_NAMES on /metrology/values
FORM_VALUES = (
    FormValue('harmonic_max_upr', _at('harmonics', 0, 'upr'), None, 'largest harmonic UPR'),
    FormValue('harmonic_max_amplitude_um', _at('harmonics', 0, 'amplitude_um'), None,
              'largest harmonic µm'),
    FormValue('roundness_um', _at('roundness_um'), 'roundness_um', 'roundness µm'),
    FormValue('waviness_max_amplitude_um', _at('waviness', 'max_amplitude_um'),
              'waviness_max_amplitude_um', 'waviness µm'),
    FormValue('waviness_upr_at_max', _at('waviness', 'upr_at_max'), None, 'waviness UPR'),
    FormValue('base_circle_runout_um', _at('base_circle_runout_um'), 'base_circle_runout_um',
              'base-circle run-out µm'),
    FormValue('diameter_deviation_um', _at('diameter_deviation_um'), 'diameter_deviation_um',
              'diameter deviation µm'),
    FormValue('runout_um', _at('runout_um'), 'runout_um', 'journal run-out µm'),
    FormValue('runout_direction_deg', _at('runout_direction_deg'), None,
              'run-out direction deg'),
    FormValue('velocity_error_max_mm_per_rad', _at('velocity_error_mm_per_rad', 'max_abs'),
              'velocity_error_mm_per_rad', 'velocity error mm/rad'),
    FormValue('acceleration_error_max_mm_per_rad2',
              _at('acceleration_error_mm_per_rad2', 'max_abs'),
              'acceleration_error_mm_per_rad2', 'acceleration error mm/rad²'),
    FormValue('nose_lift_error_um', _at('nose_lift_error_um'), None, 'track nose lift error µm'),
    FormValue('taper_um_per_mm', _at('taper_um_per_mm'), 'taper_um_per_mm', 'taper µm/mm',
              tracks=True),
    FormValue('nose_angle_difference_deg', _at('nose_angle_difference_deg'),
              'nose_angle_difference_deg', 'twist (nose-angle difference) deg', tracks=True),
)
#: the part's numbers of the shaft (report ``shaft``), after PART_NAMES
SHAFT_VALUES = ('straightness_um', 'bow_um')


def form_value_names() -> tuple[str, ...]:
    """Names on /metrology/values: each FormValue, then ``<name>_verdict`` of each judged
    one."""
    return tuple(v.name for v in FORM_VALUES) + tuple(
        f'{v.name}_verdict' for v in FORM_VALUES if v.quantity is not None)


def quantity_checks(verdict: Any, quantity: str) -> list[Mapping[str, Any]]:
    """The checks of ``quantity`` and of its zones (``<quantity>[a..b deg]``) in a
    verdict ``{checks: [{quantity, result, ...}]}``."""
    checks = verdict.get('checks') if isinstance(verdict, Mapping) else None
    return [c for c in checks or ()
            if isinstance(c, Mapping) and isinstance(c.get('quantity'), str) and
            (c['quantity'] == quantity or c['quantity'].startswith(quantity + '['))]


def quantity_verdict(verdict: Any, quantity: str) -> str | None:
    """'fail' | 'pass' of the checks of ``quantity`` (and its zones) in a verdict;
    None when it has none."""
    results = [c.get('result') for c in quantity_checks(verdict, quantity)]
    if not results:
        return None
    return 'fail' if 'fail' in results else 'pass'


def feature_form_values(entry: Entry, tracks: Entry | None
                        ) -> list[tuple[FormValue, Any, str | None]]:
    """[(FormValue, its value or None, its verdict or None)] of one feature (``tracks``:
    the lobe's ``lobe_tracks`` entry, with its ``verdict``, or None)."""
    out = []
    for v in FORM_VALUES:
        source = (tracks or {}) if v.tracks else entry
        verdict = source.get('verdict')
        out.append((v, v.get(source), None if v.quantity is None
                    else quantity_verdict(verdict, v.quantity)))
    return out
