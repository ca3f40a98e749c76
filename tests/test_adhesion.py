"""The asperity adhesion law (DMT summits, ``models.adhesion = "asperity_dmt"``) and the fold estimate.

References are independent of the implementation: the limits derived in
:mod:`solver.kernels.surface` (pull-off 2 pi R dgamma per summit, bounded
in contact, the Derjaguin far field (4/3) 2 pi R dgamma (eps/d)^2 per
summit), quad in the summit height z of the law written out here, quad of
the flat law's pressure over the separation (the asperity law is the flat
law's work of adhesion per summit), central differences, and for the fold
estimate the pull of a pitched plane face integrated along its length.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import chen_bogy
from scipy.integrate import quad
from scipy.stats import norm

from solver.abs.face import abs_grid
from solver.abs.film import AbsFilm
from solver.abs.forces import REACH_SIGMAS, SurfaceModel
from solver.abs.integrate import simulate_abs
from solver.abs.params import ADHESION_LAWS, Abs, AbsModels, AbsNumerics, AbsScene, AbsSlider
from solver.abs.steady import fly_start
from solver.jit import JIT_DISABLED
from solver.kernels import surface as kernels
from solver.params import ParameterError
from solver.surface import ADHESION_LAWS as KERNEL_LAWS
from solver.surface import adhesion_coefficient, summit_coefficient, surface_pressures

#: Intermolecular equilibrium spacing [m], summits (chen_bogy2007: 1e14 m^-2 of radius 1 um) and dgamma [J/m2].
EPS = 0.3e-9
SUMMIT_COEF = summit_coefficient(1e14, 1e-6)
DGAMMA = 0.008
#: Pull-off pressure of a fully compressed summit population, 2 pi R eta_s dgamma [Pa].
PULL_OFF = SUMMIT_COEF * DGAMMA
GW_COEF = 1e19
#: The coarsest grid that resolves every region of chen_bogy2007 (as in test_partial.py).
COARSE = {"numerics.nx": 41, "numerics.ny": 31, "numerics.refine_nodes": 2}

NO_CACHE = (np.empty(0), np.empty(0), np.empty(0), np.empty(0))  # generalized_forces without its cache


def asperity(d, sigma, dgamma=DGAMMA):
    """(p_a, dp_a/dd) of the asperity law at separations d [m] with roughness sigma [m]."""
    r = surface_pressures(
        np.atleast_1d(np.asarray(d, dtype=float)), sigma, eps=EPS, gw_coef=GW_COEF, dgamma=dgamma,
        adhesion="asperity_dmt", summit_coef=SUMMIT_COEF,
    )  # fmt: skip
    return r.adhesion, r.adhesion_slope


def flat(d, sigma):
    r = surface_pressures(np.atleast_1d(np.asarray(d, dtype=float)), sigma, eps=EPS, gw_coef=GW_COEF, dgamma=DGAMMA)
    return r.adhesion, r.adhesion_slope


def energy(h):
    """The 9-3 law's energy per area, written from p = (8 dgamma / (3 eps)) [(eps/h)^9 - (eps/h)^3]: int_h^inf p."""
    return DGAMMA / 3.0 * ((EPS / h) ** 8 - 4.0 * (EPS / h) ** 2)


def summit_force(g):
    """DMT summit force / (2 pi R) at the gap g: Derjaguin outside contact, the pull-off -dgamma in contact."""
    return energy(g) if g >= EPS else -DGAMMA


def reference(d, sigma):
    """p_a = eta_s E[2 pi R F(d - z)], z ~ N(0, sigma), by quad in z (split at the contact wall z = d - eps)."""
    top = d - EPS
    compressed = -DGAMMA * norm.sf(top / sigma)
    bottom = -14.0 * sigma
    if top <= bottom:
        return SUMMIT_COEF * compressed
    points = sorted({x for x in (0.0, top - 0.2 * EPS, top - EPS) if bottom < x < top})
    free = quad(lambda z: summit_force(d - z) * norm.pdf(z, scale=sigma), bottom, top, points=points or None,
                epsabs=0.0, epsrel=1e-12, limit=500)[0]  # fmt: skip
    return SUMMIT_COEF * (compressed + free)


# --- the law's limits -----------------------------------------------------------------------------------------------


@pytest.mark.jitless
def test_pull_off_per_summit():
    """Smooth disk at d = eps and below: every summit pulls 2 pi R dgamma, p_a = -eta_s 2 pi R dgamma, slope 0."""
    p, slope = asperity(EPS * np.array([0.2, 0.9, 1.0]), 0.0)
    np.testing.assert_allclose(p / -PULL_OFF - 1.0, 0.0, atol=1e-15)
    assert np.all(slope == 0.0)
    # sigma -> 0: the whole population at d = eps; half of it compressed, half just outside, the same pull
    # the corrections: W(eps + x) = -dgamma + 8 dgamma (x/eps)^2 - (104/3) dgamma (x/eps)^3 + ... on the half of the
    # summits above the wall, E[x^2; x > 0] = sigma^2 / 2, E[x^3; x > 0] = sqrt(2/pi) sigma^3
    for sigma in (1e-14, 1e-13):  # smaller sigma: the nodes resolve d - h only to ulp(eps) = 5e-26 m
        p, _ = asperity(EPS, sigma)
        r = sigma / EPS
        assert p[0] / -PULL_OFF - 1.0 == pytest.approx(-4.0 * r**2 + 104.0 / 3.0 * math.sqrt(2.0 / math.pi) * r**3,
                                                      abs=1e-11)  # fmt: skip


@pytest.mark.jitless
def test_deep_contact_tends_to_the_bounded_pull():
    """A cell pressed far into the summits tends to -eta_s 2 pi R dgamma and never pulls harder.

    The summits still outside the wall, a fraction P(Z < t) of them, pull
    less: p_a / (-pull-off) - 1 is between -P(Z < t) and 0 (measured at t = -4,
    -6: within 1.3e-5 and 5e-9 of the bound below it).
    """
    for sigma in (0.2e-9, 0.6e-9):
        t = np.array([-4.0, -6.0, -8.0, -30.0])
        p, _ = asperity(EPS + t * sigma, sigma)
        deficit = p / -PULL_OFF - 1.0
        assert np.all(deficit <= 1e-15) and np.all(deficit >= -norm.cdf(t) - 1e-15), deficit
        assert deficit[-1] == pytest.approx(0.0, abs=1e-15)
        sweep = EPS + sigma * np.linspace(-10.0, 40.0, 501)
        p, _ = asperity(sweep, sigma)
        assert np.all(p >= -PULL_OFF * (1.0 + 1e-15)) and np.all(p < 0.0)
        assert np.all(np.diff(p) >= 0.0)  # the pull weakens monotonically with the separation


@pytest.mark.jitless
def test_far_field_falls_like_the_inverse_square():
    """Derjaguin of the 9-3 law: p_a -> -(4/3) eta_s 2 pi R dgamma (eps/d)^2; fitted exponent -2 within 1e-4.

    The roughness multiplies the far field by E[(1 - z/d)^-2] = 1 + 3 (sigma/d)^2 + O(d^-4).
    """
    sigma = 0.2e-9
    d = EPS * np.geomspace(1e2, 1e4, 9)
    p, _ = asperity(d, sigma)
    exponent = np.polyfit(np.log(d), np.log(-p), 1)[0]
    assert exponent == pytest.approx(-2.0, abs=1e-4)
    far_field = -4.0 / 3.0 * PULL_OFF * (EPS / d) ** 2 * (1.0 + 3.0 * (sigma / d) ** 2)
    np.testing.assert_allclose(p / far_field, 1.0, rtol=1e-7)
    # the flat law on the nominal area falls one power faster (its far field is the -eps^3/h^3 term)
    p_flat, _ = flat(d[:5], 0.2e-9)
    assert np.polyfit(np.log(d[:5]), np.log(-p_flat), 1)[0] == pytest.approx(-3.0, abs=1e-3)


@pytest.mark.jitless
def test_proportional_to_delta_gamma():
    d = EPS + 0.2e-9 * np.linspace(-8.0, 40.0, 97)
    p1, s1 = asperity(d, 0.2e-9, 0.008)
    p10, s10 = asperity(d, 0.2e-9, 0.08)
    np.testing.assert_allclose(p10, 10.0 * p1, rtol=1e-13)
    np.testing.assert_allclose(s10, 10.0 * s1, rtol=1e-13, atol=1e-13 * np.max(np.abs(s10)))


@pytest.mark.jitless
def test_is_the_flat_laws_work_per_summit():
    """p_a(d) = 2 pi R eta_s int_d^inf p_a^flat: the flat law's pressure (a different kernel) integrated by quad.

    The integral runs to D = 1000 eps and the rest is the smooth law's
    W(D) (the roughness changes it by sigma^2 / D^2 ~ 4e-7 of 1e-6).  At
    sigma -> 0 and d = eps it is the flat law's work of adhesion, -dgamma.
    Tolerance 1e-7 of the pull-off (the flat quadrature's accuracy, 3e-8).
    """
    top = 1e3 * EPS
    for sigma in (1e-15, 0.2e-9, 0.6e-9):
        for t in (-3.0, 0.0, 1.0, 5.0):
            d = EPS + t * sigma
            if d <= 0.0:
                continue
            knots = [x for x in (EPS, EPS + 9 * sigma, 3 * EPS, 10 * EPS) if d < x < top]
            work = quad(lambda x, s=sigma: flat(x, s)[0][0], d, top, points=knots or None, epsabs=0.0, epsrel=1e-11,
                        limit=400)[0] + energy(top)  # fmt: skip
            assert abs(asperity(d, sigma)[0][0] - SUMMIT_COEF * work) < 1e-7 * PULL_OFF, (sigma, t)


# --- the numerics ---------------------------------------------------------------------------------------------------

QUAD_CASES = [
    (sigma, t)
    for sigma in (1e-12, 0.02e-9, 0.2e-9, 0.6e-9, 2e-9)
    for t in (-8.0, -6.95, -6.85, -4.0, -1.0, 0.0, 0.7, 3.0, 8.49, 8.51, 30.0, 300.0)
    if EPS + t * sigma > 0.0
]


@pytest.mark.jitless
@pytest.mark.parametrize(("sigma", "t"), QUAD_CASES)
def test_quadrature_matches_quad(sigma, t):
    """Panels and Gauss-Hermite against quad in z; tolerance 1e-9 relative (measured at most 1e-10)."""
    d = EPS + t * sigma
    assert asperity(d, sigma)[0][0] == pytest.approx(reference(d, sigma), rel=1e-9, abs=0.0)


@pytest.mark.jitless
@pytest.mark.parametrize("sigma", [0.0, 0.02e-9, 0.2e-9, 0.6e-9])
def test_slope_matches_central_differences(sigma):
    """dp_a/dd against central differences (step 1e-4 of sigma, or of eps on a smooth disk); 1e-6 of max |slope|."""
    scale = sigma if sigma > 0.0 else EPS
    d = EPS + scale * (np.linspace(-5.0, 12.0, 35) + 0.1)  # no node at eps: the smooth law's p'' jumps there
    step = 1e-4 * scale
    _, slope = asperity(d, sigma)
    difference = (asperity(d + step, sigma)[0] - asperity(d - step, sigma)[0]) / (2.0 * step)
    assert np.max(np.abs(difference - slope)) < 1e-6 * np.max(np.abs(slope))
    assert np.all(slope >= 0.0)


@pytest.mark.jitless
def test_smooth_limit():
    """sigma -> 0: p_a -> eta_s 2 pi R W(d) above eps; the first correction is W''(d) sigma^2 / 2 ~ 36 (sigma/eps)^2."""
    d = EPS * np.array([1.05, 1.2, 2.0, 10.0])
    smooth, _ = asperity(d, 0.0)
    np.testing.assert_allclose(smooth, SUMMIT_COEF * energy(d), rtol=1e-14)
    rough, _ = asperity(d, 1e-18)
    np.testing.assert_allclose(rough, smooth, rtol=1e-9)


@pytest.mark.jitless
def test_flat_law_unchanged():
    """The default law is "flat" and gives, bit for bit, the values of the kernels before the asperity law."""
    adh_coef = adhesion_coefficient(DGAMMA, EPS)
    pinned = {  # (d, sigma) -> (p_a, dp_a/dd) as float.hex, computed at commit 0d4ac61
        (EPS + 0.7 * 0.2e-9, 0.2e-9): ("-0x1.53218169526dcp+23", "-0x1.01cd1024f6532p+52"),
        (EPS + 9.0 * 0.6e-9, 0.6e-9): ("-0x1.5b871e424fe0ap+13", "0x1.658c9e56eb71bp+42"),
        (EPS - 1.0 * 0.2e-9, 0.2e-9): ("-0x1.7d620de11e0f2p+21", "-0x1.448f702bf136ep+54"),
    }
    tolerance = 1e-13 if JIT_DISABLED else 0.0  # plain Python rounds without the compiled code's fused multiply-adds
    for (d, sigma), pair in pinned.items():
        expected = pytest.approx(tuple(map(float.fromhex, pair)), rel=tolerance, abs=0.0)
        assert kernels.adhesion_pressure(d, sigma, EPS, adh_coef) == expected
        assert kernels.adhesion_by_law(d, sigma, EPS, adh_coef, kernels.ADHESION_FLAT, SUMMIT_COEF) == expected
    assert AbsModels().adhesion == "flat"


# --- the key --------------------------------------------------------------------------------------------------------


@pytest.mark.jitless
def test_the_registry_names_the_kernels_laws():
    assert tuple(KERNEL_LAWS) == ADHESION_LAWS
    assert sorted(KERNEL_LAWS.values()) == list(range(len(KERNEL_LAWS)))


@pytest.mark.jitless
def test_unknown_law_names_key_value_and_choices():
    with pytest.raises(ParameterError) as info:
        AbsModels(adhesion="jkr")
    message = str(info.value)
    assert "models.adhesion = 'jkr'" in message and "'flat', 'asperity_dmt'" in message
    with pytest.raises(ValueError, match="'flat', 'asperity_dmt'"):
        surface_pressures([EPS], 0.0, eps=EPS, gw_coef=GW_COEF, dgamma=DGAMMA, adhesion="jkr")


# --- the face: Newton kernel, Python paths, steady flight, a run ----------------------------------------------------


@pytest.fixture(scope="module")
def asperity_flight():
    """chen_bogy2007 on the coarse grid with the asperity law: scene, film (smooth disk), surface model, flight."""
    scene = chen_bogy(COARSE | {"models.adhesion": "asperity_dmt"})
    film = AbsFilm(scene)
    steady = fly_start(scene, film)
    film.set_disk(np.zeros(film.shape))
    return scene, film, SurfaceModel(scene, film.grid), steady


def test_steady_flight_with_the_asperity_law(asperity_flight):
    """A steady flight (balanced, no note; on this coarse grid the pad touches) pulled by the asperity law.

    At the same attitude the flat law pulls harder (the flat law's peak
    pressure, 0.385 adh_coef = 27 MPa, against 5 MPa at the pull-off).
    """
    scene, film, surface, steady = asperity_flight
    assert steady.note == "" and steady.force_residual < scene.numerics.steady_tol
    assert steady.surface.adhesion < 0.0
    d = film.spacing(steady.q)
    sigma = np.full(d.shape, scene.disk.rms)
    flat_scene = dataclasses.replace(scene, models=dataclasses.replace(scene.models, adhesion="flat"))
    assert surface.forces(d, sigma).adhesion == steady.surface.adhesion
    assert 0.0 > steady.surface.adhesion > SurfaceModel(flat_scene, film.grid).forces(d, sigma).adhesion


@pytest.mark.parametrize("drop_by", [2.0e-9, 5.0e-9])
def test_newton_kernel_and_python_paths_agree(asperity_flight, drop_by):
    """The Newton kernel's forces (law tuple) equal the Python path's; the elastic law sees the same adhesion."""
    scene, film, surface, steady = asperity_flight
    q = steady.q - [drop_by, 0.0, 0.0]
    sigma = np.full(film.shape, scene.disk.rms)
    cells = surface.candidates(np.zeros(film.shape), sigma, q, 0.0)
    python = surface.forces_on(cells, q)
    f, dfdq = np.empty(3), np.empty((3, 3))
    contact, adhesion, in_reach = kernels.generalized_forces(
        cells.base, cells.sigma, cells.b, cells.area, q, *surface.kernel_law, f, dfdq, NO_CACHE, kernels.CACHE_OFF
    )
    assert adhesion < 0.0 and in_reach == python.cells > 0
    assert (contact, adhesion) == pytest.approx((python.contact, python.adhesion), rel=1e-12)
    np.testing.assert_allclose(f, python.f, rtol=1e-12, atol=1e-12 * np.max(np.abs(f)))
    np.testing.assert_allclose(dfdq, python.dfdq, rtol=1e-10, atol=1e-12 * np.max(np.abs(dfdq)))
    elastic = dataclasses.replace(scene, models=dataclasses.replace(scene.models, contact="elastic"))
    d = film.spacing(q)
    assert SurfaceModel(elastic, film.grid).forces(d, sigma).adhesion == pytest.approx(
        surface.forces(d, sigma).adhesion, rel=1e-13
    )


def test_hard_landing_runs_with_the_asperity_law(asperity_flight):
    """A 5-cm/s landing from steady flight (implicit step, Newton kernel) runs to t_end and touches the disk."""
    scene, _, _, steady = asperity_flight
    run = {"numerics.t_end": 20e-6, "numerics.settle_time": 0.0, "numerics.output_interval": 0.2e-6,
           "initial.zdot": -0.05, "models.adhesion": "asperity_dmt"}  # fmt: skip
    result = simulate_abs(chen_bogy(COARSE | run), steady)
    assert result.status == 0, result.message
    assert np.max(result.series["contact_force"]) > 0.0
    adhesion = result.series["adhesion_force"]
    assert np.all(adhesion < 0.0)
    bound = PULL_OFF * 10.0 * np.sum(abs_grid(scene).contact_area)  # the whole face at the pull-off, x10 margin
    assert np.min(adhesion) > -bound


# --- the fold estimate ----------------------------------------------------------------------------------------------


def plane_face(adhesion: str, nx: int) -> AbsScene:
    """A plain face (no etch, crown or camber) on nx x 11 nodes with the given adhesion law, smooth disk."""
    return AbsScene(
        slider=AbsSlider(crown=0.0, camber=0.0),
        abs=Abs(base_depth=0.0),
        models=AbsModels(adhesion=adhesion),
        numerics=AbsNumerics(nx=nx, ny=11),
    )


@pytest.mark.jitless
@pytest.mark.parametrize("adhesion", ADHESION_LAWS)
def test_fold_estimate_of_a_pitched_plane(adhesion):
    """A plane pitched by theta, lowered to touch at its trailing edge: the pull is width x int p(d(x)) dx.

    With d = eps + theta (x_c - x) (x_c the lowest contact patch's centroid)
    the reference integrates the smooth laws along x by quad: the flat law
    gives about -w dgamma / theta (the notes' estimate), the asperity law
    -(9/7) 2 pi R eta_s dgamma eps w / theta on an endless plane.  The patches
    are a midpoint rule: error measured 3.7e-4 (flat) and 1.1e-5 (asperity) on
    161 nodes.
    """
    scene = plane_face(adhesion, 161)
    grid = abs_grid(scene)
    surface = SurfaceModel(scene, grid)
    theta = 1e-6
    q = np.array([1e-9, theta, 0.0])
    d = (surface.surface + q @ surface.b).reshape(grid.shape)
    force, lowering = surface.touchdown_adhesion(d, np.zeros(grid.shape))
    lowest = np.argmin(d)
    assert d.ravel()[lowest] - lowering == pytest.approx(EPS, rel=1e-12)
    x_c = grid.contact_x.ravel()[lowest]
    coef = summit_coefficient(scene.contact.summit_density, scene.contact.summit_radius)
    dgamma = scene.contact.delta_gamma

    def pressure(x: float) -> float:
        h = EPS + theta * (x_c - x)
        u = EPS / h
        if adhesion == "flat":
            return adhesion_coefficient(dgamma, EPS) * (u**9 - u**3) if h >= EPS else 0.0
        return coef * dgamma / 3.0 * (u**8 - 4.0 * u**2) if h >= EPS else -coef * dgamma

    L, W = scene.slider.length, scene.slider.width
    expected = W * quad(pressure, 0.0, L, points=[x_c], epsabs=0.0, epsrel=1e-12, limit=200)[0]
    tolerance = {"flat": 1e-3, "asperity_dmt": 1e-4}[adhesion]
    assert force == pytest.approx(expected, rel=tolerance)
    # the leading edge is 0.85 nm above eps: the endless plane's pull is 9 % (flat) and 27 % (asperity) larger
    endless = {"flat": -W * dgamma / theta, "asperity_dmt": -9.0 / 7.0 * coef * dgamma * EPS * W / theta}[adhesion]
    assert 0.6 < force / endless < 1.0


def test_fold_estimate_is_reported(asperity_flight):
    """hdi fly's report carries the estimate; it is linear in dgamma and sums the whole face (beyond the reach)."""
    from pipeline.reports import abs_fly

    scene, film, surface, steady = asperity_flight
    d = film.spacing(steady.q)
    sigma = np.full(d.shape, scene.disk.rms)
    assert (steady.touchdown_adhesion, steady.touchdown_lowering) == surface.touchdown_adhesion(d, sigma)
    ratio = -steady.touchdown_adhesion / scene.suspension.preload
    assert 0.0 < ratio < 1.0
    # lowered until the lowest contact patch (not the exact corner, which lies below every patch) is at eps
    assert steady.touchdown_lowering == pytest.approx(d.min() - EPS, abs=1e-12)
    assert steady.min_spacing <= d.min()
    strong = dataclasses.replace(scene, contact=dataclasses.replace(scene.contact, delta_gamma=0.08))
    ten_times = SurfaceModel(strong, film.grid).touchdown_adhesion(d, sigma)[0]
    assert ten_times == pytest.approx(10.0 * steady.touchdown_adhesion, rel=1e-13)
    near = d.ravel() - steady.touchdown_lowering < surface.reach + REACH_SIGMAS * scene.disk.rms
    assert not near.all()  # cells beyond the reach count too
    lines = "\n".join(abs_fly(steady, scene, 0.0))
    assert f"adhesion at touchdown {steady.touchdown_adhesion * 1e3:.3f} mN = {ratio:.3g} preloads" in lines
    assert "asperity_dmt adhesion law" in lines
    assert math.isfinite(steady.touchdown_lowering)


@pytest.mark.parametrize("drop_by", [1.8e-9, 2.2e-9])
def test_rough_elastic_contact_on_the_face(asperity_flight, drop_by):
    """The elastic law on a rough track (asperities on the half-spaces): contact below the rigid asperity law's on
    every cell, and the generalized force's Jacobian in (z, pitch, roll) against central differences."""
    scene, film, surface, steady = asperity_flight
    elastic = SurfaceModel(dataclasses.replace(scene, models=dataclasses.replace(scene.models, contact="elastic")),
                           film.grid)  # fmt: skip
    sigma = np.full(film.shape, scene.disk.rms)
    q = steady.q - [drop_by, 0.0, 0.0]
    rough = elastic.forces(film.spacing(q), sigma)
    rigid = surface.forces(film.spacing(q), sigma)
    assert 0.0 < rough.contact < 0.1 * rigid.contact  # the bulk compliance: 1.4 against 47 mN at 1.8 nm
    steps = np.array([1e-12, 0.0, 0.0])  # [m]; the angles move the far corner by 1e-12 m
    steps[1:] = 1e-12 / np.array([film.grid.x.max(), film.grid.y.max()])
    for k in range(3):
        e = np.zeros(3)
        e[k] = steps[k]
        fd = (elastic.forces(film.spacing(q + e), sigma).f - elastic.forces(film.spacing(q - e), sigma).f) / (
            2 * steps[k]
        )
        np.testing.assert_allclose(rough.dfdq[:, k], fd, rtol=1e-5, atol=1e-6 * np.abs(rough.dfdq).max())


@pytest.mark.jitless
@pytest.mark.parametrize("law", ["flat", "asperity_dmt"])
@pytest.mark.parametrize("sigma", [0.0, 0.1e-9, 0.3e-9])
def test_adhesion_curvature_is_the_slope_s_derivative(law, sigma):
    """adhesion_with_curvature: the pressure and slope of adhesion_by_law, and a curvature equal to the central
    difference of the slope (step 1e-5 of the scale) within 1e-5 of the curvature's largest value on the range."""
    code = KERNEL_LAWS[law]
    adh_coef = adhesion_coefficient(DGAMMA, EPS)
    scale = max(sigma, EPS)
    ds = np.linspace(EPS + 0.05e-9 if sigma == 0.0 else EPS - 2 * sigma, 4e-9, 61)
    exact, differences = [], []
    for d in ds:
        p, slope, curv = kernels.adhesion_with_curvature(d, sigma, EPS, adh_coef, code, SUMMIT_COEF)
        assert (p, slope) == kernels.adhesion_by_law(d, sigma, EPS, adh_coef, code, SUMMIT_COEF)
        step = 1e-5 * scale
        up = kernels.adhesion_by_law(d + step, sigma, EPS, adh_coef, code, SUMMIT_COEF)[1]
        down = kernels.adhesion_by_law(d - step, sigma, EPS, adh_coef, code, SUMMIT_COEF)[1]
        exact.append(curv)
        differences.append((up - down) / (2 * step))
    exact, differences = np.array(exact), np.array(differences)
    assert np.max(np.abs(exact - differences)) <= 1e-5 * np.max(np.abs(exact))


def test_the_adhesion_cache_is_the_exact_law_near_its_cells(asperity_flight):
    """generalized_forces with its cache: filled at q, used at q moved by 0.1 pm (inside CACHE_REACH), the force
    and Jacobian equal the exact evaluation to 1e-9; moved by 2 nm, every cell is evaluated afresh (exact)."""
    scene, film, surface, steady = asperity_flight
    q = steady.q - [3.0e-9, 0.0, 0.0]
    sigma = np.full(film.shape, scene.disk.rms)
    cells = surface.candidates(np.zeros(film.shape), sigma, q, 3.0e-9)
    n = cells.base.size
    cache = tuple(np.empty(n) for _ in range(4))
    f, dfdq = np.empty(3), np.empty((3, 3))
    args = (cells.base, cells.sigma, cells.b, cells.area)
    kernels.generalized_forces(*args, q, *surface.kernel_law, f, dfdq, cache, kernels.CACHE_FILL)
    for move, tol in ((0.1e-12, 1e-9), (2.0e-9, 0.0)):
        q1 = q + [move, 0.0, 0.0]
        exact_f, exact_j = np.empty(3), np.empty((3, 3))
        totals = kernels.generalized_forces(*args, q1, *surface.kernel_law, exact_f, exact_j, NO_CACHE,
                                            kernels.CACHE_OFF)  # fmt: skip
        cached = kernels.generalized_forces(*args, q1, *surface.kernel_law, f, dfdq, cache, kernels.CACHE_USE)
        assert totals[2] == cached[2] and totals[1] < 0.0
        assert abs(cached[1] / totals[1] - 1.0) <= tol
        assert np.max(np.abs(f - exact_f) / np.abs(exact_f)) <= tol
        assert np.max(np.abs(dfdq - exact_j)) <= max(tol, 1e-14) * np.max(np.abs(exact_j))


@pytest.mark.jitless
@pytest.mark.parametrize("law", ["flat", "asperity_dmt"])
def test_the_vectorized_fill_is_the_law_cell_by_cell(law):
    """fill_flat_adhesion and fill_asperity_adhesion (one Gauss-Hermite pass over every cell, the cells near the
    wall in one pass of near_wall_expectations, the rest again by the scalar law) against adhesion_with_curvature
    on cells far from the wall, near it (a quarter of them), in contact, fully compressed, on a smooth disk and
    beyond the flat law's range: pressure and slope within 1e-14 of each cell's own, the curvature within 1e-12
    (of the largest of the terms it sums where they cancel)."""
    rng = np.random.default_rng(7)
    n = 600
    sigma = np.concatenate([10 ** rng.uniform(-12.0, -9.0, n - 4), [0.0, 0.2e-9, 0.2e-9, 0.2e-9]])
    tau = np.concatenate([rng.uniform(-8.0, 400.0, n - 154), rng.uniform(-7.5, 9.0, 150), [2.0, 9.0, 0.0, -7.0]])
    d = EPS + sigma * tau
    d[-4] = 0.5e-9  # smooth disk above the wall
    d[-2] = 4e-6  # beyond LJ_RANGE eps
    adh_coef = adhesion_coefficient(DGAMMA, EPS)
    cache = tuple(np.empty(n) for _ in range(4))
    if law == "flat":
        kernels.fill_flat_adhesion(d, sigma, EPS, adh_coef, cache)
    else:
        kernels.fill_asperity_adhesion(d, sigma, EPS, adh_coef, SUMMIT_COEF, cache)
    assert np.array_equal(cache[0], d)
    near = 0
    for i in range(n):
        p, slope, curv = kernels.adhesion_with_curvature(cache[0][i], sigma[i], EPS, adh_coef, KERNEL_LAWS[law],
                                                         SUMMIT_COEF)  # fmt: skip
        near += sigma[i] > 0.0 and kernels.TAU_NO_ADHESION <= (cache[0][i] - EPS) / sigma[i] < kernels.N_SIGMA
        for got, want, tol in ((cache[1][i], p, 1e-14), (cache[2][i], slope, 1e-14), (cache[3][i], curv, 1e-12)):
            assert abs(got - want) <= tol * abs(want) or got == want == 0.0, (i, tau[i], sigma[i], got, want)
    assert near >= 150
