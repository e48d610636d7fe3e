"""Fatigue (ancf_jax.fatigue, ``ancf-jax fatigue``): rainflow against ASTM E1049-85,
constant-amplitude Miner sums in closed form, the Eurocode 3 curve shape, mean-stress
corrections by hand, Dirlik and rainflow against the Rayleigh closed form on
narrow-band Gaussian records, jax.grad of the spectral damage against central
differences, and the command line end to end on a 2-element M1."""

import csv
import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import rainflow
from scipy.special import gamma

from ancf_jax import fatigue as F
from ancf_jax.cli import main
from ancf_jax.element.stress import bending_stress
from ancf_jax.element.strain_energy import axial_strain

from .json_units import assert_unit_keys

MPA = 1e6


# ----------------------------------------------------------------------------- rainflow
def test_rainflow_astm_e1049_example():
    """ASTM E1049-85 §5.4.4 example (Fig. 6 history −2, 1, −3, 5, −1, 3, −4, 4, −2):
    the standard's cycle table is range 3: ½, 4: 1½, 6: ½, 8: 1, 9: ½ (half cycles
    of the residue count ½)."""
    r, m, c = F.cycles([-2, 1, -3, 5, -1, 3, -4, 4, -2])
    table = {}
    for rr, cc in zip(r, c):
        table[float(rr)] = table.get(float(rr), 0.0) + float(cc)
    assert table == {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}
    assert set(c.tolist()) <= {0.5, 1.0}
    # means of the standard's cycles: the full cycle 4 (−1 to 3) has mean 1
    assert any(rr == 4.0 and cc == 1.0 and mm == 1.0 for rr, mm, cc in zip(r, m, c))


def test_rainflow_on_reversals_equals_the_library_on_every_sample(rng):
    """cycles() hands only the turning points to the library; the cycles are those the
    library finds in the whole history (plateaus and repeated samples included)."""
    x = np.round(rng.standard_normal(3000), 1)          # many equal neighbours
    r, m, c = F.cycles(x)
    ref = np.array([(a, b, d) for a, b, d, _, _ in rainflow.extract_cycles(x)])
    np.testing.assert_array_equal(np.stack([r, m, c], axis=1), ref)
    assert F.cycles([1.0])[0].size == 0
    with pytest.raises(ValueError, match="NaN"):
        F.cycles([0.0, np.nan, 1.0])


# ----------------------------------------------------------------------------- S-N curves
def test_eurocode_curve_shape():
    """EN 1993-1-9 Fig. 7.1: Δσ_D = (2/5)^(1/3) Δσ_C ≈ 0.737 Δσ_C at 5e6 cycles,
    Δσ_L = (5/100)^(1/5) Δσ_D ≈ 0.549 Δσ_D at 1e8, slopes 3 and 5, nothing below."""
    c = F.SNCurve.eurocode(71 * MPA)
    knee, cut = float(c.knee_range), float(c.cutoff_range)
    assert knee == pytest.approx((2 / 5) ** (1 / 3) * 71 * MPA, rel=1e-14)
    assert cut == pytest.approx((5 / 100) ** (1 / 5) * knee, rel=1e-14)
    assert knee / (71 * MPA) == pytest.approx(0.737, abs=5e-4)       # printed in the standard
    assert cut / knee == pytest.approx(0.549, abs=5e-4)
    n = lambda s: float(c.cycles_to_failure(s))  # noqa: E731
    assert n(71 * MPA) == pytest.approx(2e6, rel=1e-13)
    assert n(knee * (1 + 1e-12)) == pytest.approx(5e6, rel=1e-9)
    assert n(knee * (1 - 1e-12)) == pytest.approx(5e6, rel=1e-9)     # continuous at the knee
    assert n(cut * (1 + 1e-12)) == pytest.approx(1e8, rel=1e-9)
    assert math.isinf(n(cut * (1 - 1e-9)))
    # slopes from two points on each branch
    assert math.log(n(100 * MPA) / n(200 * MPA)) / math.log(2) == pytest.approx(3.0, rel=1e-12)
    assert math.log(n(40 * MPA) / n(50 * MPA)) / math.log(50 / 40) == pytest.approx(5.0, rel=1e-12)


def test_power_law_and_endurance_limit():
    k, m = 1e12 * MPA**4, 4.0                        # N = K S^-m (S in Pa)
    p = F.SNCurve.power_law(m, k)
    for s in (1 * MPA, 50 * MPA, 500 * MPA):
        assert float(p.cycles_to_failure(s)) == pytest.approx(k * s**-m, rel=1e-12)
    e = F.SNCurve.power_law(m, k, endurance_limit=80 * MPA)
    assert float(e.cycles_to_failure(90 * MPA)) == pytest.approx(k * (90 * MPA) ** -m, rel=1e-12)
    assert math.isinf(float(e.cycles_to_failure(79 * MPA)))


def test_mean_stress_corrections_by_hand():
    """Δσ = 100, σ_m = 200, σ_u = 800: Goodman 100/(1 − ¼) = 133.33…, Gerber
    100/(1 − 1/16) = 106.66…; compressive means are not credited; σ_m ≥ σ_u fails."""
    r, m, u = 100.0, np.array([200.0, -300.0, 800.0]), 800.0
    assert np.asarray(F.equivalent_range(r, m, "none")) == pytest.approx(100.0)
    good = np.asarray(F.equivalent_range(r, m, "goodman", u))
    ger = np.asarray(F.equivalent_range(r, m, "gerber", u))
    assert good[:2] == pytest.approx([400.0 / 3.0, 100.0], rel=1e-14) and math.isinf(good[2])
    assert ger[:2] == pytest.approx([1600.0 / 15.0, 100.0], rel=1e-14) and math.isinf(ger[2])
    with pytest.raises(Exception, match="ultimate"):
        F.equivalent_range(r, m, "goodman")


# ----------------------------------------------------------------------------- Miner
@pytest.mark.parametrize("range_mpa", [100.0, 45.0, 20.0])   # first slope, second slope, below cut-off
def test_constant_amplitude_sinusoid_miner_exact(range_mpa):
    """n periods of −A cos(2πt/T) (40 samples each): n cycles of range 2A (some as
    pairs of half cycles), so D = n / N(2A) exactly."""
    n, a = 200, range_mpa * MPA / 2
    x = -a * np.cos(2 * np.pi * np.arange(n * 40 + 1) / 40)
    r, _, c = F.cycles(x)
    assert c.sum() == n
    np.testing.assert_allclose(r, 2 * a, rtol=1e-12)
    curve = F.SNCurve.eurocode(71 * MPA)
    d = F.rainflow_damage(x, curve)
    assert d == pytest.approx(n / float(curve.cycles_to_failure(2 * a)) if range_mpa > 30 else 0.0,
                              rel=1e-12, abs=0.0)
    assert d == pytest.approx(F.sinusoid_damage(a, n, curve), rel=1e-12, abs=0.0)
    # with a tensile mean and Goodman: the same, at the equivalent range
    dg = F.rainflow_damage(x + 150 * MPA, curve, "goodman", 600 * MPA)
    assert dg == pytest.approx(n * float(curve.damage_per_cycle(2 * a / 0.75)), rel=1e-12, abs=0.0)
    assert F.life(d) == (pytest.approx(1 / d) if d > 0 else math.inf)


# ----------------------------------------------------------------------------- spectral
def _band_records(rng, count, n, dt, f0, bw, sigma):
    """Stationary Gaussian narrow-band records: white noise through an ideal band-pass
    (FFT), scaled so that the process (not each record) has standard deviation σ."""
    f = np.fft.rfftfreq(n, dt)
    band = np.abs(f - f0) <= bw / 2
    out = []
    for _ in range(count):
        w = np.fft.rfft(rng.standard_normal(n))
        w[~band] = 0.0
        out.append(np.fft.irfft(w, n) * sigma / np.sqrt(2 * band.sum() / n))
    nu0 = np.sqrt(np.sum(f[band] ** 2) / band.sum())            # √(m2/m0) of the band
    return np.array(out), nu0


def test_narrow_band_gaussian_dirlik_rainflow_rayleigh(rng):
    """40 records of 2^15 samples (164 s, ≈1640 cycles each) of a Gaussian process in
    the band 9.5–10.5 Hz, σ = 20 MPa, N = K Δσ^-3.

    Expected agreement, stated: rainflow and Dirlik means within 8 % of the Rayleigh
    closed form D = ν₀ T (2√2 σ)^m Γ(1 + m/2) / K (the finite bandwidth makes rainflow
    a little lower, ≈2 %), and Dirlik within 4 % of rainflow on the same records. The
    scatter is measured, not assumed: the standard error of the mean over records
    (about 2 % for either method here, 0.6 % for the paired Dirlik/rainflow ratio) must
    be below a third of the tolerance, so the comparison can fail only by a method error.
    """
    dt, n, m, sigma = 0.005, 2**15, 3.0, 20 * MPA
    k = 1e12 * MPA**m
    curve = F.SNCurve.power_law(m, k)
    x, nu0 = _band_records(rng, 40, n, dt, 10.0, 1.0, sigma)
    ref = nu0 * n * dt * (2 * math.sqrt(2) * sigma) ** m * gamma(1 + m / 2) / k
    assert float(F.rayleigh_damage(sigma, nu0, n * dt, m, k)) == pytest.approx(ref, rel=1e-12)
    rf = np.array([F.rainflow_damage(r, curve) for r in x])
    dl = np.asarray(jax.jit(jax.vmap(lambda r: F.dirlik_damage(r, dt, curve, nperseg=4096)))(jnp.asarray(x)))
    stderr = lambda a: a.std(ddof=1) / np.sqrt(len(a))  # noqa: E731
    for d in (rf, dl):
        assert stderr(d / ref) < 0.08 / 3
        assert d.mean() / ref == pytest.approx(1.0, abs=0.08)
    ratio = dl / rf
    assert stderr(ratio) < 0.04 / 3
    assert ratio.mean() == pytest.approx(1.0, abs=0.04)


def test_spectral_integrals_against_closed_forms(rng):
    """The Z-grid integrals against the closed forms for a power law: Dirlik
    ν_p T/K (2√m₀)^m [D₁ Q^m Γ(1+m) + √2^m Γ(1+m/2)(D₂|R|^m + D₃)] and the narrow-band
    formula, on a wide-band record (so that all three Dirlik terms matter)."""
    dt, m, k = 0.01, 4.0, 1e10 * MPA**4
    x = jnp.asarray(np.convolve(rng.standard_normal(4096), np.ones(4) / 4, "same") * 10 * MPA)
    curve = F.SNCurve.power_law(m, k)
    f, g = F.welch(x, dt, 512)
    m0, m1, m2, m4 = (float(v) for v in F.spectral_moments(f, g))
    d1, d2, d3, q, r = (float(v) for v in F.dirlik_coefficients(m0, m1, m2, m4))
    assert min(d1, d2, d3) > 0.05
    t = 4096 * dt
    closed = (math.sqrt(m4 / m2) * t / k * (2 * math.sqrt(m0)) ** m
              * (d1 * q**m * gamma(1 + m) + 2 ** (m / 2) * gamma(1 + m / 2) * (d2 * abs(r) ** m + d3)))
    assert float(F.dirlik_damage(x, dt, curve, nperseg=512)) == pytest.approx(closed, rel=1e-7)
    nb = float(F.rayleigh_damage(math.sqrt(m0), math.sqrt(m2 / m0), t, m, k))
    assert float(F.narrow_band_damage(x, dt, curve, nperseg=512)) == pytest.approx(nb, rel=1e-7)
    # Parseval: the PSD integrates to the variance of the (windowed, demeaned) record
    assert m0 == pytest.approx(float(jnp.var(x)), rel=0.05)


def test_dirlik_gradient_wrt_damping_of_the_stress_process(rng):
    """d(damage)/d(ζ) by jax.grad through the PSD against central differences: the
    stress is white noise through a single-degree-of-freedom filter of damping ratio ζ
    (natural frequency 5 Hz), built in JAX, so the gradient passes the FFTs, the Welch
    PSD, Dirlik's coefficients and the S–N curve with its knee."""
    dt, n = 0.01, 4096
    w = jnp.fft.rfft(jnp.asarray(rng.standard_normal(n)))
    f = jnp.fft.rfftfreq(n, dt)
    curve = F.SNCurve.eurocode(36 * MPA)

    def damage(zeta):
        r = f / 5.0
        h = 1.0 / (1.0 - r**2 + 2j * zeta * r)
        x = 20 * MPA * jnp.fft.irfft(w * h, n)        # σ ≈ 26 MPa at ζ = 0.05
        return F.dirlik_damage(x, dt, curve, nperseg=1024)

    z, eps = 0.05, 1e-6
    damage = jax.jit(damage)
    g = float(jax.jit(jax.grad(damage))(z))
    fd = (float(damage(z + eps)) - float(damage(z - eps))) / (2 * eps)
    assert g < 0.0                           # more damping, less damage
    assert g == pytest.approx(fd, rel=1e-6)


# ----------------------------------------------------------------------------- beams
@pytest.fixture(scope="module")
def bent_history():
    """A 2-element cantilever (the M1 section) and a prescribed history: stretched
    by 0.1 % and bent back and forth (no simulation: the stresses are a function of q)."""
    from ancf_jax import mesh
    from ancf_jax.model import Model
    from ancf_jax.section import Section
    m = Model()
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), 0.4, 2), Section.circle(1e-3, 200e9, density=7850.0))
    system, state = m.build()
    t = np.linspace(0.0, 1.0, 201)
    q0 = np.asarray(state.q)
    x = q0[0::4][:3]
    q = np.repeat(q0[None], t.size, axis=0)
    for i, xx in enumerate(x):                    # y = a(t) x², slope (1.001, 2 a x)
        a = 0.3 * np.sin(2 * np.pi * 3 * t) + 0.1 * np.sin(2 * np.pi * 7 * t)
        q[:, 4 * i] = 1.001 * xx
        q[:, 4 * i + 1] = a * xx**2
        q[:, 4 * i + 2] = 1.001
        q[:, 4 * i + 3] = 2 * a * xx
    return system, jnp.asarray(q), t


def test_fibre_stress_is_axial_plus_bending(bent_history):
    system, q, t = bent_history
    beam = system.beams[0]
    k, xi, s = F.points_along(beam, "barlow")
    assert s == pytest.approx(np.array([0.5 - 0.5 / 3**0.5, 0.5 + 0.5 / 3**0.5, 1.5 - 0.5 / 3**0.5,
                                        1.5 + 0.5 / 3**0.5]) * 0.2)
    sig = np.asarray(F.stress_history(system, 0, q, jnp.asarray(k), jnp.asarray(xi), None, "exact", 2.0))
    nodes = system.beam_nodes(q[37], 0)
    e = beam.mesh.element_coordinates(nodes)[1]
    er = beam.mesh.reference_elements[1]
    x, l = float(xi[3]) * 0.2, 0.2
    c = float(beam.section.fibre_distance)
    axial = 200e9 * float(axial_strain(e, er, x, l))
    bend = float(bending_stress(e, er, x, l, 200e9, c))
    assert sig[37, 3] == pytest.approx([2 * (axial + bend), 2 * (axial - bend)], rel=1e-12)
    # the Hermite cubics reproduce r = (1.001 X, a X²): Green–Lagrange ε = ½(|r'|² − 1)
    a = 0.3 * np.sin(2 * np.pi * 3 * t[37]) + 0.1 * np.sin(2 * np.pi * 7 * t[37])
    assert axial == pytest.approx(200e9 * 0.5 * (1.001**2 + (2 * a * s[3]) ** 2 - 1), rel=1e-9)
    # the axial-force output N = EA·ε at the same arc length
    assert float(beam.axial_force(nodes, s[3])) == pytest.approx(axial * float(beam.section.area), rel=1e-12)
    ks, xis, ss = F.points_at(beam, [0.0, 0.25, 0.4])
    assert ks.tolist() == [0, 1, 1] and xis == pytest.approx([0.0, 0.25, 1.0])


def test_dirlik_gradient_wrt_section_through_beam_stresses(bent_history):
    """d(damage)/d(fibre distance c) through the surface stresses of a beam (the section
    enters σ = N/A ± E c κ) against central differences."""
    system, q, t = bent_history
    k, xi, _ = F.points_along(system.beams[0], "barlow")
    curve = F.SNCurve.eurocode(71 * MPA)
    dt = float(t[1] - t[0])

    def damage(c):
        sysc = eqx.tree_at(lambda s: s.beams[0].section.fibre_distance, system, c)
        sig = F.stress_history(sysc, 0, q, jnp.asarray(k[:1]), jnp.asarray(xi[:1]))
        return F.dirlik_damage(sig[:, 0, 0], dt, curve, correction="goodman", ultimate_strength=1.6e9)

    c0, eps = 5e-4, 1e-9
    damage = jax.jit(damage)
    g = float(jax.jit(jax.grad(damage))(c0))
    fd = (float(damage(c0 + eps)) - float(damage(c0 - eps))) / (2 * eps)
    assert g > 0.0 and g == pytest.approx(fd, rel=1e-5)


# ----------------------------------------------------------------------------- command line
def test_cli_fatigue_end_to_end(tmp_path, capsys):
    """`ancf-jax fatigue m1 --elements 2` over 0.2 s: the files, their columns and keys,
    the hot spot is the largest damage of the CSV, life = 1/damage. (Outputs every 2 ms:
    the run of the study's host path below, one compiled program for both.)"""
    out = tmp_path / "f"
    rc = main(["fatigue", "m1", "--elements", "2", "--t-end", "0.2", "--out", str(out), "--no-progress",
               "--set", "fatigue.hours_per_run=0.001", "--set", "outputs.dt=0.002"])
    assert rc == 0, capsys.readouterr().err
    with open(out / "damage.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["beam", "s", "damage", "life_repeats"]
    data = np.array([[float(v) for v in r[1:]] for r in rows[1:]])
    assert len(data) == 4 and {r[0] for r in rows[1:]} == {"beam"}        # 2 Barlow points x 2 elements
    assert (data[:, 1] > 0).all()
    np.testing.assert_allclose(data[:, 2], 1 / data[:, 1], rtol=1e-9)
    info = assert_unit_keys(out / "fatigue.json")
    assert {"max_damage", "hot_spot", "sn_curve", "method", "units"} <= set(info)
    assert info["method"] == "rainflow"
    i = int(np.argmax(data[:, 1]))
    assert info["max_damage"] == pytest.approx(data[i, 1], rel=1e-9)
    assert info["hot_spot"]["beam"] == "beam" and info["hot_spot"]["s_m"] == pytest.approx(data[i, 0])
    # named after the nearest joint holding the beam (clamp at s = 0, tip joint at the end)
    hs = info["hot_spot"]
    joint, at = min((("clamp", 0.0), ("tip_joint", 0.402)), key=lambda j: abs(j[1] - hs["s_m"]))
    assert hs["near"] == dict(joint=joint, distance_m=pytest.approx(abs(at - hs["s_m"])))
    assert info["life_hours"] == pytest.approx(0.001 / info["max_damage"], rel=1e-9)
    assert info["sn_curve"]["reference_range_Pa"] == 160e6 and info["units"]["s_m"] == "m"
    for name in ("cycles_hot_spot.png", "damage_along.png"):
        assert (out / name).stat().st_size > 1000


def test_cli_fatigue_bad_input_exits_2_before_compiling(tmp_path, capsys):
    assert main(["fatigue", "m1", "--set", 'fatigue.mean_stress="goodman"', "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "ultimate_strength" in err and len(err.splitlines()) == 1
    assert main(["fatigue", "m1", "--set", 'fatigue.method="miner"']) == 2
    assert main(["fatigue", "m1", "--set", "fatigue.t_start=9.0"]) == 2
    assert not any(tmp_path.iterdir())


# ----------------------------------------------------------------------------- studies
@pytest.fixture(scope="module")
def cli_study(tmp_path_factory):
    """`ancf-jax fatigue m1 --study alpha=0.499,0.5,0.501` (2 elements, 0-0.2 s, outputs
    every 2 ms, points at the clamp and at s = 0.2 m), run once for the two tests below,
    with the arguments and the StudyResult of the API's ``fatigue.study`` that the command
    calls (recorded by a wrapper): the vmapped study with its forward-mode derivative is
    the longest program of this module to trace (a new trace at every call of ``study``),
    so it is traced once for both."""
    import ancf_jax.fatigue
    calls = []
    api = ancf_jax.fatigue.study

    def recording(system, state, parameters, values, settings, **kw):
        res = api(system, state, parameters, values, settings, **kw)
        calls.append(dict(system=system, state=state, settings=settings, kw=kw, result=res))
        return res

    out = tmp_path_factory.mktemp("study") / "s"
    ancf_jax.fatigue.study = recording
    try:
        rc = main(["fatigue", "m1", "--elements", "2", "--t-end", "0.2", "--out", str(out), "--study",
                   "alpha=0.499,0.5,0.501", "--set", "outputs.dt=0.002",
                   "--set", 'fatigue.points.a={beam="beam", s=0.0}', "--set", 'fatigue.points.b={beam="beam", s=0.2}'])
    finally:
        ancf_jax.fatigue.study = api
    assert len(calls) == 1
    return rc, out, calls[0]


def test_study_of_damage_against_damping_with_its_derivative_through_the_run(cli_study):
    """fatigue.study (as ``ancf-jax fatigue --study`` calls it): M1 (2 elements, 0-0.2 s),
    Dirlik damage at the clamp and at s = 0.2 m for three values of the Rayleigh alpha in
    one vmapped program, with d(damage)/d(alpha) by forward mode through the simulated run
    (implicit differentiation of every Newton solve). Checked against (1) central
    differences of the study's own outer members, and (2) the host path for the middle
    member, an independent code path (simulate -> Results -> analyse with method "dirlik")."""
    from ancf_jax.simulation import simulate

    _, _, call = cli_study
    res, kw = call["result"], call["kw"]
    a0, da = 0.5, 1e-3
    np.testing.assert_array_equal(res.values[:, 0], [a0 - da, a0, a0 + da])
    assert kw["t_end"] == 0.2 and kw["dt"] == 1e-3 and kw["output_dt"] == 0.002
    assert float(call["system"].beams[0].mesh.n_elements) == 2
    assert res.names == ("alpha",) and res.damage.shape == (3, 2) and res.jacobian.shape == (3, 2, 1)
    np.testing.assert_allclose(res.s, [0.0, 0.2])
    assert (res.status == 0).all() and (res.damage > 0).all()
    assert res.hot_spot[1] == dict(beam="beam", s_m=0.0)        # the clamp
    fd = (res.damage[2] - res.damage[0]) / (2 * da)
    assert np.all(np.abs(fd) > 1e-3 * res.damage[1])            # alpha matters
    np.testing.assert_allclose(res.jacobian[1, :, 0], fd, rtol=1e-5)
    np.testing.assert_allclose(res.max_damage_gradient()[1], res.jacobian[1, 0])
    # the host path: the run of the middle member (alpha = 0.5), rainflow's settings with Dirlik
    system = eqx.tree_at(lambda s: s.beams[0].alpha, call["system"], jnp.asarray(a0))
    st = dataclasses.replace(call["settings"], method="dirlik")
    run = {k: kw[k] for k in ("t_end", "dt", "output_dt", "solver")}
    host = F.analyse(simulate(system, call["state"], **run, progress=False), st)
    np.testing.assert_allclose(res.damage[1], host.damage, rtol=1e-9)


def test_study_refuses_bad_values_before_compiling():
    from ancf_jax.errors import ModelError
    from ancf_jax.models.m1 import m1_model

    system, state = m1_model(2).build()
    st = F.FatigueSettings(F.SNCurve.eurocode(160 * MPA), at=(("beam", 0.0),))
    with pytest.raises(ModelError, match=r"shape \(members, 1\)"):
        F.study(system, state, "alpha", np.ones((2, 2)), st, t_end=0.1, dt=1e-3)
    with pytest.raises(ModelError, match="unknown parameter"):
        F.study(system, state, "zeta", [1.0], st, t_end=0.1, dt=1e-3)
    with pytest.raises(ModelError, match="t_start"):
        F.study(system, state, "alpha", [1.0], dataclasses.replace(st, t_start=1.0), t_end=0.1, dt=1e-3)


def test_cli_fatigue_study_writes_one_row_per_value(tmp_path, capsys, cli_study):
    """`ancf-jax fatigue m1 --study alpha=...`: study.csv has the members in order,
    their max damage, hot spot and derivative, and agrees with the API's study it ran
    (the fixture above); bad values exit 2 before compiling."""
    out = tmp_path / "s"
    assert main(["fatigue", "m1", "--study", "alpha=oops", "--out", str(out)]) == 2
    assert main(["fatigue", "m1", "--study", "alpha=1,2", "--study", "beta=1e-5", "--out", str(out)]) == 2
    assert main(["fatigue", "m1", "--study", "gamma=1,2", "--out", str(out)]) == 2
    assert not out.exists()
    rc, out, call = cli_study
    assert rc == 0
    with open(out / "study.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["alpha"]) for r in rows] == [0.499, 0.5, 0.501]
    assert all(r["status"] == "ok" and r["hot_beam"] == "beam" and float(r["hot_s"]) == 0.0 for r in rows)
    d = np.array([float(r["max_damage"]) for r in rows])
    g = np.array([float(r["d_max_damage_d_alpha"]) for r in rows])
    assert d[2] < d[0] and (g < 0).all()                    # more damping, less damage
    res = call["result"]
    np.testing.assert_allclose(d, res.max_damage, rtol=1e-15)
    np.testing.assert_allclose(g, res.max_damage_gradient()[:, 0], rtol=1e-15)
    info = assert_unit_keys(out / "study.json")
    assert info["parameters"] == ["alpha"] and info["method"] == "dirlik"
    assert info["hot_spot"][1] == dict(beam="beam", s_m=0.0) and info["points"]["s_m"] == [0.0, 0.2]
    np.testing.assert_allclose(info["max_damage"], d, rtol=1e-15)
