"""The one root finder of ancf_jax: a modified Newton method on structured operators.

Every nonlinear solve of the time integration, the position projection and statics
is F(x) = 0 with a Newton matrix that keeps the system's structure
(:class:`~ancf_jax.linalg.SaddleMatrix`, from :func:`ancf_jax.dae.iteration_matrix`).
:class:`ModifiedNewton` holds how it is solved, in the manner of optimistix's root
finders and diffrax's ``root_finder`` fields: the stopping rule, the refresh policy of
the matrix, and the linear solver (:class:`~ancf_jax.linalg.AbstractSaddleSolver`).

Refresh policy. The matrix is factored at the first iterate and reused while the
iteration contracts fast; it is refactored at the current iterate when a correction
shrinks by less than ``contraction`` (a strongly nonlinear solve falls back to full
Newton), every ``refresh_every`` iterations, and with ``refresh_first`` after the first
correction. ``contraction = 0`` refactors at every iteration (full Newton).
A caller may also pass the factors it holds (``factors``, e.g. those of the previous
time step, :class:`~ancf_jax.integrators.generalized_alpha.AcrossSteps`) and whether
they must be refreshed at the first iterate (``refresh``); the solution then returns
the factors in use at its end and the number of factorizations it made, for the
caller to keep. Modified Newton converges to the same root with any nonsingular
approximation of the matrix; only the rate of contraction differs, and the refresh
rules above catch a matrix that has become too stale.

Derivatives. :meth:`ModifiedNewton.root` gives the iteration a custom JVP
(:func:`jax.custom_jvp`, the closures' values made arguments), so ``jax.grad`` and
``jax.jvp`` differentiate the converged equations F(x*(θ), θ) = 0 (implicit function
theorem) rather than the iterations: ẋ = −(∂F/∂x)⁻¹ ∂F/∂θ θ̇, with the Newton matrix
factored at the solution x* and ``refinement`` steps of iterative refinement against
the exact linearization of F (none needed where the matrix is the exact Jacobian).
Reverse mode transposes these linear solves. (``jax.lax.custom_root`` hands its
tangent solver the linearization but not the solution, so the matrix could only be
factored at the initial iterate, and refinement was always needed.)
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.extend
import jax.numpy as jnp

from ._control import reached_by, run_if
from .linalg import AbstractSaddleSolver, AutoSaddleSolver


class NewtonSolution(eqx.Module):
    """Outcome of a root solve.

    Attributes:
        x: the last iterate.
        iterations: Newton iterations taken (int).
        converged: whether the stopping rule was met (bool).
        residual_norm: ``residual_norm`` of the residual at ``x``, the iterate returned
            (NaN when the solve was given no norm).
        factors: the factors of the Newton matrix in use at the end (only when the
            solve was given ``factors``; else None).
        factorizations: factorizations the solve made (int; only with ``factors``).
    """

    x: jnp.ndarray
    iterations: jnp.ndarray
    converged: jnp.ndarray
    residual_norm: jnp.ndarray
    factors: object = None
    factorizations: jnp.ndarray | None = None


def _as_float(tree):
    """Integer leaves (LU permutations) as floats: auxiliary outputs of
    :func:`jax.lax.custom_root` must be floating point (exact below 2⁵³)."""
    return jax.tree.map(lambda a: a if jnp.issubdtype(a.dtype, jnp.floating) else a.astype(float), tree)


def _like(tree, template):
    """Leaves of ``tree`` in the dtypes of ``template`` (undoes :func:`_as_float`)."""
    return jax.tree.map(lambda a, t: a.astype(t.dtype), tree, template)


def _hoisted(fn, x):
    """(g, consts) with ``g(x, *consts) == fn(x)``: every value ``fn`` closes over
    (traced or not, of any dtype) made an argument (``jax.closure_convert`` keeps
    integer tracers in the closure, which a custom JVP cannot take)."""
    closed, out_shape = jax.make_jaxpr(fn, return_shape=True)(x)
    out_tree = jax.tree.structure(out_shape)

    def g(x, *consts):
        call = jax.extend.core.jaxpr_as_fun(jax.extend.core.ClosedJaxpr(closed.jaxpr, list(consts)))
        return jax.tree.unflatten(out_tree, call(*jax.tree.leaves(x)))

    return g, tuple(closed.consts)


class ModifiedNewton(eqx.Module):
    """Modified Newton method with a refresh policy (module docstring).

    Attributes:
        tolerance: converged when max |Δx| over the first ``size`` unknowns (the
            coordinates, not the multipliers) is at most ``tolerance · scale`` [m or -].
        max_iterations: iterations before the solve counts as not converged.
        refresh_every: refactor after this many iterations without convergence.
        contraction: refactor at the current iterate when a correction is larger than
            this fraction of the previous one (0: at every iteration, full Newton).
        refresh_first: also refactor after the first correction.
        residual_tolerance: also converged when ``residual_norm(F(x))`` is at most
            this (only for solves given a ``residual_norm``).
        max_backtracks: where F(x) is not finite, retreat halfway towards the last
            iterate with a finite residual, at most this many times in a row (each
            counts as an iteration; 0: no retreat, the solve fails).
        linear_solver: solver of the Newton systems.
    """

    tolerance: float = eqx.field(static=True, default=1e-10)
    max_iterations: int = eqx.field(static=True, default=16)
    refresh_every: int = eqx.field(static=True, default=6)
    contraction: float = eqx.field(static=True, default=0.25)
    refresh_first: bool = eqx.field(static=True, default=False)
    residual_tolerance: float = eqx.field(static=True, default=0.0)
    max_backtracks: int = eqx.field(static=True, default=0)
    linear_solver: AbstractSaddleSolver = AutoSaddleSolver()

    def factor(self, linearize, x, chain_factor=None):
        """Factors of the Newton matrix ``linearize(x)`` (held constant in derivatives)."""
        return jax.lax.stop_gradient(self.linear_solver.init(linearize(x), chain_factor))

    def solve(self, residual, linearize, x0, *, size: int, chain_factor=None, scale=1.0,
              residual_norm=None, factors=None, refresh=True) -> NewtonSolution:
        """Solve residual(x) = 0 from x0.

        Args:
            residual: x ↦ F(x), shape (N,) (solver order of the operator).
            linearize: x ↦ :class:`~ancf_jax.linalg.SaddleMatrix` ∂F/∂x (or an
                approximation: modified Newton converges to the same root).
            x0: initial iterate, shape (N,).
            size: the leading unknowns whose correction decides convergence.
            chain_factor: known factors of the operator's chain block, if constant
                (the beam mass of a projection).
            scale: scale of the unknowns for the step tolerance (may be traced).
            residual_norm: F ↦ scalar, for ``residual_tolerance`` and
                ``max_backtracks`` (non-finite norm: retreat), and reported at the
                iterate returned: the loop makes one more pass, which evaluates the
                residual there and changes nothing (one residual in the program, not
                a second copy after the loop).
            factors: factors of an approximation of the Newton matrix to start with
                (a pytree as ``linear_solver.init`` returns; None: factor at x0).
            refresh: with ``factors``: factor at x0 instead (bool, may be traced).
        """
        kept = factors is not None
        # the factorization traced once, as a jaxpr with its closure hoisted: the shapes of
        # its factors (for the loop's carry) and the loop body's refactorization both come
        # from it (tracing the Newton matrix of a system twice cost ~0.4 s of the M1 chunk
        # program's 1.4 s of tracing)
        jaxpr, fac_shape = jax.make_jaxpr(lambda x: self.factor(linearize, x, chain_factor), return_shape=True)(x0)
        factor_flat = jax.extend.core.jaxpr_as_fun(jaxpr)

        def factor(x):
            return jax.tree.unflatten(jax.tree.structure(fac_shape), factor_flat(x))

        if kept:
            fac0, refresh0 = factors, jnp.asarray(refresh)
        else:
            fac0 = jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype), fac_shape)
            refresh0 = jnp.array(True)
        guarded = residual_norm is not None

        def going(c):
            return (~c["done"]) & (c["it"] < self.max_iterations) & (c["back"] <= self.max_backtracks)

        def cond(c):
            # guarded: a last pass evaluates the residual at the iterate returned
            return ~c["final"] if guarded else going(c)

        def body(c):
            x = c["x"]
            r = residual(x)
            out = dict(c, it=c["it"] + 1)
            if guarded:
                rn = residual_norm(r)
                ok = jnp.isfinite(rn)
                out["rn"] = rn
                last = ~going(c)  # the last pass: the residual at x only
            else:
                ok = jnp.array(True)
            # the matrix is factored inside the loop (first iteration and refreshes), so
            # the factorization is traced and compiled once
            fresh = c["refresh"] & ok & ~last if guarded else c["refresh"] & ok
            fac = run_if(fresh, lambda _: factor(x), c["fac"])
            out["nf"] = c["nf"] + fresh.astype(jnp.int32)
            dx = self.linear_solver.compute(fac, -r)
            x_new = x + dx
            err = jnp.max(jnp.abs(dx[:size]))
            done = (err <= self.tolerance * scale) & jnp.all(jnp.isfinite(x_new))
            if guarded and self.residual_tolerance > 0.0:
                done = done | (ok & (rn <= self.residual_tolerance))
            # contraction 0: full Newton (0 · ∞ at the first iteration would read as "fast")
            slow = (err > self.contraction * c["err"]) if self.contraction > 0.0 else jnp.array(True)
            refresh = slow | ((c["it"] + 1) % self.refresh_every == 0) | ((c["it"] == 0) & self.refresh_first)
            if guarded and self.max_backtracks:
                # a non-finite residual at x: retreat halfway towards the last good iterate
                # (same correction, half the length); the factors stay those of x_good
                half = 0.5 * c["a"]
                x_new = jnp.where(ok, x_new, c["x_good"] + half * c["dx"])
                out.update(x_good=jnp.where(ok, x, c["x_good"]), dx=jnp.where(ok, dx, c["dx"]),
                           a=jnp.where(ok, 1.0, half), back=jnp.where(ok, 0, c["back"] + 1))
                done = done & ok
                refresh = jnp.where(ok, refresh, c["refresh"])
                err = jnp.where(ok, err, c["err"])
                fac = jax.tree.map(lambda f, g: jnp.where(ok, f, g), fac, c["fac"])
            out.update(x=x_new, fac=fac, done=done, err=err, refresh=refresh)
            if guarded:
                # the last pass keeps everything but rn; the factors are its own already (no
                # refactorization there), so they are not selected (megabytes for long wires)
                kept = dict(c, rn=rn, final=jnp.array(True))
                out = dict(out, final=jnp.array(False))
                out = {k: v if k == "fac" else jax.tree.map(lambda a, b: jnp.where(last, a, b), kept[k], v)
                       for k, v in out.items()}
            return out

        zero = jnp.zeros((), jnp.int32)
        init = dict(x=x0, fac=fac0, it=zero, done=jnp.array(False), err=jnp.array(jnp.inf),
                    refresh=refresh0, rn=jnp.array(jnp.nan), back=zero, nf=zero)
        if guarded:
            init["final"] = jnp.array(False)
        if guarded and self.max_backtracks:
            init.update(x_good=x0, dx=jnp.zeros_like(x0), a=jnp.array(1.0))
        # batched (under vmap) wherever x0 is from the first pass (_control.reached_by);
        # the factors, constant in derivatives, get no tangent
        init = dict(reached_by({k: a for k, a in init.items() if k != "fac"}, x0),
                    fac=reached_by(init["fac"], x0, tangents=False))
        c = jax.lax.while_loop(cond, body, init)
        if kept:
            return NewtonSolution(c["x"], c["it"], c["done"], c["rn"], c["fac"], c["nf"])
        return NewtonSolution(c["x"], c["it"], c["done"], c["rn"])

    def root(self, residual, linearize, x0, *, size: int, implicit: bool = True,
             refinement: int = 4, chain_factor=None, factors=None, refresh=True,
             tangent_linearize=None) -> NewtonSolution:
        """:meth:`solve`, differentiated implicitly when ``implicit`` (module docstring).

        The tangent systems J ẋ = −∂F/∂θ θ̇ are solved with ``linearize`` (or
        ``tangent_linearize``) factored at the solution, then ``refinement`` steps of
        iterative refinement against the exact Jacobian of ``residual`` (by
        ``jax.linearize``). Where the matrix factored is the exact Jacobian (the
        generalized-α step at index 3), ``refinement = 0`` gives the exact derivative,
        and nothing of the residual's linearization is kept for reverse mode; an
        approximate matrix (the projection without its curvature term, the index-2
        step) needs the refinement steps.

        ``tangent_linearize``: the matrix the tangent solves factor at the solution
        instead of ``linearize`` (same signature and structure, and the same chain
        block where a ``chain_factor`` is given), e.g. the exact Jacobian where the
        iteration converges with a cheaper approximation of it: the tangents are then
        exact with ``refinement = 0``, and the iteration keeps its cheap matrix.

        ``factors`` and ``refresh`` as for :meth:`solve`: they serve the forward
        iteration only."""
        kw = dict(size=size, chain_factor=chain_factor, factors=factors, refresh=refresh)
        if not implicit:
            return self.solve(residual, linearize, x0, **kw)
        # the closures' traced values as explicit arguments (custom_jvp differentiates
        # arguments only): F(x, θ) and the matrix's own arguments
        res_fn, res_consts = _hoisted(residual, x0)
        lin_fn, lin_consts = _hoisted(linearize, x0)
        own_tangent = tangent_linearize is not None
        tan_fn, tan_consts = _hoisted(tangent_linearize, x0) if own_tangent else (lin_fn, ())
        kept = factors is not None

        def run(x0, held, refresh, res_consts, lin_consts):
            sol = self.solve(lambda x: res_fn(x, *res_consts), lambda x: lin_fn(x, *lin_consts), x0,
                             size=size, chain_factor=held[0], factors=held[1], refresh=refresh)
            # integer and boolean outputs travel as floats (their tangents are zeros)
            aux = (sol.iterations.astype(float), sol.converged.astype(float))
            if kept:
                aux += (sol.factorizations.astype(float), _as_float(sol.factors))
            return sol.x, aux

        @jax.custom_jvp
        def implicit_root(x0, held, refresh, res_consts, lin_consts, tan_consts):
            return run(x0, held, refresh, res_consts, lin_consts)

        @implicit_root.defjvp
        def implicit_root_jvp(primals, tangents):
            x0, held, refresh, res_consts, lin_consts, tan_consts = primals
            x, aux = run(*primals[:5])
            # ∂F/∂x ẋ = −∂F/∂θ θ̇ at the solution; x0's and the factors' tangents do not
            # enter (the root does not depend on them)
            _, rhs = jax.jvp(lambda c: res_fn(x, *c), (tuple(res_consts),), (tuple(tangents[3]),))
            consts = tan_consts if own_tangent else lin_consts
            fac = self.factor(lambda z: tan_fn(z, *consts), jax.lax.stop_gradient(x), held[0])
            dx = self.linear_solver.compute(fac, -rhs)
            if refinement:
                _, jac = jax.linearize(lambda z: res_fn(z, *jax.lax.stop_gradient(res_consts)), x)

                def refine(_, d):
                    return d + self.linear_solver.compute(fac, -rhs - jac(d))

                dx = jax.lax.fori_loop(0, refinement, refine, dx)
            return (x, aux), (dx, jax.tree.map(jnp.zeros_like, aux))

        held = jax.lax.stop_gradient((chain_factor, factors))
        x, aux = implicit_root(x0, held, jnp.asarray(refresh), res_consts, lin_consts, tan_consts)
        aux = jax.lax.stop_gradient(aux)
        iters, conv = aux[0].astype(jnp.int32), aux[1] > 0.5
        if not kept:
            return NewtonSolution(x, iters, conv, jnp.array(jnp.nan))
        return NewtonSolution(x, iters, conv, jnp.array(jnp.nan), _like(aux[3], factors),
                              aux[2].astype(jnp.int32))
