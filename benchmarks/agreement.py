"""Agreement check before timing: the same models in both codes, identical settings.

M1 (6, 12, 24 elements), M2 (12, 18, 24) and the flexible pendulum H1 (docs/models.md; the
parameters of ``flexible_pendulum.toml`` with Exudyn's formulation instead of the
file's Green–Lagrange strain), each built from one ancf_jax system and translated to
Exudyn, integrated by both with index-3 generalized-α (ρ∞ = 0.9, h = 1 ms, full Newton,
tight tolerances; :data:`benchmarks.compare_exudyn.SETTINGS`). Reported: the maximum
over the run of the tip (M1, H1) or point-1 (M2) distance between the codes. M2 on the
Exudyn side with its sliding-joint term cancelled (the identical problem) and as
shipped (EXUDYN.md: an O(h) term).

    python -m benchmarks.agreement [--quick]
"""

from __future__ import annotations


from . import cases as C
from .common import write

FULL = dict(M1=[(6, 2.0), (12, 2.0), (24, 2.0)], M2=[(12, 1.0), (18, 1.0), (24, 1.0)], H1=[(16, 1.0)])
QUICK = dict(M1=[(6, 0.2)], M2=[(12, 0.1)], H1=[(8, 0.2)])
KEY = dict(M1="tip", M2="point1", H1="tip")


def main(argv=None, *, quick=None, exudyn=None):
    quick, exudyn = C.section_options(__doc__, argv, quick, exudyn)
    out = dict(section="agreement", quick=quick, exudyn=exudyn,
               command="python -m benchmarks.run" + (" --quick" if quick else "") + " --only agreement")
    if not exudyn:
        out["exudyn_missing"] = C.exudyn_missing_reason()
        out["rows"] = []
        return write("agreement", out)
    from .compare_exudyn import SETTINGS, _case
    plan = QUICK if quick else FULL
    rows = []
    for name, cases in plan.items():
        for n, t_end in cases:
            initial = C.model(name, n)
            variants = [False, True] if name == "M2" else [False]
            ancf = None
            for cancel in variants:
                row, ancf = _case(name, n, 0, t_end, initial, dt=SETTINGS["dt"], output_dt=SETTINGS["output_dt"],
                                  cancel=cancel, ancf=ancf)
                row["max_distance_m"] = row["max_difference"][KEY[name]]
                row["compared_output"] = KEY[name]
                rows.append(row)
                print(f"agreement {name} n={n} ({row['exudyn_variant']}): max {KEY[name]} difference "
                      f"{row['max_distance_m']:.2e} m over {row['t_compared']:.2f} s", flush=True)
    out.update(settings=SETTINGS, rows=rows)
    return write("agreement", out)


if __name__ == "__main__":
    import sys
    print(main(sys.argv[1:]))
