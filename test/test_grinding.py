"""cam_design.grinding and `cam-bench grind` against closed forms and independent references."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from cam_design.errors import InputError
from cam_design.cam_profile import flat_profile, offset_roller_profile, rocker_profile
from cam_design.follower import EccentricDiscLift, Follower, convert_lift
from cam_design.grinding.wheel_path import Design, WheelPath, equivalent_inline
from cam_design.lift_laws import from_spec
from cam_metrology.cli import main

RC, ECC, RW = 0.02, 0.005, 0.2          # eccentric disc radius, eccentricity, wheel radius
R0 = RC - ECC
FULL = np.linspace(-math.pi, math.pi, 721)
INTAKE = {'family': 'preset', 'name': 'flat_tappet_intake'}    # base circle 16.5 mm


# --- (1) wheel-centre path -------------------------------------------------------------

@pytest.mark.parametrize('kind,r', [('flat', 0.0), ('roller', 0.008), ('knife', 0.0)])
def test_eccentric_disc_path_is_offset_circle(kind: str, r: float) -> None:
    """The wheel centre of an eccentric disc runs on a circle of radius R_c + R_w centred
    e off the axis; the contact point is on the disc."""
    law = EccentricDiscLift(RC, ECC, Follower(kind, r))
    t = WheelPath(law, R0, Design(kind, r), RW).table(FULL)
    d = ECC * np.cos(FULL) + np.sqrt((RC + RW) ** 2 - ECC ** 2 * np.sin(FULL) ** 2)
    assert np.max(np.abs(t['wheel_centre_distance_m'] - d)) < 1e-12
    assert np.max(np.abs(np.hypot(t['wheel_x_m'], t['wheel_y_m'] - ECC) - RC - RW)) < 1e-12
    assert np.max(np.abs(np.hypot(t['contact_x_m'], t['contact_y_m'] - ECC) - RC)) < 1e-12
    # the contact normal points from the disc centre to the wheel centre
    normal = np.arctan2(t['wheel_y_m'] - ECC, t['wheel_x_m']) - 0.5 * math.pi
    err = (t['normal_angle_rad'] - normal + math.pi) % (2 * math.pi) - math.pi
    assert np.max(np.abs(err)) < 1e-12


def test_flat_design_closed_form() -> None:
    """Flat design: D = sqrt((R0 + h + R_w)^2 + h'^2) at alpha + atan(h' / (R0 + h + R_w));
    D = R0 + h + R_w only where h' = 0; the contact is the flat-profile point."""
    law = from_spec(INTAKE)
    r0 = 0.0165
    a = np.linspace(-1.7, 1.7, 1201)
    h, h1 = law(a), law(a, 1)
    big = r0 + h + RW
    at = a + np.arctan(h1 / big)
    path = WheelPath(law, r0, Design('flat'), RW)
    t = path.table(at)
    assert np.max(np.abs(t['wheel_centre_distance_m'] - np.hypot(big, h1))) < 1e-12
    prof = flat_profile(law, r0, a)
    assert np.max(np.hypot(t['contact_x_m'] - prof.x, t['contact_y_m'] - prof.y)) < 1e-11
    moving = np.abs(h1) > 1e-4
    assert np.min(np.abs(t['wheel_centre_distance_m'] - big)[moving]) > 1e-10
    nose = path.distance(np.array([0.0]))[0, 0]
    assert abs(nose - (r0 + law(np.array([0.0]))[0] + RW)) < 1e-12


def test_round_trip_profile_wheel_profile() -> None:
    """design lift -> wheel path (roller R_w) -> lift of the design follower: identity."""
    law = from_spec(INTAKE)
    path = WheelPath(law, 0.0165, Design('flat'), RW)
    back = convert_lift(path.lift, 0.0165, Follower('roller', RW), Follower('flat'))
    a = np.linspace(-math.pi, math.pi, 2001)
    assert np.max(np.abs(back(a) - law(a))) < 1e-9


def test_offset_zero_equals_inline_roller() -> None:
    law = EccentricDiscLift(RC, ECC, Follower('roller', 0.008))
    p1 = WheelPath(law, R0, Design('roller', 0.008), RW)
    p2 = WheelPath(law, R0, Design('offset-roller', 0.008, offset=0.0, delta=0), RW)
    assert np.max(np.abs(p1.distance(FULL)[:3] - p2.distance(FULL)[:3])) < 1e-12


def _rotate(x: np.ndarray, y: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.stack([c * x - s * y, s * x + c * y])


@pytest.mark.parametrize('design', [
    Design('offset-roller', 0.01, offset=0.006, eta=1, delta=1),
    Design('offset-roller', 0.01, offset=0.004, eta=-1, delta=-1),
    Design('rocker', 0.01, centre_distance=0.06, arm_length=0.045, eta=1, delta=-1),
    Design('rocker', 0.008, centre_distance=0.06, arm_length=0.045, eta=-1, delta=1)])
def test_offset_and_rocker_wheel_touches_profile(design: Design) -> None:
    """Every wheel centre is R_w from the design profile (dense points of follower.py's
    offset_roller_profile / rocker_profile), never closer."""
    law = from_spec({'family': 'preset', 'name': 'methods_example'})
    r0, rw = 0.02, 0.1
    dense = np.linspace(-math.pi, math.pi, 40001)
    if design.kind == 'offset-roller':
        prof = offset_roller_profile(law, r0, design.radius, design.offset, dense,
                                     eta=design.eta, delta=design.delta)
        s0 = math.sqrt((r0 + design.radius) ** 2 - design.offset ** 2)
        base_dir = math.atan2(design.delta * design.offset, s0)
    else:
        prof = rocker_profile(law, r0, design.radius, design.centre_distance,
                              design.arm_length, dense, eta=design.eta, delta=design.delta)
        rp = r0 + design.radius
        a, arm = design.centre_distance, design.arm_length
        psi0 = math.acos((a * a + arm * arm - rp * rp) / (2 * a * arm))
        base_dir = math.atan2(arm * math.sin(design.delta * psi0), a - arm * math.cos(psi0))
    pts = _rotate(prof.x, prof.y, 0.5 * math.pi - base_dir)
    if design.eta < 0:
        pts[0] = -pts[0]           # the equivalent in-line cam turns the other way: mirror
    t = WheelPath(law, r0, design, rw).table(FULL)
    dist, _ = cKDTree(pts.T).query(np.stack([t['wheel_x_m'], t['wheel_y_m']]).T)
    assert np.min(dist) > rw - 1e-12
    assert np.max(dist) < rw + 2e-9         # 40001 profile points: chord sag < 1e-9 m


def test_bad_design_inputs() -> None:
    with pytest.raises(InputError, match='design.kind'):
        Design('cylinder')
    with pytest.raises(InputError, match='offset'):
        design = Design('offset-roller', 0.01, offset=0.05)
        equivalent_inline(from_spec(INTAKE), 0.0165, design)
    with pytest.raises(InputError, match='wheel_radius'):
        WheelPath(from_spec(INTAKE), 0.0165, Design('flat'), 0.0)


@pytest.fixture()
def cam_file(tmp_path: Path) -> Path:
    path = tmp_path / 'cam.yaml'
    path.write_text('lift_law: {family: preset, name: flat_tappet_intake}\n'
                    'base_radius: 0.0165\n'
                    'grinding:\n  design: flat\n  wheel_radius: [0.2, 0.19]\n'
                    '  step_deg: 1.0\n')
    return path


def test_cli_table_several_radii(cam_file: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(['grind', 'table', str(cam_file), '--csv', '-']) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    head = lines[0].split(',')
    assert head[:4] == ['wheel_radius_m', 'angle_rad', 'wheel_centre_distance_m',
                        'contact_angle_rad']
    rows = np.array([[float(v) for v in ln.split(',')] for ln in lines[1:]])
    assert rows.shape[0] == 720
    law = from_spec(INTAKE)
    for rw in (0.2, 0.19):
        sel = rows[:, 0] == rw
        ref = WheelPath(law, 0.0165, Design('flat'), rw).distance(rows[sel, 1])[0]
        assert np.max(np.abs(rows[sel, 2] - ref)) < 1e-14 + 1e-15 * 0.22 * 10
        base = np.abs(rows[sel, 1]) > 1.7
        assert np.allclose(rows[sel, 2][base], 0.0165 + rw, atol=1e-15)


def test_cli_table_scene_and_machine(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """A scene lobe (its lift, follower and base circle) with the section from --machine."""
    from cam_metrology.scene.parse import load_scene

    repo = Path(__file__).resolve().parent.parent
    machine = tmp_path / 'machine.yaml'
    machine.write_text('grinding:\n  wheel_radius: 0.25\n  step_deg: 2\n')
    assert main(['grind', 'table', str(repo / 'config' / 'default_scene.yaml'), '--lobe',
                 'lobe_2', '--machine', str(machine), '--csv', '-']) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    rows = np.array([[float(v) for v in ln.split(',')] for ln in lines[1:]])
    scene = load_scene(repo / 'config' / 'default_scene.yaml')
    lobe = scene.lobe('lobe_2')
    ref = WheelPath(lobe.lift, scene.base_circle_radius, Design(lobe.follower.kind),
                    0.25).distance(rows[:, 1])[0]
    assert rows.shape[0] == 180
    assert np.max(np.abs(rows[:, 2] - ref)) < 1e-14


def test_cli_table_errors(cam_file: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(['grind', 'table', str(cam_file), '--wheel-radius', '-0.1']) == 2
    assert '--wheel-radius: got -0.1' in capsys.readouterr().err
    assert main(['grind', 'table', str(cam_file), '--step-deg', '50']) == 2
    assert '--step-deg: got 50' in capsys.readouterr().err


# --- (2) master cam on a rocking cradle --------------------------------------------------

def _disc_path() -> WheelPath:
    return WheelPath(EccentricDiscLift(RC, ECC, Follower('flat')), R0, Design('flat'), RW)


def test_similar_cradle_master_is_scaled_copy() -> None:
    """a_m = k a, c = k b, master_angle 0: master pitch curve = k x wheel path at the same
    angle, and with a master roller k R_w the master profile is k x the cam profile."""
    from cam_design.grinding.master_cam import Cradle, MasterCam

    k = 1.7
    law = from_spec(INTAKE)
    path = WheelPath(law, 0.0165, Design('flat'), RW)
    master = MasterCam(path, Cradle(0.35, 0.45, 0.35 * k, 0.45 * k), 'roller', k * RW)
    assert abs(master.magnification - k) < 1e-12
    s = np.linspace(-math.pi, math.pi, 721, endpoint=False)
    st = master.jets(s)
    assert np.max(np.abs(st['dm'][0] - k * path.distance(s)[0])) < 1e-12
    assert np.max(np.abs(st['angle'][0] - s)) < 1e-12
    prof = master.profile(720)
    t = path.table(-math.pi + 2 * math.pi * np.arange(720) / 720)
    assert np.max(np.hypot(prof.x - k * t['contact_x_m'], prof.y - k * t['contact_y_m'])) < 1e-12
    assert not np.any(prof.undercut)


@pytest.mark.parametrize('side,angle', [(1, 0.0), (-1, 0.1), (1, -0.2)])
def test_master_lift_against_circle_intersection(side: int, angle: float) -> None:
    """Eccentric disc: at spindle angle theta the wheel centre is where the circle of
    radius R_c + R_w about the disc centre meets the circle of radius b about the pivot;
    the master-follower distance then follows from the machine triangle (brute force)."""
    from cam_design.grinding.master_cam import Cradle, MasterCam

    a, b, am, c = 0.35, 0.45, 0.3, 0.5
    master = MasterCam(_disc_path(), Cradle(a, b, am, c, angle, side), 'roller', 0.03)
    theta = np.linspace(-math.pi, math.pi, 73)
    lift = master.follower_lift(theta)
    phib = master._base['phi']
    rot = np.array([[math.cos(side * angle), -math.sin(side * angle)],
                    [math.sin(side * angle), math.cos(side * angle)]])
    ref = []
    for t in theta:
        centre = ECC * np.array([math.cos(phib - t), math.sin(phib - t)])
        pivot = np.array([a, 0.0])
        dvec = centre - pivot
        dist = float(np.linalg.norm(dvec))
        x = (b * b - (RC + RW) ** 2 + dist * dist) / (2 * dist)
        foot = pivot + x * dvec / dist
        perp = np.array([-dvec[1], dvec[0]]) / dist * math.sqrt(b * b - x * x)
        w = [p for p in (foot + perp, foot - perp) if np.sign(p[1]) == side][0]
        m = np.array([am, 0.0]) + c * rot @ ((w - pivot) / b)
        ref.append(np.linalg.norm(m) - master.base_value)
    assert np.max(np.abs(lift[0] - np.array(ref))) < 1e-12
    # derivatives against central differences of the exact lift
    eps = 1e-5
    up, dn = master.follower_lift(theta + eps), master.follower_lift(theta - eps)
    assert np.max(np.abs((up[0] - dn[0]) / (2 * eps) - lift[1])) < 1e-9
    assert np.max(np.abs((up[1] - dn[1]) / (2 * eps) - lift[2])) < 1e-8


def test_flat_master_face_touches_profile() -> None:
    """Flat master follower: at every spindle angle the face (support H, normal psi) is
    tangent to the master profile: max over dense profile points of P.n equals H."""
    from cam_design.grinding.master_cam import Cradle, MasterCam

    master = MasterCam(_disc_path(), Cradle(0.35, 0.45, 0.3, 0.5, 0.1, 1), 'flat')
    prof = master.profile(40000)
    assert not np.any(prof.undercut)
    s = np.linspace(-math.pi, math.pi, 97)
    st = master.jets(s)
    psi = st['angle'][0]
    nx, ny = -np.sin(psi), np.cos(psi)
    support = np.max(np.outer(nx, prof.x) + np.outer(ny, prof.y), axis=1)
    assert np.max(np.abs(support - st['value'][0])) < 2e-9     # chord sag of 40000 points


def test_small_swing_error_shrinks_with_cradle_size() -> None:
    """The magnified-copy approximation k h_w(theta) tends to the exact lift as the
    pivot recedes at right angles to the wheel line (the swing turns into a radial
    slide): its error falls at least 5x for a 10x longer cradle."""
    from cam_design.grinding.master_cam import Cradle, MasterCam

    theta = np.linspace(-math.pi, math.pi, 361)
    errs = []
    for a in (0.5, 5.0):          # wheel and master follower at right angles to the pivot
        am = 0.9 * a
        turn = math.atan(0.25 / am) - math.atan((R0 + RW) / a)
        cr = Cradle(a, math.hypot(a, R0 + RW), am, math.hypot(am, 0.25), turn, 1)
        tab = MasterCam(_disc_path(), cr, 'roller', 0.03).lift_table(theta)
        errs.append(np.max(np.abs(tab['approx_error_m'])))
        assert np.allclose(tab['approx_error_m'], tab['master_lift_approx_m']
                           - tab['master_lift_m'], atol=1e-15)
    assert errs[1] < errs[0] / 5
    assert errs[0] > 1e-6          # not trivially zero on the small cradle


def test_master_undercut_and_bad_cradle() -> None:
    from cam_design.grinding.master_cam import Cradle, MasterCam

    path = WheelPath(from_spec(INTAKE), 0.0165, Design('flat'), RW)
    cradle = Cradle(0.35, 0.45, 0.35, 0.45)          # 1:1 copy: pitch = wheel path
    # wheel-path radius of curvature at the nose ~ rho1 + R_w = 204.3 mm: a 210 mm
    # master roller cannot follow it (undercut), a 30 mm one can
    assert np.any(MasterCam(path, cradle, 'roller', 0.21).profile(3600).undercut)
    assert not np.any(MasterCam(path, cradle, 'roller', 0.03).profile(3600).undercut)
    with pytest.raises(InputError, match='grinding.cradle'):
        MasterCam(path, Cradle(0.05, 0.3, 0.3, 0.5), 'roller', 0.03)
    with pytest.raises(InputError, match='grinding.cradle.side'):
        Cradle(0.35, 0.45, 0.3, 0.5, 0.0, 2)


def test_cli_master(cam_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    import json

    text = cam_file.read_text() + ('  cradle: {pivot_to_work: 0.35, pivot_to_wheel: 0.45, '
                                   'pivot_to_master: 0.595, pivot_to_master_follower: 0.765}\n'
                                   '  master_follower: {kind: roller, radius: 0.03}\n')
    cam_file.write_text(text)
    out = tmp_path / 'm.json'
    assert main(['grind', 'master', str(cam_file), '--json', str(out)]) == 0
    doc = json.loads(out.read_text())
    assert abs(doc['magnification'] - 1.7) < 1e-12
    assert doc['profile']['undercut'] is False
    cols = doc['columns']
    rows = np.array(doc['rows'])
    lift = rows[:, cols.index('master_lift_m')]
    dist = rows[:, cols.index('wheel_centre_distance_m')]
    assert np.max(np.abs(lift - 1.7 * (dist - 0.0165 - 0.2))) < 1e-12    # similar cradle
    assert abs(np.max(lift) - 1.7 * from_spec(INTAKE).max_lift()) < 1e-6   # 1 deg grid
    cam_file.write_text(text.replace('pivot_to_wheel: 0.45', 'pivot_to_wheel: -0.45'))
    assert main(['grind', 'master', str(cam_file)]) == 2
    assert 'grinding.cradle.pivot_to_wheel: got -0.45' in capsys.readouterr().err


# --- (3) machining-error sensitivities ---------------------------------------------------

def _disc(kind: str, r: float) -> WheelPath:
    """Eccentric disc R_c 22 mm, e 5 mm (convex for every follower) and a 200 mm wheel."""
    return WheelPath(EccentricDiscLift(0.022, 0.005, Follower(kind, r)), 0.017,
                     Design(kind, r), RW)


CASES = [('intake-flat', lambda: WheelPath(from_spec(INTAKE), 0.0165, Design('flat'), RW)),
         ('disc-roller', lambda: _disc('roller', 0.012)),
         ('disc-knife', lambda: _disc('knife', 0.0))]


@pytest.mark.parametrize('name,make', CASES)
def test_ground_cam_nominal_is_design(name: str, make) -> None:
    """Exact grinding simulation with no error returns the design lift (round trip)."""
    from cam_design.grinding.machining_error import GroundCam, MachineErrors

    path = make()
    a = np.linspace(-math.pi, math.pi, 721)
    lift, _ = GroundCam(path, MachineErrors()).lift(a)
    assert np.max(np.abs(lift - path.design_law(a))) < 1e-12


@pytest.mark.parametrize('cradle', [False, True])
@pytest.mark.parametrize('name,make', CASES)
def test_sensitivities_against_finite_differences(name: str, make, cradle: bool) -> None:
    """Each first-order sensitivity equals the central difference of the exactly
    simulated ground lift (errors +-1e-6 m or rad)."""
    from cam_design.grinding.machining_error import GroundCam, MachineErrors, sensitivities
    from cam_design.grinding.master_cam import Cradle

    path = make()
    cr = Cradle(0.35, 0.45, 0.3, 0.5, 0.1, 1) if cradle else None
    a = np.linspace(-math.pi, math.pi, 361)
    sens = sensitivities(path, a, cradle=cr)
    assert set(sens) == {'wheel_radius', 'centre_distance', 'index', 'run_out_x', 'run_out_y'}
    _, s0 = GroundCam(path, MachineErrors()).lift(a)
    eps = 1e-6
    for source, value in sens.items():
        up, _ = GroundCam(path, MachineErrors(**{source: eps}), cradle=cr).lift(a, s0)
        dn, _ = GroundCam(path, MachineErrors(**{source: -eps}), cradle=cr).lift(a, s0)
        fd = (up - dn) / (2 * eps)
        assert np.max(np.abs(fd - value)) < 1e-7, source
        assert np.max(np.abs(value)) > 1e-4, source          # not trivially zero


def test_sensitivity_closed_forms() -> None:
    """Index error: -h'(alpha); run-out on a flat design: the support of a shifted cam,
    (x, y) . (-sin alpha, cos alpha); wheel radius: 0 at the nose and on the base circle;
    CNC centre distance on a flat design: cos(mu_w) <= 1."""
    from cam_design.grinding.machining_error import sensitivities

    law = from_spec(INTAKE)
    path = WheelPath(law, 0.0165, Design('flat'), RW)
    a = np.linspace(-math.pi, math.pi, 721)
    s = sensitivities(path, a)
    assert np.max(np.abs(s['index'] + law(a, 1))) < 1e-12
    assert np.max(np.abs(s['run_out_x'] + np.sin(a))) < 1e-12
    assert np.max(np.abs(s['run_out_y'] - np.cos(a))) < 1e-12
    still = (np.abs(law(a, 1)) < 1e-15)
    assert np.max(np.abs(s['wheel_radius'][still])) < 1e-15
    assert np.all(s['wheel_radius'] <= 0) and np.min(s['wheel_radius']) < -1e-3
    assert np.all(s['centre_distance'] <= 1.0)


@pytest.mark.parametrize('kind,r', [('flat', 0.0), ('roller', 0.012)])
def test_master_radius_similar_cradle_closed_form(kind: str, r: float) -> None:
    """1:k similar cradle: a master roller bigger by dr offsets the master pitch curve
    by dr along its normal, i.e. the cam by dr / k along its normal: lift error
    dr / (k cos mu_f)."""
    from cam_design.grinding.machining_error import follower_normal, sensitivities
    from cam_design.grinding.master_cam import Cradle, MasterCam

    k = 1.7
    path = _disc(kind, r)
    master = MasterCam(path, Cradle(0.35, 0.45, 0.35 * k, 0.45 * k), 'roller', 0.03)
    a = np.linspace(-math.pi, math.pi, 361)
    sens = sensitivities(path, a, master=master)['master_follower_radius']
    _, mu = follower_normal(path, a)
    assert np.max(np.abs(sens * np.cos(mu) - 1.0 / k)) < 1e-12


def test_master_radius_against_exact_cradle_balance() -> None:
    """General cradle: finite differences of the exact wheel-centre path when the master
    roller grows by +-1e-6 m (the master follower's new centre path by convert_lift on
    the master pitch curve, the cradle re-balanced by a root solve), projected on the
    profile normal, equal the analytic normal move."""
    from scipy.optimize import brentq

    from cam_design.grinding.curve import PolarCurveLift
    from cam_design.grinding.machining_error import _master_radius_dn
    from cam_design.grinding.master_cam import Cradle, MasterCam

    path = _disc('flat', 0.0)
    rm = 0.03
    master = MasterCam(path, Cradle(0.35, 0.45, 0.3, 0.5, 0.1, -1), 'roller', rm)

    def pitch(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        from cam_design.jets import jet_mul
        from cam_design.grinding.curve import jet_cos_sin

        st = master.jets(s)
        c, sn = jet_cos_sin(st['angle'])
        return -jet_mul(st['value'], sn), jet_mul(st['value'], c)

    d_m0 = master.base_value
    pitch_lift = PolarCurveLift(pitch, d_m0)
    cr = master.cradle
    base = master._base
    theta = np.linspace(-3.0, 3.0, 11)
    s_nom = master.wheel_angle(theta)
    d_nom = path.distance(s_nom)[0]

    def wheel(eps: float) -> np.ndarray:
        new = convert_lift(pitch_lift, d_m0 - rm, Follower('roller', rm),
                           Follower('roller', rm + eps))
        out = []
        for t, d0 in zip(theta, d_nom):
            def gap(d: float) -> float:
                st = cr.wheel_jets(np.array([[d], [0.0], [0.0], [0.0]]))
                alpha_m = t + st['phim'][0][0] - base['phim']
                return st['dm'][0][0] - (d_m0 + eps + new(np.array([alpha_m]))[0])
            d = brentq(gap, d0 - 1e-4, d0 + 1e-4, xtol=1e-16, rtol=1e-15)
            phi = cr.wheel_jets(np.array([[d], [0.0], [0.0], [0.0]]))['phi'][0][0]
            ang = 0.5 * math.pi + t + phi - base['phi']
            out.append([d * math.cos(ang), d * math.sin(ang)])
        return np.array(out)

    eps = 1e-6
    dw = (wheel(eps) - wheel(-eps)) / (2 * eps)
    d = path.distance(s_nom)
    norm = np.hypot(d[0], d[1])
    ux, uy = -np.sin(s_nom), np.cos(s_nom)
    nx, ny = (d[0] * ux + d[1] * uy) / norm, (d[0] * uy - d[1] * ux) / norm
    fd = dw[:, 0] * nx + dw[:, 1] * ny
    dj = np.stack([d[0], d[1], d[2] / 2, d[3] / 6])
    analytic = _master_radius_dn(master, s_nom, cr.wheel_jets(dj), nx, ny)
    assert np.max(np.abs(fd - analytic)) < 1e-6
    assert np.min(np.abs(analytic)) > 0.5


def test_bridged_hollow_is_reported() -> None:
    """A roller design with concave flanks tighter than the wheel (methods_example as a
    roller lift, hollows near +-40 deg): the wheel path lists them."""
    law = from_spec({'family': 'preset', 'name': 'methods_example'})
    path = WheelPath(law, 0.02, Design('roller', 0.012), RW)
    assert len(path.bridged) == 2
    lo, hi = path.bridged[1]
    assert 0.5 < lo < hi < 0.9
    assert WheelPath(from_spec(INTAKE), 0.0165, Design('flat'), RW).bridged == []
    assert _disc('roller', 0.012).bridged == []


# --- (4) measure -> correct ---------------------------------------------------------------

def _intake_path() -> WheelPath:
    return WheelPath(from_spec(INTAKE), 0.0165, Design('flat'), RW)


def test_fit_recovers_small_errors_without_noise() -> None:
    """Linear regime (errors << R_w): the fit returns the simulated errors."""
    from cam_design.grinding.correction import fit_errors
    from cam_design.grinding.machining_error import GroundCam, MachineErrors

    path = _intake_path()
    truth = {'wheel_radius': -5e-4, 'index': 1e-4, 'run_out_x': 2e-6, 'run_out_y': -1e-6}
    a = np.linspace(-math.pi, math.pi, 1440, endpoint=False)
    err = GroundCam(path, MachineErrors(**truth)).lift(a)[0] - from_spec(INTAKE)(a)
    fit = fit_errors(path, a, err)
    assert fit.settled and fit.condition < 10
    for k, v in truth.items():
        assert abs(fit.values[k] - v) < 0.01 * abs(v) + 1e-9, k
    assert fit.residual_rms_m < 1e-9


@pytest.mark.parametrize('probe', [None, Follower('roller', 0.0125)])
def test_measure_correct_regrind_loop(probe: Follower | None) -> None:
    """Grind with a 5 mm small wheel and a 0.05 deg index error, measure with 0.2 um
    noise (design follower or a 12.5 mm roller probe), fit, regrind with the corrected
    table on the same faulty machine: the systematic lift error falls more than 10x."""
    from cam_design.grinding.correction import corrected_curve, fit_errors
    from cam_design.grinding.machining_error import GroundCam, MachineErrors

    path = _intake_path()
    law = from_spec(INTAKE)
    ref_law = law if probe is None else convert_lift(law, 0.0165, Follower('flat'), probe)
    truth = MachineErrors(wheel_radius=-5e-3, index=math.radians(0.05))
    a = np.linspace(-math.pi, math.pi, 1440, endpoint=False)
    before = GroundCam(path, truth, probe=probe).lift(a)[0] - ref_law(a)
    noisy = before + np.random.default_rng(7).normal(0.0, 2e-7, a.size)
    fit = fit_errors(path, a, noisy, sources=('wheel_radius', 'index'), probe=probe)
    assert fit.settled
    assert abs(fit.values['index'] - truth.index) < 5 * fit.std['index'] + 1e-6
    assert abs(fit.values['wheel_radius'] - truth.wheel_radius) < 0.05 * 5e-3
    assert 1.5e-7 < fit.residual_rms_m < 2.5e-7          # the noise, not the model
    curve, radius = corrected_curve(path, fit)
    after = GroundCam(path, truth, curve=curve, table_radius=radius,
                      probe=probe).lift(a)[0] - ref_law(a)
    rms = [float(np.std(x)) for x in (before, after)]
    assert rms[0] > 3e-6
    assert rms[1] < rms[0] / 10


def test_exact_iterations_remove_linearisation_bias() -> None:
    """A 5 mm wheel-radius error on a 200 mm wheel: the linear fit is biased by about
    2.4 %; three Gauss-Newton steps on the exact simulation recover the truth."""
    from cam_design.grinding.correction import fit_errors
    from cam_design.grinding.machining_error import GroundCam, MachineErrors

    path = _intake_path()
    truth = MachineErrors(wheel_radius=-5e-3, index=math.radians(0.05), run_out_x=2e-6)
    a = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    err = GroundCam(path, truth).lift(a)[0] - from_spec(INTAKE)(a)
    linear = fit_errors(path, a, err)
    assert 0.01 < abs(linear.values['wheel_radius'] / truth.wheel_radius - 1) < 0.05
    exact = fit_errors(path, a, err, exact_iterations=3)
    assert abs(exact.values['wheel_radius'] - truth.wheel_radius) < 1e-7
    assert abs(exact.values['index'] - truth.index) < 1e-9
    assert abs(exact.values['run_out_x'] - truth.run_out_x) < 1e-10
    assert exact.residual_rms_m < 1e-10


def test_fit_flags_indistinguishable_sources() -> None:
    """On a CNC slide the centre-distance error is a wheel-radius change plus an
    offset: the fit says so and is not settled."""
    from cam_design.grinding.correction import fit_errors

    path = _intake_path()
    a = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    err = np.random.default_rng(3).normal(0.0, 1e-7, a.size)
    fit = fit_errors(path, a, err, sources=('wheel_radius', 'centre_distance'))
    assert not fit.settled
    assert 'centre_distance' in fit.warnings[0] or 'wheel_radius' in fit.warnings[0]
    # pure noise: settled with the default sources, but the fit explains almost nothing
    noise = fit_errors(path, a, err)
    assert noise.settled and any('explain only' in w for w in noise.warnings)
    with pytest.raises(InputError, match='lift_error'):
        fit_errors(path, a, err[:-1])
    with pytest.raises(InputError, match='lift_error'):
        fit_errors(path, a, np.where(a > 0, np.nan, err))
    with pytest.raises(InputError, match='sources'):
        fit_errors(path, a, err, sources=('wheel_radius', 'coolant'))


def test_fit_wrapped_and_shuffled_angles() -> None:
    """Angles in any order and beyond one turn (an unwrapped encoder) give the same fit."""
    from cam_design.grinding.correction import fit_errors
    from cam_design.grinding.machining_error import GroundCam, MachineErrors

    path = _intake_path()
    a = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    lift, _ = GroundCam(path, MachineErrors(wheel_radius=-1e-3, index=2e-4)).lift(a)
    err = lift - from_spec(INTAKE)(a)
    ref = fit_errors(path, a, err)
    order = np.random.default_rng(5).permutation(a.size)
    turned = a[order] + 2 * math.pi * np.random.default_rng(6).integers(-2, 3, a.size)
    got = fit_errors(path, turned, err[order])
    for k, v in ref.values.items():
        assert abs(got.values[k] - v) < 1e-12 + 1e-9 * abs(v), k


def test_curve_table_round_trip() -> None:
    """The polar table of the nominal table curve is the wheel path itself."""
    from cam_design.grinding.correction import curve_table
    from cam_design.grinding.machining_error import path_curve

    path = _intake_path()
    a = np.linspace(-math.pi, math.pi, 721)
    tab = curve_table(path_curve(path), 0.0165 + RW, a)
    assert np.max(np.abs(tab['wheel_centre_distance_m'] - path.distance(a)[0])) < 1e-12


def test_cli_errors_and_correct(cam_file: Path, tmp_path: Path,
                                capsys: pytest.CaptureFixture) -> None:
    """`grind errors` simulates a faulty machine; its simulated error fed to `grind
    correct` gives back the errors, and a corrected table for the measured wheel."""
    import json

    cam_file.write_text(cam_file.read_text() + '  errors: {wheel_radius: -0.005, '
                                               'index: 0.00087}\n')
    err_csv = tmp_path / 'err.csv'
    assert main(['grind', 'errors', str(cam_file), '--csv', str(err_csv)]) == 0
    lines = err_csv.read_text().strip().splitlines()
    head = lines[0].split(',')
    assert head[:3] == ['alpha_rad', 'lift_m', 'wheel_radius_m_per_m']
    rows = np.array([[float(v) for v in ln.split(',')] for ln in lines[1:]])
    sim = rows[:, head.index('simulated_error_m')]
    pred = rows[:, head.index('predicted_error_m')]
    assert np.max(np.abs(sim)) > 1e-5
    assert np.max(np.abs(sim - pred)) < 0.03 * np.max(np.abs(sim))   # nearly linear
    meas = tmp_path / 'meas.csv'
    triples = zip(rows[:, 0].tolist(), rows[:, 1].tolist(), sim.tolist())
    meas.write_text('alpha_rad,lift_m,design_lift_m\n' + ''.join(
        f'{a!r},{h + e!r},{h!r}\n' for a, h, e in triples))
    out = tmp_path / 'c.json'
    assert main(['grind', 'correct', str(cam_file), '--measured', str(meas),
                 '--sources', 'wheel_radius,index', '--json', str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc['fit']['settled'] is True
    assert abs(doc['fit']['values']['index'] - 0.00087) < 2e-5
    assert abs(doc['fit']['values']['wheel_radius'] + 0.005) < 3e-4
    cols = doc['columns']
    table = np.array(doc['rows'])
    assert abs(table[0, cols.index('wheel_radius_m')] - doc['table_wheel_radius_m']) < 1e-15
    # ill-conditioned choice: exit 1, no table
    assert main(['grind', 'correct', str(cam_file), '--measured', str(meas),
                 '--sources', 'wheel_radius,centre_distance']) == 1
    assert 'nearly indistinguishable' in capsys.readouterr().err
    meas.write_text('alpha_rad,lift\n0,1\n')
    assert main(['grind', 'correct', str(cam_file), '--measured', str(meas)]) == 2
    assert 'lift_error_m, or lift_m and design_lift_m' in capsys.readouterr().err


def test_end_to_end_simulate_analyze_correct() -> None:
    """The default scene's lobe_1 (flat tappet) ground with a wheel 5 mm smaller than the
    table's and a 0.05 deg index error; the bench simulator measures it with the scene's
    12.5 mm roller probe and 0.2 um noise, the metrology analysis aligns it. The lift
    error it reports is fitted (wheel radius; index and run-out as nuisance: the analysis
    re-aligns the nose and removes a once-per-turn harmonic), the index comes from the
    nose-angle shift (on a real bench: the phase against the dowel pin). Reground with
    the corrected table, measured again: the systematic lift error falls > 10x, the
    measured one to the noise, the nose shift to ~0."""
    import dataclasses

    from cam_design.grinding.correction import ErrorFit, corrected_curve, fit_errors
    from cam_design.grinding.machining_error import GroundCam, MachineErrors
    from cam_design.lift_laws import TabulatedLift
    from cam_metrology.metrology.analysis import Settings, analyze_lobe, seen_lift
    from cam_metrology.metrology.features import clean_feature
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, simulate

    scene = load_scene(Path(__file__).resolve().parent.parent / 'config' /
                       'default_scene.yaml')
    lobe = scene.lobe('lobe_1')
    base, probe = scene.base_circle_radius, scene.probe
    path = WheelPath(lobe.lift, base, Design(lobe.follower.kind), RW)
    truth = MachineErrors(wheel_radius=-5e-3, index=math.radians(0.05))
    grid = np.linspace(-math.pi, math.pi, 14401)
    design = seen_lift(lobe, probe, base)

    def grind_and_measure(curve=None, radius=None):
        got = GroundCam(path, truth, curve=curve, table_radius=radius, probe=probe)
        lift = got.lift(grid)[0]
        ground = dataclasses.replace(lobe, lift=TabulatedLift(grid, np.clip(lift, 0, None)),
                                     follower=probe)
        bench = dataclasses.replace(scene, lobes=[ground])
        run = simulate(bench, SimParams(probe_noise=2e-7, seed=4))
        feat = [f for f in run.features if f.id == 'lobe_1'][0]
        res = analyze_lobe(clean_feature(feat.id, feat.stamp_ns, feat.theta, feat.s),
                           design, bench.direction, Settings())
        alpha, measured, expected = res.table.T
        shift = (res.angle_rad - feat.true_angle + math.pi) % (2 * math.pi) - math.pi
        return alpha, measured - expected, shift, lift - design(grid)

    alpha, err, shift, systematic = grind_and_measure()
    assert abs(scene.direction * shift - truth.index) < 2e-6
    fit = fit_errors(path, alpha, err, probe=probe)
    assert fit.settled and not fit.warnings
    assert abs(fit.values['wheel_radius'] - truth.wheel_radius) < 0.03 * 5e-3
    estimate = ErrorFit({'wheel_radius': fit.values['wheel_radius'],
                         'index': scene.direction * shift}, {}, 0.0, 0.0, 1.0, 0, True)
    curve, radius = corrected_curve(path, estimate)
    alpha2, err2, shift2, systematic2 = grind_and_measure(curve, radius)
    lobe_zone = np.abs(alpha) < 1.6
    assert np.std(systematic2) < np.std(systematic) / 10
    assert np.std(err[lobe_zone]) > 2e-6
    assert np.std(err2[np.abs(alpha2) < 1.6]) < 3e-7          # the 0.2 um noise
    assert abs(shift2) < abs(shift) / 100


def test_cli_correct_master_radius_is_reported(cam_file: Path, tmp_path: Path,
                                               capsys: pytest.CaptureFixture) -> None:
    """On a cradle with a roller master, a fitted master-roller error is reported, not
    compensated in the table: warning and exit 1."""
    cam_file.write_text(cam_file.read_text() + (
        '  cradle: {pivot_to_work: 0.35, pivot_to_wheel: 0.45, pivot_to_master: 0.3, '
        'pivot_to_master_follower: 0.5, master_angle: 0.1}\n'
        '  master_follower: {kind: roller, radius: 0.03}\n'))
    path = _intake_path()
    a = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    from cam_design.grinding.machining_error import sensitivities
    from cam_design.grinding.master_cam import master_from_section
    from cam_metrology.cli.law_input import load_yaml

    master = master_from_section(path, load_yaml(str(cam_file))['grinding'])
    sens = sensitivities(path, a, master=master)
    err = 2e-5 * sens['master_follower_radius'] - 1e-3 * sens['wheel_radius']
    meas = tmp_path / 'm.csv'
    meas.write_text('alpha_rad,lift_error_m\n' + ''.join(
        f'{x!r},{y!r}\n' for x, y in zip(a.tolist(), err.tolist())))
    rc = main(['grind', 'correct', str(cam_file), '--measured', str(meas), '--sources',
               'wheel_radius,master_follower_radius', '--exact-iterations', '0'])
    out = capsys.readouterr()
    assert rc == 1
    assert 'master_follower_radius (2e-05 m) is not compensated' in out.err
    assert 'wheel_radius: -0.001 +-' in out.out


def test_cli_table_reports_bridged_hollows(tmp_path: Path,
                                           capsys: pytest.CaptureFixture) -> None:
    import json

    path = tmp_path / 'roller.yaml'
    path.write_text('lift_law: {family: preset, name: methods_example}\nbase_radius: 0.02\n'
                    'grinding: {design: {kind: roller, radius: 0.012}, wheel_radius: 0.2}\n')
    assert main(['grind', 'table', str(path), '--json', '-', '--step-deg', '2']) == 0
    out = capsys.readouterr()
    wheel = json.loads(out.out)['wheels'][0]
    assert wheel['reproduces_design'] is False and len(wheel['bridged_intervals_rad']) == 2
    assert 'WARNING: wheel 200.0000 mm bridges concave flanks' in out.err


def test_cli_correct_reads_a_measurement_bag(tmp_path: Path, capsys) -> None:
    """`grind correct SCENE --lobe lobe_1 --measured BAG`: the bag of a cam ground with a
    wheel 5 mm too small (measured by the simulator through the scene's roller probe) is
    analysed as `analyze` does; the fitted wheel-radius error is the true one within 3 %."""
    import dataclasses
    import json

    from cam_design.grinding.machining_error import GroundCam, MachineErrors
    from cam_design.lift_laws import TabulatedLift
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    scene_path = Path(__file__).resolve().parent.parent / 'config' / 'default_scene.yaml'
    scene = load_scene(scene_path)
    lobe = scene.lobe('lobe_1')
    path = WheelPath(lobe.lift, scene.base_circle_radius, Design(lobe.follower.kind), RW)
    grid = np.linspace(-math.pi, math.pi, 14401)
    ground = GroundCam(path, MachineErrors(wheel_radius=-5e-3), probe=scene.probe)
    lift = np.clip(ground.lift(grid)[0], 0, None)
    bench = dataclasses.replace(scene, lobes=[dataclasses.replace(
        lobe, lift=TabulatedLift(grid, lift), follower=scene.probe)])
    bag = tmp_path / 'ground'
    write_sim_bag(bag, bench, SimParams(probe_noise=2e-7, seed=4))
    code = main(['grind', 'correct', str(scene_path), '--lobe', 'lobe_1', '--measured',
                 str(bag), '--wheel-radius', str(RW), '--probe', 'roller',
                 '--probe-radius', str(scene.probe.radius),
                 '--sources', 'wheel_radius,run_out_x,run_out_y', '--json', '-'])
    out = json.loads(capsys.readouterr().out)
    assert code == 0, out
    assert out['fit']['values']['wheel_radius'] == pytest.approx(-5e-3, rel=0.03)
    assert main(['grind', 'correct', str(scene_path), '--lobe', 'lobe_9', '--measured',
                 str(bag), '--wheel-radius', str(RW)]) == 2
    assert '--lobe' in capsys.readouterr().err


def test_correct_measured_error_in_um_or_with_decimal_commas_is_one_clear_line(
        cam_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """A lift error written in um under lift_error_m (11.15 for 11.15 um) was refused as
    'a ground-cam contact that does not settle'; now the message names the unit. A
    semicolon/decimal-comma row names its file line. The index error alone (-h'(alpha)
    d, d = 0.00087 rad, from the exact law) is fitted back within 1e-9 rad."""
    import json

    law = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'x')
    a = np.radians(np.arange(-180.0, 180.0, 0.5))
    err = np.asarray(law(a - 0.00087, 0)) - np.asarray(law(a, 0))
    meas = tmp_path / 'meas.csv'
    meas.write_text('alpha_rad,lift_error_m\n' + ''.join(
        f'{x!r},{e!r}\n' for x, e in zip(a.tolist(), err.tolist())))
    out = tmp_path / 'c.json'
    assert main(['grind', 'correct', str(cam_file), '--measured', str(meas), '--sources',
                 'index', '--json', str(out)]) == 0
    assert json.loads(out.read_text())['fit']['values']['index'] == pytest.approx(
        0.00087, abs=1e-9)
    meas.write_text('alpha_rad,lift_error_m\n' + ''.join(
        f'{x!r},{e * 1e6!r}\n' for x, e in zip(a.tolist(), err.tolist())))
    assert main(['grind', 'correct', str(cam_file), '--measured', str(meas)]) == 2
    msg = capsys.readouterr().err.strip()
    assert len(msg.splitlines()) == 1
    assert 'expected lift errors in metres (at most 2 mm); the values look like ' \
           'micrometres' in msg
    meas.write_text('alpha_rad;lift_error_m\n\n0,5;0,000001\n')
    assert main(['grind', 'correct', str(cam_file), '--measured', str(meas)]) == 2
    assert "meas.csv:3: got '0,5;0,000001'" in capsys.readouterr().err
