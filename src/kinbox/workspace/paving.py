"""A workspace paving and the loop that makes it: set inversion in the manner of Jaulin and
Walter (SIVIA) over boxes of position space, each decided by a *decider* -- an object with
``decide(lo, hi, resolution) -> (verdict, witness, stats)`` and ``nq``, the length of its
witnesses (:class:`~kinbox.workspace.arm.Reach` for serial arms,
:class:`~kinbox.workspace.platform.PlatformReach` for parallel platforms).

Each box is decided by a computation that depends on that box alone, and a box is split by a
rule that depends on the box alone, so the paving is the same serial, over local processes
(``workers``) or on a Dask cluster (``executor``): the top of the tree is decided wave by wave,
then each box of the last wave paves its whole subtree as one task (few round trips on a
cluster), and the leaves are kept in the order of the waves and then of the tasks.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..errors import InputError

#: box verdicts, as stored in :attr:`Paving.verdict`
OUTSIDE, INSIDE, BOUNDARY = 0, 1, 2
VERDICTS = ("outside", "inside", "boundary")
#: at most this many boxes (decided and pending) in one paving
MAX_BOXES = 2_000_000
#: the top of a paving is decided wave by wave until a wave holds this many boxes; each of them
#: then paves its whole subtree as one task (a fixed number, not one per worker: a budget then
#: stops a paving at the same box however it is computed)
SUBTREE_TASKS = 256
#: the description fields a paving file keeps beside its boxes
META_KEYS = ("robot", "frame", "base", "orientation", "cone", "lock", "joints", "legs", "angle")


class Decider(Protocol):
    """What :func:`pave` asks of a workspace problem."""

    nq: int

    def decide(self, lo: np.ndarray, hi: np.ndarray, resolution: float) -> tuple[int, np.ndarray | None, dict]: ...


@dataclass
class Paving:
    """A paving of a position region: ``lo``/``hi`` (N x d boxes, d = 3 in space, 2 in the plane), ``verdict`` (N,
    :data:`OUTSIDE`, :data:`INSIDE` or :data:`BOUNDARY`), ``witness`` (N x nq: a configuration
    reaching the box's centre for inside boxes, NaN elsewhere). ``complete`` is False when a
    budget stopped the paving: then ``pending`` boxes were not decided."""

    lo: np.ndarray
    hi: np.ndarray
    verdict: np.ndarray
    witness: np.ndarray
    complete: bool
    message: str
    region: np.ndarray
    resolution: float
    meta: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)
    pending: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 3)))

    @property
    def dims(self) -> int:
        """Coordinates of a position: 3 (x y z), or 2 (x y) for a planar mechanism."""
        return int(self.region.shape[1])

    def volumes(self) -> dict[str, float]:
        """Volume of each verdict's boxes (cubic metres; square metres for a planar paving), and of
        the undecided ones."""
        vol = np.prod(self.hi - self.lo, axis=1) if len(self.lo) else np.zeros(0)
        out = {name: float(vol[self.verdict == k].sum()) for k, name in enumerate(VERDICTS)}
        out["pending"] = float(np.prod(self.pending[:, 1] - self.pending[:, 0], axis=1).sum()) if len(self.pending) else 0.0
        return out

    def counts(self) -> dict[str, int]:
        return {name: int(np.sum(self.verdict == k)) for k, name in enumerate(VERDICTS)}

    def as_dict(self) -> dict[str, Any]:
        return {
            "kind": "workspace",
            "complete": self.complete,
            "message": self.message,
            "region": {"lo": self.region[0].tolist(), "hi": self.region[1].tolist()},
            "resolution": self.resolution,
            **self.meta,
            "volumes": self.volumes(),
            "counts": self.counts(),
            "stats": self.stats,
            "boxes": [
                {
                    "lo": lo.tolist(),
                    "hi": hi.tolist(),
                    "verdict": VERDICTS[int(v)],
                    **({"witness": w.tolist()} if int(v) == INSIDE else {}),
                }
                for lo, hi, v, w in zip(self.lo, self.hi, self.verdict, self.witness)
            ],
        }

    def to_json(self) -> str:
        d = self.as_dict()
        if len(self.pending):  # a paving stopped by its budget keeps what is left to decide
            d["pending"] = self.pending.tolist()
        return json.dumps(d)

    def save(self, path: str) -> None:
        """Write the paving: ``.npz`` (arrays, and the rest as JSON in ``meta``) or JSON."""
        if str(path).endswith(".npz"):
            head = {k: v for k, v in self.as_dict().items() if k != "boxes"}
            with open(path, "wb") as f:
                np.savez_compressed(
                    f,
                    lo=self.lo,
                    hi=self.hi,
                    verdict=self.verdict.astype(np.int8),
                    witness=self.witness,
                    pending=self.pending,
                    meta=np.array(json.dumps(head)),
                )
        else:
            with open(path, "w", encoding="utf-8") as f:
                f.write(self.to_json())

    @classmethod
    def load(cls, path: str) -> Paving:
        """A paving written by :meth:`save` (either format); a file that is not one is refused
        with one line (:class:`~kinbox.errors.InputError`)."""
        import zipfile

        try:
            return cls._load(path)
        except InputError:
            raise
        except (OSError, ValueError, KeyError, TypeError, IndexError, zipfile.BadZipFile) as e:
            raise InputError(f"{path}: not a workspace paving written by kinbox reach ({type(e).__name__})") from None

    @classmethod
    def _load(cls, path: str) -> Paving:
        if str(path).endswith(".npz"):
            with np.load(path, allow_pickle=False) as z:
                head = json.loads(str(z["meta"]))
                lo, hi, verdict, witness, pending = (np.array(z[k]) for k in ("lo", "hi", "verdict", "witness", "pending"))
        else:
            with open(path, encoding="utf-8") as f:
                head = json.load(f)
            boxes = head.pop("boxes")
            d = len(head["region"]["lo"])
            lo = np.array([b["lo"] for b in boxes], dtype=float).reshape(-1, d)
            hi = np.array([b["hi"] for b in boxes], dtype=float).reshape(-1, d)
            verdict = np.array([VERDICTS.index(b["verdict"]) for b in boxes], dtype=np.int8)
            nq = max((len(b["witness"]) for b in boxes if "witness" in b), default=0)
            witness = np.full((len(boxes), nq), np.nan)
            for i, b in enumerate(boxes):
                if "witness" in b:
                    witness[i] = b["witness"]
            pending = np.array(head.pop("pending", []), dtype=float).reshape(-1, 2, d)
        if head.get("kind") != "workspace":
            raise InputError(f"{path}: not a workspace paving (kind {head.get('kind')!r})")
        region = np.array([head["region"]["lo"], head["region"]["hi"]], dtype=float)
        meta = {k: head[k] for k in META_KEYS if k in head}
        return cls(
            lo,
            hi,
            verdict,
            witness,
            bool(head["complete"]),
            head["message"],
            region,
            float(head["resolution"]),
            meta,
            head["stats"],
            pending,
        )

    def table(self) -> str:
        v, c = self.volumes(), self.counts()
        total = float(np.prod(self.region[1] - self.region[0]))
        unit = "m^3" if self.dims == 3 else "m^2"
        lines = [
            f"workspace of {self.meta.get('robot')} {self.meta.get('frame', 'platform')}: "
            f"{'complete' if self.complete else 'INCOMPLETE: ' + self.message}",
            f"  region {self.region[0].tolist()} .. {self.region[1].tolist()} ({total:.4g} {unit}), resolution {self.resolution:g} m",
        ]
        for name in VERDICTS:
            share = v[name] / total if total > 0 else 0.0
            lines.append(f"  {name:9s} {c[name]:8d} boxes  {v[name]:10.5f} {unit}  ({100 * share:5.1f} %)")
        if v["pending"]:
            lines.append(f"  {'pending':9s} {len(self.pending):8d} boxes  {v['pending']:10.5f} {unit}")
        st = self.stats
        lines.append(f"  {st.get('searches', 0)} searches, {st.get('search_boxes', 0)} search boxes, {st.get('seconds', 0.0):.2f} s")
        return "\n".join(lines)


def check_region(region, dims: int) -> np.ndarray:
    """``region`` (``xmin ymin [zmin] xmax ymax [zmax]``) as a 2 x ``dims`` array, or a one-line error."""
    reg = np.asarray(region, dtype=float).reshape(-1)
    names = " ".join([f"{a}MIN" for a in "XYZ"[:dims]] + [f"{a}MAX" for a in "XYZ"[:dims]])
    if reg.shape != (2 * dims,) or not np.all(np.isfinite(reg)) or np.any(reg[dims:] <= reg[:dims]):
        raise InputError(f"the region takes {2 * dims} finite numbers {names} with each max above its min")
    return reg.reshape(2, dims)


def check_same_problem(old: Paving, region: np.ndarray, resolution: float, meta: dict, nq: int) -> None:
    """A paving to resume must be of the same problem: region, resolution, description, witnesses."""
    same = (
        old.region.shape == region.shape
        and np.array_equal(old.region, region)
        and old.resolution == resolution
        and old.witness.shape[1] in (0, nq)
        and all(_canon(old.meta.get(k)) == _canon(meta.get(k)) for k in META_KEYS if k in meta or k in old.meta)
    )
    if not same:
        raise InputError("the paving to resume is of another problem (robot, frame, orientation, legs, region or resolution differ)")


def _canon(v) -> str:
    return json.dumps(v, sort_keys=True, default=lambda o: np.asarray(o).tolist())


def check_resolution(resolution) -> float:
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
        raise InputError(f"the resolution must be a positive number of metres, not {resolution!r}")
    return float(resolution)


def _subtree_task(task) -> dict:
    lo, hi, resolution, budget = task
    assert _WORKER is not None
    return pave_subtree(_WORKER, lo, hi, resolution, budget)


_WORKER: Decider | None = None


def _set_worker(r: Decider) -> None:
    global _WORKER
    _WORKER = r


def _split(lo: np.ndarray, hi: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """The two halves of a box across its widest side (the first such side), lower half first."""
    i = int(np.argmax(hi - lo))
    mid = 0.5 * (lo[i] + hi[i])
    a_hi, b_lo = hi.copy(), lo.copy()
    a_hi[i] = mid
    b_lo[i] = mid
    return (lo, a_hi), (b_lo, hi)


def pave_subtree(decider: Decider, lo: np.ndarray, hi: np.ndarray, resolution: float, budget: int) -> dict:
    """Pave one box down to the resolution, depth first (the lower half of each split first):
    its leaves in that order (``lo``, ``hi``, ``verdict``, ``witness``), the boxes left when the
    decisions made plus the boxes waiting reach ``budget`` (``pending``, in the order they would
    have been decided), the decider's stats summed (with ``decided``), and the CPU seconds it
    took in this process (``cpu``, ``pid``: for the measure of balance, not for any decision).
    Every leaf is what the decider says of that box alone, and the split rule depends on the box
    alone: the leaves are those the breadth-first loop of :func:`pave` would reach from this
    box, whoever computes them (``tests/workspace/test_dask.py``)."""
    import os

    cpu0, thread0 = time.process_time(), time.thread_time()
    nq = decider.nq
    d = len(lo)
    stack = [(np.asarray(lo, dtype=float), np.asarray(hi, dtype=float))]
    out_lo: list = []
    out_hi: list = []
    out_v: list = []
    out_w: list = []
    stats: dict[str, float] = {"decided": 0}
    while stack:
        if stats["decided"] + len(stack) > budget:
            break
        blo, bhi = stack.pop()
        v, w, st = decider.decide(blo, bhi, resolution)
        for k, x in st.items():
            stats[k] = stats.get(k, 0) + x
        stats["decided"] += 1
        if v < 0:
            a, b = _split(blo, bhi)
            stack += [b, a]
            continue
        out_lo.append(blo)
        out_hi.append(bhi)
        out_v.append(v)
        out_w.append(w if w is not None else np.full(nq, np.nan))
    return {
        "lo": np.array(out_lo, dtype=float).reshape(-1, d),
        "hi": np.array(out_hi, dtype=float).reshape(-1, d),
        "verdict": np.array(out_v, dtype=np.int8),
        "witness": np.array(out_w, dtype=float).reshape(len(out_v), nq),
        "pending": np.array([[a, b] for a, b in reversed(stack)], dtype=float).reshape(-1, 2, d),
        "stats": stats,
        "cpu": time.process_time() - cpu0,
        "thread_cpu": time.thread_time() - thread0,
        "pid": os.getpid(),
    }


def _map_subtrees(reach_: Decider, tasks: list, workers: int | None, remote) -> Iterator[dict]:
    """:func:`pave_subtree` of each task, yielded in the order of ``tasks``: here, over local
    processes (one task at a time to each) or on a Dask cluster (``remote``, a
    :class:`~kinbox.workspace.remote.DaskPaving`: chunks of subtrees as tasks)."""
    if remote is not None:
        yield from remote.subtrees(pave_subtree, tasks)
        return
    if workers is None or len(tasks) < 2:
        for lo, hi, res, budget in tasks:
            yield pave_subtree(reach_, lo, hi, res, budget)
        return
    from ..search.parallel import imap_tasks

    yield from imap_tasks(_subtree_task, tasks, workers, initializer=_set_worker, initargs=(reach_,), batch=1)


def pave_top(decider: Decider, wave: list, resolution: float, max_boxes: int, cut: int, report: Callable | None = None) -> dict:
    """Decide ``wave`` breadth first in this process, wave by wave, until a wave holds ``cut``
    boxes (every undecided box split by :func:`_split`, the halves in the order of their
    parents): the leaves in the order they were decided (``lo``, ``hi``, ``verdict``,
    ``witness``), the last wave (``wave``, 2 x d per box: the roots of the subtree tasks), the
    decider's stats summed (with ``decided`` and ``waves``), and ``complete`` False when the
    boxes decided plus the next wave would pass ``max_boxes`` (that wave is then left
    undecided). ``report(lo, hi, verdict, wave)`` is called after each wave with the leaves so
    far. The same boxes in the same order wherever it runs (in the calling process, or as one
    task on Dask)."""
    nq = decider.nq
    d = len(wave[0][0]) if wave else 0
    out_lo: list = []
    out_hi: list = []
    out_v: list = []
    out_w: list = []
    stats: dict[str, Any] = {"waves": 0, "decided": 0}
    complete = True
    while wave and len(wave) < cut:
        if stats["decided"] + len(wave) > max_boxes:
            complete = False
            break
        nxt: list[tuple[np.ndarray, np.ndarray]] = []
        for lo, hi in wave:
            lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
            v, w, st = decider.decide(lo, hi, resolution)
            for k, x in st.items():
                stats[k] = stats.get(k, 0) + x
            stats["decided"] += 1
            if v < 0:
                nxt += list(_split(lo, hi))
                continue
            out_lo.append(lo)
            out_hi.append(hi)
            out_v.append(v)
            out_w.append(w if w is not None else np.full(nq, np.nan))
        stats["waves"] += 1
        wave = nxt
        if report is not None:
            report(out_lo, out_hi, out_v, wave)
    return {
        "lo": np.array(out_lo, dtype=float).reshape(-1, d),
        "hi": np.array(out_hi, dtype=float).reshape(-1, d),
        "verdict": np.array(out_v, dtype=np.int8),
        "witness": np.array(out_w, dtype=float).reshape(len(out_v), nq),
        "wave": np.array([[lo, hi] for lo, hi in wave], dtype=float).reshape(-1, 2, d),
        "stats": stats,
        "complete": complete,
    }


def pave(
    decider: Decider,
    region: np.ndarray,
    resolution: float,
    meta: dict,
    *,
    workers: int | None = None,
    executor=None,
    max_boxes: int = MAX_BOXES,
    progress: Callable[[dict], None] | None = None,
    resume: Paving | None = None,
) -> Paving:
    """Pave ``region`` (2 x d) with ``decider``'s verdicts down to boxes of side ``resolution``:
    every undecided box wider than the resolution is split in two across its widest side.

    The top of the tree is decided breadth first, wave by wave (:func:`pave_top`: in this
    process, or on Dask as one task), until a wave holds :data:`SUBTREE_TASKS` boxes; each box
    of that wave is then one task that paves its whole subtree (:func:`pave_subtree`), serially,
    over ``workers`` local processes or on a Dask cluster (``executor``; chunks of subtrees as
    tasks, :mod:`kinbox.workspace.remote`). The leaves are kept
    in the order of the waves, then of the tasks: the same paving, box for box and in the same
    order, however it is computed. The budget counts decided boxes (and those waiting): a task
    whose decisions would pass it is not kept, and it and the tasks after it are left pending.
    ``progress`` is called after each wave and task with the counts and volumes decided so far.
    ``resume``: a paving of the same problem stopped by its budget; its decided boxes are kept
    and its pending ones decided (``max_boxes`` counts from now)."""
    reg = np.asarray(region, dtype=float)
    side = float(np.max(reg[1] - reg[0]))
    if side / resolution > 4096:
        raise InputError(f"the resolution {resolution:g} m is too fine for a region of side {side:g} m (at most 4096 steps a side)")
    start = time.perf_counter()
    cpu0 = time.process_time()
    wave: list[tuple[np.ndarray, np.ndarray]] = [(reg[0].copy(), reg[1].copy())]
    out_lo: list = []
    out_hi: list = []
    out_v: list = []
    out_w: list = []
    stats: dict[str, Any] = {"waves": 0, "decided": 0}
    nq = decider.nq
    d = reg.shape[1]
    if resume is not None:
        check_same_problem(resume, reg, resolution, meta, nq)
        wave = [(p[0].copy(), p[1].copy()) for p in resume.pending]
        out_lo, out_hi, out_v, out_w = list(resume.lo), list(resume.hi), list(resume.verdict), list(resume.witness)
    complete, message = True, "every box decided"
    budget_hit = f"box budget of {max_boxes} reached"

    pending: list = []
    remote = None
    if executor is not None:
        from .remote import DaskPaving

        remote = DaskPaving(executor, decider)
    try:
        if wave and len(wave) < SUBTREE_TASKS:
            if remote is not None:  # one task: one round trip, not one per wave
                top = remote.top(pave_top, wave, resolution, max_boxes, SUBTREE_TASKS)
            else:
                top = pave_top(decider, wave, resolution, max_boxes, SUBTREE_TASKS, _progress_of_top(progress, out_lo, out_hi, out_v))
            for key, x in top["stats"].items():
                stats[key] = stats.get(key, 0) + x
            out_lo += list(top["lo"])
            out_hi += list(top["hi"])
            out_v += list(top["verdict"])
            out_w += list(top["witness"])
            wave = [(p[0], p[1]) for p in top["wave"]]
            if not top["complete"]:
                complete, message = False, budget_hit
            elif remote is not None and progress is not None:
                progress({"decided": len(out_v), "pending": len(wave), "volume": _decided_volume(out_lo, out_hi, out_v)})
        if wave and complete:
            # each box of the wave paves its subtree as one task (few round trips on a cluster)
            roots: list[tuple[np.ndarray, np.ndarray, float, int]] = [(lo, hi, resolution, max_boxes) for lo, hi in wave]
            stats["subtrees"] = len(roots)
            cpu_by_pid: dict[int, float] = {}
            task_cpu = task_thread_cpu = 0.0
            k = 0
            results = _map_subtrees(decider, roots, workers, remote)
            try:
                for k, res in enumerate(results):
                    st = res["stats"]
                    if stats["decided"] + st["decided"] > max_boxes:
                        complete, message = False, budget_hit
                        break
                    for key, x in st.items():
                        stats[key] = stats.get(key, 0) + x
                    out_lo += list(res["lo"])
                    out_hi += list(res["hi"])
                    out_v += list(res["verdict"])
                    out_w += list(res["witness"])
                    task_cpu += res["cpu"]
                    task_thread_cpu += res["thread_cpu"]
                    cpu_by_pid[res["pid"]] = cpu_by_pid.get(res["pid"], 0.0) + res["cpu"]
                    if len(res["pending"]):
                        pending += list(res["pending"])
                        complete, message = False, budget_hit
                        k += 1
                        break
                    wave_left = len(roots) - k - 1
                    if progress is not None:
                        progress({"decided": len(out_v), "pending": wave_left, "volume": _decided_volume(out_lo, out_hi, out_v)})
                else:
                    k = len(roots)
            finally:
                close = getattr(results, "close", None)
                if close is not None:
                    close()
            pending += [np.array([lo, hi]) for lo, hi, _, _ in roots[k:]] if not complete else []
            # the balance of the work: CPU of all tasks, and of the busiest process (measures only)
            stats["task_cpu_seconds"] = task_cpu
            stats["task_thread_cpu_seconds"] = task_thread_cpu
            stats["max_process_cpu_seconds"] = max(cpu_by_pid.values(), default=0.0)
            wave = []
    finally:
        if remote is not None:
            remote.close()
    stats["seconds"] = time.perf_counter() - start
    stats["cpu_seconds"] = time.process_time() - cpu0
    pend = np.array([[lo, hi] for lo, hi in wave] + [np.asarray(p) for p in pending], dtype=float).reshape(-1, 2, d)
    return Paving(
        np.array(out_lo, dtype=float).reshape(-1, d),
        np.array(out_hi, dtype=float).reshape(-1, d),
        np.array(out_v, dtype=np.int8),
        np.array(out_w, dtype=float).reshape(len(out_v), nq),
        complete,
        message,
        reg,
        float(resolution),
        meta,
        stats,
        pend,
    )


def _progress_of_top(progress: Callable[[dict], None] | None, out_lo: list, out_hi: list, out_v: list) -> Callable | None:
    """The report :func:`pave_top` makes after each wave, as ``progress`` of the whole paving
    (``out_*``: the leaves decided before the top, those of a paving resumed)."""
    if progress is None:
        return None

    def report(lo: list, hi: list, v: list, wave: list) -> None:
        progress({"decided": len(out_v) + len(v), "pending": len(wave), "volume": _decided_volume(out_lo + lo, out_hi + hi, out_v + v)})

    return report


def _decided_volume(lo, hi, v) -> dict[str, float]:
    if not lo:
        return dict.fromkeys(VERDICTS, 0.0)
    vol = np.prod(np.array(hi) - np.array(lo), axis=1)
    vv = np.array(v)
    return {name: float(vol[vv == k].sum()) for k, name in enumerate(VERDICTS)}
