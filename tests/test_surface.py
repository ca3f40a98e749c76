"""Rough-surface contact, adhesion and elastic half-space contact (scene 2).

References are independent of the implementation: scipy's quad with an
algebraic-singularity weight for the Greenwood-Williamson integrals, quad
in the height z (the code integrates in the gap h) for the adhesion, and
the half-space solutions of Johnson, Contact Mechanics, 3.4 and 4.2.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import ellipe, gamma
from scipy.stats import norm

from solver.elastic import (
    ElasticContactError,
    influence_coefficients,
    influence_matrix,
    pressure_sensitivity,
    solve_contact,
)
from solver.kernels import surface as kernels
from solver.surface import (
    adhesion_coefficient,
    composite_modulus,
    gw_coefficient,
    gw_integrals,
    lj_pressure,
    surface_pressures,
)

#: Fast enough to run a second time with the JIT off (HDI_DISABLE_JIT=1, .ci/run).
pytestmark = pytest.mark.jitless

#: Intermolecular equilibrium spacing [m].
EPS_LJ = 0.3e-9
#: Representative composite modulus [Pa]: AlTiC slider (400 GPa, 0.22) on a disk (150 GPa, 0.3).
E_COMPOSITE = composite_modulus(400e9, 0.22, 150e9, 0.3)
#: Representative summits: 1e14 per m^2 of radius 1 um (not from the source).
GW_COEF = gw_coefficient(1e14, 1e-6, E_COMPOSITE)
DGAMMA = 0.008
ADH_COEF = adhesion_coefficient(DGAMMA, EPS_LJ)


def reference_gw(t: float, n: float) -> float:
    """F_n(t) by QAWS (weight (s - t)^n at the left end), truncated where phi < 1e-300."""
    upper = max(t, 0.0) + 38.0
    return quad(norm.pdf, t, upper, weight="alg", wvar=(n, 0.0), epsabs=0.0, epsrel=1e-13, limit=200)[0]


def reference_adhesion(d: float, sigma: float, integrand=lj_pressure) -> float:
    """p_a = int_-inf^(d - eps) p_LJ(d - z) phi_sigma(z) dz by quad in z."""
    top = d - EPS_LJ
    bottom = -12.0 * sigma
    if top <= bottom:
        return 0.0

    def f(z: float) -> float:
        return float(integrand(d - z, DGAMMA, EPS_LJ)) * norm.pdf(z, scale=sigma)

    points = sorted({x for x in (0.0, top - 0.2 * EPS_LJ, top - EPS_LJ) if bottom < x < top})
    return quad(f, bottom, top, points=points or None, epsabs=0.0, epsrel=1e-10, limit=500)[0]


def lj_slope(h, dgamma, eps):
    u = eps / np.asarray(h)
    return adhesion_coefficient(dgamma, eps) * (3.0 * u**3 - 9.0 * u**9) / h


def pressures(d, sigma, dgamma=DGAMMA):
    return surface_pressures(np.atleast_1d(d), sigma, eps=EPS_LJ, gw_coef=GW_COEF, dgamma=dgamma)


# --- Greenwood-Williamson integrals -------------------------------------------------------------------------------


def test_gw_integrals_match_quad():
    t = np.concatenate([np.linspace(-6.0, 6.0, 25), [-9.99, -10.01, -0.001, 0.001, 7.7, 12.0]])
    f32, f12 = gw_integrals(t)
    err32 = [abs(a / reference_gw(x, 1.5) - 1.0) for a, x in zip(f32, t, strict=True)]
    err12 = [abs(a / reference_gw(x, 0.5) - 1.0) for a, x in zip(f12, t, strict=True)]
    assert max(err32) < 1e-12
    assert max(err12) < 1e-12


def test_gw_integrals_continuous_at_table_joins():
    for join in (kernels.T_ASYMPTOTIC, 0.0, 1.0, -1.0, kernels.T_ZERO - 2.0):
        below = np.array(kernels.gw_integrals(np.nextafter(join, -np.inf)))
        above = np.array(kernels.gw_integrals(join))
        np.testing.assert_allclose(below, above, rtol=1e-13)


def test_gw_derivative_relation():
    """dF_{3/2}/dt = -(3/2) F_{1/2}: central differences, truncation ~ h^2 F''' < 1e-9."""
    step = 1e-4
    for t in np.linspace(-12.0, 8.0, 41):
        plus, _ = kernels.gw_integrals(t + step)
        minus, _ = kernels.gw_integrals(t - step)
        _, f12 = kernels.gw_integrals(t)
        assert (plus - minus) / (2.0 * step) == pytest.approx(-1.5 * f12, rel=1e-7)


@pytest.mark.parametrize("t", [-15.0, -30.0, -100.0, -1e4])
def test_gw_large_negative_t(t):
    """F_{3/2}(t) = a^{3/2} (1 + 3/(8 a^2) + 9/(128 a^4) + O(a^-6)), a = -t; F_{1/2} = a^{1/2} (1 - 1/(8 a^2) ...)."""
    a = -t
    f32, f12 = kernels.gw_integrals(t)
    assert abs(f32 / (a**1.5 * (1.0 + 3.0 / (8.0 * a * a))) - 1.0 - 9.0 / (128.0 * a**4)) < 0.2 * a**-6 + 1e-15
    assert abs(f12 / (a**0.5 * (1.0 - 1.0 / (8.0 * a * a))) - 1.0) < 0.12 * a**-4 + 1e-15


def test_gw_limits():
    assert kernels.gw_integrals(np.inf) == (0.0, 0.0)
    assert kernels.gw_integrals(-np.inf) == (np.inf, np.inf)
    assert np.isnan(kernels.gw_integrals(np.nan)[0])
    # F_n(0) = 2^((n-1)/2) Gamma((n+1)/2) / sqrt(2 pi)
    exact = [2.0 ** ((n - 1.0) / 2.0) * gamma((n + 1.0) / 2.0) / np.sqrt(2.0 * np.pi) for n in (1.5, 0.5)]
    assert kernels.gw_integrals(0.0) == pytest.approx(exact, rel=1e-14)


def test_contact_pressure_smooth_limit():
    """sigma -> 0: p_c -> gw_coef (eps - d)^{3/2}, relative correction 3/8 r^2 + 9/128 r^4, r = sigma / (eps - d)."""
    d = EPS_LJ - np.array([0.05e-9, 0.2e-9, 1e-9])
    smooth = pressures(d, 0.0)
    np.testing.assert_allclose(smooth.contact, GW_COEF * (EPS_LJ - d) ** 1.5, rtol=1e-15)
    np.testing.assert_allclose(smooth.contact_slope, -1.5 * GW_COEF * (EPS_LJ - d) ** 0.5, rtol=1e-15)
    sigma = 1e-13
    rough = pressures(d, sigma)
    ratio = sigma / (EPS_LJ - d)
    np.testing.assert_allclose(rough.contact / smooth.contact - 1.0, 3 / 8 * ratio**2 + 9 / 128 * ratio**4, atol=1e-14)
    np.testing.assert_allclose(
        rough.contact_slope, smooth.contact_slope * (1.0 - ratio**2 / 8.0 - 15 / 128 * ratio**4), rtol=1e-13
    )
    assert np.all(pressures(EPS_LJ + np.array([0.0, 1e-12, 1e-9]), 0.0).contact == 0.0)


def test_contact_beyond_its_reach_is_below_round_off_of_a_touching_cell():
    """From t = T_NEGLIGIBLE on a cell's contact is 0; what that drops (the law just below the cut-off, and every
    t beyond it, where F_n falls) is below 1e-30 of a touching cell's pressure and slope (t = 0), far under the
    round-off (1.1e-16) of any sum the cell enters with one that touches."""
    sigma = 1e-9
    t_cut = kernels.T_NEGLIGIBLE
    beyond = [kernels.contact_pressure(EPS_LJ + sigma * t, sigma, EPS_LJ, GW_COEF) for t in (t_cut, t_cut + 1, 100.0)]
    assert all(p == 0.0 and dp == 0.0 for p, dp in beyond)
    touching = kernels.contact_pressure(EPS_LJ, sigma, EPS_LJ, GW_COEF)
    below = kernels.contact_pressure(EPS_LJ + sigma * np.nextafter(t_cut, 0.0), sigma, EPS_LJ, GW_COEF)
    assert 0.0 < below[0] < 1e-30 * touching[0]
    assert 0.0 < abs(below[1]) < 1e-30 * abs(touching[1])
    f32, f12 = kernels.gw_integrals(t_cut)  # the exact law at the cut-off
    assert f32 < 1e-30 * kernels.gw_integrals(0.0)[0] and f12 < 1e-30 * kernels.gw_integrals(0.0)[1]


# --- adhesion ---------------------------------------------------------------------------------------------------------


@pytest.mark.jitless
def test_the_vectorized_contact_pass_is_the_law_cell_by_cell():
    """fill_contact_pressures (one branch-free pass, then cell by cell where it does not apply) against
    contact_pressure on cells at every t of the tables, at their joins, below T_ASYMPTOTIC, beyond T_ZERO, on a
    smooth disk and at nan: within 1e-14 of each cell's own pressure and slope (beyond t = 37.6, where phi(t) falls
    below the smallest normal number, the pass gives 0 where libm's exp gives subnormal pressures below 1e-290 Pa)."""
    rng = np.random.default_rng(3)
    eps = 0.3e-9
    joins = np.arange(kernels.T_ASYMPTOTIC, kernels.T_ZERO + 1.0)
    t = np.concatenate([rng.uniform(-12.0, 45.0, 2000), joins, np.nextafter(joins, -np.inf), [-1e3, 1e3, np.nan]])
    sigma = 10 ** rng.uniform(-12.0, -9.0, t.size)
    d = eps + sigma * t
    sigma[:3] = 0.0  # smooth disk: in contact, at the wall, off it
    d[:3] = [0.1e-9, eps, 0.5e-9]
    gw_coef = 1.25e22
    pc, dpc = np.empty(t.size), np.empty(t.size)
    kernels.fill_contact_pressures(d, sigma, eps, gw_coef, pc, dpc)
    for i in range(t.size):
        want = kernels.contact_pressure(d[i], sigma[i], eps, gw_coef)
        for got, ref in zip((pc[i], dpc[i]), want, strict=True):
            close = abs(got - ref) <= 1e-14 * abs(ref) + 1e-290
            assert got == ref or close or (np.isnan(got) and np.isnan(ref)), (t[i], got, ref)


def test_lj_zero_force_spacing_and_work():
    assert lj_pressure(EPS_LJ, DGAMMA, EPS_LJ) == 0.0
    assert lj_pressure(0.99 * EPS_LJ, DGAMMA, EPS_LJ) > 0.0 > lj_pressure(1.01 * EPS_LJ, DGAMMA, EPS_LJ)
    root = brentq(lambda h: lj_pressure(h, DGAMMA, EPS_LJ), 0.5 * EPS_LJ, 2.0 * EPS_LJ, xtol=1e-24)
    assert root == pytest.approx(EPS_LJ, rel=1e-14)
    # in units of eps: int_1^inf p_LJ(eps x) eps dx
    work = quad(lambda x: lj_pressure(EPS_LJ * x, DGAMMA, EPS_LJ) * EPS_LJ, 1.0, np.inf, epsabs=0.0, epsrel=1e-13)[0]
    assert work == pytest.approx(-DGAMMA, rel=1e-12)


def test_smooth_disk_total_pressure_vanishes_at_eps():
    d = EPS_LJ * np.array([0.5, 0.9, 1.0, 1.1, 3.0, 100.0])
    total = pressures(d, 0.0)
    np.testing.assert_allclose(total.adhesion, np.where(d >= EPS_LJ, lj_pressure(d, DGAMMA, EPS_LJ), 0.0), rtol=1e-15)
    net = total.contact + total.adhesion
    assert net[2] == 0.0
    assert np.all(net[:2] > 0.0) and np.all(net[3:] < 0.0)


ADHESION_CASES = [
    (sigma, tau)
    for sigma in (0.02e-9, 0.2e-9, 0.6e-9, 2e-9)
    for tau in (-4.0, -1.0, 0.0, 0.7, 3.0, 8.0, 9.0, 30.0)
    if EPS_LJ + tau * sigma > 0.0
]


@pytest.mark.parametrize(("sigma", "tau"), ADHESION_CASES)
def test_adhesion_matches_quad(sigma, tau):
    """Rough-disk adhesion and its slope against quad in z; tolerance 1e-7 of the value (1e-7 of max|slope|)."""
    d = EPS_LJ + tau * sigma
    result = pressures(d, sigma)
    reference = reference_adhesion(d, sigma)
    assert result.adhesion[0] == pytest.approx(reference, rel=1e-7)
    slope_reference = reference_adhesion(d, sigma, integrand=lj_slope)
    assert abs(result.adhesion_slope[0] - slope_reference) < 1e-7 * 6.0 * ADH_COEF / EPS_LJ


def test_adhesion_smooth_limit():
    """sigma -> 0: p_a -> p_LJ(d); the first correction p_LJ''(d) sigma^2 / 2 is ~ 45 (sigma/eps)^2 adh_coef."""
    d = EPS_LJ * np.array([1.05, 1.2, 2.0, 10.0])
    rough = pressures(d, 1e-18)
    np.testing.assert_allclose(rough.adhesion, lj_pressure(d, DGAMMA, EPS_LJ), rtol=1e-9)
    np.testing.assert_allclose(rough.adhesion_slope, lj_slope(d, DGAMMA, EPS_LJ), rtol=1e-9)
    assert np.all(pressures(EPS_LJ * np.array([0.5, 0.99]), 1e-18).adhesion == 0.0)


@pytest.mark.parametrize("sigma", [0.02e-9, 0.2e-9, 0.6e-9])
def test_slopes_match_finite_differences(sigma):
    """Central differences in d (step 1e-4 sigma); tolerance 1e-6 of the largest slope of each law."""
    d = EPS_LJ + sigma * np.linspace(-5.0, 12.0, 35)
    step = 1e-4 * sigma
    centre = pressures(d, sigma)
    plus = pressures(d + step, sigma)
    minus = pressures(d - step, sigma)
    for value, slope in ((0, 1), (2, 3)):
        difference = (plus[value] - minus[value]) / (2.0 * step)
        scale = np.max(np.abs(centre[slope]))
        assert np.max(np.abs(difference - centre[slope])) < 1e-6 * scale


@pytest.mark.parametrize("dgamma", [0.008, 0.08])
@pytest.mark.parametrize("sigma", [0.2e-9, 0.6e-9])
def test_total_pressure_has_one_zero(sigma, dgamma):
    """p_c + p_a changes sign once: repulsive below the zero, attractive above.

    With GW_COEF the zero lies at (d - eps)/sigma = 0.39, 1.94 (dgamma 0.008;
    sigma 0.2, 0.6 nm) and -0.70, 0.48 (dgamma 0.08): above eps only when
    p_c(eps) > -p_a(eps), so a strong adhesion on a compliant rough disk pulls
    the equilibrium below eps.
    """
    d = EPS_LJ + sigma * np.linspace(-6.0, 60.0, 2001)
    result = pressures(d, sigma, dgamma)
    net = result.contact + result.adhesion
    assert np.count_nonzero(np.diff(np.sign(net))) == 1
    assert net[0] > 0.0 > net[-1]

    def net_at(x: float) -> float:
        r = pressures(x, sigma, dgamma)
        return r.contact[0] + r.adhesion[0]

    zero = brentq(net_at, d[0], d[-1], xtol=1e-18)
    expected = {(0.2e-9, 0.008): 0.392, (0.6e-9, 0.008): 1.938, (0.2e-9, 0.08): -0.704, (0.6e-9, 0.08): 0.477}
    assert (zero - EPS_LJ) / sigma == pytest.approx(expected[sigma, dgamma], abs=1e-3)
    assert (zero > EPS_LJ) == (net_at(EPS_LJ) > 0.0)


def test_surface_pressures_validates_and_fills_out():
    out = np.empty((4, 3))
    result = surface_pressures(np.full(3, EPS_LJ), 0.2e-9, eps=EPS_LJ, gw_coef=GW_COEF, dgamma=DGAMMA, out=out)
    assert np.shares_memory(result.contact, out)
    with pytest.raises(ValueError, match="sigma"):
        surface_pressures([EPS_LJ], -1e-10, eps=EPS_LJ, gw_coef=GW_COEF, dgamma=DGAMMA)
    with pytest.raises(ValueError, match="out"):
        surface_pressures([EPS_LJ], 0.0, eps=EPS_LJ, gw_coef=GW_COEF, dgamma=DGAMMA, out=np.empty((4, 2)))


# --- elastic half-space -----------------------------------------------------------------------------------------------


def uniform_grid(n: int, half_length: float):
    """Cell centres of an n x n grid on [-half_length, half_length]^2 and the cell width."""
    width = 2.0 * half_length / n
    centres = (np.arange(n) - 0.5 * (n - 1)) * width
    x, y = np.meshgrid(centres, centres, indexing="ij")
    return x.ravel(), y.ravel(), width


def disk_fraction(x: np.ndarray, y: np.ndarray, width: float, radius: float, samples: int = 64) -> np.ndarray:
    """Fraction of each square cell inside the circle of ``radius`` (midpoint rule across x)."""
    xs = x[:, None] + ((np.arange(samples) + 0.5) / samples - 0.5) * width
    half_chord = np.sqrt(np.clip(radius**2 - xs**2, 0.0, None))
    lo = np.maximum((y - 0.5 * width)[:, None], -half_chord)
    hi = np.minimum((y + 0.5 * width)[:, None], half_chord)
    return np.clip(hi - lo, 0.0, None).mean(axis=1) / width


def test_influence_matrix_symmetric_positive_definite():
    nx, ny, dx, dy = 7, 5, 2e-6, 0.7e-6
    x, y = np.meshgrid(dx * np.arange(nx), dy * np.arange(ny), indexing="ij")
    C = influence_matrix(x.ravel(), y.ravel(), 0.5 * dx, 0.5 * dy, E_COMPOSITE)
    np.testing.assert_allclose(C, C.T, rtol=1e-13, atol=0.0)
    assert np.linalg.eigvalsh(C).min() > 0.0
    # self-influence of a square of side s: (s / (pi E')) 4 asinh(1); far field: area / (pi E' r)
    square = influence_matrix([0.0], [0.0], 0.5e-6, 0.5e-6, E_COMPOSITE)[0, 0]
    assert square == pytest.approx(1e-6 * 4.0 * np.arcsinh(1.0) / (np.pi * E_COMPOSITE), rel=1e-14)
    far = influence_coefficients([1e-3], [0.0], [0.0], [0.0], 0.5e-6, 0.5e-6, E_COMPOSITE)[0, 0]
    assert far == pytest.approx(1e-12 / (np.pi * E_COMPOSITE * 1e-3), rel=1e-6)


def test_uniform_circular_pressure_converges_to_johnson():
    """Uniform p0 on a circle of radius a (Johnson 3.4): w(0) = 2 p0 a / E', w(a) = 4 p0 a / (pi E'),
    w(a/2) = 4 p0 a E(1/4) / (pi E') with E(m) the complete elliptic integral of the second kind.

    Cells cut by the circle carry p0 times the fraction of their area inside
    it; the error then falls as h^2 (measured 2.8e-3, 7.4e-4, 1.9e-4 at the
    centre for 10, 20, 40 cells across).
    """
    radius, p0 = 1e-5, 1e6
    points_r = np.array([0.0, radius, 0.5 * radius])
    exact = np.array([2.0, 4.0 / np.pi, 4.0 / np.pi * ellipe(0.25)]) * p0 * radius / E_COMPOSITE
    counts = np.array([10, 20, 40])
    errors = []
    for n in counts:
        x, y, width = uniform_grid(n, radius)
        load = p0 * disk_fraction(x, y, width, radius)
        loaded = load > 0.0
        C = influence_coefficients(points_r, np.zeros(3), x[loaded], y[loaded], 0.5 * width, 0.5 * width, E_COMPOSITE)
        errors.append(np.abs(C @ load[loaded] / exact - 1.0))
    errors = np.array(errors)
    assert np.all(errors[-1] < 3e-4)
    assert np.all(np.diff(errors, axis=0) < 0.0)
    order = -np.polyfit(np.log(counts), np.log(errors), 1)[0]
    np.testing.assert_allclose(order, 2.0, atol=0.2)


def stretched_grid(n: int, half_length: float, stretch: float):
    """n x n cells on [-half_length, half_length]^2, edges at L sinh(b s) / sinh(b): finest at the centre."""
    s = np.linspace(-1.0, 1.0, n + 1)
    edges = half_length * (np.sinh(stretch * s) / np.sinh(stretch) if stretch > 0.0 else s)
    centres, half_widths = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
    x, y = np.meshgrid(centres, centres, indexing="ij")
    hx, hy = np.meshgrid(half_widths, half_widths, indexing="ij")
    return x.ravel(), y.ravel(), hx.ravel(), hy.ravel()


@pytest.fixture(scope="module", params=[0.0, 0.8], ids=["uniform", "stretched"])
def hertz_problem(request):
    """A rigid sphere (R = 1 mm) pressed 10 nm into the half-space, 25 x 25 cells over 2.6 a.

    Stretched cells give an unsymmetric influence matrix (solved by LU).
    """
    radius, delta = 1e-3, 1e-8
    contact_radius = np.sqrt(radius * delta)
    x, y, hx, hy = stretched_grid(25, 1.3 * contact_radius, request.param)
    C = influence_matrix(x, y, hx, hy, E_COMPOSITE)
    gap = (x**2 + y**2) / (2.0 * radius) - delta
    p, active = solve_contact(gap, C)
    area = 4.0 * hx * hy
    return {
        "R": radius,
        "delta": delta,
        "a": contact_radius,
        "area": area,
        "C": C,
        "gap": gap,
        "p": p,
        "active": active,
    }


def test_hertz_load_radius_and_peak(hertz_problem):
    """Johnson 4.2: P = (4/3) E' sqrt(R) delta^{3/2}, a = sqrt(R delta), p_max = 2 E' a / (pi R)."""
    h = hertz_problem
    load = h["p"] @ h["area"]
    assert load == pytest.approx(4.0 / 3.0 * E_COMPOSITE * np.sqrt(h["R"]) * h["delta"] ** 1.5, rel=0.01)
    radius = np.sqrt(h["area"][h["active"]].sum() / np.pi)
    assert radius == pytest.approx(h["a"], rel=0.03)
    assert h["p"].max() == pytest.approx(2.0 * E_COMPOSITE * h["a"] / (np.pi * h["R"]), rel=0.01)


def test_contact_complementarity(hertz_problem):
    h = hertz_problem
    p, gap, active = h["p"], h["gap"], h["active"]
    g = gap + h["C"] @ p
    round_off = 1e-13 * np.abs(gap).max()
    assert np.all(p >= 0.0)
    assert np.all(p[~active] == 0.0)
    assert np.all(g >= -round_off)
    assert np.max(np.abs(g[active])) < round_off
    assert np.max(np.abs(p * g)) < round_off * p.max()


def test_pressure_sensitivity_matches_finite_difference(hertz_problem):
    """A rigid approach dq changes the gap by -dq everywhere; with the contact set unchanged p is linear in it."""
    h = hertz_problem
    S = pressure_sensitivity(h["C"], h["active"])
    step = 1e-6 * h["delta"]
    p_plus, active_plus = solve_contact(h["gap"] - step, h["C"])
    p_minus, active_minus = solve_contact(h["gap"] + step, h["C"])
    assert np.array_equal(active_plus, h["active"]) and np.array_equal(active_minus, h["active"])
    np.testing.assert_allclose((p_plus - p_minus) / (2.0 * step), S @ -np.ones(h["gap"].size), rtol=1e-6, atol=0.0)


def test_contact_without_interpenetration_and_failure():
    C = influence_matrix(np.arange(4.0) * 1e-6, np.zeros(4), 0.5e-6, 0.5e-6, E_COMPOSITE)
    p, active = solve_contact(np.full(4, 1e-9), C)
    assert np.all(p == 0.0) and not active.any()
    x, y, width = uniform_grid(15, 1.3 * np.sqrt(1e-3 * 1e-8))
    C = influence_matrix(x, y, 0.5 * width, 0.5 * width, E_COMPOSITE)
    with pytest.raises(ElasticContactError, match="did not converge"):
        solve_contact((x**2 + y**2) / 2e-3 - 1e-8, C, max_iter=1)


# rough elastic contact: asperities (Greenwood-Williamson) on the elastic half-spaces ------------------------------


@pytest.fixture(scope="module")
def rough_sphere():
    """The Hertz sphere (R = 1 mm, 10 nm approach) on 15 x 15 uniform cells, its gap measured to the mean planes."""
    radius, delta = 1e-3, 1e-8
    x, y, width = uniform_grid(15, 1.3 * np.sqrt(radius * delta))
    C = influence_matrix(x, y, 0.5 * width, 0.5 * width, E_COMPOSITE)
    d = EPS_LJ + (x**2 + y**2) / (2.0 * radius) - delta  # rigid separation of the mean planes
    return {"C": C, "d": d, "area": np.full(x.size, width**2), "delta": delta}


def rigid_gw(d, sigma):
    out = np.empty((2, d.size))
    kernels.contact_pressures(np.ascontiguousarray(d), np.full(d.size, sigma), EPS_LJ, GW_COEF, out)
    return out


@pytest.mark.parametrize("sigma", [0.5e-9, 2e-9])
def test_rough_contact_solves_the_series_law(rough_sphere, sigma):
    """u = d + C P(u) on every cell to 1e-12 sigma, and the bulk compliance only lowers a pressure: 0 <= p <= P(d),
    with p > 0 on every cell within the contact's reach ((u - eps) / sigma < T_NEGLIGIBLE)."""
    from solver.elastic import solve_rough_contact

    s = rough_sphere
    p, _, iterations = solve_rough_contact(s["d"], np.full(s["d"].size, sigma), s["C"], EPS_LJ, GW_COEF)
    u = s["d"] + s["C"] @ p
    P_u = rigid_gw(u, sigma)[0]
    np.testing.assert_allclose(p, P_u, rtol=1e-6, atol=1e-6 * p.max())
    reach = (u - EPS_LJ) / sigma < kernels.T_NEGLIGIBLE
    assert np.all(p[reach] > 0.0) and np.all(p[~reach] == 0.0) and reach.sum() > 0.9 * p.size
    assert np.all(p <= rigid_gw(s["d"], sigma)[0] * (1 + 1e-12))
    assert (p @ s["area"]) < 0.5 * (rigid_gw(s["d"], sigma)[0] @ s["area"])  # the half-space carries real compliance
    assert iterations <= 30


def test_rough_contact_limits(rough_sphere):
    """A stiff half-space (C -> 0) gives the Greenwood-Williamson pressures; a stiff asperity layer (summits 1e6
    times stiffer) of vanishing roughness gives the smooth complementarity solution's load, the Hertz load, with an
    error shrinking in proportion to sigma (the summits stand a few sigma above the mean plane)."""
    from solver.elastic import solve_rough_contact

    s = rough_sphere
    n = s["d"].size
    sigma = 1e-9
    p, _, _ = solve_rough_contact(s["d"], np.full(n, sigma), 1e-12 * s["C"], EPS_LJ, GW_COEF)
    np.testing.assert_allclose(p, rigid_gw(s["d"], sigma)[0], rtol=1e-6)
    p_smooth, _ = solve_contact(s["d"] - EPS_LJ, s["C"])
    smooth = p_smooth @ s["area"]
    errors = []
    for sigma in (0.1e-9, 0.03e-9, 0.01e-9):
        p, _, _ = solve_rough_contact(s["d"], np.full(n, sigma), s["C"], EPS_LJ, 1e6 * GW_COEF)
        errors.append(p @ s["area"] / smooth - 1.0)
    assert errors[0] > 3.0 * errors[1] > 9.0 * errors[2] > 0.0 and errors[2] < 0.006, errors


def test_rough_contact_jacobian_matches_finite_difference(rough_sphere):
    """dp/dd against central differences of the separations: a rigid approach and two random directions."""
    from solver.elastic import solve_rough_contact

    s = rough_sphere
    n = s["d"].size
    sigma = np.full(n, 1e-9)
    _, dpdd, _ = solve_rough_contact(s["d"], sigma, s["C"], EPS_LJ, GW_COEF)
    step = 1e-4 * sigma[0]
    rng = np.random.default_rng(7)
    for v in (np.ones(n), rng.uniform(0.5, 1.5, n), rng.uniform(-1.0, 1.0, n)):
        p_plus, _, _ = solve_rough_contact(s["d"] + step * v, sigma, s["C"], EPS_LJ, GW_COEF)
        p_minus, _, _ = solve_rough_contact(s["d"] - step * v, sigma, s["C"], EPS_LJ, GW_COEF)
        fd = (p_plus - p_minus) / (2.0 * step)
        np.testing.assert_allclose(dpdd @ v, fd, rtol=1e-5, atol=1e-7 * np.abs(fd).max())


def test_rough_contact_refuses_a_smooth_cell_and_reports_no_convergence(rough_sphere):
    from solver.elastic import solve_rough_contact

    s = rough_sphere
    n = s["d"].size
    with pytest.raises(ValueError, match="sigma > 0"):
        solve_rough_contact(s["d"], np.zeros(n), s["C"], EPS_LJ, GW_COEF)
    with pytest.raises(ElasticContactError, match="did not converge"):
        solve_rough_contact(s["d"], np.full(n, 0.1e-9), s["C"], EPS_LJ, GW_COEF, max_iter=1)
