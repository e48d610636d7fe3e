"""Moving loads and contact in scenario files: the example of docs/scenario-format.md
(a pre-tensioned wire pinned at both ends, a moving force, a moving mass and a
two-stage pantograph in contact with the wire) builds into the system it describes;
bad moving-load input gives one line naming the key and what is accepted, before
anything is built or compiled. Nothing is run (the dynamics are tested on the builder
in tests/test_moving_loads.py)."""

import re
from pathlib import Path

import numpy as np
import pytest

from ancf_jax.contact import AtArcLength, AtHorizontalPosition, MovingForce, UnilateralContact
from ancf_jax.errors import ModelError
from ancf_jax.forces import DirectedSpringDamper, PointForce
from ancf_jax.functions import ConstantSpeed
from ancf_jax.joints import PathCoordinate
from ancf_jax.scenario import ScenarioError, load_scenario

from .conftest import write

PAGE = Path(__file__).resolve().parents[2] / "docs" / "scenario-format.md"


def doc_example() -> str:
    """The TOML example of the page's section "Moving loads and contact"."""
    text = PAGE.read_text(encoding="utf-8")
    section = text[text.index("## Moving loads and contact"):text.index("## Example: model M1")]
    return re.search(r"```toml\n(.*?)```", section, re.S).group(1)


EXAMPLE = doc_example()


def test_the_documented_example_validates_without_building(tmp_path, no_build):
    with no_build():
        sc = load_scenario(str(write(tmp_path, EXAMPLE)))
    assert sc.name == "wire_crossing"
    assert "1 moving mass: wagon (0.05 kg on wire); 1 chain: pan (2 masses);" in sc.summary()
    assert [(o.name, o.kind, o.target, o.component) for o in sc.outputs] == [
        ("contact_force", "contact", "touch", "force"), ("gap", "contact", "touch", "gap"),
        ("under_load", "load", "P", "y"), ("head_y", "body", "pan.2", "y"),
        ("wagon_s", "sliding", "wagon.slider", "s"), ("wagon_drive", "drive", "wagon.drive", "force")]


def test_the_example_builds_into_the_system_the_file_describes(tmp_path):
    sc = load_scenario(str(write(tmp_path, EXAMPLE)), ['loads.P.profile="0.01 * sin(2*pi*t)"',
                                                       "loads.P.time_function=0.5"])
    system, state = sc.build()
    assert system.beam_names == ("wire",)
    assert system.body_names == ("wagon", "pan.1", "pan.2")      # moving mass, then the chain
    assert system.sliding_names == ("wagon.slider",)
    assert [c.name for c in system.constraints] == ["wagon.drive", "pan.1.x", "pan.2.x", "a", "b", "wagon.slider",
                                                   "wagon.rotation", "pan.1.rotation", "pan.2.rotation"]
    forces = {f.name: f for f in system.forces}
    assert list(forces) == ["pan.stage1", "pan.stage2", "pan.2.force", "P", "touch"]

    # the moving force: under x(t) = 0 + 5 t + 0.01 sin(2 pi t), scaled by 0.5
    p = forces["P"]
    assert isinstance(p, MovingForce) and isinstance(p.location, AtHorizontalPosition)
    assert isinstance(p.location.path, ConstantSpeed)
    assert (float(p.location.path.start), float(p.location.path.speed)) == (0.0, 5.0)
    assert float(p.location.path(0.25)) == pytest.approx(5 * 0.25 + 0.01, abs=1e-12)
    np.testing.assert_array_equal(np.asarray(p.force), [0.0, -0.01])
    assert float(p.time_function(0.3)) == 0.5

    # the contact: the chain's head below the wire (1 mm into it: see the initial state)
    c = forces["touch"]
    assert isinstance(c, UnilateralContact)
    assert (c.side, float(c.stiffness), float(c.damping), float(c.offset)) == (-1.0, 1e3, 1.0, 0.0)
    assert c.beam == 0 and c.point.body == system.body_names.index("pan.2")

    # the chain: two stages along +y, unstressed as built; the uplift on the head
    s1, s2 = forces["pan.stage1"], forces["pan.stage2"]
    assert isinstance(s1, DirectedSpringDamper) and isinstance(s2, DirectedSpringDamper)
    assert [float(s.stiffness) for s in (s1, s2)] == [100.0, 1000.0]
    assert [float(s.damping) for s in (s1, s2)] == [1.0, 0.5]
    assert [float(s.rest_length) for s in (s1, s2)] == pytest.approx([0.3, 0.201], abs=1e-15)
    assert isinstance(forces["pan.2.force"], PointForce)
    paths = {k.name: k for k in system.constraints if isinstance(k, PathCoordinate)}
    assert set(paths) == {"wagon.drive", "pan.1.x", "pan.2.x"}
    assert [(float(paths[n].path.start), float(paths[n].path.speed)) for n in ("wagon.drive", "pan.1.x")] == [
        (0.1, 2.0), (0.2, 1.0)]

    # initial state: the wagon on the wire at x = 0.1, the chain's masses above its base;
    # the joints set their velocities from the paths
    q, v = np.asarray(state.q), np.asarray(state.v)
    poses = {name: q[system.body_offset(k):system.body_offset(k) + 2] for k, name in enumerate(system.body_names)}
    np.testing.assert_allclose(poses["wagon"], [0.1, 0.0], atol=1e-12)
    np.testing.assert_allclose(poses["pan.1"], [0.2, -0.2], atol=1e-12)
    np.testing.assert_allclose(poses["pan.2"], [0.2, 0.001], atol=1e-12)
    assert v[system.body_offset(0)] == pytest.approx(2.0, abs=1e-10)
    assert v[system.body_offset(2)] == pytest.approx(1.0, abs=1e-10)
    assert q[system.sliding_offset] == pytest.approx(0.1 / 1.001, abs=1e-12)


def test_contact_friction_table_builds_a_contact_friction(tmp_path):
    """[loads.NAME.friction] of a contact (the sliding joints' friction table) makes its
    ContactFriction; without it the contact is frictionless."""
    from ancf_jax.contact import ContactFriction

    text = _text(("side = -1", "side = -1\n\n[loads.touch.friction]\nmu = 0.2\nregularization = 2e-3"))
    system, _ = load_scenario(str(write(tmp_path, text))).model().build(assemble=False)
    touch = next(f for f in system.forces if f.name == "touch")
    assert isinstance(touch.friction, ContactFriction)
    assert [float(v) for v in (touch.friction.mu, touch.friction.regularization, touch.friction.viscous)] == [
        0.2, 2e-3, 0.0]
    plain, _ = load_scenario(str(write(tmp_path, EXAMPLE))).model().build(assemble=False)
    assert next(f for f in plain.forces if f.name == "touch").friction is None


def test_moving_mass_along_the_arc_length_drives_its_sliding_joint(tmp_path):
    sc = load_scenario(str(write(tmp_path, EXAMPLE)), ['moving_masses.wagon.along="arc_length"',
                                                       'loads.P.along="arc_length"'])
    system, state = sc.model().build(assemble=False)
    drive = next(k for k in system.constraints if k.name == "wagon.drive")
    assert drive.index == system.sliding_offset     # the sliding coordinate follows s(t)
    p = next(f for f in system.forces if f.name == "P")
    assert isinstance(p.location, AtArcLength)


def _text(*pairs, extra=""):
    text = EXAMPLE
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text + ("\n" + extra if extra else "")


VERTICAL = ('[beams.mast]\ngeometry = { type = "straight", start = [2.0, 0.0], direction = [0.0, 1.0], '
            'length = 1.0 }\nelements = 2\nsection = { EA = 1e5, EI = 1e-3, mass_per_length = 1.0 }\n')

# (case id, file text, key path in the message, fragment of the accepted text)
CASES = [
    ("contact side not 1 or -1", _text(("side = -1", "side = 2")), "loads.touch.side", "1 (the point on the side"),
    ("contact side as a boolean", _text(("side = -1", "side = true")), "loads.touch.side", "or -1"),
    ("zero contact stiffness", _text(("stiffness = 1e3", "stiffness = 0.0")), "loads.touch.stiffness",
     "a number > 0 [N/m]"),
    ("negative contact offset", _text(("side = -1", "side = -1\noffset = -0.01")), "loads.touch.offset",
     "a number >= 0 [m]"),
    ("contact with a missing chain mass", _text(('point = { body = "pan.2" }', 'point = { body = "pan.3" }')),
     "loads.touch.point.body", 'the name of a body: "wagon", "pan.1", "pan.2"'),
    ("contact of a beam with itself", _text(('point = { body = "pan.2" }', 'point = { beam = "wire", s = 0.5 }')),
     "loads.touch.point", "a point of another beam"),
    ("contact with a missing beam", _text(('beam = "wire"\nstiffness', 'beam = "rope"\nstiffness')),
     "loads.touch.beam", 'the name of a beam: "wire"'),
    ("moving force on a missing beam", _text(('beam = "wire"\nforce', 'beam = "wyre"\nforce')),
     "loads.P.beam", 'the name of a beam: "wire"'),
    ("moving force without speed", _text(("start = 0.0\nspeed = 5.0\n", "start = 0.0\n")), "loads.P.speed",
     "a number [m/s]"),
    ("moving force along an unknown coordinate", _text(("speed = 5.0\n", 'speed = 5.0\nalong = "s"\n')),
     "loads.P.along", '"x", "arc_length"'),
    ("moving force along x on a vertical beam", _text(('beam = "wire"\nforce', 'beam = "mast"\nforce'),
                                                     extra=VERTICAL), "loads.P.along", '"arc_length"'),
    ("contact with a vertical beam", _text(('beam = "wire"\nstiffness', 'beam = "mast"\nstiffness'), extra=VERTICAL),
     "loads.touch.beam", "a beam running left to right or right to left"),
    ("moving force profile outside the safe set", _text(("speed = 5.0\n", 'speed = 5.0\nprofile = "open(1)"\n')),
     "loads.P.profile", "an expression in t"),
    ("drive output naming a missing moving mass", _text(('moving_mass = "wagon" }', 'moving_mass = "wagen" }')),
     "outputs.columns.wagon_drive.moving_mass", 'the name of a moving mass: "wagon"'),
    ("drive output naming a moving mass's slider", _text(('moving_mass = "wagon" }', 'joint = "wagon.slider" }')),
     "outputs.columns.wagon_drive.joint", "moving_mass = NAME"),
    ("drive output naming a joint and a moving mass", _text(('moving_mass = "wagon" }',
                                                             'moving_mass = "wagon", joint = "wagon.slider" }')),
     "outputs.columns.wagon_drive.moving_mass", "one of joint, moving_mass"),
    ("drive output naming nothing", _text(('{ type = "drive", moving_mass = "wagon" }', '{ type = "drive" }')),
     "outputs.columns.wagon_drive", "one of joint, moving_mass"),
    ("zero moving mass", _text(("mass = 0.05", "mass = 0.0")), "moving_masses.wagon.mass", "a number > 0 [kg]"),
    ("moving mass leaving the beam", _text(("start = 0.1\nspeed = 2.0", "start = 0.1\nspeed = 20.0")),
     "moving_masses.wagon.speed", "x in 0 .. 1.001 [m] at every output time"),
    ("moving mass starting off the beam", _text(("start = 0.1\nspeed = 2.0", "start = 1.5\nspeed = 2.0\n"
                                                                              'along = "arc_length"')),
     "moving_masses.wagon.start", "arc length in 0 .. 1 [m]"),
    ("moving mass led off the beam by a table", _text(("speed = 2.0\n", "speed = 2.0\n"
                                                                        "profile = { table = [[0.0, 0.0], [0.1, 1.0]] }\n")),
     "moving_masses.wagon.profile", "x in 0 .. 1.001 [m]"),
    ("moving mass profile not finite", _text(("speed = 2.0\n", 'speed = 2.0\nprofile = "log(t)"\n')),
     "moving_masses.wagon.profile", "finite at every output time"),
    ("negative chain mass", _text(("masses = [0.2, 0.1]", "masses = [0.2, -0.1]")), "chains.pan.masses[1]",
     "a number > 0 [kg]"),
    ("chain stiffness per stage", _text(("stiffness = [100.0, 1000.0]", "stiffness = [100.0]")),
     "chains.pan.stiffness", "2 numbers [N/m], one per mass"),
    ("chain heights decreasing", _text(("heights = [0.3, 0.501]", "heights = [0.501, 0.3]")), "chains.pan.heights",
     "increasing"),
    ("chain heights as a number", _text(("heights = [0.3, 0.501]", "heights = 0.3")), "chains.pan.heights",
     "an array of 1 to 100 finite numbers [m]"),
    ("chain start without a speed", _text(("speed = 1.0                    # x", "start = 0.3    # x")),
     "chains.pan.start", "start with speed or profile"),
    ("unknown chain key", _text(("base = [0.2, -0.5]", "base = [0.2, -0.5]\nbass = 1")), "chains.pan.bass",
     "keys base, heights, masses"),
    ("chain named like a moving mass", _text(("[chains.pan]", "[chains.wagon]"),
                                             ('{ body = "pan.2" }', '{ body = "wagon" }'),
                                             ('body = "pan.2", component', 'body = "wagon", component')),
     "chains.wagon", "names unique across beams, bodies, joints and loads"),
    ("contact output of a moving force", _text(('{ type = "contact", load = "touch" }',
                                                '{ type = "contact", load = "P" }')),
     "outputs.columns.contact_force.load", 'the name of a contact load: "touch"'),
    ("load output of a contact", _text(('{ type = "load", load = "P" }', '{ type = "load", load = "touch" }')),
     "outputs.columns.under_load.load", 'the name of a moving_force load: "P"'),
    ("unknown load component", _text(('{ type = "load", load = "P" }',
                                      '{ type = "load", load = "P", component = "z" }')),
     "outputs.columns.under_load.component", '"y", "x", "s", "on_beam"'),
    ("body placed at a chain mass", _text(extra='[bodies.lamp]\nmass = 1.0\ninertia = 0.1\nat = { body = "pan.2" }'),
     "bodies.lamp.at.body", "the name of a body declared before: none defined"),
    ("torque on a chain mass", _text(extra='[loads.twist]\ntype = "torque"\nbody = "pan.1"\ntorque = 1.0'),
     "loads.twist.body", "a rigid body with an inertia"),
]


@pytest.mark.parametrize("text,path,accepted", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_moving_load_input_gives_one_line_naming_the_key(tmp_path, no_build, text, path, accepted):
    file = write(tmp_path, text)
    with no_build():
        with pytest.raises(ScenarioError) as err:
            load_scenario(str(file))
    msg = str(err.value)
    assert isinstance(err.value, ModelError)
    assert "\n" not in msg
    assert msg.startswith(f"{file}: {path}: "), msg
    assert err.value.key == path
    assert "(accepted: " in msg and msg.endswith(")")
    assert accepted in err.value.accepted, msg


INCLINE = """
name = "incline"
gravity = [0.0, -9.81]

[beams.track]                  # a rigid incline: every node clamped, slope angle 0.3 rad
geometry = { type = "straight", start = [0.0, 0.0], direction = [0.955336489125606, -0.29552020666133955], length = 2.0 }
elements = 2
section = { EA = 2e7, EI = 2e2, mass_per_length = 0.8 }

[joints.c0]
type = "clamp"
beam = "track"
node = 0

[joints.c1]
type = "clamp"
beam = "track"
node = 1

[joints.c2]
type = "clamp"
beam = "track"
node = 2

[moving_masses.cart]
beam = "track"
mass = 3.0
start = 0.3
speed = 2.0

[solver]
dt = 0.01
t_end = 0.03

[outputs.columns]
drive = { type = "drive", moving_mass = "cart" }
"""


def test_drive_output_of_a_moving_mass(tmp_path):
    """The drive output of a moving mass driven along x at constant speed on a rigid
    incline (slope angle β = 0.3, frictionless): the horizontal force −m g tan β that
    balances the weight's part the track does not carry (as the Python API's
    Results.drive_force("cart.drive"), tests/test_moving_loads.py)."""
    from ancf_jax.outputs import evaluate

    sc = load_scenario(str(write(tmp_path, INCLINE)))
    (o,) = sc.outputs
    assert (o.kind, o.target, o.unit) == ("drive", "cart.drive", "N")
    c = evaluate(sc.simulate(progress=False), sc.outputs)
    assert len(c["drive"]) == 4
    np.testing.assert_allclose(c["drive"], -3.0 * 9.81 * np.tan(0.3), rtol=1e-8)
