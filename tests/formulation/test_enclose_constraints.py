"""Constraint systems' core rows as enclosures of the input as given
(:mod:`kinbox.formulation.enclose_constraints`): the coordinate and distance formulations'
core rows carry ``merr``/``mgrad``, and every certified box holds the root of the exact input,
found by Newton in mpmath at 50 digits on the constraints written here from the file's numbers
as exact rationals (not from kinbox's rows)."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import mpmath as mp
import numpy as np
import pytest

import kinbox
from kinbox.answer.assembly import distance_assemblies
from kinbox.formulation import enclose_constraints
from kinbox.formulation.errfloat import EF
from kinbox.formulation.system import CORE_SLACK
from kinbox.search.options import SolverOptions
from kinbox.search.point import point_certifier
from kinbox.search.processor import BoxProcessor


def _rounded(monkeypatch) -> None:
    """The rows as rounded, taken as exact (no shadow build)."""
    monkeypatch.setattr(enclose_constraints, "enclosed_core", lambda *a: None)


def _core(system):
    comp = system.compile()
    n = comp.n_core
    return comp, comp.merr[:n], comp.slack[:n]


def _newton(f, x0, n: int) -> list:
    """A root of ``f`` at 50 digits from ``x0`` (its residual checked)."""
    mp.mp.dps = 50
    x = mp.findroot(f, [mp.mpf(float(v)) for v in x0], tol=mp.mpf(10) ** -45, maxsteps=60)
    x = [x[i] for i in range(n)]
    assert max(abs(v) for v in f(*x)) < mp.mpf(10) ** -40
    return x


def _holds(box, names: list[str], values: dict[str, object]) -> bool:
    for k, name in enumerate(names):
        if name in values and not (mp.mpf(float(box.lo[k])) <= values[name] <= mp.mpf(float(box.hi[k]))):
            return False
    return True


# -- tangent lines: a free line at distance r from four fixed points (coordinates) -------------
def _tangent_oracle(model, x0: dict[str, float]) -> dict[str, object]:
    """The line ``(c, d)`` at distance ``r`` from the four fixed points, ``|d| = 1``, ``c . d = 0``."""
    pts = [[mp.mpf(float(v)) for v in model.entities[n].point] for n in ("p1", "p2", "p3", "p4")]
    r = mp.mpf(model.value(model.constraints[0]))

    def f(cx, cy, cz, dx, dy, dz):
        c, d = [cx, cy, cz], [dx, dy, dz]
        out = []
        for p in pts:
            w = [p[k] - c[k] for k in range(3)]
            out.append(sum(v * v for v in w) - sum(w[k] * d[k] for k in range(3)) ** 2 - r * r)
        return out + [sum(v * v for v in d) - 1, sum(c[k] * d[k] for k in range(3))]

    names = ["L.cx", "L.cy", "L.cz", "L.dx", "L.dy", "L.dz"]
    return dict(zip(names, _newton(f, [x0[n] for n in names], 6)))


def test_tangent_lines_rows_carry_the_rounding_of_the_radius_squared():
    p = kinbox.Assemble("tangent-lines")
    comp, merr, slack = _core(p.system)
    assert p.system.core_errors is not None
    r = Fraction(p.model.value(p.model.constraints[0]))
    core = [c for c in p.system.constraints if c.kind == "core"]
    for k, name in enumerate(comp.row_names[: comp.n_core]):
        if name.endswith("|dist"):
            # the constant 3 - r^2, computed in binary64: its distance to the exact one is in merr
            exact = 3 - r * r
            assert merr[k] >= float(abs(Fraction(float(comp.c[k])) - exact))
            # and merr is a few roundings of the row's size (below the rows' own core slack)
            assert 0.0 < merr[k] <= CORE_SLACK * p.system.size(core[k].expr)
        else:  # |d| = 1 and c . d = 0: exact
            assert merr[k] == 0.0
    assert np.all(merr <= slack)


def test_tangent_lines_certified_boxes_hold_the_exact_lines(monkeypatch):
    p = kinbox.Assemble("tangent-lines")
    enclosed = p.solve(progress=False)
    names = enclosed.raw.system.names
    cert = enclosed.raw.certified
    assert enclosed.stats["certified"] == 12  # (a line whose direction has x = 0 is found twice)
    for b in cert:
        assert _holds(b, names, _tangent_oracle(p.model, dict(zip(names, b.x))))
    _rounded(monkeypatch)
    rounded = kinbox.Assemble("tangent-lines").solve(progress=False)
    assert rounded.raw.system.core_errors is None
    assert rounded.stats["certified"] == 12 and len(rounded.raw.certified) == len(cert)
    assert rounded.stats["boxes"] == enclosed.stats["boxes"]


# -- octahedral manipulator: free points under squared distances (distances, by default) --------
def _points_oracle(model, start: dict[str, np.ndarray]) -> dict[str, list]:
    """The points, p1 at the origin, p2 on the x axis, p3 in the xy plane, at the exact
    squared distances of the file (a ``squared`` value is exact as given)."""
    unknown = [("p2", 0), ("p3", 0), ("p3", 1)] + [(n, k) for n in ("p4", "p5", "p6") for k in range(3)]
    cons = []
    for c in model.constraints:
        raw = model.parameters[c.param] if c.param is not None else c.value
        S = mp.mpf(raw) if c.squared else mp.mpf(raw) ** 2
        cons.append((c.entities, S))

    def pts(*x):
        P = {n: [mp.mpf(0)] * 3 for n in ("p1", "p2", "p3", "p4", "p5", "p6")}
        for (n, k), v in zip(unknown, x):
            P[n] = list(P[n])
            P[n][k] = v
        return P

    def f(*x):
        P = pts(*x)
        return [sum((P[a][k] - P[b][k]) ** 2 for k in range(3)) - S for (a, b), S in cons]

    root = _newton(f, [start[n][k] for n, k in unknown], len(unknown))
    return pts(*root)


def _octahedral(name: str):
    p = kinbox.Assemble(name)
    res = p.solve(progress=False)
    assert p.formulation == "distances"
    return p, res


@pytest.mark.parametrize("name", ["octahedral-a", "octahedral-b"])
def test_octahedral_rows_carry_the_rounding_of_their_squared_legs(name):
    p = kinbox.Assemble(name)
    for system in (p.geometry.system, p.distances.system):
        comp, merr, slack = _core(system)
        assert system.core_errors is not None
        assert np.all(merr <= slack) and merr.max() > 0.0
    # the coordinate rows |w|^2 - v^2 with v = sqrt(S) rounded: merr covers |fl(v^2) - S|
    comp, merr, _ = _core(p.geometry.system)
    by_key = {c.key: c for c in p.model.constraints}
    for k, row in enumerate(comp.row_names[: comp.n_core]):
        own, what = row.split("|")
        if what != "dist":
            continue
        c = by_key[own]
        S = Fraction(p.model.parameters[c.param] if c.param is not None else c.value)
        off = abs(Fraction(-float(comp.c[k])) - S)
        assert merr[k] >= float(off)
        assert (merr[k] > 0.0) if off else True


def test_octahedral_certified_boxes_hold_the_exact_assemblies(monkeypatch):
    p, res = _octahedral("octahedral-b")
    assert res.stats["certified"] == len(res.solutions) == 16
    geo = p.geometry
    prove = point_certifier(geo.system)
    gnames = geo.system.names
    for s in res.solutions:
        # the assembly's proof (coordinate rows, around its point) holds the exact assembly
        box = prove(s.x, newton_iters=40)
        assert box is not None
        P = _points_oracle(p.model, {n: pl.p for n, pl in s.entities.items()})
        exact = {f"{n}.{'xyz'[k]}": P[n][k] for n in P for k in range(3)}
        assert _holds(box, gnames, exact)
    # the distance search's certified boxes hold the exact squared distances
    dnames = p.distances.system.names
    cert = res.raw.certified
    assert cert
    for b in cert:
        for a in distance_assemblies(p.distances, b.x):
            P = _points_oracle(p.model, {n: pl.p for n, pl in a.entities.items()})
            exact = {f"r[{u},{v}]": sum((P[u][k] - P[v][k]) ** 2 for k in range(3)) for u, v in itertools.permutations(P, 2)}
            assert _holds(b, dnames, exact)
    _rounded(monkeypatch)
    p2, res2 = _octahedral("octahedral-b")
    assert p2.distances.system.core_errors is None
    assert res2.stats["certified"] == 16 and res2.stats["boxes"] == res.stats["boxes"]


# -- a proof that holds for the rounded rows only ------------------------------------------------
#: a point on a plane given by a point far out (1e8: its offset n . p, rounded, is some 1e-8 off
#: the exact one) at unit distance from two fixed points
FAR_PLANE = {
    "kind": "constraints",
    "name": "far-plane",
    "entities": {
        "A": {"type": "point", "fixed": [0, 0, 0]},
        "B": {"type": "point", "fixed": [1, 0, 0]},
        "F": {"type": "plane", "fixed": {"point": [100000000.3, 100000000, 0], "normal": [1, -1, 0]}},
        "P": {"type": "point"},
    },
    "constraints": [
        {"type": "incident", "entities": ["P", "F"]},
        {"type": "distance", "entities": ["A", "P"], "value": 1},
        {"type": "distance", "entities": ["B", "P"], "value": 1},
    ],
}


def _far_plane_root(z0: float) -> dict[str, object]:
    mp.mp.dps = 50
    fp = FAR_PLANE["entities"]["F"]["fixed"]
    px, py = mp.mpf(float(fp["point"][0])), mp.mpf(float(fp["point"][1]))

    def f(x, y, z):  # on the plane (x - px) - (y - py) = 0, unit distance from A and B
        return [(x - px) - (y - py), x * x + y * y + z * z - 1, (x - 1) ** 2 + y * y + z * z - 1]

    return dict(zip(["P.x", "P.y", "P.z"], _newton(f, [0.5, 0.3, z0], 3)))


def test_a_proof_of_the_rounded_rows_misses_the_exact_root():
    """Around the rounded rows' root, Krawczyk on the rounded rows proves a box that misses
    the input's root (the plane's offset is off by some 1e-8); with the enclosure the box it
    proves holds the exact root, and so does a proof in a wider box and the search's."""
    p = kinbox.Assemble(FAR_PLANE)
    s = p.system
    names = s.names
    assert s.core_errors is not None and _core(s)[1].max() > 1e-9
    guess = np.zeros(s.n)
    for k, v in (("P.x", 0.5), ("P.y", 0.2), ("P.z", 0.84)):
        guess[names.index(k)] = v
    guess = p.geometry.encode(p.geometry.placements(guess))
    exact = _far_plane_root(0.84)
    ce = s.core_errors

    s.core_errors = None  # the rows as rounded
    s.invalidate()
    box = point_certifier(s)(guess, newton_iters=40)
    assert box is not None and not _holds(box, names, exact)

    s.core_errors = ce
    s.invalidate()
    box = point_certifier(s)(guess, newton_iters=40)
    assert box is not None and _holds(box, names, exact)
    proc = BoxProcessor(s, SolverOptions(lp=False))
    x = proc.cert.newton(guess, iters=40)
    r = 1e-6 * (1.0 + np.abs(x))
    sol = proc.process(x - r, x + r).solution
    assert sol is not None and sol.certified and _holds(sol, names, exact)
    res = p.solve(progress=False)
    assert res.stats["certified"] == 2
    for b in res.raw.certified:
        assert _holds(b, names, _far_plane_root(float(b.x[names.index("P.z")])))


#: a plane G through two fixed points at the binary64 angle nearest pi/2 to the plane z = 0
RIGHT = 1.5707963267948966


def _snapped(value: float = RIGHT, a: str = "plane") -> dict:
    return {
        "kind": "constraints",
        "name": "snapped",
        "bounds": 2,
        "entities": {
            "F": {"type": a, "fixed": {"point": [0, 0, 0], ("normal" if a == "plane" else "direction"): [0, 0, 1]}},
            "G": {"type": "plane"},
            "p": {"type": "point", "fixed": [1, 0, 0]},
            "q": {"type": "point", "fixed": [0, 1, 0]},
        },
        "constraints": [
            {"type": "angle", "entities": ["F", "G"], "value": value},
            {"type": "incident", "entities": ["p", "G"]},
            {"type": "incident", "entities": ["q", "G"]},
        ],
    }


def _snapped_roots(t) -> list[dict[str, object]]:
    """G's exact normal ``(a, a, +-t)`` and offset ``a`` (``a = sqrt((1 - t^2) / 2)``): the two
    senses of the angle whose cosine is ``t`` between G and the plane z = 0, at 50 digits."""
    mp.mp.dps = 50
    a = mp.sqrt((1 - t * t) / 2)
    return [{"G.dx": a, "G.dy": a, "G.dz": sg * t, "G.h": a} for sg in (1, -1)]


def _snapped_box(p):
    s = p.system
    guess = np.array([0.7, 0.7, 0.7, 0.0])
    guess[s.names.index("G.dz")] = 0.0
    box = point_certifier(s)(guess, newton_iters=40)
    assert box is not None
    return box


def test_an_angle_taken_as_perpendicular_carries_its_cosine():
    """An angle of binary64 pi/2 between two planes is written as perpendicularity (one row
    ``u . v = 0``); the exact angle's cosine, 6.1e-17, is that row's ``merr``, so the proof
    covers both senses of the angle as given (``u . v = +-cos``): the certified box holds
    both 50-digit roots, and the search's assembly is certified."""
    p = kinbox.Assemble(_snapped(), check=False)
    s = p.system
    comp, merr, _ = _core(s)
    row = comp.row_names.index("c1|perp")
    mp.mp.dps = 50
    t = abs(mp.cos(mp.mpf(RIGHT)))
    assert s.core_errors is not None and mp.mpf(float(merr[row])) >= t > 6e-17
    box = _snapped_box(p)
    assert all(_holds(box, s.names, r) for r in _snapped_roots(t))
    res = p.solve(progress=False)
    assert res.stats["certified"] == 1
    assert all(_holds(b, s.names, r) for b in res.raw.certified for r in _snapped_roots(t))
    # a line parallel to a plane at the binary64 pi (sin pi = 1.2e-16 as given): the same
    line = kinbox.Assemble(_snapped(3.141592653589793, a="line"), check=False).system
    comp = line.compile()
    assert line.core_errors is not None
    assert comp.merr[comp.row_names.index("c1|par")] >= abs(mp.sin(mp.mpf(math.pi)))


def test_a_right_angle_known_within_a_radius_is_carried_to_the_box(monkeypatch):
    """The angle's row error set to 1e-10 (an angle known only within 1e-10 of pi/2): the
    certified box holds the roots of the angles pi/2 +- 1e-10; with the error of the binary64
    angle (6.1e-17) the box is a few ulps wide and misses them: what the test catches if the
    snapped row's error were lost on the way (``Numbers.snapped``, ``core_errors``)."""
    r = 1e-10
    mp.mp.dps = 50
    wide = _snapped_roots(mp.sin(mp.mpf(r)))
    box = _snapped_box(kinbox.Assemble(_snapped(), check=False))
    assert not any(_holds(box, ["G.h", "G.dx", "G.dy", "G.dz"], w) for w in wide)
    monkeypatch.setattr(enclose_constraints.EnclosedNumbers, "snapped", lambda self, m, c, row: EF(0.0, r))
    p = kinbox.Assemble(_snapped(), check=False)
    box = _snapped_box(p)
    assert all(_holds(box, p.system.names, w) for w in wide)


def test_an_angle_taken_as_parallel_stays_rounded():
    """A line at the binary64 angle pi/2 to a plane, or two planes at the binary64 pi, are
    written as one direction: the exact angle leaves the directions a cone of 6.1e-17 (1.2e-16)
    apart, which no row carries, so the rows are not claimed to be the input's
    (``core_errors`` None); the angle 0 is exact."""
    assert kinbox.Assemble(_snapped(a="line"), check=False).system.core_errors is None
    assert kinbox.Assemble(_snapped(3.141592653589793), check=False).system.core_errors is None
    assert kinbox.Assemble(_snapped(0.0), check=False).system.core_errors is not None
    assert kinbox.Assemble(_snapped(1.2), check=False).system.core_errors is not None


@pytest.mark.parametrize(
    "value, a, noted", [(RIGHT, "line", True), (3.141592653589793, "plane", True), (0.0, "plane", False), (RIGHT, "plane", False)]
)
def test_the_answer_notes_an_angle_taken_as_parallel(value, a, noted):
    """The answer says which angle its certificates take as exact parallelism (JSON ``notes``,
    the table's ``note:`` lines); an angle 0, or one carried as a row error, needs no note."""
    res = kinbox.assemble(_snapped(value, a=a), check=False)
    assert res.complete and res.solutions
    assert bool(res.notes) == noted
    assert ("notes" in res.to_dict()) == noted and ("note: constraint #1" in res.table()) == noted


def test_the_diagnosis_proves_inconsistency_for_the_input_as_given(monkeypatch):
    """``kinbox check``'s proof that a set of constraints has no assembly searches rows that
    carry their rounding (0.9 squared is not a binary64 number)."""
    from kinbox.problems import diagnosis

    searched = []
    solve = diagnosis.solver.solve_system

    def spy(system, opts, **kw):
        searched.append(system.core_errors is not None and float(system.compile().merr.max()))
        return solve(system, opts, **kw)

    monkeypatch.setattr(diagnosis.solver, "solve_system", spy)
    model = {
        "kind": "constraints",
        "name": "four-spheres",
        "entities": {
            "A": {"type": "point", "fixed": [0, 0, 0]},
            "B": {"type": "point", "fixed": [1, 0, 0]},
            "C": {"type": "point", "fixed": [0, 1, 0]},
            "D": {"type": "point", "fixed": [0, 0, 1]},
            "P": {"type": "point"},
        },
        # any three spheres of radius 0.9 about A..D meet, the four do not
        "constraints": [{"type": "distance", "entities": [n, "P"], "value": 0.9} for n in "ABCD"],
    }
    c = kinbox.check(model)
    assert c.inconsistent and all(f"#{k}" in c.inconsistent for k in range(1, 5))
    assert searched and all(m and m > 0.0 for m in searched)
