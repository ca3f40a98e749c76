"""Reynolds film: flux kernel, Jacobian, line solves, steady and time-dependent solutions.

Cheapest first: kernel identities against independent formulas, then the
1-D inclined slider against published loads and the incompressible and
high-bearing-number limits, then the 2-D scene-1 film (symmetry, static
stability, squeeze damping, observed order of the film time step).

Tolerances are stated in units of a known error: machine epsilon (EPS),
the published rounding (half a unit of the last printed digit), or the
discretisation error estimated from the grids themselves (Richardson).
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from conftest import EPS, SCENE1_ATTITUDE, inclined_slider_arrays, small_scene

from solver.grid import control_volume_widths
from solver.kernels import reynolds as kr
from solver.rails.film import make_film, steady_newton
from solver.rails.params import Numerics
from solver.slip import POLYNOMIAL_SLIP_LAWS, SLIP_LAWS

COEFFICIENTS = {name: SLIP_LAWS[name].coefficients for name in POLYNOMIAL_SLIP_LAWS}

# ---------------------------------------------------------------------------- helpers


def empty_outputs(shape):
    return tuple(np.zeros(shape) for _ in range(7))


def assemble(P, H, Hx, Hy, x, y, lam, kn, c1, c2, y_flux, outputs=None):
    """Run the kernel on nodes x, y and return (R, Jcx, Jxm, Jxp, Jcy, Jym, Jyp)."""
    out = empty_outputs(P.shape) if outputs is None else outputs
    kr.assemble(
        P, H, Hx, Hy, np.diff(x), np.diff(y), control_volume_widths(x), control_volume_widths(y),
        lam, kn, c1, c2, *out, y_flux,
    )  # fmt: skip
    return out


def random_film(rng, nr=2, nx=9, ny=7):
    """Random positive pressure and spacing on non-uniform grids (scaled units)."""
    x = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, nx - 2)]))
    y = np.sort(np.concatenate([[0.0, 0.3], rng.uniform(0.0, 0.3, ny - 2)]))
    P = rng.uniform(0.5, 5.0, (nr, nx, ny))
    H = rng.uniform(0.5, 3.0, (nr, nx, ny))
    Hx = rng.uniform(0.5, 3.0, (nr, nx - 1, ny))
    Hy = rng.uniform(0.5, 3.0, (nr, nx, ny - 1))
    return x, y, P, H, Hx, Hy


def diffusivity(P, H, kn, c1, c2):
    return H**3 * P + c1 * kn * H**2 + c2 * kn**2 * H / P


def reference_fluxes(P, Hx, Hy, x, y, lam, kn, c1, c2):
    """Face fluxes written independently of the kernel.

    x-faces: Scharfetter-Gummel flux in its exponential form
    F = a (P_L - P_R e^-Pe) / (1 - e^-Pe), a = Lambda H_f, Pe = a dx / D_f
    (algebraically g (P_L - P_R) + a P_L with g = D_f B(Pe) / dx);
    y-faces: G = -D_f (P_R - P_L) / dy.  D_f at the mean face pressure.
    """
    dx = np.diff(x)[None, :, None]
    dy = np.diff(y)[None, None, :]
    left, right = P[:, :-1, :], P[:, 1:, :]
    D = diffusivity(0.5 * (left + right), Hx, kn, c1, c2)
    a = lam * Hx
    pe = a * dx / D
    with np.errstate(divide="ignore", invalid="ignore"):
        F = np.where(pe > 0.0, a * (left - right * np.exp(-pe)) / -np.expm1(-pe), D * (left - right) / dx)
    low, high = P[:, :, :-1], P[:, :, 1:]
    G = -diffusivity(0.5 * (low + high), Hy, kn, c1, c2) * (high - low) / dy
    return F, G


def reference_residual(P, Hx, Hy, x, y, lam, kn, c1, c2, y_flux):
    """R_ij = (F_i+1/2 - F_i-1/2) dy_j + (G_j+1/2 - G_j-1/2) dx_i at interior nodes, and a magnitude scale."""
    F, G = reference_fluxes(P, Hx, Hy, x, y, lam, kn, c1, c2)
    wx = ((x[2:] - x[:-2]) / 2)[None, :, None]
    wy = ((y[2:] - y[:-2]) / 2)[None, None, :]
    R = np.zeros_like(P)
    scale = np.zeros_like(P)
    R[:, 1:-1, 1:-1] = (F[:, 1:, 1:-1] - F[:, :-1, 1:-1]) * wy
    scale[:, 1:-1, 1:-1] = (np.abs(F[:, 1:, 1:-1]) + np.abs(F[:, :-1, 1:-1])) * wy
    if y_flux:
        R[:, 1:-1, 1:-1] += (G[:, 1:-1, 1:] - G[:, 1:-1, :-1]) * wx
        scale[:, 1:-1, 1:-1] += (np.abs(G[:, 1:-1, 1:]) + np.abs(G[:, 1:-1, :-1])) * wx
    return R, scale


def dense_jacobian(J, shape):
    """Dense matrix of the split Jacobian (rows at interior nodes, columns at every node)."""
    Jcx, Jxm, Jxp, Jcy, Jym, Jyp = J
    nr, nx, ny = shape
    index = np.arange(nr * nx * ny).reshape(shape)
    A = np.zeros((index.size, index.size))
    for r in range(nr):
        for i in range(1, nx - 1):
            for j in range(1, ny - 1):
                row = index[r, i, j]
                A[row, row] = Jcx[r, i, j] + Jcy[r, i, j]
                A[row, index[r, i - 1, j]] += Jxm[r, i, j]
                A[row, index[r, i + 1, j]] += Jxp[r, i, j]
                A[row, index[r, i, j - 1]] += Jym[r, i, j]
                A[row, index[r, i, j + 1]] += Jyp[r, i, j]
    return A


def interior_line_matrix(diag, Jc, Jm, Jp, weight, axis):
    """Sparse diag + weight * J_line restricted to interior nodes (Dirichlet neighbours dropped)."""
    nr, nx, ny = diag.shape
    inner = (nr, nx - 2, ny - 2)
    index = np.arange(np.prod(inner)).reshape(inner)
    rows, cols, vals = [], [], []
    for r in range(nr):
        for i in range(nx - 2):
            for j in range(ny - 2):
                k = index[r, i, j]
                rows.append(k)
                cols.append(k)
                vals.append(diag[r, i + 1, j + 1] + weight * Jc[r, i + 1, j + 1])
                pos = i if axis == 0 else j
                size = nx - 2 if axis == 0 else ny - 2
                if pos > 0:
                    rows.append(k)
                    cols.append(index[r, i - 1, j] if axis == 0 else index[r, i, j - 1])
                    vals.append(weight * Jm[r, i + 1, j + 1])
                if pos < size - 1:
                    rows.append(k)
                    cols.append(index[r, i + 1, j] if axis == 0 else index[r, i, j + 1])
                    vals.append(weight * Jp[r, i + 1, j + 1])
    n = index.size
    return sp.csc_matrix((vals, (rows, cols)), shape=(n, n))


def inclined_slider_load(n, lam, kn, K=2.0, c1=6.0, c2=0.0, tol=1e-13):
    """Load per unit width / (p_a L) of the 1-D inclined slider on n uniform nodes; also X and P."""
    x = np.linspace(0.0, 1.0, n)
    H, Hx, Hy, dx, dy, dxc, dyc = inclined_slider_arrays(x, K)
    P, _ = steady_newton(H, Hx, Hy, dx, dy, dxc, dyc, lam, kn, c1, c2, tol, y_flux=False)
    return float(np.sum((P[0, :, 1] - 1.0) * dxc)), x, P[0, :, 1]


def richardson(values, order, ratio=2.0):
    """Observed order, extrapolated value and its uncertainty from three grids refined by ``ratio``.

    The extrapolation uses the scheme's theoretical ``order`` on the two
    finest grids; its uncertainty is the change from extrapolating the two
    coarsest instead (the size of the neglected higher-order terms).
    """
    w1, w2, w3 = values
    observed = np.log(abs((w2 - w1) / (w3 - w2))) / np.log(ratio)
    factor = ratio**order - 1.0
    finer = w3 + (w3 - w2) / factor
    coarser = w2 + (w2 - w1) / factor
    return observed, finer, abs(finer - coarser)


# ---------------------------------------------------------------------------- Bernoulli function


def bernoulli_reference(x):
    """B(x) = x / (e^x - 1) and B'(x) in high precision (enough digits to survive the cancellation)."""
    digits = 50 + int(max(0.0, -np.log10(x))) if x > 0 else 50
    with mpmath.workdps(2 * digits):
        if x == 0.0:
            return mpmath.mpf(1), mpmath.mpf(-0.5)
        xm = mpmath.mpf(x)
        em1 = mpmath.expm1(xm)
        return xm / em1, (em1 - xm * mpmath.exp(xm)) / em1**2


BERNOULLI_POINTS = [0.0, 1e-300, 1e-12, 1e-6, 0.1, 0.5, 0.9, 1.0 - 1e-15, 1.0, 1.0 + 1e-15, 1.5, 2.0, 10.0, 36.7]
BERNOULLI_POINTS += [37.0, 100.0, 500.0, 699.9, 700.0]


@pytest.mark.jitless
@pytest.mark.parametrize("x", BERNOULLI_POINTS)
def test_bernoulli_function_to_a_few_ulp(x):
    # the series (x < 1) and the exponential form (x >= 1) each round to ~2 ulp
    b, db = kr.bernoulli(x)
    ref_b, ref_db = bernoulli_reference(x)
    assert abs(b - float(ref_b)) <= 4 * EPS * float(ref_b)
    assert abs(db - float(ref_db)) <= 4 * EPS * abs(float(ref_db))


@pytest.mark.jitless
def test_bernoulli_agrees_with_expm1_form_across_the_series_switch():
    xs = np.concatenate([np.linspace(1e-3, 3.0, 301), np.geomspace(3.0, 690.0, 50)])
    for x in xs:
        b, db = kr.bernoulli(float(x))
        em1 = np.expm1(x)
        exact_b = x / em1
        # B' = B (1/x - 1 - 1/(e^x - 1)); the bracket cancels to ~1/2 from terms ~1/x: error ~EPS/x
        exact_db = exact_b * (1.0 / x - 1.0 - 1.0 / em1)
        assert abs(b - exact_b) <= 4 * EPS * exact_b
        assert abs(db - exact_db) <= (4 * EPS + 4 * EPS / x) * abs(exact_db)


@pytest.mark.jitless
def test_bernoulli_underflow_region():
    # above x = 700 the kernel returns 0: the true value is below B(700) = 7e-302
    for x in (700.1, 745.0, 1e4):
        b, db = kr.bernoulli(x)
        assert 0.0 <= b <= 7e-302 and abs(db) <= 7e-302


# ---------------------------------------------------------------------------- residual, conservation


@pytest.mark.jitless
@pytest.mark.parametrize("slip", sorted(POLYNOMIAL_SLIP_LAWS))
@pytest.mark.parametrize("y_flux", [True, False])
def test_residual_matches_independent_flux_formula(slip, y_flux):
    rng = np.random.default_rng(1)
    x, y, P, H, Hx, Hy = random_film(rng)
    c1, c2 = SLIP_LAWS[slip].coefficients
    # Lambda = 300 puts the cell Peclet numbers in [0.1, 500]: both branches of B(x)
    lam, kn = 300.0, 0.3
    R = assemble(P, H, Hx, Hy, x, y, lam, kn, c1, c2, y_flux)[0]
    R_ref, scale = reference_residual(P, Hx, Hy, x, y, lam, kn, c1, c2, y_flux)
    assert np.all(np.abs(R - R_ref) <= 32 * EPS * scale)


@pytest.mark.jitless
@pytest.mark.parametrize("slip", sorted(POLYNOMIAL_SLIP_LAWS))
def test_uniform_pressure_fluxes_telescope_to_the_boundary(slip):
    # with P = 1 only convection carries mass: the interior residuals must
    # sum to Lambda * (H at the outlet face - H at the inlet face) per column
    rng = np.random.default_rng(2)
    x, y, _, H, Hx, Hy = random_film(rng)
    P = np.ones_like(H)
    lam = 40.0
    R = assemble(P, H, Hx, Hy, x, y, lam, 0.2, *SLIP_LAWS[slip].coefficients, True)[0]
    wy = control_volume_widths(y)[1:-1]
    expected = lam * np.sum((Hx[:, -1, 1:-1] - Hx[:, 0, 1:-1]) * wy, axis=1)
    total = R[:, 1:-1, 1:-1].sum(axis=(1, 2))
    magnitude = lam * np.sum(np.abs(Hx[:, :, 1:-1]) * wy, axis=(1, 2))
    np.testing.assert_allclose(total, expected, rtol=0, atol=64 * EPS * magnitude.max())


@pytest.mark.jitless
def test_random_pressure_fluxes_telescope_to_the_boundary():
    # exact conservation: interior faces cancel pairwise, only boundary-face fluxes remain
    rng = np.random.default_rng(3)
    x, y, P, H, Hx, Hy = random_film(rng)
    lam, kn, (c1, c2) = 80.0, 0.1, SLIP_LAWS["second_order"].coefficients
    R = assemble(P, H, Hx, Hy, x, y, lam, kn, c1, c2, True)[0]
    F, G = reference_fluxes(P, Hx, Hy, x, y, lam, kn, c1, c2)
    wx, wy = control_volume_widths(x)[1:-1], control_volume_widths(y)[1:-1]
    boundary = np.sum((F[:, -1, 1:-1] - F[:, 0, 1:-1]) * wy, axis=1)
    boundary += np.sum((G[:, 1:-1, -1] - G[:, 1:-1, 0]) * wx, axis=1)
    _, scale = reference_residual(P, Hx, Hy, x, y, lam, kn, c1, c2, True)
    np.testing.assert_allclose(R[:, 1:-1, 1:-1].sum(axis=(1, 2)), boundary, rtol=0, atol=64 * EPS * scale.sum())


@pytest.mark.jitless
def test_assemble_overwrites_interior_and_never_touches_dirichlet_nodes():
    # the time stepper relies on this (no per-step zeroing)
    rng = np.random.default_rng(4)
    x, y, P, H, Hx, Hy = random_film(rng)
    clean = assemble(P, H, Hx, Hy, x, y, 50.0, 0.1, 6.0, 0.0, True)
    dirty = tuple(np.full(P.shape, 7.0) for _ in range(7))
    assemble(P, H, Hx, Hy, x, y, 50.0, 0.1, 6.0, 0.0, True, outputs=dirty)
    boundary = np.ones(P.shape, dtype=bool)
    boundary[:, 1:-1, 1:-1] = False
    for a, b in zip(clean, dirty, strict=True):
        np.testing.assert_array_equal(a[~boundary], b[~boundary])
        assert np.all(b[boundary] == 7.0) and np.all(a[boundary] == 0.0)


# ---------------------------------------------------------------------------- Jacobian


@pytest.mark.jitless
@pytest.mark.parametrize("slip", sorted(POLYNOMIAL_SLIP_LAWS))
@pytest.mark.parametrize("y_flux", [True, False])
def test_jacobian_matches_central_differences(slip, y_flux):
    rng = np.random.default_rng(5)
    x, y, P, H, Hx, Hy = random_film(rng, nr=1, nx=8, ny=6)
    c1, c2 = SLIP_LAWS[slip].coefficients
    lam, kn = 300.0, 0.3
    out = assemble(P, H, Hx, Hy, x, y, lam, kn, c1, c2, y_flux)
    A = dense_jacobian(out[1:], P.shape)
    _, scale = reference_residual(P, Hx, Hy, x, y, lam, kn, c1, c2, y_flux)
    step = 1e-5
    fd = np.zeros_like(A)
    for k in range(P.size):
        plus, minus = P.copy(), P.copy()
        h = step * P.flat[k]
        plus.flat[k] += h
        minus.flat[k] -= h
        r_plus = assemble(plus, H, Hx, Hy, x, y, lam, kn, c1, c2, y_flux)[0]
        r_minus = assemble(minus, H, Hx, Hy, x, y, lam, kn, c1, c2, y_flux)[0]
        fd[:, k] = (r_plus - r_minus).ravel() / (2 * h)
    # central differences: truncation ~ step^2 = 1e-10, round-off ~ EPS/step = 2e-11
    # (relative to the row's flux scale / P); allow 10x their sum
    row_scale = (scale / P.min()).ravel()[:, None]
    interior = (scale > 0).ravel()
    err = np.abs(A - fd)[interior] / row_scale[interior]
    assert err.max() <= 10 * (step**2 + EPS / step)


# ---------------------------------------------------------------------------- approximate factorisation


def film_step_system(rng, with_y):
    x, y, P, H, Hx, Hy = random_film(rng, nr=2, nx=10, ny=8)
    out = assemble(P, H, Hx, Hy, x, y, 120.0, 0.2, 6.0, 0.0, True)
    _, Jcx, Jxm, Jxp, Jcy, Jym, Jyp = out
    if not with_y:
        Jcy, Jym, Jyp = np.zeros_like(Jcy), np.zeros_like(Jym), np.zeros_like(Jyp)
    # the film step's diagonal sigma/dt A H' at the source's 0.1 us step
    area = np.outer(control_volume_widths(x), control_volume_widths(y))
    diag = 14.0 * area[None] * H
    rhs = np.zeros_like(P)
    rhs[:, 1:-1, 1:-1] = rng.standard_normal((2, 8, 6))
    return diag, (Jcx, Jxm, Jxp, Jcy, Jym, Jyp), rhs


def af_solve(diag, J, rhs, weight):
    delta, work = np.empty_like(rhs), np.empty_like(rhs)
    kr.af_solve(diag, *J, rhs, weight, delta, work)
    return delta


@pytest.mark.jitless
def test_af_solve_is_exact_without_y_coupling():
    rng = np.random.default_rng(6)
    diag, J, rhs = film_step_system(rng, with_y=False)
    delta = af_solve(diag, J, rhs, 0.5)
    Ax = interior_line_matrix(diag, J[0], J[1], J[2], 0.5, axis=0)
    exact = spla.spsolve(Ax, rhs[:, 1:-1, 1:-1].ravel())
    cond = np.linalg.cond(Ax.toarray())
    np.testing.assert_allclose(delta[:, 1:-1, 1:-1].ravel(), exact, rtol=0, atol=16 * cond * EPS * np.abs(exact).max())
    boundary = np.ones(rhs.shape, dtype=bool)
    boundary[:, 1:-1, 1:-1] = False
    assert np.all(delta[boundary] == 0.0)


@pytest.mark.jitless
def test_af_solve_inverts_the_factorised_product():
    rng = np.random.default_rng(7)
    diag, J, rhs = film_step_system(rng, with_y=True)
    delta = af_solve(diag, J, rhs, 0.5)
    Ax = interior_line_matrix(diag, J[0], J[1], J[2], 0.5, axis=0)
    Ay = interior_line_matrix(diag, J[3], J[4], J[5], 0.5, axis=1)
    Dinv = sp.diags(1.0 / diag[:, 1:-1, 1:-1].ravel())
    product = (Ax @ Dinv @ Ay).tocsc()
    exact = spla.spsolve(product, rhs[:, 1:-1, 1:-1].ravel())
    cond = np.linalg.cond(product.toarray())
    np.testing.assert_allclose(delta[:, 1:-1, 1:-1].ravel(), exact, rtol=0, atol=16 * cond * EPS * np.abs(exact).max())


# ---------------------------------------------------------------------------- 1-D inclined slider

# Published dimensionless loads W / (p_a L b) of the K = 2 inclined slider
# with first-order slip (Kn = lambda / h_min), printed to 6 decimals.
PUBLISHED_LOADS = [
    (0.0, 1.0, 0.026382),
    (0.0, 10.0, 0.210029),
    (0.0, 100.0, 0.370741),
    (0.1, 1.0, 0.018735),
    (0.1, 10.0, 0.167147),
    (0.1, 100.0, 0.364387),
]
PUBLISHED_ROUNDING = 0.5e-6


@pytest.mark.jitless
@pytest.mark.parametrize(("kn", "lam", "published"), PUBLISHED_LOADS)
def test_inclined_slider_matches_published_loads(kn, lam, published):
    loads = [inclined_slider_load(n, lam, kn)[0] for n in (101, 201, 401)]
    order, extrapolated, uncertainty = richardson(loads, 2)
    # the scheme is second order; pre-asymptotic drift of the observed order stays within 0.1
    assert abs(order - 2.0) < 0.1
    assert abs(extrapolated - published) <= PUBLISHED_ROUNDING + uncertainty


@pytest.mark.jitless
def test_slip_laws_order_the_load():
    # slip adds Poiseuille flow (D grows with c1 Kn and c2 Kn^2), so the film carries less load
    loads = {slip: inclined_slider_load(101, 10.0, 0.1, c1=c1, c2=c2)[0] for slip, (c1, c2) in COEFFICIENTS.items()}
    assert loads["continuum"] > loads["first_order"] > loads["second_order"] > 0.0


def incompressible_pressure(x, K):
    """6 (P - 1) / Lambda of the inclined slider as Lambda -> 0 (classical incompressible solution)."""
    H = K - (K - 1.0) * x
    return 6.0 / (K - 1.0) * (1.0 / H - K / ((K + 1.0) * H**2) - 1.0 / (K + 1.0))


@pytest.mark.jitless
@pytest.mark.parametrize("K", [2.0, 3.0])
def test_incompressible_limit_load(K):
    exact = 6.0 * (np.log(K) / (K - 1.0) ** 2 - 2.0 / (K**2 - 1.0))
    lam = 1e-4

    def scaled_load(lam):
        loads = [6.0 / lam * inclined_slider_load(n, lam, 0.0, K=K)[0] for n in (121, 241, 481)]
        return richardson(loads, 2)

    order, w_star, uncertainty = scaled_load(lam)
    assert abs(order - 2.0) < 0.1
    # compressibility correction is O(Lambda): measure it from a 10x larger Lambda
    compressibility = abs(scaled_load(10 * lam)[1] - w_star) / 9.0
    assert abs(w_star - exact) <= 2.0 * (uncertainty + compressibility) + 16 * EPS
    if K == 2.0:
        assert abs(w_star - 0.158883) <= PUBLISHED_ROUNDING


@pytest.mark.jitless
def test_incompressible_limit_pressure_profile():
    # max-norm error of the nodal profile falls at second order; the peak 0.25 sits at H = 4/3 (X = 2/3)
    K = 2.0

    def profiles(lam):
        errors, peaks = [], []
        for n in (61, 121, 241):
            _, x, P = inclined_slider_load(n, lam, 0.0, K=K)
            profile = 6.0 * (P - 1.0) / lam
            errors.append(np.abs(profile - incompressible_pressure(x, K)).max())
            peak = int(np.argmax(profile))
            assert abs(x[peak] - 2.0 / 3.0) < 1e-12
            peaks.append(profile[peak])
        return np.array(errors), richardson(peaks, 2)

    lam = 1e-4
    errors, (_, peak, uncertainty) = profiles(lam)
    orders = np.log2(errors[:-1] / errors[1:])
    assert np.all(np.abs(orders - 2.0) < 0.1)
    compressibility = abs(profiles(10 * lam)[1][1] - peak) / 9.0
    assert abs(peak - 0.25) <= 2.0 * (uncertainty + compressibility) + 16 * EPS


@pytest.mark.jitless
def test_high_bearing_number_limit():
    # Lambda -> inf: P H = K except in an outlet layer of width ~1/Lambda, load -> K ln K / (K - 1) - 1.
    # At Lambda = 1e6 the layer is far thinner than any cell, so the error is the
    # unresolved layer's share of the last control volume: first order in dx.
    K = 2.0
    limit = K * np.log(K) / (K - 1.0) - 1.0
    assert abs(limit - 0.386294) <= PUBLISHED_ROUNDING
    loads = [inclined_slider_load(n, 1e6, 0.0, K=K)[0] for n in (201, 401, 801)]
    order, extrapolated, uncertainty = richardson(loads, 1)
    assert abs(order - 1.0) < 0.1
    assert abs(extrapolated - limit) <= uncertainty + 1e-6 * limit  # O(1/Lambda) remainder
    # Cell Peclet numbers >= 1e3 make the exponentially fitted flux pure upwind, Lambda H_f P_L:
    # constant mass flux gives P_i H_(i+1/2) = H_(1/2) exactly (the discrete form of P H = K)
    _, x, P = inclined_slider_load(201, 1e6, 0.0, K=K)
    faces = K - (K - 1.0) * 0.5 * (x[1:] + x[:-1])
    np.testing.assert_allclose(P[:-1] * faces, faces[0], rtol=1e-12)


# ---------------------------------------------------------------------------- 2-D scene-1 film


@pytest.fixture(scope="module")
def film1(scene1):
    film = make_film(scene1)
    film.solve_steady(SCENE1_ATTITUDE)
    return film


@pytest.mark.jitless
def test_symmetric_slider_has_no_roll_moment(film1, scene1):
    load, _, roll_moment = film1.generalized_forces()
    assert load > 0.0
    # both rails carry the same load to the steady tolerance: their roll moments cancel to that much
    assert abs(roll_moment) <= force_noise(scene1) * scene1.slider.width / 2 + 64 * EPS * load * scene1.slider.width
    # the rails mirror each other across x2 = 0 to the steady solver's tolerance
    mirror = np.abs(film1.P[0, :, ::-1] - film1.P[1]).max()
    assert mirror <= scene1.numerics.steady_tol


def force_noise(scene):
    """Film force uncertainty [N] of a steady solve: P converged to steady_tol p0 over both rails."""
    s = scene.slider
    return scene.numerics.steady_tol * scene.air.ambient_pressure * 2.0 * s.rail_width * s.length


@pytest.mark.jitless
def test_roll_moment_is_odd_in_roll(scene1):
    film = make_film(scene1)
    roll = 2e-6
    forces = []
    for sign in (1.0, -1.0):
        film.solve_steady(SCENE1_ATTITUDE + np.array([0.0, 0.0, sign * roll]))
        forces.append(film.generalized_forces())
    up, down = forces
    tol = 2.0 * force_noise(scene1)
    assert abs(up[0] - down[0]) <= tol
    assert abs(up[1] - down[1]) <= tol * scene1.slider.length
    assert abs(up[2] + down[2]) <= tol * scene1.slider.width / 2
    # rolling the x2 < 0 side up unloads it: the film pushes roll back (negative moment)
    assert up[2] < 0.0


@pytest.mark.jitless
def test_scene1_film_converges_at_second_order():
    # refine the clustered grid by 2 in every direction (the tanh maps are smooth, the
    # juncture stays on a node): load and pitch moment follow the scheme's order 2
    forces = []
    for level in range(3):
        k = 2**level
        numerics = Numerics(nx=60 * k + 1, nx_taper=10 * k + 1, ny=8 * k + 1)
        film = make_film(small_scene(numerics=numerics))
        film.solve_steady(SCENE1_ATTITUDE)
        forces.append(film.generalized_forces()[:2])
    forces = np.array(forces)
    for column in forces.T:
        order, _, _ = richardson(column, 2)
        assert abs(order - 2.0) < 0.1, order


STIFFNESS_STEPS = np.array([1e-10, 1e-8, 1e-8])  # 0.1 % of z and of the pitch [m, rad, rad]


def stiffness_matrix(film, q0):
    """K = -d(film generalized forces)/dq at q0 by central differences (warm-started steady solves)."""
    P = film.solve_steady(q0).copy()
    K = np.empty((3, 3))
    for k, step in enumerate(STIFFNESS_STEPS):
        dq = np.zeros(3)
        dq[k] = step
        film.solve_steady(q0 + dq, P)
        plus = film.generalized_forces()
        film.solve_steady(q0 - dq, P)
        minus = film.generalized_forces()
        K[:, k] = -(plus - minus) / (2 * step)
    film.solve_steady(q0, P)
    return K


@pytest.mark.jitless
def test_steady_flight_is_statically_stable(scene1):
    film = make_film(scene1)
    K = stiffness_matrix(film, SCENE1_ATTITUDE)
    # heave: pushing the slider down raises the film force; roll: restoring
    assert K[0, 0] > 0.0
    assert K[2, 2] > 0.0
    # Pitch about the gimbal is coupled to heave.  With the heave in equilibrium (z follows,
    # as it does on the much faster heave mode) the pitch stiffness is K11 - K10 K01 / K00.
    # (At fixed z, d(pitch moment)/d pitch alone is not restoring on this slider: the gimbal
    # sits 0.38 mm from the trailing edge, so pitching up mostly squeezes the film behind it.)
    assert K[1, 1] - K[1, 0] * K[0, 1] / K[0, 0] > 0.0
    assert np.all(np.linalg.eigvals(K).real > 0.0)
    # symmetric slider at zero roll: roll decouples from heave and pitch, up to the
    # finite-difference noise of the steady solves (force_noise / step)
    noise = force_noise(scene1) / STIFFNESS_STEPS
    half_width = scene1.slider.width / 2
    assert abs(K[2, 0]) <= noise[0] * half_width and abs(K[2, 1]) <= noise[1] * half_width
    assert abs(K[0, 2]) <= noise[2] and abs(K[1, 2]) <= noise[2] * scene1.slider.length


@pytest.mark.jitless
@pytest.mark.parametrize("direction", [-1.0, 1.0])
def test_squeeze_film_resists_motion(scene1, direction):
    # a film squeezed by an approaching slider carries more than the steady film at the
    # same attitude (and less when the slider withdraws): the squeeze term damps heave
    film = make_film(scene1)
    P0 = film.solve_steady(SCENE1_ATTITUDE).copy()
    dt, n, speed = 0.1e-6, 10, 1e-3  # 1 mm/s for 1 us: 1 nm, ~1 % of the spacing
    q = SCENE1_ATTITUDE.copy()
    for _ in range(n):
        q_new = q + np.array([direction * speed * dt, 0.0, 0.0])
        film.step(q, q_new, dt)
        q = q_new
    moving = film.generalized_forces()[0]
    steady = make_film(scene1)
    steady.solve_steady(q, P0)
    assert direction * (moving - steady.generalized_forces()[0]) < 0.0


@pytest.mark.jitless
def test_steady_pressure_is_a_fixed_point_of_the_film_step(film1, scene1):
    # R(P_steady) ~ 0, so a step at fixed attitude changes P by less than the steady tolerance
    P = film1.P.copy()
    film1.step(SCENE1_ATTITUDE, SCENE1_ATTITUDE, scene1.numerics.dt)
    change = np.abs(film1.P - P).max()
    film1.P = P
    assert change <= scene1.numerics.steady_tol


def test_film_time_step_is_second_order(scene1):
    # attitude on a smooth prescribed path from a steady start; forces at T against a 4x finer step
    film = make_film(scene1)
    P0 = film.solve_steady(SCENE1_ATTITUDE).copy()
    omega, T = 2 * np.pi * 20e3, 20e-6

    def path(t):
        phase = omega * t
        return SCENE1_ATTITUDE + np.array(
            [10e-9 * np.sin(phase), 2e-6 * np.sin(1.3 * phase), 3e-6 * np.sin(0.7 * phase)]
        )

    def forces_at_T(dt):
        film.P = P0.copy()
        n = int(round(T / dt))
        for k in range(n):
            film.step(path(k * dt), path((k + 1) * dt), dt)
        return film.generalized_forces()

    dts = np.array([0.4e-6, 0.2e-6, 0.1e-6, 0.05e-6, 0.025e-6])
    forces = np.array([forces_at_T(dt) for dt in dts])
    # observed order from successive differences (no reference solution needed)
    differences = np.abs(np.diff(forces, axis=0))
    orders = np.log2(differences[:-1] / differences[1:])
    assert np.all(np.abs(orders - 2.0) < 0.1), orders
