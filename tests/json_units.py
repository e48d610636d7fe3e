"""The units convention of the JSON files the command line writes (issue 25): every
number's key either ends in its unit (``max_abs_sigma_e1_mid_Pa``, ``mean_N``,
``dt_s``; :func:`ancf_jax.outputs.unit_suffix`), is named in the file's ``units`` map,
or is dimensionless (a count, a ratio, a damage, a p-value: :data:`DIMENSIONLESS`).

:func:`assert_unit_keys` walks a file (summary.json, fatigue.json, study.json,
fit.json, the JSON of ``static --json``) and lists every key that breaks it.
"""

import json
import re
from pathlib import Path

from ancf_jax.outputs import unit_suffix

#: key endings that are a unit (SI symbols; N*m as Nm, a/b as a_per_b, b^2 as b2)
SUFFIX = re.compile(r"_(s|m|mm|N|Nm|J|Pa|Hz|rad|kg|h|hours|pct|kmh|(?:[A-Za-z]+_)?per_[A-Za-z0-9]+)$")

#: keys of numbers without a unit: counts, ratios, relative errors, damages, statistics
DIMENSIONLESS = frozenset({
    # run summaries (max_*constraint_violation: in the units of each constraint equation,
    # m for positions and - for slopes, so no one suffix; energy_balance_error: relative)
    "elements", "element_counts", "outputs", "newton_iterations", "max_constraint_violation",
    "max_velocity_constraint_violation", "energy_balance_error", "steps", "substeps_per_output",
    "batch_size", "load_steps",
    # fatigue
    "max_damage", "damage", "life_repeats", "life_passes", "points", "scf", "reference_cycles",
    "knee_cycles", "cutoff_cycles", "m1", "m2",
    # fits: counts, p-values, correlations, shifts in standard errors
    "iterations", "evaluations", "n_samples", "n", "ljung_box_q", "ljung_box_p", "ljung_box_lags",
    "lag1_autocorrelation", "rms_over_noise", "chi2_p_high", "chi2_p_low", "matrix", "members", "seed",
    "converged", "limit_se", "budget", "remaining_shift_se", "max_shift_se", "step_divided_by",
    "elements_multiplied_by", "final_elements", "record",
})


def _numeric(v) -> bool:
    if isinstance(v, bool):
        return False
    if isinstance(v, (int, float)):
        return True
    return isinstance(v, list) and bool(v) and all(_numeric(x) or x is None for x in v) and any(
        _numeric(x) for x in v)


def _walk(obj, path, units, bad, inherited):
    if isinstance(obj, list):
        for i, x in enumerate(obj):
            if isinstance(x, (dict, list)) and not _numeric(x):
                _walk(x, f"{path}[{i}]", units, bad, inherited)
        return
    if not isinstance(obj, dict):
        return
    for key, value in obj.items():
        if key == "units":
            continue
        column = re.match(r"(.+)_(min|max)$", key)
        ok = (inherited or key in DIMENSIONLESS or key in units or SUFFIX.search(key) is not None
              or (column is not None and isinstance(units.get(column.group(1)), str)
                  and unit_suffix(units[column.group(1)]) == ""))
        where = f"{path}.{key}" if path else key
        if _numeric(value) and not ok:
            bad.append(where)
        elif isinstance(value, (dict, list)):
            # a dict under a key with its unit holds values keyed by name (beam, parameter)
            named = inherited or (key not in DIMENSIONLESS and ok)
            _walk(value, where, units, bad, named)


def assert_unit_keys(source) -> dict:
    """Assert the units convention on a JSON file (path) or its parsed data; returns
    the data. A column's ``NAME_min``/``NAME_max`` may go without a suffix when the
    file's ``units`` map gives NAME a dimensionless or mixed unit."""
    data = json.loads(Path(source).read_text()) if isinstance(source, (str, Path)) else source
    units = data.get("units", {}) if isinstance(data, dict) else {}
    bad = []
    _walk(data, "", units, bad, False)
    assert not bad, f"numbers without a unit in their key or the units map: {', '.join(bad)}"
    return data
