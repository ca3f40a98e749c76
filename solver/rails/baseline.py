"""The baseline the bench measures the film solver against (``hdi bench``).

One time step of the film as a textbook implementation would take it: the exact-Jacobian Newton step of the
midpoint rule, assembled by the same residual kernel, its linear system solved by scipy's sparse direct solver
(SuperLU), instead of this solver's approximate factorisation with line relaxation.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..kernels import reynolds as kr
from .film import make_film
from .params import Scene
from .steady import fly

#: The attitude change of the timed step from steady flight (z [m], pitch, roll [rad]): a typical step's.
STEP_ATTITUDE_CHANGE = np.array([-1e-9, 5e-7, 1e-6])


def sparse_direct_step_cost(scene: Scene, n_steps: int = 10) -> float:
    """Median seconds per step of the baseline: exact-Jacobian midpoint step, scipy sparse direct solve."""
    film = make_film(scene)
    steady = fly(scene, film=film)
    q_old = steady.q
    q_new = steady.q + STEP_ATTITUDE_CHANGE
    shape = film.P.shape
    ny = shape[2]
    R = np.zeros(shape)
    J = [np.zeros(shape) for _ in range(6)]
    interior = np.zeros(shape, dtype=bool)
    interior[:, 1:-1, 1:-1] = True
    H_new, H_old = np.empty(shape), np.empty(shape)
    film.fill_spacing(q_new, H_new, np.empty_like(film.Hx), np.empty_like(film.Hy))
    film.fill_spacing(q_old, H_old, np.empty_like(film.Hx), np.empty_like(film.Hy))
    film.fill_spacing(0.5 * (q_old + q_new), film.H_mid, film.Hx_mid, film.Hy_mid)
    ct = film.sigma / scene.numerics.dt
    P = film.P.copy()
    times = []
    for _ in range(n_steps):
        t0 = time.perf_counter()
        kr.assemble(P, film.H_mid, film.Hx_mid, film.Hy_mid, film.dx, film.dy, film.dxc, film.dyc,
                    film.lam, film.kn, film.c1, film.c2, R, *J, True)  # fmt: skip
        Jcx, Jxm, Jxp, Jcy, Jym, Jyp = J
        diag_t = ct * film.area[None] * H_new
        main = np.ones(P.size)
        main[interior.ravel()] = (diag_t + 0.5 * (Jcx + Jcy))[interior]
        mat = sp.diags(
            [main, 0.5 * Jym.ravel()[1:], 0.5 * Jyp.ravel()[:-1], 0.5 * Jxm.ravel()[ny:], 0.5 * Jxp.ravel()[:-ny]],
            [0, -1, 1, -ny, ny],
            format="csc",
        )
        rhs = np.where(interior, -(ct * film.area[None] * (P * H_new - film.P * H_old) + R), 0.0).ravel()
        spla.spsolve(mat, rhs)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))
