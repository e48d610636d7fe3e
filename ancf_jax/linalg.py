"""Structured matrices of the assembled system.

The beam coordinates of a chain of ANCF elements couple only neighbouring nodes, so
every beam matrix (mass, stiffness, damping, the iteration matrix of an implicit
integrator) is block tridiagonal with 4×4 node blocks. :class:`BlockTridiagonal` stores
such a matrix in O(n) memory; the border (rigid bodies, sliding coordinates,
constraints) is handled by a Schur complement in the solvers.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _products, _xla


class BlockTridiagonal(eqx.Module):
    """Block-tridiagonal matrix with ``n`` square blocks of size ``b``.

    Attributes:
        diagonal: shape (n, b, b).
        lower: shape (n - 1, b, b), block (i + 1, i).
        upper: shape (n - 1, b, b), block (i, i + 1).
    """

    diagonal: jnp.ndarray
    lower: jnp.ndarray
    upper: jnp.ndarray

    @property
    def n_blocks(self) -> int:
        return self.diagonal.shape[-3]

    @property
    def block_size(self) -> int:
        return self.diagonal.shape[-1]

    @property
    def size(self) -> int:
        return self.n_blocks * self.block_size

    @classmethod
    def from_element_matrices(cls, element_matrices):
        """Assemble (n_el, 2b, 2b) element matrices of a chain (element k joins nodes
        k and k + 1) into an (n_el + 1)-block matrix."""
        k = element_matrices
        b = k.shape[-1] // 2
        n_el = k.shape[0]
        diag = jnp.zeros((n_el + 1, b, b), k.dtype)
        diag = diag.at[:-1].add(k[:, :b, :b]).at[1:].add(k[:, b:, b:])
        return cls(diag, k[:, b:, :b], k[:, :b, b:])

    @classmethod
    def concatenate(cls, parts):
        """Block-diagonal composition of chains (no coupling between parts)."""
        parts = list(parts)
        b = parts[0].block_size
        zero = jnp.zeros((1, b, b))
        diag = jnp.concatenate([p.diagonal for p in parts])
        lower, upper = [], []
        for i, p in enumerate(parts):
            if i:
                lower.append(zero)
                upper.append(zero)
            lower.append(p.lower)
            upper.append(p.upper)
        return cls(diag, jnp.concatenate(lower), jnp.concatenate(upper))

    def __add__(self, other):
        return BlockTridiagonal(self.diagonal + other.diagonal, self.lower + other.lower,
                                self.upper + other.upper)

    def scale(self, c):
        """The matrix times the scalar c."""
        return BlockTridiagonal(c * self.diagonal, c * self.lower, c * self.upper)

    def add_diagonal(self, d):
        """Add a diagonal (vector of length n·b)."""
        n, b = self.n_blocks, self.block_size
        dd = jax.vmap(jnp.diag)(jnp.reshape(d, (n, b)))
        return BlockTridiagonal(self.diagonal + dd, self.lower, self.upper)

    def matvec(self, x):
        """Product with a vector x of shape (n_blocks · block_size,)."""
        n, b = self.n_blocks, self.block_size
        xb = jnp.reshape(x, (n, b))
        with _products.batch(n):
            y = _products.matvec(self.diagonal, xb)
            y = y.at[1:].add(_products.matvec(self.lower, xb[:-1]))
            y = y.at[:-1].add(_products.matvec(self.upper, xb[1:]))
        return jnp.reshape(y, (n * b,))

    def add_local(self, positions, a):
        """The matrix plus a local (k, k) matrix ``a`` at rows and columns
        ``positions`` (k,) (ints, may be traced) that lie in two consecutive blocks
        (a force element between points of neighbouring nodes: a dropper between two
        interleaved beams, a support spring). Entries at repeated positions add.

        The block pair is found from the positions at run time; positions spread over
        more than two consecutive blocks are outside the pattern (the caller checks,
        :func:`within_two_blocks`)."""
        return self.add_local_many(jnp.asarray(positions)[None], jnp.asarray(a)[None])

    def add_local_many(self, positions, a):
        """:meth:`add_local` for m local matrices at once: positions (m, k), a (m, k, k)."""
        n, b = self.n_blocks, self.block_size
        positions = jnp.asarray(positions)
        if n == 1:
            w = jax.vmap(lambda p, x: jnp.zeros((b, b), x.dtype).at[p[:, None], p[None, :]].add(x))(positions, a)
            return BlockTridiagonal(self.diagonal + jnp.sum(w, axis=0)[None], self.lower, self.upper)
        i0 = jnp.clip(jnp.min(positions, axis=1) // b, 0, n - 2)
        loc = positions - i0[:, None] * b
        w = jax.vmap(lambda p, x: jnp.zeros((2 * b, 2 * b), x.dtype).at[p[:, None], p[None, :]].add(x))(loc, a)
        diag = self.diagonal.at[i0].add(w[:, :b, :b]).at[i0 + 1].add(w[:, b:, b:])
        return BlockTridiagonal(diag, self.lower.at[i0].add(w[:, b:, :b]), self.upper.at[i0].add(w[:, :b, b:]))

    def to_dense(self):
        """The dense matrix, shape (n_blocks · block_size,) × 2 (for tests and small systems)."""
        n, b = self.n_blocks, self.block_size
        a = jnp.zeros((n, b, n, b))
        idx = jnp.arange(n)
        a = a.at[idx, :, idx, :].set(self.diagonal)
        a = a.at[idx[1:], :, idx[:-1], :].set(self.lower)
        a = a.at[idx[:-1], :, idx[1:], :].set(self.upper)
        return jnp.reshape(a, (n * b, n * b))


def within_two_blocks(positions, block_size: int) -> bool:
    """Whether the (concrete) positions lie in two consecutive blocks of size
    ``block_size`` (the pattern of :meth:`BlockTridiagonal.add_local`)."""
    blocks = np.asarray(positions) // block_size
    return blocks.size == 0 or int(blocks.max() - blocks.min()) <= 1


# ---------------------------------------------------------------------- chain layouts
class AbstractChainLayout(eqx.Module):
    """Order of the beam coordinates in the block-tridiagonal chain of the solvers.

    A layout maps the beams' node coordinates (each beam a chain of 4×4 node blocks,
    beams one after another in q) to the rows of one :class:`BlockTridiagonal`, so
    that every coupling the solver should see as banded lies in neighbouring blocks.
    """

    @abc.abstractmethod
    def order(self, sizes: tuple[int, ...]) -> np.ndarray:
        """Indices of the beam coordinates (counted from the first beam coordinate in
        q; beams of ``sizes`` coordinates one after another) in chain order."""

    @abc.abstractmethod
    def assemble(self, parts) -> BlockTridiagonal:
        """The chain matrix from one block-tridiagonal matrix (4×4 blocks) per beam."""

    @abc.abstractmethod
    def block_size(self, n_beams: int) -> int:
        """Size of the chain's blocks for ``n_beams`` beams."""


class SequentialChain(AbstractChainLayout):
    """Beams one after another, node blocks of 4 (no coupling between beams in the
    pattern: a force element between two beams is a low-rank border term)."""

    def order(self, sizes):
        return np.arange(int(sum(sizes)))

    def assemble(self, parts):
        return BlockTridiagonal.concatenate(parts)

    def block_size(self, n_beams):
        return 4


class InterleavedChain(AbstractChainLayout):
    """Beams side by side: block i holds node i of every beam (block size 4 × the
    number of beams), for beams with the same number of node slots laid out along a
    common track (the contact and messenger wires of a catenary, meshed with nodes at
    the same x). A force element between two beams at the same node interval (a
    dropper) then lies in neighbouring blocks and enters the chain instead of the
    border: the cost per step stays linear in the element count whatever the number
    of droppers (:meth:`BlockTridiagonal.add_local`)."""

    def order(self, sizes):
        sizes = tuple(int(s) for s in sizes)
        if len(set(sizes)) != 1 or sizes[0] % 4:
            raise ValueError(f"InterleavedChain needs beams with the same number of node slots, got "
                             f"{[s // 4 for s in sizes]} nodes")
        m, n = len(sizes), sizes[0] // 4
        # q index of (beam j, node i, coordinate c) is j·4n + 4i + c; chain order (i, j, c)
        return np.reshape(np.arange(m * n * 4).reshape(m, n, 4).transpose(1, 0, 2), (-1,))

    def assemble(self, parts):
        parts = list(parts)
        m = len(parts)

        def interleave(blocks):  # (m, k, 4, 4) → (k, 4m, 4m) block diagonal per node
            k = blocks.shape[1]
            out = jnp.zeros((k, m, 4, m, 4), blocks.dtype)
            idx = jnp.arange(m)
            out = out.at[:, idx, :, idx, :].set(blocks)
            return jnp.reshape(out, (k, 4 * m, 4 * m))

        stack = lambda name: jnp.stack([getattr(p, name) for p in parts])  # noqa: E731
        return BlockTridiagonal(interleave(stack("diagonal")), interleave(stack("lower")),
                                interleave(stack("upper")))

    def block_size(self, n_beams):
        return 4 * n_beams


# ---------------------------------------------------------------------- block Thomas
class ChainFactor(eqx.Module):
    """Block-LU factors of a block-tridiagonal matrix (block Thomas algorithm).

    For T with diagonal D, lower L, upper U blocks: D'₀ = D₀,
    D'ᵢ = Dᵢ − Lᵢ₋₁ D'ᵢ₋₁⁻¹ Uᵢ₋₁. Stores D'ᵢ⁻¹ and Gᵢ = D'ᵢ⁻¹ Uᵢ. Without pivoting
    across blocks: meant for the positive definite or block diagonally dominant beam
    matrices (mass, M β' + K of implicit integrators). O(n b³) work, O(n b²) memory.
    """

    dinv: jnp.ndarray   # (n, b, b)
    g: jnp.ndarray      # (n - 1, b, b)
    lower: jnp.ndarray  # (n - 1, b, b)


def _inverse4(m):
    """Inverses of 4×4 matrices, shape (..., 4, 4), by cofactors: the 2×2 minors s of
    rows 0–1 and c of rows 2–3 give det = Σ ±s c and every cofactor (Laplace
    expansion). Elementwise arithmetic only, so it fuses with its neighbours and
    vectorizes under ``vmap``; ``jnp.linalg.inv`` is two LAPACK calls per block."""
    a = [[m[..., i, j] for j in range(4)] for i in range(4)]

    def minor(r, i, j):
        return a[r][i] * a[r + 1][j] - a[r + 1][i] * a[r][j]

    s0, s1, s2, s3, s4, s5 = (minor(0, i, j) for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)))
    c0, c1, c2, c3, c4, c5 = (minor(2, i, j) for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)))
    det = s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0
    rows = [
        [a[1][1] * c5 - a[1][2] * c4 + a[1][3] * c3, -a[0][1] * c5 + a[0][2] * c4 - a[0][3] * c3,
         a[3][1] * s5 - a[3][2] * s4 + a[3][3] * s3, -a[2][1] * s5 + a[2][2] * s4 - a[2][3] * s3],
        [-a[1][0] * c5 + a[1][2] * c2 - a[1][3] * c1, a[0][0] * c5 - a[0][2] * c2 + a[0][3] * c1,
         -a[3][0] * s5 + a[3][2] * s2 - a[3][3] * s1, a[2][0] * s5 - a[2][2] * s2 + a[2][3] * s1],
        [a[1][0] * c4 - a[1][1] * c2 + a[1][3] * c0, -a[0][0] * c4 + a[0][1] * c2 - a[0][3] * c0,
         a[3][0] * s4 - a[3][1] * s2 + a[3][3] * s0, -a[2][0] * s4 + a[2][1] * s2 - a[2][3] * s0],
        [-a[1][0] * c3 + a[1][1] * c1 - a[1][2] * c0, a[0][0] * c3 - a[0][1] * c1 + a[0][2] * c0,
         -a[3][0] * s3 + a[3][1] * s1 - a[3][2] * s0, a[2][0] * s3 - a[2][1] * s1 + a[2][2] * s0]]
    return jnp.stack([jnp.stack(r, axis=-1) for r in rows], axis=-2) / det[..., None, None]


#: largest diagonal block of :func:`factor_chain` inverted without LAPACK (:func:`block_inverse`)
ELEMENTWISE_INVERSE = 16


def block_inverse(a):
    """Inverses of the diagonal blocks of :func:`factor_chain`, shape (..., b, b).

    The 4×4 node blocks of one beam by cofactors (:func:`_inverse4`); the 4m×4m blocks
    of m interleaved beams up to :data:`ELEMENTWISE_INVERSE` by the Schur complement
    of their first 4×4 block, [[A, B], [C, D]]⁻¹ with S = D − C A⁻¹ B, recursively;
    larger ones by ``jnp.linalg.inv``. Without pivoting, as the block Thomas algorithm
    itself: for the positive definite or block diagonally dominant beam matrices.
    Measured (M2 with the bordered solver, 0–3 s, with the chain's products of
    :mod:`ancf_jax._products`): 0.69 → 0.40 s."""
    b = a.shape[-1]
    if b == 4:
        return _inverse4(a)
    if b % 4 or b > ELEMENTWISE_INVERSE:
        return jnp.linalg.inv(a)
    ai = _inverse4(a[..., :4, :4])
    bb, cc = a[..., :4, 4:], a[..., 4:, :4]
    ai_b = _products.matmul(ai, bb)
    si = block_inverse(a[..., 4:, 4:] - _products.matmul(cc, ai_b))
    c_ai = _products.matmul(cc, ai)
    top_right = -_products.matmul(ai_b, si)
    top_left = ai - _products.matmul(top_right, c_ai)
    bottom_left = -_products.matmul(si, c_ai)
    return jnp.concatenate([jnp.concatenate([top_left, top_right], axis=-1),
                            jnp.concatenate([bottom_left, si], axis=-1)], axis=-2)


def factor_chain(t: BlockTridiagonal) -> ChainFactor:
    """Factor a block-tridiagonal matrix (see :class:`ChainFactor`)."""
    d0inv = block_inverse(t.diagonal[0])

    def body(dinv_prev, blk):
        d, low, up_prev = blk
        dp = d - _products.matmul(low, _products.matmul(dinv_prev, up_prev))
        dinv = block_inverse(dp)
        return dinv, dinv

    if t.n_blocks == 1:
        return ChainFactor(d0inv[None], t.upper, t.lower)
    _, dinvs = jax.lax.scan(body, d0inv, (t.diagonal[1:], t.lower, t.upper))
    dinv = jnp.concatenate([d0inv[None], dinvs])
    g = _products.matmul(dinv[:-1], t.upper)
    return ChainFactor(dinv, g, t.lower)


def solve_chain(f: ChainFactor, r):
    """Solve T x = r with the factors of :func:`factor_chain`; r shape (n·b,) or (n·b, k)."""
    n, b = f.dinv.shape[0], f.dinv.shape[-1]
    vec = r.ndim == 1
    rb = jnp.reshape(r, (n, b, -1))
    z0 = _products.matmul(f.dinv[0], rb[0])

    def fwd(z_prev, blk):
        dinv, low, ri = blk
        z = _products.matmul(dinv, ri - _products.matmul(low, z_prev))
        return z, z

    if n == 1:
        x = z0[None]
    else:
        _, zs = jax.lax.scan(fwd, z0, (f.dinv[1:], f.lower, rb[1:]))
        z = jnp.concatenate([z0[None], zs])

        def bwd(x_next, blk):
            zi, gi = blk
            x = zi - _products.matmul(gi, x_next)
            return x, x

        _, xs = jax.lax.scan(bwd, z[-1], (z[:-1], f.g), reverse=True)
        x = jnp.concatenate([xs, z[-1][None]])
    x = jnp.reshape(x, (n * b, -1))
    return x[:, 0] if vec else x


# ---------------------------------------------------------------------- dense LU
#: largest matrix that :func:`lu_factor` factors elementwise (without LAPACK) when XLA
#: compiles loops into kernels (:func:`ancf_jax._xla.loop_kernels`)
ELEMENTWISE_LU = 24


def _elementwise(n: int) -> bool:
    """Whether an n×n LU is factored and solved elementwise (:func:`lu_factor`)."""
    return n <= ELEMENTWISE_LU and _xla.loop_kernels()


def lu_factor(a):
    """LU factors with partial pivoting of a square matrix: ``(lu, permutation)``.

    Unlike ``jax.scipy.linalg.lu_factor`` this keeps the row permutation that the
    factorization computes, so a solve is one gather and two triangular solves; the
    scipy form stores LAPACK pivots and converts them to a permutation in every solve,
    a loop over the rows that dominated the Newton iterations of vmapped runs.

    LAPACK (``jax.lax.linalg.lu``) by default; with loop kernels on
    (:func:`ancf_jax._xla.loop_kernels`) matrices up to :data:`ELEMENTWISE_LU` are
    factored by :func:`lu_factor_elementwise`, as a LAPACK call keeps the loop around
    it (the Newton iteration) from becoming one kernel."""
    if _elementwise(a.shape[-1]):
        return lu_factor_elementwise(a)
    lu, _, perm = jax.lax.linalg.lu(a)
    return lu, perm


def lu_solve(factors, b):
    """Solve A x = b with ``factors = lu_factor(A)``; b shape (n,) or (n, k)."""
    lu, perm = factors
    vec = b.ndim == 1
    x = jnp.reshape(b, (b.shape[0], -1))[perm]
    if _elementwise(lu.shape[-1]):
        x = triangular_solve_elementwise(lu, x)
    else:
        x = jax.lax.linalg.triangular_solve(lu, x, left_side=True, lower=True, unit_diagonal=True)
        x = jax.lax.linalg.triangular_solve(lu, x, left_side=True, lower=False)
    return x[:, 0] if vec else x


def lu_factor_elementwise(a):
    """:func:`lu_factor` of an n×n matrix by Gaussian elimination with partial pivoting,
    unrolled over the n (static) columns in elementwise operations and products with
    unit vectors: no LAPACK call, no gather or scatter. Same factors as LAPACK's
    ``getrf`` (L unit lower and U in one array, rows permuted by ``perm``) up to
    rounding and the choice among equal pivots. For small n (the border of a saddle
    system): n stages of O(n²) work."""
    n = a.shape[-1]
    rows = jnp.arange(n)
    perm = rows
    for k in range(n):
        # the pivot: largest |a_ik| at or below the diagonal; swap rows k and p
        p = jnp.argmax(jnp.where(rows >= k, jnp.abs(a[:, k]), -1.0))
        e_k, e_p = (rows == k).astype(a.dtype), (rows == p).astype(a.dtype)
        row_k, row_p = a[k], e_p @ a
        a = a + jnp.outer(e_k - e_p, row_p - row_k)
        perm = jnp.where(rows == k, jnp.sum(jnp.where(rows == p, perm, 0)), jnp.where(rows == p, perm[k], perm))
        # eliminate below the pivot; the multipliers stored in column k
        below = rows > k
        lower = jnp.where(below, a[:, k] / a[k, k], 0.0)
        a = a - jnp.outer(lower, jnp.where(below, a[k], 0.0))
        a = jnp.where(below[:, None] & (rows == k)[None, :], lower[:, None], a)
    return a, perm


def triangular_solve_elementwise(lu, x):
    """Solve L U y = x with the factors of :func:`lu_factor_elementwise` (L unit lower),
    x shape (n, k), rows already permuted: forward and back substitution unrolled over
    the n columns in elementwise operations."""
    n = lu.shape[-1]
    rows = jnp.arange(n)[:, None]
    for k in range(n):
        x = x - jnp.where(rows > k, lu[:, k:k + 1], 0.0) * x[k]
    for k in range(n - 1, -1, -1):
        xk = x[k] / lu[k, k]
        x = jnp.where(rows == k, xk, x - jnp.where(rows < k, lu[:, k:k + 1], 0.0) * xk)
    return x


# ---------------------------------------------------------------------- saddle systems
class SaddleMatrix(eqx.Module):
    """A matrix in bordered form

        A = [[T, B], [C, E]]

    with T block tridiagonal (the beam chain, size n_c), B (n_c, n_b), C (n_b, n_c)
    and E (n_b, n_b) dense. The border holds rigid-body and sliding coordinates and
    the Lagrange multipliers of the joints. Solving costs O(n_c n_b b²) + O(n_b³):
    linear in the number of elements.

    Auxiliary unknowns. The last ``n_aux`` border rows and columns may hold auxiliary
    unknowns z that carry a low-rank term outside the block-tridiagonal pattern: a
    force element coupling coordinates P x (any elements, any bodies) with a local
    matrix A_f adds Pᵀ A_f P, written as z = A_f P x (rows [A_f P, −I]) and Pᵀ z in the
    rows of x (columns). The operator on the primary unknowns x (size ``size``) is the
    Schur complement of the −I block, A₁₁ + A₁₂ A₂₁: :meth:`matvec` and the solves act
    on x alone (z is eliminated); :meth:`to_dense` is the extended matrix.
    """

    chain: BlockTridiagonal | None
    b: jnp.ndarray
    c: jnp.ndarray
    e: jnp.ndarray
    n_aux: int = eqx.field(static=True, default=0)

    @property
    def chain_size(self) -> int:
        return 0 if self.chain is None else self.chain.size

    @property
    def size(self) -> int:
        """Number of primary unknowns (auxiliary ones excluded)."""
        return self.chain_size + self.e.shape[0] - self.n_aux

    def _extended_matvec(self, x):
        if self.chain is None:
            return self.e @ x
        n_c = self.chain.size
        xc, xb = x[:n_c], x[n_c:]
        return jnp.concatenate([self.chain.matvec(xc) + self.b @ xb, self.c @ xc + self.e @ xb])

    def matvec(self, x):
        """A x for x of size :attr:`size` (chain entries first), shape (size,)."""
        if not self.n_aux:
            return self._extended_matvec(x)
        z = self._extended_matvec(jnp.concatenate([x, jnp.zeros(self.n_aux, x.dtype)]))[-self.n_aux:]
        return self._extended_matvec(jnp.concatenate([x, z]))[:-self.n_aux]

    def to_dense(self):
        """The dense (extended) saddle-point matrix (for tests and small systems)."""
        if self.chain is None:
            return self.e
        top = jnp.concatenate([self.chain.to_dense(), self.b], axis=1)
        bottom = jnp.concatenate([self.c, self.e], axis=1)
        return jnp.concatenate([top, bottom], axis=0)

    def effective_dense(self):
        """The dense operator on the primary unknowns (auxiliary ones eliminated)."""
        a = self.to_dense()
        if not self.n_aux:
            return a
        n = self.size
        return a[:n, :n] + a[:n, n:] @ a[n:, :n]

    def with_low_rank(self, p, a):
        """This matrix plus pᵀ a p (p (k, size): the selection of the coupled
        unknowns in solver order; a (k, k)) as k auxiliary unknowns (class docstring)."""
        k = p.shape[0]
        if k == 0:
            return self
        n_c = self.chain_size
        n_prim_b = self.e.shape[0] - self.n_aux
        # split the existing border into primary and auxiliary parts
        b1, b2 = self.b[:, :n_prim_b], self.b[:, n_prim_b:]
        c1, c2 = self.c[:n_prim_b], self.c[n_prim_b:]
        e11, e12 = self.e[:n_prim_b, :n_prim_b], self.e[:n_prim_b, n_prim_b:]
        e21, e22 = self.e[n_prim_b:, :n_prim_b], self.e[n_prim_b:, n_prim_b:]
        pc, pb = p[:, :n_c], p[:, n_c:]
        ap_c, ap_b = a @ pc, a @ pb
        na = self.n_aux
        zeros = jnp.zeros
        b = jnp.concatenate([b1, b2, pc.T], axis=1)
        c = jnp.concatenate([c1, c2, ap_c], axis=0)
        e = jnp.block([[e11, e12, pb.T],
                       [e21, e22, zeros((na, k))],
                       [ap_b, zeros((k, na)), -jnp.eye(k, dtype=a.dtype)]])
        return SaddleMatrix(self.chain, b, c, e, n_aux=na + k)


class SaddleFactor(eqx.Module):
    """Factors of a :class:`SaddleMatrix` for repeated solves (Schur complement on the
    border, or dense LU when ``dense`` is set)."""

    chain: ChainFactor | None
    x: jnp.ndarray | None        # T⁻¹ B, (n_c, n_b)
    c: jnp.ndarray | None
    lu: tuple                    # LU of the Schur complement (or of the dense matrix)
    dense: bool = eqx.field(static=True, default=False)
    n_chain: int = eqx.field(static=True, default=0)
    n_aux: int = eqx.field(static=True, default=0)


def factor_saddle(a: SaddleMatrix, *, dense: bool = False,
                  chain_factor: ChainFactor | None = None) -> SaddleFactor:
    """Factor a bordered matrix: Schur complement (default) or dense LU.

    ``chain_factor`` reuses known factors of the chain block (e.g. of a constant mass).
    """
    n_c = a.chain_size
    if dense or n_c == 0:
        return SaddleFactor(None, None, None, lu_factor(a.to_dense()),
                            dense=True, n_chain=n_c, n_aux=a.n_aux)
    cf = factor_chain(a.chain) if chain_factor is None else chain_factor
    n_b = a.e.shape[0]
    if n_b == 0:
        return SaddleFactor(cf, jnp.zeros((n_c, 0)), a.c, (), dense=False, n_chain=n_c)
    x = solve_chain(cf, a.b)
    s = a.e - a.c @ x
    return SaddleFactor(cf, x, a.c, lu_factor(s), dense=False, n_chain=n_c, n_aux=a.n_aux)


def solve_symmetric_implicit(a: SaddleMatrix, f: SaddleFactor, r):
    """x = A⁻¹ r for a symmetric A with its factors f, differentiated implicitly.

    ``jax.lax.custom_linear_solve``: the derivative of x is dx = A⁻¹ (dr − dA x),
    one more solve with the same factors (held constant) and a product with dA from
    ``a.matvec``, instead of differentiating through the factorization (the reverse
    pass of an LU factorization costs several times the factorization).
    """
    fac = jax.lax.stop_gradient(f)
    return jax.lax.custom_linear_solve(a.matvec, r, lambda _, rhs: solve_saddle(fac, rhs), symmetric=True)


def solve_saddle(f: SaddleFactor, r):
    """Solve A x = r for r of size n_c + n_b (chain entries first), shape (n,) or (n, k);
    auxiliary unknowns (:class:`SaddleMatrix`) are eliminated: r and x have the size
    of the primary unknowns."""
    if f.n_aux:
        pad = jnp.zeros((f.n_aux,) + r.shape[1:], r.dtype)
        return _solve_saddle(f, jnp.concatenate([r, pad], axis=0))[:-f.n_aux]
    return _solve_saddle(f, r)


def _solve_saddle(f: SaddleFactor, r):
    if f.dense:
        return lu_solve(f.lu, r)
    n_c = f.n_chain
    rc, rb = r[:n_c], r[n_c:]
    y = solve_chain(f.chain, rc)
    if rb.shape[0] == 0:
        return y
    xb = lu_solve(f.lu, rb - f.c @ y)
    xc = y - f.x @ xb
    return jnp.concatenate([xc, xb], axis=0)


# ---------------------------------------------------------------------- solvers
class AbstractSaddleSolver(eqx.Module):
    """A linear solver for :class:`SaddleMatrix` operators (lineax style): ``init``
    factors an operator once, ``compute`` solves with the factors as often as needed.

    ``chain_factor``: known factors of the chain block (the constant beam mass), used
    by solvers that factor the chain separately. Why an argument, passed down from the
    integrators' ``prepare`` through :class:`~ancf_jax.newton.ModifiedNewton` (and not a
    field of the operator or a solver built per run): the factors are computed once per
    run from the system, outside the compiled step, while the operator is rebuilt at
    every linearization inside it, and the solver is part of the integrator, which is
    static configuration (a jit cache key, shared by every run and by vmapped systems
    of different masses). Moving the factors into a per-run solver would make it data
    of each run; it is left as an argument (review of issue 16).
    """

    @abc.abstractmethod
    def init(self, operator: SaddleMatrix, chain_factor: ChainFactor | None = None) -> SaddleFactor:
        """Factors of ``operator``."""

    def compute(self, factors: SaddleFactor, rhs):
        """x with A x = rhs (primary unknowns; shape (n,) or (n, k))."""
        return solve_saddle(factors, rhs)


class BorderedChainSolver(AbstractSaddleSolver):
    """Block Thomas on the beam chain and a dense LU of the border's Schur complement:
    O(n_c n_b b²) + O(n_b³), linear in the number of elements."""

    def init(self, operator, chain_factor=None):
        return factor_saddle(operator, dense=False, chain_factor=chain_factor)


class DenseLUSolver(AbstractSaddleSolver):
    """Dense LU with partial pivoting of the whole (extended) matrix: O(n³), for GPU
    batches, where one batched LU beats the chain's sequential scans, and for
    systems without a chain. (On the CPU the bordered solver is faster even for M1's
    38 unknowns: :mod:`ancf_jax.integrators.generalized_alpha`.)"""

    def init(self, operator, chain_factor=None):
        return factor_saddle(operator, dense=True)


class AutoSaddleSolver(AbstractSaddleSolver):
    """Chosen from the structure of the operator (static shapes): the bordered chain
    solver while the border (bodies, sliding coordinates, multipliers and the
    auxiliary unknowns of force elements) is smaller than the chain, else dense LU
    (no beams, or a force element coupling every coordinate)."""

    def select(self, operator: SaddleMatrix) -> AbstractSaddleSolver:
        """The solver used for ``operator``."""
        if operator.chain_size and operator.e.shape[0] < operator.chain_size:
            return BorderedChainSolver()
        return DenseLUSolver()

    def init(self, operator, chain_factor=None):
        return self.select(operator).init(operator, chain_factor)


#: the linear solvers by the names the scenario format and the CLI use
LINEAR_SOLVERS = {"auto": AutoSaddleSolver, "bordered": BorderedChainSolver, "dense": DenseLUSolver}


def linear_solver(name: str) -> AbstractSaddleSolver:
    """The linear solver called ``name`` (:data:`LINEAR_SOLVERS`)."""
    if name not in LINEAR_SOLVERS:
        raise ValueError(f"linear_solver must be one of {', '.join(LINEAR_SOLVERS)}, got {name!r}")
    return LINEAR_SOLVERS[name]()
