"""The lift-law interface shared by the whole project.

A lift law is a function h(alpha) of the cam angle alpha [rad], measured from the
lobe centreline (the nose of a symmetric lobe), giving the follower lift h [m] above
the base circle for the follower kind it was designed for. Outside ``support`` the
follower is on the base circle and h = 0 with all derivatives 0.

Call it like a scipy spline: ``law(alpha, nu)`` returns the nu-th derivative
(nu = 0..3: h [m], h' [m/rad], h'' [m/rad^2], h''' [m/rad^3]).
"""
from __future__ import annotations

import abc
import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError

MAX_ORDER = 3
#: m: how far a design table may sit off the base circle at its ends, or below it
DESIGN_TABLE_TOLERANCE = 1e-6


class LiftLaw(abc.ABC):
    """Abstract lift law h(alpha); subclasses implement ``_evaluate`` on the support."""

    #: order up to which h is continuous everywhere (0: h, 1: h', 2: h'', 3: h''').
    continuity_order: int = 0

    @property
    @abc.abstractmethod
    def support(self) -> tuple[float, float]:
        """(alpha_lo, alpha_hi) in rad: h may be non-zero only inside this interval."""

    @abc.abstractmethod
    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        """Return the nu-th derivative at ``alpha`` (1-D, all inside ``support``)."""

    @property
    def junctions(self) -> tuple[float, ...]:
        """Angles [rad] where segments meet (for continuity checks); empty if smooth."""
        return ()

    def __call__(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        """Evaluate the nu-th derivative of h at ``alpha`` [rad]; same shape as input."""
        if nu not in range(MAX_ORDER + 1):
            raise InputError('nu', nu, f'a derivative order 0..{MAX_ORDER}')
        a = np.asarray(alpha, dtype=float)
        flat = a.reshape(-1)
        out = np.zeros_like(flat)
        lo, hi = self.support
        inside = (flat >= lo) & (flat <= hi)
        if np.any(inside):
            out[inside] = self._evaluate(flat[inside], nu)
        return out.reshape(a.shape)

    def derivatives(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """Array of shape (4, n): h, h', h'', h''' at the flattened ``alpha``."""
        a = np.asarray(alpha, dtype=float).reshape(-1)
        return np.stack([self(a, nu) for nu in range(MAX_ORDER + 1)])

    def max_lift(self, samples: int = 20001) -> float:
        """Largest lift [m] on the support, from ``samples`` evenly spaced points (no
        refinement: low by at most |h''| d^2 / 8 for spacing d, ~1e-10 m on a lobe)."""
        lo, hi = self.support
        a = np.linspace(lo, hi, samples)
        h = self(a)
        return float(np.max(h))


class SolvedLift(LiftLaw):
    """A lift law whose lift and first three derivatives come from one ``solve(alpha)`` (a (4, n)
    array on the support, e.g. a contact-point iteration): every order asked for the same
    angles reuses that solve (cached on the angles' bytes)."""

    _cache: tuple[bytes, NDArray[np.float64]] | None = None

    @abc.abstractmethod
    def solve(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """(4, n): lift and its derivatives 1..3 [m, m/rad^k] at ``alpha`` [rad] (support)."""

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        tag = alpha.tobytes()
        if self._cache is None or self._cache[0] != tag:
            self._cache = (tag, self.solve(alpha))
        return self._cache[1][nu]

    def derivatives(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """(4, n): lift and derivatives 1..3 at the flattened ``alpha`` (one solve for all;
        zero outside the support)."""
        a = np.asarray(alpha, dtype=float).reshape(-1)
        out = np.zeros((4, a.size))
        lo, hi = self.support
        inside = (a >= lo) & (a <= hi)
        if np.any(inside):
            out[:, inside] = self.solve(a[inside])
        return out


class TabulatedLift(LiftLaw):
    """Lift from a table (alpha [rad] strictly increasing, h [m]).

    Interpolated by a quintic spline (C4) so that h''' is continuous; outside the
    table h = 0. Use this for nominal tables from a drawing or gauge; measured, noisy
    tables belong to the lobe law of `cam_design.lift_table`, which smooths them first.
    """

    continuity_order = 3

    def __init__(self, alpha: ArrayLike, h: ArrayLike, *, key: str = 'lift') -> None:
        from scipy.interpolate import make_interp_spline

        a, v = _checked_table(alpha, h, key)
        self.alpha = a
        self.h = v
        self._spline = make_interp_spline(a, v, k=5)
        self._derivs = [self._spline] + [self._spline.derivative(n) for n in (1, 2, 3)]
        self._check_no_dip(key)

    def _check_no_dip(self, key: str) -> None:
        """Reject a table whose interpolant dips below the lowest tabulated lift.

        A coarse table rings between its points (a 7-point lobe dipped 1 mm below the
        base circle): that would be silently wrong lift, not a property of the cam.
        Tolerance: 1 um + 0.1 % of the lift range.
        """
        a = self.alpha
        dense = np.linspace(a[0], a[-1], max(2001, 8 * a.size))
        h = self._spline(dense)
        floor = float(np.min(self.h))
        tol = 1e-6 + 1e-3 * float(np.ptp(self.h))
        i = int(np.argmin(h))
        if h[i] < floor - tol:
            raise InputError(
                f'{key}.alpha', f'{a.size} points',
                f'a table fine enough that its quintic interpolant stays above the lowest '
                f'tabulated lift ({floor:g} m); it reaches {h[i]:.4g} m at alpha = '
                f'{np.degrees(dense[i]):.2f} deg: tabulate more points')

    @property
    def support(self) -> tuple[float, float]:
        return float(self.alpha[0]), float(self.alpha[-1])

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        return self._derivs[nu](alpha)


def _float_array(values: ArrayLike, key: str, what: str) -> NDArray[np.float64]:
    """``values`` as a float array, or InputError naming ``key`` if not numeric."""
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(key, values, f'a list of numbers ({what})') from None


def check_design_table(alpha: ArrayLike, h: ArrayLike, key: str
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(alpha, h) of a design lift table that keeps the rules of a nominal lobe, else
    InputError naming the key: structure (``_checked_table``), angles [rad] within
    [-pi, pi] from the lobe centreline, lifts >= 0 m, h = 0 (within
    ``DESIGN_TABLE_TOLERANCE``) at both ends (the table covers the whole lobe down to the
    base circle), a positive lift, and lifts in m (not mm)."""
    a, v = _checked_table(alpha, h, key)
    tol = DESIGN_TABLE_TOLERANCE
    for j in (0, a.size - 1):
        if abs(a[j]) > np.pi:
            raise InputError(f'{key}.alpha[{j}]', float(a[j]),
                             'an angle in rad within [-pi, pi] from the lobe centreline '
                             '(degrees given?)')
    neg = np.nonzero(v < -tol)[0]
    if neg.size:
        j = int(neg[0])
        raise InputError(f'{key}.h[{j}]', float(v[j]), 'a lift >= 0 m above the base circle')
    for j in (0, v.size - 1):
        if abs(v[j]) > tol:
            raise InputError(f'{key}.h[{j}]', float(v[j]),
                             f'0 (within {tol:g} m) at both ends: the table '
                             'must cover the whole lobe down to the base circle')
    if float(np.max(v)) <= tol:
        raise InputError(f'{key}.h', 'all zero', 'a lobe with a positive lift in m')
    if float(np.max(v)) > 0.1:
        raise InputError(f'{key}.h', float(np.max(v)), 'lifts in m (mm given?)')
    return a, v


def _checked_table(alpha: ArrayLike, h: ArrayLike, key: str,
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validate a lift table's structure: numeric, 1-D, same length, >= 6 points,
    finite, alpha strictly increasing. Returns (alpha, h) as float arrays."""
    a = _float_array(alpha, f'{key}.alpha', 'angles in rad')
    v = _float_array(h, f'{key}.h', 'lifts in m')
    if a.ndim != 1 or v.ndim != 1:
        raise InputError(f'{key}.alpha', a.shape, 'one-dimensional lists')
    if a.size != v.size:
        raise InputError(f'{key}.h', f'{v.size} values',
                         f'as many values as {key}.alpha ({a.size})')
    if a.size < 6:
        raise InputError(f'{key}.alpha', f'{a.size} points', 'at least 6 points')
    if not np.all(np.isfinite(a)):
        raise InputError(f'{key}.alpha', 'non-finite entries', 'finite angles in rad')
    if not np.all(np.isfinite(v)):
        raise InputError(f'{key}.h', 'non-finite entries', 'finite lifts in m')
    bad = np.nonzero(np.diff(a) <= 0)[0]
    if bad.size:
        i = int(bad[0])
        raise InputError(f'{key}.alpha[{i + 1}]', float(a[i + 1]),
                         f'strictly increasing angles (previous is {float(a[i])})')
    return a, v
