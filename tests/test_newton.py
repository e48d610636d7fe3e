"""The root finder (ancf_jax.newton.ModifiedNewton) on small problems with known roots:
full Newton converges quadratically, a frozen matrix linearly, a refresh policy in
between; non-finite residuals are retreated from; implicit derivatives equal the
implicit-function-theorem derivative."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax.linalg import SaddleMatrix
from ancf_jax.newton import ModifiedNewton

N = 3
C = jnp.array([2.0, 3.0, 5.0])


def dense(jac):
    """A SaddleMatrix without chain (a dense operator)."""
    return SaddleMatrix(None, jnp.zeros((0, N)), jnp.zeros((N, 0)), jac)


def residual(x, c=C):
    # x_i³ + 0.1 Σ x = c_i: coupled, with a root near c^(1/3)
    return x**3 + 0.1 * jnp.sum(x) - c


def linearize(x):
    return dense(jnp.diag(3.0 * x**2) + 0.1)


@pytest.fixture(scope="module")
def root():
    x = jnp.cbrt(C)
    for _ in range(50):
        x = x - jnp.linalg.solve(jax.jacfwd(residual)(x), residual(x))
    return x


def iterations(newton, x0=jnp.full(N, 1.5)):
    sol = jax.jit(lambda x: newton.solve(residual, linearize, x, size=N))(x0)
    return int(sol.iterations), bool(sol.converged), sol.x


def test_full_newton_is_quadratic_and_modified_newton_linear(root):
    full = ModifiedNewton(tolerance=1e-13, contraction=0.0, max_iterations=50)
    frozen = ModifiedNewton(tolerance=1e-13, contraction=0.999, refresh_every=1000, max_iterations=200)
    policy = ModifiedNewton(tolerance=1e-13, contraction=0.25, max_iterations=50)
    n_full, ok_full, x_full = iterations(full)
    n_frozen, ok_frozen, x_frozen = iterations(frozen)
    n_policy, ok_policy, _ = iterations(policy)
    assert ok_full and ok_frozen and ok_policy
    np.testing.assert_allclose(x_full, root, atol=1e-13)
    np.testing.assert_allclose(x_frozen, root, atol=1e-12)
    # quadratic: from 1.5 to 1e-13 in a handful; linear with a rate ~0.3-0.6: tens
    assert n_full <= 7 and n_frozen >= 3 * n_full and n_full <= n_policy < n_frozen


def test_convergence_order_of_full_newton_is_two(root):
    """Errors after k = 1, 2, 3 iterations (max_iterations caps the loop): the fitted
    order log(e_{k+1}) / log(e_k) ratio of successive errors is ~2."""
    errs = []
    for k in (1, 2, 3, 4):
        newton = ModifiedNewton(tolerance=1e-30, contraction=0.0, max_iterations=k)
        errs.append(float(jnp.max(jnp.abs(iterations(newton)[2] - root))))
    orders = [np.log(errs[i + 1]) / np.log(errs[i]) for i in range(len(errs) - 1)
              if errs[i + 1] > 1e-14]
    assert orders and all(1.8 < p < 2.3 for p in orders), (errs, orders)


def test_non_finite_residual_is_retreated_from():
    """log(x / a) = 0 from x = 100 a: the full Newton step x ← x (1 − log(x / a)) lands
    at x < 0, where the residual is NaN. Without retreat the solve fails; with
    ``max_backtracks`` the step is halved until the residual is finite, and Newton
    then converges to x = a."""
    a = 0.04

    def g(x):
        return jnp.log(x / a)

    def lin_g(x):
        return dense(jnp.diag(1.0 / x))

    norm = lambda r: jnp.max(jnp.abs(r))  # noqa: E731
    plain = ModifiedNewton(tolerance=1e-12, contraction=0.0, max_iterations=60)
    guarded = ModifiedNewton(tolerance=1e-12, contraction=0.0, max_iterations=60, max_backtracks=30)
    x0 = jnp.full(N, 100 * a)
    bad = plain.solve(g, lin_g, x0, size=N, residual_norm=norm)
    good = guarded.solve(g, lin_g, x0, size=N, residual_norm=norm)
    assert not bool(bad.converged)
    assert bool(good.converged) and int(good.iterations) < 40
    np.testing.assert_allclose(good.x, a, rtol=1e-10)


def test_residual_norm_is_that_of_the_iterate_returned():
    """Given a residual norm, the solve reports the norm at the iterate it returns (a
    last pass evaluates it there and moves nothing): the norm of F(x) evaluated apart,
    with the iterates and iteration counts of the solve without a norm, for a solve
    that converges and one stopped by its iteration cap (the residual before the last
    correction, reported before, is 20 times larger there)."""
    norm = lambda r: jnp.max(jnp.abs(r))  # noqa: E731
    x0 = jnp.full(N, 1.5)
    for newton, converged in ((ModifiedNewton(tolerance=1e-13, contraction=0.0, max_iterations=50), True),
                              (ModifiedNewton(tolerance=1e-30, contraction=0.0, max_iterations=2), False)):
        guarded = jax.jit(lambda x: newton.solve(residual, linearize, x, size=N, residual_norm=norm))(x0)
        plain = jax.jit(lambda x: newton.solve(residual, linearize, x, size=N))(x0)
        assert bool(guarded.converged) == converged == bool(plain.converged)
        assert int(guarded.iterations) == int(plain.iterations)
        np.testing.assert_array_equal(guarded.x, plain.x)
        np.testing.assert_allclose(guarded.residual_norm, norm(residual(guarded.x)), rtol=1e-12, atol=1e-15)
    before = jax.jit(lambda x: ModifiedNewton(tolerance=1e-30, contraction=0.0, max_iterations=1).solve(
        residual, linearize, x, size=N))(x0).x
    assert float(norm(residual(before))) > 10 * float(guarded.residual_norm)


@pytest.mark.parametrize("matrix, refinement", [("exact", 0), ("approximate", 12), ("exact tangent", 0)])
def test_implicit_derivative_is_the_implicit_function_theorem(root, matrix, refinement):
    """d x*/d c of the root: (∂F/∂x)⁻¹ (the custom JVP), against the closed form. The
    tangent solves factor ``linearize`` at the root: the exact matrix needs no
    refinement; a matrix 10 % off on its diagonal (Newton still converges) is made up
    by iterative refinement against the residual's linearization (contraction 0.11:
    12 steps reach 1e-11), or, unrefined, by an exact ``tangent_linearize`` that the
    tangent solves factor instead while the iteration keeps the approximate matrix."""
    newton = ModifiedNewton(tolerance=1e-13, contraction=0.0, max_iterations=80)
    approximate = lambda x: dense(jnp.diag(2.7 * x**2) + 0.1)  # noqa: E731
    lin = linearize if matrix == "exact" else approximate

    def solve(c, refinement=refinement, exact_tangent=matrix == "exact tangent"):
        # the tangent matrix closes over a traced value (c, adding nothing), as a time
        # step's does, and the iteration's matrix over none: their arguments differ
        tangent = (lambda x: dense(jnp.diag(3.0 * x**2) + 0.1 + 0.0 * c[0])) if exact_tangent else None
        return newton.root(lambda x: residual(x, c), lin, jnp.cbrt(c), size=N, refinement=refinement,
                           tangent_linearize=tangent).x

    jac = jax.jacfwd(solve)(C)
    reference = jnp.linalg.inv(jax.jacfwd(residual)(root))  # ∂F/∂c = −I
    np.testing.assert_allclose(jac, reference, rtol=1e-8, atol=1e-12)
    grad = jax.grad(lambda c: jnp.sum(solve(c) ** 2))(C)
    np.testing.assert_allclose(grad, reference.T @ (2 * root), rtol=1e-8)
    if matrix != "exact":  # without the refinement the derivative is that of the wrong matrix
        err = jnp.max(jnp.abs(jax.jacfwd(lambda c: solve(c, 0, False))(C) - reference))
        assert err > 1e-3 * jnp.max(jnp.abs(reference))
    if matrix == "exact tangent":  # the iteration keeps the approximate matrix (linear rate)
        its = newton.root(residual, approximate, jnp.cbrt(C), size=N, tangent_linearize=linearize).iterations
        exact_its = newton.solve(residual, linearize, jnp.cbrt(C), size=N).iterations
        assert int(its) == int(newton.solve(residual, approximate, jnp.cbrt(C), size=N).iterations)
        assert int(its) > int(exact_its) + 3
