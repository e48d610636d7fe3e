"""Fatigue of a simulated run: damage and life along every beam, hot spots, files.

:func:`analyse` takes a :class:`~ancf_jax.results.Results` and
:class:`FatigueSettings`, evaluates the surface-fibre stresses
(:mod:`ancf_jax.fatigue.stress`) at the chosen points of every beam over the output
rows with t ≥ ``t_start``, and computes the Miner damage of each fibre by rainflow
counting (:mod:`ancf_jax.fatigue.rainflow`) or Dirlik's spectral method
(:mod:`ancf_jax.fatigue.spectral`); the damage of a point is the larger of its two
fibres. :meth:`FatigueResult.write` writes ``damage.csv`` (``beam,s,damage,life_repeats``),
``fatigue.json`` and, optionally, the figures ``cycles_hot_spot.png`` (rainflow
histogram at the hot spot) and ``damage_along.png``.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..results import Results
from .damage import life, rainflow_damage
from .rainflow import cycles
from .sn import CORRECTIONS, SNCurve, equivalent_range
from .spectral import dirlik_damage
from .stress import points_along, points_at, stress_history

#: damage methods
METHODS = ("rainflow", "dirlik")


@dataclasses.dataclass(frozen=True)
class Concentration:
    """A stress concentration factor K_t on the points of ``beam`` with s_min ≤ s ≤ s_max [m]."""

    beam: str
    s_min: float
    s_max: float
    factor: float


@dataclasses.dataclass(frozen=True)
class FatigueSettings:
    """What and how to assess (the ``[fatigue]`` table of a scenario).

    Attributes:
        curve: the S–N curve.
        method: ``"rainflow"`` or ``"dirlik"``.
        correction: mean-stress correction (``"none"``, ``"goodman"``, ``"gerber"``).
        ultimate_strength: σ_u [Pa] for the correction.
        measure: curvature measure of the bending stress.
        fibre: fibre distance c [m] (None: each section's outer fibre).
        scf: stress concentration factor K_t everywhere.
        concentrations: further factors on ranges of arc length (multiplying ``scf``).
        layout: ``"barlow"`` or ``"uniform"`` points along every beam (when ``at`` is None).
        points_per_element: points of the uniform layout.
        at: chosen points instead, ((beam, s [m]), ...).
        t_start: discard output rows before this time [s] (a start-up transient).
        hours_per_run: hours of service one run represents (life in hours).
        passes_per_run: passes (crossings, trips) one run represents (life in passes).
        nperseg: Welch segment length of the Dirlik PSD (None: one periodogram).
    """

    curve: SNCurve
    method: str = "rainflow"
    correction: str = "none"
    ultimate_strength: Optional[float] = None
    measure: str = "exact"
    fibre: Optional[float] = None
    scf: float = 1.0
    concentrations: tuple = ()
    layout: str = "barlow"
    points_per_element: int = 5
    at: Optional[tuple] = None
    t_start: float = 0.0
    hours_per_run: Optional[float] = None
    passes_per_run: Optional[float] = None
    nperseg: Optional[int] = None

    def __post_init__(self):
        if self.method not in METHODS:
            raise ModelError(f"fatigue method must be one of {METHODS}, got {self.method!r}")
        if self.correction not in CORRECTIONS:
            raise ModelError(f"mean-stress correction must be one of {CORRECTIONS}, got {self.correction!r}")
        if self.correction != "none" and self.ultimate_strength is None:
            raise ModelError(f"the {self.correction} mean-stress correction needs ultimate_strength [Pa]")


@dataclasses.dataclass
class FatigueResult:
    """Damage of one run (one repetition of the simulated history) along the beams.

    Attributes:
        settings: the settings used.
        beam: beam name of each point, shape (P,).
        s: reference arc length of each point [m], shape (P,).
        damage_fibres: Miner damage of fibres +c, −c, shape (P, 2).
        stress: surface-fibre stress histories [Pa], shape (N, P, 2).
        t: the output times used [s], shape (N,).
        duration: the span of ``t`` (last minus first time) [s].
        attachments: {beam name: ((joint name, s [m], reach [m]), ...)}: where joints hold
            each beam at a fixed arc length (:func:`attachments`), to name the hot spots.
    """

    settings: FatigueSettings
    beam: np.ndarray
    s: np.ndarray
    damage_fibres: np.ndarray
    stress: np.ndarray
    t: np.ndarray
    duration: float
    attachments: dict = dataclasses.field(default_factory=dict)

    def near(self, beam: str, s: float) -> Optional[dict]:
        """The joint holding ``beam`` closest to arc length ``s`` within
        :data:`NEAR_ELEMENTS` element lengths: ``{"joint", "distance_m"}``, else None."""
        joints = self.attachments.get(beam, ())
        if not joints:
            return None
        name, at, reach = min(joints, key=lambda j: abs(j[1] - s))
        return dict(joint=name, distance_m=abs(at - s)) if abs(at - s) <= reach else None

    @property
    def damage(self) -> np.ndarray:
        """Damage of each point (the larger fibre), shape (P,)."""
        return self.damage_fibres.max(axis=1)

    @property
    def life_repeats(self) -> np.ndarray:
        """Repetitions of the simulated history to failure, 1/D, shape (P,)."""
        return life(self.damage)

    @property
    def hot_index(self) -> tuple[int, int]:
        """(point, fibre) of the largest damage."""
        i = int(np.argmax(self.damage_fibres))
        return divmod(i, 2)

    def hot_spots(self, count: int = 5) -> list[dict]:
        """The ``count`` most damaged points (local maxima along each beam first)."""
        d = self.damage
        order = np.argsort(-d, kind="stable")
        out = []
        for i in order:
            if len(out) == count or d[i] <= 0.0:
                break
            if any(o["beam"] == self.beam[i] and abs(o["s_m"] - self.s[i]) < 1e-12 for o in out):
                continue
            out.append(dict(beam=str(self.beam[i]), s_m=float(self.s[i]), damage=float(d[i]),
                            life_repeats=_num(life(d[i])),
                            fibre="+c" if self.damage_fibres[i, 0] >= self.damage_fibres[i, 1] else "-c",
                            near=self.near(str(self.beam[i]), float(self.s[i]))))
        return out

    def summary(self) -> dict:
        """JSON-ready summary: max damage, hot spot, S–N curve, method, lives, units."""
        p, f = self.hot_index
        st = self.settings
        d = float(self.damage.max()) if self.damage.size else 0.0
        out = dict(max_damage=d, hot_spot=dict(beam=str(self.beam[p]), s_m=float(self.s[p]),
                                               fibre="+c" if f == 0 else "-c",
                                               near=self.near(str(self.beam[p]), float(self.s[p]))),
                   life_repeats=_num(life(d)), sn_curve=st.curve.to_dict(), method=st.method,
                   mean_stress_correction=st.correction, ultimate_strength_Pa=st.ultimate_strength,
                   measure=st.measure, scf=st.scf, points=len(self.s), duration_s=self.duration,
                   t_start_s=st.t_start, hot_spots=self.hot_spots())
        if st.hours_per_run is not None:
            out["life_hours"] = _num(life(d) * st.hours_per_run)
        if st.passes_per_run is not None:
            out["life_passes"] = _num(life(d) * st.passes_per_run)
        out["units"] = dict(s_m="m", distance_m="m", damage="-", max_damage="- (per run)",
                            life_repeats="repetitions of the simulated history", life_hours="h",
                            life_passes="passes", duration_s="s", t_start_s="s", stress="Pa",
                            ultimate_strength_Pa="Pa", reference_range_Pa="Pa", knee_range_Pa="Pa",
                            cutoff_range_Pa="Pa", reference_cycles="cycles", knee_cycles="cycles",
                            cutoff_cycles="cycles", m1="- (S-N slope)", m2="- (S-N slope)", scf="-")
        return out

    def hot_spot_cycles(self):
        """Rainflow cycles (ranges [Pa], means [Pa], counts) at the hot spot."""
        p, f = self.hot_index
        return cycles(self.stress[:, p, f])

    def write(self, out: str | Path, figures: bool = True) -> dict:
        """Write damage.csv, fatigue.json (returned) and the figures into ``out``."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "damage.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["beam", "s", "damage", "life_repeats"])
            for b, s, d, n in zip(self.beam, self.s, self.damage, self.life_repeats):
                w.writerow([b, f"{s:.10g}", f"{d:.10g}", f"{n:.10g}" if math.isfinite(n) else "inf"])
        data = self.summary()
        (out / "fatigue.json").write_text(json.dumps(data, indent=2))
        if figures:
            from .plots import cycle_histogram, damage_along
            r, _, c = self.hot_spot_cycles()
            hs = data["hot_spot"]
            cycle_histogram(r, c, title=f"rainflow cycles at {hs['beam']} s = {hs['s_m']:.3f} m ({hs['fibre']})",
                            path=out / "cycles_hot_spot.png")
            damage_along(self.beam, self.s, self.damage_fibres, path=out / "damage_along.png",
                         hot_spots=data["hot_spots"])
        return data


def _num(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _beam_index(system, name: str) -> int:
    if name not in system.beam_names:
        raise ModelError(f"no beam named {name!r} (known: {', '.join(map(repr, system.beam_names)) or 'none'})")
    return system.beam_names.index(name)


#: a hot spot is named after a joint at most this many element lengths away along the beam
NEAR_ELEMENTS = 2.0


def attachments(system) -> dict:
    """{beam name: ((joint name, s [m], reach [m]), ...)}: the joints that hold a beam at
    a fixed point (a node or an arc length: clamps, pins, fixed joints, prescribed
    points; not sliding joints, which move), with the reach within which a hot spot is
    named after them (:data:`NEAR_ELEMENTS` lengths of the element there)."""
    from ..points import BeamNode, BeamPoint
    out: dict = {}
    for c in system.constraints:
        for f in dataclasses.fields(c):
            p = getattr(c, f.name)
            if not isinstance(p, (BeamNode, BeamPoint)):
                continue
            mesh = system.beams[p.beam].mesh
            if isinstance(p, BeamNode):
                s = float(np.asarray(mesh.node_arc_lengths)[int(p.node)])
            else:
                s = float(p.s)
            k, _ = mesh.locate(jnp.asarray(s))
            reach = NEAR_ELEMENTS * float(np.asarray(mesh.element_lengths)[int(k)])
            out.setdefault(system.beam_names[p.beam], []).append((c.name, s, reach))
    return {b: tuple(v) for b, v in out.items()}


def assessed_points(system, st: FatigueSettings) -> dict:
    """{beam index: (element, xi, s, scf)} of every beam with points to assess (the
    settings' ``at`` points, else its layout along every beam), each an array of
    shape (P_b,); s is the reference arc length [m], scf the factor K_t of each point."""
    for c in st.concentrations:
        _beam_index(system, c.beam)
    chosen: dict[int, list] = {}
    if st.at is not None:
        for name, s in st.at:
            chosen.setdefault(_beam_index(system, name), []).append(float(s))
    out = {}
    for b, name in enumerate(system.beam_names):
        beam = system.beams[b]
        if st.at is not None:
            if b not in chosen:
                continue
            k, xi, s = points_at(beam, chosen[b])
        else:
            k, xi, s = points_along(beam, st.layout, st.points_per_element)
        scf = np.full(s.shape, float(st.scf))
        for c in st.concentrations:
            if c.beam == name:
                scf = np.where((s >= c.s_min) & (s <= c.s_max), scf * c.factor, scf)
        out[b] = (k, xi, s, scf)
    if not out:
        raise ModelError("fatigue: no points to assess")
    return out


def fibre_stresses(system, q, points: dict, st: FatigueSettings):
    """Surface-fibre stresses of the ``points`` (:func:`assessed_points`) over the
    rows of ``q`` (N, n): σ [Pa], shape (N, P, 2) (fibres +c, −c). Traceable."""
    fibre = None if st.fibre is None else jnp.asarray(st.fibre, float)
    return jnp.concatenate([stress_history(system, b, q, jnp.asarray(k), jnp.asarray(xi), fibre, st.measure,
                                           jnp.asarray(scf)) for b, (k, xi, _, scf) in points.items()], axis=1)


def dirlik_fibres(sigma, dt, st: FatigueSettings):
    """Dirlik damage of every fibre of σ (N, P, 2) sampled every ``dt`` [s]: shape (P, 2).
    Traceable and differentiable."""
    n, p, _ = sigma.shape
    series = jnp.reshape(sigma, (n, p * 2)).T
    dmg = jax.vmap(lambda x: dirlik_damage(x, dt, st.curve, nperseg=st.nperseg, correction=st.correction,
                                           ultimate_strength=st.ultimate_strength))(series)
    return jnp.reshape(dmg, (p, 2))


def analyse(results: Results, settings: FatigueSettings) -> FatigueResult:
    """Damage and life along the beams of a run (module docstring)."""
    st = settings
    points = assessed_points(results.system, st)
    rows = np.asarray(results.t) >= st.t_start - 1e-12
    if rows.sum() < 3:
        raise ModelError(f"fatigue: fewer than 3 output rows at t >= t_start = {st.t_start:g} s")
    t = np.asarray(results.t)[rows]
    sigma = np.asarray(fibre_stresses(results.system, jnp.asarray(results.q[rows]), points, st))
    names = [results.system.beam_names[b] for b, (_, _, s, _) in points.items() for _ in s]
    ss = np.concatenate([s for (_, _, s, _) in points.values()])
    if not np.isfinite(sigma).all():
        raise ModelError("fatigue: the stress histories contain NaN or inf (a failed run?)")
    p = sigma.shape[1]
    if st.method == "rainflow":
        series = sigma.reshape(len(t), p * 2).T
        dmg = np.array([rainflow_damage(x, st.curve, st.correction, st.ultimate_strength)
                        for x in series]).reshape(p, 2)
    else:
        dt = float(np.mean(np.diff(t)))
        dmg = np.asarray(jax.jit(lambda x: dirlik_fibres(x, dt, st))(jnp.asarray(sigma)))
    return FatigueResult(st, np.array(names), ss, dmg, sigma, t, float(t[-1] - t[0]),
                         attachments(results.system))


def settings_from_table(table) -> FatigueSettings:
    """:class:`FatigueSettings` of a scenario's validated ``[fatigue]`` table
    (:class:`ancf_jax.scenario.schema.FatigueSpec`; read by attribute, nothing imported
    from the scenario layer)."""
    c = table.sn_curve
    curve = SNCurve(c.reference_range, c.reference_cycles, c.m1, c.knee_cycles, c.m2, c.cutoff_cycles)
    at = tuple((p.beam, p.s) for p in table.points.values()) or None
    conc = tuple(Concentration(k.beam, k.s_min, k.s_max, k.factor) for k in table.concentrations.values())
    return FatigueSettings(curve, method=table.method, correction=table.mean_stress,
                           ultimate_strength=table.ultimate_strength, measure=table.measure,
                           fibre=table.fibre, scf=table.scf, concentrations=conc, layout=table.layout,
                           points_per_element=table.points_per_element, at=at, t_start=table.t_start,
                           hours_per_run=table.hours_per_run, passes_per_run=table.passes_per_run,
                           nperseg=table.nperseg)


def sinusoid_damage(amplitude, cycles_count: int, curve: SNCurve, mean=0.0, correction="none",
                    ultimate_strength=None):
    """Closed-form Miner damage n / N(2A) of n cycles of a sinusoid of amplitude A [Pa]
    (the reference for constant-amplitude checks)."""
    s = equivalent_range(2.0 * amplitude, mean, correction, ultimate_strength)
    return float(cycles_count * curve.damage_per_cycle(s))
