"""QA findings on the offline commands (notes/qa.md #1, #4, #8, #9, #18, #19, #24):
bad input gives one line and exit 2, an empty measurement is not a success, plots do
not hide their data."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology import bagio
from cam_metrology.cli import main

ROOT = Path(__file__).resolve().parent.parent
CLEAN = ROOT / 'bags' / 'default_clean'
NOT_A_BAG = ROOT / 'config' / 'default_scene.yaml'


def _scene_text() -> str:
    return NOT_A_BAG.read_text()


def _bag(path: Path, frames: list[str]) -> Path:
    """A bag with the default scene and 100 samples per frame id in ``frames``."""
    with bagio.BagWriter(path) as writer:
        writer.add_topic('/bench/scene', 'std_msgs/msg/String')
        writer.write('/bench/scene', 1000, bagio.encode_string(_scene_text()))
        if frames:
            writer.add_topic(bagio.JOINT_STATES, 'sensor_msgs/msg/JointState')
        t = 2000
        for frame in frames:
            for k in range(100):
                writer.write(bagio.JOINT_STATES, t,
                             bagio.encode_joint_state(frame, t, 0.01 * k, 0.0))
                t += 1000
    return path


# --- #1: no samples is not a passing report ---------------------------------------

def test_analyze_bag_without_joint_states_exits_2_naming_the_topic(tmp_path, capsys):
    bag = _bag(tmp_path / 'nojs', [])
    assert main(['analyze', str(bag)]) == 2
    cap = capsys.readouterr()
    assert '/bench/joint_states' in cap.err
    assert len(cap.err.strip().splitlines()) == 1
    assert 'camshaft' not in cap.out   # no (empty) report printed


def test_analyze_with_nothing_measured_reports_and_exits_nonzero(tmp_path, capsys):
    bag = _bag(tmp_path / 'wrongframe', ['not_a_feature'])
    assert main(['analyze', str(bag), '--json', '-', '--only-metrology']) == 1
    cap = capsys.readouterr()
    report = json.loads(cap.out)
    assert report['features']['not_a_feature']['status'] == 'failed'
    assert 'nothing was measured' in cap.err


# --- #4, #9: the parameter file -----------------------------------------------------

@pytest.mark.parametrize('text', ['metrologyy:\n  ros__parameters:\n    fit_runout: false\n',
                                  '/metrolgy:\n  ros__parameters: {}\n'])
def test_params_unknown_node_is_an_error_listing_the_nodes(tmp_path, capsys, text):
    params = tmp_path / 'p.yaml'
    params.write_text(text)
    assert main(['analyze', str(CLEAN), '--params', str(params)]) == 2
    err = capsys.readouterr().err
    assert 'params.' in err and 'metrol' in err
    assert 'metrology, reconstruction, dynamics' in err
    assert 'Traceback' not in err


def test_params_known_node_with_leading_slash_still_applies(tmp_path):
    from cam_metrology.cli.analyze import load_params
    params = tmp_path / 'p.yaml'
    params.write_text('/metrology:\n  ros__parameters:\n    sp_pairs: 2\n')
    assert load_params(str(params)) == {'metrology': {'sp_pairs': 2}}


@pytest.mark.parametrize('kind', ['malformed', 'directory', 'binary'])
def test_params_unreadable_file_is_one_line(tmp_path, capsys, kind):
    params = tmp_path / 'p.yaml'
    if kind == 'malformed':
        params.write_text('metrology: [\n')
    elif kind == 'directory':
        params.mkdir()
    else:
        params.write_bytes(bytes(range(128, 256)) * 4)
    assert main(['analyze', str(CLEAN), '--params', str(params)]) == 2
    err = capsys.readouterr().err
    assert err.startswith('cam-bench analyze: error: --params: got ')
    assert len(err.strip().splitlines()) == 1


# --- #8: a file that is not a bag ---------------------------------------------------

@pytest.mark.parametrize('argv', [['analyze'], ['bag', 'info']])
def test_cli_on_a_yaml_file_is_one_line(capsys, argv):
    assert main([*argv, str(NOT_A_BAG)]) == 2
    err = capsys.readouterr().err
    assert 'bag: got' in err and 'expected a rosbag2 directory or .mcap file' in err
    assert len(err.strip().splitlines()) == 1


def test_reader_on_a_yaml_file_raises_input_error():
    """The shared reader (analyze, bag info and the live replayer use it)."""
    for call in (bagio.bag_topics, lambda p: list(bagio.iter_messages(p)),
                 bagio.open_reader):
        with pytest.raises(InputError) as exc:
            call(NOT_A_BAG)
        assert exc.value.key == 'bag'


# --- #19: --out-bag checked before the analysis -------------------------------------

def test_out_bag_existing_fails_before_the_replay(tmp_path, capsys, monkeypatch):
    from cam_metrology.offline import analyze as offline

    calls = []
    monkeypatch.setattr(offline, 'replay', lambda *a, **k: calls.append(a))
    out = tmp_path / 'exists'
    out.mkdir()
    assert main(['analyze', str(CLEAN), '--out-bag', str(out)]) == 2
    cap = capsys.readouterr()
    assert calls == []
    assert cap.out == ''
    assert '--out-bag' in cap.err


# --- #18: simulate names the option and the value typed -----------------------------

@pytest.mark.parametrize('option, value, expected', [
    ('--noise-um', '-1', '--noise-um: got -1.0; expected a number >= 0'),
    ('--runout-um', '-5', '--runout-um: got -5.0; expected a number >= 0'),
    ('--revolutions', '0', '--revolutions: got 0.0; expected a number > 0'),
    ('--start-deg', 'inf', '--start-deg: got inf; expected a finite'),
    ('--encoder-noise-deg', '-0.5', '--encoder-noise-deg: got -0.5; expected a number >= 0'),
    ('--zero-mm', 'nan', '--zero-mm: got nan; expected a finite'),
    ('--rate', '0', '--rate: got 0.0; expected a number > 0'),
])
def test_simulate_errors_name_the_option(tmp_path, capsys, option, value, expected):
    out = tmp_path / 'sim'
    assert main(['simulate', str(out), option, value, '--quiet']) == 2
    err = capsys.readouterr().err
    assert expected in err
    assert not out.exists()


# --- #24: the dowel-pin plot ---------------------------------------------------------

@pytest.fixture(scope='module')
def fixture_tables():
    """The /metrology/lift tables and the report of the clean fixture bag."""
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.cores.outputs import TableOutput
    from cam_metrology.offline.replay import run_offline

    result = run_offline(CLEAN, [MetrologyCore()])
    tables = {o.output.label: o.output.data for o in result.outputs
              if isinstance(o.output, TableOutput) and o.output.topic == '/metrology/lift'}
    return tables, result.report()


def test_pin_lift_table_is_centred_on_the_pin(fixture_tables):
    """What the pin plot's x axis is: alpha from the fitted pin centre (the lift, seed
    004's L - R_c, peaks at alpha = 0 and the arc is symmetric), not from a nose."""
    tables, _ = fixture_tables
    pin = tables['dowel_pin']
    alpha, lift = pin[:, 0], pin[:, 2]
    assert abs(alpha[np.argmax(lift)]) < np.radians(0.2)
    assert alpha.min() == pytest.approx(-alpha.max(), abs=np.radians(0.2))


@pytest.mark.parametrize('label, xlabel', [('dowel_pin', 'alpha from the fitted pin centre'),
                                           ('lobe_1', 'alpha from the fitted nose')])
def test_plot_legend_hides_no_data_and_x_label(fixture_tables, label, xlabel):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from cam_metrology.report.plots import lift_figure

    tables, report = fixture_tables
    fig = lift_figure(label, tables[label], report['features'][label])
    try:
        fig.canvas.draw()
        ax1, ax2 = fig.axes
        box = ax1.get_legend().get_window_extent()
        for line in ax1.get_lines():
            xy = ax1.transData.transform(line.get_xydata())
            inside = ((xy[:, 0] >= box.x0) & (xy[:, 0] <= box.x1)
                      & (xy[:, 1] >= box.y0) & (xy[:, 1] <= box.y1))
            assert not inside.any(), (label, line.get_label(), int(inside.sum()))
        assert xlabel in ax2.get_xlabel()
    finally:
        plt.close(fig)


# --- additional finding: `bag recover` of something that is not MCAP ----------------

@pytest.mark.parametrize('kind', ['random', 'yaml', 'magic_only'])
def test_recover_of_non_mcap_writes_nothing(tmp_path, capsys, kind):
    if kind == 'yaml':
        src = NOT_A_BAG
    else:
        src = tmp_path / 'src'
        src.mkdir()
        (src / 'metadata.yaml').write_text('rosbag2_bagfile_information: {}\n')
        head = (CLEAN / 'default_clean.mcap').read_bytes()[:20] if kind == 'magic_only' \
            else np.random.default_rng(3).bytes(100_000)
        (src / 'src_0.mcap').write_bytes(head)
    dst = tmp_path / 'dst'
    assert main(['bag', 'recover', str(src), str(dst)]) == 2
    err = capsys.readouterr().err
    assert 'expected an MCAP recording' in err
    assert not dst.exists()


# --- additional finding: asymmetry with samples exactly one knot spacing apart ------

@pytest.mark.parametrize('seed', [1, 2, 3])
def test_asymmetry_spline_at_the_knot_spacing(seed):
    """Samples every 0.5 deg (720/rev) with the 0.5 deg default knot spacing: a
    symmetric lobe (closed form, true axis 0) gives its top point near 0, no
    'gaps in the lobe data'."""
    from cam_metrology.metrology.asymmetry import lift_spline, top_point

    alpha = np.radians(np.arange(-60.0, 60.0 + 1e-9, 0.5))
    h = 8e-3 * np.clip(1 - (alpha / 1.05) ** 2, 0, None) ** 3
    noisy = h + np.random.default_rng(seed).normal(0.0, 2e-6, alpha.size)
    spline = lift_spline(alpha, noisy, knot_spacing=np.radians(0.5))
    tp = top_point(spline, float(alpha.min()), float(alpha.max()))
    assert abs(np.degrees(tp.d)) < 0.005
    exact = top_point(lift_spline(alpha, h, knot_spacing=np.radians(0.5)),
                      float(alpha.min()), float(alpha.max()))
    assert abs(np.degrees(exact.d)) < 1e-6


def test_analyze_and_run_read_parameter_files_alike(tmp_path, config_dir):
    """`analyze --params` and `run --params` share one reader (rcl's YAML typing): the
    shipped files and a YAML-1.1 exponent without a dot give the same values to both."""
    from cam_metrology.cli.analyze import load_params
    from cam_metrology.inputs.params import read_params_file
    for node in ('metrology', 'reconstruction', 'dynamics'):
        path = config_dir / f'{node}.yaml'
        assert load_params(str(path))[node] == read_params_file(path, node)
    p = tmp_path / 'p.yaml'
    p.write_text('metrology:\n  ros__parameters:\n    outlier_sigma: 5e0\n')
    value = load_params(str(p))['metrology']['outlier_sigma']
    assert value == read_params_file(p, 'metrology')['outlier_sigma']
    assert isinstance(value, float) and value == 5.0


def test_commands_say_what_they_computed_and_wrote(tmp_path, capsys) -> None:
    """`analyze` shows one line per other core it ran (reconstruction, dynamics), and
    `reconstruct --json FILE` says what it wrote."""
    from cam_metrology.cli import main

    bag = str(CLEAN)
    assert main(['analyze', bag]) == 0
    out = capsys.readouterr().out
    assert 'reconstruction: lobe_1/spline OK' in out
    assert 'dynamics: lobe_1/1500rpm' in out and '(all of it: --json)' in out
    target = tmp_path / 'r.json'
    assert main(['reconstruct', bag, '--feature', 'lobe_1', '--json', str(target)]) == 0
    assert capsys.readouterr().out.startswith(f'wrote {target}: lobe_1/spline')
