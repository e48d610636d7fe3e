"""One scenario with every geometry, joint, load, time-function and output type: it
builds into the system the file describes and runs a few steps that follow the
prescribed motions."""

import math

import numpy as np
import pytest

from ancf_jax.element.strain_energy import Formulation
from ancf_jax.outputs import evaluate
from ancf_jax.scenario import load_scenario

from .conftest import write

pytestmark = pytest.mark.slow

EVERY = '''
name = "every_entity"
gravity = [0.0, -9.81]

[beams.hoop]      # a quarter circle, its first node clamped in direction only
geometry = { type = "arc", center = [0.0, 0.0], radius = 0.5, start_angle = 0.0, end_angle = 1.5707963267948966 }
elements = 4
alpha = 0.5
section = { E = 2e9, diameter = 0.01, density = 1000.0 }
formulation = { axial_strain = "engineering", curvature = "material", axial_quadrature = ["gauss", 2] }

[beams.rope]      # through points; pinned at the start, its end driven along a path
geometry = { type = "points", points = [[1.0, 0.0], [1.5, 0.0], [2.0, 0.0]], slopes = [[2.0, 0.0], [1.0, 0.0], [1.0, 0.0]] }
section = { E = 1e9, A = 1e-4, I = 1e-10, mass = 0.2, fibre = 0.005 }

[bodies.weight]   # hangs on the hoop's tip by its centre
mass = 0.3
inertia = 0.001
at = { beam = "hoop", node = -1 }
points = { top = [0.0, 0.0] }

[bodies.wheel]    # fully prescribed: fixed centre, turning from 1 rev/s
mass = 1.0
inertia = 0.1
position = [1.5, 1.0]
angular_velocity = 6.283185307179586
points = { rim = [0.2, 0.0] }

[bodies.ring]     # held on the rope for the whole run
mass = 0.05
inertia = 1e-4
at = { beam = "rope", s = 0.5 }

[joints.clamp]
type = "clamp"
beam = "hoop"
node = 0
mode = "direction"

[joints.hinge]
type = "revolute"
a = { beam = "hoop", node = -1 }
b = { body = "weight", point = "top" }

[joints.anchor]
type = "pin"
point = { beam = "rope", node = 0 }
location = [1.0, 0.0]

[joints.drive]
type = "prescribed_point"
point = { beam = "rope", node = -1 }
x = { file = "path.csv" }
y = "0.01 * sin(2*pi*t)"

[joints.wheel_x]
type = "prescribed_body"
body = "wheel"
coordinate = "x"
value = 1.5

[joints.wheel_y]
type = "prescribed_body"
body = "wheel"
coordinate = "y"
value = { table = [[0.0, 1.0], [1.0, 1.0]] }

[joints.wheel_theta]
type = "prescribed_body"
body = "wheel"
coordinate = "theta"
value = "2*pi*t + 50*t**2"    # accelerating: free rotation would keep 2 pi rad/s

[joints.slide]
type = "sliding"
body = "ring"
beam = "rope"
s = 0.5
hold = true

[loads.spring]
type = "spring_damper"
a = { body = "wheel", point = "rim" }
b = { beam = "rope", s = 1.0 }
stiffness = 10.0
damping = 0.1

[loads.twist]
type = "torque"
body = "weight"
torque = 0.01
time_function = { table = [[0.0, 0.0], [0.01, 1.0]] }

[loads.push]
type = "point_force"
point = { beam = "hoop", s = 0.3 }
force = [0.1, 0.0]
time_function = 2

[solver]
name = "rk4"
dt = 1e-5
t_end = 3e-3

[solver.rk4]
projection = true

[solver.generalized_alpha]   # checked, not used by rk4
newton_tol = 1e-11

[outputs]
dt = 1e-3

[outputs.columns]
hoop_tip_slope_y = { type = "node", beam = "hoop", node = -1, component = "slope_y" }
hoop_y = { type = "point", beam = "hoop", s = 0.4, component = "y" }
weight_theta = { type = "body", body = "weight", component = "theta" }
rim_x = { type = "body", body = "wheel", point = "rim", component = "x" }
rim_y = { type = "body", body = "wheel", local = [0.2, 0.0], component = "y" }
s_ring = { type = "sliding", joint = "slide" }
ring_y = { type = "sliding_point", joint = "slide", component = "y" }
rope_x = { type = "node", beam = "rope", node = 2, component = "x" }
rope_y = { type = "node", beam = "rope", node = -1, component = "y" }
sigma_rope = { type = "stress", beam = "rope", s = 0.25, fibre = -0.005, measure = "small_strain" }
sigma_hoop = { type = "stress", beam = "hoop", element = 1, xi = 0.25 }
ring_normal = { type = "reaction", joint = "slide", component = "normal" }
clamp_2 = { type = "reaction", joint = "clamp", index = 2 }
kinetic = { type = "energy", component = "kinetic" }
'''


@pytest.fixture(scope="module")
def scenario(tmp_path_factory):
    folder = tmp_path_factory.mktemp("every")
    (folder / "path.csv").write_text("t,x\n0,2.0\n1,2.05\n")
    return load_scenario(str(write(folder, EVERY)))


def test_the_system_is_what_the_file_says(scenario):
    system, state = scenario.build()
    assert system.beam_names == ("hoop", "rope") and system.body_names == ("weight", "wheel", "ring")
    assert [c.name for c in system.constraints] == ["clamp", "hinge", "anchor", "drive", "wheel_x", "wheel_y",
                                                   "wheel_theta", "slide", "slide.hold"]
    assert [f.name for f in system.forces] == ["spring", "twist", "push"]
    hoop, rope = system.beams
    assert hoop.formulation == Formulation(axial_strain="engineering", curvature="material",
                                           axial_quadrature=("gauss", 2), bending_quadrature=("gauss", 3))
    assert float(hoop.mesh.length) == pytest.approx(0.25 * math.pi, rel=1e-4)  # cubics through the arc
    assert scenario.beam_lengths["hoop"] == pytest.approx(float(hoop.mesh.length), rel=1e-12)
    assert scenario.beam_lengths["rope"] == pytest.approx(float(rope.mesh.length), rel=1e-12)
    assert float(hoop.section.area) == pytest.approx(math.pi * 0.01**2 / 4, rel=1e-15)
    assert float(hoop.section.second_moment) == pytest.approx(math.pi * 0.01**4 / 64, rel=1e-15)
    assert float(hoop.section.fibre_distance) == 0.005
    assert float(hoop.section.mass_per_length) == pytest.approx(1000.0 * math.pi * 0.01**2 / 4, rel=1e-15)
    assert float(rope.section.mass_per_length) == pytest.approx(0.2 / 1.0, rel=1e-12)
    assert int(rope.mesh.n_elements) == 2
    q = np.asarray(state.q)
    np.testing.assert_allclose(q[0:2], [0.0, 0.5], atol=1e-12)   # weight at the hoop's tip
    np.testing.assert_allclose(q[6:8], [1.5, 0.0], atol=1e-12)   # ring at s = 0.5 on the rope
    np.testing.assert_allclose(np.asarray(state.v)[5], 2 * math.pi)  # wheel turning


def test_a_few_steps_follow_the_prescribed_motions(scenario):
    results = scenario.simulate(progress=False)
    assert results.status == "ok" and results.solver == "rk4"
    c = evaluate(results, scenario.outputs)
    t = c["t"]
    assert len(t) == 4
    for key, values in c.items():
        assert np.all(np.isfinite(values)), key
    wheel = results.body("wheel")
    np.testing.assert_allclose(wheel[:, 2], 2 * math.pi * t + 50 * t**2, atol=1e-10)
    np.testing.assert_allclose(wheel[:, :2], np.tile([1.5, 1.0], (4, 1)), atol=1e-10)
    theta = 2 * math.pi * t + 50 * t**2
    np.testing.assert_allclose(c["rim_x"], 1.5 + 0.2 * np.cos(theta), atol=1e-10)
    np.testing.assert_allclose(c["rim_y"], 1.0 + 0.2 * np.sin(theta), atol=1e-10)
    np.testing.assert_allclose(c["rope_x"], 2.0 + 0.05 * t, atol=1e-10)
    np.testing.assert_allclose(c["rope_y"], 0.01 * np.sin(2 * math.pi * t), atol=1e-10)
    np.testing.assert_allclose(c["s_ring"], 0.5, atol=1e-12)
    assert c["kinetic"][-1] > 0.0
    assert np.all(c["weight_theta"][1:] > 0.0)  # the torque turns it counter-clockwise


MACHINERY = '''
name = "machinery"
gravity = [0.0, -9.81]

[beams.rail]
geometry = { type = "straight", start = [0.0, 0.0], direction = [1.0, 0.0], length = 2.0 }
elements = 2
section = { E = 2e11, A = 1e-4, I = 1e-9, density = 7800.0 }

[bodies]
pulled = { mass = 1.0, inertia = 0.1, at = { beam = "rail", s = 0.5 } }
servoed = { mass = 2.0, inertia = 0.1, at = { beam = "rail", s = 1.5 } }

[joints.clamp]
type = "clamp"
beam = "rail"
node = 0

[joints.slide_a]
type = "sliding"
body = "pulled"
beam = "rail"
s = 0.5
friction = { mu = 0.2, viscous = 3.0 }
drive = { force = 4.0, time_function = "1 + t" }

[joints.slide_b]
type = "sliding"
body = "servoed"
beam = "rail"
s = 1.5
drive = { speed = 0.5, gain = 100.0, max_force = 30.0 }

[loads.rope]      # 0.5 m from the anchor, rest length 0.4: taut
type = "spring_damper"
a = { ground = [0.5, 0.5] }
b = { body = "pulled" }
stiffness = 1000.0
damping = 5.0
rest_length = 0.4
acts = "tension"

[loads.stop]      # open: 0.5 m apart, rest length 0.3
type = "spring_damper"
a = { ground = [1.5, -0.5] }
b = { body = "servoed" }
stiffness = 1e4
rest_length = 0.3
acts = "compression"

[solver]
name = "generalized-alpha"
dt = 1e-3
t_end = 0.01

[outputs.columns]
rope = { type = "member", load = "rope" }
rope_taut = { type = "member", load = "rope", component = "engaged" }
stop = { type = "member", load = "stop" }
stop_closed = { type = "member", load = "stop", component = "engaged" }
pull = { type = "drive", joint = "slide_a" }
servo = { type = "drive", joint = "slide_b" }
friction = { type = "friction", joint = "slide_a" }
'''


def test_machinery_builds_its_members_drives_and_columns(tmp_path):
    """Cable machinery from a file (no run): a tension-only and a compression-only
    spring-damper, sliding joints with friction (a viscous part), a force drive scaled
    by a time function and a velocity servo; their output columns at the initial state
    (the body at rest: rope k e, the open stop 0, the pull F f(0), the servo
    F_max tanh(k u*/F_max), no friction at zero speed)."""
    from ancf_jax.forces import CompressionOnlySpringDamper, TensionOnlySpringDamper
    from ancf_jax.results import Results
    from ancf_jax.sliding import SlidingDriveForce, SlidingFriction, SlidingServo

    sc = load_scenario(str(write(tmp_path, MACHINERY)))
    system, state = sc.build()
    forces = {f.name: f for f in system.forces}
    assert isinstance(forces["rope"], TensionOnlySpringDamper)
    assert isinstance(forces["stop"], CompressionOnlySpringDamper)
    pull, servo = forces["slide_a.drive"], forces["slide_b.drive"]
    assert isinstance(pull, SlidingDriveForce) and float(pull.force) == 4.0
    assert float(pull.time_function(2.0)) == pytest.approx(3.0)
    assert isinstance(servo, SlidingServo) and (float(servo.gain), float(servo.max_force)) == (100.0, 30.0)
    assert float(servo.speed(0.0)) == 0.5
    (friction,) = system.reaction_forces
    assert isinstance(friction, SlidingFriction) and friction.name == "slide_a.friction"
    assert (float(friction.mu), float(friction.viscous), float(friction.regularization)) == (0.2, 3.0, 1e-3)
    one = lambda a: np.asarray(a)[None]  # noqa: E731
    results = Results(system, np.zeros(1), one(state.q), one(state.v), np.zeros((1, system.n_coordinates)),
                      np.zeros((1, system.n_constraints)), np.zeros((1, 3)), np.zeros(1))
    c = evaluate(results, sc.outputs)
    assert list(c) == ["t", "rope", "rope_taut", "stop", "stop_closed", "pull", "servo", "friction"]
    np.testing.assert_allclose([c["rope"][0], c["rope_taut"][0], c["stop"][0], c["stop_closed"][0]],
                               [1000.0 * 0.1, 1.0, 0.0, 0.0], rtol=1e-12)
    np.testing.assert_allclose([c["pull"][0], c["servo"][0], c["friction"][0]],
                               [4.0, 30.0 * np.tanh(100.0 * 0.5 / 30.0), 0.0], rtol=1e-12, atol=1e-12)
