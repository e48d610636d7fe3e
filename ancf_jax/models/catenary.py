"""Railway catenaries and pantographs (issue 21): the builder, the design equilibrium
by hand, a lumped-mass pantograph and the contact-force statistics of EN 50318.

A simple catenary is two pre-tensioned wires along the track: the *messenger* hung
from the poles, the *contact wire* hung from the messenger by *droppers*
(tension-only), held sideways at the poles by *steady arms*. :func:`add_catenary`
adds one to a :class:`~ancf_jax.model.Model`:

* both wires are ANCF beams meshed with nodes at the same x (the poles, every
  dropper, equal elements in between no longer than ``element_length``), so the
  solver lays them side by side (:class:`~ancf_jax.linalg.InterleavedChain`) and
  every dropper enters the block-tridiagonal chain: the cost per step is linear in the
  element count whatever the number of droppers;
* the wires start in the design equilibrium computed by hand
  (:func:`design_equilibrium`): each wire a taut string of horizontal tension H under
  its weight w = ρA g and point loads, parabolic between its supports, the contact
  wire at its design height (pre-sag) at the droppers, the messenger at its design
  height at the poles. The stress-free length of every element follows from the
  tension along it, N = H √(1 + y'²), with engineering axial strain
  (ε = N / EA), and each dropper's rest length from its design force; the static
  solve of the assembled model then adds what the string model leaves out (bending
  stiffness, the pantograph's uplift);
* the ends of both wires are pinned at the first and last poles; the messenger rests
  on the intermediate poles on vertical support springs and the contact wire on
  steady-arm springs, both stressed so that they carry the design reactions
  (the steady arms carry none: the contact wire hangs from its droppers).

:func:`add_pantograph` adds a lumped-mass current collector (a
:meth:`~ancf_jax.model.Model.lumped_chain` moving at the train speed) in unilateral
penalty contact with the contact wire (:meth:`~ancf_jax.model.Model.contact`);
:func:`contact_statistics` computes the statistics of EN 50318 from the contact
force: low-pass filtered at 20 Hz, over the evaluated spans, mean, standard
deviation, statistical maximum and minimum (mean ± 3σ), actual maximum and minimum,
and the share of time without contact.

Model data and their sources: docs/pantograph-catenary.md.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..element.strain_energy import Formulation
from ..errors import ModelError
from ..functions import ConstantSpeed
from ..mesh import through_points
from ..section import Section
from ..simulation import DEFAULT_SOLVER

#: acceleration of gravity used by the design equilibrium [m/s²] (the model's gravity
#: must be (0, −G) for the design state to be in equilibrium)
G = 9.81
#: the axial strain measure of the wires (N = EA ε, as the design equilibrium assumes)
WIRE_FORMULATION = Formulation(axial_strain="engineering")
#: low-pass cut-off [Hz] of the contact-force statistics (EN 50318: 20 Hz)
CUTOFF = 20.0
#: default step [s] of :func:`run_pantograph_catenary`: this model's own convergence
#: study (docs/pantograph-catenary.md: with 0.5 m elements, 0.75 N RMS from the
#: reference, the mesh's error dominating; 1 ms until 2026-12-06), not
#: :data:`ancf_jax.integrate.DEFAULT_DT` (M1's and M2's)
RUN_DT = 2e-3


# ---------------------------------------------------------------------- data
@dataclasses.dataclass(frozen=True)
class Wire:
    """A pre-tensioned wire.

    Attributes:
        tension: horizontal tension H of the design state [N] > 0.
        mass_per_length: ρA [kg/m] > 0.
        axial_stiffness: EA [N] > 0.
        bending_stiffness: EI [N·m²] > 0.
    """

    tension: float
    mass_per_length: float
    axial_stiffness: float
    bending_stiffness: float

    def check(self, name: str) -> None:
        for field in dataclasses.fields(self):
            v = getattr(self, field.name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ModelError(f"{name}.{field.name} must be a finite number > 0, got {v!r}")


@dataclasses.dataclass(frozen=True)
class CatenaryDesign:
    """A simple catenary of equal spans (all lengths in m, x along the track from the
    first pole).

    Attributes:
        spans: number of spans (>= 1).
        span_length: distance between poles.
        height: contact-wire height at the poles (design, before sag and pre-sag).
        encumbrance: height of the messenger above the contact wire at the poles.
        presag: design sag of the contact wire at mid-span (a parabola through the
            droppers, 0: level) [m] >= 0.
        droppers: dropper positions within a span, from its first pole, increasing,
            inside (0, span_length).
        dropper_stiffness: axial stiffness of a dropper in tension [N/m] > 0 (slack
            in compression).
        dropper_damping: axial damping of a dropper while taut [N·s/m] >= 0.
        dropper_mass: mass of a dropper [kg] >= 0, half lumped at each end.
        contact_clamp_mass, messenger_clamp_mass: dropper clamps [kg] >= 0.
        contact, messenger: the wires.
        support_stiffness: vertical stiffness of the messenger's intermediate supports
            [N/m] > 0.
        steady_arm_stiffness: vertical stiffness of a steady arm at each intermediate
            pole [N/m] >= 0 (0: none).
        steady_arm_mass: mass of a steady arm at the contact wire [kg] >= 0.
        element_length: longest element [m] > 0 (elements are equal between
            consecutive poles and droppers).
        alpha, beta: Rayleigh damping of both wires, C = αM + βK [1/s, s] >= 0.
    """

    spans: int = 10
    span_length: float = 60.0
    height: float = 5.3
    encumbrance: float = 1.2
    presag: float = 0.0
    droppers: tuple = (5.0, 10.5, 17.0, 23.5, 30.0, 36.5, 43.0, 49.5, 55.0)
    dropper_stiffness: float = 1.0e5
    dropper_damping: float = 0.0
    dropper_mass: float = 0.117
    contact_clamp_mass: float = 0.165
    messenger_clamp_mass: float = 0.195
    contact: Wire = Wire(20.0e3, 1.35, 1.2e7, 195.0)
    messenger: Wire = Wire(16.0e3, 1.07, 7.0e6, 131.7)
    support_stiffness: float = 5.0e4
    steady_arm_stiffness: float = 300.0
    steady_arm_mass: float = 0.0
    element_length: float = 0.5
    alpha: float = 0.0
    beta: float = 0.0

    @property
    def length(self) -> float:
        """Length of the line between the first and last poles [m]."""
        return self.spans * self.span_length

    def check(self) -> None:
        """Raise a one-line :class:`~ancf_jax.errors.ModelError` for bad data."""
        if isinstance(self.spans, bool) or not isinstance(self.spans, (int, np.integer)) or self.spans < 1:
            raise ModelError(f"catenary spans must be an integer >= 1, got {self.spans!r}")
        positive = ("span_length", "height", "encumbrance", "dropper_stiffness", "support_stiffness",
                    "element_length")
        nonneg = ("presag", "dropper_damping", "dropper_mass", "contact_clamp_mass", "messenger_clamp_mass",
                  "steady_arm_stiffness", "steady_arm_mass", "alpha", "beta")
        for name in positive + nonneg:
            v = getattr(self, name)
            ok = isinstance(v, (int, float)) and math.isfinite(v) and (v > 0 if name in positive else v >= 0)
            if not ok:
                raise ModelError(f"catenary {name} must be a finite number {'> 0' if name in positive else '>= 0'}, "
                                 f"got {v!r}")
        d = np.asarray(self.droppers, float)
        if d.ndim != 1 or d.size < 1 or np.any(np.diff(d) <= 0) or d[0] <= 0 or d[-1] >= self.span_length:
            raise ModelError(f"catenary droppers must be increasing positions inside (0, {self.span_length:g}) m, "
                             f"got {list(self.droppers)}")
        self.contact.check("catenary contact")
        self.messenger.check("catenary messenger")


@dataclasses.dataclass(frozen=True)
class PantographDesign:
    """A lumped-mass current collector, masses from the bottom (frame) to the top
    (head, the one in contact).

    Attributes:
        masses: m_i [kg] > 0.
        stiffness: k_i [N/m] >= 0 of the stage below each mass (stage 1: to the roof).
        damping: c_i [N·s/m] >= 0 likewise.
        uplift: static uplift force F₀ on the bottom mass [N] > 0 (the pantograph's
            masses carry no weight: the uplift is the net static force, the mean
            contact force at rest).
        aero_coefficient: aerodynamic uplift coefficient c_aero [N/(m/s)²], finite
            (negative: a downforce): the uplift at speed v is F₀ + c_aero v² (EN 50367's
            form of the mean contact force; e.g. its AC curve 70 + 0.00097 v² with v in
            km/h is c_aero = 0.00097 · 3.6² = 0.0126 N/(m/s)²). Default 0: no
            aerodynamic part.
        contact_stiffness: penalty stiffness of the head–wire contact [N/m] > 0.
        contact_damping: its damping [N·s/m] >= 0.
        spacing: height of each mass above the one below (above the roof for the
            first) in the unstressed chain [m] > 0.
    """

    masses: tuple = (6.0, 9.0, 7.5)
    stiffness: tuple = (160.0, 15500.0, 7000.0)
    damping: tuple = (0.0, 0.0, 0.0)
    uplift: float = 100.0
    aero_coefficient: float = 0.0
    contact_stiffness: float = 5.0e4
    contact_damping: float = 0.0
    spacing: float = 0.5

    def check(self) -> None:
        n = len(self.masses)
        if n < 1 or len(self.stiffness) != n or len(self.damping) != n:
            raise ModelError(f"pantograph masses, stiffness and damping need one value per mass, got "
                             f"{len(self.masses)}, {len(self.stiffness)}, {len(self.damping)}")
        for label, vals, pos in (("masses", self.masses, True), ("stiffness", self.stiffness, False),
                                 ("damping", self.damping, False)):
            for v in vals:
                if not (math.isfinite(v) and (v > 0 if pos else v >= 0)):
                    raise ModelError(f"pantograph {label} must be finite and {'> 0' if pos else '>= 0'}, "
                                     f"got {list(vals)}")
        for name, pos in (("uplift", True), ("contact_stiffness", True), ("contact_damping", False),
                          ("spacing", True)):
            v = getattr(self, name)
            if not (math.isfinite(v) and (v > 0 if pos else v >= 0)):
                raise ModelError(f"pantograph {name} must be finite and {'> 0' if pos else '>= 0'}, got {v!r}")
        if not (isinstance(self.aero_coefficient, (int, float)) and math.isfinite(self.aero_coefficient)):
            raise ModelError(f"pantograph aero_coefficient must be a finite number [N/(m/s)^2], got "
                             f"{self.aero_coefficient!r}")

    def total_uplift(self, speed):
        """F₀ + c_aero v² [N] at speed v [m/s] (a number or traced data)."""
        return self.uplift + self.aero_coefficient * speed ** 2


# ---------------------------------------------------------------------- design by hand
@dataclasses.dataclass(frozen=True)
class DesignEquilibrium:
    """The catenary's design state by hand (:func:`design_equilibrium`).

    Attributes:
        x: node positions along the track, shape (n + 1,) (both wires).
        contact_nodes, messenger_nodes: the wires' nodal coordinates (x, y, r'),
            shape (n + 1, 4) (r' = dr/ds₀, s₀ the unstretched arc length).
        contact_rest, messenger_rest: stress-free element lengths, shape (n,).
        dropper_nodes: node index of each dropper, shape (d,).
        dropper_force: dropper tensions [N] (at the contact-wire end), shape (d,).
        dropper_length: dropper lengths [m], shape (d,).
        pole_nodes: node index of each pole, shape (spans + 1,).
        support_force: upward reaction of the messenger at each pole [N], shape
            (spans + 1,) (the end poles: the pinned ends' vertical reactions).
        contact_end_force: upward reaction at each pinned end of the contact wire
            [N], shape (2,).
    """

    x: np.ndarray
    contact_nodes: np.ndarray
    messenger_nodes: np.ndarray
    contact_rest: np.ndarray
    messenger_rest: np.ndarray
    dropper_nodes: np.ndarray
    dropper_force: np.ndarray
    dropper_length: np.ndarray
    pole_nodes: np.ndarray
    support_force: np.ndarray
    contact_end_force: np.ndarray


def _mesh_x(design: CatenaryDesign):
    """Node x of both wires, with the poles and droppers as nodes; the node index of
    each pole and dropper."""
    poles = design.span_length * np.arange(design.spans + 1)
    drops = (poles[:-1, None] + np.asarray(design.droppers, float)[None, :]).reshape(-1)
    keys = np.unique(np.concatenate([poles, drops]))
    xs = [keys[:1]]
    for a, b in zip(keys[:-1], keys[1:]):
        n = max(1, math.ceil((b - a) / design.element_length - 1e-9))
        xs.append(a + (b - a) * np.arange(1, n + 1) / n)
    x = np.concatenate(xs)
    x[-1] = keys[-1]
    index = lambda v: np.searchsorted(x, v - 1e-9)  # noqa: E731
    return x, index(poles), index(drops)


# An elastic catenary segment (Irvine, Cable Structures, 1981, §2.3): a string of
# weight w per unstretched length, axial stiffness EA (N = EA ε, engineering strain),
# horizontal tension H and vertical tension component V_a at its start, at the
# unstretched arc length s₀ from the start:
#   T_y = V_a + w s₀,  T = √(H² + T_y²),
#   x = H s₀ / EA + (H / w) (asinh(T_y / H) − asinh(V_a / H)),
#   y = (V_a s₀ + w s₀² / 2) / EA + (T − T_a) / w,
# and dr/ds₀ = (H, T_y) (1 / T + 1 / EA), the ANCF gradient r' of the stressed wire.
def _catenary(h, va, w, ea, s0):
    """(x, y, x', y') of an elastic catenary segment at unstretched arc length s0."""
    ty = va + w * s0
    t, ta = np.hypot(h, ty), np.hypot(h, va)
    x = h * s0 / ea + (h / w) * (np.arcsinh(ty / h) - np.arcsinh(va / h))
    y = (va * s0 + 0.5 * w * s0 * s0) / ea + (t - ta) / w
    g = 1.0 / t + 1.0 / ea
    return x, y, h * g, ty * g


def _s0_at(h, va, w, ea, x):
    """Unstretched arc length at which the segment reaches horizontal distance x
    (Newton's method from s₀ = x, ``scipy.optimize.newton``, elementwise; to steps of
    1e-13 (1 + |x|): x(s₀) carries rounding of (H/w)·ε ~ 1e-14 m, which Newton's steps
    cannot go below)."""
    from scipy.optimize import newton
    x = np.asarray(x, float)
    s0 = newton(lambda s: _catenary(h, va, w, ea, s)[0] - x, x.copy(), lambda s: _catenary(h, va, w, ea, s)[2],
                tol=1e-13 * (1 + np.max(np.abs(x), initial=0.0)), rtol=1e-13, maxiter=50)
    return np.reshape(s0, x.shape)


def _span_between(h, w, ea, dx, dy):
    """(V_a, s₀ length) of the segment joining two points dx, dy apart (MINPACK's
    hybrid Newton method, ``scipy.optimize.root``, from the parabola)."""
    from scipy.optimize import root

    def residual(z):
        va, s0 = z
        x, y, xs, ys = _catenary(h, va, w, ea, s0)
        ty = va + w * s0
        t, ta = math.hypot(h, ty), math.hypot(h, va)
        jac = np.array([[(h / w) * (1 / t - 1 / ta), xs], [s0 / ea + (ty / t - va / ta) / w, ys]])
        return np.array([x - dx, y - dy]), jac

    guess = [h * dy / dx - 0.5 * w * dx, math.hypot(dx, dy) / (1 + h / ea)]
    sol = root(residual, guess, jac=True, method="hybr", options=dict(xtol=1e-13))
    if not sol.success:
        raise ModelError(f"catenary segment over dx = {dx:g} m, dy = {dy:g} m: {sol.message}")
    return float(sol.x[0]), float(sol.x[1])


class _Wire:
    """Segments of one wire between key points: start x, V_a and s₀ length each."""

    def __init__(self, wire: Wire, key_x, key_y0, segments):
        self.wire, self.key_x, self.y0 = wire, np.asarray(key_x, float), float(key_y0)
        self.va = np.array([v for v, _ in segments])
        self.s0 = np.array([l for _, l in segments])

    @property
    def w(self):
        """Weight per unstretched length [N/m]."""
        return self.wire.mass_per_length * G

    def end_vertical(self):
        """T_y at the end of each segment."""
        return self.va + self.w * self.s0

    def key_y(self):
        _, dy, _, _ = _catenary(self.wire.tension, self.va, self.w, self.wire.axial_stiffness, self.s0)
        return self.y0 + np.concatenate([[0.0], np.cumsum(dy)])

    def shape(self, x, point_forces):
        """Heights and slopes dy/dx at x, with the bending boundary layers of the
        point forces (upward [N], one per interior key point): a taut wire of bending
        stiffness EI rounds the kink of a point force F over λ = √(EI / H), passing
        F λ / (2H) below the string's apex (the exact solution of
        H y″ − EI y⁗ = −F δ(x − x_k) on a long span is the string plus
        −(F λ / 2H) exp(−|x − x_k| / λ)). Without it the far field shifts by the
        rounding at the poles (4 mm for a messenger's support)."""
        x = np.asarray(x, float)
        k = np.clip(np.searchsorted(self.key_x, x, side="right") - 1, 0, len(self.va) - 1)
        h, w, ea = self.wire.tension, self.w, self.wire.axial_stiffness
        s0 = _s0_at(h, self.va[k], w, ea, x - self.key_x[k])
        _, y, xs, ys = _catenary(h, self.va[k], w, ea, s0)
        y = self.key_y()[k] + y
        slope = ys / xs
        # at an interior key point: the mean of both sides (the apex of the rounding)
        inner = np.flatnonzero(np.isin(x, self.key_x[1:-1]))
        kk = k[inner]
        slope[inner] = 0.5 * (self.va[kk - 1] + w * self.s0[kk - 1] + self.va[kk]) / h
        lam = math.sqrt(self.wire.bending_stiffness / h)
        for xk, f in zip(self.key_x[1:-1], point_forces):
            decay = np.exp(-np.abs(x - xk) / lam)
            y = y - f * lam / (2 * h) * decay
            slope = slope + f / (2 * h) * np.sign(x - xk) * decay
        return y, slope

    def nodes(self, x, point_forces):
        """Nodal coordinates (n + 1, 4) at the nodes x (positions and ANCF gradients
        r' = (1 + ε) t, ε = N / EA, N = H √(1 + y'²)) and the stress-free element
        lengths ∫ √(1 + y'²) / (1 + ε) dx (composite Gauss, fine enough for the
        boundary layers: the rounding shortens the wire, and the tension with it)."""
        h, ea = self.wire.tension, self.wire.axial_stiffness
        y, slope = self.shape(x, point_forces)
        root = np.hypot(1.0, slope)
        gradient = (1 + h * root / ea)[:, None] * np.column_stack([np.ones_like(slope), slope]) / root[:, None]
        g, gw = np.polynomial.legendre.leggauss(6)
        sub = 8
        a = x[:-1, None] + (x[1:] - x[:-1])[:, None] * np.arange(sub)[None, :] / sub   # (n, sub)
        half = 0.5 * (x[1:] - x[:-1])[:, None, None] / sub
        pts = a[:, :, None] + half * (1 + g[None, None, :])
        _, sl = self.shape(pts.reshape(-1), point_forces)
        r = np.hypot(1.0, sl).reshape(pts.shape)
        rest = np.sum(half[..., 0] * ((r / (1 + h * r / ea)) @ gw), axis=1)
        return np.column_stack([x, y, gradient]), rest


def design_equilibrium(design: CatenaryDesign) -> DesignEquilibrium:
    """The catenary's static design state, by hand: both wires elastic catenaries
    between their key points (Irvine's closed form, above), with H the given
    horizontal tensions, and the bending boundary layer of every point force
    (``_Wire.at``).

    Contact wire: at the droppers at ``height`` less the pre-sag parabola
    4 p ξ(1 − ξ) over each span, pinned at ``height`` at both end poles, carried by
    the droppers alone; each segment between key points is the catenary through
    both (a 2×2 nonlinear solve, ``scipy.optimize.root``, for its V_a and unstretched
    length). Dropper j pulls it up with F_j = T_y⁻ − T_y⁺ + m_j g (the vertical
    tension components just left and right of it; m_j the contact clamp plus half the
    dropper).

    Messenger: at ``height + encumbrance`` at the poles, loaded at each dropper by
    P_j = F_j + (messenger clamp + half dropper) g (T_y⁺ = T_y⁻ + P_j); per span,
    V_a at the first pole is found by the secant method so that the span ends at
    the next pole's height. The support reactions are the jumps of T_y at the poles.
    """
    from scipy.optimize import newton
    design.check()
    x, poles, drops = _mesh_x(design)
    L, p = design.span_length, design.presag
    c, m = design.contact, design.messenger
    wc, wm = c.mass_per_length * G, m.mass_per_length * G
    xd = x[drops]
    xi = np.mod(xd, L) / L
    key_cx = np.concatenate([[x[0]], xd, [x[-1]]])
    key_cy = np.concatenate([[design.height], design.height - 4 * p * xi * (1 - xi), [design.height]])
    contact = _Wire(c, key_cx, key_cy[0], [
        _span_between(c.tension, wc, c.axial_stiffness, dx, dy) for dx, dy in zip(np.diff(key_cx), np.diff(key_cy))])
    m_c = design.contact_clamp_mass + 0.5 * design.dropper_mass
    m_m = design.messenger_clamp_mass + 0.5 * design.dropper_mass
    force = contact.end_vertical()[:-1] - contact.va[1:] + m_c * G
    if np.any(force <= 0):
        raise ModelError("the design equilibrium has a dropper in compression (pre-sag too large for the "
                         "dropper spacing); reduce presag")
    end_c = np.array([-contact.va[0], contact.end_vertical()[-1]])

    top = design.height + design.encumbrance
    load = force + m_m * G
    nd = len(design.droppers)
    h, ea = m.tension, m.axial_stiffness
    segments, support = [], np.zeros(design.spans + 1)
    for k in range(design.spans):
        dxs = np.diff(np.concatenate([[x[poles[k]]], xd[k * nd:(k + 1) * nd], [x[poles[k + 1]]]]))
        loads = load[k * nd:(k + 1) * nd]

        def march(va0):
            out, va, rise = [], va0, 0.0
            for j, dx in enumerate(dxs):
                s0 = float(_s0_at(h, va, wm, ea, np.array(dx)))
                _, dy, _, _ = _catenary(h, va, wm, ea, s0)
                out.append((va, s0))
                rise += float(dy)
                va = va + wm * s0 + (loads[j] if j < nd else 0.0)
            return out, rise

        a = -0.5 * (wm * L + loads.sum())  # the symmetric guess: half the span's load
        try:
            b = newton(lambda va0: march(va0)[1], a, x1=1.01 * a, tol=1e-12, rtol=1e-13, maxiter=60)  # secant
        except (RuntimeError, ArithmeticError) as err:
            raise ModelError(f"the messenger's span {k + 1} has no static equilibrium the secant method finds "
                             f"({err}); check presag, the dropper positions and the messenger tension") from None
        span, _ = march(b)
        segments += span
        support[k] += -span[0][0]                      # upward pull needed at the first pole
        support[k + 1] += span[-1][0] + wm * span[-1][1]  # and at the next
    messenger = _Wire(m, np.sort(np.concatenate([x[poles], xd])), top, segments)

    cn, c_rest = contact.nodes(x, force - m_c * G)
    on_messenger = np.zeros(len(messenger.key_x) - 2)
    is_pole = np.isin(messenger.key_x[1:-1], x[poles])
    on_messenger[is_pole] = support[1:-1]
    on_messenger[~is_pole] = -load
    mn, m_rest = messenger.nodes(x, on_messenger)
    return DesignEquilibrium(
        x=x, contact_nodes=cn, messenger_nodes=mn, contact_rest=c_rest, messenger_rest=m_rest,
        dropper_nodes=drops, dropper_force=force, dropper_length=mn[drops, 1] - cn[drops, 1],
        pole_nodes=poles, support_force=support, contact_end_force=end_c)


# ---------------------------------------------------------------------- builders
@dataclasses.dataclass(frozen=True)
class CatenaryNames:
    """Names of what :func:`add_catenary` added.

    Attributes:
        contact, messenger: the beams.
        droppers: the dropper spring-dampers, along the track.
        supports: the messenger's intermediate support springs.
        steady_arms: the steady-arm springs (empty without steady arms).
        design: the design equilibrium the wires start in.
    """

    contact: str
    messenger: str
    droppers: tuple
    supports: tuple
    steady_arms: tuple
    design: DesignEquilibrium


def _stress_free_mesh(x0, y0, rest):
    """A straight stress-free mesh along +x from (x0, y0) with the given element lengths."""
    s = np.concatenate([[0.0], np.cumsum(rest)])
    return through_points(np.column_stack([x0 + s, np.full_like(s, y0)]), np.tile([1.0, 0.0], (len(s), 1)))


def add_catenary(model, design: CatenaryDesign = CatenaryDesign(), name: str = "catenary") -> CatenaryNames:
    """Add a simple catenary to ``model`` in its design equilibrium (module docstring).

    Adds the beams ``"<name>.contact"`` and ``"<name>.messenger"``, pins
    ``"<name>.<wire>.start|end"``, the set ``"<name>.droppers"`` of tension-only
    droppers ``"<name>.dropper<k>"`` (k = 1, 2, … along the track,
    :class:`~ancf_jax.forces.NodeSpringSet`), clamp masses, and at the intermediate
    poles (k = 1 … spans − 1) the sets ``"<name>.supports"`` of messenger support
    springs ``"<name>.support<k>"`` and ``"<name>.steady_arms"`` of steady arms
    ``"<name>.steady_arm<k>"``. The model's gravity must be (0, −9.81).
    """
    from ..model import ground, node  # imported here: the model layer is above this one
    design.check()
    if tuple(np.asarray(model.gravity, float)) != (0.0, -G):
        raise ModelError(f"a catenary needs the model's gravity (0, -{G}) m/s^2, got {tuple(model.gravity)}")
    eq = design_equilibrium(design)
    beams = {}
    for wire_name, wire, nodes, rest in (
            ("contact", design.contact, eq.contact_nodes, eq.contact_rest),
            ("messenger", design.messenger, eq.messenger_nodes, eq.messenger_rest)):
        beam = f"{name}.{wire_name}"
        mesh = _stress_free_mesh(nodes[0, 0], nodes[0, 1], rest)
        section = Section.from_stiffness(wire.axial_stiffness, wire.bending_stiffness, wire.mass_per_length)
        model.add_beam(beam, mesh, section, alpha=design.alpha, beta=design.beta,
                       formulation=WIRE_FORMULATION, initial_nodes=nodes)
        model.pin(f"{beam}.start", node(beam, 0))
        model.pin(f"{beam}.end", node(beam, -1))
        beams[wire_name] = (beam, np.concatenate([[0.0], np.cumsum(rest)]))
    contact, s_c = beams["contact"]
    messenger, s_m = beams["messenger"]
    m_c = design.contact_clamp_mass + 0.5 * design.dropper_mass
    m_m = design.messenger_clamp_mass + 0.5 * design.dropper_mass
    droppers = tuple(f"{name}.dropper{k + 1}" for k in range(len(eq.dropper_nodes)))
    model.spring_damper_set(
        f"{name}.droppers", {d: (node(contact, int(i)), node(messenger, int(i)))
                             for d, i in zip(droppers, eq.dropper_nodes)},
        stiffness=design.dropper_stiffness, damping=design.dropper_damping,
        rest_length=eq.dropper_length - eq.dropper_force / design.dropper_stiffness, acts="tension")
    for d, i in zip(droppers, eq.dropper_nodes):
        if m_c > 0:
            model.attached_mass(f"{d}.contact_clamp", contact, float(s_c[i]), m_c)
        if m_m > 0:
            model.attached_mass(f"{d}.messenger_clamp", messenger, float(s_m[i]), m_m)
    inner = eq.pole_nodes[1:-1]
    supports = tuple(f"{name}.support{k + 1}" for k in range(len(inner)))
    arms = tuple(f"{name}.steady_arm{k + 1}" for k in range(len(inner))) if design.steady_arm_stiffness > 0 else ()
    if len(inner):
        # vertical springs from 1 m above the messenger, stretched to carry the reactions
        model.spring_damper_set(
            f"{name}.supports", {sname: (ground(float(eq.x[i]), float(eq.messenger_nodes[i, 1]) + 1.0),
                                         node(messenger, int(i))) for sname, i in zip(supports, inner)},
            stiffness=design.support_stiffness,
            rest_length=1.0 - eq.support_force[1:-1] / design.support_stiffness)
    if arms:
        model.spring_damper_set(
            f"{name}.steady_arms", {aname: (ground(float(eq.x[i]), float(eq.contact_nodes[i, 1]) - 1.0),
                                            node(contact, int(i))) for aname, i in zip(arms, inner)},
            stiffness=design.steady_arm_stiffness, rest_length=1.0)
    if design.steady_arm_mass > 0:
        for k, i in enumerate(inner):
            model.attached_mass(f"{name}.steady_arm{k + 1}.mass", contact, float(s_c[i]), design.steady_arm_mass)
    return CatenaryNames(contact, messenger, droppers, supports, arms, eq)


def contact_wire_height(eq: DesignEquilibrium, x):
    """Design height of the contact wire at track position(s) x [m]."""
    return np.interp(x, eq.x, eq.contact_nodes[:, 1])


def add_pantograph(model, catenary: CatenaryNames, design: PantographDesign = PantographDesign(), *,
                   start: float, speed, name: str = "pantograph") -> tuple[str, ...]:
    """A lumped-mass pantograph (``"<name>.1"`` … at the bottom … the head on top)
    moving at x = ``start`` + ``speed`` t [m, m/s] under the catenary's contact wire,
    with the uplift F₀ + c_aero v² on the bottom mass (``"<name>.uplift"``, a
    :class:`~ancf_jax.forces.SpeedSquaredForce` on the chain's path: static plus
    aerodynamic, :class:`PantographDesign`) and a unilateral penalty contact
    ``"<name>.contact"`` between the head and the wire. The chain is built unstressed
    with the head on the wire at its design height (at the line's end height if it
    starts off the line): solve the statics for the pressed state
    (:func:`~ancf_jax.model.build_in_equilibrium` or
    :func:`~ancf_jax.statics.solve_static`). Returns the mass names, bottom first.
    ``speed`` may be traced data (a batch over speeds; the path's ``speed`` leaf,
    which the uplift reads too)."""
    from ..model import body_point
    design.check()
    top = float(contact_wire_height(catenary.design, start))
    n = len(design.masses)
    heights = design.spacing * np.arange(1, n + 1)
    base = (float(start), top - heights[-1])
    path = ConstantSpeed(float(start), speed)
    names = model.lumped_chain(name, base=base, heights=heights, masses=design.masses,
                               stiffness=design.stiffness, damping=design.damping, path=path, gravity=False)
    model.speed_squared_force(f"{name}.uplift", body_point(names[0]), static=design.uplift,
                              coefficient=design.aero_coefficient, path=path)
    model.contact(f"{name}.contact", body_point(names[-1]), catenary.contact,
                  stiffness=design.contact_stiffness, damping=design.contact_damping, side=-1)
    return tuple(names)


# ---------------------------------------------------------------------- statistics
#: the standard's keys of :func:`contact_statistics` (statistics.json)
STATISTICS_KEYS = ("speed_kmh", "mean_N", "std_N", "stat_max_N", "stat_min_N", "max_N", "min_N",
                   "uplift_support_mm", "contact_loss_pct", "spans_evaluated")


def lowpass(values, dt: float, cutoff: float = CUTOFF, order: int = 4):
    """Zero-phase Butterworth low-pass of a uniformly sampled signal (forward and
    backward, ``scipy.signal.sosfiltfilt``): ``order`` poles, −3 dB at ``cutoff`` [Hz]
    per pass."""
    from scipy import signal
    if not 0 < cutoff < 0.5 / dt:
        raise ModelError(f"cutoff must be in (0, {0.5 / dt:g}) Hz (below the Nyquist frequency of the "
                         f"samples), got {cutoff!r}")
    sos = signal.butter(order, cutoff, fs=1.0 / dt, output="sos")
    values = np.asarray(values, float)
    need = 3 * (2 * len(sos) + 1)  # sosfiltfilt's default padding, and one sample more
    if values.shape[-1] <= need:
        raise ModelError(f"the low-pass filter needs more than {need} samples, got {values.shape[-1]} "
                         f"(a run of {values.shape[-1] * dt:g} s at dt = {dt:g} s): run longer or sample finer")
    return signal.sosfiltfilt(sos, values)


def contact_statistics(t, x, force, *, window, cutoff: float = CUTOFF, uplift=None, speed_kmh=None,
                       spans_evaluated=None) -> dict:
    """Contact-force statistics of EN 50318 over the track window ``(x_from, x_to)``.

    The force (sampled at uniform t) is low-pass filtered at ``cutoff`` (:func:`lowpass`,
    over the whole record so the window has no filter transients), then over the
    samples with x in the window: mean, standard deviation σ, statistical maximum and
    minimum mean ± 3σ, actual maximum and minimum (filtered), and the percentage of
    samples with no contact (unfiltered force = 0). ``uplift``: the largest uplift
    at a support [m] (reported in mm).

    Returns:
        dict with :data:`STATISTICS_KEYS` and ``filtered`` (the filtered force).
    """
    t, x, f = (np.asarray(a, float) for a in (t, x, force))
    dt = float(np.mean(np.diff(t)))
    filtered = lowpass(f, dt, cutoff)
    sel = (x >= window[0]) & (x <= window[1])
    if not np.any(sel):
        raise ModelError(f"no samples in the evaluated window {tuple(window)} m (track positions "
                         f"{x.min():g} to {x.max():g} m)")
    fw = filtered[sel]
    mean, std = float(np.mean(fw)), float(np.std(fw))
    return dict(speed_kmh=speed_kmh, mean_N=mean, std_N=std, stat_max_N=mean + 3 * std,
                stat_min_N=mean - 3 * std, max_N=float(fw.max()), min_N=float(fw.min()),
                uplift_support_mm=None if uplift is None else 1e3 * float(uplift),
                contact_loss_pct=100.0 * float(np.mean(f[sel] <= 0.0)),
                spans_evaluated=spans_evaluated, filtered=filtered)


# ---------------------------------------------------------------------- the coupled model
#: the (leading) pantograph's name in :func:`pantograph_catenary` (its contact:
#: ``"pantograph.contact"``); trailing pantographs are :func:`pantograph_name` 2, 3, …
PANTOGRAPH = "pantograph"


def pantograph_name(k: int) -> str:
    """Name of the k-th pantograph (1: the leading one, ``"pantograph"``; k >= 2:
    the trailing ones, ``"pantograph2"`` …)."""
    return PANTOGRAPH if k == 1 else f"{PANTOGRAPH}{k}"


def check_trailing(trailing) -> tuple[float, ...]:
    """The trailing pantographs' distances behind the leading one [m]: increasing
    numbers > 0 (a one-line :class:`~ancf_jax.errors.ModelError` otherwise)."""
    d = tuple(float(v) for v in trailing)
    if not all(math.isfinite(v) and v > 0 for v in d) or any(b <= a for a, b in zip(d, d[1:])):
        raise ModelError(f"pantograph trailing must be increasing distances > 0 m behind the leading "
                         f"pantograph, got {list(trailing)}")
    return d


def default_start(catenary: CatenaryDesign, trailing=()) -> float:
    """x of the leading pantograph at t = 0 [m] by default: the last pantograph at a
    tenth of the first dropper's distance from the first pole, the others
    ``trailing`` [m] ahead of it."""
    return 0.1 * float(catenary.droppers[0]) + (max(trailing) if len(trailing) else 0.0)


def pantograph_catenary(catenary: CatenaryDesign = CatenaryDesign(), pantograph: PantographDesign = PantographDesign(),
                        *, speed, start: float | None = None, trailing=()):
    """A model of a pantograph running at ``speed`` [m/s] (may be traced data) under a
    catenary, from ``start`` [m] (:func:`default_start`), and of trailing pantographs
    of the same design ``trailing`` [m] behind it (:func:`check_trailing`; e.g.
    (200.0,): double traction), named :func:`pantograph_name` 2, 3, … each with its own
    contact on the contact wire. The leading pantograph starts inside the line; a
    trailing one may start behind it (x <= 0: no contact, its head standing free
    above the wire's end height; :func:`pantograph_run_time` refuses a run that takes
    it onto the line). Returns
    ``(model, names)``: build with ``model.build(assemble=False)`` and start from
    :func:`moving_equilibrium` (the design state is consistent with every joint)."""
    from ..model import Model
    trailing = check_trailing(trailing)
    m = Model(gravity=(0.0, -G))
    names = add_catenary(m, catenary)
    x0 = default_start(catenary, trailing) if start is None else float(start)
    if not 0.0 < x0 < catenary.length:
        raise ModelError(f"pantograph start must be inside the line (0, {catenary.length:g}) m, got {x0!r}")
    for k, d in enumerate((0.0,) + trailing):
        add_pantograph(m, names, pantograph, start=x0 - d, speed=speed, name=pantograph_name(k + 1))
    return m, names


def pantograph_run_time(catenary: CatenaryDesign, *, start: float, speed: float, trailing=(), spans=None,
                        cutoff: float = CUTOFF, t_end: float | None = None) -> float:
    """Duration [s] of a run: until the last pantograph is one span (at least
    3 / ``cutoff`` seconds of travel: the filter's margin) past the evaluated spans
    (:func:`evaluated_spans`), or the leading one half the first dropper distance
    before the last pole, whichever comes first (or at ``t_end`` [s] if earlier).
    ``start``: the leading pantograph's x at t = 0 [m], ``speed`` [m/s] > 0. Raises a
    :class:`~ancf_jax.errors.ModelError` if a trailing pantograph starting off the
    line (x <= 0) would reach it before the end."""
    trailing = check_trailing(trailing)
    _, last = evaluated_spans(catenary, spans)
    x_last = last * catenary.span_length + max(catenary.span_length, 3.0 * speed / cutoff)
    x_lead = catenary.length - 0.5 * catenary.droppers[0]
    back = max(trailing) if trailing else 0.0
    natural = min(x_last - (start - back), x_lead - start) / speed
    t_end = natural if t_end is None else min(float(t_end), natural)
    for k, d in enumerate(trailing):
        if start - d <= 0.0 < start - d + speed * t_end:
            raise ModelError(f"{pantograph_name(k + 2)} starts off the line (x = {start - d:g} m) and would "
                             f"reach it at t = {(d - start) / speed:g} s, before the run ends ({t_end:g} s): "
                             f"its free head stands above the wire; start it on the line (start > {d:g} m)")
    return t_end


def moving_equilibrium(system, guess, *, load_steps: int = 2):
    """The initial state of a run: the static equilibrium at t = 0 (structured Newton,
    :data:`~ancf_jax.statics.STATIC_NEWTON`; raises a :class:`~ancf_jax.errors.StaticsError`)
    with the beams at rest and the border coordinates (bodies) moving as the joints
    prescribe (Φ_q v = −Φ_t, least squares over the border). Returns
    ``(State, StaticSolution)``."""
    import jax.numpy as jnp

    from ..model import _JACOBIAN, _TIME_DERIVATIVE
    from ..statics import STATIC_NEWTON, solve_static
    from ..system import State
    sol = solve_static(system, guess, load_steps=load_steps, root_finder=STATIC_NEWTON)
    q = sol.state.q
    border = system.border_indices()
    jac = np.asarray(_JACOBIAN(system, q, 0.0))
    phi_t = np.asarray(_TIME_DERIVATIVE(system, q, 0.0))
    vb, *_ = np.linalg.lstsq(jac[:, border], -phi_t, rcond=None)
    if np.max(np.abs(jac[:, border] @ vb + phi_t), initial=0.0) > 1e-9 * max(1.0, np.max(np.abs(phi_t))):
        raise ModelError("the prescribed motions at t = 0 cannot be met by the bodies alone (a beam "
                         "coordinate is driven); start from a consistent state instead")
    v = np.zeros(system.n_coordinates)
    v[border] = vb
    return State(q, jnp.asarray(v), jnp.zeros(())), sol


@dataclasses.dataclass(frozen=True)
class PantographRun:
    """Outcome of :func:`run_pantograph_catenary`.

    Attributes:
        results: the run (:class:`~ancf_jax.results.Results`).
        t, x: output times [s] and pantograph positions [m], shape (N,).
        force, filtered: contact force and its low-pass filtered version [N], (N,).
        uplift: contact-wire uplift at the poles of the evaluated spans [m], shape
            (N, p) (y − y at t = 0).
        window: the evaluated stretch of track (x_from, x_to) [m].
        statistics: :func:`contact_statistics` (without ``filtered``); with trailing
            pantographs also ``trailing``: one dict per trailing pantograph,
            ``spacing_m`` [m] and its own :data:`STATISTICS_KEYS` (None if it did not
            reach the evaluated spans).
        trailing: the trailing pantographs' :class:`PantographRun` (their own x, force
            and window; None where it did not reach the evaluated spans), in the order
            of ``trailing``.
    """

    results: object
    t: np.ndarray
    x: np.ndarray
    force: np.ndarray
    filtered: np.ndarray
    uplift: np.ndarray
    window: tuple
    statistics: dict
    trailing: tuple = ()


def evaluated_spans(design: CatenaryDesign, spans=None) -> tuple[int, int]:
    """First and last evaluated span (1-based, inclusive): ``spans``, or by default the
    two central spans of four or more, else the last (the first holds the start)."""
    if spans is None:
        n = design.spans
        return (n // 2, n // 2 + 1) if n >= 4 else (n, n)
    a, b = (int(v) for v in spans)
    if not 1 <= a <= b <= design.spans:
        raise ModelError(f"evaluated spans must be 1 <= first <= last <= {design.spans}, got {spans!r}")
    return a, b


def analyse_pantograph_run(results, design: CatenaryDesign, *, speed_kmh: float, start: float, spans=None,
                           cutoff: float = CUTOFF, trailing=(), name: str = PANTOGRAPH) -> PantographRun:
    """The statistics of EN 50318 of a run of :func:`pantograph_catenary` (or of the
    scenario tables): contact force of ``"<name>.contact"`` at the outputs, the
    pantograph at x = start + v t, the contact wire's uplift at the poles of the
    evaluated spans. The window ends at least 3 / ``cutoff`` seconds of travel before
    the run does (the zero-phase filter's end transient). ``trailing``: the trailing
    pantographs' distances behind the leading one [m], each analysed alike over the
    same spans (``statistics["trailing"]``, ``PantographRun.trailing``)."""
    first, last = evaluated_spans(design, spans)
    L = design.span_length
    t = np.asarray(results.t)
    v = speed_kmh / 3.6
    x = float(start) + v * t
    window = ((first - 1) * L, min(last * L, float(x[-1]) - 3.0 * v / cutoff))
    force = np.asarray(results.contact(f"{name}.contact")[:, 0])
    system = results.system
    eq = design_equilibrium(design)
    poles = eq.pole_nodes[first - 1:last + 1]
    iy = system.beam_offset(system.beam_names.index("catenary.contact")) + 4 * np.asarray(poles) + 1
    q = np.asarray(results.q)
    uplift = q[:, iy] - q[:1, iy]
    stats = contact_statistics(t, x, force, window=window, cutoff=cutoff, uplift=uplift.max(),
                               speed_kmh=float(speed_kmh), spans_evaluated=[first, last])
    filtered = stats.pop("filtered")
    behind, rows = [], []
    for k, d in enumerate(check_trailing(trailing)):
        if float(start) - d + v * t[-1] - 3.0 * v / cutoff < window[0]:
            behind.append(None)  # it did not reach the evaluated spans
            rows.append(dict({key: None for key in STATISTICS_KEYS}, spacing_m=d, speed_kmh=float(speed_kmh),
                             spans_evaluated=[first, last]))
            continue
        behind.append(analyse_pantograph_run(results, design, speed_kmh=speed_kmh, start=float(start) - d,
                                             spans=spans, cutoff=cutoff, name=pantograph_name(k + 2)))
        rows.append(dict(spacing_m=d, **behind[-1].statistics))
    if rows:
        stats["trailing"] = rows
    return PantographRun(results, t, x, force, filtered, uplift, window, stats, tuple(behind))


def run_pantograph_catenary(catenary: CatenaryDesign = CatenaryDesign(),
                            pantograph: PantographDesign = PantographDesign(), *, speed_kmh: float,
                            dt: float = RUN_DT, output_dt: float | None = None, spans=None,
                            cutoff: float = CUTOFF, solver=DEFAULT_SOLVER,
                            pad_to: int | None = None, t_end: float | None = None,
                            chunks: int | None = None, start: float | None = None,
                            trailing=()) -> PantographRun:
    """Run a pantograph along a catenary at ``speed_kmh`` and compute the statistics
    of EN 50318 over the evaluated ``spans`` (:func:`evaluated_spans`,
    :func:`analyse_pantograph_run`): from the static equilibrium at the start
    (:func:`moving_equilibrium`) for :func:`pantograph_run_time` (``t_end``: an
    earlier end). ``start``, ``trailing``: the leading pantograph's x at t = 0 [m]
    and the trailing pantographs' distances behind it [m]
    (:func:`pantograph_catenary`). ``pad_to``: element slots of both wires; with it,
    equal ``t_end``, ``output_dt = dt`` and ``chunks`` in proportion to the step
    count, runs of different meshes and steps share one compiled program."""
    from ..integrate import RunLimits
    from ..simulation import simulate
    if not (isinstance(speed_kmh, (int, float)) and 0 < speed_kmh <= 600):
        raise ModelError(f"speed_kmh must be a number in (0, 600] km/h, got {speed_kmh!r}")
    evaluated_spans(catenary, spans)
    v = speed_kmh / 3.6
    if not 0 < cutoff:
        raise ModelError(f"cutoff must be a frequency > 0 Hz, got {cutoff!r}")
    trailing = check_trailing(trailing)
    x0 = default_start(catenary, trailing) if start is None else float(start)
    span = pantograph_run_time(catenary, start=x0, speed=v, trailing=trailing, spans=spans, cutoff=cutoff,
                               t_end=t_end)
    model, _ = pantograph_catenary(catenary, pantograph, speed=v, start=x0, trailing=trailing)
    system, guess = model.build(assemble=False, pad_to=pad_to)
    state, _ = moving_equilibrium(system, guess)
    res = simulate(system, state, t_end=span, dt=dt, output_dt=output_dt or dt, solver=solver, progress=None,
                   limits=RunLimits(chunks=chunks))
    return analyse_pantograph_run(res, catenary, speed_kmh=speed_kmh, start=x0, spans=spans, cutoff=cutoff,
                                  trailing=trailing)


#: EN 50318:2002 acceptance ranges of the reference model's statistics, by speed
#: [km/h]: (low, high) [N or mm], and no loss of contact. Sources (secondary): Wang et
#: al., "An Extended Habedank's Equation-Based EMTP Model of Pantograph Arcing …",
#: IEEE, Table III; github.com/ChandraguptSharma07/faraway backend/sim/validate.py
#: (identical values; docs/pantograph-catenary.md).
EN50318_2002_RANGES = {
    250: dict(mean_N=(110, 120), std_N=(26, 31), stat_max_N=(190, 210), stat_min_N=(20, 40),
              max_N=(175, 210), min_N=(50, 75), uplift_support_mm=(48, 55), contact_loss_pct=(0, 0)),
    300: dict(mean_N=(110, 120), std_N=(32, 40), stat_max_N=(210, 230), stat_min_N=(-5, 20),
              max_N=(190, 225), min_N=(30, 55), uplift_support_mm=(55, 65), contact_loss_pct=(0, 0)),
}


def against_ranges(statistics: dict) -> list[dict] | None:
    """Each statistic against the EN 50318:2002 range at its speed (250 or 300 km/h;
    None at other speeds): rows {key, value, low, high, inside}."""
    ranges = EN50318_2002_RANGES.get(int(round(statistics["speed_kmh"])))
    if ranges is None or abs(statistics["speed_kmh"] - round(statistics["speed_kmh"])) > 1e-9:
        return None
    return [dict(key=k, value=statistics[k], low=lo, high=hi, inside=bool(lo <= statistics[k] <= hi))
            for k, (lo, hi) in ranges.items()]
