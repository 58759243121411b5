"""Make the fixture bags of bags/ (deterministic: fixed seeds and stamps).

    .venv/bin/python bags/make_bags.py [--out DIR] [--only NAME ...]

Every fixture scene is self-contained: lobes given by a lift law are tabulated
(``lift: {alpha, h}`` every 0.25 deg over the law's support) before simulating, so the
bags stay valid if a lift-law family changes later. The truth of each bag is in its
``/bench/truth`` message and summarised in bags/README.md.
"""
from __future__ import annotations

import argparse
import math
import shutil
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from cam_metrology import bagio  # noqa: E402
from cam_metrology.scene.parse import load_scene, parse_scene  # noqa: E402
from cam_metrology.simulation.bench import (  # noqa: E402
    SimParams, scene_with_direction, simulate, write_sim_bag)

TABLE_STEP_DEG = 0.25


def tabulated_scene_text(scene: Any, title: str) -> str:
    """The scene's YAML with every ``lift_law`` replaced by its table (SI, rad/m)."""
    doc = yaml.safe_load(scene.text)
    for item, lobe in zip(doc['lobes'], scene.lobes):
        if 'lift_law' not in item:
            continue
        lo, hi = lobe.lift.support
        n = int(round((hi - lo) / math.radians(TABLE_STEP_DEG))) + 1
        alpha = np.linspace(lo, hi, n)
        h = lobe.lift(alpha)
        h[0] = h[-1] = 0.0
        del item['lift_law']
        item['lift'] = {'alpha': [float(f'{a:.12g}') for a in alpha],
                        'h': [float(f'{v:.12g}') for v in h]}
    header = (f'# {title}\n# Lift laws tabulated every {TABLE_STEP_DEG} deg by '
              'bags/make_bags.py (self-contained fixture).\n')
    return header + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=99)


def fixture_scene(path: Path, title: str, direction: int | None = None) -> Any:
    scene = load_scene(path)
    if direction is not None:
        scene = scene_with_direction(scene, direction)
    return parse_scene(tabulated_scene_text(scene, title), source=str(path))


def make_default_clean(out: Path) -> Any:
    scene = fixture_scene(REPO / 'config' / 'default_scene.yaml',
                          'default scene (config/default_scene.yaml)')
    return write_sim_bag(out, scene, SimParams(samples_per_rev=3600, seed=1),
                         compression=True)


def make_default_noisy(out: Path) -> Any:
    scene = fixture_scene(REPO / 'config' / 'default_scene.yaml',
                          'default scene, direction -1', direction=-1)
    params = SimParams(samples_per_rev=1800, revolutions=2, wrapped=True,
                       start_theta=math.radians(200.0), probe_zero_offset=-2.345e-3,
                       probe_noise=1e-6, seed=2)
    return write_sim_bag(out, scene, params, compression=True)


def make_no_pin(out: Path) -> Any:
    scene = fixture_scene(HERE / 'scenes' / 'two_lobes_no_pin.yaml',
                          'two lobes, no dowel pin, no valve_train (bags/scenes)')
    params = SimParams(samples_per_rev=3600, probe_noise=0.5e-6, seed=3,
                       start_theta=math.radians(-75.0))
    return write_sim_bag(out, scene, params, compression=False)   # the uncompressed fixture


def make_runout(out: Path) -> Any:
    scene = fixture_scene(REPO / 'config' / 'default_scene.yaml',
                          'default scene (run-out and encoder noise)')
    params = SimParams(samples_per_rev=1800, probe_noise=0.5e-6,
                       encoder_noise=math.radians(2.0 / 3600.0), runout=3e-6,
                       start_theta=math.radians(123.0), seed=5)
    return write_sim_bag(out, scene, params, compression=True)


def make_irregular(out: Path) -> Any:
    """Default scene written as another program might: see bags/README.md."""
    scene = fixture_scene(REPO / 'config' / 'default_scene.yaml',
                          'default scene (irregular stream)')
    params = SimParams(samples_per_rev=1800, probe_noise=0.5e-6, seed=4)
    run = simulate(scene, params)
    ts = bagio.typestore()
    js_t = ts.types['sensor_msgs/msg/JointState']
    header_t = ts.types['std_msgs/msg/Header']
    time_t = ts.types['builtin_interfaces/msg/Time']

    def joint_state(fid: str, stamp: int, theta: float, s: float, k: int) -> bytes:
        """rosbags-encoded JointState: extra joint, joint order varying by feature."""
        sec, nsec = divmod(stamp, 10**9)
        if k % 2:
            names, pos = ['table_z', 'probe', 'camshaft'], [0.125, s, theta]
        else:
            names, pos = ['camshaft', 'probe', 'table_z'], [theta, s, 0.125]
        msg = js_t(header=header_t(stamp=time_t(sec=sec, nanosec=nsec), frame_id=fid),
                   name=names, position=np.array(pos), velocity=np.zeros(0),
                   effort=np.zeros(0))
        return bytes(ts.serialize_cdr(msg, js_t.__msgtype__))

    first = int(run.features[0].stamp_ns[0])
    import json
    with bagio.BagWriter(out, compression=True) as w:
        # no /bench/feature_done: features end when the next starts / at the end
        w.write('/bench/scene', first - 2_000_000, bagio.encode_string(scene.text))
        w.write('/bench/truth', first - 1_000_000,
                bagio.encode_string(json.dumps(run.truth, sort_keys=True)))
        w.add_topic('/rosout_text', 'std_msgs/msg/String')
        for k, feat in enumerate(run.features):
            theta = feat.theta.copy()
            s = feat.s.copy()
            stamps = feat.stamp_ns.copy()
            s[37::97] = np.nan            # probe dropouts
            theta[501::503] = np.nan      # encoder dropouts
            order = np.arange(theta.size)
            for i in range(50, theta.size - 1, 101):   # adjacent pairs out of order
                order[i], order[i + 1] = order[i + 1], order[i]
            rx = stamps[0]
            for j, i in enumerate(order.tolist()):
                reps = 2 if i % 89 == 0 else 1            # duplicated samples
                for _ in range(reps):
                    rx += 1_000_000 // 2
                    w.write(bagio.JOINT_STATES, int(rx),
                            joint_state(feat.id, int(stamps[i]), float(theta[i]),
                                        float(s[i]), k))
                if j % 500 == 0:
                    w.write('/rosout_text', int(rx), bagio.encode_string(f'{feat.id} {j}'))
    return run


FIXTURES: dict[str, tuple[Callable[[Path], Any], str]] = {
    'default_clean': (make_default_clean, 'default scene, noise-free'),
    'default_noisy_dirneg_wrapped': (make_default_noisy,
                                     'direction -1, 1 um noise, 2 rev, wrapped'),
    'no_pin_no_valve_train': (make_no_pin, 'two lobes, no pin, no valve_train'),
    'irregular': (make_irregular, 'NaN, duplicates, out of order, extra/swapped joints'),
    'runout_encoder_noise': (make_runout, '3 um run-out, 2 arcsec encoder noise'),
}


def truth_line(name: str, run: Any) -> str:
    """One Markdown line with the truth of a bag."""
    feats = run.truth['features']
    parts = []
    for fid, f in feats.items():
        text = f'{fid} {f["angle_deg"]:.6f} deg'
        if 'phase_error_deg' in f:
            text += f' (phase err {f["phase_error_deg"]:+.6f})'
        parts.append(text)
    return f'`{name}`: ' + '; '.join(parts)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', type=Path, default=HERE, help='directory (default bags/)')
    parser.add_argument('--only', nargs='*', choices=sorted(FIXTURES), help='some bags only')
    parser.add_argument('--force', action='store_true', help='replace existing bags')
    args = parser.parse_args(argv)
    for name in args.only or list(FIXTURES):
        make, what = FIXTURES[name]
        path = args.out / name
        if path.exists():
            if not args.force:
                print(f'{path} exists (use --force to replace)', file=sys.stderr)
                return 2
            shutil.rmtree(path)
        run = make(path)
        size = sum(p.stat().st_size for p in path.iterdir())
        print(f'{name}: {what}; {run.sample_count} samples; {size / 1e6:.2f} MB')
        print('  ' + truth_line(name, run))
    return 0


if __name__ == '__main__':
    sys.exit(main())
