"""Damping identification (issue 7): fit Rayleigh α, β of model M1 to tip displacement.

Every fit here uses one problem — M1 with 3 elements, 1 s, generalized-α at h = 2 ms,
samples at 500 Hz — so that two compiled programs serve all tests: residuals with the
forward-mode Jacobian of (α, β) for one member (fit, gradient, synthetic data, and the
CLI, which builds the same problem in-process), and the same under ``vmap`` for batches
of two members (initial guesses, noise seeds). 3 elements instead of 6 keep M1's
physics (the same wire, tip body, release under gravity and large swing) at a lower
cost per evaluation; the synthetic data come from the same discretisation, so noise-free
recovery is exact. Over 1 s at 500 Hz α is only marginally determined by 1 mm of noise
(standard error about 0.02 1/s, as large as α); the 20-seed study on the paper's 2 s at
1 kHz is ``benchmarks/identification_study.py`` (docs/identification.md). The coverage
test on foreign data adds one program: the run at h = 1 ms that makes its data and
serves the discretization check.
"""

import csv
import json

import numpy as np
import pytest

from ancf_jax.cli import main
from ancf_jax.errors import ModelError
from ancf_jax.identification import DataError, Measurements, Problem, fit, fit_batch, read_csv, synthesize
from ancf_jax.identification.report import DETERMINED, FIXED, ZERO

from .json_units import assert_unit_keys

#: the fits run each program dozens of times: compiled at XLA's LLVM level 3, not the
#: suite's 0 (tests/conftest.py, measured there)
COMPILER_OPTIONS = {"xla_backend_optimization_level": 3}
TRUTH = {"alpha": 0.02, "beta": 0.0}
ELEMENTS, T_END, DT, RATE, SIGMA = 3, 1.0, 2e-3, 500.0, 1e-3
#: the batched tests' members: two, one vmapped program of two members for both tests (on
#: the CPU a batch costs its slowest member's iterations for every member; the spread
#: over 20 seeds is test_coverage_on_foreign_data_seeds)
SEEDS = (0, 1)
CLI_PROBLEM = ["--elements", str(ELEMENTS), "--t-end", str(T_END), "--dt", str(DT)]


@pytest.fixture(scope="module")
def problem():
    return Problem.from_scenario("m1", ("alpha", "beta"), elements=ELEMENTS, t_end=T_END, dt=DT)


@pytest.fixture(scope="module")
def clean(problem):
    # simulated with the fits' program: one compilation for all single-member work
    data, _ = synthesize(problem, TRUTH, noise=0.0, rate=RATE, program="jacobian")
    assert len(data) == 501
    return data


def _noisy(clean, seed):
    rng = np.random.default_rng(seed)
    return Measurements.from_arrays(clean.t, clean.y + SIGMA * rng.standard_normal(len(clean)),
                                    source=f"noisy seed {seed}")


@pytest.fixture(scope="module")
def noisy(clean):
    """1 mm of noise on the same samples (seed fixed)."""
    return _noisy(clean, 7)


# ---------------------------------------------------------------------------- gradient
def test_gradient_equals_central_differences(problem, clean):
    """Forward-mode gradient of the loss with respect to θ = log p against central
    differences in θ, Richardson-extrapolated, off the optimum. Measured (Newton
    tolerance 1e-10 on the positions): plain central differences in θ are off by
    3.5e-5 (δθ = 1e-2), 3.5e-7 (1e-3, truncation, O(δθ²)) and 3e-8 (1e-4, truncation and
    Newton noise); the extrapolation (4 D(δθ/2) − D(δθ))/3 with δθ = 2e-3 removes the
    δθ² term, leaving the noise of about 1e-8, so the 1e-6 test has a wide margin."""
    p = np.array([0.05, 5e-5])
    loss, grad, ok = problem.loss_and_gradient(p, clean)
    assert ok and loss > 0 and np.all(grad > 0)  # more damping than the truth: loss rises with both
    grad_theta = grad * p

    def value(theta):
        r, *_ = problem.evaluate(np.exp(theta), [clean])
        return float(r[0] @ r[0])

    theta, h = np.log(p), 2e-3
    for k in range(2):
        e = np.zeros(2)
        e[k] = 1.0

        def central(step):
            return (value(theta + step * e) - value(theta - step * e)) / (2 * step)

        coarse, fine = central(h), central(h / 2)
        richardson = (4 * fine - coarse) / 3
        assert abs(richardson - grad_theta[k]) <= 1e-6 * abs(grad_theta[k]), \
            (problem.names[k], richardson, fine, coarse, grad_theta[k])
        assert abs(richardson - grad_theta[k]) < abs(fine - grad_theta[k])  # the δθ² term was the error


# ---------------------------------------------------------------------------- recovery
def test_noise_free_recovery_single(problem, clean):
    """From alpha = 0.08 (4x the truth) with beta free: alpha to 1e-4 relative, beta to
    its floor and reported as not identifiable, in a few iterations."""
    res = fit(problem, clean, {"alpha": 0.08, "beta": 1e-5})
    assert res.converged
    assert abs(res.estimates[0] - 0.02) <= 1e-4 * 0.02
    assert res.status == (DETERMINED, ZERO) and res.value("beta") is None
    assert res.iterations <= 8
    assert res.loss_history[-1] < 1e-12 * res.loss_history[0]
    assert all(b <= a for a, b in zip(res.loss_history, res.loss_history[1:]))  # LM never goes uphill
    d = res.to_dict()
    assert d["alpha_identifiable"] is True and d["beta_identifiable"] is False
    assert d["beta"] is None and "not distinguishable from zero" in d["beta_identifiability"]


def test_optax_adam_descends_on_log_alpha(problem, clean):
    """The optax path (Adam on θ = log α, β fixed) on the same compiled program: the best
    loss never rises and α moves from 0.005 towards 0.02 (Adam needs hundreds of
    iterations to converge; LM five)."""
    res = fit(problem, clean, {"alpha": 0.005, "beta": 0.0}, free=("alpha",), method="adam",
              learning_rate=0.1, max_iterations=12)
    assert res.method == "adam" and res.iterations == 12 and not res.converged
    assert all(b <= a for a, b in zip(res.loss_history, res.loss_history[1:]))
    assert res.loss_history[-1] < 0.5 * res.loss_history[0]
    assert 0.005 < res.estimates[0] < 0.04


@pytest.mark.slow  # compiles the vmapped program (the file's second compilation)
def test_noise_free_recovery_batched_initial_guesses(problem, clean):
    """Initial guesses at both ends of 0.005 to 0.08 (a quarter and four times the
    truth) under one vmap: both recover alpha to 1e-4."""
    inits = [{"alpha": a, "beta": 1e-5} for a in (0.005, 0.08)]
    results = fit_batch(problem, [clean], inits)
    for r, i in zip(results, inits):
        assert r.converged, r.stop_reason
        assert abs(r.estimates[0] - 0.02) <= 1e-4 * 0.02, (i, r.estimates)
        assert r.estimates[1] <= 1e-12 and r.status[1] == ZERO


@pytest.mark.slow  # compiles the vmapped program (the file's second compilation)
def test_noisy_alpha_within_three_standard_errors_batched_seeds(problem, clean):
    """1 mm noise, two seeds as one vmapped batch of data sets, beta fixed at its true
    0: alpha within 3 of its standard errors in every seed; the standard errors agree
    across seeds (they depend on the data only through the residual RMS, which
    estimates the noise: 501 samples, 3 % sampling error). The agreement of the SE with
    the scatter over seeds is test_coverage_on_foreign_data_seeds (20 seeds) and
    benchmarks/identification_study.py."""
    sets = [_noisy(clean, s) for s in SEEDS]
    results = fit_batch(problem, sets, [{"alpha": 0.01, "beta": 0.0}], free=("alpha",))
    se = np.array([r.stderr[0] for r in results])
    for r in results:
        assert r.converged and r.status[1] == FIXED, r.stop_reason
        assert abs(r.estimates[0] - 0.02) <= 3 * r.stderr[0], (r.estimates[0], r.stderr[0])
        assert abs(r.residual_rms / SIGMA - 1) < 0.1
    assert np.max(se) / np.min(se) < 1.2
    assert 0.01 < np.mean(se) < 0.04  # measured 0.023 1/s: alpha is marginal over 1 s


@pytest.mark.slow  # one program more: the 1 ms run that makes the data and serves the check
def test_coverage_on_foreign_data_seeds(problem):
    """Coverage of the reported standard errors on data the fitted model did not make
    (the 2 × finer step, so that the data and the discretization check share one
    program), with the default settings: 20 noise seeds of 0.1 mm, α free, β fixed at
    its true 0, after the default discretization check on seed 0 (step axis; the mesh
    axis and M1's paper settings are measured in benchmarks/identification_coverage.py)
    found the 2 ms model within its limit, so the fits run at 2 ms. The issue's
    criteria: the scatter of the estimates over seeds agrees with the mean reported SE
    within ±30 %, and the truth lies within 2 reported SE in at least 90 % of the seeds;
    the residuals are white in most. The seeds are fitted one by one with the file's
    single-member program: on the CPU a vmapped batch of four costs its slowest
    member's iterations for all four (measured: 13.6 s a batch against ~1.2 s a fit),
    and batched fits equal single ones (the batched tests above)."""
    _, clean = synthesize(problem.refined(step=2), TRUTH, noise=0.0, rate=RATE, program="values")
    t = np.arange(len(clean)) / RATE
    sigma = 1e-4
    records = [Measurements.from_arrays(t, clean + sigma * np.random.default_rng(100 + k).standard_normal(len(t)),
                                        source=f"finer step, seed {k}") for k in range(20)]
    # started at the truth: the estimates do not depend on the start (the noise-free
    # tests above recover α from 0.005 to 0.08), and LM stops in fewer iterations
    start = {"alpha": 0.02, "beta": 0.0}
    checked = fit(problem, records[0], start, free=("alpha",), noise=sigma,
                  discretization=True, refine_axes=("step",), strain_measure=False)
    dz = checked.discretization
    assert dz["within_limit"] and dz["refined"] == [] and dz["final_dt_s"] == DT, dz
    results = [checked] + [fit(problem, d, start, free=("alpha",), noise=sigma) for d in records[1:]]
    assert all(r.converged for r in results)
    est = np.array([r.estimates[0] for r in results])
    se = np.array([r.stderr[0] for r in results])
    ratio = est.std(ddof=1) / se.mean()
    inside = int(np.sum(np.abs(est - 0.02) <= 2 * se))
    assert 0.7 <= ratio <= 1.3, (ratio, est, se)
    assert inside >= 18, (inside, est, se)
    assert sum(r.diagnostics["white"] for r in results) >= 16


def test_beta_identifiability_reported_from_standard_error(problem, noisy):
    """Fitting alpha and beta to noisy tip data: beta is not printed as a number; the
    report gives its standard error, its 95 % upper bound, the correlation and why."""
    res = fit(problem, noisy, {"alpha": 0.01, "beta": 1e-5})
    assert res.converged
    k = res.names.index("beta")
    assert res.status[k] == ZERO
    d = res.to_dict()
    assert d["beta"] is None and d["beta_status"] == ZERO and d["beta_identifiable"] is False
    assert d["beta_stderr"] > 0 and d["beta_upper_95"] >= 2 * d["beta_stderr"]
    rho = d["correlation"]["matrix"][0][1]
    assert rho < -0.95  # measured -0.998: over 1 s both only damp the first mode
    assert "correlation with alpha" in d["beta_identifiability"]
    assert any("beta is not distinguishable from zero" in n for n in d["notes"])
    assert any("strongly correlated" in n for n in d["notes"])
    assert "beta  : not distinguishable from zero" in res.summary()


# ---------------------------------------------------------------------------- bad data
def _write(path, text):
    path.write_text(text)
    return path


GOOD = "".join(f"{0.01 * k:.2f},{-0.001 * k:.4f}\n" for k in range(12))


@pytest.mark.parametrize("text,expected", [
    ("t,y\n" + GOOD.replace("0.05,", "0.01,"), "line 7: t = 0.01 is not after the previous time 0.04 (line 6)"),
    ("t,y\n" + GOOD.replace("0.03,", "0.02,"), "line 5: t = 0.02 is not after the previous time 0.02"),
    ("t,y\n" + GOOD.replace("-0.0030", "nan"), "line 5: column y is NaN"),
    ("t,y\n" + GOOD.replace("-0.0030", "inf"), "line 5: column y is infinite"),
    ("t,y\n" + GOOD.replace("-0.0030", "abc"), "line 5: column y: 'abc' is not a number"),
    ("t,y\n" + GOOD.replace("-0.0030", ""), "line 5: column y: empty"),
    ("t,y\n" + GOOD.replace("0.03,-0.0030", "0.03,-0.0030,7"), "line 5: 3 fields, but the header has 2"),
    ("t,y\n" + "".join(GOOD.splitlines(True)[:9]), "9 samples; at least 10 are needed"),
    ("t,x\n" + GOOD, "line 1: missing column 'y' (header: t, x"),
    ("time,y\n" + GOOD, "line 1: missing column 't'"),
    (GOOD, "line 1: no header row"),
    ("t,y,t\n" + GOOD, "line 1: column 't' appears twice"),
    ("", "line 1: no header"),
    ("t,y\n", "no samples after the header"),
    ("t,y,w\n" + "".join(f"{0.01 * k:.2f},0,{-1 if k == 4 else 1}\n" for k in range(12)),
     "line 6: column w = -1 is negative"),
    ("# measured 2026-01-01\nt,y\n" + GOOD.replace("0.05,", "0.01,"), "line 8: t = 0.01 is not after"),
])
def test_bad_data_names_line_or_column(tmp_path, text, expected):
    path = _write(tmp_path / "data.csv", text)
    with pytest.raises(DataError) as e:
        read_csv(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}: ") and expected in msg and "\n" not in msg


def test_times_outside_the_simulated_span(problem, tmp_path):
    late = _write(tmp_path / "late.csv", "t,y\n" + "".join(f"{0.25 * k:g},0\n" for k in range(10)))
    with pytest.raises(DataError, match=r"late.csv: line 7: t = 1.25 s is after the end of the simulated "
                                        r"span \[0, 1\] s"):
        problem.prepare(read_csv(late))
    early = _write(tmp_path / "early.csv", "t,y\n" + "".join(f"{0.1 * k - 0.1:.1f},0\n" for k in range(12)))
    with pytest.raises(DataError, match=r"early.csv: line 2: t = -0.1 s is before the start"):
        problem.prepare(read_csv(early))
    ok = read_csv(_write(tmp_path / "ok.csv", "t,y\n" + GOOD))
    with pytest.raises(DataError, match=r"4 samples in the time window \[0, 0.03\] s; at least 10"):
        problem.prepare(ok, window=(0.0, 0.03))


def test_bad_arrays_name_the_sample():
    t = np.linspace(0, 1, 12)
    with pytest.raises(DataError, match="data: sample 3: column y is NaN"):
        Measurements.from_arrays(t, np.where(np.arange(12) == 3, np.nan, 0.0))
    with pytest.raises(DataError, match="t has 12 samples but y has 11"):
        Measurements.from_arrays(t, np.zeros(11))


def test_bad_parameters(problem):
    with pytest.raises(ModelError, match="unknown parameter 'gamma'"):
        Problem(problem.system, problem.state, ("alpha", "gamma"), dt=1e-3, t_end=1.0)
    with pytest.raises(ModelError, match="parameter 'mass.cabin': no body named 'cabin'"):
        Problem(problem.system, problem.state, ("mass.cabin",), dt=1e-3, t_end=1.0)
    with pytest.raises(ModelError, match="parameter alpha must be a finite number >= 0"):
        problem.vector({"alpha": -1.0})
    with pytest.raises(ModelError, match="no output named 'tip_z'"):
        Problem.from_scenario("m1", output="tip_z")
    # dotted scenario keys name the same parameters; a shape-changing key is refused
    from ancf_jax.identification.parameters import resolve
    a, m, e = resolve(problem.system, ["beams.beam.alpha", "bodies.tip.mass", "beams.beam.section.E"])
    assert (a.kind, a.target, m.kind, m.target, e.kind) == ("alpha", "beam", "mass", "tip", "E")
    assert a.name == "beams.beam.alpha"
    with pytest.raises(ModelError, match="beams.beam.elements: no derivative with respect to this key"):
        resolve(problem.system, ["beams.beam.elements"])


def test_parameters_are_set_on_the_built_system(problem):
    """E and the tip mass are traced leaves too: set, read back, and the system changes."""
    from ancf_jax.identification.parameters import resolve
    e, m = resolve(problem.system, ("E", "tip_mass"))
    assert (e.target, m.target, e.unit, m.unit) == ("beam", "tip", "Pa", "kg")
    s2 = m.set(e.set(problem.system, 1.5e11), 0.03)
    assert float(e.get(s2)) == 1.5e11 and float(m.get(s2)) == 0.03
    assert float(e.get(problem.system)) == 200e9 and float(m.get(problem.system)) == 0.02


# ---------------------------------------------------------------------------- CLI
@pytest.mark.parametrize("argv,needle", [
    (["synth", "m1", "--noise", "-1", "--out", "x.csv"], "--noise"),
    (["synth", "m1", "--noise", "0", "--rate", "0", "--out", "x.csv"], "--rate"),
    (["synth", "m1", "--noise", "0", "--t-end", "0.005", "--out", "x.csv"], "at least 10"),
    (["synth", "m1", "--noise", "0", "--alpha", "-0.1", "--out", "x.csv"], "--alpha"),
    (["fit", "m1", "--data", "missing.csv"], "missing.csv: cannot read"),
    (["fit", "m1", "--data", "{good}", "--params", "alpha,gamma"], "unknown parameter 'gamma'"),
    (["fit", "m1", "--data", "{bad}"], "line 7: t = 0.01 is not after the previous time 0.04"),
    (["fit", "m1", "--data", "{good}", "--init", "alpha=x"], "--init"),
    (["fit", "m1", "--data", "{good}", "--init", "zeta=1"], "unknown parameter(s) zeta"),
    (["fit", "m1", "--data", "{good}", "--window", "1,0"], "--window"),
    (["fit", "m1", "--data", "{good}", "--window", "0,0.03"], "4 samples in the time window"),
    (["fit", "m1", "--data", "{late}"], "is after the end of the simulated span"),
    (["fit", "m1", "--data", "{good}", "--output", "energy"], "no output named 'energy'"),
    # joint fits (--joint) and --profile: refused before anything is compiled
    (["fit", "m1", "--joint", "--data", "{good}"], "argument --joint: needs at least two --data records, got 1"),
    (["fit", "m1", "--data", "{good}", "--record-set", "gravity=[0.0, -5.0]"],
     "argument --record-set: only with --joint"),
    (["fit", "m1", "--joint", "--record-noise", "1e-4", "--data", "{good}"],
     "argument --record-noise: must follow the --data CSV"),
    (["fit", "m1", "--joint", "--data", "{good}", "--record-noise", "0", "--data", "{good}"],
     "argument --record-noise: must be a number > 0"),
    (["fit", "m1", "--joint", "--data", "{good}", "--record-noise", "1e-4", "--record-noise", "2e-4"],
     "argument --record-noise: given twice"),
    (["fit", "m1", "--joint", "--data", "{good}", "--record-noise", "1e-4", "--data", "{good}"],
     "record 2 (good.csv) has no noise level"),
    (["fit", "m1", "--joint", "--data", "{good}", "--data", "{good}", "--record-set", "beams.beam.nope=1"],
     "argument --record-set (record 2, good.csv):"),
    (["fit", "m1", "--joint", "--data", "{good}", "--data", "{good}", "--nuisance", "offset", "--init", "offset=0"],
     "unknown parameter(s) offset (parameters: alpha, beta, offset@1, offset@2)"),
    (["fit", "m1", "--joint", "--data", "{good}", "--data", "{good}", "--init", "alpha=0.01", "--init", "alpha=0.02"],
     "argument --joint: give at most one --init"),
    (["fit", "m1", "--joint", "--data", "{good}", "--data", "{good}", "--bootstrap", "4"],
     "argument --bootstrap: not with --joint"),
    (["fit", "m1", "--joint", "--data", "{good}", "--data", "{bad}"], "line 7: t = 0.01 is not after"),
    (["fit", "m1", "--data", "{good}", "--params", "alpha", "--profile", "beta"],
     "argument --profile: 'beta' is not a fitted parameter (fitted: alpha)"),
    (["fit", "m1", "--data", "{good}", "--data", "{good}", "--profile", "alpha"],
     "argument --profile: needs one --data (or --joint)"),
])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path / "bad.csv", "t,y\n" + GOOD.replace("0.05,", "0.01,"))
    _write(tmp_path / "good.csv", "t,y\n" + GOOD)
    _write(tmp_path / "late.csv", "t,y\n" + "".join(f"{0.25 * k:g},0\n" for k in range(10)))
    argv = [a.format(bad="bad.csv", good="good.csv", late="late.csv") for a in argv]
    try:
        code = main(argv)
    except SystemExit as e:
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err, err


def test_cli_synth_then_fit(tmp_path, capsys, problem, clean):
    """synth writes t,y at the rate; fit writes fit.json with the contract's keys and the
    figure. Same problem and sample count as the fixtures: no new compilation."""
    data = tmp_path / "data.csv"
    assert main(["synth", "m1", *CLI_PROBLEM, "--alpha", "0.02", "--beta", "0", "--rate", str(RATE),
                 "--noise", "2e-4", "--seed", "3", "--out", str(data)]) == 0
    with open(data) as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["t", "y"] and len(rows) == 1 + len(clean)
    t = np.array([float(r[0]) for r in rows[1:]])
    y = np.array([float(r[1]) for r in rows[1:]])
    np.testing.assert_allclose(np.diff(t), 1 / RATE, rtol=1e-9)
    assert np.std(y - clean.y) == pytest.approx(2e-4, rel=0.15)

    out = tmp_path / "fit"
    # --no-refine: these data come from the fitted discretization itself, so the
    # discretization check (on by default, tests/test_identification_real.py) does not apply
    assert main(["fit", "m1", *CLI_PROBLEM, "--data", str(data), "--params", "alpha",
                 "--init", "alpha=0.01", "--out", str(out), "--no-progress", "--no-refine"]) == 0
    report = assert_unit_keys(out / "fit.json")  # numbers with their unit: in the key or the units map
    for key in ("alpha", "beta", "alpha_stderr", "beta_stderr", "loss_history", "iterations", "wall_time_s",
                "dt_s", "residual_rms"):
        assert key in report
    assert report["units"]["alpha"] == "1/s" and report["units"]["residual_rms"] == "m"
    assert report["beta"] == 0.0 and report["beta_stderr"] is None and report["beta_status"] == FIXED
    assert report["alpha_stderr"] > 0 and report["iterations"] >= 1 and report["converged"]
    # 0.2 mm of noise: alpha is determined (standard error about 0.005 1/s)
    assert report["alpha_status"] == DETERMINED and report["alpha_identifiable"] is True
    assert abs(report["alpha"] - 0.02) <= 3 * report["alpha_stderr"]
    assert report["loss_history"][-1] <= report["loss_history"][0]
    assert (out / "fit.png").stat().st_size > 10_000
    assert "alpha" in capsys.readouterr().out
