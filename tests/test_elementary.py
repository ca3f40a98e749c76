"""The vectorizable exp and log (:mod:`solver.kernels.elementary`) and the film's face loops written with them.

The references are libm's (``math.exp``, ``math.log``) and the scalar kernels they replace
(:func:`solver.kernels.slip.fk_factor`, :func:`solver.kernels.film.bernoulli_signed`,
:func:`solver.kernels.film.face_flux`); errors are in units of the double's ulp or of its relative round-off.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import chen_bogy

from solver.kernels import elementary as el
from solver.kernels import film as kf
from solver.kernels import slip as ks

ULP = np.finfo(float).eps
SEED = 20261126


def ulps(value: float, exact: float) -> float:
    """|value - exact| in units of the spacing of doubles at ``exact``."""
    return abs(value - exact) / math.ulp(exact) if exact != 0.0 else abs(value) / math.ulp(0.0)


@pytest.mark.jitless
def test_exp_minus_is_within_two_ulp_of_libm():
    RNG = np.random.default_rng(SEED)
    # the whole range the Bernoulli function uses, and the reduction's breakpoints r = +-ln2/2
    ys = np.concatenate([RNG.uniform(0.0, 40.0, 4000), RNG.uniform(0.0, 708.0, 2000), [0.0, 1e-300, 1e-8, 0.5,
                         math.log(2.0) / 2.0, math.log(2.0), 1.0, 36.0, 700.0, 708.0]])  # fmt: skip
    worst = max(ulps(el.exp_minus(float(y)), math.exp(-float(y))) for y in ys)
    assert worst <= 2.0, worst


@pytest.mark.jitless
def test_exp_minus_clamps_far_arguments_to_the_last_normal_binade():
    assert el.exp_minus(1.0e4) == pytest.approx(math.exp(-el.EXP_ARGUMENT_MAX), rel=4 * ULP)
    assert el.exp_minus(1.0e4) > 0.0


@pytest.mark.jitless
def test_log_positive_is_within_two_ulp_of_libm():
    RNG = np.random.default_rng(SEED)
    xs = np.concatenate([np.exp(RNG.uniform(-700.0, 700.0, 3000)), RNG.uniform(0.1, 10.0, 3000),
                         [1.0, 2.0, 0.5, math.sqrt(2.0), math.nextafter(math.sqrt(2.0), 2.0), 1.0 + 1e-15,
                          1.0 - 1e-16, 0.2, 1.0 / 0.15, 100.0]])  # fmt: skip
    worst_rel = 0.0
    for x in xs:
        exact = math.log(float(x))
        got = el.log_positive(float(x))
        # near x = 1 the log is small and libm's own error is relative to it; elsewhere 2 ulp of the result
        scale = max(abs(exact), ULP)
        worst_rel = max(worst_rel, abs(got - exact) / scale)
        if abs(exact) > 1e-3:
            assert ulps(got, exact) <= 2.0, (x, got, exact)
    assert worst_rel <= 4 * ULP


def fk_arguments() -> list[tuple[float, float]]:
    RNG = np.random.default_rng(SEED)
    """(P, H) pairs putting x = kn / (sqrt(pi)/2 P H) in every piece of the Fukui-Kaneko fit and on its breakpoints."""
    kn = 6.5
    xs = np.concatenate([np.exp(RNG.uniform(math.log(1e-3), math.log(1e3), 400)), [0.2, 1.0 / 0.15, 100.0]])
    pairs = []
    for x in xs:
        P = float(RNG.uniform(0.3, 30.0))
        pairs.append((P, kn / (ks.HALF_SQRT_PI * P * float(x))))
    return pairs


@pytest.mark.jitless
def test_vectorizable_fk_factor_is_the_scalar_one_to_round_off():
    kn = 6.5
    for P, H in fk_arguments():
        phi, dphi = ks.fk_factor(P, H, kn)
        phi_v, dphi_v = ks.fk_factor_vectorizable(P, H, kn)
        assert abs(phi_v - phi) <= 8 * ULP * abs(phi), (P, H)
        assert abs(dphi_v - dphi) <= 64 * ULP * (abs(dphi) + 1e-3 * abs(phi) / P), (P, H)


@pytest.mark.jitless
def test_vectorizable_bernoulli_is_the_scalar_one_to_round_off():
    RNG = np.random.default_rng(SEED)
    xs = np.concatenate([RNG.uniform(-2.0, 2.0, 1000), RNG.uniform(-800.0, 800.0, 1000),
                         [0.0, 1.0, -1.0, math.nextafter(1.0, 0.0), 700.0, -700.0, 701.0, -701.0]])  # fmt: skip
    for x in xs:
        b, db = kf.bernoulli_signed(float(x))
        b_v, db_v = kf.bernoulli_vectorizable(float(x))
        assert abs(b_v - b) <= 8 * ULP * max(abs(b), abs(x) * ULP), x
        assert abs(db_v - db) <= 8 * ULP * max(abs(db), 1.0), x


@pytest.mark.jitless
def test_vectorized_face_flux_is_the_scalar_one_to_round_off():
    """Random faces from the cavity (1.5 um) to the pad in contact (below the slip law's switch), both flow
    directions: F, dF/dP_L, dF/dP_R within a few ulp of the sum of the flux's own terms."""
    RNG = np.random.default_rng(SEED)
    kn, h_ref, h_switch = 6.5, 10.0e-9, 0.3e-9
    n = 3000
    P = np.exp(RNG.uniform(math.log(0.3), math.log(40.0), (1, 3, n)))
    H = np.exp(RNG.uniform(math.log(0.01), math.log(200.0), (1, 3, n)))  # 0.1 nm .. 2 um
    Hx = H[:, :-1] * np.exp(RNG.uniform(-0.05, 0.05, (1, 2, n)))
    ends = np.exp(RNG.uniform(-0.3, 0.3, (2, 2, n)))
    Hxe = np.stack([H[0, :-1] * ends[0], H[0, 1:] * ends[1]])
    Hy = np.ones((1, 3, n - 1))
    Hye = np.ones((2, 3, n - 1))
    dx = np.array([2e-3, 5e-3])
    dy = np.full(n - 1, 4e-3)
    for lam in (1.9e5, -2.2e4):
        xface = np.zeros((3, 2, n))
        yface = np.zeros((3, 3, n - 1))
        kf.fk_face_fluxes(P, Hx, Hy, Hxe, Hye, dx, dy, lam, 0.1 * lam, kn, h_ref, h_switch, xface, yface)
        thin = 0
        for i in range(2):
            for j in range(n):
                ref = kf.face_flux(P[0, i, j], P[0, i + 1, j], Hxe[0, i, j], Hxe[1, i, j], Hx[0, i, j], 1.0 / dx[i],
                                   lam, kn, h_ref, h_switch, ks.FUKUI_KANEKO)  # fmt: skip
                thin += Hx[0, i, j] * h_ref < h_switch
                # the size of the flux's terms, F = g (m_L - m_R) + A m_L, which cancel where the flow is reversed;
                # g = (K / d) B(Pe) carries Pe's round-off times |d ln B / d Pe| <= 1 + |Pe|
                pl, pr, hl, hr = P[0, i, j], P[0, i + 1, j], Hxe[0, i, j], Hxe[1, i, j]
                g_hr, _, ga_hl, _, pe = kf.segment(0.5 * (pl + pr), Hx[0, i, j], hl, hr, 1.0 / dx[i], lam, kn, h_ref,
                                                  h_switch, ks.FUKUI_KANEKO)  # fmt: skip
                g, a = g_hr / hr, ga_hl / hl - g_hr / hr
                scale = abs(g) * (pl * hl + pr * hr) * (1.0 + abs(pe)) + abs(a) * pl * hl
                assert abs(xface[0, i, j] - ref[0]) <= 32 * ULP * scale, (i, j)  # measured: at most 11.3
                for k in (1, 2):
                    assert abs(xface[k, i, j] - ref[k]) <= 1e-12 * (abs(ref[1]) + abs(ref[2])), (k, i, j)
        assert thin > 10  # the scalar pass took the faces under the switch


def test_assembly_takes_the_vectorized_faces_and_the_cut_links_on_top():
    """The face fluxes :func:`solver.kernels.film.assemble` leaves on the default face (61 x 51): every plain link
    within round-off of the scalar :func:`~solver.kernels.film.face_flux`.  The face is lowered into contact and
    the film floor set to 0.1 nm, so that faces fall under the slip law's switch (its scalar pass)."""
    RNG = np.random.default_rng(SEED)
    from solver.abs.film import AbsFilm

    # a film floor under the slip law's switch, so that faces in contact take the bounded second-order law
    scene = chen_bogy({"numerics.nx": 61, "numerics.ny": 51, "numerics.film_floor": 0.1e-9})
    film = AbsFilm(scene)
    q = np.array([40.0e-9, 135.0e-6, -15.0e-6])
    q[0] -= float(film.spacing(q).min()) - 0.05e-9  # the face's lowest point 0.05 nm from the disk
    film.fill_faces(q)
    film.P[0] += RNG.uniform(0.0, 2.0, film.P.shape[1:])
    film.residual()
    c = film.constants
    thin = 0
    for axis, faces, cuts, H, He, spacing, lam in (
        (0, film.scratch.xface, film.cuts.xface, film.Hx, film.Hxe, c.dx, c.lamx),
        (1, film.scratch.yface, film.cuts.yface, film.Hy, film.Hye, c.dy, c.lamy),
    ):
        cut = {(int(i), int(j)) for i, j in cuts}
        for i in range(H.shape[1]):
            for j in range(H.shape[2]):
                if (i, j) in cut:
                    continue
                right = (i + 1, j) if axis == 0 else (i, j + 1)
                ref = kf.face_flux(film.P[0, i, j], film.P[0, right[0], right[1]], He[0, i, j], He[1, i, j], H[0, i, j],
                                   1.0 / spacing[(i, j)[axis]], lam, c.kn, c.h_ref, c.h_switch, c.code)  # fmt: skip
                thin += H[0, i, j] * c.h_ref < c.h_switch
                atol = 1e-12 * (abs(c.lamx) + abs(c.lamy)) * H[0, i, j] * film.P[0, i, j]
                assert np.allclose(faces[:, i, j], ref, rtol=1e-12, atol=atol), (axis, i, j)
    assert thin > 0
