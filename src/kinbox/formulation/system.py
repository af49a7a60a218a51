"""Polynomial systems with linear, bilinear and quadratic monomials (Porta, Ros and Thomas 2009, Sec. IV-A).

A :class:`System` holds named variables with finite interval domains and three kinds of
constraints, each a polynomial of degree at most two built with :class:`Expr`:

* **core equations** ``f(x) = 0``: the square part used for certification (Krawczyk);
* **redundant equations** ``f(x) = 0``: implied by the core equations together with the
  inequalities; they only tighten pruning and are checked at every reported solution;
* **inequalities** ``g(x) <= 0``: prune boxes and rule out spurious branches of the core.

:meth:`System.compile` produces the *expanded* form of Sec. IV-A: every monomial
``x_i x_j`` or ``x_i^2`` becomes a dummy variable, so that all constraints are linear in
``z = (x, m)``, plus the block of parabolic (``m = x_i^2``) and hyperbolic (``m = x_i x_j``)
equations. Everything the solver does starts from that :class:`Compiled` form.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..errors import FormulationError
from ..interval import TINY  # the smallest normal number
from .errfloat import keep, num

#: relative slack of every row: a search keeps every point where each row holds to within this
#: share of the system's size. The rows are computed in floating point from the model, the
#: redundant ones and the inequalities along other paths than the core's, so at a root of the
#: model they hold only up to that rounding (a few hundred ulps at most): with exact targets an
#: overdetermined system can have no root at all near a true one, and a model whose solutions
#: form a curve can keep only a few isolated roots of its rounded equations (docs/soundness.md)
SLACK = 1e-10
#: relative slack of the core rows, which define the problem: their coefficients are rounded
#: once each (a few ulps), so this is 1000 times that and no more. It keeps the points of a
#: curve that the rounded equations hold only approximately; wider, it would blunt Krawczyk's
#: contraction next to a near-singular root (an assembly mode 1e-3 from its twin was left
#: uncertified, reported inside one box with its twin)
CORE_SLACK = 1e-15

Key = tuple  # () constant, (i,) linear, (i, j) with i <= j quadratic


def _without(e: Expr, v: int) -> Expr:
    """``e`` without its term linear in ``v`` (``e - a v`` for its coefficient ``a``, exactly:
    an :class:`~kinbox.formulation.errfloat.EF` coefficient leaves no zero term with an error)."""
    return Expr({k: a for k, a in e.terms.items() if k != (v,)})


class Expr:
    """A polynomial of degree <= 2 over variable indices, with float coefficients.

    Supports ``+ - *`` with floats and other expressions; a product whose degree would
    exceed two raises :class:`~kinbox.errors.FormulationError` (the formulation must then
    introduce an auxiliary variable, see :meth:`System.materialize`).
    """

    __slots__ = ("terms",)

    def __init__(self, terms: dict | None = None):
        self.terms: dict[Key, float] = terms if terms is not None else {}

    @staticmethod
    def const(c: float) -> Expr:
        return Expr({(): num(c)} if keep(c) else {})

    @staticmethod
    def var(i: int) -> Expr:
        return Expr({(i,): 1.0})

    @property
    def degree(self) -> int:
        return max((len(k) for k, v in self.terms.items() if v != 0.0), default=0)

    @property
    def constant(self) -> float:
        return self.terms.get((), 0.0)

    def is_constant(self) -> bool:
        return self.degree == 0

    def variables(self) -> set[int]:
        return {i for k in self.terms for i in k}

    def copy(self) -> Expr:
        return Expr(dict(self.terms))

    # -- arithmetic -------------------------------------------------------------
    def _add(self, other, sign: float) -> Expr:
        t = dict(self.terms)
        if isinstance(other, Expr):
            for k, v in other.terms.items():
                t[k] = t.get(k, 0.0) + sign * v
        else:
            c = num(other)
            if keep(c):
                t[()] = t.get((), 0.0) + sign * c
        return Expr({k: v for k, v in t.items() if keep(v)})

    def __add__(self, other):
        return self._add(other, 1.0)

    __radd__ = __add__

    def __sub__(self, other):
        return self._add(other, -1.0)

    def __rsub__(self, other):
        return (-self)._add(other, 1.0)

    def __neg__(self):
        return Expr({k: -v for k, v in self.terms.items()})

    def __mul__(self, other):
        if not isinstance(other, Expr):
            c = num(other)
            if not keep(c):
                return Expr()
            return Expr({k: c * v for k, v in self.terms.items()})
        if self.degree + other.degree > 2:
            raise FormulationError("product of degree > 2; materialize a factor first")
        t: dict[Key, float] = {}
        for k1, v1 in self.terms.items():
            for k2, v2 in other.terms.items():
                k = tuple(sorted(k1 + k2))
                t[k] = t.get(k, 0.0) + v1 * v2
        return Expr({k: v for k, v in t.items() if keep(v)})

    __rmul__ = __mul__

    def __truediv__(self, c: float):
        return self * (1.0 / float(c))

    def value(self, x: np.ndarray) -> float:
        s = 0.0
        for k, v in self.terms.items():
            if len(k) == 0:
                s += v
            elif len(k) == 1:
                s += v * x[k[0]]
            else:
                s += v * x[k[0]] * x[k[1]]
        return s

    def __repr__(self) -> str:
        parts = []
        for k, v in sorted(self.terms.items(), key=lambda kv: (len(kv[0]), kv[0])):
            parts.append(f"{v:+g}" + "".join(f"*x{i}" for i in k))
        return "Expr(" + (" ".join(parts) or "0") + ")"


Scalar = Expr | float


def as_expr(a: Scalar) -> Expr:
    return a if isinstance(a, Expr) else Expr.const(float(a))


def degree(a: Scalar) -> int:
    return a.degree if isinstance(a, Expr) else 0


@dataclass
class Constraint:
    expr: Expr
    name: str
    kind: str  # "core", "redundant" or "ineq"
    #: the size of terms that cancelled when ``expr`` was derived (by substitution), if any
    cancelled: float = 0.0


def terms_key(terms: dict, sign: float) -> tuple:
    """The terms of a polynomial times ``sign``, in a canonical order (zero terms dropped)."""
    return tuple(sorted((k, sign * v) for k, v in terms.items() if v != 0.0))


def made_before(made: dict[tuple, int], e: Expr) -> tuple[int, float] | None:
    """The variable ``made`` (the :func:`terms_key` of each expression made a variable -> its
    index) holds for ``e`` or for ``-e``, and the sign, or None."""
    for sign in (1.0, -1.0):
        i = made.get(terms_key(e.terms, sign))
        if i is not None:
            return i, sign
    return None


@dataclass
class System:
    """Named variables with finite domains plus polynomial constraints of degree <= 2."""

    names: list[str] = field(default_factory=list)
    lo: list[float] = field(default_factory=list)
    hi: list[float] = field(default_factory=list)
    tags: list[str] = field(default_factory=list)
    constraints: list[Constraint] = field(default_factory=list)
    #: variables removed by :meth:`eliminate_linear`: name -> expression in the others
    eliminated: dict[str, Expr] = field(default_factory=dict)
    #: optional split ranks, one per variable: the solver splits variables of a lower rank
    #: first, until they are narrow (a block of the system that decides the others, e.g. the
    #: position of an arm with a spherical wrist); empty: no preference
    ranks: list[int] = field(default_factory=list)
    #: per core row in order, ``(merr, mgrad)``: bounds on the distance between the row as
    #: written and the row of the model as given, and on its partial derivatives, over the
    #: search domain (:attr:`Compiled.merr`; :mod:`kinbox.formulation.enclose_rows`); None: the
    #: rows are taken as exact
    core_errors: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)
    _compiled: Compiled | None = field(default=None, repr=False)
    #: a test ``exclude(lo, hi) -> bool`` of boxes that hold no wanted solution, which the search
    #: discards after their first propagation (None: none): the solutions asked for are fewer
    #: than the system's, e.g. the collision-free ones (:mod:`kinbox.search.scene_prune`)
    exclude: Any = field(default=None, repr=False)
    #: expressions :meth:`materialize` made variables of: their terms -> the variable's index
    _defined: dict[tuple, int] = field(default_factory=dict, repr=False)

    # -- building ----------------------------------------------------------------
    def add_var(self, name: str, lo: float, hi: float, tag: str = "") -> Expr:
        """Add a variable with domain ``[lo, hi]`` (finite) and return it as an expression.

        ``tag`` says what the variable is (``cos``, ``sin``, ``rot``, ``disp``, ``unit``...);
        ``aux`` marks a variable *derived* from others by a core definition equation: the
        solver does not split on it, since splitting the independent ones decides it (unless
        they are pinned and it is still wide: ``BoxProcessor._split_variable``).
        """
        lo, hi = float(lo), float(hi)
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise FormulationError(f"variable {name!r} needs a finite domain, got [{lo}, {hi}]")
        if lo > hi:
            raise FormulationError(f"variable {name!r} has an empty domain [{lo}, {hi}]")
        if name in self._index:
            raise FormulationError(f"variable {name!r} defined twice")
        self.names.append(name)
        self.lo.append(lo)
        self.hi.append(hi)
        self.tags.append(tag)
        self._index[name] = len(self.names) - 1
        self._compiled = None
        return Expr.var(len(self.names) - 1)

    def __post_init__(self):
        self._index = {n: i for i, n in enumerate(self.names)}

    def index(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise FormulationError(f"no variable named {name!r}") from None

    def var(self, name: str) -> Expr:
        return Expr.var(self.index(name))

    def _add(self, expr: Scalar, name: str, kind: str, scale: float = 0.0) -> None:
        """``scale``: the size of the terms that cancelled when ``expr`` was computed (0 if
        none): a constant left by that cancellation holds up to its rounding."""
        e = as_expr(expr)
        if e.degree > 2:
            raise FormulationError(f"constraint {name!r} has degree {e.degree} > 2")
        for v in e.terms.values():
            if not math.isfinite(v):
                raise FormulationError(f"constraint {name!r} has a non-finite coefficient")
        if e.is_constant():
            c = e.constant
            tol = SLACK * scale
            if kind == "ineq" and c <= tol:
                return  # always true
            if kind != "ineq" and abs(c) <= tol:
                return  # holds (exactly, or up to the rounding of a cancellation)
            # a constant constraint that fails: the system has no solution; keep it so the
            # solver proves emptiness at the root box
        if kind == "redundant" and self._same_equation(e):
            return  # e.g. |u| = 1 and |v| = 1 of a rotation whose u, v share their entries
        self.constraints.append(Constraint(e, name, kind, scale))
        self._compiled = None

    def _same_equation(self, e: Expr) -> bool:
        """Is ``e = 0`` (or ``-e = 0``) an equation of the system already?"""
        n = len(e.terms)
        keys = (terms_key(e.terms, 1.0), terms_key(e.terms, -1.0))
        return any(c.kind != "ineq" and len(c.expr.terms) == n and terms_key(c.expr.terms, 1.0) in keys for c in self.constraints)

    def add_eq(self, expr: Scalar, name: str = "", redundant: bool = False) -> None:
        """Add ``expr = 0``; ``redundant=True`` marks it implied by the core and inequalities
        (and leaves it out if the system has that equation already)."""
        self._add(expr, name or f"eq{len(self.constraints)}", "redundant" if redundant else "core")

    def add_ineq(self, expr: Scalar, name: str = "") -> None:
        """Add ``expr <= 0``."""
        self._add(expr, name or f"ineq{len(self.constraints)}", "ineq")

    def materialize(self, expr: Scalar, name: str, lo: float, hi: float, tag: str = "aux") -> Expr:
        """Return ``expr`` itself if it is linear, else a new variable ``v`` with ``v = expr``.

        An expression made a variable before, or its negative, gives that variable (or its
        negative) again, its domain narrowed to both bounds: a rotation about an axis the
        frame's parent shares (a planar chain) has only two distinct entries among the four
        that move, and four variables for them doubled the unknowns of the problem."""
        e = as_expr(expr)
        if e.degree <= 1:
            return e
        found = made_before(self._defined, e)
        if found is not None:
            i, sign = found
            vlo, vhi = (lo, hi) if sign > 0 else (-hi, -lo)
            self.lo[i], self.hi[i] = max(self.lo[i], vlo), min(self.hi[i], vhi)
            self._compiled = None
            return sign * Expr.var(i)
        v = self.add_var(name, lo, hi, tag)
        self.add_eq(v - e, f"def:{name}")
        self._defined[terms_key(e.terms, 1.0)] = self.n - 1
        return v

    # -- sizes -----------------------------------------------------------------
    @property
    def n(self) -> int:
        return len(self.names)

    def count(self, kind: str) -> int:
        return sum(1 for c in self.constraints if c.kind == kind)

    @property
    def is_square(self) -> bool:
        return self.count("core") == self.n

    def independent(self) -> np.ndarray:
        """Mask of the variables the solver may split on (all but ``aux``; all if none left)."""
        m = np.array([t != "aux" for t in self.tags], dtype=bool)
        return m if m.any() else np.ones(self.n, dtype=bool)

    def split_ranks(self) -> np.ndarray | None:
        """The split ranks as an array, or None when there are none (or all are equal)."""
        if len(self.ranks) != self.n or len(set(self.ranks)) < 2:
            return None
        return np.array(self.ranks, dtype=np.int64)

    def domain(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array(self.lo, dtype=float), np.array(self.hi, dtype=float)

    def search_domain(self) -> tuple[np.ndarray, np.ndarray]:
        """The domain widened by :data:`SLACK` of each bound (at least of 1): the box a search
        starts from. Bounds such as ``[-1, 1]`` on an auxiliary rotation entry hold at a root
        only up to the rounding of the constants that define it, and a root on a joint limit
        only up to the rounding of the limit's cosine and sine."""
        lo, hi = self.domain()
        return lo - SLACK * np.maximum(1.0, np.abs(lo)), hi + SLACK * np.maximum(1.0, np.abs(hi))

    # -- transformations --------------------------------------------------------
    def eliminate_linear(self, names: Iterable[str]) -> System:
        """Eliminate variables that appear only in linear terms, one core equation each.

        Returns a new system; the eliminated variables are recorded in ``eliminated`` as
        expressions of the remaining ones, for :meth:`full_point`.
        """
        cons = [Constraint(c.expr.copy(), c.name, c.kind, c.cancelled) for c in self.constraints]
        scales: dict[int, float] = {}  # size of the terms each substitution cancelled
        elim: dict[int, Expr] = {}
        for name in names:
            v = self.index(name)
            for c in cons:
                for k in c.expr.terms:
                    if len(k) == 2 and v in k:
                        raise FormulationError(f"{name!r} appears in a quadratic term")
            pivot = None
            for c in cons:
                a = c.expr.terms.get((v,), 0.0)
                if c.kind == "core" and a != 0.0 and (pivot is None or abs(a) > abs(pivot[1])):
                    pivot = (c, a)
            if pivot is None:
                raise FormulationError(f"no core equation to eliminate {name!r}")
            c0, a = pivot
            rest = _without(c0.expr, v)
            sol = rest * (-1.0 / a)  # v = sol
            cons.remove(c0)
            for c in cons:
                b = c.expr.terms.get((v,), 0.0)
                if b != 0.0:
                    scales[id(c)] = max(scales.get(id(c), 0.0), self.size(c.expr) + abs(b) * self.size(sol))
                    c.expr = _without(c.expr, v) + sol * b
            for u, e in elim.items():
                b = e.terms.get((v,), 0.0)
                if b != 0.0:
                    elim[u] = _without(e, v) + sol * b
            elim[v] = sol
        keep = [i for i in range(self.n) if i not in elim]
        remap = {old: new for new, old in enumerate(keep)}

        def re(e: Expr) -> Expr:
            return Expr({tuple(sorted(remap[i] for i in k)): v for k, v in e.terms.items()})

        out = System(
            names=[self.names[i] for i in keep],
            lo=[self.lo[i] for i in keep],
            hi=[self.hi[i] for i in keep],
            tags=[self.tags[i] for i in keep],
        )
        for c in cons:
            out._add(re(c.expr), c.name, c.kind, max(c.cancelled, scales.get(id(c), 0.0)))
        out.eliminated = {k: re(e) for k, e in self.eliminated.items()}
        for v, e in elim.items():
            out.eliminated[self.names[v]] = re(e)
        return out

    def size(self, e: Expr) -> float:
        """An upper bound of the terms of ``e`` over the domain: sum |a| max|x_i| (max|x_j|)."""
        mag = [max(abs(a), abs(b)) for a, b in zip(self.lo, self.hi)]
        t = 0.0
        for k, v in e.terms.items():
            m = abs(v)
            for i in k:
                m *= mag[i]
            t += m
        return t

    def full_point(self, x: np.ndarray) -> dict[str, float]:
        """Values of all variables, eliminated ones included, at ``x``."""
        vals = {n: float(x[i]) for i, n in enumerate(self.names)}
        for n, e in self.eliminated.items():
            vals[n] = e.value(x)
        return vals

    # -- evaluation ---------------------------------------------------------------
    def invalidate(self) -> None:
        """Forget the compiled rows (after the constraints were changed in place)."""
        self._compiled = None

    def compile(self) -> Compiled:
        if self._compiled is None:
            self._compiled = Compiled.build(self)
        return self._compiled

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """Values of the core and redundant equations at ``x``."""
        return self.compile().eval_eqs(np.asarray(x, dtype=float))

    def summary(self) -> dict:
        return {
            "variables": self.n,
            "equations": self.count("core") + self.count("redundant"),
            "core_equations": self.count("core"),
            "redundant_equations": self.count("redundant"),
            "inequalities": self.count("ineq"),
        }


@dataclass
class Compiled:
    """The expanded system: linear rows over ``z = (x, m)`` with ``m_k = x[mi_k] * x[mj_k]``.

    Rows ``0 .. n_core-1`` are core equations, then redundant equations (``n_eq`` in all),
    then inequalities. Row ``r`` reads ``A[r] @ z + c[r] = 0`` (equations) or ``<= 0``.
    """

    n: int
    mi: np.ndarray
    mj: np.ndarray
    A: sp.csr_matrix
    c: np.ndarray
    n_core: int
    n_eq: int
    row_names: list[str]
    #: per row: how far ``A z + c`` may stray from 0 (equations) or above 0 (inequalities) at a
    #: solution: a bound on the error of the row's floating-point derivation (see :data:`SLACK`)
    slack: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: per row: whether the LP relaxation holds it (None: every row). Rows that are linear
    #: combinations of others add nothing to a relaxation that is linear in ``z``, only dense
    #: rows to each LP; propagation still uses them
    lp_rows: np.ndarray | None = None
    #: per row: a bound on ``|F*(x) - (A z + c)|`` over the search domain, where ``F*`` is the row
    #: of the input as given (exact numbers) and ``A z + c`` the row as rounded here (empty: the
    #: rows are taken as exact). Krawczyk adds it to the error of ``F(x0)``, so its proofs hold for
    #: every system whose rows lie within these bounds, the input's among them; every slack is at
    #: least this, so no contractor discards a root of the input (docs/soundness.md,
    #: "Parameters as enclosures"; tests/formulation/test_enclosures.py)
    merr: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: per row: a bound on every partial derivative of that difference over the search domain
    #: (empty: zero), added to the spread of Krawczyk's Jacobian enclosure
    mgrad: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def model_error(self, m: int) -> tuple[np.ndarray, np.ndarray]:
        """``(merr, mgrad)`` of rows ``0..m`` (zeros where none were given)."""
        if self.merr.shape[0] == 0:
            return np.zeros(m), np.zeros(m)
        return np.ascontiguousarray(self.merr[:m]), np.ascontiguousarray(self.mgrad[:m])

    def for_lp(self) -> Compiled:
        """The rows the LP relaxation holds (all of them, or those of :attr:`lp_rows`); leaving
        rows out of a relaxation keeps it a relaxation."""
        keep = self.lp_rows
        if keep is None or bool(np.all(keep)):
            return self
        names = [n for n, k in zip(self.row_names, keep) if k]
        n_core, n_eq = int(np.sum(keep[: self.n_core])), int(np.sum(keep[: self.n_eq]))
        merr = self.merr[keep] if self.merr.shape[0] else self.merr
        mgrad = self.mgrad[keep] if self.mgrad.shape[0] else self.mgrad
        return replace(
            self,
            A=self.A[keep],
            c=self.c[keep],
            slack=self.slack[keep],
            n_core=n_core,
            n_eq=n_eq,
            row_names=names,
            lp_rows=None,
            merr=merr,
            mgrad=mgrad,
        )

    @property
    def target_lo(self) -> np.ndarray:
        """Lower bounds of ``A z`` over the solutions, per row."""
        lo = -self.c - self.slack
        lo[self.n_eq :] = -np.inf
        return lo

    @property
    def target_hi(self) -> np.ndarray:
        """Upper bounds of ``A z`` over the solutions, per row."""
        return -self.c + self.slack

    @property
    def nm(self) -> int:
        return len(self.mi)

    @property
    def nz(self) -> int:
        return self.n + len(self.mi)

    @staticmethod
    def build(s: System) -> Compiled:
        order = [c for c in s.constraints if c.kind == "core"]
        order += [c for c in s.constraints if c.kind == "redundant"]
        order += [c for c in s.constraints if c.kind == "ineq"]
        monos: dict[tuple[int, int], int] = {}
        rows, cols, vals = [], [], []
        const = np.zeros(len(order))
        # the size of each row's terms over the domain, |c| + sum |a_k| max|z_k|, with the
        # constant and every coefficient counted as at least the smallest normal number (below it
        # an ulp no longer shrinks with the number: a constant of 1e-316 is off by ulps of 5e-324
        # each) and each product formed as (|a| max|x_i|) max|x_j|, so that a big coefficient of
        # a tiny monomial does not underflow to 0
        lo, hi = s.domain()
        xmag = np.maximum(np.abs(lo), np.abs(hi)).tolist()  # Python floats: no overflow warnings
        scale = np.full(len(order), TINY)
        for r, con in enumerate(order):
            for k, v in con.expr.terms.items():
                t = abs(v) if len(k) == 0 else max(abs(v), TINY)
                for i in k:
                    t *= xmag[i]
                scale[r] += t
                if len(k) == 0:
                    const[r] += v
                    continue
                if len(k) == 1:
                    col = k[0]
                else:
                    col = s.n + monos.setdefault(k, len(monos))
                rows.append(r)
                cols.append(col)
                vals.append(v)
        nm = len(monos)
        mi = np.array([k[0] for k in monos], dtype=np.int64).reshape(-1)
        mj = np.array([k[1] for k in monos], dtype=np.int64).reshape(-1)
        A = sp.csr_matrix((vals, (rows, cols)), shape=(len(order), s.n + nm))
        A.sum_duplicates()
        n_core = s.count("core")
        # a row is off by the rounding of what was cancelled to derive it, not only of its own
        # terms (a row whose terms all cancelled is left with rounding noise for coefficients),
        # so every slack is relative to the largest of the row's own size, the size of the terms
        # substitution cancelled in it, and the size of the system's core rows
        floor = float(scale[:n_core].max(initial=0.0)) if n_core else float(scale.max(initial=0.0))
        cancelled = np.array([c.cancelled for c in order])
        slack = SLACK * np.maximum(np.maximum(scale, cancelled), floor)
        slack[:n_core] = CORE_SLACK * np.maximum(scale, cancelled)[:n_core]
        merr, mgrad = np.zeros(0), np.zeros(0)
        if s.core_errors is not None and len(s.core_errors[0]) == n_core:
            merr, mgrad = np.zeros(len(order)), np.zeros(len(order))
            merr[:n_core], mgrad[:n_core] = s.core_errors
            slack = np.maximum(slack, merr)  # no contractor discards a root of the model as given
        return Compiled(
            n=s.n,
            mi=mi,
            mj=mj,
            A=A,
            c=const,
            n_core=n_core,
            n_eq=n_core + s.count("redundant"),
            row_names=[c.name for c in order],
            slack=slack,
            merr=merr,
            mgrad=mgrad,
        )

    def z(self, x: np.ndarray) -> np.ndarray:
        return np.concatenate([x, x[self.mi] * x[self.mj]])

    def eval_rows(self, x: np.ndarray) -> np.ndarray:
        return self.A @ self.z(x) + self.c

    def eval_eqs(self, x: np.ndarray) -> np.ndarray:
        return self.eval_rows(x)[: self.n_eq]

    def eval_ineqs(self, x: np.ndarray) -> np.ndarray:
        return self.eval_rows(x)[self.n_eq :]

    def jacobian(self, x: np.ndarray, rows: slice | None = None) -> np.ndarray:
        """Dense Jacobian of the first rows (default: all equations, else ``rows=slice(0, m)``)
        at ``x``."""
        if rows is not None and (rows.start not in (None, 0) or rows.step not in (None, 1)):
            raise ValueError(f"jacobian takes the first rows, slice(0, m); got {rows}")
        R = self.rows(self.n_eq if rows is None else rows.stop)
        return R.Ax + np.bincount(R.t_flat, weights=R.t_coef * x[R.t_var], minlength=R.Ax.size).reshape(R.Ax.shape)

    def rows(self, m: int) -> Rows:
        """Rows ``0..m`` as :class:`Rows` (built once per ``m``)."""
        cache = self.__dict__.setdefault("_rows", {})
        if m not in cache:
            cache[m] = Rows.of(self, m)
        return cache[m]


@dataclass(frozen=True)
class Rows:
    """Rows ``0..m`` of ``A z + c`` as plain arrays (for compiled Newton steps): ``A`` in CSR form,
    and the Jacobian as its linear part ``Ax`` plus the slope terms ``t_coef * x[t_var]``, summed
    at the flat places ``t_flat`` of the ``m x n`` matrix (``d(x_i x_j)/dx_i = x_j``)."""

    n: int
    mi: np.ndarray
    mj: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    c: np.ndarray
    Ax: np.ndarray
    t_flat: np.ndarray
    t_var: np.ndarray
    t_coef: np.ndarray

    @staticmethod
    def of(comp: Compiled, m: int) -> Rows:
        n = comp.n
        A = comp.A[:m].tocsr()
        A.sort_indices()
        coo = A.tocoo()
        lin = coo.col < n
        Ax = np.zeros((m, n))
        np.add.at(Ax, (coo.row[lin], coo.col[lin]), coo.data[lin])
        r, k, a = coo.row[~lin], coo.col[~lin] - n, coo.data[~lin]

        def i64(v):
            return np.ascontiguousarray(v, dtype=np.int64)

        return Rows(
            n,
            i64(comp.mi),
            i64(comp.mj),
            i64(A.indptr),
            i64(A.indices),
            np.ascontiguousarray(A.data, dtype=float),
            np.ascontiguousarray(comp.c[:m], dtype=float),
            Ax,
            i64(np.concatenate([r * n + comp.mi[k], r * n + comp.mj[k]])),
            i64(np.concatenate([comp.mj[k], comp.mi[k]])),
            np.concatenate([a, a]).astype(float),
        )
