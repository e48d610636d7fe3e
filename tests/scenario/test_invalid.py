"""Invalid scenarios: each gives one line naming the file, the key path and what is
accepted, and nothing is built or compiled (table-driven)."""

import numpy as np
import pytest

from ancf_jax.errors import ModelError
from ancf_jax.scenario import ScenarioError, load_scenario

from .conftest import BASE, write


def replaced(*pairs):
    text = BASE
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def added(extra):
    return BASE + "\n" + extra


# (case id, file text, key path in the message, fragment of the accepted text)
CASES = [
    # unknown keys
    ("unknown top-level key", added('colour = "red"').replace('colour = "red"', "")
     .replace('gravity = [0.0, -9.81]', 'gravity = [0.0, -9.81]\ncolour = "red"'), "colour", "keys version, name"),
    ("unknown section key", replaced(("density = 7800.0", "density = 7800.0\nG = 8e10")),
     "beams.arm.section.G", "keys E, A, I"),
    ("unknown joint key", replaced(('node = 0\n', 'node = 0\nnod = 1\n')), "joints.clamp.nod", "keys type, beam, node, mode"),
    ("unknown output key", replaced(('component = "y" }', 'component = "y", scale = 2 }')),
     "outputs.columns.tip_y.scale", "keys type, beam, node, component"),
    ("unknown point key", replaced(('point = { beam = "arm", node = -1 }\nbody', 'point = { beam = "arm", nod = -1 }\nbody')),
     "joints.tip.point.nod", "keys ground, body, local"),
    # missing required keys
    ("missing t_end", replaced(("t_end = 0.01\n", "")), "solver.t_end", "a number > 0 [s]"),
    ("missing solver table", replaced(('[solver]\nname = "generalized-alpha"\ndt = 1e-3\nt_end = 0.01\n', "")),
     "solver", "a table with keys name, dt, t_end"),
    ("missing E", replaced(("E = 2e11\n", "")), "beams.arm.section.E", "a number > 0 [Pa]"),
    ("section by both E, A, I and EA, EI", replaced(("density = 7800.0", "density = 7800.0\nEA = 2e7\nEI = 200.0")),
     "beams.arm.section.A", "either E with A and I (or diameter), or EA and EI"),
    ("coordinate of a beam point", added('[joints.c]\ntype = "coordinate"\npoint = { beam = "arm", s = 0.5 }\n'
                                          'component = "y"'), "joints.c.point", '{ beam = "a", node = i } or { body = "b" }'),
    ("theta of a beam node", added('[joints.c]\ntype = "coordinate"\npoint = { beam = "arm", node = 1 }\n'
                                   'component = "theta"'), "joints.c.component", "x, y, slope_x, slope_y"),
    ("fixed joint to a point mass", replaced(("mass = 1.0\ninertia = 0.1", "mass = 1.0\npoint_mass = true")),
     "joints.tip.body", "a rigid body with an inertia"),
    ("local point of a point mass", replaced(("mass = 0.5\ninertia = 0.01", "mass = 0.5\npoint_mass = true"))
     .replace("[solver]", '[joints.r]\ntype = "revolute"\na = { body = "trolley", local = [0.1, 0.0] }\n'
              'b = { ground = [0.0, 0.0] }\n\n[solver]'), "joints.r.a.local", "a rigid body with an inertia"),
    ("point mass with an inertia", replaced(("mass = 0.5\ninertia = 0.01", "mass = 0.5\ninertia = 0.01\npoint_mass = true")),
     "bodies.trolley.inertia", "mass, position or at"),
    ("body without inertia", replaced(("mass = 0.5\ninertia = 0.01", "mass = 0.5")), "bodies.trolley.inertia",
     "a number > 0 [kg·m²]"),
    ("mass-proportional load on a joint", added('[loads.g]\ntype = "mass_proportional"\nitem = "clamp"\n'
                                                 'acceleration = [0.0, -1.0]'), "loads.g.item", "the name of a beam or body"),
    ("tabulated law off the origin", replaced(("alpha = 0.1\n", 'alpha = 0.1\naxial_law = { type = "tabulated", '
                                                                  'table = [[-0.01, -1.0], [0.01, 3.0]] }\n')),
     "beams.arm.axial_law.table", "through [0, 0]"),
    ("unknown law", replaced(("alpha = 0.1\n", 'alpha = 0.1\nbending_law = { type = "plastic" }\n')),
     "beams.arm.bending_law.type", '"linear", "strain_rate_damped"'),
    ("stress of a section without E", replaced(("E = 2e11\nA = 1e-4\nI = 1e-9\ndensity = 7800.0", "EA = 2e7\nEI = 200.0\nmass = 7.8"))
     + '\nsig = { type = "stress", beam = "arm", s = 0.2 }', "outputs.columns.sig", "key E in beams.arm.section"),
    ("EA without EI", replaced(("E = 2e11\nA = 1e-4\nI = 1e-9\ndensity = 7800.0", "EA = 2e7\nmass = 7.8")),
     "beams.arm.section.EI", "EA [N] and EI [N·m²]"),
    ("missing joint type", replaced(('type = "clamp"\n', "")), "joints.clamp.type", '"clamp", "pin"'),
    ("missing elements", replaced(("elements = 4\n", "")), "beams.arm.elements", "an integer 1 .. 2000"),
    ("missing mass of section", replaced(("density = 7800.0\n", "")), "beams.arm.section",
     "one of mass_per_length, density, mass"),
    # wrong types
    ("elements as string", replaced(("elements = 4", 'elements = "four"')), "beams.arm.elements", "an integer 1 .. 2000"),
    ("elements as float", replaced(("elements = 4", "elements = 4.5")), "beams.arm.elements", "an integer"),
    ("mass as string", replaced(("mass = 1.0", 'mass = "heavy"')), "bodies.cart.mass", "a number > 0 [kg]"),
    ("gravity as number", replaced(("gravity = [0.0, -9.81]", "gravity = 9.81")), "gravity", "[x, y]"),
    ("boolean for a number", replaced(("alpha = 0.1", "alpha = true")), "beams.arm.alpha", "a number >= 0 [1/s]"),
    ("string for a boolean", replaced(("s = 0.5\n\n[loads", 's = 0.5\nhold = "yes"\n\n[loads')),
     "joints.slide.hold", "true or false"),
    ("unknown joint type", replaced(('type = "clamp"', 'type = "weld"')), "joints.clamp.type", '"clamp", "pin", "revolute"'),
    ("unknown solver", replaced(('name = "generalized-alpha"', 'name = "euler"')), "solver.name", '"generalized-alpha", "rk4"'),
    # negative or zero sizes
    ("negative length", replaced(("length = 1.0", "length = -1.0")), "beams.arm.geometry.length", "a number > 0 [m]"),
    ("zero elements", replaced(("elements = 4", "elements = 0")), "beams.arm.elements", "an integer 1 .. 2000"),
    ("zero body mass", replaced(("mass = 1.0", "mass = 0.0")), "bodies.cart.mass", "a number > 0 [kg]"),
    ("negative inertia", replaced(("inertia = 0.1", "inertia = -0.1")), "bodies.cart.inertia", "a number > 0 [kg·m²]"),
    ("negative E", replaced(("E = 2e11", "E = -2e11")), "beams.arm.section.E", "a number > 0 [Pa]"),
    ("negative damping", replaced(("alpha = 0.1", "alpha = -0.1")), "beams.arm.alpha", "a number >= 0 [1/s]"),
    ("zero step", replaced(("dt = 1e-3\nt_end", "dt = 0.0\nt_end")), "solver.dt", "a number > 0 [s]"),
    ("infinite length", replaced(("length = 1.0", "length = inf")), "beams.arm.geometry.length", "a number > 0 [m]"),
    # names
    ("joint naming a missing body", replaced(('body = "cart"', 'body = "kart"')), "joints.tip.body",
     'the name of a body: "cart", "trolley"'),
    ("joint naming a missing beam", replaced(('beam = "arm"\nnode = 0', 'beam = "rope"\nnode = 0')),
     "joints.clamp.beam", 'the name of a beam: "arm"'),
    ("load at a missing body", replaced(('point = { beam = "arm", node = -1 }\nforce', 'point = { body = "ghost" }\nforce')),
     "loads.push.point.body", 'the name of a body'),
    ("output of a missing beam", replaced(('tip_y = { type = "node", beam = "arm"', 'tip_y = { type = "node", beam = "rope"')),
     "outputs.columns.tip_y.beam", 'the name of a beam: "arm"'),
    ("sliding output of a clamp", added('s = { type = "sliding", joint = "clamp" }'), "outputs.columns.s.joint",
     'a sliding joint: "slide"'),
    ("body placed at a later body", replaced(('at = { beam = "arm", s = 0.5 }', 'at = { body = "nobody" }')),
     "bodies.trolley.at.body", "the name of a body declared before"),
    ("duplicate name across kinds", added('[bodies.arm]\nmass = 1.0\ninertia = 1.0'), "bodies.arm",
     "names unique across beams, bodies, joints and loads"),
    ("duplicate table", added('[joints.clamp]\ntype = "pin"'), "joints.clamp", "each table or name declared once"),
    ("bad output name", added('t = { type = "energy" }'), "outputs.columns.t", "not 't'"),
    ("scenario name with a path", replaced(('name = "base"', 'name = "../../etc/x"')), "name", "a name of letters"),
    # arc lengths and indices
    ("sliding joint outside the beam", replaced(("s = 0.5\n\n[loads", "s = 1.5\n\n[loads")), "joints.slide.s", "0 .. 1 [m]"),
    ("sliding joint at negative s", replaced(("s = 0.5\n\n[loads", "s = -0.1\n\n[loads")), "joints.slide.s", "a number >= 0 [m]"),
    ("body at a point outside the beam", replaced(('at = { beam = "arm", s = 0.5 }', 'at = { beam = "arm", s = 2.0 }')),
     "bodies.trolley.at.s", "0 .. 1 [m]"),
    ("node out of range", replaced(('point = { beam = "arm", node = -1 }\nbody', 'point = { beam = "arm", node = 9 }\nbody')),
     "joints.tip.point.node", "an integer 0 .. 4"),
    ("point with two entities", replaced(('point = { beam = "arm", node = -1 }\nbody', 'point = { beam = "arm", node = 0, body = "cart" }\nbody')),
     "joints.tip.point", "exactly one" if False else "{ ground = [x, y] }"),
    ("position and at together", replaced(('at = { beam = "arm", s = 0.5 }', 'at = { beam = "arm", s = 0.5 }\nposition = [0.5, 0.0]')),
     "bodies.trolley.at", "one of position, at"),
    ("two mass keys", replaced(("density = 7800.0", "density = 7800.0\nmass = 0.78")), "beams.arm.section.mass",
     "one of mass_per_length, density, mass"),
    ("solver option at the wrong level", replaced(('name = "generalized-alpha"', 'name = "generalized-alpha"\nrho_inf = 0.5')),
     "solver.rho_inf", "keys name, dt, t_end, drift_tolerance, locate_crossings, generalized_alpha, rk4, explicit_euler, diffrax"),
    ("option of another solver", added("[solver.rk4]\nrho_inf = 0.5"), "solver.rk4.rho_inf", "keys projection, baumgarte, linear_solver"),
    ("rho_inf out of range", added("[solver.generalized_alpha]\nrho_inf = 1.5"),
     "solver.generalized_alpha.rho_inf", "a number 0 .. 1"),
    ("output interval below the step", replaced(("[outputs]\ndt = 1e-3", "[outputs]\ndt = 1e-4")), "outputs.dt", ">= 0.001"),
    # time functions outside the safe set
    ("import in an expression", replaced(('"0.5 * sin(2*pi*t)"', '''"__import__('os').system('true')"''')),
     "loads.push.time_function", "an expression in t"),
    ("attribute access", replaced(('"0.5 * sin(2*pi*t)"', '"t.real"')), "loads.push.time_function", "sin, cos"),
    ("open() in an expression", replaced(('"0.5 * sin(2*pi*t)"', '''"open('/etc/passwd')"''')),
     "loads.push.time_function", "an expression in t"),
    ("unknown name", replaced(('"0.5 * sin(2*pi*t)"', '"x + 1"')), "loads.push.time_function", "numbers, t, pi"),
    ("wrong arity", replaced(('"0.5 * sin(2*pi*t)"', '"ramp(t, 1)"')), "loads.push.time_function", "ramp"),
    ("absolute data file", replaced(('"0.5 * sin(2*pi*t)"', '{ file = "/etc/passwd" }')),
     "loads.push.time_function", "inside the scenario's directory"),
    ("data file above the directory", replaced(('"0.5 * sin(2*pi*t)"', '{ file = "../x.csv" }')),
     "loads.push.time_function", "no '..'"),
    ("table with decreasing times", replaced(('"0.5 * sin(2*pi*t)"', '{ table = [[0.0, 0.0], [0.0, 1.0]] }')),
     "loads.push.time_function", "{ table = [[t, value], ...] }"),
    ("TOML syntax error", replaced(("elements = 4", "elements = ")), "line 8, column 12", "TOML 1.0 syntax"),
    # cable machinery (issue 19)
    ("negative friction coefficient", replaced(('beam = "arm"\ns = 0.5\n', 'beam = "arm"\ns = 0.5\nfriction = { mu = -0.1 }\n')),
     "joints.slide.friction.mu", ">= 0"),
    ("zero regularization", replaced(('beam = "arm"\ns = 0.5\n', 'beam = "arm"\ns = 0.5\nfriction = { mu = 0.1, regularization = 0.0 }\n')),
     "joints.slide.friction.regularization", "> 0"),
    ("drive with two modes", replaced(('beam = "arm"\ns = 0.5\n', 'beam = "arm"\ns = 0.5\ndrive = { position = "0.5 + t", force = 1.0 }\n')),
     "joints.slide.drive", "exactly one of position, force, speed"),
    ("servo without gain", replaced(('beam = "arm"\ns = 0.5\n', 'beam = "arm"\ns = 0.5\ndrive = { speed = 1.0, max_force = 10.0 }\n')),
     "joints.slide.drive.gain", "a number > 0 with speed"),
    ("drive position outside the safe set", replaced(('beam = "arm"\ns = 0.5\n', 'beam = "arm"\ns = 0.5\ndrive = { position = "t.real" }\n')),
     "joints.slide.drive.position", "sin, cos"),
    ("unknown spring action", added('[loads.rope]\ntype = "spring_damper"\na = { body = "cart" }\n'
                                    'b = { ground = [0.0, 1.0] }\nstiffness = 1.0\nacts = "pull"\n'),
     "loads.rope.acts", "both"),
    ("clamp mass outside the beam", replaced(("alpha = 0.1\n", "alpha = 0.1\nmasses = [{ s = 2.0, mass = 0.1 }]\n")),
     "beams.arm.masses[0].s", "0 .. 1 [m]"),
    ("friction output without friction", added('[outputs.columns.f]\ntype = "friction"\njoint = "slide"\n'),
     "outputs.columns.f.joint", "a sliding joint with a friction table"),
]


@pytest.mark.parametrize("text,path,accepted", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_invalid_input_gives_one_line_naming_file_key_and_accepted(tmp_path, no_build, text, path, accepted):
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


def test_at_least_25_cases():
    assert len(CASES) >= 25


def test_base_scenario_is_valid(tmp_path, no_build):
    with no_build():
        sc = load_scenario(str(write(tmp_path, BASE)))
    assert sc.name == "base" and [o.name for o in sc.outputs] == ["tip_y"]


def test_override_errors_say_they_come_from_set(tmp_path, no_build):
    file = write(tmp_path, BASE)
    with no_build():
        with pytest.raises(ScenarioError) as err:
            load_scenario(str(file), ["solver.dt=-1"])
    assert err.value.key == "solver.dt"
    assert "from --set solver.dt=-1" in str(err.value)
    with pytest.raises(ScenarioError, match=r": --set solver: expected KEY=VALUE \(accepted: KEY=VALUE"):
        load_scenario(str(file), ["solver"])


def test_missing_file_and_unknown_name(tmp_path):
    with pytest.raises(ScenarioError, match=r"cannot read the scenario file.*accepted: .*m1"):
        load_scenario(str(tmp_path / "nope.toml"))
    with pytest.raises(ScenarioError, match=r"^m7: \(file\): no such shipped scenario"):
        load_scenario("m7")


def test_arc_lengths_at_the_very_end_of_a_beam_are_accepted(tmp_path):
    # 1.0 / 7 * 7 falls an ulp short of 1.0: s = L must still be on the beam
    text = replaced(("elements = 4", "elements = 7"), ("s = 0.5\n\n[loads", "s = 1.0\n\n[loads"),
                    ('at = { beam = "arm", s = 0.5 }', 'at = { beam = "arm", s = 1.0 }'))
    assert np.full(7, 1.0 / 7).sum() < 1.0
    system, _ = load_scenario(str(write(tmp_path, text))).model().build(assemble=False)
    assert system.sliding_names == ("slide",)


def test_another_format_version_is_refused_naming_both():
    from ancf_jax.scenario import ScenarioError, load_scenario
    with pytest.raises(ScenarioError, match=r"format version 2 \(a newer ancf_jax wrote it\).*reads version 1"):
        load_scenario("m1", ["version=2"])
    with pytest.raises(ScenarioError, match="Changelog"):
        load_scenario("m1", ["version=0"])
