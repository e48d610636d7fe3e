"""The key tables of ``docs/scenario-format.md``, generated from the schema.

``python -m ancf_jax.scenario.docs docs/scenario-format.md`` rewrites the part of the
page between the markers; the test suite checks that the page is up to date, so the
documentation cannot drift from the schema.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from pydantic_core import PydanticUndefined

from . import schema as S
from .describe import accepted
from .expressions import FUNCTIONS

BEGIN = "<!-- BEGIN GENERATED KEY TABLES (python -m ancf_jax.scenario.docs) -->"
END = "<!-- END GENERATED KEY TABLES -->"

#: (heading, table class) in the order of the page
TABLES = [
    ("Top level", S.ScenarioSpec),
    ("`[beams.NAME]`", S.BeamSpec),
    ('`[beams.NAME.geometry]` with `type = "straight"`', S.Straight),
    ('`[beams.NAME.geometry]` with `type = "points"`', S.ThroughPoints),
    ('`[beams.NAME.geometry]` with `type = "arc"`', S.Arc),
    ("`[beams.NAME.section]`", S.SectionSpec),
    ("`[beams.NAME.formulation]`", S.FormulationSpec),
    ("`[beams.NAME.initial]`", S.BeamInitial),
    ('`[beams.NAME.axial_law]`, `[beams.NAME.bending_law]` with `type = "linear"`', S.LinearLawSpec),
    ('… with `type = "strain_rate_damped"`', S.StrainRateDampedLawSpec),
    ('… with `type = "bilinear"`', S.BilinearLawSpec),
    ('… with `type = "tabulated"`', S.TabulatedLawSpec),
    ("`[[beams.NAME.masses]]`", S.AttachedMassSpec),
    ("`[bodies.NAME]`", S.BodySpec),
    ("`[moving_masses.NAME]`", S.MovingMassSpec),
    ("`[chains.NAME]`", S.ChainSpec),
    ("`[catenary]`", S.CatenarySpec),
    ("`[catenary.contact]`, `[catenary.messenger]`", S.WireSpec),
    ("`[pantograph]`", S.PantographSpec),
    ("Point references (`point`, `a`, `b`, `at`)", S.PointRef),
    ('`[joints.NAME]` with `type = "clamp"`', S.ClampSpec),
    ('`[joints.NAME]` with `type = "pin"`', S.PinSpec),
    ('`[joints.NAME]` with `type = "revolute"`', S.RevoluteSpec),
    ('`[joints.NAME]` with `type = "fixed"`', S.FixedSpec),
    ('`[joints.NAME]` with `type = "sliding"`', S.SlidingSpec),
    ("`[joints.NAME.friction]` (sliding joints) and `[loads.NAME.friction]` (contacts)", S.FrictionSpec),
    ("`[joints.NAME.drive]` (sliding joints)", S.DriveSpec),
    ('`[joints.NAME]` with `type = "prescribed_point"`', S.PrescribedPointSpec),
    ('`[joints.NAME]` with `type = "prescribed_body"`', S.PrescribedBodySpec),
    ('`[joints.NAME]` with `type = "coordinate"`', S.CoordinateSpec),
    ('`[loads.NAME]` with `type = "point_force"`', S.PointForceSpec),
    ('`[loads.NAME]` with `type = "torque"`', S.TorqueSpec),
    ('`[loads.NAME]` with `type = "spring_damper"`', S.SpringDamperSpec),
    ('`[loads.NAME]` with `type = "mass_proportional"`', S.MassProportionalSpec),
    ('`[loads.NAME]` with `type = "moving_force"`', S.MovingForceSpec),
    ('`[loads.NAME]` with `type = "contact"`', S.ContactSpec),
    ("`[initial]`", S.InitialSpec),
    ("`[statics]`", S.StaticsSpec),
    ("`[modal]`", S.ModalSpec),
    ("`[solver]`", S.SolverSpec),
    ("`[solver.generalized_alpha]`", S.GeneralizedAlphaOptions),
    ("`[solver.rk4]`, `[solver.explicit_euler]`", S.ExplicitOptions),
    ("`[solver.diffrax]`", S.DiffraxOptions),
    ("`[outputs]`", S.OutputsSpec),
    ('`[outputs.columns.NAME]` with `type = "node"`', S.NodeOutput),
    ('`[outputs.columns.NAME]` with `type = "point"`', S.PointOutput),
    ('`[outputs.columns.NAME]` with `type = "body"`', S.BodyOutput),
    ('`[outputs.columns.NAME]` with `type = "sliding"`', S.SlidingOutput),
    ('`[outputs.columns.NAME]` with `type = "sliding_point"`', S.SlidingPointOutput),
    ('`[outputs.columns.NAME]` with `type = "stress"`', S.StressOutput),
    ('`[outputs.columns.NAME]` with `type = "axial"`', S.AxialOutput),
    ('`[outputs.columns.NAME]` with `type = "bending"`', S.BendingOutput),
    ('`[outputs.columns.NAME]` with `type = "reaction"`', S.ReactionOutput),
    ('`[outputs.columns.NAME]` with `type = "energy"`', S.EnergyOutput),
    ('`[outputs.columns.NAME]` with `type = "member"`', S.MemberOutput),
    ('`[outputs.columns.NAME]` with `type = "friction"`', S.FrictionOutput),
    ('`[outputs.columns.NAME]` with `type = "drive"`', S.DriveOutput),
    ('`[outputs.columns.NAME]` with `type = "contact"`', S.ContactOutput),
    ('`[outputs.columns.NAME]` with `type = "load"`', S.LoadOutput),
    ("`[fatigue]`", S.FatigueSpec),
    ("`[fatigue.sn_curve]`", S.SNCurveSpec),
    ("`[fatigue.concentrations.NAME]`", S.ConcentrationSpec),
    ("`[fatigue.points.NAME]`", S.FatiguePointSpec),
]


def _default(field) -> str:
    if field.is_required():
        return "**required**"
    value = field.default
    if value is None:
        return "—"
    if value is PydanticUndefined:
        return "**required**"
    if isinstance(value, S.Table):
        return "(table)"
    if isinstance(value, dict) and not value:
        return "{}"
    if isinstance(value, tuple):
        value = list(value)
    return "`" + json.dumps(value).replace("|", "\\|") + "`"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(cls) -> str:
    """Markdown table of one schema class: key, accepted, unit, default, meaning."""
    lines = [_cell(" ".join((cls.__doc__ or "").split())), "",
             "| key | accepted | unit | default | meaning |", "| --- | --- | --- | --- | --- |"]
    for name, field in cls.model_fields.items():
        unit = (field.json_schema_extra or {}).get("unit", "")
        lines.append(f"| `{name}` | {_cell(accepted(field.annotation, field, unit=False, short=True))} | "
                     f"{unit or '—'} | {_default(field)} | {_cell(field.description or '')} |")
    return "\n".join(lines)


def functions_table() -> str:
    """Markdown table of the functions of the safe expression set."""
    lines = ["| function | arguments | meaning |", "| --- | --- | --- |"]
    for name, (_, arity, doc) in FUNCTIONS.items():
        lines.append(f"| `{name}` | {arity} | {_cell(doc)} |")
    return "\n".join(lines)


def generated() -> str:
    """The generated part of the page (between :data:`BEGIN` and :data:`END`)."""
    parts = [BEGIN, ""]
    for heading, cls in TABLES:
        parts += [f"### {heading}", "", table(cls), ""]
    parts += ["### Functions of time expressions", "", functions_table(), "", END]
    return "\n".join(parts)


def splice(page: str) -> str:
    """``page`` with its generated part replaced by :func:`generated`."""
    start, end = page.index(BEGIN), page.index(END) + len(END)
    return page[:start] + generated() + page[end:]


def main(argv=None) -> int:
    """Regenerate the key tables of a scenario-format page in place (default
    ``docs/scenario-format.md``)."""
    args = sys.argv[1:] if argv is None else argv
    path = Path(args[0] if args else "docs/scenario-format.md")
    path.write_text(splice(path.read_text(encoding="utf-8")), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
