"""The OCP's assembled derivatives against CasADi's automatic ones (ocp/feedforward.py).

solve_program_ocp hands IPOPT a constraint Jacobian and a Lagrangian Hessian assembled from
per-interval blocks of the RK4 step; they must be the derivatives CasADi itself computes for
the same NLP, at any point and multipliers.
"""

import casadi as ca
import numpy as np

from rsp_inertia.ocp.feedforward import RHO, W_PHI, _nlp_derivatives, _step_derivatives


def test_block_derivatives_are_casadis(programs):
    nominal = programs[1].nominal
    rng = np.random.default_rng(3)
    N, h = 12, 0.02
    blocks = _step_derivatives(h)
    X = ca.MX.sym("X", 3, N + 1)
    V = ca.MX.sym("V", 1, N)
    ref_phi, ref_omega = rng.uniform(0, 6, N + 1), rng.uniform(-12, 0, N + 1)
    err = ca.vertcat(X[1, :] - ref_omega[None, :], W_PHI * (X[0, :] - ref_phi[None, :]))
    cost = h * ca.sumsqr(err) + RHO * h * ca.sumsqr(V)
    w = ca.vertcat(ca.vec(X), ca.vec(V))
    g = ca.vec(X[:, 1:] - blocks.F.map(N)(X[:, :-1], V, nominal.vector))
    mine = _nlp_derivatives(blocks, X, V, nominal.vector, cost, w, g)

    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", 3 * N)
    jac = ca.Function("auto_jac", [w], [ca.jacobian(g, w)])
    hess = ca.Function(
        "auto_hess", [w, lam_f, lam_g], [ca.triu(ca.hessian(lam_f * cost + ca.dot(lam_g, g), w)[0])]
    )
    for _ in range(3):
        x = np.column_stack(
            [rng.uniform(0, 6, N + 1), rng.uniform(-12, 0, N + 1), rng.uniform(-0.5, 0.5, N + 1)]
        ).ravel()
        z = np.concatenate([x, rng.uniform(-20, 20, N)])
        lf, lg = rng.uniform(0.5, 2), rng.standard_normal(3 * N)
        g_mine, jac_mine = mine["jac_g"](z, [])
        np.testing.assert_allclose(np.asarray(g_mine), np.asarray(ca.Function("g", [w], [g])(z)))
        expected = np.asarray(ca.DM(jac(z)).full())
        np.testing.assert_allclose(
            np.asarray(jac_mine.full()), expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max()
        )
        expected = np.asarray(ca.DM(hess(z, lf, lg)).full())
        np.testing.assert_allclose(
            np.asarray(mine["hess_lag"](z, [], lf, lg).full()),
            expected,
            rtol=1e-10,
            atol=1e-12 * np.abs(expected).max(),
        )
