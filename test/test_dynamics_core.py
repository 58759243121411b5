"""Dynamics node core and CLI (no rclpy): topics, labels, skips, profile input."""
from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace as NS

import numpy as np
import pytest
import yaml

from cam_design.errors import InputError
from cam_metrology.dynamics.core import (MOTION, PROFILE, RESULT, DynamicsCore,
                                         law_from_profile)
from cam_metrology.cores.outputs import StatusOutput, TableOutput

REPO = Path(__file__).resolve().parent.parent
SCENE = (REPO / 'config' / 'default_scene.yaml').read_text()


def scene_text(**changes) -> str:
    doc = yaml.safe_load(SCENE)
    doc['lobes'] = doc['lobes'][:1]
    doc['valve_train']['cam_speed_rpm'] = [1500.0]
    doc.update(changes)
    return yaml.safe_dump(doc, sort_keys=False)


def profile_msg(label: str, alpha: np.ndarray, jets: np.ndarray) -> NS:
    cols = 'alpha_rad,lift_m,velocity_m_per_rad,acceleration_m_per_rad2,jerk_m_per_rad3'
    data = np.column_stack([alpha, *jets])
    dims = [NS(label=label, size=data.shape[0], stride=data.size),
            NS(label=cols, size=5, stride=5)]
    return NS(layout=NS(dim=dims, data_offset=0), data=data.ravel().tolist())


def test_parameters_declared_and_config_matches() -> None:
    cfg = yaml.safe_load((REPO / 'config' / 'dynamics.yaml').read_text())
    assert set(cfg['dynamics']['ros__parameters']) == set(DynamicsCore.PARAMETERS)
    core = DynamicsCore(cfg['dynamics']['ros__parameters'])
    assert core.subscriptions == {'/bench/scene': 'std_msgs/msg/String',
                                  PROFILE: 'std_msgs/msg/Float64MultiArray'}
    with pytest.raises(InputError, match='dynamics.bogus'):
        DynamicsCore({'bogus': 1})
    with pytest.raises(InputError, match='dynamics.source'):
        DynamicsCore({'source': 'x'})
    with pytest.raises(InputError, match=r'dynamics.cam_speeds_rpm\[1\]'):
        DynamicsCore({'cam_speeds_rpm': '1500,-3'})


def test_design_source_publishes_tables_and_statuses() -> None:
    core = DynamicsCore({'source': 'design', 'step_deg': 0.5})
    outs = core.handle('/bench/scene', NS(data=scene_text()), 7)
    tables = [o for o in outs if isinstance(o, TableOutput)]
    assert [t.label for t in tables] == ['lobe_1/1500rpm']
    t = tables[0]
    assert t.topic == MOTION and t.columns == ('alpha_rad', 'valve_lift_m',
                                               'valve_velocity_m_per_s', 'contact_force_n',
                                               'contact_stress_pa')
    assert t.data.shape == (721, 5) and np.all(np.isfinite(t.data))
    assert np.allclose(np.diff(t.data[:, 0]), math.radians(0.5))
    st = [o for o in outs if isinstance(o, StatusOutput)][0]
    assert st.topic == RESULT and st.statuses[0].name == 'lobe_1/1500rpm'
    vals = st.statuses[0].values
    assert vals['source'] == 'design' and float(vals['epsilon']) > 0
    assert float(vals['seating_velocity_m_s']) > 0
    assert core.finish() == []


@pytest.mark.parametrize('changes, why', [
    ({'valve_train': None}, 'scene has no valve_train'),
    ({'compute': ['nose', 'pin']}, 'dynamics not in compute'),
])
def test_skipped_with_reason(changes: dict, why: str) -> None:
    core = DynamicsCore()
    outs = core.handle('/bench/scene', NS(data=scene_text(**changes)), 0)
    assert len(outs) == 1 and outs[0].statuses[0].name == 'skipped/dynamics'
    assert outs[0].statuses[0].message == why
    assert core.finish() == []


def test_profile_source_and_design_fallback() -> None:
    """A reconstructed profile (design law sampled with its jets) gives the same motion
    as the design law; lobes without a profile fall back to the design at finish."""
    doc = yaml.safe_load(SCENE)
    doc['lobes'] = doc['lobes'][:2]
    doc['valve_train']['cam_speed_rpm'] = [2000.0]
    text = yaml.safe_dump(doc, sort_keys=False)
    ref = DynamicsCore({'source': 'design', 'step_deg': 0.5})
    ref_out = [o for o in ref.handle('/bench/scene', NS(data=text), 0)
               if isinstance(o, TableOutput)]
    core = DynamicsCore({'step_deg': 0.5, 'profile_method': 'spline'})
    assert core.handle('/bench/scene', NS(data=text), 0) == []
    law = ref.scene.lobe('lobe_1').lift
    a = np.linspace(-math.pi, math.pi, 3601)
    assert core.handle(PROFILE, profile_msg('lobe_1/harmonic', a, law.derivatives(a)), 1) == []
    assert core.handle(PROFILE, profile_msg('lobe_1/spline/probe', a, law.derivatives(a)),
                       1) == []
    outs = core.handle(PROFILE, profile_msg('lobe_1/spline', a, law.derivatives(a)), 2)
    tab = [o for o in outs if isinstance(o, TableOutput)][0]
    # both grids are multiples of the step (alpha = 0 is a node): compare common rows
    ia = np.rint(tab.data[:, 0] / math.radians(0.5)).astype(int)
    ib = np.rint(ref_out[0].data[:, 0] / math.radians(0.5)).astype(int)
    common, i1, i2 = np.intersect1d(ia, ib, return_indices=True)
    assert common.size > 600
    assert np.max(np.abs(tab.data[i1, 1] - ref_out[0].data[i2, 1])) < 1e-9
    status = [o for o in outs if isinstance(o, StatusOutput)][0].statuses[0]
    assert status.values['source'] == 'profile:spline'
    rest = core.finish()
    assert [o.label for o in rest if isinstance(o, TableOutput)] == ['lobe_2/2000rpm']


def test_bad_profile_reported_not_raised() -> None:
    core = DynamicsCore({'step_deg': 0.5})
    core.handle('/bench/scene', NS(data=scene_text()), 0)
    a = np.linspace(-1, 1, 50)
    outs = core.handle(PROFILE, profile_msg('lobe_1/spline', a, np.full((4, 50), np.nan)), 1)
    assert outs[0].statuses[0].level == 2 and 'non-finite' in outs[0].statuses[0].message
    with pytest.raises(InputError):
        law_from_profile(('alpha_rad', 'lift_m'), np.zeros((5, 2)), 'x')


def test_cli_scene_json_and_sweep(tmp_path: Path, capsys) -> None:
    from cam_metrology.cli import main

    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    out = tmp_path / 'out.json'
    rc = main(['dynamics', str(scene), '--rpm', '1500', '--rpm', '2500', '--step-deg', '0.5',
               '--sweep', '1500:2500:250', '--json', str(out), '--plot', str(tmp_path / 'p')])
    assert rc == 0
    res = json.loads(out.read_text())
    feat = res['features']['lobe_1']
    assert [r['cam_speed_rpm'] for r in feat['runs']] == [1500.0, 2500.0]
    run = feat['runs'][0]
    for key in ('alpha_deg', 'valve_lift_m', 'contact_force_n', 'separations',
                'seating_velocity_m_s', 'bounce_count', 'max_contact_stress_pa', 'epsilon'):
        assert key in run
    assert len(run['alpha_deg']) == len(run['valve_lift_m']) == 721
    assert 1500 < feat['jump_speed_rpm'] <= 2500
    assert feat['runs'][1]['separations']
    assert (tmp_path / 'p' / 'lobe_1.png').exists()


def test_cli_errors_exit_2(tmp_path: Path, capsys) -> None:
    from cam_metrology.cli import main

    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    assert main(['dynamics', str(scene), '--rpm', '-5', '--json', '-']) == 2
    assert '--rpm[0]' in capsys.readouterr().err
    assert main(['dynamics', str(scene), '--feature', 'nope']) == 2
    assert main(['dynamics', str(scene), '--sweep', '5:1:1']) == 2
    assert main(['dynamics', str(tmp_path / 'missing.yaml')]) == 2
    novt = tmp_path / 'novt.yaml'
    novt.write_text(scene_text(valve_train=None))
    assert main(['dynamics', str(novt)]) == 2
    assert 'valve_train' in capsys.readouterr().err


@pytest.mark.slow
def test_cli_bag_uses_reconstructed_profiles(tmp_path: Path) -> None:
    from cam_metrology.cli import main

    bag = REPO / 'bags' / 'default_clean'
    if not bag.exists():
        pytest.skip('fixture bag missing')
    out = tmp_path / 'bag.json'
    assert main(['dynamics', str(bag), '--rpm', '1500', '--step-deg', '0.5',
                 '--json', str(out)]) == 0
    res = json.loads(out.read_text())
    assert res['kind'] == 'bag' and res['features']
    for feat in res['features'].values():
        assert feat['source'].startswith(('profile:', 'design'))
        assert feat['runs'][0]['opening_deg'] is not None


def test_cli_mdof_model(tmp_path: Path) -> None:
    from cam_metrology.cli import main

    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    out = tmp_path / 'mdof.json'
    assert main(['dynamics', str(scene), '--model', 'mdof', '--rpm', '1500',
                 '--step-deg', '1', '--json', str(out)]) == 0
    run = json.loads(out.read_text())['features']['lobe_1']['runs'][0]
    assert run['model'] == 'mdof' and len(run['natural_frequencies_hz']) == 6
    assert run['seating_velocity_m_s'] > 0 and run['opening_deg'] < 0 < run['closing_deg']
    assert len(run['spring_surge_hz']) == 2


def test_cli_mdof_sweep_and_hydraulic_refused(tmp_path: Path, capsys) -> None:
    """`--model mdof --sweep`: the MDOF model's speeds with the SDOF rules (brackets with
    null open ends, statuses, notes); no no-open speed for the cam-driven train (null with
    its reason); the hydraulic model on a scene without its block: refused naming it."""
    from cam_metrology.cli import main

    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    out = tmp_path / 'mdof_sweep.json'
    assert main(['dynamics', str(scene), '--model', 'mdof', '--rpm', '1500', '--step-deg',
                 '2', '--sweep', '1500:1600:100', '--json', str(out)]) == 0
    res = json.loads(out.read_text())
    feat = res['features']['lobe_1']
    sw = feat['sweep']
    run = feat['runs'][0]
    assert res['model'] == 'mdof' and sw['sweep_rpm'] == [1500.0, 1600.0]
    # the sweep's 1500 rpm is the --rpm 1500 run (the same MDOF computation)
    assert sw['status'][0] == ('separated' if run['jump'] else
                               'clean' if run['settled'] else 'unsettled')
    assert sw['max_valve_lift_m'][0] == pytest.approx(run['max_valve_lift_m'], rel=1e-9)
    assert sw['settled'][0] == run['settled']
    if 'clean' not in sw['status']:
        assert feat['jump_bracket_rpm'] == [None, 1500.0]
    elif sw['status'] == ['clean', 'clean']:
        assert feat['jump_bracket_rpm'] == [1600.0, None] and feat['jump_speed_rpm'] is None
    assert feat['no_open_speed_rpm'] is None and feat['no_open_bracket_rpm'] is None
    assert 'the cam drives the valve open' in feat['no_open_note']
    # no gas: the force to overcome at the opening is the preload, at every opened speed
    assert all(f is None or f == pytest.approx(250.0) for f in sw['opening_force_n'])
    assert main(['dynamics', str(scene), '--model', 'hydraulic', '--sweep',
                 '1500:3000:1500']) == 2
    assert 'valve_train.hydraulic' in capsys.readouterr().err


# -- QA findings (notes/qa.md #3, #6, #11, #16, #23) and the scene's lobes[].width ------

def _run_values(core: DynamicsCore, outs: list) -> tuple[np.ndarray, dict]:
    tab = [o for o in outs if isinstance(o, TableOutput)][0]
    status = [o for o in outs if isinstance(o, StatusOutput)][0].statuses[0]
    return tab.data, status.values


def test_lobe_width_used_for_hertz_stress_else_parameter() -> None:
    """Flat tappet Hertz (2.11): sigma = 0.418 sqrt(E F / (W rho1)), rho1 = R0 + h + h'':
    with the scene's lobes[].width = 3 mm the stress is exactly twice that with the
    12 mm parameter (same forces), and the status says which width was used."""
    doc = yaml.safe_load(scene_text())
    plain = yaml.safe_dump(doc, sort_keys=False)
    doc['lobes'][0]['width'] = 0.003
    narrow = yaml.safe_dump(doc, sort_keys=False)
    ref = DynamicsCore({'source': 'design', 'step_deg': 1.0, 'cam_width': 0.012})
    d12, v12 = _run_values(ref, ref.handle('/bench/scene', NS(data=plain), 0))
    core = DynamicsCore({'source': 'design', 'step_deg': 1.0, 'cam_width': 0.012})
    d3, v3 = _run_values(core, core.handle('/bench/scene', NS(data=narrow), 0))
    assert v12['cam_width_m'] == '0.012' and v12['cam_width_source'] == 'parameter cam_width'
    assert v3['cam_width_m'] == '0.003' and v3['cam_width_source'] == 'scene lobes[].width'
    assert np.array_equal(d3[:, 3], d12[:, 3])                       # same forces
    loaded = d12[:, 3] > 1.0
    assert np.allclose(d3[loaded, 4], 2.0 * d12[loaded, 4], rtol=1e-12)
    law = core.scene.lobe('lobe_1').lift
    i = int(np.argmax(d3[:, 3]))
    a = d3[i, 0]
    rho1 = core.scene.base_circle_radius + float(law(a)) + float(law(a, 2))
    sigma = 0.418 * math.sqrt(2.06e11 * d3[i, 3] / (0.003 * rho1))
    assert d3[i, 4] == pytest.approx(sigma, rel=1e-3)   # 0.418 is the rounded constant
    assert float(v3['max_contact_stress_pa']) == pytest.approx(np.nanmax(d3[:, 4]))


def test_cli_width_precedence_and_human_output(tmp_path: Path, capsys) -> None:
    import re

    from cam_metrology.cli import main

    doc = yaml.safe_load(scene_text())
    doc['lobes'] = yaml.safe_load(SCENE)['lobes'][:2]
    doc['lobes'][1]['width'] = 0.008
    scene = tmp_path / 'scene.yaml'
    scene.write_text(yaml.safe_dump(doc, sort_keys=False))
    out = tmp_path / 'w.json'
    assert main(['dynamics', str(scene), '--cam-width', '0.01', '--step-deg', '1',
                 '--json', str(out)]) == 0
    human = capsys.readouterr().out.strip().splitlines()
    feats = json.loads(out.read_text())['features']
    r1, r2 = feats['lobe_1']['runs'][0], feats['lobe_2']['runs'][0]
    assert (r1['cam_width_m'], r1['cam_width_source']) == (0.01, 'parameter cam_width')
    assert (r2['cam_width_m'], r2['cam_width_source']) == (0.008, 'scene lobes[].width')
    # human output (QA #23): fixed precision with units, consistent with the JSON
    assert len(human) == 2
    line = human[0]
    assert not re.findall(r'\d\.\d{4,}', line), line
    assert f"opening {r1['opening_deg']:.3f} deg" in line
    assert f"closing {r1['closing_deg']:.3f} deg" in line
    assert f"seating {r1['seating_velocity_m_s']:.3f} m/s" in line
    assert f"max stress {r1['max_contact_stress_pa'] / 1e6:.1f} MPa" in line
    assert 'W 10.0 mm, parameter cam_width' in line
    assert 'W 8.0 mm, scene lobes[].width' in human[1]


def test_step_deg_range_checked_before_allocation(tmp_path: Path, capsys) -> None:
    """QA #11: --step-deg 1e-7 needed 27 GiB (traceback); now a one-line error."""
    from cam_design.valve_train.sdof import simulate
    from cam_metrology.cli import main

    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    for bad in ('1e-7', '0.001', '6', 'nan', 'inf'):
        assert main(['dynamics', str(scene), '--step-deg', bad]) == 2
        err = capsys.readouterr().err
        assert '--step-deg' in err and '[0.01, 5] deg' in err and 'Traceback' not in err
    for bad in (1e-7, float('nan'), 10):
        with pytest.raises(InputError, match=r'dynamics\.step_deg'):
            DynamicsCore({'step_deg': bad})
    law = DynamicsCore({'source': 'design'})
    law.handle('/bench/scene', NS(data=scene_text(compute=['nose'])), 0)
    with pytest.raises(InputError, match='step_deg'):
        simulate(law.scene.lobe('lobe_1').lift, None, 1500.0, step_deg=1e-7)  # type: ignore


def test_absurd_speeds_rejected_and_unseated_runs_explained(tmp_path: Path, capsys) -> None:
    """QA #16: speeds above 1e5 rpm are rejected naming the option; a speed the valve
    train cannot follow (20000 rpm: the valve never returns to the seat) has no events
    and says why instead of 'opening None deg'."""
    from cam_metrology.cli import main

    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    assert main(['dynamics', str(scene), '--rpm', '1e9']) == 2
    assert '--rpm[0]' in capsys.readouterr().err
    assert main(['dynamics', str(scene), '--sweep', '1000:1e9:1e8']) == 2
    assert '--sweep.HI' in capsys.readouterr().err
    with pytest.raises(InputError, match=r'dynamics\.cam_speeds_rpm\[0\]'):
        DynamicsCore({'cam_speeds_rpm': '1e9'})
    out = tmp_path / 'fast.json'
    assert main(['dynamics', str(scene), '--rpm', '20000', '--step-deg', '1',
                 '--json', str(out)]) == 0
    human = capsys.readouterr().out
    run = json.loads(out.read_text())['features']['lobe_1']['runs'][0]
    assert run['closing_deg'] is None and run['left_cam'] is True
    assert run['max_valve_lift_m'] > 1.2 * run['rigid_max_lift_m']
    assert 'leaves the cam at 20000 rpm' in run['note']
    assert 'None' not in human and 'closing none' in human
    assert 'VALVE LEAVES THE CAM' in human and 'note: the valve leaves the cam' in human


def test_bag_without_profiles_says_design_law_used(tmp_path: Path, capsys) -> None:
    """QA #3: a bag with a scene but no measured samples -> the design law is used and
    said so: `note` in the feature's JSON, a warning line on stderr, `source_note` in
    the status; a scene input (design asked for) has no note."""
    from cam_metrology.bagio import BagWriter, encode_string
    from cam_metrology.cli import main

    bag = tmp_path / 'scene_only'
    with BagWriter(bag) as w:
        w.write('/bench/scene', 1, encode_string(scene_text()))
    out = tmp_path / 'bag.json'
    assert main(['dynamics', str(bag), '--rpm', '1500', '--step-deg', '1',
                 '--json', str(out)]) == 0
    cap = capsys.readouterr()
    feat = json.loads(out.read_text())['features']['lobe_1']
    assert feat['source'] == 'design'
    assert feat['note'].startswith('no measured profile for this lobe')
    assert 'warning: lobe_1: no measured profile' in cap.err
    core = DynamicsCore({'step_deg': 1.0})
    assert core.handle('/bench/scene', NS(data=scene_text()), 0) == []
    status = [o for o in core.finish() if isinstance(o, StatusOutput)][0].statuses[0]
    assert status.values['source'] == 'design' and 'design law used' in status.values[
        'source_note']
    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    assert main(['dynamics', str(scene), '--step-deg', '1', '--json', str(out)]) == 0
    assert 'note' not in json.loads(out.read_text())['features']['lobe_1']
    assert 'warning' not in capsys.readouterr().err


def test_sweep_reports_bounced_not_a_partial_count(tmp_path: Path) -> None:
    """QA #6: the sweep stops after the first bounce, so it reports `bounced` (bool),
    which agrees with the full runs' bounce_count > 0 at the same speeds."""
    from cam_metrology.cli import main

    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    out = tmp_path / 's.json'
    assert main(['dynamics', str(scene), '--rpm', '1000', '--rpm', '1500', '--step-deg',
                 '1', '--sweep', '1000:1500:500', '--json', str(out)]) == 0
    feat = json.loads(out.read_text())['features']['lobe_1']
    sw = feat['sweep']
    assert 'bounce_count' not in sw and sw['sweep_rpm'] == [1000.0, 1500.0]
    assert sw['bounced'] == [r['bounce_count'] > 0 for r in feat['runs']]
    assert all(isinstance(b, bool) for b in sw['bounced'])
    assert feat['runs'][1]['bounce_count'] > 1          # a full run counts every bounce


def test_failed_run_shown_and_exit_1(tmp_path: Path, capsys) -> None:
    """A scene speed beyond 1e5 rpm fails that run (the others are computed): the
    failure is printed with its reason and the exit status is 1 (was silent, exit 0)."""
    from cam_metrology.cli import main

    doc = yaml.safe_load(scene_text())
    doc['valve_train']['cam_speed_rpm'] = [1500.0, 1.0e9]
    scene = tmp_path / 'scene.yaml'
    scene.write_text(yaml.safe_dump(doc, sort_keys=False))
    out = tmp_path / 'f.json'
    assert main(['dynamics', str(scene), '--step-deg', '1', '--json', str(out)]) == 1
    human = capsys.readouterr().out
    feat = json.loads(out.read_text())['features']['lobe_1']
    assert [r['cam_speed_rpm'] for r in feat['runs']] == [1500.0]
    (name, why), = feat['failures'].items()
    assert name == 'lobe_1/1e+09rpm' and '(0, 100000] rpm' in why
    assert f'{name}: FAILED: {why}' in human


def test_json_without_sweep_has_the_sweep_keys_as_null(tmp_path: Path, capsys) -> None:
    """docs/dynamics.md lists jump_speed_rpm, bounce_onset_rpm and sweep for every
    feature: without --sweep they are null (they were missing), and the human output
    does not print a 'jump speed none' line for a sweep that was not asked for."""
    from cam_metrology.cli import main

    scene = tmp_path / 'scene.yaml'
    scene.write_text(scene_text())
    out = tmp_path / 'n.json'
    assert main(['dynamics', str(scene), '--rpm', '1500', '--step-deg', '1',
                 '--json', str(out)]) == 0
    feat = json.loads(out.read_text())['features']['lobe_1']
    for key in ('jump_speed_rpm', 'bounce_onset_rpm', 'sweep'):
        assert key in feat and feat[key] is None, key
    assert 'jump speed' not in capsys.readouterr().out


SHAFT = {'stations': ['sprocket', 'journal_1', 'lobe_1', 'lobe_2', 'journal_2', 'lobe_3',
                      'lobe_4', 'journal_3'],
         'sections': [{'length': 0.03, 'diameter': 0.03}] * 7,
         'lobe_inertia': 1.4e-5, 'damping_ratio': 0.05}


def _shaft_scene() -> str:
    doc = yaml.safe_load(SCENE)
    doc['valve_train']['cam_speed_rpm'] = [1500.0]
    doc['camshaft'] = SHAFT
    return yaml.safe_dump(doc, sort_keys=False)


def _feed(core: DynamicsCore, ref: DynamicsCore, ids: list[str]) -> list:
    a = np.linspace(-math.pi, math.pi, 3601)
    outs: list = []
    for lid in ids:
        law = ref.scene.lobe(lid).lift
        outs.append(core.handle(PROFILE, profile_msg(f'{lid}/spline', a, law.derivatives(a)),
                                1))
    return outs


def test_measured_profiles_run_on_the_flexible_shaft() -> None:
    """With a camshaft block, measured profiles wait until every lobe has one, then run
    together on the flexible shaft: the profiles being the design laws sampled with their
    jets, twist and timing shift equal the design run's to 2e-2 of the peak twist (a
    table law: its support ends where the lift falls below 0.1 % of the peak and its
    junctions are not known, so their kinks stay in the load's plain transform; measured
    5e-3);
    source=auto fills the lobes without a profile with their design law at finish;
    source=profile with lobes missing runs the measured ones on a rigid shaft, saying so."""
    text = _shaft_scene()
    ref = DynamicsCore({'source': 'design', 'step_deg': 1.0})
    ref.handle('/bench/scene', NS(data=text), 0)
    ids = [lb.id for lb in ref.scene.lobes]
    assert len(ids) == 4 and len(ref.camshaft_runs) == 1
    want = ref.camshaft_runs[0]
    peak = max(float(np.max(np.abs(t))) for t in want.twist.values())
    assert peak > 1e-5

    core = DynamicsCore({'step_deg': 1.0, 'profile_method': 'spline'})
    assert core.handle('/bench/scene', NS(data=text), 0) == []
    outs = _feed(core, ref, ids)
    assert all(o == [] for o in outs[:-1])
    labels = sorted(o.label for o in outs[-1] if isinstance(o, TableOutput))
    assert labels == [f'{i}/1500rpm' for i in sorted(ids)]
    got = core.camshaft_runs[0]
    for lid in ids:
        assert np.max(np.abs(got.twist[lid] - want.twist[lid])) < 2e-2 * peak
        assert got.extras[lid]['timing_shift_deg'] == pytest.approx(
            want.extras[lid]['timing_shift_deg'], abs=2e-2 * math.degrees(peak))
        assert core.laws[lid][1] == 'profile:spline'
    assert core.finish() == []

    auto = DynamicsCore({'step_deg': 1.0, 'profile_method': 'spline'})
    auto.handle('/bench/scene', NS(data=text), 0)
    assert _feed(auto, ref, ids[:2]) == [[], []]
    rest = auto.finish()
    assert len([o for o in rest if isinstance(o, TableOutput)]) == 4
    assert [auto.laws[i][1] for i in ids] == ['profile:spline'] * 2 + ['design'] * 2
    assert len(auto.camshaft_runs) == 1 and auto.camshaft_runs[0].converged

    only = DynamicsCore({'source': 'profile', 'step_deg': 1.0, 'profile_method': 'spline'})
    only.handle('/bench/scene', NS(data=text), 0)
    _feed(only, ref, ids[:1])
    rest = only.finish()
    assert [o.label for o in rest if isinstance(o, TableOutput)] == ['lobe_1/1500rpm']
    assert not only.camshaft_runs
    status = [o for o in rest if isinstance(o, StatusOutput)][0].statuses[0]
    assert 'rigid shaft' in status.values['source_note']
