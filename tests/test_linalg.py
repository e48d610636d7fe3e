"""Structured solvers of ancf_jax.linalg against dense numpy solves."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax.linalg import (BlockTridiagonal, InterleavedChain, SaddleMatrix, SequentialChain, factor_chain,
                             factor_saddle, lu_factor, lu_solve, solve_chain, solve_saddle,
                             solve_symmetric_implicit, within_two_blocks)


def _chain(rng, n_blocks=5, b=4):
    """A random block-diagonally dominant block-tridiagonal matrix."""
    diag = rng.normal(size=(n_blocks, b, b)) + 8.0 * np.eye(b)
    return BlockTridiagonal(jnp.asarray(diag), jnp.asarray(rng.normal(size=(n_blocks - 1, b, b))),
                            jnp.asarray(rng.normal(size=(n_blocks - 1, b, b))))


def test_block_thomas_solves_like_dense(rng):
    t = _chain(rng)
    r = rng.normal(size=(t.size, 3))
    x = solve_chain(factor_chain(t), jnp.asarray(r))
    np.testing.assert_allclose(x, np.linalg.solve(np.asarray(t.to_dense()), r), rtol=1e-12, atol=1e-12)
    # A single right-hand side takes other BLAS kernels (vector, not matrix) than the column of a
    # block: they agree to rounding relative to the solution's size, not elementwise (an element
    # 1e-3 of the largest differed by 1.9e-14 of itself on CI's CPU).
    x0 = solve_chain(factor_chain(t), jnp.asarray(r[:, 0]))
    np.testing.assert_allclose(x0, x[:, 0], rtol=0, atol=1e-14 * np.abs(x[:, 0]).max())


@pytest.mark.parametrize("dense", [False, True])
def test_bordered_saddle_solves_like_dense(rng, dense):
    t = _chain(rng)
    n_b = 5
    b = rng.normal(size=(t.size, n_b))
    e = np.zeros((n_b, n_b))
    e[:2, :2] = rng.normal(size=(2, 2)) + 4.0 * np.eye(2)  # border coordinates, then multipliers
    a = SaddleMatrix(t, jnp.asarray(b), jnp.asarray(b.T), jnp.asarray(e))
    r = rng.normal(size=t.size + n_b)
    x = solve_saddle(factor_saddle(a, dense=dense), jnp.asarray(r))
    np.testing.assert_allclose(x, np.linalg.solve(np.asarray(a.to_dense()), r), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("dense", [False, True])
def test_implicitly_differentiated_solve_has_the_derivatives_of_a_dense_solve(rng, dense):
    """x(p) = A(p)⁻¹ r(p) for a symmetric bordered A(p) (block-tridiagonal SPD chain,
    border and constraint rows depending on p): value, JVP and gradient of
    ``solve_symmetric_implicit`` (factors held constant, derivatives by extra solves)
    equal those of ``jnp.linalg.solve`` on the dense matrix (differentiated through)."""
    n_blocks, b, n_b = 4, 4, 3
    d = rng.normal(size=(n_blocks, b, b))
    low = jnp.asarray(rng.normal(size=(n_blocks - 1, b, b)))
    diag = jnp.asarray(d + np.swapaxes(d, 1, 2) + 16.0 * np.eye(b))  # symmetric, dominant
    n_c = n_blocks * b
    g0, g1 = rng.normal(size=(n_b, n_c)), rng.normal(size=(n_b, n_c))
    r0, r1 = rng.normal(size=n_c + n_b), rng.normal(size=n_c + n_b)

    def parts(p):
        scale = 1.0 + 0.1 * p[0]
        chain = BlockTridiagonal(scale * diag, scale * low, scale * jnp.swapaxes(low, 1, 2))
        jac = jnp.asarray(g0) + p[1] * jnp.asarray(g1)
        return chain, jac, jnp.asarray(r0) + p[0] * p[1] * jnp.asarray(r1)

    def dense_solve(p):
        chain, jac, r = parts(p)
        a = jnp.block([[chain.to_dense(), jac.T], [jac, jnp.zeros((n_b, n_b))]])
        return jnp.linalg.solve(a, r)

    def implicit(p):
        chain, jac, r = parts(p)
        a = SaddleMatrix(chain, jac.T, jac, jnp.zeros((n_b, n_b)))
        return solve_symmetric_implicit(a, factor_saddle(a, dense=dense), r)

    # jitted: run op by op, their derivatives compiled ~250 one-operation programs (10 s)
    implicit, dense_solve = jax.jit(implicit), jax.jit(dense_solve)
    p = jnp.array([0.3, -0.7])
    np.testing.assert_allclose(implicit(p), dense_solve(p), rtol=1e-10, atol=1e-12)
    tangent = jnp.array([0.4, 1.1])
    np.testing.assert_allclose(jax.jvp(implicit, (p,), (tangent,))[1],
                               jax.jvp(dense_solve, (p,), (tangent,))[1], rtol=1e-9, atol=1e-12)
    w = jnp.asarray(rng.normal(size=n_c + n_b))
    np.testing.assert_allclose(jax.grad(lambda q: implicit(q) @ w)(p),
                               jax.grad(lambda q: dense_solve(q) @ w)(p), rtol=1e-9, atol=1e-12)


# both factorizations: LAPACK (default) and the elementwise one that loop kernels select
# (ancf_jax._xla.loop_kernels reads XLA_FLAGS when a program is traced)
LOOP_KERNEL_FLAGS = {"lapack": "", "elementwise": "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=1000000"}


@pytest.fixture(params=sorted(LOOP_KERNEL_FLAGS))
def lu_kind(request, monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", LOOP_KERNEL_FLAGS[request.param])
    return request.param


def _primitives(f, *args):
    return {e.primitive.name for e in jax.make_jaxpr(f)(*args).jaxpr.eqns}


def test_lu_keeps_the_permutation_and_solves_with_pivoting(rng, lu_kind):
    a = rng.normal(size=(7, 7))
    a[0, 0] = 0.0  # needs a row exchange
    a[3, :] = 1e-3 * a[3, :]  # and a small row, which partial pivoting must not pick
    rhs = rng.normal(size=(7, 2))
    f = lu_factor(jnp.asarray(a))
    np.testing.assert_allclose(lu_solve(f, jnp.asarray(rhs)), np.linalg.solve(a, rhs), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(lu_solve(f, jnp.asarray(rhs[:, 1])), np.linalg.solve(a, rhs[:, 1]),
                               rtol=1e-10, atol=1e-12)
    # the same factors and row order as LAPACK's getrf, to rounding
    lu, _, perm = jax.lax.linalg.lu(jnp.asarray(a))
    np.testing.assert_array_equal(f[1], perm)
    np.testing.assert_allclose(f[0], lu, rtol=0, atol=1e-14 * np.abs(a).max())
    used = _primitives(lambda m, r: lu_solve(lu_factor(m), r), jnp.asarray(a), jnp.asarray(rhs))
    assert ("lu" in used and "triangular_solve" in used) == (lu_kind == "lapack")


def test_lu_under_vmap(rng, lu_kind):
    a = rng.normal(size=(4, 6, 6)) + 3.0 * np.eye(6)
    rhs = rng.normal(size=(4, 6))
    x = jax.vmap(lambda m, r: lu_solve(lu_factor(m), r))(jnp.asarray(a), jnp.asarray(rhs))
    np.testing.assert_allclose(x, np.linalg.solve(a, rhs[..., None])[..., 0], rtol=1e-10, atol=1e-12)


def test_elementwise_lu_only_for_small_matrices(monkeypatch):
    from ancf_jax.linalg import ELEMENTWISE_LU
    monkeypatch.setenv("XLA_FLAGS", LOOP_KERNEL_FLAGS["elementwise"])
    assert "lu" not in _primitives(lu_factor, jnp.eye(ELEMENTWISE_LU))
    assert "lu" in _primitives(lu_factor, jnp.eye(ELEMENTWISE_LU + 1))


def test_add_local_matches_a_dense_scatter(rng):
    """A local matrix at positions in two neighbouring blocks (repeats add) lands where
    a dense scatter puts it, also at the last block pair and for a one-block chain."""
    for n_blocks, positions in ((5, [5, 6, 9, 11, 6]), (5, [16, 19, 17]), (1, [0, 3, 3])):
        t = _chain(rng, n_blocks=n_blocks)
        a = rng.normal(size=(len(positions), len(positions)))
        dense = np.asarray(t.to_dense()).copy()
        np.add.at(dense, (np.asarray(positions)[:, None], np.asarray(positions)[None, :]), a)
        got = t.add_local(jnp.asarray(positions), jnp.asarray(a)).to_dense()
        np.testing.assert_allclose(got, dense, rtol=0, atol=1e-14)
    assert within_two_blocks([5, 6, 9, 11], 4) and not within_two_blocks([3, 8], 4)


def test_interleaved_layout_orders_nodes_of_all_beams_side_by_side(rng):
    """Chain order (node, beam, coordinate); the assembled chain is the beams' matrices
    permuted into that order (one dense check), and the sequential layout is the
    identity."""
    parts = [_chain(rng, n_blocks=3), _chain(rng, n_blocks=3)]
    order = InterleavedChain().order((12, 12))
    np.testing.assert_array_equal(order[:8], [0, 1, 2, 3, 12, 13, 14, 15])
    full = np.zeros((24, 24))
    full[:12, :12], full[12:, 12:] = parts[0].to_dense(), parts[1].to_dense()
    got = InterleavedChain().assemble(parts)
    assert got.block_size == 8 == InterleavedChain().block_size(2)
    np.testing.assert_array_equal(got.to_dense(), full[np.ix_(order, order)])
    np.testing.assert_array_equal(SequentialChain().order((12, 8)), np.arange(20))
    with pytest.raises(ValueError, match="same number of node slots"):
        InterleavedChain().order((12, 8))


def test_block_inverse_by_cofactors_matches_lu(rng):
    """The chain's diagonal blocks inverted without LAPACK equal LAPACK's inverse to
    rounding (times the condition number): 4×4 by cofactors, on batched blocks,
    nonsymmetric and with entries of mixed scale (positions and slopes), NaN/inf on a
    singular block; the 8×8 and 12×12 blocks of interleaved beams by Schur complements."""
    from ancf_jax.linalg import block_inverse
    a = rng.normal(size=(3, 5, 4, 4)) * np.array([1.0, 1e3, 1.0, 1e-2])[:, None]
    inv = np.asarray(block_inverse(jnp.asarray(a)))
    ref = np.linalg.inv(a)
    cond = np.linalg.cond(a)[..., None, None]
    assert np.all(np.abs(inv - ref) <= 1e-14 * cond * np.abs(ref).max(axis=(-2, -1), keepdims=True))
    singular = np.ones((4, 4))
    assert not np.all(np.isfinite(np.asarray(block_inverse(jnp.asarray(singular)))))
    for b in (8, 12, 6, 20):  # interleaved beams: Schur complement of the first 4x4 block; else LAPACK
        g = rng.normal(size=(2, b, b))
        spd = g @ np.swapaxes(g, -1, -2) + b * np.eye(b)
        np.testing.assert_allclose(np.asarray(block_inverse(jnp.asarray(spd))), np.linalg.inv(spd),
                                   rtol=0, atol=1e-14 * np.abs(np.linalg.inv(spd)).max() * np.linalg.cond(spd).max())


def test_interleaved_chain_under_vmap_and_grad(rng):
    """The multi-beam linear algebra as the solver uses it, two beams interleaved with
    a dropper-like coupling of stiffness k added locally (``add_local``, across two
    nodes of both beams), then factored and solved: jax.vmap over k equals the single
    solves, and jax.grad of a solution entry with respect to k equals the dense
    derivative −(A⁻¹ ∂A/∂k x)ᵢ (to rounding)."""
    chain = InterleavedChain().assemble([_chain(rng, n_blocks=4), _chain(rng, n_blocks=4)])
    positions = jnp.asarray([9, 13, 17, 21])  # y of node 1 and node 2 of both beams: two blocks
    unit = jnp.asarray(np.kron(np.array([[1.0, -1.0], [-1.0, 1.0]]), np.eye(2)))
    r = jnp.asarray(rng.normal(size=chain.size))

    def solve(k):
        return solve_chain(factor_chain(chain.add_local(positions, k * unit)), r)

    ks, single = jnp.asarray([0.5, 2.0, 7.0]), jax.jit(solve)
    np.testing.assert_allclose(jax.jit(jax.vmap(solve))(ks), np.stack([single(k) for k in ks]), rtol=0, atol=1e-13)
    a = np.asarray(chain.add_local(positions, 2.0 * unit).to_dense())
    da = np.zeros_like(a)
    da[np.ix_(np.asarray(positions), np.asarray(positions))] = np.asarray(unit)
    x = np.linalg.solve(a, np.asarray(r))
    np.testing.assert_allclose(jax.jit(jax.grad(lambda k: solve(k)[3]))(2.0), -np.linalg.solve(a, da @ x)[3],
                               rtol=1e-10, atol=1e-14)
