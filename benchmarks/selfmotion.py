"""Self-motions and singular roots: CPU seconds, boxes, components,
with curve boxes on and off in one run.

    python benchmarks/selfmotion.py [--cases ur5-zero,panda-1,...] [--time-limit S] [--off]

``--sweep`` runs the seven-joint cases (``panda-*``) by the sweep (the default, see
``kinbox.problems.selfmotion``) and by the branch and prune in one run and prints a JSON line each;
``--record`` stores those rows on docs/benchmarks.md. ``--anchors`` runs the sweep's cases
(``panda-*``, and ``shoulder7-*``: a seven-joint arm whose first joint is swept,
``tests/data/arms/skew_shoulder7_dh.json``) with the exact goal's anchors and without (the
linear goal's binary64 value), interleaved three times each, and prints the median CPU of
each, their ratio and the certified points (docs/soundness.md). ``--off`` also runs every case with
``curve_boxes=False`` (every uncertified box split down to sigma, as before curve boxes), right
after the same case with them, so both see the same machine load. CPU time is
``time.process_time`` of the solve and its answer stage (kernels loaded before). Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from collections.abc import Callable

import numpy as np

import kinbox
from kinbox.model.builders import stewart


def _ur5(q) -> Callable[..., kinbox.Result]:
    prob = kinbox.IK("ur5", "tool0")
    goal = prob.pose_at(q)
    return lambda **kw: prob.solve(goal, **kw)


def _panda(seed: int) -> Callable[..., kinbox.Result]:
    prob = kinbox.IK("panda", "panda_hand")
    m = prob.robot.model
    q = np.random.default_rng(seed).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = prob.pose_at(q)
    return lambda **kw: prob.solve(goal, **kw)


def _tangent_3_3() -> Callable[..., kinbox.Result]:
    """The 3-3 platform of tests/answer/test_answer.py measured at a singular pose (two assembly modes
    merge): legs from the pose found there by a sign change of the Jacobian's determinant."""
    import pinocchio as pin
    from scipy.optimize import brentq

    base = np.array([[1.0, 0.0, 0.0], [-0.45, 0.85, 0.0], [-0.55, -0.8, 0.0]])
    top = np.array([[0.5, 0.1, 0.0], [-0.2, 0.45, 0.0], [-0.3, -0.4, 0.0]])
    P, Q = base[[0, 0, 1, 1, 2, 2]], top[[0, 1, 1, 2, 2, 0]]

    def legs(p):
        return np.linalg.norm(p[3:] + Q @ pin.exp3(p[:3]).T - P, axis=1)

    def det(s):
        p = np.array([0.1, -0.05, 0.2 + s, 0.05, -0.02, 0.8])  # turned about the vertical
        rq = Q @ pin.exp3(p[:3]).T
        d = p[3:] + rq - P
        u = d / np.linalg.norm(d, axis=1)[:, None]
        return float(np.linalg.det(np.hstack([u, np.cross(rq, u)])))

    grid = np.linspace(-1.0, 1.0, 201)
    a = next(a for a, b in zip(grid, grid[1:]) if det(a) * det(b) < 0)
    s = brentq(det, a, a + grid[1] - grid[0], xtol=1e-15, rtol=1e-15)
    mech = stewart(P, Q, legs(np.array([0.1, -0.05, 0.2 + s, 0.05, -0.02, 0.8])), name="tangent-3-3")
    return lambda **kw: kinbox.solve(mech, **kw)


def _shoulder7_ik() -> kinbox.IK:
    from pathlib import Path

    return kinbox.IK(str(Path(__file__).resolve().parents[1] / "tests" / "data" / "arms" / "skew_shoulder7_dh.json"), "tool")


def anchors_row(name: str, reps: int = 3) -> dict:
    """One seven-joint pose by the sweep with the exact goal's anchors and without, interleaved
    (the order alternates), ``reps`` times each: median CPU seconds, ratio, certified points."""
    family, seed = name.rsplit("-", 1)
    prob = kinbox.IK("panda", "panda_hand") if family == "panda" else _shoulder7_ik()
    sw = prob.sweeper
    m = prob.robot.model
    q = np.random.default_rng(int(seed)).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = prob.pose_at(q)
    real = sw.anchors
    sw.anchors(goal)  # the anchors' constants built once per arm, before any timing
    cpu: dict[bool, list[float]] = {True: [], False: []}
    cert: dict[bool, tuple[int, int]] = {}
    for rep in range(reps):
        for on in (True, False) if rep % 2 == 0 else (False, True):
            sw.anchors = real if on else (lambda g: None)
            t = time.process_time()
            res = sw.solve(prob.problem(goal), goal)
            cpu[on].append(time.process_time() - t)
            cert[on] = (int(res.stats["certified_points"]), int(res.stats["curve_points"])) if res is not None else (0, 0)
    sw.anchors = real
    a, b = float(np.median(cpu[True])), float(np.median(cpu[False]))
    return dict(
        case=name,
        swept=sw.swept.name,
        cpu_anchors=a,
        cpu_binary64=b,
        ratio=a / b,
        certified_anchors=cert[True][0],
        certified_binary64=cert[False][0],
        points=cert[True][1],
    )


def slab_proof_row(name: str, reps: int = 3) -> dict:
    """One seven-joint pose by the sweep with the slabs' proof (kinbox.search.slab_proof) and
    without, interleaved (the order alternates), ``reps`` times each: median CPU seconds, their
    ratio, the decided slabs proven and not."""
    from kinbox.answer import selfmotion as answer_selfmotion

    family, seed = name.rsplit("-", 1)
    prob = kinbox.IK("panda", "panda_hand") if family == "panda" else _shoulder7_ik()
    sw = prob.sweeper
    m = prob.robot.model
    q = np.random.default_rng(int(seed)).uniform(m.lowerPositionLimit[:7], m.upperPositionLimit[:7])
    goal = prob.pose_at(q)
    sw.anchors(goal)  # the anchors' constants built once per arm, before any timing
    cpu: dict[bool, list[float]] = {True: [], False: []}
    counts: tuple[int, int] = (0, 0)
    old = answer_selfmotion.PROVE_SLABS
    try:
        for rep in range(reps):
            for on in (True, False) if rep % 2 == 0 else (False, True):
                answer_selfmotion.PROVE_SLABS = on
                t = time.process_time()
                res = sw.solve(prob.problem(goal), goal)
                cpu[on].append(time.process_time() - t)
                if on and res is not None:
                    counts = (int(res.stats["slabs_proven"]), int(res.stats["slabs_unproven"]))
    finally:
        answer_selfmotion.PROVE_SLABS = old
    a, b = float(np.median(cpu[True])), float(np.median(cpu[False]))
    return dict(case=name, cpu_proof=a, cpu_without=b, ratio=a / b, slabs_proven=counts[0], slabs_unproven=counts[1])


CASES: dict[str, Callable[[], Callable[..., kinbox.Result]]] = {
    "ur5-zero": lambda: _ur5(np.zeros(6)),
    "ur5-wrist": lambda: _ur5([0.3, -1.2, 1.5, -0.8, 0.0, 0.4]),
    "ur5-home": lambda: _ur5([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0]),
    "ur5-elbow": lambda: _ur5([0.3, -1.2, 0.0, -0.8, 1.2, 0.4]),
    "tangent-3-3": _tangent_3_3,
    "panda-1": lambda: _panda(1),
    "panda-2": lambda: _panda(2),
    "panda-3": lambda: _panda(3),
    "four-bar": lambda: lambda **kw: kinbox.solve("four-bar", **kw),
    "bricard": lambda: lambda **kw: kinbox.solve("bricard", **kw),
    "griffis-duffy 1/4": lambda: lambda **kw: kinbox.solve("griffis-duffy", sigma=0.25, **kw),
}


def run(name: str, curve_boxes: bool, time_limit: float) -> str:
    solve = CASES[name]()
    t = time.process_time()
    res = solve(curve_boxes=curve_boxes, time_limit=time_limit)
    cpu = time.process_time() - t
    st = res.stats
    curves = [c for c in res.components if c.dimension >= 1]
    sing = [s for s in res.solutions if s.singular]
    mult = ",".join("inf" if s.multiplicity is None else str(s.multiplicity) for s in sing) or "-"
    worst = max([cv.residual for cv in res.curves.values()] + [s.residual for s in res.solutions], default=0.0)
    return (
        f"| {name} | {'on' if curve_boxes else 'off'} | {'yes' if res.complete else 'NO'} | {cpu:.2f} | "
        f"{st['boxes']} | {len(res.raw.boxes)} | {sum(s.certified for s in res.solutions)} | {len(sing)} ({mult}) | "
        f"{len(curves)} | {len(res.undecided)} | {worst:.1e} |"
    )


def _gap(P: list[np.ndarray], Q: list[np.ndarray]) -> float:
    """Largest distance (any joint) from a point of ``P`` to the nearest point of ``Q``."""
    if not P or not Q:
        return float("nan") if P or Q else 0.0
    allq = np.vstack(Q)
    return float(max(np.abs(allq - p).max(axis=1).min() for p in P))


def sweep_row(name: str, time_limit: float) -> dict:
    """One pose by the sweep (the default for seven joints) and by the branch and prune."""
    solve = CASES[name]()
    t = time.process_time()
    res = solve()
    cpu = time.process_time() - t
    t = time.process_time()
    bp = solve(closed_form=False, time_limit=time_limit)
    bp_cpu = time.process_time() - t

    def points(r: kinbox.Result) -> list[np.ndarray]:
        return [q for cv in r.curves.values() for b in cv.branches for q in b]

    st = res.stats
    return dict(
        case=name,
        method=st.get("method", "branch-and-prune"),
        sweep_cpu=cpu,
        bp_cpu=bp_cpu,
        curves=len(res.curves),
        bp_curves=len(bp.curves),
        complete=res.complete,
        bp_complete=bp.complete,
        gap_to_bp=_gap(points(res), points(bp)),
        gap_from_bp=_gap(points(bp), points(res)),
        certified_points=int(st.get("certified_points", 0)),
        points=int(st.get("curve_points", len(points(res)))),
        residual=max([cv.residual for cv in res.curves.values()] + [s.residual for s in res.solutions], default=0.0),
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--time-limit", type=float, default=300.0)
    ap.add_argument("--off", action="store_true", help="also run each case without curve boxes")
    ap.add_argument("--sweep", action="store_true", help="seven-joint cases: the sweep against the branch and prune")
    ap.add_argument("--record", action="store_true", help="with --sweep: record the rows on docs/benchmarks.md")
    ap.add_argument("--anchors", action="store_true", help="seven-joint cases: the sweep with and without the exact goal's anchors")
    ap.add_argument("--slab-proof", action="store_true", help="seven-joint cases: the sweep with and without the slabs' proof")
    a = ap.parse_args(argv)
    from kinbox.search import bernstein, certify, propagate, relaxation

    for load in (propagate.load_kernel, certify.load_kernel, relaxation.load_kernel, bernstein.load_kernel):
        load()
    print(
        f"Machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}; "
        f"time limit {a.time_limit:g} s (wall) per solve",
        file=sys.stderr,
    )
    if a.slab_proof:
        import json

        names = a.cases.split(",") if a.cases != ",".join(CASES) else ["panda-1", "panda-3", "shoulder7-3", "shoulder7-5"]
        prows = []
        for name in names:
            prows.append(slab_proof_row(name))
            print(json.dumps(prows[-1]), flush=True)
        print(f"CPU with the slabs' proof over without, median {float(np.median([r['ratio'] for r in prows])):.2f}", file=sys.stderr)
        return
    if a.anchors:
        import json

        names = (
            a.cases.split(",")
            if a.cases != ",".join(CASES)
            else [f"shoulder7-{k}" for k in (3, 5, 7, 8, 9)] + ["panda-1", "panda-2", "panda-3"]
        )
        rows = []
        for name in names:
            rows.append(anchors_row(name))
            print(json.dumps(rows[-1]), flush=True)
        for fam in sorted({r["case"].rsplit("-", 1)[0] for r in rows}):
            rs = [r["ratio"] for r in rows if r["case"].startswith(fam + "-")]
            print(f"{fam}: CPU with anchors over without, median {float(np.median(rs)):.2f} on {len(rs)} poses", file=sys.stderr)
        return
    if a.sweep:
        import json

        from benchmarks import report

        calibration = report.calibrate()
        _panda(0)()  # the sweep's kernels loaded (compiled at the first run after a change) before any timing
        cases = [c for c in a.cases.split(",") if c.startswith("panda")] if a.cases == ",".join(CASES) else a.cases.split(",")
        rows = []
        for name in cases:
            rows.append(sweep_row(name, a.time_limit))
            print(json.dumps(rows[-1]), flush=True)
        if a.record:
            report.record("selfmotion", rows, calibration=calibration, mode=f"time limit {a.time_limit:g} s (wall) per branch and prune")
        return
    print(
        "| case | curve boxes | complete | CPU s | boxes | solution boxes | certified | singular (multiplicity) "
        "| curves | undecided | max FK residual |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name in a.cases.split(","):
        for on in (True, False) if a.off else (True,):
            print(run(name, on, a.time_limit), flush=True)


if __name__ == "__main__":
    main()
