"""The three LP contractors (``relaxation="linear"`` of Porta, Ros and Thomas 2009, ``"bernstein"`` of Fünfzig et al. 2010, ``"none"``)
give the same answers: the same certified solutions of isolated problems, the same curves of
mobile ones, and each is selected by the option and by ``--relaxation``."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import kinbox
from kinbox.errors import InputError
from kinbox.formulation.system import System
from kinbox.pipeline import solve_system
from kinbox.search.bernstein import BernsteinRelaxation
from kinbox.search.contractors import CtcBernstein, CtcLinear, LinearRelaxation
from kinbox.search.solver import BoxProcessor, SolverOptions

RELAXATIONS = ["linear", "bernstein", "none"]


def same_points(a, b, tol=1e-8) -> bool:
    a, b = sorted(map(tuple, a)), sorted(map(tuple, b))
    return len(a) == len(b) and all(np.max(np.abs(np.subtract(p, q))) <= tol for p, q in zip(a, b))


def test_the_option_selects_the_contractor():
    s = System()
    x, y = s.add_var("x", -2, 2), s.add_var("y", -2, 2)
    s.add_eq(x * x + y * y - 1.0)
    s.add_eq(x - y)
    kinds = {rel: type(BoxProcessor(s, SolverOptions(relaxation=rel)).lp) for rel in RELAXATIONS}
    assert kinds == {"linear": CtcLinear, "bernstein": CtcBernstein, "none": type(None)}
    engines = {rel: type(BoxProcessor(s, SolverOptions(relaxation=rel)).lp.engine) for rel in ("linear", "bernstein")}
    assert engines == {"linear": LinearRelaxation, "bernstein": BernsteinRelaxation}
    assert BoxProcessor(s, SolverOptions(relaxation="bernstein", lp=False)).lp is None
    with pytest.raises(InputError, match="relaxation"):
        solve_system(s, relaxation="simplex")


def test_the_lp_contractor_is_built_when_first_asked_for_with_the_deadline_set_before():
    """Most IK poses run no LP round, so the processor builds its relaxation only when a round
    asks for it; a deadline set before then still stops that relaxation's LPs."""
    s = System()
    x, y = s.add_var("x", -2, 2), s.add_var("y", -2, 2)
    s.add_eq(x * x + y * y - 1.0)
    s.add_eq(x - y)
    proc = BoxProcessor(s, SolverOptions(relaxation="bernstein"))
    assert proc.has_lp
    proc.set_deadline(123.0)
    lp = proc.lp
    assert isinstance(lp, CtcBernstein) and lp.deadline == lp.engine.deadline == lp.relax.deadline == 123.0
    assert proc.lp is lp  # built once
    proc.set_deadline(None)
    assert lp.deadline is None and lp.engine.deadline is None and lp.relax.deadline is None
    assert not BoxProcessor(s, SolverOptions(relaxation="none")).has_lp


def test_lps_run_with_each_relaxation():
    """A curve (the unit circle in 3-space, cut by a plane) to a fine sigma: no Krawczyk, LPs
    probe and pay; each LP contractor solves LPs, and every choice covers the same curve."""
    s = System()
    x, y, z = s.add_var("x", -2, 2), s.add_var("y", -2, 2), s.add_var("z", -2, 2)
    s.add_eq(x * x + y * y + z * z - 1.0)
    s.add_eq(x + y * 0.5 - z * 0.25 - 0.1)
    cover = {}
    for rel in RELAXATIONS:
        r = solve_system(s, sigma=0.02, relaxation=rel)
        assert r.complete and r.boxes
        assert (r.stats["lps"] > 0) == (rel != "none")
        # every box is near the circle, and the circle's points are in the union of the boxes
        cover[rel] = r.boxes
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    n = np.array([1.0, 0.5, -0.25])
    c = 0.1 * n / (n @ n)  # the plane's point nearest the origin; the circle's radius follows
    e1 = np.cross(n, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n / np.linalg.norm(n), e1)
    rad = np.sqrt(1.0 - c @ c)
    for rel, boxes in cover.items():
        for p in c + rad * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2):
            assert any(np.all(b.lo - 1e-9 <= p) and np.all(p <= b.hi + 1e-9) for b in boxes), (rel, p)


def test_general_6r_same_16_solutions():
    qs = {}
    for rel in RELAXATIONS:
        r = kinbox.solve("general-6r", relaxation=rel, progress=False)
        assert r.complete and len(r.solutions) == 16 and all(s.certified for s in r.solutions)
        qs[rel] = [s.q for s in r.solutions]
    assert same_points(qs["linear"], qs["bernstein"]) and same_points(qs["linear"], qs["none"])


def test_ur5_pose_same_8_solutions():
    ik = kinbox.IK("ur5", "tool0")
    pose = ik.pose_at([0.3, -1.2, 1.5, -0.8, 1.2, 0.4])
    qs = {}
    for rel in RELAXATIONS:
        r = ik.solve(pose, relaxation=rel, progress=False, closed_form=False)
        assert r.complete and len(r.solutions) == 8 and all(s.certified for s in r.solutions)
        qs[rel] = [s.q for s in r.solutions]
    assert same_points(qs["linear"], qs["bernstein"]) and same_points(qs["linear"], qs["none"])


@pytest.mark.slow
@pytest.mark.parametrize("rel", RELAXATIONS)
def test_four_bar_two_curves(rel):
    r = kinbox.solve("four-bar", relaxation=rel, sigma=0.1, progress=False)
    assert r.complete
    assert sum(1 for c in r.components if c.dimension >= 1) == 2
    assert not r.solutions  # no isolated point: the unresolved boxes "none" leaves are not solutions


def test_cli_relaxation_flag():
    p = subprocess.run(
        [sys.executable, "-m", "kinbox.cli", "solve", "general-6r", "--relaxation", "bernstein", "--json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] and len(d["solutions"]) == 16


@pytest.mark.slow
@pytest.mark.parametrize("name,kw,expect", [("dietmeier", {}, 40), ("griffis-duffy", {"legs": "vector", "sigma": 0.25}, None)])
def test_published_problems_same_answer(name, kw, expect):
    """Dietmeier's 40 assembly modes and the two curves of the Griffis-Duffy platform, with each
    LP contractor (minutes each; intervals alone take longest)."""
    qs = {}
    for rel in ("linear", "bernstein"):
        r = kinbox.solve(name, relaxation=rel, progress=False, **kw)
        assert r.complete
        if expect is not None:
            assert len(r.solutions) == expect and all(s.certified for s in r.solutions)
            qs[rel] = [s.q for s in r.solutions]
        else:
            assert sum(1 for c in r.components if c.dimension >= 1) == 2
    if qs:
        assert same_points(qs["linear"], qs["bernstein"], tol=1e-6)


def test_bernstein_layout_is_shared_by_the_poses_of_an_arm_and_equals_a_fresh_one():
    """The layout of the Bernstein LP depends on the pattern of the system only: two poses of an
    arm (one template, new numbers) share it, and the LP a pose gets from the shared layout is
    the one built from nothing, array for array (coefficients, rows, bounds on a box)."""
    from kinbox.search import bernstein

    ik = kinbox.IK("ur5", "tool0")
    c1, c2 = (
        ik.problem(ik.pose_at(q)).formulation.system.compile() for q in ([0.3, -1.2, 1.5, -0.8, 1.2, 0.4], [1.0, 0.2, -2.0, 0.5, -1.0, 2.0])
    )
    bernstein._LAYOUTS.clear()
    a, b = bernstein.BernsteinLP(c1), bernstein.BernsteinLP(c2)
    assert a._cp is b._cp and a.index is b.index
    bernstein._LAYOUTS.clear()
    fresh = bernstein.BernsteinLP(c2)
    assert fresh._cp is not b._cp
    lo, hi = -np.ones(c2.n) * 0.9, np.ones(c2.n) * 0.8
    for lp in (b, fresh):
        lp.build(lo, hi)
    for name in ("_ca", "_cp", "_cq", "_cs", "_slot_row", "start", "index", "value", "row_lo", "row_hi", "rel_lo", "col_nnz", "sq_of"):
        assert np.array_equal(getattr(b, name), getattr(fresh, name)), name
    assert not np.array_equal(a._ca, b._ca)  # the numbers of each pose are its own
