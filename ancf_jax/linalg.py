"""Structured matrices of the assembled system.

The beam coordinates of a chain of ANCF elements couple only neighbouring nodes, so
every beam matrix (mass, stiffness, damping, the iteration matrix of an implicit
integrator) is block tridiagonal with 4×4 node blocks. :class:`BlockTridiagonal` stores
such a matrix in O(n) memory; the border (rigid bodies, sliding coordinates,
constraints) is handled by a Schur complement in the solvers.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp


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
        return BlockTridiagonal(c * self.diagonal, c * self.lower, c * self.upper)

    def add_diagonal(self, d):
        """Add a diagonal (vector of length n·b)."""
        n, b = self.n_blocks, self.block_size
        dd = jax.vmap(jnp.diag)(jnp.reshape(d, (n, b)))
        return BlockTridiagonal(self.diagonal + dd, self.lower, self.upper)

    def matvec(self, x):
        n, b = self.n_blocks, self.block_size
        xb = jnp.reshape(x, (n, b))
        y = jnp.einsum("nij,nj->ni", self.diagonal, xb)
        y = y.at[1:].add(jnp.einsum("nij,nj->ni", self.lower, xb[:-1]))
        y = y.at[:-1].add(jnp.einsum("nij,nj->ni", self.upper, xb[1:]))
        return jnp.reshape(y, (n * b,))

    def to_dense(self):
        n, b = self.n_blocks, self.block_size
        a = jnp.zeros((n, b, n, b))
        idx = jnp.arange(n)
        a = a.at[idx, :, idx, :].set(self.diagonal)
        a = a.at[idx[1:], :, idx[:-1], :].set(self.lower)
        a = a.at[idx[:-1], :, idx[1:], :].set(self.upper)
        return jnp.reshape(a, (n * b, n * b))
