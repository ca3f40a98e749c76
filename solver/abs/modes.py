"""Air-bearing modes: the slider on its film, linearized about steady flight, as an eigenproblem.

The semi-discrete film of :mod:`solver.kernels.film` at the interior nodes,

    sigma A (H dP/dt + P dH/dt) + R(P, H(q)) = 0,

and the slider's equations of motion (:mod:`solver.abs.integrate`),

    M q'' + C q' + (K - K_s) q = f_air(P, q),

linearized about the steady state (P0, q0) on a smooth disk give the
first-order system y' = A y for y = (dP, dq, dv):

    dP' = -(sigma A H0)^-1 [J_P dP + R_q dq + sigma A P0 H_q dv]
    dq' = dv
    dv' = M^-1 [F_P dP - (K - K_s - F_q) dq - C dv]

with J_P = dR/dP (the exact Jacobian the steady solve uses), R_q = dR/dq
and H_q = dH/dq by forward differences of the face and node spacings, K_s
the surface forces' stiffness at steady flight.  Each complex eigenvalue
lambda = -zeta omega + i omega sqrt(1 - zeta^2) is a mode: frequency
|Im lambda| / 2 pi, damping ratio zeta = -Re lambda / |lambda|.  The
eigenvalues near the imaginary axis are found by shift-invert Arnoldi
(ARPACK through :func:`scipy.sparse.linalg.eigs`) at shifts spread over
the frequency band; small systems (coarse grids) get all their
eigenvalues at once.

The film forces are those of :meth:`solver.abs.film.AbsFilm.forces`, the
node quadrature with the segment profiles of the cut links and the edge
links: F_P = d f_air / dP (:meth:`~solver.abs.film.AbsFilm.force_gradient`)
and F_q = d f_air / dq at fixed P (through the links' spacings, forward
differences).  The modes are those of the time stepper's equations
without its time discretization: what a run tends to as dt -> 0, and the
reference for the numerical damping a step adds (:func:`numerical_damping`) and the frequency it runs a
mode at (:func:`step_frequency_ratio`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from solver.abs.dynamics import mass_matrix, stiffness_damping
from solver.abs.film import AbsFilm
from solver.abs.forces import SurfaceModel
from solver.abs.params import AbsScene
from solver.abs.steady import AbsSteady, element_row, fly_start

#: Largest spacing change [m] of the face's corners by which the spacings are probed for dR/dq and dH/dq.
PROBE = 1.0e-12
#: Systems up to this size are solved for all their eigenvalues (dense QR); larger ones by shift-invert.
DENSE_LIMIT = 3000
#: Arnoldi iterations per shift: far from any mode a shift may not converge in reasonable time (its converged
#: pairs are kept).
ARPACK_ITERATIONS = 2000
#: Eigenvalues closer than this (relative to their modulus) are the same mode found from two shifts.
SAME_MODE = 1.0e-6


@dataclass
class AbsModes:
    """Modes of the slider on its air bearing, sorted by frequency.

    frequency [Hz], damping_ratio [1], shape (n, 3): the spacing amplitudes |z|, |pitch| L, |roll| W of
    each mode, scaled to a largest of 1 (the face's corners move by these); element (n,): the flying
    height's amplitude at the element on the same scale.
    """

    frequency: np.ndarray
    damping_ratio: np.ndarray
    shape: np.ndarray
    element: np.ndarray
    eigenvalues: np.ndarray
    nodes: int


def linear_system(scene: AbsScene, film: AbsFilm, q0: np.ndarray) -> sp.csc_matrix:
    """The matrix A of y' = A y, y = (dP at the interior nodes, dq, dv), about the steady film at q0.

    ``film`` must hold the steady pressure at q0 on a smooth disk (:meth:`AbsFilm.solve_steady`).
    """
    nx, ny = film.shape
    g = film.grid
    film.set_disk(np.zeros(film.shape))
    film.fill_faces(q0)
    R0 = film.residual()[0, 1:-1, 1:-1].copy()
    J = film.sparse_jacobian()
    H0 = np.zeros((1, nx, ny))
    film.fill_nodes(q0, H0)
    n = R0.size
    reach = np.array([1.0, max(g.x[-1] - film.pivot[0], film.pivot[0] - g.x[0]), np.max(np.abs(g.y - film.pivot[1]))])
    Rq, Hq = np.zeros((n, 3)), np.zeros((n, 3))
    Hk = np.zeros((1, nx, ny))
    for k in range(3):
        probe = PROBE / reach[k]
        q = q0.copy()
        q[k] += probe
        film.fill_faces(q)
        Rq[:, k] = (film.residual()[0, 1:-1, 1:-1] - R0).ravel() / probe
        film.fill_nodes(q, Hk)
        Hq[:, k] = (Hk[0, 1:-1, 1:-1] - H0[0, 1:-1, 1:-1]).ravel() / probe
    film.fill_faces(q0)
    film.residual()  # leave the film's scratch as the steady state's
    F_P = film.force_gradient()[:, 1:-1, 1:-1].reshape(3, -1)
    f0 = film.forces()
    F_q = np.zeros((3, 3))  # the film forces' own attitude dependence at fixed P (the links' segment profiles)
    for k in range(3):
        probe = PROBE / reach[k]
        q = q0.copy()
        q[k] += probe
        film.fill_faces(q)
        F_q[:, k] = (film.forces() - f0) / probe
    film.fill_faces(q0)
    A_s = film.area_scaled[1:-1, 1:-1].ravel()
    P0 = film.P[0, 1:-1, 1:-1].ravel()
    store = film.sigma * A_s * H0[0, 1:-1, 1:-1].ravel()
    M = mass_matrix(scene)
    K, C = stiffness_damping(scene)
    surface = SurfaceModel(scene, g)
    K_total = K - surface.forces(film.spacing(q0), np.zeros(film.shape)).dfdq - F_q
    M_inv = np.linalg.inv(M)
    scale = sp.diags(1.0 / store)
    top = sp.hstack([-(scale @ J), sp.csr_matrix(-Rq / store[:, None]),
                     sp.csr_matrix(-(film.sigma * A_s * P0 / store)[:, None] * Hq)])  # fmt: skip
    middle = sp.hstack([sp.csr_matrix((3, n)), sp.csr_matrix((3, 3)), sp.identity(3)])
    bottom = sp.hstack([sp.csr_matrix(M_inv @ F_P), sp.csr_matrix(-M_inv @ K_total), sp.csr_matrix(-M_inv @ C)])
    return sp.vstack([top, middle, bottom]).tocsc()


def air_bearing_modes(
    scene: AbsScene,
    steady: AbsSteady | None = None,
    film: AbsFilm | None = None,
    band: tuple[float, float] = (20.0e3, 1.2e6),
    shifts: int = 7,
    per_shift: int = 6,
    max_damping: float = 0.5,
) -> AbsModes:
    """The modes with frequencies in ``band`` [Hz] and damping ratio below ``max_damping``, about steady flight.

    Steady flight from :func:`fly_start` unless given (its attitude is used, on a smooth disk).  Shift-invert
    at ``shifts`` log-spaced frequencies of the band, ``per_shift`` eigenvalues each.
    """
    if not band[0] > 0.0 or not band[1] > band[0]:
        raise ValueError(f"band = {band}: need 0 < low < high [Hz]")
    film = film if film is not None else AbsFilm(scene)
    steady = steady if steady is not None else fly_start(scene, film)
    q0 = np.asarray(steady.q, dtype=float)
    film.set_disk(np.zeros(film.shape))
    film.solve_steady(q0)
    A = linear_system(scene, film, q0)
    n = A.shape[0] - 6
    found: list[complex] = []
    vectors: list[np.ndarray] = []
    if A.shape[0] <= DENSE_LIMIT:  # every eigenvalue at once: no shift can miss a mode
        lam, V = scipy.linalg.eig(A.toarray())
        found = [complex(value) for value in lam if value.imag > 0.0]
        vectors = [vector[n : n + 3] for value, vector in zip(lam, V.T, strict=True) if value.imag > 0.0]
    for f in np.geomspace(band[0], band[1], shifts) if A.shape[0] > DENSE_LIMIT else ():
        try:
            lam, V = spla.eigs(A, k=per_shift, sigma=2j * math.pi * f, which="LM", maxiter=ARPACK_ITERATIONS)
        except spla.ArpackNoConvergence as err:  # the pairs that did converge are still modes
            lam, V = err.eigenvalues, err.eigenvectors
        for value, vector in zip(lam, V.T, strict=True):
            if value.imag <= 0.0 or any(abs(value - other) <= SAME_MODE * abs(value) for other in found):
                continue
            found.append(complex(value))
            vectors.append(vector[n : n + 3])
    s = scene.slider
    reach = np.array([1.0, s.length, s.width])
    row = np.array([1.0, *element_row(scene)[1:]])  # d(flying height) / dq
    keep = []
    for value, q in zip(found, vectors, strict=True):
        frequency, zeta = abs(value.imag) / (2.0 * math.pi), -value.real / abs(value)
        if band[0] <= frequency <= band[1] and zeta < max_damping:
            amplitude = np.abs(q * reach)
            top = float(np.max(amplitude)) or 1.0
            keep.append((frequency, zeta, amplitude / top, abs(complex(row @ q)) / top, value))
    keep.sort(key=lambda m: m[0])
    return AbsModes(
        frequency=np.array([m[0] for m in keep]),
        damping_ratio=np.array([m[1] for m in keep]),
        shape=np.array([m[2] for m in keep]).reshape(-1, 3),
        element=np.array([m[3] for m in keep]),
        eigenvalues=np.array([m[4] for m in keep], dtype=complex),
        nodes=n,
    )


def step_root(omega_dt: float, rho_infinity: float) -> complex:
    """The principal root r e^(i theta) of the generalized-alpha step's amplification matrix on x'' + omega^2 x = 0.

    A free oscillation of the step is x_n ~ r^n cos(n theta): it decays by r and turns by theta per step,
    where the exact solution turns by omega dt and does not decay.
    """
    am, af = (2.0 * rho_infinity - 1.0) / (rho_infinity + 1.0), rho_infinity / (rho_infinity + 1.0)
    gamma, beta = 0.5 - am + af, 0.25 * (1.0 - am + af) ** 2
    w2 = omega_dt * omega_dt
    step = np.zeros((3, 3))
    for j, (q0, v0, a0) in enumerate(np.eye(3)):
        a1 = -(am * a0 + w2 * ((1.0 - af) * (q0 + v0 + (0.5 - beta) * a0) + af * q0)) / (
            (1.0 - am) + w2 * (1.0 - af) * beta
        )
        q1 = q0 + v0 + (0.5 - beta) * a0 + beta * a1
        step[:, j] = (q1, v0 + (1.0 - gamma) * a0 + gamma * a1, a1)
    roots = np.linalg.eigvals(step)
    return complex(roots[np.argmax(np.abs(roots.imag))])


def numerical_damping(omega_dt: float, rho_infinity: float) -> float:
    """Damping ratio the generalized-alpha step adds to an undamped oscillator at omega dt (its amplification matrix).

    The spectral radius r and phase theta of the principal root per step give zeta_num = -ln r / theta.
    """
    principal = step_root(omega_dt, rho_infinity)
    return float(-math.log(abs(principal)) / abs(math.atan2(principal.imag, principal.real)))


def step_frequency_ratio(omega_dt: float, rho_infinity: float) -> float:
    """Frequency of the step's free oscillation over the oscillator's own: theta / (omega dt), below 1.

    The step runs a mode slow (its period error): a run's spectral peak sits at this fraction of the mode's
    frequency.  For rho_infinity = 1 (the trapezoidal rule) it is 2 atan(omega dt / 2) / (omega dt); for
    every rho_infinity 1 - ratio grows as (omega dt)^2 (by c (omega dt)^2 / 12 with c = 1 at rho_infinity 1,
    1.01 at 0.9, 1.5 at 0.5, 5.5 at 0).
    """
    principal = step_root(omega_dt, rho_infinity)
    return float(abs(math.atan2(principal.imag, principal.real)) / omega_dt)
