"""The Python binding (python/spacearm_module.cpp): load, every output as a method over numpy
arrays, batches, parameters and errors. Cost: one compile of the paper's geared model into the
test cache (about 1 s), then milliseconds."""
import os

import numpy as np
import pytest

import spacearm

SOURCE = os.path.join(os.path.dirname(__file__), "..", "..")
CACHE = os.environ.get("SPACEARM_TEST_CACHE_DIR", "")


@pytest.fixture(scope="module")
def geared():
    return spacearm.load(os.path.join(SOURCE, "models", "paper_geared.yaml"), cache_dir=CACHE)


def with_outputs(model_file, outputs):
    """The text of models/`model_file` with its `outputs: [...]` list replaced by `outputs` (YAML
    lines: the list, and further fields)."""
    with open(os.path.join(SOURCE, "models", model_file)) as f:
        text = f.read()
    start = text.index("outputs:")
    return text[:start] + outputs + text[text.index("]", start) + 1:]


def states(model, k, seed=1):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, (k, model.nq)), rng.uniform(-1, 1, (k, model.nv))


def test_mass_matrix_is_symmetric_positive_definite(geared):
    q, _ = states(geared, 1)
    M = geared.mass_matrix(q[0])
    assert M.shape == (geared.nv, geared.nv)
    assert np.allclose(M, M.T, rtol=0, atol=1e-15 * abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0


def test_forward_dynamics_solves_the_equations_of_motion(geared):
    """M qdd + b = Q (eq. 8), each output through its own method."""
    q, qd = states(geared, 3)
    Q = np.arange(geared.nv, dtype=float)
    for i in range(3):
        qdd = geared.forward_dynamics(q[i], qd[i], Q)
        M, b = geared.mass_matrix(q[i]), geared.bias_forces(q[i], qd[i])
        assert np.allclose(M @ qdd + b, Q, rtol=0, atol=1e-12 * abs(Q).max())
        assert np.allclose(geared.inverse_dynamics(q[i], qd[i], qdd), Q, atol=1e-11)


def test_a_batch_equals_its_states_one_by_one(geared):
    q, qd = states(geared, 7)
    M = geared.mass_matrix(q)
    T = geared.kinetic_energy(q, qd)
    assert M.shape == (7, geared.nv, geared.nv) and T.shape == (7,)
    for i in range(7):
        assert np.array_equal(M[i], geared.mass_matrix(q[i]))
        assert T[i] == geared.kinetic_energy(q[i], qd[i])
        assert np.isclose(T[i], 0.5 * qd[i] @ M[i] @ qd[i], rtol=1e-13)


def test_parameters_by_name(geared):
    q, _ = states(geared, 1)
    assert geared.parameter_names == ["p", "Im"]
    p10 = spacearm.load(os.path.join(SOURCE, "models", "paper_geared.yaml"), params={"p": 10},
                        cache_dir=CACHE)
    assert p10.params == {"p": 10, "Im": geared.params["Im"]}  # by name, in the scene's order
    assert list(p10.params) == ["p", "Im"]
    assert np.array_equal(p10.mass_matrix(q[0]), geared.mass_matrix(q[0], params={"p": 10}))
    assert not np.allclose(p10.mass_matrix(q[0]), geared.mass_matrix(q[0]))


def test_scene_as_yaml_text_and_repr():
    with open(os.path.join(SOURCE, "models", "paper_reference.yaml")) as f:
        model = spacearm.load(f.read(), cache_dir=CACHE)
    assert model.coordinate_names == ["x0", "y0", "q0", "q1", "q2", "q3"]
    assert repr(model).startswith("<spacearm.Model 'paper_reference': nq = 6, nv = 6, 3 links;")
    assert "forward_dynamics" in model.outputs


def test_results_of_several_arrays_and_empty_batches(geared):
    q, qd = states(geared, 2)
    r = geared.free_base_inverse_dynamics(q, qd, np.zeros((2, geared.num_links)))
    assert sorted(r) == ["qdd_base", "tau"] and r["tau"].shape == (2, geared.num_links)
    assert geared.mass_matrix(np.zeros((0, geared.nq))).shape == (0, geared.nv, geared.nv)


def test_errors_name_what_is_wrong(geared):
    q, qd = states(geared, 2)
    with pytest.raises(ValueError, match="no parameter 'mass' \\(it has: p, Im\\)"):
        geared.mass_matrix(q[0], params={"mass": 1})
    with pytest.raises(TypeError, match=r"forward_dynamics\(\) takes q, qd, Q \(3 arrays\), got 2"):
        geared.forward_dynamics(q[0], qd[0])
    with pytest.raises(ValueError, match="qd: one state where q has k states"):
        geared.bias_forces(q, qd[0])
    with pytest.raises(ValueError, match="q: expected 6 values, got 3"):
        geared.mass_matrix(q[0][:3])
    with pytest.raises(TypeError, match="q: not an array of numbers"):
        geared.mass_matrix("abc")
    bad = q.copy()
    bad[1, 2] = np.nan
    with pytest.raises(ValueError, match=r"state 1: q\[2\] is not finite: nan"):
        geared.mass_matrix(bad)
    with pytest.raises(spacearm.DynamicsError, match="accelerations not finite"):
        geared.forward_dynamics(q[0], qd[0], np.full(geared.nv, 1e308))
    with pytest.raises(ValueError, match="gears\\[0\\].ratio must be positive"):
        spacearm.load(os.path.join(SOURCE, "models", "paper_geared.yaml"), params={"p": -1},
                      cache_dir=CACHE)
    with pytest.raises(RuntimeError, match="no_such_scene.yaml"):
        spacearm.load("no_such_scene.yaml", cache_dir=CACHE)


def test_batches_on_four_lanes_are_the_bits_of_one_state_per_call(geared):
    """model.lanes = 4 (the default) evaluates four states per call of the generated code where
    the output has a 4-lane function; 1 calls it once per state: the same arrays, bit for bit,
    and an error names the same state."""
    q, qd = states(geared, 11)  # two groups of four and three states alone
    Q = np.random.default_rng(2).uniform(-5, 5, (11, geared.nv))
    assert geared.lanes == 4
    four = {o: getattr(geared, o) for o in ("forward_dynamics", "end_effector_pose", "momentum",
                                            "kinetic_energy", "mass_matrix")}
    results = {"forward_dynamics": four["forward_dynamics"](q, qd, Q),
               "end_effector_pose": four["end_effector_pose"](q),
               "momentum": four["momentum"](q, qd),
               "kinetic_energy": four["kinetic_energy"](q, qd)}
    geared.lanes = 1
    try:
        assert np.array_equal(results["forward_dynamics"], geared.forward_dynamics(q, qd, Q))
        assert np.array_equal(results["end_effector_pose"], geared.end_effector_pose(q))
        assert np.array_equal(results["momentum"], geared.momentum(q, qd))
        assert np.array_equal(results["kinetic_energy"], geared.kinetic_energy(q, qd))
        assert results["forward_dynamics"].shape == (11, geared.nv)
    finally:
        geared.lanes = 4
    bad = Q.copy()
    bad[6, :] = 1e308  # in the second group of four: accelerations overflow there
    for lanes in (4, 1):
        geared.lanes = lanes
        # qdd alone (its pivots computed and checked but not kept) is qdd with them
        full = geared.forward_dynamics(q, qd, Q, pivots=True)
        assert np.array_equal(full["qdd"], results["forward_dynamics"])
        for pivots in (False, True):
            with pytest.raises(spacearm.DynamicsError, match="state 6: .*accelerations not finite"):
                geared.forward_dynamics(q, qd, bad, pivots=pivots)
    geared.lanes = 4
    with pytest.raises(ValueError, match="lanes: 1 or 4, got 2"):
        geared.lanes = 2


def test_two_models_at_once_are_their_own():
    with open(os.path.join(SOURCE, "models", "paper_reference.yaml")) as f:
        text = f.read()
    a = spacearm.load(text, cache_dir=CACHE)
    b = spacearm.load(text.replace("mass: 64.859", "mass: 100.0"), cache_dir=CACHE)
    q = np.zeros(6)
    assert b.mass_matrix(q)[0, 0] - a.mass_matrix(q)[0, 0] == pytest.approx(100 - 64.859, abs=1e-12)


def test_shapes_follow_the_outputs_not_the_sizes():
    """A one-link fixed-base arm: M is 1 x 1 and J is 3 x 1, still a matrix."""
    m = spacearm.load(os.path.join(SOURCE, "tests", "scenes", "fixed_n1.yaml"), cache_dir=CACHE)
    assert m.nq == 1
    assert m.mass_matrix([0.3]).shape == (1, 1)
    assert m.mass_matrix(np.zeros((4, 1))).shape == (4, 1, 1)
    assert m.end_effector_jacobian([0.3]).shape == (3, 1)
    assert isinstance(m.kinetic_energy([0.3], [0.1]), float)


def test_bad_values_are_refused(geared):
    q, qd = states(geared, 1)
    with pytest.raises(TypeError, match=r"params\['p'\]: a number, not str"):
        geared.mass_matrix(q[0], params={"p": "10"})
    with pytest.raises(TypeError, match="parameter names are strings, not int"):
        geared.mass_matrix(q[0], params={1: 10})
    with pytest.raises(TypeError, match="q: not an array of numbers"):
        geared.mass_matrix([str(x) for x in q[0]])
    with pytest.raises(ValueError, match="q: expected 6 values, got 3"):
        geared.mass_matrix(np.zeros((0, 3)))
    with pytest.raises(spacearm.DynamicsError, match="b is not finite"):
        geared.bias_forces(q[0], np.full(geared.nv, 1e200))


def value(text):
    """A printed entry's value at a fixed state and parameters (GiNaC's syntax, ^ for powers)."""
    import math
    names = {"sin": math.sin, "cos": math.cos, "p": 1.7, "Im": 2e-5}
    for k, name in enumerate(["x0", "y0", "q0", "qm1", "qm2", "qm3"]):
        names[name], names[name + "d"] = 0.1 * (k + 1), -0.2 * (k + 1)
    return eval(text.replace("^", "**"), {"__builtins__": {}}, names)


def test_inspect_prints_what_the_cli_prints(geared):
    # GiNaC orders terms by its symbols' creation, which differs between processes: the same
    # expression may print its terms in another order, so the texts are compared by value.
    cli = os.environ.get("SPACEARM_CLI")
    if not cli:
        pytest.skip("SPACEARM_CLI (the spacearm program) is set by ctest")
    import subprocess
    scene = os.path.join(SOURCE, "models", "paper_geared.yaml")
    for entry, flags in (("M[3][4]", []), ("b[2]", []), ("T", ["--decimal"])):
        expected = subprocess.run([cli, "inspect", scene, entry] + flags, check=True,
                                  capture_output=True, text=True).stdout
        text = geared.inspect(entry, decimal="--decimal" in flags)
        assert value(text) == pytest.approx(value(expected), rel=1e-12)
        assert value(text) != 0
    latex = geared.inspect("M[3][4]", latex=True)
    assert "\\frac{Im}{p}" in latex and "\\sin(\\frac{qm3}{p})" in latex
    with pytest.raises(ValueError, match="index 9 out of range 0..5"):
        geared.inspect("M[9][1]")
    with pytest.raises(ValueError, match="unknown quantity 'X'"):
        geared.inspect("X")


def test_plan_is_the_cli_plan(geared, tmp_path):
    cli = os.environ.get("SPACEARM_CLI")
    if not cli:
        pytest.skip("SPACEARM_CLI (the spacearm program) is set by ctest")
    import subprocess
    scene = os.path.join(SOURCE, "models", "paper_geared.yaml")
    out = tmp_path / "plan.csv"
    subprocess.run([cli, "plan", scene, "--from", "1.5,0,0.5", "--to", "1.4,0.05,0.6",
                    "--duration", "2", "--dt", "0.02", "--param", "p=3", "-o", str(out),
                    "--cache-dir", CACHE], check=True, capture_output=True)
    names = out.read_text().splitlines()[0].split(",")
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    plan = geared.plan([1.5, 0, 0.5], [1.4, 0.05, 0.6], 2, dt=0.02, params={"p": 3})
    assert list(plan["columns"]) == names
    for c, name in enumerate(names):  # %.17g in the CSV: the same doubles
        assert np.array_equal(plan["columns"][name], table[:, c]), name
    assert np.array_equal(plan["q"][:, 3:], table[:, 4:7])
    assert np.allclose(plan["tau_motor"], plan["tau"] / 3)
    with pytest.raises(ValueError, match="goal has 3 values and start 2"):
        geared.plan([1.5, 0], [1.4, 0.05, 0.6], 2)
    with pytest.raises(ValueError, match="unknown time law 'sine'"):
        geared.plan([1.5, 0, 0.5], [1.4, 0.05, 0.6], 2, time_law="sine")


def test_simulate_is_the_cli_simulate(geared, tmp_path):
    cli = os.environ.get("SPACEARM_CLI")
    if not cli:
        pytest.skip("SPACEARM_CLI (the spacearm program) is set by ctest")
    import subprocess
    scene = os.path.join(SOURCE, "models", "paper_geared.yaml")
    plan = geared.plan([1.5, 0, 0.5], [1.4, 0.05, 0.6], 1, params={"p": 3})
    torques = np.column_stack([plan["t"], plan["tau"]])
    path = tmp_path / "tau.csv"
    np.savetxt(path, torques, delimiter=",", header="t,tau1,tau2,tau3", comments="", fmt="%.17g")
    q0 = plan["q"][0]
    out = tmp_path / "sim.csv"
    subprocess.run([cli, "simulate", scene, "--torques", str(path), "--t-end", "1", "--param",
                    "p=3", "--q0", ",".join("%.17g" % v for v in q0), "--integrator", "dopri5",
                    "--dt-out", "0.05", "-o", str(out), "--cache-dir", CACHE],
                   check=True, capture_output=True)
    names = out.read_text().splitlines()[0].split(",")
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    run = geared.simulate(1, torques=torques, q0=q0, integrator="dopri5", dt_out=0.05,
                          params={"p": 3})
    assert list(run["columns"]) == names and len(run["t"]) == 21
    for c, name in enumerate(names):
        assert np.array_equal(run["columns"][name], table[:, c]), name
    # write_csv gives the CLI's bytes, and spacearm view draws them (issue 32).
    mine = tmp_path / "python.csv"
    spacearm.write_csv(run, mine)
    assert mine.read_bytes() == out.read_bytes()
    if os.path.exists(os.path.join(os.path.dirname(cli), "..", "web", "viewer.js")):
        subprocess.run([cli, "view", str(mine), "--scene", scene, "--param", "p=3", "-o",
                        str(tmp_path / "view.html"), "--cache-dir", CACHE], check=True,
                       capture_output=True)
        assert "python.csv': 21 rows, all drawn" in (tmp_path / "view.html").read_text()
    # The replay follows the plan's line (the open-loop torques of the same model).
    assert np.abs(run["columns"]["ee_x"][-1] - 1.4) < 1e-4
    rest = geared.simulate(0.5)  # no torque, from rest: nothing moves
    assert np.all(rest["q"] == 0) and len(rest["t"]) == 51
    with pytest.raises(ValueError, match=r"torques cover t = 0 \.\. 1 s, the run needs 0 \.\. 2 s"):
        geared.simulate(2, torques=torques)
    with pytest.raises(ValueError, match="unknown integrator"):
        geared.simulate(1, integrator="euler")
    with pytest.raises(ValueError, match=r"torques: an array of shape \(k, 4\)"):
        geared.simulate(1, torques=torques[:, :3])
    bad = torques.copy()
    bad[5, 0] += 0.003
    with pytest.raises(ValueError, match="row numbers from 1.* line 6: time step"):
        geared.simulate(1, torques=bad)


def test_hostile_arguments_get_named_errors_not_crashes(geared):
    """Issue 28, items 4 and 7: a batch whose float64 copy cannot be allocated (512 TiB, more than
    any address space) raises MemoryError (it used to segfault); pybind11's "Unable to cast"
    never reaches the user; options that would do nothing are refused."""
    for dtype in (np.float32, np.int64):
        huge = np.broadcast_to(dtype(0), (1 << 46, geared.nq))
        with pytest.raises(MemoryError):
            geared.mass_matrix(huge)
    with pytest.raises(MemoryError):
        geared.simulate(1, torques=np.broadcast_to(np.float32(0), (1 << 46, geared.num_links + 1)))
    with pytest.raises(TypeError, match="q0: a 1-D array of numbers, not str"):
        geared.simulate(1, q0="abc")
    with pytest.raises(TypeError, match="qd0: a 1-D array of numbers"):
        geared.simulate(1, qd0=[1, "a", 2, 3, 4, 5])
    with pytest.raises(TypeError, match="q0:"):
        geared.plan([1.5, 0, 0.5], [1.4, 0.05, 0.6], 1, q0="x")
    with pytest.raises(ValueError, match=r"params\['p'\]: 1000.* out of the range of double"):
        geared.mass_matrix(np.zeros(geared.nq), params={"p": 10**400})
    for dt_out in (float("nan"), -0.01, float("inf")):
        with pytest.raises(ValueError, match="dt_out"):
            geared.simulate(1, dt_out=dt_out)
    with pytest.raises(ValueError, match="rtol: applies only to the adaptive integrators"):
        geared.simulate(1, rtol=1e-6)
    with pytest.raises(ValueError, match="atol: applies only"):
        geared.simulate(1, integrator="rk4", atol=1e-6)
    assert len(geared.simulate(0.1, integrator="dopri5", rtol=1e-6, atol=1e-9)["t"]) == 11


def test_forward_dynamics_pivots_on_request(geared):
    """forward_dynamics(..., pivots=True): qdd and the LDL^T pivots, all positive (M is SPD),
    their product the determinant of M."""
    q, qd = states(geared, 3)
    Q = np.zeros_like(qd)
    plain = geared.forward_dynamics(q, qd, Q)
    full = geared.forward_dynamics(q, qd, Q, pivots=True)
    assert set(full) == {"qdd", "pivots", "scaled_pivots"}
    assert np.array_equal(full["qdd"], plain)
    assert np.all(full["pivots"] > 0)
    for i in range(3):
        M = geared.mass_matrix(q[i])
        assert np.isclose(np.prod(full["pivots"][i]), np.linalg.det(M), rtol=1e-10)


def test_plan_replays_into_the_flexible_twin(tmp_path):
    """simulate(plan=...) (issue 29): the geared model's plan, as a dict or as the CLI's file,
    flown by the flexible model with friction fed forward reaches the goal; 'auto' chooses
    rosenbrock4 for its stiff springs and says why."""
    geared = spacearm.load(os.path.join(SOURCE, "models", "paper_geared.yaml"), params={"p": 10},
                           cache_dir=CACHE)
    flexible = spacearm.load(os.path.join(SOURCE, "models", "paper_flexible.yaml"),
                             cache_dir=CACHE)
    plan = geared.plan([0.9, 0.3, 0.0], [0.7, 0.6, 0.5], 5)
    run = flexible.simulate(plan=plan, feedforward="friction", dt_out=0.5)
    assert run["t"][-1] == 5 and "rosenbrock4" in run["integrator"]
    end = np.array([run["columns"][c][-1] for c in ("ee_x", "ee_y", "ee_phi")])
    assert np.linalg.norm(end - [0.7, 0.6, 0.5]) < 1e-3, end
    path = tmp_path / "plan.csv"
    names = list(plan["columns"])
    np.savetxt(path, np.column_stack([plan["columns"][n] for n in names]), delimiter=",",
               header=",".join(names), comments="", fmt="%.17g")
    again = flexible.simulate(plan=str(path), feedforward="friction", dt_out=0.5)
    assert np.array_equal(again["q"], run["q"])
    with pytest.raises(ValueError, match="plan: replaces torques"):
        flexible.simulate(plan=plan, q0=np.zeros(9))
    with pytest.raises(ValueError, match="feedforward: needs a plan"):
        flexible.simulate(1, feedforward="friction")


def test_closed_loop_tracks_the_plan_on_the_flexible_twin():
    """model.closed_loop (issue 29): the geared plan tracked on the flexible model with friction,
    sampled at 1 kHz: a motor-side PD loop around the plan's torques and friction, and computed
    torque on the rigid model, both end far closer to the goal than the open-loop replay; a loop
    with gains too high for the period diverges with a message that says so."""
    rigid = spacearm.load(os.path.join(SOURCE, "models", "paper_geared.yaml"), params={"p": 10},
                          cache_dir=CACHE)
    flexible = spacearm.load(os.path.join(SOURCE, "models", "paper_flexible.yaml"),
                             cache_dir=CACHE)
    plan = rigid.plan([0.9, 0.3, 0.0], [0.7, 0.6, 0.5], 5)
    goal = np.array([0.7, 0.6, 0.5])

    def error(run):
        return np.linalg.norm([run["columns"][c][-1] - g
                               for c, g in zip(("ee_x", "ee_y", "ee_phi"), goal)])

    open_loop = error(flexible.simulate(plan=plan))
    pd = flexible.closed_loop(plan, omega=0.5, feedforward="friction")
    ct = flexible.closed_loop(plan, controller="computed_torque", control_model=rigid)
    assert len(pd["t"]) == 501 and pd["t"][-1] == 5
    assert error(pd) < 1e-3 < 0.05 < open_loop, (error(pd), open_loop)
    assert error(ct) < 1e-3, error(ct)
    with pytest.raises(RuntimeError, match="closed_loop: diverged after"):
        flexible.closed_loop(plan, omega=20)  # kd period / (p^2 I_m) = 40
    with pytest.raises(ValueError, match="controller: 'pd' or 'computed_torque'"):
        flexible.closed_loop(plan, controller="lqr")



def test_a_rebuilt_extension_gets_its_own_cache_entries(tmp_path):
    """The cache key names the generator by a hash of the binary that holds it: for Python the
    extension, not the interpreter (the same whatever spacearm was built from). A copy of the
    package whose extension differs by one trailing byte stands for a rebuilt generator."""
    import shutil
    import subprocess
    import sys

    package = os.path.dirname(spacearm.__file__)
    copy = tmp_path / "pkg" / "spacearm"
    shutil.copytree(package, copy)
    (extension,) = [p for p in copy.iterdir() if p.name.startswith("_spacearm")]
    with open(extension, "ab") as f:
        f.write(b"\0")
    cache = tmp_path / "cache"
    scene = os.path.join(SOURCE, "models", "paper_reference.yaml")
    load = f"import spacearm; spacearm.load({scene!r}, cache_dir={str(cache)!r})"

    def entries(pythonpath):
        env = dict(os.environ, PYTHONPATH=pythonpath)
        subprocess.run([sys.executable, "-c", load], env=env, check=True)
        return {p.name for p in cache.iterdir() if p.is_dir()}

    first = entries(os.path.dirname(package))
    assert len(first) == 1
    both = entries(str(tmp_path / "pkg"))
    assert len(both) == 2, "the rebuilt extension reused the first one's entry"


def test_a_spatial_arm_loads_evaluates_and_moves():
    """A spatial scene (space: spatial) through the same load: MuJoCo's free-joint layout
    (nq = nv + 1), M symmetric positive definite and unchanged by the quaternion's scale, free
    motion on the unit sphere with momentum conserved; inspect's closed form where affordable, else
    the statements; a plan a 2-joint arm cannot follow is refused by name. Cost: one compile, about 1 s."""
    arm = spacearm.load(os.path.join(SOURCE, "tests", "scenes", "spatial_arm2.yaml"),
                        cache_dir=CACHE)
    assert (arm.nq, arm.nv) == (9, 8)
    assert arm.coordinate_names[:7] == ["x0", "y0", "z0", "qw0", "qx0", "qy0", "qz0"]
    q = np.array([0.1, 0.2, 0.3, 0.5, 0.5, -0.5, 0.5, 3.0, -7.0])
    M = arm.mass_matrix(q)
    assert np.allclose(M, M.T, rtol=0, atol=1e-14 * abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0
    scaled = q.copy()
    scaled[3:7] *= 2
    assert np.allclose(arm.mass_matrix(scaled), M, rtol=0, atol=1e-13 * abs(M).max())
    run = arm.simulate(2, qd0=[0.1, 0, 0, 0.2, -0.1, 0.3, 5, -2], integrator="rkf78",
                       rtol=1e-11, atol=1e-12, dt_out=0.25)
    assert np.allclose(np.linalg.norm(run["q"][:, 3:7], axis=1), 1, rtol=0, atol=1e-14)
    h = np.column_stack([run["columns"][c] for c in ("Px", "Py", "Pz", "Lx", "Ly", "Lz")])
    assert np.abs(h - h[0]).max() < 1e-9 * (1 + np.abs(h[0]).max())
    assert "cos((0.05)*qm2)" in arm.inspect("M[6][7]")  # a closed form where affordable
    assert "\\cos" in arm.inspect("M[6][7]", latex=True)
    program = arm.inspect("qdd[0]")  # else the statements that compute it
    assert program.startswith("// qdd[0] of forward_dynamics") and "\n  qdd[0] = " in program
    with pytest.raises(ValueError, match="LaTeX and decimals need a closed form"):
        arm.inspect("qdd[0]", latex=True)
    # The 3D planner needs three joints for a position (six for a pose): it says so by name.
    with pytest.raises(ValueError, match="a 2-link arm cannot follow a position"):
        arm.plan([1, 0, 0], [1.1, 0, 0], 1)


def test_a_spatial_plan_gives_its_arrays_by_size():
    """A plan on a base floating in 3D: q has nq columns, qd and qdd nv (the base's velocity
    is six numbers, its configuration seven), each array the CSV's named columns. Cost: one
    compile of space_arm7, about 1.5 s."""
    arm = spacearm.load(os.path.join(SOURCE, "models", "space_arm7.yaml"), cache_dir=CACHE)
    start = [1.5199002392044572, 0.20122055952054133, 1.243704490684638, -0.6356536114580597,
             0.14067478618696588, 0.6807863076312657, 0.3356860052390699]
    q0 = [0, 0, 0, 1, 0, 0, 0, 30, 50, -20, -160, 40, 90, 10]  # motor angles qm = 100 q
    plan = arm.plan(start, [1.6, 0.15, 1.15, -0.5, 0.2, 0.7, 0.4], 1, q0=q0)
    assert plan["q"].shape[1] == arm.nq and plan["qd"].shape[1] == arm.nv
    assert plan["qdd"].shape[1] == arm.nv and plan["tau"].shape[1] == 7
    cols = plan["columns"]
    assert np.array_equal(plan["qd"][:, 0], cols["vx0"])
    assert np.array_equal(plan["qd"][:, 5], cols["wz0"])
    assert np.array_equal(plan["qdd"][:, -1], cols["qm7dd"])
    assert np.array_equal(plan["tau"][:, 0], cols["tau1"])


def test_a_reactionless_plan_keeps_the_base_still():
    """objective='reactionless' holds the base's angular velocity at zero (the reaction null
    space of the 7-joint arm): the plan's own report, its base rates and its quaternion say so,
    where the straight line turns the base. Cost: space_arm7 from the cache, about 1 s."""
    arm = spacearm.load(os.path.join(SOURCE, "models", "space_arm7.yaml"), cache_dir=CACHE)
    q0 = [0, 0, 0, 1, 0, 0, 0, 30, 50, -20, -160, 40, 90, 10]  # motor angles qm = 100 q
    start = np.array([1.5199002392044572, 0.20122055952054133, 1.243704490684638])
    goal = start + [-0.1, 0.1, 0.1]
    line = arm.plan(start, goal, 4, q0=q0)
    still = arm.plan(start, goal, 4, q0=q0, objective="reactionless")
    assert line["max_base_rotation"] > 1e-3
    assert still["max_base_rotation"] < 1e-12
    assert np.abs(still["qd"][:, 3:6]).max() < 1e-14 * np.abs(still["qd"][:, 6:]).max()
    assert np.abs(still["q"][:, 3:7] - [1, 0, 0, 0]).max() < 1e-12
    assert 0 < still["min_jacobian_rcond"] <= 1
    with pytest.raises(ValueError, match="objective: unknown objective 'still'"):
        arm.plan(start, goal, 4, q0=q0, objective="still")


def test_a_least_effort_plan_lands_at_rest_on_its_goal():
    """objective='min_effort' (IPOPT): from rest to rest at the goal by any path, with less
    effort than the straight line, and the solver's report in the dict. Cost: about 3 s."""
    arm = spacearm.load(os.path.join(SOURCE, "models", "space_arm7.yaml"), cache_dir=CACHE)
    q0 = [0, 0, 0, 1, 0, 0, 0, 30, 50, -20, -160, 40, 90, 10]
    start = np.array([1.5199002392044572, 0.20122055952054133, 1.243704490684638])
    goal = start + [-0.1, 0.1, 0.1]
    line = arm.plan(start, goal, 4, q0=q0)
    least = arm.plan(start, goal, 4, q0=q0, objective="min_effort", knots=20)
    assert least["goal_error"] < 5e-6 and least["iterations"] > 0
    assert np.abs(least["qd"][-1]).max() < 1e-4 and np.abs(least["qd"][0]).max() == 0
    ee = [least["columns"][c][-1] for c in ("ee_x", "ee_y", "ee_z")]
    assert np.linalg.norm(np.array(ee) - goal) == pytest.approx(least["goal_error"], abs=1e-15)
    effort = lambda p: np.trapz((p["tau"] ** 2).sum(axis=1), p["t"])
    assert effort(least) < effort(line)
    with pytest.raises(ValueError, match=r"must be a whole multiple of knots \(7\)"):
        arm.plan(start, goal, 4, q0=q0, objective="min_effort", knots=7)
    # As plan --objective, an argument the objective does not use is an error, not dropped.
    with pytest.raises(ValueError, match="knots: not used by objective 'line'"):
        arm.plan(start, goal, 4, q0=q0, knots=25)
    with pytest.raises(ValueError, match="effort_weight: not used by objective 'min_effort'"):
        arm.plan(start, goal, 4, q0=q0, objective="min_effort", effort_weight=0.1)
    with pytest.raises(ValueError, match="time_law: not used by objective 'min_effort'"):
        arm.plan(start, goal, 4, q0=q0, objective="min_effort", time_law="cubic")
    with pytest.raises(TypeError, match="knots: expected an integer, got str"):
        arm.plan(start, goal, 4, q0=q0, objective="min_effort", knots="25")
    with pytest.raises(TypeError, match="knots: expected a number, got bool"):
        arm.plan(start, goal, 4, q0=q0, objective="min_effort", knots=True)
    with pytest.raises(ValueError, match="knots: 1099511627776 is out of range"):
        arm.plan(start, goal, 4, q0=q0, objective="min_effort", knots=2**40)


def test_a_point_to_point_plan_takes_the_exact_state_jacobian(tmp_path):
    """A model without forward_dynamics_derivatives plans point to point on the scene compiled
    with it (a second cache entry, as plan --objective does), not by central differences: its
    plan is the one a model loaded with the state Jacobian makes. Cost: two planar compiles and
    two solves, about 2 s."""
    lean = with_outputs("paper_reference.yaml",
                        "outputs: [mass_matrix, bias_forces, forward_dynamics, end_effector_pose, "
                        "end_effector_jacobian, generalized_jacobian]")
    arm = spacearm.load(lean, cache_dir=str(tmp_path), engine="compiled")  # its sibling alike
    assert "forward_dynamics_derivatives" not in arm.outputs
    entries = lambda: [e for e in os.listdir(tmp_path) if e.startswith("paper_reference-")]
    with pytest.raises(ValueError, match="must be a whole multiple of knots"):
        arm.plan([1.5, 0], [1.2, 0.2], 10, objective="min_effort", knots=7)
    assert len(entries()) == 1  # a task refused before the sibling is compiled
    plan = arm.plan([1.5, 0], [1.2, 0.2], 10, objective="min_effort")
    assert len(entries()) == 2  # the scene's entry and its sibling's
    rich = spacearm.load(lean.replace("generalized_jacobian]",
                                      "generalized_jacobian, forward_dynamics_derivatives]"),
                         cache_dir=str(tmp_path))
    again = rich.plan([1.5, 0], [1.2, 0.2], 10, objective="min_effort")
    assert plan["iterations"] == again["iterations"]
    assert np.array_equal(plan["tau"], again["tau"])


def test_point_to_point_plans_from_threads_take_turns():
    """Two threads planning at once (the binding releases the GIL): IPOPT's sequential MUMPS
    keeps global state, so solves take turns instead of crashing the interpreter (an attacker's
    review found a segfault). Cost: two planar solves, about 0.5 s."""
    import threading
    arm = spacearm.load(os.path.join(SOURCE, "models", "paper_reference.yaml"), cache_dir=CACHE)
    results, errors = [], []

    def solve(goal):
        try:
            results.append(arm.plan([1.5, 0], goal, 10, objective="min_effort")["goal_error"])
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=solve, args=(g,)) for g in ([1.1, 0.2], [1.2, -0.1])]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(results) == 2 and max(results) < 1e-5


def test_hostile_input_third_round(geared, tmp_path):
    """Issue 49: a failed run keeps its rows (IntegrationError.partial), a plan for another arm
    is refused, one angle rule, sizes named one by one, write_csv never onto a folder."""
    arm = spacearm.load(os.path.join(SOURCE, "tests", "scenes", "spatial_arm2.yaml"),
                        cache_dir=CACHE)
    spin = np.zeros(arm.nv)
    spin[-2:] = [100, -100]
    with pytest.raises(spacearm.IntegrationError, match="left the model's domain") as failed:
        arm.simulate(300, qd0=spin, integrator="rk4", dt=1.5)
    assert isinstance(failed.value, RuntimeError)
    assert failed.value.t == 4.5
    assert list(failed.value.partial["t"]) == [0, 1.5, 3, 4.5]
    assert failed.value.partial["q"].shape == (4, arm.nq)
    # A plan made on the geared arm, replayed into the same arm with a longer link 3.
    plan = geared.plan([1.5, 0, 0.5], [1.4, 0.05, 0.6], 1)
    text = open(os.path.join(SOURCE, "models", "paper_geared.yaml")).read()
    assert "length: 0.355" in text
    longer = spacearm.load(text.replace("length: 0.355", "length: 0.4"), cache_dir=CACHE)
    with pytest.raises(ValueError, match=r"plan: made for another arm .* the plan's end effector "
                                         r"is at \(1\.5, "):
        longer.simulate(plan=plan)
    with pytest.warns(UserWarning, match="plan: made for another arm"):
        longer.simulate(plan=plan, other_arm=True)
    geared.simulate(plan=plan)  # its own arm: no complaint
    q0 = np.zeros(geared.nq)
    q0[2] = 1e100
    with pytest.raises(ValueError, match=r"q0\[2\] \(q0\) = 1e\+100 rad: angles must lie within"):
        geared.simulate(1, q0=q0)
    with pytest.raises(ValueError, match="qd0: expected 6 values, got 7"):
        geared.simulate(1, qd0=np.zeros(7))
    with pytest.raises(ValueError, match="outside the supported magnitude range"):
        geared.mass_matrix(np.zeros(geared.nq), params={"p": 1e300})
    with pytest.raises(ValueError, match="is a folder, not a file to write a CSV into"):
        spacearm.write_csv(plan, tmp_path)


def test_identified_inertias_load_with_one_warning():
    """Issue 51: a URDF with identified link tensors under inertia_check: positive_definite loads
    with one UserWarning naming its bodies, and its mass matrix is symmetric positive definite."""
    scene = os.path.join(SOURCE, "models", "identified_arm3.yaml")
    with pytest.warns(UserWarning) as caught:
        model = spacearm.load(scene, cache_dir=CACHE)
    said = [str(w.message) for w in caught if "inertia_check" in str(w.message)]
    assert len(said) == 1 and "link 'Link_1' (principal moments 0.25, 0.25, 1.69)" in said[0]
    M = model.mass_matrix([0, 0, 0, 1, 0, 0, 0, 0.3, 0.5, -0.8])
    assert np.allclose(M, M.T, rtol=0, atol=1e-12)
    assert np.linalg.eigvalsh(M).min() > 0


def test_engines_give_the_same_bits(geared):
    """load(engine=...): the interpreter (no compiler) gives the compiled model's numbers to the
    last bit, in batches of four states too; an unknown engine is a ValueError naming it."""
    path = os.path.join(SOURCE, "models", "paper_geared.yaml")
    interpreted = spacearm.load(path, engine="interpreter")
    assert interpreted.engine == "interpreter"
    compiled = spacearm.load(path, cache_dir=CACHE, engine="compiled")
    assert compiled.engine == "compiled"
    q, qd = states(geared, 9, seed=5)
    Q = np.random.default_rng(6).uniform(-1, 1, (9, geared.nv))
    assert np.array_equal(interpreted.forward_dynamics(q, qd, Q),
                          compiled.forward_dynamics(q, qd, Q))
    assert np.array_equal(interpreted.mass_matrix(q[0]), compiled.mass_matrix(q[0]))
    with pytest.raises(ValueError, match="engine: expected auto, interpreter or compiled, got 'jit'"):
        spacearm.load(path, engine="jit")


def test_the_state_jacobian_is_on_the_tangent_space():
    """Issue 53: a spatial arm's dqdd_dq is nv x nv, the derivative along q ⊕ delta
    (Model.integrate: the base's quaternion turned in its own frame), equal to central differences
    of forward dynamics along it; dqdd_dtau is the response to each joint's link-side torque;
    difference undoes integrate; step_jacobians' step is simulate's rk4 step and its A, B are
    the step's derivatives; sizes are checked by name."""
    with open(os.path.join(SOURCE, "tests", "scenes", "spatial_arm2.yaml")) as f:
        text = f.read().replace("name: spatial_arm2", "name: spatial_arm2_derivatives")
    arm = spacearm.load(text + "outputs: [forward_dynamics, forward_dynamics_derivatives]\n",
                        cache_dir=CACHE)
    q = np.array([0.1, 0.2, 0.3, 0.5, 0.5, -0.5, 0.5, 3.0, -7.0])
    qd = np.array([0.1, -0.2, 0.3, 0.4, -0.5, 0.6, 0.7, -0.8])
    Q = np.array([0, 0, 0, 0, 0, 0, 0.5, -0.3])
    jacobian = arm.forward_dynamics_derivatives(q, qd, Q)
    dq = jacobian["dqdd_dq"]
    assert dq.shape == (8, 8) and jacobian["dqdd_dqd"].shape == (8, 8)
    h = 1e-6
    for k in range(8):
        step = h * np.eye(8)[k]
        column = (arm.forward_dynamics(arm.integrate(q, step), qd, Q) -
                  arm.forward_dynamics(arm.integrate(q, -step), qd, Q)) / (2 * h)
        assert np.abs(dq[:, k] - column).max() < 1e-6 * (1 + np.abs(column).max()), k
    # dqdd/dtau by the link-side torques: tau / p on each joint's slot (ratios 50 and 20).
    dtau = jacobian["dqdd_dtau"]
    assert dtau.shape == (8, 2)
    for j, ratio in enumerate((50, 20)):
        dQ = np.eye(8)[6 + j] / ratio
        column = (arm.forward_dynamics(q, qd, Q + dQ) - arm.forward_dynamics(q, qd, Q - dQ)) / 2
        assert np.abs(dtau[:, j] - column).max() < 1e-9 * (1 + np.abs(column).max()), j
    delta = np.array([0.3, -0.1, 0.2, 0.4, 0.5, -0.6, 0.1, 0.2])
    assert np.abs(arm.difference(q, arm.integrate(q, delta)) - delta).max() < 1e-13
    # One rk4 step's Jacobians: the step is simulate's (rk4, the torques held), and A, B equal
    # central differences of it on the tangent spaces.
    tau, dt = np.array([0.5, -0.3]), 0.01
    step = arm.step_jacobians(q, qd, tau, dt)
    assert step["A"].shape == (16, 16) and step["B"].shape == (16, 2)
    run = arm.simulate(dt, torques=np.array([[0, *tau], [dt, *tau]]), q0=q, qd0=qd,
                       integrator="rk4", dt=dt)
    assert np.abs(run["q"][-1] - step["q"]).max() < 1e-14
    assert np.abs(run["qd"][-1] - step["v"]).max() < 1e-13

    def after(q0, v0, tau0):
        s = arm.step_jacobians(q0, v0, tau0, dt)
        return np.concatenate([arm.difference(step["q"], s["q"]), s["v"] - step["v"]])

    for k in range(16):
        e = h * np.eye(16)[k]
        column = (after(arm.integrate(q, e[:8]), qd + e[8:], tau) -
                  after(arm.integrate(q, -e[:8]), qd - e[8:], tau)) / (2 * h)
        assert np.abs(step["A"][:, k] - column).max() < 1e-6 * (1 + np.abs(column).max()), k
    for j in range(2):
        e = 1e-5 * np.eye(2)[j]
        column = (after(q, qd, tau + e) - after(q, qd, tau - e)) / 2e-5
        assert np.abs(step["B"][:, j] - column).max() < 1e-6 * (1 + np.abs(column).max()), j
    with pytest.raises(ValueError, match="dt must be positive"):
        arm.step_jacobians(q, qd, tau, 0)
    unturned = q.copy()
    unturned[3:7] = 0
    with pytest.raises(ValueError, match=r"q1\[3..6\], the base's quaternion, must have a norm"):
        arm.difference(q, unturned)
    with pytest.raises(ValueError, match="delta: expected 8 values, got 9"):
        arm.integrate(q, q)


def test_a_tree_names_its_end_effectors_and_plans_one_while_the_other_holds():
    """Issue 52: models/dual_arm7 (two arms on one satellite) gives each tool's pose (7 values
    each) and Jacobian rows (6 each), named; plan moves the left tool while the right one holds
    its pose, and an unknown end effector is a ValueError naming it."""
    tree = spacearm.load(os.path.join(SOURCE, "models", "dual_arm7.yaml"), cache_dir=CACHE)
    assert tree.end_effector_names == ["l_tool_flange", "r_tool_flange"]
    chain = spacearm.load(os.path.join(SOURCE, "tests", "scenes", "spatial_arm2.yaml"),
                          cache_dir=CACHE)
    assert chain.end_effector_names == []  # one end effector
    q = np.zeros(tree.nq)
    q[3] = 1
    assert tree.end_effector_pose(q).shape == (14,)
    assert tree.end_effector_jacobian(q).shape == (12, tree.nv)
    assert tree.generalized_jacobian(q).shape == (12, tree.num_links)
    plan = tree.plan([0.6, 0.5, 2.67], [0.9, 0.6, 2.3], 2.0, end_effector="l_tool_flange",
                     hold="pose")
    columns = plan["columns"]
    left = np.array([columns["ee_l_tool_flange_" + c][-1] for c in "xyz"])
    assert np.abs(left - [0.9, 0.6, 2.3]).max() < 1e-10
    for c in "xyz":
        right = columns["ee_r_tool_flange_" + c]
        assert np.abs(right - right[0]).max() < 1e-10
    with pytest.raises(ValueError, match="end_effector: 'hand' is not an end effector"):
        tree.plan([0.6, 0.5, 2.67], [0.9, 0.6, 2.3], 2.0, end_effector="hand")
    with pytest.raises(ValueError, match="hold: unknown hold 'both'"):
        tree.plan([0.6, 0.5, 2.67], [0.9, 0.6, 2.3], 2.0, hold="both")


def test_a_tree_plans_several_end_effectors_at_once():
    """Issue 52: a list of end effectors moves each along its own line with its own time law
    (as `spacearm plan` repeats --end-effector); each reaches its goal, each law holds a quarter
    of the way (where the two differ), and malformed lists are errors naming the argument and the row."""
    tree = spacearm.load(os.path.join(SOURCE, "models", "dual_arm7.yaml"), cache_dir=CACHE)
    starts = [[0.6, 0.5, 2.67], [0.6, -0.5, 2.67]]
    goals = np.array([[0.9, 0.6, 2.3], [0.8, -0.7, 2.4]])
    plan = tree.plan(starts, goals, 2.0, end_effector=["l_tool_flange", "r_tool_flange"],
                     time_law=["quintic", "cubic"])
    columns = plan["columns"]
    middle = len(plan["t"]) // 4  # tau = 1/4, where the two laws differ
    for name, start, goal, law in zip(("l_tool_flange", "r_tool_flange"), starts, goals,
                                      (lambda s: 10 * s**3 - 15 * s**4 + 6 * s**5,
                                       lambda s: 3 * s**2 - 2 * s**3)):
        tool = np.array([columns["ee_%s_%s" % (name, c)] for c in "xyz"])
        assert np.abs(tool[:, 0] - start).max() < 1e-10
        assert np.abs(tool[:, -1] - goal).max() < 1e-10
        s = law(plan["t"][middle] / 2.0)  # along the line as its law says
        assert np.abs(tool[:, middle] - (np.array(start) + s * (goal - start))).max() < 1e-8
    # One law (a str, the default quintic) serves every line: the right tool now moves quintic.
    one_law = tree.plan(starts, goals, 2.0, end_effector=("l_tool_flange", "r_tool_flange"))
    right = np.array([one_law["columns"]["ee_r_tool_flange_" + c][middle] for c in "xyz"])
    s = plan["t"][middle] / 2.0
    s = 10 * s**3 - 15 * s**4 + 6 * s**5
    assert np.abs(right - (np.array(starts[1]) + s * (goals[1] - starts[1]))).max() < 1e-8
    with pytest.raises(ValueError, match=r"start: 1 rows for 2 end effectors"):
        tree.plan(starts[:1], goals, 2.0, end_effector=["l_tool_flange", "r_tool_flange"])
    with pytest.raises(ValueError, match=r"time_law: 1 names for 2 end effectors"):
        tree.plan(starts, goals, 2.0, end_effector=["l_tool_flange", "r_tool_flange"],
                  time_law=["cubic"])
    with pytest.raises(ValueError, match=r"end_effector\[1\]: 'hand' is not an end effector"):
        tree.plan(starts, goals, 2.0, end_effector=["l_tool_flange", "hand"])
    with pytest.raises(ValueError, match=r"goal\[1\] has 2 values and start\[1\] 3"):
        tree.plan(starts, [goals[0], [0.8, -0.7]], 2.0,
                  end_effector=["l_tool_flange", "r_tool_flange"])
    with pytest.raises(ValueError, match=r"end effector 1 is given two lines"):
        tree.plan(starts, goals, 2.0, end_effector=["l_tool_flange", "l_tool_flange"])
    with pytest.raises(TypeError, match=r"end_effector\[0\]: a name, not int"):
        tree.plan(starts, goals, 2.0, end_effector=[0, 1])
    with pytest.raises(TypeError, match=r"start: one row per end effector"):
        tree.plan("0.6", goals, 2.0, end_effector=["l_tool_flange", "r_tool_flange"])


def test_a_scenes_lanes_give_the_state_jacobian_four_states_per_call():
    """`lanes: [forward_dynamics_derivatives]` gives the state Jacobian a 4-lane function: a
    batch through it is the bits of one state per call."""
    scene = with_outputs("paper_geared.yaml",
                         "outputs: [forward_dynamics, forward_dynamics_derivatives]\n"
                         "lanes: [forward_dynamics_derivatives]")
    m = spacearm.load(scene, cache_dir=CACHE, engine="compiled")  # the library's, not the interpreter's
    q, qd = states(m, 9)
    Q = np.random.default_rng(3).uniform(-5, 5, (9, m.nv))
    four = m.forward_dynamics_derivatives(q, qd, Q)
    m.lanes = 1
    one = m.forward_dynamics_derivatives(q, qd, Q)
    assert set(four) == {"dqdd_dq", "dqdd_dqd", "qdd", "dqdd_dtau"}
    for name in four:
        assert np.array_equal(four[name], one[name]), name
    assert four["dqdd_dq"].shape == (9, m.nv, m.nv)
    # forward_dynamics has its own program (closed forms here): equal to rounding
    assert np.allclose(four["qdd"], m.forward_dynamics(q, qd, Q), rtol=1e-10, atol=1e-12)
