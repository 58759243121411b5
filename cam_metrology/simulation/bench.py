"""A simulated camshaft measuring bench (pure numpy; no rclpy).

``simulate(scene, params)`` measures every feature of a scene in turn (the lobes in
scene order, then the datum: dowel pin or keyway) the way the bench does: the shaft
turns, the encoder gives ``theta`` [rad] and the probe gives ``s`` [m] with an
arbitrary zero. The truth
(true nose and pin angles, phases, probe zero, noise) comes with the samples so that
the analysis can be scored. ``iter_joint_state_messages`` gives the sample stream the
live ``bench-sim`` node publishes, and ``write_sim_bag`` records it into a bag exactly
as the recorder would (``/bench/scene``, ``/bench/truth``, ``/bench/joint_states``,
``/bench/feature_done``).

Model (conventions of docs/contract.md):

* lobe: ``s = zero + h_probe(alpha) + runout + noise`` with
  ``alpha = direction * (theta_true - nose)`` wrapped to (-pi, pi], where ``h_probe``
  is the lobe's design lift converted through the cam profile to the scene's probe
  (``cam_design.follower.convert_lift``; identity when the followers are the same);
* dowel pin: ``s = zero + DowelPinGeometry.lift(alpha)`` (Liu's absolute lift)
  inside contact; outside it the probe rests on its stop ``pin_stop_depth`` below the
  lowest contact lift;
* keyway: ``s = zero + KeywayGeometry.lift(alpha)`` (0 on the shaft, negative over the
  slot; ``cam_design.keyway``) plus run-out and noise like a lobe;
* ``theta`` reported = ``theta_true + encoder noise``; the shaft turns continuously
  from ``start_theta`` through all features (unwrapped, or wrapped to [0, 2 pi)),
  theta increasing with time (decreasing with ``reverse``);
* ``runout``: base-circle run-out amplitude [m], ``runout * cos(theta_true)`` (a shaft
  eccentric on its centres, first order).
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_finite, require_positive
from cam_metrology.scene.model import Scene

__all__ = ['SimParams', 'SimFeature', 'BenchRun', 'simulate', 'probe_lift',
           'iter_joint_state_messages', 'write_sim_bag', 'wrap_pi', 'DOWEL_PIN',
           'scene_with_direction']

DOWEL_PIN = 'dowel_pin'
KEYWAY = 'keyway'
TWO_PI = 2.0 * math.pi
#: bag/stream start when SimParams.start_ns is None: 2026-01-01T00:00:00Z [ns]
DEFAULT_START_NS = 1_767_225_600 * 1_000_000_000


def _doc(default: Any, doc: str) -> Any:
    """A dataclass field with a description (``metadata['doc']``, used as the ROS
    parameter description by the bench-sim node)."""
    return field(default=default, metadata={'doc': doc})


@dataclass(frozen=True)
class SimParams:
    """Simulation parameters (SI: m, rad, s).

    ``true_angles``: feature id -> true nose / pin-centre encoder angle [rad]; None:
    drawn from ``seed`` (pin within +-1 deg of its nominal angle, lobes at their
    nominal phase from the pin +-0.5 deg, or uniform when no nominal phase). Features
    missing from a given dict are drawn as well.
    """

    samples_per_rev: int = _doc(3600, 'encoder samples per camshaft revolution')
    revolutions: float = _doc(1.0, 'revolutions measured per feature')
    wrapped: bool = _doc(False, 'encoder angle wrapped to [0, 2 pi) instead of unwrapped')
    start_theta: float = _doc(0.0, 'rad, encoder angle of the first sample')
    probe_zero_offset: float = _doc(5.0e-4, 'm, probe reading on the base circle '
                                    '(the probe zero is arbitrary)')
    probe_noise: float = _doc(0.0, 'm, standard deviation of the probe noise')
    encoder_noise: float = _doc(0.0, 'rad, standard deviation of the encoder noise')
    seed: int = _doc(0, 'random seed of the true angles and of the noise')
    true_angles: dict[str, float] | None = _doc(
        None, 'feature id -> true nose / pin-centre encoder angle [rad]; None: from seed')
    rate: float = _doc(1000.0, 'samples/s (stamps; publishing rate of the live node)')
    pin_stop_depth: float = _doc(5.0e-4, 'm, the probe stop below the lowest pin-contact '
                                 'lift (outside the pin contact)')
    runout: float = _doc(0.0, 'm, base-circle run-out amplitude (once per revolution)')
    feature_gap: float = _doc(0.05, 's, pause between two features (stamps)')
    start_ns: int | None = _doc(None, 'ns, stamp of the first sample (None: 2026-01-01)')
    reverse: bool = _doc(False, 'shaft turned backwards: theta decreases with time')
    lift_scale: float = _doc(1.0, 'true lift of every lobe = lift_scale x its design lift '
                             '(a form error for acceptance tests; 1: the design)')
    chatter_upr: int = _doc(0, 'chatter marks on every lobe: a ripple of this many '
                            'undulations per revolution (0: none)')
    chatter_amplitude: float = _doc(0.0, 'm, amplitude of the chatter ripple')
    chatter_extent_deg: float = _doc(360.0, 'cam degrees the chatter covers (360: all round)')
    chatter_centre_deg: float = _doc(0.0, 'cam angle [deg] from the lobe centreline at the '
                                     'middle of the chattered arc')
    journal_lobes: int = _doc(0, 'journals: lobing of this many UPR (3: a 3-lobed journal; '
                              '0: round)')
    journal_lobing: float = _doc(0.0, 'm, amplitude of the journals\' lobing')
    bend: float = _doc(0.0, 'm, bow of a bent shaft: eccentricity of the journals (and of '
                       'the lobes with an axial_position) '
                       'bend * sin(pi (z - z_first) / (z_last - z_first)) along the axis')
    bend_direction_deg: float = _doc(0.0, 'encoder angle [deg] of the bow\'s direction')
    lobe_tracks_mm: tuple[float, ...] | None = _doc(
        None, 'every lobe measured on these tracks across its width [mm from its mid-plane] '
        'as frame_id <lobe>@<z> (None: one track, frame_id the lobe id)')
    taper_um_per_mm: float = _doc(0.0, 'tracks: nose lift grows by this many um per mm of '
                                  'z (the lift scaled by 1 + taper z / max lift)')
    twist_deg_per_mm: float = _doc(0.0, 'tracks: the nose turns by this many cam degrees per '
                                   'mm of z')
    samples_per_message: int = _doc(1, 'how the bench sends its samples: 1 = one '
                                    'sensor_msgs/JointState each on /bench/joint_states; '
                                    'N > 1 = blocks of N per trajectory_msgs/JointTrajectory '
                                    'on /bench/joint_trajectory')

    def validated(self) -> SimParams:
        """Raise InputError for an impossible parameter; return self."""
        if isinstance(self.samples_per_rev, bool) or not isinstance(
                self.samples_per_rev, (int, np.integer)) or self.samples_per_rev < 8:
            raise InputError('samples_per_rev', self.samples_per_rev, 'an integer >= 8')
        revs = require_positive('revolutions', self.revolutions)
        if round(revs * self.samples_per_rev) < 8:
            raise InputError('revolutions', self.revolutions,
                             f'at least 8 samples per feature ({self.samples_per_rev} '
                             'samples per revolution)')
        if revs * self.samples_per_rev > 50_000_000:
            # blame the factor that made it huge: the per-revolution count unless the
            # revolutions exceed one
            key, value = (('revolutions', self.revolutions) if revs > 1
                          else ('samples_per_rev', self.samples_per_rev))
            raise InputError(key, value,
                             f'at most 5e7 samples per feature (samples per revolution '
                             f'{self.samples_per_rev} x revolutions {revs:g})')
        require_finite('start_theta', self.start_theta)
        require_finite('probe_zero_offset', self.probe_zero_offset)
        require_positive('probe_noise', self.probe_noise, allow_zero=True)
        require_positive('encoder_noise', self.encoder_noise, allow_zero=True)
        require_positive('rate', self.rate)
        require_positive('pin_stop_depth', self.pin_stop_depth, allow_zero=True)
        require_positive('runout', self.runout, allow_zero=True)
        require_positive('feature_gap', self.feature_gap, allow_zero=True)
        require_positive('lift_scale', self.lift_scale)
        if isinstance(self.chatter_upr, bool) or int(self.chatter_upr) != self.chatter_upr \
                or self.chatter_upr < 0:
            raise InputError('chatter_upr', self.chatter_upr, 'a whole number of UPR >= 0')
        require_positive('chatter_amplitude', self.chatter_amplitude, allow_zero=True)
        extent = require_positive('chatter_extent_deg', self.chatter_extent_deg)
        if extent > 360.0:
            raise InputError('chatter_extent_deg', extent, 'cam degrees in (0, 360]')
        require_finite('chatter_centre_deg', self.chatter_centre_deg)
        if isinstance(self.journal_lobes, bool) or int(self.journal_lobes) != \
                self.journal_lobes or self.journal_lobes < 0:
            raise InputError('journal_lobes', self.journal_lobes, 'a whole number of UPR >= 0')
        require_positive('journal_lobing', self.journal_lobing, allow_zero=True)
        require_positive('bend', self.bend, allow_zero=True)
        require_finite('bend_direction_deg', self.bend_direction_deg)
        for j, z in enumerate(self.lobe_tracks_mm or ()):
            require_finite(f'lobe_tracks_mm[{j}]', z)
        require_finite('taper_um_per_mm', self.taper_um_per_mm)
        require_finite('twist_deg_per_mm', self.twist_deg_per_mm)
        if isinstance(self.samples_per_message, bool) or not isinstance(
                self.samples_per_message, (int, np.integer)) or self.samples_per_message < 1:
            raise InputError('samples_per_message', self.samples_per_message,
                             'an integer >= 1')
        if self.true_angles is not None:
            if not isinstance(self.true_angles, dict):
                raise InputError('true_angles', self.true_angles, 'a mapping id -> rad')
            for k, v in self.true_angles.items():
                require_finite(f'true_angles.{k}', v)
        return self


@dataclass
class SimFeature:
    """The samples of one feature: encoder ``theta`` [rad], probe ``s`` [m], stamps [ns]."""

    id: str
    kind: str                     # 'lobe' | 'dowel_pin' | 'keyway'
    true_angle: float             # rad, true nose / pin-centre encoder angle
    theta: NDArray[np.float64]
    s: NDArray[np.float64]
    stamp_ns: NDArray[np.int64]


@dataclass
class BenchRun:
    """A simulated measurement: features in measurement order and the JSON-able truth."""

    scene: Scene
    params: SimParams
    features: list[SimFeature]
    truth: dict[str, Any] = field(default_factory=dict)

    @property
    def sample_count(self) -> int:
        """Total number of samples."""
        return int(sum(f.theta.size for f in self.features))


def wrap_pi(x: NDArray[np.float64] | float) -> Any:
    """Wrap angles [rad] to (-pi, pi]."""
    y = np.pi - np.mod(np.pi - np.asarray(x, dtype=float), TWO_PI)
    return float(y) if np.ndim(y) == 0 else y


def _wrap_2pi(x: float) -> float:
    """Wrap an angle [rad] to [0, 2 pi) (np.mod can round up to 2 pi itself)."""
    y = float(np.mod(x, TWO_PI))
    return 0.0 if y >= TWO_PI else y


def _wrap_deg_pm180(x: float) -> float:
    return 180.0 - (180.0 - x) % 360.0


def scene_with_direction(scene: Scene, direction: int) -> Scene:
    """The scene with another ``direction`` (+1/-1), its YAML text edited to match
    (comments kept), so that the /bench/scene a bag carries describes the data."""
    import re

    from cam_metrology.scene.parse import parse_scene

    if direction not in (1, -1):
        raise InputError('direction', direction, '+1 or -1')
    line = f'direction: {direction:d}'
    text, count = re.subn(r'^direction:[^\n#]*', line + '   ', scene.text, count=1,
                          flags=re.MULTILINE)
    if count == 0:
        text = f'{line}\n{scene.text}'
    return parse_scene(text)


def probe_lift(scene: Scene, lobe_id: str) -> Any:
    """The lift [m] the scene's probe sees on a lobe: the design lift converted through
    the profile (``convert_lift``), or the design lift itself for the same follower."""
    from cam_design import follower as fol

    lobe = scene.lobe(lobe_id)
    convert = getattr(fol, 'convert_lift', None)
    if convert is None:   # the follower module without conversion: identity
        return lobe.lift
    return convert(lobe.lift, scene.base_circle_radius, lobe.follower, scene.probe,
                   key=f'lobes[{scene.lobes.index(lobe)}].lift')


def _true_angles(scene: Scene, params: SimParams) -> dict[str, float]:
    """True encoder angles [rad, wrapped to [0, 2 pi)] of every feature."""
    rng = np.random.default_rng(np.random.SeedSequence([int(params.seed), 1]))
    given = dict(params.true_angles or {})
    deg = math.pi / 180.0
    # one draw per feature in a fixed order, whether used or not: the truth of a
    # feature never depends on which others were given
    pin_draw = rng.uniform(-1.0, 1.0) * deg
    lobe_draws = [(rng.uniform(-0.5, 0.5) * deg, rng.uniform(0.0, TWO_PI))
                  for _ in scene.lobes]
    pin = scene.datum   # dowel pin or keyway
    datum_id = scene.datum_id or DOWEL_PIN
    pin_angle = given.get(datum_id, ((pin.nominal_angle or 0.0) if pin else 0.0) + pin_draw)
    out: dict[str, float] = {}
    for lobe, (err, uniform) in zip(scene.lobes, lobe_draws):
        if lobe.id in given:
            angle = given[lobe.id]
        elif lobe.nominal_phase is not None and pin is not None:
            angle = pin_angle + lobe.nominal_phase + err
        else:
            angle = uniform
        out[lobe.id] = _wrap_2pi(angle)
    if pin is not None:
        out[datum_id] = _wrap_2pi(pin_angle)
    unknown = set(given) - set(out)
    if unknown:
        raise InputError('true_angles', sorted(unknown),
                         'ids of the scene\'s features: ' + ', '.join(out))
    return out


def simulate(scene: Scene, params: SimParams | None = None) -> BenchRun:
    """Simulate the bench measuring every feature of ``scene`` (see the module doc)."""
    from cam_design.dowel_pin import DowelPinGeometry
    from cam_design.keyway import KeywayGeometry

    params = (params or SimParams()).validated()
    angles = _true_angles(scene, params)
    seq = np.random.SeedSequence([int(params.seed), 2])
    probe_rng, enc_rng = (np.random.default_rng(s) for s in seq.spawn(2))
    n = int(round(params.revolutions * params.samples_per_rev))
    step = TWO_PI / params.samples_per_rev
    dt_ns = 1e9 / params.rate
    start_ns = DEFAULT_START_NS if params.start_ns is None else int(params.start_ns)
    gap_ns = int(round(params.feature_gap * 1e9))
    zero = params.probe_zero_offset
    scale = float(params.lift_scale)
    order: list[tuple[str, str]] = [
        (lobe.id if params.lobe_tracks_mm is None else f'{lobe.id}@{z:g}', 'lobe')
        for lobe in scene.lobes for z in (params.lobe_tracks_mm or (0.0,))]
    order += [(j.id, 'journal') for j in scene.journals]
    if scene.datum_id is not None:
        order.append((scene.datum_id, scene.datum_id))
    features: list[SimFeature] = []
    k0 = 0
    t0 = start_ns
    conversions: dict[str, str] = {}
    for fid, kind in order:
        k = np.arange(k0, k0 + n, dtype=np.float64)
        theta_true = params.start_theta + (-k if params.reverse else k) * step
        base_id, _, track = fid.partition('@')
        alpha = wrap_pi(scene.direction * (theta_true - angles.get(base_id, 0.0)))
        if kind == 'lobe':
            law = probe_lift(scene, base_id)
            lobe = scene.lobe(base_id)
            conversions[base_id] = ('identity' if law is lobe.lift else
                                    f'{lobe.follower.kind} -> {scene.probe.kind}')
            if track:
                law = tapered(law, float(track), params)
            s = zero + (law(alpha) if scale == 1.0 else scale * law(alpha))
            if params.chatter_upr and params.chatter_amplitude:
                s = s + chatter(theta_true, alpha, params)
            s = s + bow_reading(scene, base_id, theta_true, params)
        elif kind == 'journal':
            s = zero + journal_reading(scene, fid, theta_true, params)
        elif kind == KEYWAY:
            kw = scene.keyway
            kgeo = KeywayGeometry(kw.width, kw.shaft_radius, kw.probe_radius, kw.depth)
            h = kgeo.lift(alpha)   # 0 on the shaft, negative over the slot
            s = zero + np.where(np.isfinite(h), h, kgeo.depth_seen)
        else:
            pin = scene.dowel_pin
            geo = DowelPinGeometry(pin.pin_radius, pin.circle_radius, pin.probe_radius)
            # contact only for |alpha| <= alpha_max: the formula's radicand is also
            # positive near |alpha| = pi (the pin behind the axis), which is no contact
            contact = np.abs(alpha) <= geo.contact_half_angle
            with np.errstate(invalid='ignore'):
                h = geo.lift(np.where(contact, alpha, 0.0))
            stop = geo.lift_min - params.pin_stop_depth
            s = zero + np.where(contact & np.isfinite(h), h, stop)
        if params.runout:
            s = s + params.runout * np.cos(theta_true)
        if params.probe_noise:
            s = s + probe_rng.normal(0.0, params.probe_noise, n)
        theta = theta_true
        if params.encoder_noise:
            theta = theta + enc_rng.normal(0.0, params.encoder_noise, n)
        if params.wrapped:
            theta = np.mod(theta, TWO_PI)
        stamps = t0 + np.round(np.arange(n) * dt_ns).astype(np.int64)
        features.append(SimFeature(fid, kind, angles.get(base_id, 0.0), theta, s, stamps))
        k0 += n
        t0 = int(stamps[-1]) + int(round(dt_ns)) + gap_ns
    run = BenchRun(scene, params, features)
    run.truth = _truth(scene, params, angles, conversions, n)
    return run


def tapered(law: Callable[..., Any], z_mm: float, params: SimParams) -> Callable[..., Any]:
    """The lift [m] of a track ``z_mm`` across the lobe's width: ``law`` turned by
    ``twist_deg_per_mm * z`` and scaled by ``1 + taper_um_per_mm * z / max lift``."""
    shift = math.radians(params.twist_deg_per_mm * z_mm)
    grid = np.linspace(-math.pi, math.pi, 7201)
    factor = 1.0 + params.taper_um_per_mm * 1e-6 * z_mm / float(np.max(law(grid)))
    return lambda a: factor * law(wrap_pi(np.asarray(a) - shift))


def bow(scene: Scene, feature_id: str, params: SimParams) -> float:
    """Eccentricity [m] of a feature's centre on a bent shaft (``SimParams.bend``): a
    journal, or a lobe with an ``axial_position`` (0 without one), the half sine spanning
    the journals."""
    z = [j.axial_position for j in scene.journals]
    journal = scene.journal(feature_id)
    at = journal.axial_position if journal is not None else \
        scene.lobe(feature_id).axial_position
    span = max(z) - min(z) if z else 0.0
    if not params.bend or span <= 0 or at is None:
        return 0.0
    return params.bend * math.sin(math.pi * (at - min(z)) / span)


def bow_reading(scene: Scene, feature_id: str, theta_true: NDArray[np.float64],
                params: SimParams) -> NDArray[np.float64] | float:
    """The bow's once-per-revolution reading [m] on a feature (towards
    ``bend_direction_deg``; 0.0 on a straight shaft)."""
    e = bow(scene, feature_id, params)
    return e * np.cos(theta_true - math.radians(params.bend_direction_deg)) if e else 0.0


def journal_reading(scene: Scene, journal_id: str, theta_true: NDArray[np.float64],
                    params: SimParams) -> NDArray[np.float64]:
    """Probe reading [m] on a journal above the base-circle reading: the radius
    difference, the bow of a bent shaft (once per revolution towards
    ``bend_direction_deg``) and the lobing ``journal_lobing cos(journal_lobes theta)``."""
    j = scene.journal(journal_id)
    out = np.full(theta_true.size, j.radius - scene.base_circle_radius)
    out += bow_reading(scene, journal_id, theta_true, params)
    if params.journal_lobes and params.journal_lobing:
        out += params.journal_lobing * np.cos(int(params.journal_lobes) * theta_true)
    return out


def chatter(theta_true: NDArray[np.float64], alpha: NDArray[np.float64],
            params: SimParams) -> NDArray[np.float64]:
    """The chatter ripple [m]: ``chatter_amplitude * cos(chatter_upr * theta_true)`` on
    the cam angles ``alpha`` [rad] within ``chatter_extent_deg / 2`` of
    ``chatter_centre_deg``, 0 elsewhere."""
    off = wrap_pi(alpha - math.radians(params.chatter_centre_deg))
    inside = np.abs(off) <= math.radians(params.chatter_extent_deg) / 2.0 + 1e-12
    return np.where(inside, params.chatter_amplitude *
                    np.cos(int(params.chatter_upr) * theta_true), 0.0)


def _truth(scene: Scene, params: SimParams, angles: dict[str, float],
           conversions: dict[str, str], n: int) -> dict[str, Any]:
    """The JSON-able truth of a run (angles in deg, wrapped like the report's)."""
    deg = 180.0 / math.pi
    feats: dict[str, Any] = {}
    datum_id = scene.datum_id or DOWEL_PIN
    pin_angle = angles.get(datum_id)
    for lobe in scene.lobes:
        a = angles[lobe.id]
        entry: dict[str, Any] = {'kind': 'lobe', 'angle_deg': a * deg, 'angle_rad': a,
                                 'samples': n, 'lift_conversion': conversions[lobe.id]}
        if pin_angle is not None:
            phase = _wrap_deg_pm180((a - pin_angle) * deg)
            entry['phase_deg'] = phase
            if lobe.nominal_phase is not None:
                entry['nominal_phase_deg'] = lobe.nominal_phase * deg
                entry['phase_error_deg'] = _wrap_deg_pm180(phase - lobe.nominal_phase * deg)
        feats[lobe.id] = entry
    if pin_angle is not None:
        feats[datum_id] = {'kind': datum_id, 'angle_deg': pin_angle * deg,
                           'angle_rad': pin_angle, 'samples': n}
    p = asdict(params)
    if p.get('lift_scale') == 1.0:   # the design itself: truth as before the option existed
        del p['lift_scale']
    if not p.get('chatter_upr'):     # no chatter: truth as before the option existed
        for k in ('chatter_upr', 'chatter_amplitude', 'chatter_extent_deg',
                  'chatter_centre_deg'):
            del p[k]
    if p.get('lobe_tracks_mm') is None:   # one track: truth as before the options existed
        for k in ('lobe_tracks_mm', 'taper_um_per_mm', 'twist_deg_per_mm'):
            del p[k]
    else:
        p['lobe_tracks_mm'] = list(p['lobe_tracks_mm'])
    if not scene.journals:           # no journals: truth as before the options existed
        for k in ('journal_lobes', 'journal_lobing', 'bend', 'bend_direction_deg'):
            del p[k]
    for lobe in scene.lobes:
        if params.bend and lobe.axial_position is not None:
            feats[lobe.id]['bow_m'] = bow(scene, lobe.id, params)
    for j in scene.journals:
        feats[j.id] = {'kind': 'journal', 'bow_m': bow(scene, j.id, params),
                       'probe_zero_radius_m': scene.base_circle_radius -
                       params.probe_zero_offset, 'samples': n}
    if p.get('samples_per_message') == 1:   # one sample per message: truth as before
        del p['samples_per_message']
    return {
        'camshaft_id': scene.camshaft_id,
        'direction': scene.direction,
        'features': feats,
        'measurement_order': [lobe.id if params.lobe_tracks_mm is None else f'{lobe.id}@{z:g}'
                              for lobe in scene.lobes for z in (params.lobe_tracks_mm or (0,))] +
        [j.id for j in scene.journals] + ([datum_id] if pin_angle is not None else []),
        'probe_zero_offset_m': params.probe_zero_offset,
        'probe_noise_m': params.probe_noise,
        'encoder_noise_rad': params.encoder_noise,
        'runout_m': params.runout,
        'params': p,
    }


def iter_joint_state_messages(run: BenchRun) -> Iterator[tuple[int, str, float, float]]:
    """Yield ``(stamp_ns, frame_id, theta, s)`` per sample in measurement order.

    The live bench-sim node and ``write_sim_bag`` both publish this stream; each
    feature's samples are contiguous and ``frame_id`` is the feature id.
    """
    for feat in run.features:
        for stamp, theta, s in zip(feat.stamp_ns.tolist(), feat.theta.tolist(),
                                   feat.s.tolist()):
            yield stamp, feat.id, theta, s


def write_sim_bag(path: str | Path, scene: Scene, params: SimParams | None = None, *,
                  compression: bool = True,
                  progress: Callable[[int, int], None] | None = None,
                  rounds: int = 1, samples_per_message: int | None = None) -> BenchRun:
    """Simulate and record a bag as the bench + recorder would (returns the run).

    Topics: ``/bench/scene`` (scene YAML) and ``/bench/truth`` (JSON) first, latched;
    ``/bench/joint_states`` (one message per sample, log time = header stamp);
    ``/bench/feature_done`` after each feature's last sample. ``progress(done, total)``
    is called every 10 000 samples. ``rounds``: the bench measures every feature that
    many times in a row (the same samples, each round later by the run's duration plus
    ``feature_gap``): a long bag of repeated measurements of one part.
    ``samples_per_message`` (default: ``params.samples_per_message``) > 1: the samples
    go in blocks of that many on ``/bench/joint_trajectory`` (log time = the block's
    last sample) instead.
    """
    from cam_metrology.bagio import BagWriter
    from cam_metrology.wire.cdr import encode_joint_states, encode_sample_blocks, encode_string
    from cam_metrology.wire.topics import (FEATURE_DONE, JOINT_STATES, JOINT_TRAJECTORY, SCENE,
                                           TOPIC_TYPES, TRUTH)

    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)) or rounds < 1:
        raise InputError('rounds', rounds, 'an integer >= 1')
    if samples_per_message is None:
        samples_per_message = (params or SimParams()).samples_per_message
    if isinstance(samples_per_message, bool) or not isinstance(
            samples_per_message, (int, np.integer)) or samples_per_message < 1:
        raise InputError('samples_per_message', samples_per_message, 'an integer >= 1')
    samples_topic = JOINT_STATES if samples_per_message == 1 else JOINT_TRAJECTORY
    run = simulate(scene, params)
    total = run.sample_count * int(rounds)
    first = int(run.features[0].stamp_ns[0]) if run.features else DEFAULT_START_NS
    period = 0
    if run.features:
        p = run.params
        period = int(run.features[-1].stamp_ns[-1]) - first + int(round(1e9 / p.rate)) + \
            int(round(p.feature_gap * 1e9))
    with BagWriter(path, compression=compression) as writer:
        for topic in (SCENE, TRUTH, samples_topic, FEATURE_DONE):
            writer.add_topic(topic, TOPIC_TYPES[topic])
        writer.write(SCENE, first - 2_000_000, encode_string(scene.text))
        writer.write(TRUTH, first - 1_000_000,
                     encode_string(json.dumps(run.truth, sort_keys=True)))
        done = 0
        write = writer.write
        for feat in (f for r in range(int(rounds)) for f in _shifted(run, r * period)):
            stamps = feat.stamp_ns.tolist()
            if samples_per_message > 1:
                for stamp, cdr in encode_sample_blocks(feat.id, feat.stamp_ns, feat.theta,
                                                       feat.s, samples_per_message):
                    write(JOINT_TRAJECTORY, stamp, cdr)
                done += len(stamps)
                if progress is not None:
                    progress(done, total)
                writer.write(FEATURE_DONE, stamps[-1] + 1000, encode_string(feat.id))
                continue
            cdrs = encode_joint_states(feat.id, feat.stamp_ns, feat.theta, feat.s)
            for stamp, cdr in zip(stamps, cdrs):
                write(JOINT_STATES, stamp, cdr)
                done += 1
                if progress is not None and done % 10_000 == 0:
                    progress(done, total)
            writer.write(FEATURE_DONE, stamps[-1] + 1000, encode_string(feat.id))
    if progress is not None:
        progress(total, total)
    return run


def _shifted(run: BenchRun, shift_ns: int) -> list[SimFeature]:
    """The run's features with their stamps moved by ``shift_ns`` [ns]."""
    if not shift_ns:
        return list(run.features)
    return [SimFeature(f.id, f.kind, f.true_angle, f.theta, f.s, f.stamp_ns + shift_ns)
            for f in run.features]
