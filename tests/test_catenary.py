"""Pantograph–catenary (issue 21) against independent answers.

* The design equilibrium by hand (:func:`~ancf_jax.models.catenary.design_equilibrium`:
  elastic catenaries between key points plus the bending boundary layers of the point
  forces) against its own global balance (reactions = weights, exactly), and against
  the static solve of the assembled ANCF model: dropper forces and wire heights agree
  to the mesh error, which falls at least as h² (measured ~h⁴).
* The builder's contact wire alone, pinned over one span, under a constant force
  moving at 250 km/h: the deflection under the load against the beam's modal series.
* A small two-span catenary with the pantograph: the filtered contact force and its
  statistics against the run of itself with half the elements and half the step,
  within what the convergence study measured.
* The aerodynamic uplift F₀ + c v² and two pantographs on one wire: the static
  balance of each pantograph (contact force = uplift − frame spring), Maxwell–Betti
  reciprocity between the two; the trailing pantograph's statistics and files.

Programs are shared: the static solves and the runs pad both wires to one element count.
"""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax.errors import ModelError
from ancf_jax.model import Model
from ancf_jax.models.catenary import (G, WIRE_FORMULATION, CatenaryDesign, PantographDesign,
                                      contact_statistics, design_equilibrium, lowpass, moving_equilibrium, pantograph_catenary,
                                      pantograph_name, run_pantograph_catenary)

from .beam_theory import moving_load_series
from .dynamics import LazyRuns

#: three short spans with the standard wires (shortened for speed): the middle one is
#: evaluated, the last is the filter's margin
RUN = dict(spans=3, span_length=10.0, droppers=(2.0, 5.0, 8.0))


def _balance_error(d, eq):
    """Relative difference of the vertical reactions (messenger supports, contact-wire
    ends) from the weight of the wires (unstretched lengths × ρA g), clamps and
    droppers in the design equilibrium ``eq`` of ``d``."""
    weight = G * (d.contact.mass_per_length * eq.contact_rest.sum() + d.messenger.mass_per_length
                  * eq.messenger_rest.sum() + len(eq.dropper_force) * (
                      d.dropper_mass + d.contact_clamp_mass + d.messenger_clamp_mass))
    return abs(eq.support_force.sum() + eq.contact_end_force.sum() - weight) / weight


def _contact_mass(d):
    """Mass lumped on the contact wire at a dropper [kg]: its clamp and half the dropper."""
    return d.contact_clamp_mass + 0.5 * d.dropper_mass


def test_design_equilibrium_balances_the_weights():
    """Vertical reactions equal the weights (:func:`_balance_error`): to 1e-5 (the
    boundary layers shorten the wires by ~2 mm over 600 m, which the strings' weight
    does not see; 2e-6 of it); the droppers are taut and longer at the poles than at
    mid-span (the messenger sags).

    The level contact wire (no pre-sag) by hand: each segment between key points is a
    symmetric catenary, so each dropper carries the weight of half the wire on either
    side, w (s₀,left + s₀,right) / 2, plus the clamp and half the dropper, with the
    unstretched length s₀ ≈ dx / (1 + H/EA): to 2e-6 (the chord neglects the arc of
    the sag, a relative (w s₀ / 2H)² / 6 = 1.8e-6 on the 10 m segments across a pole;
    leaving out the clamps would be 5 % off, the stretch 1.7e-3)."""
    d = CatenaryDesign()
    eq = design_equilibrium(d)
    assert _balance_error(d, eq) < 1e-5
    assert np.all(eq.dropper_force > 0)
    mid = len(d.droppers) // 2
    assert eq.dropper_length[0] > eq.dropper_length[mid] < eq.dropper_length[len(d.droppers) - 1]
    # the wires pass through their design heights: messenger at the poles (less the
    # rounding of the support, F λ / 2H), contact wire at the droppers (less its rounding)
    lam = np.sqrt(d.messenger.bending_stiffness / d.messenger.tension)
    top = d.height + d.encumbrance - eq.support_force[1:-1] * lam / (2 * d.messenger.tension)
    np.testing.assert_allclose(eq.messenger_nodes[eq.pole_nodes[1:-1], 1], top, atol=1e-9)
    c = d.contact
    key = np.concatenate([eq.x[:1], eq.x[eq.dropper_nodes], eq.x[-1:]])
    s0 = np.diff(key) / (1 + c.tension / c.axial_stiffness)
    hand = c.mass_per_length * G * (s0[:-1] + s0[1:]) / 2 + _contact_mass(d) * G
    np.testing.assert_allclose(eq.dropper_force, hand, rtol=2e-6, atol=0)


def test_presag_puts_the_contact_wire_on_its_parabola():
    """Pre-sag p ≠ 0 on the small catenary (p = 5 mm on 10 m spans: with droppers at
    2, 5 and 8 m, p above wL²/8H ≈ 8 mm would need droppers to push): the contact wire
    passes through the design heights 4 p ξ(1 − ξ) below ``height`` at the droppers,
    less the rounding of each dropper's pull F λ / 2H (as the messenger at the poles),
    to 1e-9 m; the weights still balance; and by hand, the pre-sag moves each
    dropper's force from the level wire's by H times the kink of the key points'
    polyline there, H (Δy/Δx left − Δy/Δx right): −24 N at mid-span, +12 N next to
    the poles (to 1e-4 N; measured 2e-5 N, the weight of the slightly longer sloped
    segments)."""
    d = CatenaryDesign(presag=0.005, element_length=0.5, **RUN)
    level = design_equilibrium(dataclasses.replace(d, presag=0.0))
    eq = design_equilibrium(d)
    c = d.contact
    xi = np.mod(eq.x[eq.dropper_nodes], d.span_length) / d.span_length
    lam = np.sqrt(c.bending_stiffness / c.tension)
    rounding = (eq.dropper_force - _contact_mass(d) * G) * lam / (2 * c.tension)
    design = d.height - 4 * d.presag * xi * (1 - xi) - rounding
    np.testing.assert_allclose(eq.contact_nodes[eq.dropper_nodes, 1], design, rtol=0, atol=1e-9)
    assert np.ptp(eq.contact_nodes[eq.dropper_nodes, 1]) > 1.5e-3  # the sag: 4p (ξ(1 − ξ) at 0.5 less at 0.2)
    assert _balance_error(d, eq) < 1e-5
    x = np.concatenate([eq.x[:1], eq.x[eq.dropper_nodes], eq.x[-1:]])
    y = np.concatenate([[0.0], -4 * d.presag * xi * (1 - xi), [0.0]])  # key points, the pinned ends at 0
    slope = np.diff(y) / np.diff(x)
    np.testing.assert_allclose(eq.dropper_force - level.dropper_force, c.tension * (slope[:-1] - slope[1:]),
                               rtol=0, atol=1e-4)


def test_a_design_without_a_found_equilibrium_is_one_line():
    """A pre-sag the secant method of the messenger's span does not converge for gives a
    one-line ModelError naming the span and what to check, not scipy's RuntimeError."""
    with pytest.raises(ModelError, match="messenger's span 1 has no static equilibrium"):
        design_equilibrium(CatenaryDesign(presag=0.007, element_length=0.5, **RUN))


def static_dropper_errors(element_length, presag=0.0):
    """Largest relative dropper-force error (with ``presag``: largest error [N]) and
    height change [m] of the static solve from the design state (the run's catenary
    and program, the pantograph's uplift made negligible)."""
    design = CatenaryDesign(element_length=element_length, alpha=0.06, beta=7.6e-5, presag=presag, **RUN)
    m, names = pantograph_catenary(design, PantographDesign(uplift=1e-3), speed=250 / 3.6)
    system, guess = m.build(assemble=False, pad_to=60)
    state, _ = moving_equilibrium(system, guess)
    q = state.q
    droppers = next(f for f in system.forces if f.name == "catenary.droppers")
    tension = np.asarray(droppers.member_forces(system, q, jnp.zeros_like(q)))
    dy = max(float(jnp.max(jnp.abs(system.beam_nodes(q - guess.q, b)[:, 1]))) for b in range(2))
    if presag:  # the largest error [N] (relative errors grow where the forces are small)
        return np.max(np.abs(tension - names.design.dropper_force)), dy
    return np.max(np.abs(tension / names.design.dropper_force - 1)), dy


def test_the_shipped_design_meshes_its_600_m_wires():
    """The shipped design (10 spans of 60 m, 0.5 m elements) builds its model: the
    stress-free meshes of both wires, 1,200 elements each, whose lengths add up to the
    600 m line shortened by the wire's pre-strain H/EA (to 1e-3: the sag between the
    supports lengthens the messenger by 3.5e-4, the contact wire by 1e-6) (the Hermite length of an element 300 m from the origin had not
    converged, so the shipped scenario failed to build; no solve here)."""
    design = CatenaryDesign()
    model, names = pantograph_catenary(design, speed=250 / 3.6)
    for wire, spec in ((names.contact, design.contact), (names.messenger, design.messenger)):
        lengths = np.asarray(model._beams[wire].mesh.element_lengths)
        assert lengths.size == 1200
        strain = spec.tension / spec.axial_stiffness
        assert lengths.sum() == pytest.approx(600.0 / (1 + strain), rel=1e-3), strain


def test_static_dropper_forces_match_the_hand_equilibrium():
    """The static solve of the assembled model (bending, extensible wires, tension-only
    droppers, support springs) from the design state moves it by the mesh error only:
    dropper forces and heights converge to the hand values (measured: 2.0 %, 0.53 %,
    0.079 % and 0.84, 0.23, 0.04 mm at 1, 0.5, 0.25 m elements; 5e-5 and 0.01 mm at
    0.125 m on 60 m spans). With a pre-sag of 5 mm (the wire on its parabola) the
    static solve stays within the same bounds at 0.5 m (same program): heights, and
    forces within 1 % of the largest dropper force, 0.48 N (measured 0.41 N, and 1.52 N
    at 1 m: the ratio 3.7 of the level wire; 1.9 % of the end droppers' 15 N)."""
    (f1, y1), (f2, y2) = static_dropper_errors(1.0), static_dropper_errors(0.5)
    assert f2 < 1e-2 and y2 < 5e-4, (f2, y2)
    assert f1 / f2 > 3 and y1 / y2 > 3, (f1, f2, y1, y2)
    fp, yp = static_dropper_errors(0.5, presag=0.005)
    assert fp < 1e-2 * 48.5 and yp < 5e-4, (fp, yp)


def test_moving_force_on_the_builders_contact_wire():
    """The catenary's contact wire (20 kN, 1.35 kg/m, EI 195 N·m², engineering strain,
    stress-free length L / (1 + T / EA)) pinned over 60 m, gravity off, a 5 N force at
    250 km/h (v = 0.57 c): deflection under the load against the (linear) modal series
    while the load crosses the middle half. Second order in the element length: 0.12 %
    of the peak at 0.5 m elements, 4× that at 1 m. (The load is small because the
    series is linear: at 100 N the stretching by the 14 cm deflection raises the
    tension by ~2 % and the deflection differs by 0.75 % at any mesh.)"""
    from ancf_jax import mesh
    from ancf_jax.functions import ConstantSpeed
    from ancf_jax.model import node
    from ancf_jax.section import Section
    from ancf_jax.simulation import simulate
    wire = CatenaryDesign().contact
    length, v, force = 60.0, 250 / 3.6, 5.0
    eps = wire.tension / wire.axial_stiffness
    mu = wire.mass_per_length / (1 + eps)
    errors = []
    for n in (60, 120):
        m = Model(gravity=(0.0, 0.0))
        track = mesh.straight((0.0, 0.0), (1.0, 0.0), length / (1 + eps), n)
        nodes = np.asarray(track.reference_nodes).copy()
        nodes[:, 0] *= 1 + eps
        nodes[:, 2] = 1 + eps
        m.add_beam("wire", track, Section.from_stiffness(wire.axial_stiffness, wire.bending_stiffness,
                                                         wire.mass_per_length),
                   formulation=WIRE_FORMULATION, initial_nodes=nodes)
        m.pin("a", node("wire", 0))
        m.pin("b", node("wire", -1))
        m.moving_force("P", "wire", (0.0, -force), path=ConstantSpeed(0.0, v))
        # straight, stretched and at rest between the pins: consistent as built (the
        # assembly's projection, a dense SVD of the padded model, is 2 s per build)
        system, state = m.build(pad_to=120, assemble=False)
        res = simulate(system, state, t_end=0.75 * length / v, dt=5e-4, output_dt=5e-3, progress=False)
        load = res.moving_load("P")
        t = np.asarray(res.t)
        sel = (load[:, 1] > 0.25 * length) & (load[:, 1] < 0.75 * length)
        w = moving_load_series(t[sel], load[sel, 1], v, wire.tension, mu, wire.bending_stiffness, length, force,
                               modes=2000)
        errors.append(np.max(np.abs(load[sel, 2] + w)) / np.max(np.abs(w)))
    assert errors[1] < 2e-3 and errors[0] / errors[1] > 3.0, errors


@pytest.fixture(scope="module")
def small_runs():
    """The small catenary at 250 km/h: 1 m elements and 1 ms steps, and the run of
    itself with both halved (made only for the validation study that compares them).
    One compiled program: both wires have 60 element slots, the runs are chunks of 400
    steps with outputs at every step."""
    design = lambda el: CatenaryDesign(element_length=el, alpha=0.06, beta=7.6e-5, **RUN)  # noqa: E731
    return LazyRuns(lambda el: run_pantograph_catenary(design(el), speed_kmh=250, dt=1e-3 * el, pad_to=60, t_end=0.4,
                                                    spans=(2, 2), chunks=round(1 / el)))


@pytest.mark.study
def test_contact_force_against_the_fine_run_of_itself(small_runs):
    """Filtered contact force over the evaluated span against the run with half the
    elements and half the step. The convergence study of this catenary
    (docs/pantograph-catenary.md: 1, 0.5, 0.25 m against 0.125 m, steps in proportion)
    measured second order, RMS errors 1.66, 0.54, 0.076 N of a 15.2 N standard
    deviation and statistics within 1.1 N of the reference at 1 m: the coarse run
    differs from the fine one by about its own error. The bounds (RMS 0.5–4 N,
    statistics 3 N) leave room for platforms and for the shorter run here."""
    coarse, fine = small_runs[1.0], small_runs[0.5]
    sel = (coarse.x >= coarse.window[0]) & (coarse.x <= coarse.window[1])
    fine_on_coarse = np.interp(coarse.t[sel], fine.t, fine.filtered)
    d = np.sqrt(np.mean((coarse.filtered[sel] - fine_on_coarse) ** 2))
    assert 0.5 < d < 4.0, d  # a difference that vanished would mean the runs were not refined
    for key in ("mean_N", "std_N", "max_N", "min_N"):
        assert abs(coarse.statistics[key] - fine.statistics[key]) < 3.0, key
    # uplift at the support [mm]: 17.9, 18.5 at 1 and 0.5 m in the study (18.6 at 0.125 m)
    uplift = coarse.statistics["uplift_support_mm"], fine.statistics["uplift_support_mm"]
    assert uplift[1] > 1.0 and abs(uplift[0] - uplift[1]) < 1.5, uplift
    assert fine.statistics["contact_loss_pct"] == 0.0 == coarse.statistics["contact_loss_pct"]
    assert coarse.statistics["spans_evaluated"] == [2, 2]


def test_against_ranges_gives_the_verdicts():
    """against_ranges: values inside, on either bound and outside the EN 50318:2002
    ranges at 250 and 300 km/h get the right verdicts (bounds are inside); other
    speeds, 275 or 250.5 km/h, have no ranges (None)."""
    from ancf_jax.models.catenary import EN50318_2002_RANGES, against_ranges
    for speed, ranges in EN50318_2002_RANGES.items():
        for pick, inside in ((lambda lo, hi: 0.5 * (lo + hi), True), (lambda lo, hi: lo, True),
                             (lambda lo, hi: hi, True), (lambda lo, hi: lo - 0.01, False),
                             (lambda lo, hi: hi + 0.01, False)):
            stats = dict(speed_kmh=float(speed), **{k: pick(*r) for k, r in ranges.items()})
            rows = against_ranges(stats)
            assert [row["key"] for row in rows] == list(ranges)
            assert all(row["inside"] is inside and row["value"] == stats[row["key"]] for row in rows), (speed, rows)
            assert all((row["low"], row["high"]) == ranges[row["key"]] for row in rows)
    assert EN50318_2002_RANGES[250]["std_N"] == (26, 31) and EN50318_2002_RANGES[300]["stat_min_N"] == (-5, 20)
    mixed = dict({k: lo for k, (lo, hi) in EN50318_2002_RANGES[250].items()}, speed_kmh=250.0, mean_N=109.0)
    assert [row["key"] for row in against_ranges(mixed) if not row["inside"]] == ["mean_N"]
    for speed in (275.0, 250.5, 200.0):
        assert against_ranges(dict(mixed, speed_kmh=speed)) is None


def test_statistics_of_a_known_signal():
    """contact_statistics on a sampled 5 Hz + 60 Hz signal: the 20 Hz filter removes
    the 60 Hz part (zero phase), mean and σ are those of the 5 Hz part, statistical
    extremes mean ± 3σ, losses the share of samples at or below zero."""
    t = np.arange(0, 2.0, 1e-3)
    slow = 100 + 30 * np.sin(2 * np.pi * 5 * t)
    f = slow + 20 * np.sin(2 * np.pi * 60 * t)
    f[:100] = 0.0  # a loss of contact outside the window
    stats = contact_statistics(t, 100 * t, f, window=(50.0, 150.0))
    inner = (t >= 0.5) & (t <= 1.5)
    assert abs(stats["mean_N"] - 100) < 0.5 and abs(stats["std_N"] - 30 / np.sqrt(2)) < 0.3
    np.testing.assert_allclose(stats["filtered"][inner], slow[inner], atol=0.5)
    assert stats["stat_max_N"] == pytest.approx(stats["mean_N"] + 3 * stats["std_N"])
    assert stats["contact_loss_pct"] == 0.0
    assert contact_statistics(t, 100 * t, f, window=(0.0, 50.0))["contact_loss_pct"] == pytest.approx(20.0, abs=0.3)
    # a record too short for the zero-phase filter's padding: one line naming the length,
    # not scipy's padlen error (the 4-pole filter pads 15 samples; 16 are filtered)
    with pytest.raises(ModelError, match="more than 15 samples, got 15"):
        contact_statistics(t[:15], 100 * t[:15], f[:15], window=(0.0, 1.5))
    assert lowpass(f[:16], 1e-3).shape == (16,)


#: the shipped scenario reduced to RUN at 0.5 m elements
SCENARIO_RUN = ["catenary.spans=3", "catenary.span_length=10.0", "catenary.droppers=[2.0, 5.0, 8.0]",
                "catenary.element_length=0.5", "pantograph.spans=[2, 2]"]


def test_shipped_scenario_is_the_python_model_and_the_cli_writes_the_contract(small_runs, tmp_path):
    """The shipped scenario's tables build the same system and initial state as the
    Python API (reduced to the small catenary; the static solve is the program of the
    tests above), its run ends one span past the evaluated ones, and the CLI's report
    writes statistics.json with the contract's keys, contact_force.csv with its
    columns, and the figures."""
    from ancf_jax.models.catenary import STATISTICS_KEYS
    from ancf_jax.reports import report_pantograph
    from ancf_jax.scenario import load_scenario

    from .json_units import assert_unit_keys
    sc = load_scenario("pantograph_catenary", SCENARIO_RUN)
    system, state = sc.build()
    m, _ = pantograph_catenary(sc.spec.catenary.design(), sc.spec.pantograph.design(), speed=250 / 3.6)
    ref_system, guess = m.build(assemble=False, pad_to=60)
    ref_state, _ = moving_equilibrium(ref_system, guess)
    assert system.beam_names == ref_system.beam_names and system.n_coordinates == ref_system.n_coordinates
    np.testing.assert_allclose(state.q, ref_state.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(state.v, ref_state.v, rtol=0, atol=1e-12)
    assert sc.solver.t_end == pytest.approx((min(2 * 10.0 + 10.4166, 30.0 - 1.0) - 0.2) / (250 / 3.6))
    data = report_pantograph(small_runs[1.0], tmp_path)
    stored = assert_unit_keys(tmp_path / "statistics.json")
    assert all(k in stored for k in STATISTICS_KEYS) and stored["speed_kmh"] == 250.0 == data["speed_kmh"]
    assert [row["key"] for row in stored["en50318_2002"]][:2] == ["mean_N", "std_N"]
    header = (tmp_path / "contact_force.csv").read_text().splitlines()[0]
    assert header == "t,x,contact_force_N,contact_force_filtered_N"
    for fig in ("contact_force.png", "uplift.png", "dropper_slack.png"):
        assert (tmp_path / fig).stat().st_size > 0


def test_the_checks_use_the_pantograph_runs_end():
    """A pantograph run ends before solver.t_end (one span past the evaluated ones):
    the scenario's run and the checker's time grids end at the same time
    (:func:`~ancf_jax.scenario.build.run_end`), and an output interval longer than
    the run but shorter than solver.t_end is refused, naming the run time."""
    from ancf_jax.scenario import load_scenario
    from ancf_jax.scenario.build import pantograph_run_time
    from ancf_jax.scenario.checks import Checker
    from ancf_jax.scenario.errors import ScenarioError
    sc = load_scenario("pantograph_catenary", SCENARIO_RUN)
    end, checker = sc.solver.t_end, Checker(sc.spec)  # the run's end, as simulate gets it
    assert end < 0.5 * sc.spec.solver.t_end and end == pytest.approx(pantograph_run_time(sc.spec), rel=1e-12)
    assert checker.output_times()[-1] == pytest.approx(end, rel=1e-12)
    assert checker.step_times()[-1] == pytest.approx(end, rel=1e-12)
    with pytest.raises(ScenarioError, match="longer than the run, the pantograph's run time"):
        load_scenario("pantograph_catenary", SCENARIO_RUN + [f"outputs.dt={end + 0.5:g}"])


def _static(design, pantograph, *, speed, start=None, trailing=(), uplifts=None):
    """Static state at t = 0 of the small catenary's model (the tests' program: 60
    element slots): (system, built state, solved state); ``uplifts``: F₀ of each
    pantograph, set in the built system's data."""
    import equinox as eqx
    m, _ = pantograph_catenary(design, pantograph, speed=speed, start=start, trailing=trailing)
    system, guess = m.build(assemble=False, pad_to=60)
    if uplifts is not None:
        for k, f in enumerate(uplifts):
            i = next(j for j, e in enumerate(system.forces) if e.name == f"{pantograph_name(k + 1)}.uplift")
            system = eqx.tree_at(lambda s: s.forces[i].static, system, jnp.asarray(f, float))
    state, _ = moving_equilibrium(system, guess)
    return system, guess, state


def _balance(system, guess, state, name):
    """(vertical contact force on the head [N], frame rise Δy₁ [m], uplift [N]) of
    pantograph ``name`` in a static state. The contact force acts along the wire's
    normal: its vertical part is F_n cos θ (θ the wire's slope, ~1.5e-3 rad here, so
    1.2e-6 F_n less than F_n); the prescribed x of the head takes the rest."""
    contact = next(f for f in system.forces if f.name == f"{name}.contact")
    uplift = next(f for f in system.forces if f.name == f"{name}.uplift")
    iy = system.body_offset(system.body_names.index(f"{name}.1")) + 1
    head = system.body_offset(system.body_names.index(f"{name}.{len(PantographDesign().masses)}")) + 1
    q0 = jnp.zeros_like(state.q)
    return (-float(contact.generalized_force(system, state.q, q0, 0.0)[head]),
            float(state.q[iy] - guess.q[iy]), float(uplift.magnitude(0.0)))


def test_aerodynamic_uplift_shifts_the_static_balance():
    """The uplift F₀ + c v² (EN 50367's AC curve, c = 0.00097 · 3.6² N/(m/s)², 48.6 N
    at 250 km/h) in the static state at t = 0: the chain's masses carry no weight, so
    its balance is contact force = F₀ + c v² − k₁ Δy₁ (the frame spring) exactly, and
    the contact force rises by c v² less the frame spring's share. The force reads the
    path's speed leaf: setting the pantograph's speed (``speed.pantograph``) moves it,
    with dF/dv = 2 c v by autodiff. (Balance to the static solve's round-off: 3e-11 N
    measured.)"""
    import jax

    from ancf_jax.identification.parameters import resolve
    design = CatenaryDesign(element_length=1.0, alpha=0.06, beta=7.6e-5, **RUN)
    v, c = 250 / 3.6, 0.00097 * 3.6 ** 2
    k1 = PantographDesign().stiffness[0]
    forces = []
    for coefficient in (0.0, c):
        system, guess, state = _static(design, PantographDesign(aero_coefficient=coefficient), speed=v)
        fc, dy, uplift = _balance(system, guess, state, "pantograph")
        assert uplift == pytest.approx(100.0 + coefficient * v * v, rel=1e-15)
        assert abs(fc - (uplift - k1 * dy)) < 1e-8, (fc, uplift, k1 * dy)
        forces.append((fc, dy))
    (f0, y0), (f1, y1) = forces
    assert f1 - f0 == pytest.approx(c * v * v - k1 * (y1 - y0), abs=1e-8)
    assert 0.9 * c * v * v < f1 - f0 < c * v * v  # the frame spring takes a few per cent
    speed = resolve(system, "speed.pantograph")[0]

    def uplift_at(w):
        return next(f for f in speed.set(system, w).forces if f.name == "pantograph.uplift").magnitude(0.0)
    assert float(uplift_at(300 / 3.6)) == pytest.approx(100.0 + c * (300 / 3.6) ** 2, rel=1e-14)
    assert float(jax.grad(uplift_at)(v)) == pytest.approx(2 * c * v, rel=1e-14)


@pytest.mark.study
def test_two_pantographs_share_the_wire_statically():
    """Two pantographs at rest on the small catenary, 7 m apart between droppers
    (x = 6.5 and 13.5 m): each one's static balance holds (contact force = uplift −
    k₁ Δy₁), and the pair obeys Maxwell–Betti reciprocity: 1 N more uplift on one
    raises the other's frame as much as 1 N more on the other raises the one's (the
    tangent stiffness of a conservative system is symmetric; measured 7.9e-7 relative
    at 1 N and 4.0e-7 at 0.5 N: the finite step's own error, first order in it; B's
    frame rises by 4.7 % of A's own rise)."""
    design = CatenaryDesign(element_length=1.0, alpha=0.06, beta=7.6e-5, **RUN)
    kw = dict(speed=0.0, start=13.5, trailing=(7.0,))
    names = ("pantograph", pantograph_name(2))
    k1 = PantographDesign().stiffness[0]
    rises = {}
    for uplifts in ((100.0, 100.0), (101.0, 100.0), (100.0, 101.0)):
        system, guess, state = _static(design, PantographDesign(), uplifts=uplifts, **kw)
        balance = [_balance(system, guess, state, n) for n in names]
        for (fc, dy, uplift), f in zip(balance, uplifts):
            assert uplift == f and abs(fc - (uplift - k1 * dy)) < 1e-8, (fc, uplift, dy)
        rises[uplifts] = np.array([dy for _, dy, _ in balance])
    base = rises[(100.0, 100.0)]
    ab = rises[(101.0, 100.0)][1] - base[1]  # B's rise per N on A
    ba = rises[(100.0, 101.0)][0] - base[0]  # A's rise per N on B
    assert ab > 0 and abs(ab - ba) < 1e-5 * ab, (ab, ba)


def test_a_trailing_pantograph_that_would_enter_the_line_is_refused():
    """A trailing pantograph may start off the line only if it never reaches it during
    the run: otherwise the run is refused before anything is built. (That one far
    behind leaves the leading run unchanged was checked on the small catenary to 1e-9 N
    when this was built; the run needs a program of its own, 41 s of the suite.)"""
    design = CatenaryDesign(element_length=1.0, alpha=0.06, beta=7.6e-5, **RUN)
    with pytest.raises(ModelError, match="pantograph2 starts off the line"):
        run_pantograph_catenary(design, speed_kmh=250, start=0.2, trailing=(20.0,), t_end=0.4)


def test_a_list_of_speeds_on_the_command_line_is_read_and_checked(tmp_path, capsys):
    """``--set pantograph.speed_kmh=[...]`` is taken as a batch of speeds (the other
    overrides kept), and its misuses are one-line usage errors before anything is
    built: a speed given twice, --elements, a speed outside the key's range, a
    trailing pantograph that the run would take onto the line."""
    from ancf_jax.cli import _speed_list, main
    assert _speed_list(["catenary.spans=3", "pantograph.speed_kmh=[250, 300.0]"]) == ([250, 300.0],
                                                                                      ["catenary.spans=3"])
    assert _speed_list(["pantograph.speed_kmh=300"]) == (None, ["pantograph.speed_kmh=300"])
    out = str(tmp_path / "out")
    for extra, message in ((["--set", "pantograph.speed_kmh=[250, 250.0]"], "250 km/h is given twice"),
                           (["--set", "pantograph.speed_kmh=[250]", "--elements", "4"], "argument --elements"),
                           (["--set", "pantograph.speed_kmh=[250, 700]"], "pantograph.speed_kmh"),
                           (["--set", "pantograph.speed_kmh=[250]", "--set", "pantograph.start=100.0",
                             "--set", "pantograph.trailing=[150.0]"], "pantograph2 starts off the line")):
        assert main(["run", "pantograph_catenary", "--out", out, *extra]) == 2, extra
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err


def test_results_until_cuts_every_history():
    """Results.until keeps the outputs at t <= t_end (to 1e-9 of a step) in every
    history, and is the results themselves when nothing is cut."""
    from ancf_jax.results import Results
    t = np.arange(6) * 0.1
    arrays = {k: np.arange(12.0).reshape(6, 2) for k in ("q", "v", "acc", "lam", "work")}
    r = Results(None, t, iterations=np.arange(6), checkpoint="end", **arrays)
    cut = r.until(0.3 + 1e-12)
    assert cut.t.shape == (4,) and cut.q.shape == cut.work.shape == (4, 2) and cut.iterations.shape == (4,)
    assert cut.checkpoint is None and r.until(0.5) is r and r.until(0.29).t[-1] == pytest.approx(0.2)


def test_trailing_statistics_and_report(small_runs, tmp_path):
    """The trailing pantograph's analysis and files, on the recorded single run: its
    contact force taken as both pantographs' (a stand-in results object), the leading
    one 1 m ahead of the recorded start, so the trailing one is the recorded
    pantograph: its statistics are the single run's, under ``trailing`` with
    ``spacing_m``; statistics.json keeps the leading keys and its units convention, and
    contact_force.csv adds the trailing columns."""
    from ancf_jax.models.catenary import analyse_pantograph_run
    from ancf_jax.reports import report_pantograph

    from .json_units import assert_unit_keys
    single = small_runs[1.0]
    recorded = single.results
    force = recorded.contact("pantograph.contact")

    class Both:  # the recorded run, its pantograph's contact answering for either name
        t, q, system = recorded.t, recorded.q, recorded.system
        summary = recorded.summary

        @staticmethod
        def contact(name):
            assert name in ("pantograph.contact", "pantograph2.contact"), name
            return force

    design = CatenaryDesign(element_length=1.0, alpha=0.06, beta=7.6e-5, **RUN)
    run = analyse_pantograph_run(Both, design, speed_kmh=250, start=single.x[0] + 1.0, spans=(2, 2),
                                 trailing=(1.0,))
    (row,), (behind,) = run.statistics["trailing"], run.trailing
    assert row["spacing_m"] == 1.0 and row == dict(single.statistics, spacing_m=1.0)
    np.testing.assert_array_equal(behind.filtered, single.filtered)
    report_pantograph(run, tmp_path, figures=False)
    stored = assert_unit_keys(tmp_path / "statistics.json")
    assert stored["trailing"][0]["mean_N"] == single.statistics["mean_N"] and "mean_N" in stored
    header = (tmp_path / "contact_force.csv").read_text().splitlines()[0]
    assert header == ("t,x,contact_force_N,contact_force_filtered_N,pantograph2_x,pantograph2_contact_force_N,"
                      "pantograph2_contact_force_filtered_N")
