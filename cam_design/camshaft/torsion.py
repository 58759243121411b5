"""Torsional model of the camshaft: lumped stations joined by round-bar sections,
driven at the sprocket (docs/camshaft.md).

Each section (length L, diameter d, bore b, shear modulus G, density rho) is a spring
k = G J / L with J = pi (d^4 - b^4) / 32, and carries rho J L of polar inertia, half to
each end station; station inertias (lobes, sprocket) are added. The shaft's damping is
stiffness-proportional, C = (2 zeta / w1) K_shaft, so the first mode has the ratio zeta.
The unknowns are the stations' angles psi [rad] relative to the rigid, constant-speed
rotation (alpha = omega t): a constant-speed drive holds the sprocket at psi = 0; a
chain, belt or gear ties it to the crank through k_d and c_d.

Periodic response to load torques L_j(alpha) [N m] (positive: the station takes torque
from the shaft): psi = sum Psi_n exp(i n alpha) with
    (K - (n omega)^2 M + i n omega C) Psi_n = -L_n,   n = 0 .. N/2,
exact for the sampled loads (discrete Fourier series on the N-point grid).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import eigh

from cam_design.camshaft.piecewise_fourier import coefficients, integral, kernel_coefficients
from cam_design.camshaft.spec import SPROCKET, CamshaftSpec


@dataclass(frozen=True)
class Shaft:
    """Assembled shaft: full matrices over all stations (``K``, ``M``, ``C``; SI), the
    sprocket's index, whether it is held (constant-speed drive) and the drive's
    stiffness/damping to the crank."""

    stations: tuple[str, ...]
    K: NDArray[np.float64]
    M: NDArray[np.float64]
    C: NDArray[np.float64]
    sprocket: int
    held: bool
    drive_stiffness: float
    drive_damping: float

    @property
    def free(self) -> NDArray[np.int64]:
        """Indices of the stations that move (all but a held sprocket)."""
        return np.array([i for i in range(len(self.stations))
                         if not (self.held and i == self.sprocket)], dtype=np.int64)


def section_stiffness(length: float, diameter: float, bore: float,
                      shear_modulus: float) -> float:
    """Torsional stiffness [N m/rad] of a round bar: G pi (d^4 - b^4) / (32 L)."""
    return shear_modulus * math.pi * (diameter ** 4 - bore ** 4) / (32.0 * length)


def section_inertia(length: float, diameter: float, bore: float, density: float) -> float:
    """Polar mass moment of inertia [kg m^2] of a round bar: rho L pi (d^4 - b^4) / 32."""
    return density * length * math.pi * (diameter ** 4 - bore ** 4) / 32.0


def assemble(spec: CamshaftSpec) -> Shaft:
    """The shaft of a validated ``camshaft:`` block."""
    n = len(spec.stations)
    K = np.zeros((n, n))
    M = np.diag([spec.inertia_of(s) for s in spec.stations]).astype(float)
    for i, sec in enumerate(spec.sections):
        k = section_stiffness(sec.length, sec.diameter, sec.bore, spec.shear_modulus)
        j = section_inertia(sec.length, sec.diameter, sec.bore, spec.density)
        K[i:i + 2, i:i + 2] += k * np.array([[1.0, -1.0], [-1.0, 1.0]])
        M[i, i] += 0.5 * j
        M[i + 1, i + 1] += 0.5 * j
    s = spec.stations.index(SPROCKET)
    drive = spec.drive
    held = drive.kind == 'constant_speed'
    M[s, s] += drive.sprocket_inertia
    Kt = K.copy()
    if not held:
        Kt[s, s] += drive.stiffness
    idx = [i for i in range(n) if not (held and i == s)]
    w2 = eigh(Kt[np.ix_(idx, idx)], M[np.ix_(idx, idx)], eigvals_only=True)
    w1 = math.sqrt(max(float(w2[0]), 0.0))
    C = (2.0 * spec.damping_ratio / w1) * K if w1 > 0 else np.zeros_like(K)
    if not held:
        C[s, s] += drive.damping
    return Shaft(stations=spec.stations, K=Kt, M=M, C=C, sprocket=s, held=held,
                 drive_stiffness=drive.stiffness if not held else 0.0,
                 drive_damping=drive.damping if not held else 0.0)


def natural_frequencies(shaft: Shaft) -> NDArray[np.float64]:
    """Undamped torsional natural frequencies [Hz], ascending (rigid-body mode of a
    free shaft excluded: the drive always grounds it)."""
    idx = shaft.free
    w2 = eigh(shaft.K[np.ix_(idx, idx)], shaft.M[np.ix_(idx, idx)], eigvals_only=True)
    return np.sqrt(np.maximum(w2, 0.0)) / (2.0 * math.pi)


def order_crossings(freqs_hz: NDArray[np.float64], orders: int,
                    max_rpm: float) -> list[dict[str, float]]:
    """Camshaft speeds [rpm] at which excitation order n (n per cam revolution,
    n = 1..``orders``) equals a natural frequency: rpm = 60 f / n, those <= max_rpm."""
    out = []
    for mode, f in enumerate(freqs_hz, start=1):
        for n in range(1, orders + 1):
            rpm = 60.0 * float(f) / n
            if rpm <= max_rpm:
                out.append({'mode': mode, 'frequency_hz': float(f), 'order': n,
                            'cam_speed_rpm': rpm})
    return sorted(out, key=lambda c: c['cam_speed_rpm'])


@dataclass(frozen=True)
class Response:
    """Periodic torsional response on the N-point grid alpha_k = 2 pi k / N.

    ``spectrum`` (stations, N/2 + 1): Fourier coefficients Psi_n of psi [rad] (rfft
    scaling: psi = irfft(spectrum * N)) up to the grid's Nyquist order; ``psi``,
    ``dpsi``, ``d2psi``, ``d3psi``: (stations, N) psi and its alpha derivatives
    [rad, -, 1/rad, 1/rad^2] on the grid, with the harmonics above N/2 of loads with
    breakpoints (``respond``) folded in; ``drive`` (N,): the torque the drive applies
    to the sprocket [N m]."""

    spectrum: NDArray[np.complex128]
    psi: NDArray[np.float64]
    dpsi: NDArray[np.float64]
    d2psi: NDArray[np.float64]
    d3psi: NDArray[np.float64]
    drive: NDArray[np.float64]


#: bands of N harmonics above the Nyquist order kept for loads with breakpoints
TAIL_BANDS = 2


@dataclass(frozen=True)
class Receptance:
    """The shaft's dynamic compliance at one speed on one grid: (K - (n omega)^2 M +
    i n omega C)^-1 over the free stations for the harmonics n = 0..N/2 (``low``) and
    N/2..N/2 + TAIL_BANDS N - 1 (``high``; harmonics of the loads' breakpoints)."""

    omega: float
    N: int
    low: NDArray[np.complex128]            # (N/2 + 1, free, free)
    high: NDArray[np.complex128]           # (TAIL_BANDS N, free, free)
    high_n: NDArray[np.int64]


def receptance(shaft: Shaft, omega: float, N: int, tail: bool = True) -> Receptance:
    """The compliances of ``shaft`` at ``omega`` [rad/s] for an N-point grid, computed
    once per speed and grid (``tail``: also the harmonics above N/2)."""
    free = shaft.free
    Kf = shaft.K[np.ix_(free, free)]
    Mf = shaft.M[np.ix_(free, free)]
    Cf = shaft.C[np.ix_(free, free)]

    def invert(n: NDArray[np.int64]) -> NDArray[np.complex128]:
        w = n.astype(float) * omega
        dyn: NDArray[np.complex128] = (Kf[None, :, :] - (w * w)[:, None, None] * Mf[None, :, :]
                                       + 1j * w[:, None, None] * Cf[None, :, :])
        return np.asarray(np.linalg.inv(dyn), dtype=np.complex128)

    low_n = np.arange(N // 2 + 1)
    first = N // 2 + N % 2                    # the first harmonic above the grid's
    high_n = (np.arange(first, first + TAIL_BANDS * N) if tail
              else np.zeros(0, dtype=np.int64))
    return Receptance(omega=float(omega), N=N, low=invert(low_n), high=invert(high_n),
                      high_n=high_n)


def respond(shaft: Shaft, loads: NDArray[np.float64], omega: float,
            breaks: Sequence[ArrayLike] | None = None,
            rec: Receptance | None = None) -> Response:
    """Periodic response of the shaft at ``omega`` [rad/s] to the station load torques
    ``loads`` (stations, N) [N m] sampled on the grid (module docstring). ``breaks``:
    per station the angles [rad] where its load or a derivative jumps (contact onset
    and loss, the lobe's junctions); their jumps are taken out of the samples and
    transformed exactly (``piecewise_fourier``), harmonics above N/2 included, so the
    response does not depend on where the kinks fall between the samples. None: the
    plain discrete Fourier series of the samples. ``rec``: the receptance of this
    speed and grid (computed when None)."""
    n_st, N = loads.shape
    free = shaft.free
    rec = rec if rec is not None and rec.N == N and rec.omega == omega else \
        receptance(shaft, omega, N, tail=breaks is not None)
    H = N // 2 + 1
    Lh = np.zeros((free.size, H), dtype=complex)
    tail = np.zeros((free.size, rec.high_n.size), dtype=complex)
    for r, st in enumerate(free.tolist()):
        if breaks is None or len(np.atleast_1d(breaks[st])) == 0:
            Lh[r] = np.fft.rfft(loads[st]) / N
            continue
        Lh[r], br = coefficients(loads[st], breaks[st])
        if rec.high_n.size:
            tail[r] = kernel_coefficients(br, rec.high_n)
    spec = np.zeros((n_st, H), dtype=complex)
    spec[free] = -np.einsum('nij,jn->in', rec.low, Lh)
    harm = np.arange(H)
    nyq = N % 2 == 0

    def synth(power: int) -> NDArray[np.float64]:
        factor = (1j * harm) ** power
        if nyq and power % 2:
            factor[-1] = 0.0                       # the Nyquist term has no odd derivative
        return np.fft.irfft(spec * factor * N, n=N, axis=1)

    psi, dpsi, d2psi, d3psi = (synth(p) for p in range(4))
    if np.any(tail):
        high = -np.einsum('nij,jn->in', rec.high, tail)       # (free, T)
        for p, arr in enumerate((psi, dpsi, d2psi, d3psi)):
            folded = (2.0 * high * (1j * rec.high_n) ** p).reshape(free.size, -1, N).sum(axis=1)
            folded = np.roll(folded, int(rec.high_n[0]) % N, axis=1)  # column j: n0 + j
            arr[free] += (np.fft.ifft(folded, axis=1) * N).real
    dpsi_dt = dpsi * omega
    s = shaft.sprocket
    if shaft.held:
        drive = shaft.K[s] @ psi + shaft.C[s] @ dpsi_dt + loads[s]
    else:
        drive = -shaft.drive_stiffness * psi[s] - shaft.drive_damping * dpsi_dt[s]
    return Response(spectrum=spec, psi=psi, dpsi=dpsi, d2psi=d2psi, d3psi=d3psi,
                    drive=drive)


def damping_work(shaft: Shaft, response: Response, omega: float,
                 breaks: ArrayLike = ()) -> float:
    """Energy [J] the shaft's and the drive's dampers dissipate over one revolution:
    the integral of psi_dot^T C psi_dot dt on the periodic grid, with ``breaks`` [rad]
    the loads' breakpoints (where psi'' and so the power's slope jump)."""
    v = response.dpsi * omega                          # rad/s
    power = np.einsum('ik,ij,jk->k', v, shaft.C, v)
    return integral(power, breaks) / omega


def harmonic_orders(signal: NDArray[np.float64], orders: int) -> list[float]:
    """Amplitudes of orders 1..``orders`` (per revolution) of a periodic signal sampled
    on the grid (the peak of each cosine, in the signal's unit)."""
    N = signal.size
    c = np.fft.rfft(signal) / N
    amp = 2.0 * np.abs(c[1:orders + 1])
    return [float(a) for a in amp] + [0.0] * max(0, orders - amp.size)
