#!/usr/bin/env python3
"""SymPy peer for the benchmarks: M and the bias of a chain scene, derived the way a SymPy
user would (T, hessian, Euler-Lagrange), printed as C++ with sympy.cse.

    sympy_chain.py SCENE.yaml OUT_DIR        writes OUT_DIR/<name>_sympy.hpp

This is an independent derivation (it shares no code with generator/), so bench_dynamics
also checks it against the generated model before timing either. It reads the subset of the
scene format that bench/scenes uses: a free-floating or fixed base, links, one gear mapping
for all joints (exact or armature rotor coupling), numbers or parameter names.
"""
import sys
import time
from pathlib import Path

import sympy as sp
from sympy.printing.c import C99CodePrinter
import yaml


def value(v, params):
    """A scene number, or the symbol of a run-time parameter."""
    if isinstance(v, str):
        if v not in params:
            sys.exit(f"sympy_chain.py: '{v}' is not a parameter")
        return params[v]
    return sp.nsimplify(v, rational=True)  # exact, as the generator folds constants


def derive(scene):
    params = {name: sp.Symbol(f"param_{name}", positive=True) for name in scene.get("parameters", {})}
    base, links, gears = scene["base"], scene["links"], scene.get("gears")
    free = base.get("type", "free_floating") == "free_floating"
    n_links = len(links)
    if gears is not None and not isinstance(gears, dict):
        sys.exit("sympy_chain.py: only one gear mapping for all joints is supported")
    names = (["x0", "y0", "q0"] if free else []) + [f"q{i + 1}" for i in range(n_links)]
    q = sp.symbols([f"q_{k}" for k in range(len(names))], real=True)
    qd = sp.symbols([f"qd_{k}" for k in range(len(names))], real=True)
    first = 3 if free else 0

    def rot(a, v):
        return sp.Matrix([sp.cos(a) * v[0] - sp.sin(a) * v[1], sp.sin(a) * v[0] + sp.cos(a) * v[1]])

    p = value(gears["ratio"], params) if gears else 1
    Im = value(gears["motor_inertia"], params) if gears else 0
    joint = [q[first + i] / p for i in range(n_links)]  # eq. 12: coordinates are motor angles
    th0 = q[2] if free else 0
    origin = sp.Matrix([q[0], q[1]]) if free else sp.Matrix([0, 0])

    def velocity(r):  # dr/dt = (dr/dq) qd
        return r.jacobian(sp.Matrix(q)) * sp.Matrix(qd)

    T = 0
    if free:
        T += sp.Rational(1, 2) * value(base["mass"], params) * (qd[0] ** 2 + qd[1] ** 2)
        T += sp.Rational(1, 2) * value(base["inertia"], params) * qd[2] ** 2
    mount = [value(c, params) for c in base.get("mount", [0, 0])]
    j = origin + rot(th0, mount)
    th_prev, thd_prev = th0, (qd[2] if free else 0)
    for i, link in enumerate(links):
        th = th_prev + joint[i]
        thd = thd_prev + qd[first + i] / p
        com = j + rot(th, [value(c, params) for c in link["com"]])
        v = velocity(com)
        I_link = value(link["inertia"], params)
        if gears and gears.get("compensate_link_inertia", False):
            I_link -= Im
        T += sp.Rational(1, 2) * value(link["mass"], params) * (v.T * v)[0] + sp.Rational(1, 2) * I_link * thd ** 2
        if gears:  # eqs. 10-11 (with the 1/2): the rotor turns with the previous body
            omega_m = qd[first + i] if gears.get("rotor_coupling", "exact") == "armature" else thd_prev + qd[first + i]
            T += sp.Rational(1, 2) * Im * omega_m ** 2
        j = j + rot(th, [value(link["length"], params), 0])
        th_prev, thd_prev = th, thd

    qv, qdv = sp.Matrix(q), sp.Matrix(qd)
    M = sp.hessian(T, qd)  # eq. 6
    # Euler-Lagrange at qdd = 0: d/dt dT/dqd - dT/dq = Mdot qd - dT/dq = C qd (eq. 5)
    bias = (M * qdv).jacobian(qv) * qdv - sp.Matrix([T]).jacobian(qv).T
    return names, list(params.items()), q, qd, M, bias


def emit(scene, out_dir):
    t0 = time.perf_counter()
    names, params, q, qd, M, bias = derive(scene)
    n = len(names)
    t1 = time.perf_counter()
    upper = [(i, k) for i in range(n) for k in range(i, n)]
    exprs = [M[i, k] for i, k in upper] + [bias[i] for i in range(n)]
    replacements, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("t"))
    t2 = time.perf_counter()
    printer = C99CodePrinter()
    ops = sp.count_ops([e for _, e in replacements] + reduced)
    name = scene["name"] + "_sympy"
    lines = [
        f"// SymPy {sp.__version__} peer for bench_dynamics, from {scene['name']}.yaml by bench/sympy_chain.py.",
        "// Generated at build time; do not edit.",
        f"// derive {t1 - t0:.2f} s, cse {t2 - t1:.2f} s, {len(replacements)} subexpressions, {ops} operations",
        "#pragma once",
        "#include <cmath>",
        f"namespace spacearm::bench::{name} {{",
        f"inline constexpr int kNq = {n};",
        f"inline constexpr int kOperations = {ops};",
        "inline constexpr const char* kParameterNames[] = {"
        + ", ".join(f'"{p}"' for p, _ in params) + ("" if params else "nullptr") + "};",
        "// M (row-major, full) and the bias C qd at (q, qd); params in kParameterNames order.",
        "inline void mass_matrix_and_bias(const double* q, const double* qd, const double* params, double* M,",
        "                                 double* bias) {",
        "  (void)params;",
    ]
    used = set().union(*(e.free_symbols for e in [e for _, e in replacements] + reduced))
    for k in range(n):  # only what is used: the base position never appears
        for sym, array in ((q[k], "q"), (qd[k], "qd")):
            if sym in used:
                lines.append(f"  const double {sym} = {array}[{k}];")
    for k, (p, sym) in enumerate(params):
        if sym in used:
            lines.append(f"  const double {sym} = params[{k}];  // {p}")
    for sym, e in replacements:
        lines.append(f"  const double {sym} = {printer.doprint(e)};")
    for (i, k), e in zip(upper, reduced[: len(upper)]):
        lines.append(f"  M[{i * n + k}] = {printer.doprint(e)};")
        if i != k:
            lines.append(f"  M[{k * n + i}] = M[{i * n + k}];")
    for i, e in enumerate(reduced[len(upper):]):
        lines.append(f"  bias[{i}] = {printer.doprint(e)};")
    lines += ["}", f"}}  // namespace spacearm::bench::{name}", ""]
    Path(out_dir, name + ".hpp").write_text("\n".join(lines))
    print(f"sympy_chain.py: {name}: derive {t1 - t0:.2f} s, cse {t2 - t1:.2f} s, {ops} operations")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    emit(yaml.safe_load(Path(sys.argv[1]).read_text()), sys.argv[2])
