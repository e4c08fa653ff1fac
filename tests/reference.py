"""Independent reference for one flexure: 200-node Gauss-Legendre of cos/sin of phi(sigma).

Built from numpy.polynomial.legendre only (no flexgen code), so it checks the SymPy derivation.
"""

import numpy as np
from numpy.polynomial import legendre

NODES, WEIGHTS = legendre.leggauss(200)
SIGMA, WEIGHTS = (NODES + 1) / 2, WEIGHTS / 2


def angle_basis(modes: int, sigma: np.ndarray) -> np.ndarray:
    """B[k, n] = int_0^sigma_k P_n(2t - 1) dt."""
    cols = []
    for n in range(modes):
        c = np.zeros(n + 1)
        c[n] = 1
        cols.append(legendre.legval(2 * sigma - 1, legendre.legint(c, lbnd=-1) / 2))
    return np.array(cols).T


def max_angle(q: np.ndarray, samples: int = 2001) -> np.ndarray:
    """max over sigma of |phi(sigma)| on a dense grid (for sampling q near a range edge)."""
    B = angle_basis(q.shape[-1], np.linspace(0, 1, samples))
    return np.abs(q @ B.T).max(axis=-1)


def tip(q: np.ndarray):
    """pose (..., 2) = (x, y), J (..., 2, N), H (..., 2, N, N) in units of L."""
    B = angle_basis(q.shape[-1], SIGMA)
    phi = q @ B.T
    c, s = np.cos(phi) * WEIGHTS, np.sin(phi) * WEIGHTS
    pose = np.stack([c.sum(-1), s.sum(-1)], -1)
    J = np.stack([-s @ B, c @ B], -2)
    BB = np.einsum("gi,gj->gij", B, B)
    H = np.stack([-np.einsum("...g,gij->...ij", c, BB), -np.einsum("...g,gij->...ij", s, BB)], -3)
    return pose, J, H


def near_edge(modes: int, phi_max: float, count: int, seed: int = 0) -> np.ndarray:
    """Random q whose higher modes are 1..30 times the first (the wiggly profiles are the
    quadrature kernels' worst cases), plus each pure mode, all scaled so that max|phi| is
    0.97..1.0 of phi_max."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(count, modes))
    q[:, 1:] *= rng.choice([1.0, 3.0, 10.0, 30.0], size=(count, 1))
    q = np.concatenate([q, np.eye(modes), -np.eye(modes)])
    return q * phi_max * rng.uniform(0.97, 1.0, size=(len(q), 1)) / max_angle(q)[:, None]


# -- a plain Newton on one clamped flexure model (the reference tests of fem and prb models) ----
def solve_cantilever(
    model,
    force=(0.0, 0.0),
    moment: float = 0.0,
    q0=None,
    steps: int = 20,
    tol: float = 1e-13,
    max_iter: int = 50,
):
    """Equilibrium of any FlexureModel clamped at its root under a dead tip load: a plain
    NumPy Newton, independent of the solver core (which fem and prb models are checked against
    in tests/test_reference_models.py).

    Solves grad U(q) - J(q)^T (Fx, Fy, M) = 0 by Newton's method on the stiffness
    K = hess U - sum_k H_k w_k, with the load applied in ``steps`` equal increments from q0
    (default: unloaded). Returns (q, TipKinematics). Raises RuntimeError if Newton fails.
    """
    w_full = np.array([force[0], force[1], moment], dtype=float)
    q = np.zeros(model.n_dof) if q0 is None else np.array(q0, dtype=float)
    scale = model.EI / model.length
    for lam in np.linspace(0.0, 1.0, steps + 1)[1:]:
        w = lam * w_full
        for _ in range(max_iter):
            tk = model.tip(q)
            r = model.energy_gradient(q) - tk.J.T @ w
            K = model.energy_hessian(q) - np.einsum("k,kij->ij", w, tk.H)
            dq = np.linalg.solve(K, -r)
            q = q + dq
            if np.max(np.abs(dq)) < tol and np.max(np.abs(r)) < 1e3 * tol * scale:
                break
        else:
            raise RuntimeError(
                f"solve_cantilever: Newton did not converge at load factor {lam:.3g}"
            )
    return q, model.tip(q)
