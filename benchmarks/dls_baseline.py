#!/usr/bin/env python
"""Baseline: what users do today to get "all" IK solutions -- Pinocchio damped least squares (CLIK)
from random restarts, collecting the distinct solutions.

The iteration is the one of Pinocchio's inverse-kinematics example, written for a frame:

    iMd  = oMf.actInv(goal)                      # current frame -> goal
    err  = log6(iMd)                             # 6-vector, LOCAL frame
    J    = -Jlog6(iMd.inverse()) @ J_frame_local # d err / d q
    dq   = -J^T (J J^T + lambda I)^-1 err        # damped least squares
    dq  *= min(1, max_step / |dq|)               # step limitation
    q    = integrate(q, dq)

with a constant ``lambda`` (``damping``, default 1e-6; the usual range is 1e-6..1e-3) or, with
``damping='adaptive'``, Levenberg-Marquardt-like ``lambda = clip(|err|^2, 1e-12, 1e-3)``.  A
constant ``lambda`` stalls (|err| ~ 1e-8) near singular poses where sigma_min(J)^2 << lambda, e.g.
near the UR shoulder singularity; 'adaptive' does not.  Converged when ``|err| < tol``.  Restarts are drawn uniformly
inside the joint limits (``[-pi, pi]`` where a revolute joint is unlimited).

Distinct solutions: two converged configurations are the same when their ``difference`` is
below ``dedup_tol`` after identifying ``q ~ q + 2 pi`` on the "periodic" joints, chosen by
``periodic``: ``'auto'`` (default: unbounded revolute joints -- nq = 2 -- and revolute joints whose
limit range is >= 2 pi, e.g. all six UR joints), ``'none'``, or an explicit list of joint names.
Periodic joints are reported wrapped to (-pi, pi] (shifted back inside the limits if needed).
Converged configurations outside the joint limits (after wrapping) are counted but not kept.

Python API
----------
``dls_solutions(model, frame_name, goal, restarts, seed, tol=1e-10, max_iter=200, ...) -> (solutions, stats)``
``restarts_until_complete(model, frame_name, goal, reference, max_restarts=..., seed=...) -> dict``
``coverage_from_stats(solutions, stats, reference) -> dict``  (post hoc, from a finished run)

CLI
---
    python benchmarks/dls_baseline.py ur5 --restarts 200
    python benchmarks/dls_baseline.py ur5 --poses 20 --max-restarts 2000   # restarts to find all (vs oracle)
    python benchmarks/dls_baseline.py ur5 --poses 20 --max-restarts 2000 --oracle-count 8  # 8-solution poses

For ``ur3``/``ur5``/``ur10`` the CLI compares with the closed-form oracle
``tests/support/oracles/ur_ik.py`` (loads the genuine UR3: ``example_robot_data.load('ur3')`` is a UR5).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np
import pinocchio as pin

__all__ = [
    "dls_solve",
    "dls_solutions",
    "restarts_until_complete",
    "coverage_from_stats",
    "periodic_mask",
    "random_configuration",
    "same_solution",
    "load_robot",
]

_REVOLUTE = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned"}
_REVOLUTE_UNBOUNDED = {
    "JointModelRUBX",
    "JointModelRUBY",
    "JointModelRUBZ",
    "JointModelRevoluteUnboundedUnaligned",
}


# ----------------------------------------------------------------------------------- helpers


def periodic_mask(model: pin.Model, periodic="auto") -> np.ndarray:
    """Boolean mask over ``q`` (nq) of the 1-nq revolute coordinates identified modulo 2 pi.
    (Unbounded revolute joints, nq = 2, are periodic by construction: their (cos, sin) is compared.)"""
    mask = np.zeros(model.nq, dtype=bool)
    for j in range(1, model.njoints):
        jm = model.joints[j]
        name = jm.shortname()
        if name not in _REVOLUTE:
            continue
        i = jm.idx_q
        if periodic == "none":
            continue
        if periodic == "auto":
            lo, hi = model.lowerPositionLimit[i], model.upperPositionLimit[i]
            if not (np.isfinite(lo) and np.isfinite(hi)) or hi - lo >= 2 * math.pi - 1e-9:
                mask[i] = True
        elif model.names[j] in periodic:
            mask[i] = True
    return mask


def _angle_diff(a, b):
    return np.angle(np.exp(1j * (np.asarray(a, float) - np.asarray(b, float))))


def same_solution(model, q1, q2, mask, tol=1e-6) -> bool:
    """``q1 == q2`` up to ``tol`` (inf-norm), modulo 2 pi on ``mask``."""
    d = np.asarray(q1, float) - np.asarray(q2, float)
    d[mask] = _angle_diff(q1[mask], q2[mask])
    return bool(np.abs(d).max() <= tol)


def _normalize(model, q, mask, lower, upper):
    """Wrap periodic coordinates to (-pi, pi], shifting by 2 pi back inside the limits if needed;
    returns (q, within_limits)."""
    q = q.copy()
    q[mask] = math.pi - np.mod(math.pi - q[mask], 2 * math.pi)
    for i in np.flatnonzero(mask):
        if q[i] < lower[i] - 1e-9 and q[i] + 2 * math.pi <= upper[i] + 1e-9:
            q[i] += 2 * math.pi
        elif q[i] > upper[i] + 1e-9 and q[i] - 2 * math.pi >= lower[i] - 1e-9:
            q[i] -= 2 * math.pi
    bounded = _bounded_coords(model)
    inside = bool(np.all(q[bounded] >= lower[bounded] - 1e-9) and np.all(q[bounded] <= upper[bounded] + 1e-9))
    return q, inside


def _bounded_coords(model) -> np.ndarray:
    """Coordinates of 1-nq joints (revolute / prismatic) with finite limits."""
    m = np.zeros(model.nq, dtype=bool)
    for j in range(1, model.njoints):
        jm = model.joints[j]
        if jm.nq == 1:
            i = jm.idx_q
            if np.isfinite(model.lowerPositionLimit[i]) and np.isfinite(model.upperPositionLimit[i]):
                m[i] = True
    return m


def random_configuration(model: pin.Model, rng: np.random.Generator) -> np.ndarray:
    """Uniform inside the joint limits (angles in [-pi, pi] where unlimited; unit (cos, sin) for
    unbounded revolute joints; pin.randomConfiguration for other joint types)."""
    q = pin.neutral(model)
    for j in range(1, model.njoints):
        jm = model.joints[j]
        i, name = jm.idx_q, jm.shortname()
        if jm.nq == 1:
            lo, hi = model.lowerPositionLimit[i], model.upperPositionLimit[i]
            if not np.isfinite(lo) or not np.isfinite(hi):
                lo, hi = (-math.pi, math.pi) if name in _REVOLUTE else (-1.0, 1.0)
            q[i] = rng.uniform(lo, hi)
        elif name in _REVOLUTE_UNBOUNDED:
            a = rng.uniform(-math.pi, math.pi)
            q[i : i + 2] = (math.cos(a), math.sin(a))
        else:
            pin.seed(int(rng.integers(2**31 - 1)))
            qr = pin.randomConfiguration(model)
            q[i : i + jm.nq] = qr[i : i + jm.nq]
    return q


# ----------------------------------------------------------------------------------- solver


def dls_solve(
    model: pin.Model,
    data: pin.Data,
    frame_id: int,
    goal: pin.SE3,
    q0: np.ndarray,
    tol: float = 1e-10,
    max_iter: int = 200,
    damping=1e-6,
    max_step: float = 0.5,
):
    """One CLIK run from ``q0``.  Returns (q, |err|, iterations, converged)."""
    q = np.array(q0, dtype=float)
    adaptive = damping == "adaptive"
    lam = None if adaptive else float(damping)
    err_norm = math.inf
    for it in range(max_iter + 1):
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacement(model, data, frame_id)
        iMd = data.oMf[frame_id].actInv(goal)
        err = pin.log6(iMd).vector
        err_norm = float(np.linalg.norm(err))
        if err_norm < tol:
            return q, err_norm, it, True
        if it == max_iter:
            break
        J = pin.computeFrameJacobian(model, data, q, frame_id, pin.LOCAL)
        J = -pin.Jlog6(iMd.inverse()) @ J
        lk = min(max(err_norm**2, 1e-12), 1e-3) if adaptive else lam
        dq = -J.T @ np.linalg.solve(J @ J.T + lk * np.eye(6), err)
        n = float(np.linalg.norm(dq))
        if n > max_step:
            dq *= max_step / n
        q = pin.integrate(model, q, dq)
    return q, err_norm, max_iter, False


def _match(model, q, sols, mask, dedup_tol):
    for k, s in enumerate(sols):
        if same_solution(model, q, s, mask, dedup_tol):
            return k
    return -1


def dls_solutions(
    model: pin.Model,
    frame_name: str,
    goal: pin.SE3,
    restarts: int,
    seed: int,
    tol: float = 1e-10,
    max_iter: int = 200,
    damping=1e-6,
    max_step: float = 0.5,
    periodic="auto",
    dedup_tol: float = 1e-6,
    reference=None,
):
    """Random-restart DLS.  Returns ``(solutions, stats)``:

    * ``solutions``: list of distinct converged configurations (inside the limits, periodic joints
      wrapped), in order of discovery;
    * ``stats`` (dict of numpy arrays / scalars): ``time`` (seconds per restart), ``iters``,
      ``converged`` (bool), ``residual`` (final |log6|), ``hit`` (index into ``solutions`` of the
      restart's solution, -1 if not converged or out of limits), ``out_of_limits`` (count),
      ``first_found`` (restart index at which each solution was first found),
      ``total_time``, ``restarts``.

    If ``reference`` (list of configurations) is given, stop as soon as every reference
    configuration has been found (see :func:`restarts_until_complete`).
    """
    data = model.createData()
    fid = model.getFrameId(frame_name)
    if fid >= len(model.frames):
        raise ValueError(f"no frame named {frame_name!r}")
    mask = periodic_mask(model, periodic)
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    rng = np.random.default_rng(seed)
    sols: list[np.ndarray] = []
    times, iters, conv, res, hit, first = [], [], [], [], [], []
    out_of_limits = 0
    ref_left = None if reference is None else list(range(len(reference)))
    for r in range(restarts):
        q0 = random_configuration(model, rng)
        t0 = time.perf_counter()
        q, e, it, ok = dls_solve(model, data, fid, goal, q0, tol, max_iter, damping, max_step)
        k = -1
        if ok:
            q, inside = _normalize(model, q, mask, lower, upper)
            if inside:
                k = _match(model, q, sols, mask, dedup_tol)
                if k < 0:
                    sols.append(q)
                    first.append(r)
                    k = len(sols) - 1
            else:
                out_of_limits += 1
        times.append(time.perf_counter() - t0)
        iters.append(it)
        conv.append(ok)
        res.append(e)
        hit.append(k)
        if ref_left is not None and k >= 0:
            ref_left = [i for i in ref_left if not same_solution(model, reference[i], sols[k], mask, dedup_tol)]
            if not ref_left:
                break
    stats = {
        "time": np.array(times),
        "iters": np.array(iters),
        "converged": np.array(conv, dtype=bool),
        "residual": np.array(res),
        "hit": np.array(hit),
        "first_found": np.array(first),
        "out_of_limits": out_of_limits,
        "total_time": float(np.sum(times)),
        "restarts": len(times),
    }
    return sols, stats


def coverage_from_stats(model, solutions, stats, reference, periodic="auto", dedup_tol=1e-6) -> dict:
    """Post hoc: how many restarts / seconds until every configuration of ``reference`` was found
    (``restarts``/``seconds`` are None if never).  Also lists ``missing`` reference indices and
    ``extra`` solutions (found but not in ``reference`` -- a sign that the reference is incomplete)."""
    mask = periodic_mask(model, periodic)
    first_found = stats["first_found"]
    cum = np.cumsum(stats["time"])
    when = []
    missing = []
    for i, qr in enumerate(reference):
        k = _match(model, np.asarray(qr, float), solutions, mask, dedup_tol)
        if k < 0:
            missing.append(i)
        else:
            when.append(int(first_found[k]))
    extra = [k for k, s in enumerate(solutions) if _match(model, s, [np.asarray(r, float) for r in reference], mask, dedup_tol) < 0]
    if missing or not reference:
        n, sec = (None, None) if missing else (0, 0.0)
    else:
        n = max(when) + 1
        sec = float(cum[n - 1])
    return {"restarts": n, "seconds": sec, "found": len(reference) - len(missing), "missing": missing, "extra": extra}


def restarts_until_complete(
    model: pin.Model,
    frame_name: str,
    goal: pin.SE3,
    reference,
    max_restarts: int = 5000,
    seed: int = 0,
    **kw,
) -> dict:
    """Run restarts until every configuration of ``reference`` has been found (or ``max_restarts``).
    Returns ``{'restarts': n or None, 'seconds': s or None, 'found', 'missing', 'extra', 'stats',
    'solutions'}`` -- n is the number of restarts (1-based) at which the set became complete."""
    sols, stats = dls_solutions(model, frame_name, goal, max_restarts, seed, reference=reference, **kw)
    out = coverage_from_stats(model, sols, stats, reference, kw.get("periodic", "auto"), kw.get("dedup_tol", 1e-6))
    out.update(stats=stats, solutions=sols)
    return out


# ----------------------------------------------------------------------------------- CLI


def load_robot(name: str) -> pin.Model:
    """example-robot-data model; 'ur3' is the genuine UR3 (erd.load('ur3') returns a UR5)."""
    import example_robot_data as erd
    from example_robot_data.robots_loader import UR3Loader

    if name == "ur3":
        return UR3Loader().robot.model
    return erd.load(name).model


def _default_frame(model) -> str:
    names = [f.name for f in model.frames]
    for cand in ("tool0", "ee_link"):
        if cand in names:
            return cand
    return names[-1]


def _secs(t) -> str:
    return "never" if t is None else f"{t:.3f} s"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("robot", help="example-robot-data name, e.g. ur5")
    ap.add_argument("--frame", default=None, help="end-effector frame (default tool0)")
    ap.add_argument("--restarts", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0, help="seed of the restarts")
    ap.add_argument("--pose-seed", type=int, default=1, help="seed of the random goal pose(s)")
    ap.add_argument("--poses", type=int, default=1, help="number of random goal poses")
    ap.add_argument("--tol", type=float, default=1e-10)
    ap.add_argument("--max-iter", type=int, default=200)
    ap.add_argument("--damping", default="1e-6", help="lambda (float) or 'adaptive'")
    ap.add_argument(
        "--max-restarts",
        type=int,
        default=None,
        help="UR only: instead of a fixed number, restart until the oracle's set is found (cap)",
    )
    ap.add_argument(
        "--oracle-count",
        type=int,
        default=None,
        help="UR only: draw goal poses until the oracle gives exactly this many solutions (e.g. 8)",
    )
    a = ap.parse_args(argv)

    model = load_robot(a.robot)
    frame = a.frame or _default_frame(model)
    fid = model.getFrameId(frame)
    data = model.createData()
    oracle = None
    if a.robot in ("ur3", "ur5", "ur10"):
        sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
        from tests.support.oracles.ur_ik import ur_ik

        oracle = lambda T: ur_ik(a.robot, T, frame=frame)  # noqa: E731
    prng = np.random.default_rng(a.pose_seed)
    kw = dict(tol=a.tol, max_iter=a.max_iter, damping=a.damping)
    rows = []
    for p in range(a.poses):
        while True:
            qg = random_configuration(model, prng)
            pin.forwardKinematics(model, data, qg)
            pin.updateFramePlacements(model, data)
            goal = data.oMf[fid].copy()
            ref = oracle(goal.homogeneous) if oracle else None
            if a.oracle_count is None or ref is None or len(ref) == a.oracle_count:
                break
        if a.max_restarts and ref is not None:
            out = restarts_until_complete(model, frame, goal, ref, a.max_restarts, a.seed + p, **kw)
            st = out["stats"]
            rows.append(out)
            print(
                f"pose {p}: oracle {len(ref)} solutions; DLS found {out['found']} "
                f"after {st['restarts']} restarts, {st['total_time']:.3f} s; complete at restart "
                f"{out['restarts']} ({_secs(out['seconds'])});"
                f" extra {len(out['extra'])}; converged {st['converged'].mean():.0%}"
            )
        else:
            sols, st = dls_solutions(model, frame, goal, a.restarts, a.seed + p, **kw)
            line = (
                f"pose {p}: {len(sols)} distinct solutions from {st['restarts']} restarts in "
                f"{st['total_time']:.3f} s (converged {st['converged'].mean():.0%}, "
                f"median {np.median(st['time']) * 1e3:.2f} ms/restart, out of limits {st['out_of_limits']})"
            )
            if ref is not None:
                cov = coverage_from_stats(model, sols, st, ref)
                rows.append(cov)
                line += (
                    f"; oracle {len(ref)}: complete at restart {cov['restarts']}"
                    f" ({_secs(cov['seconds'])}),"
                    f" missing {len(cov['missing'])}, extra {len(cov['extra'])}"
                )
            print(line)
    if rows and a.poses > 1:
        n = [r["restarts"] for r in rows]
        ok = [x for x in n if x is not None]
        secs = [r["seconds"] for r in rows if r["seconds"] is not None]
        print(
            f"complete for {len(ok)}/{len(n)} poses; restarts to complete: median "
            f"{np.median(ok) if ok else float('nan')}, max {max(ok) if ok else None}; seconds: median "
            f"{np.median(secs) if secs else float('nan'):.3f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
