"""Systems built once whose coefficients depend on parameters: each instance only binds numbers.

An inverse-kinematics problem of one arm and frame is the same polynomial system for every goal
pose, except for numbers that depend on the pose. A :class:`Template` holds that system once,
with every coefficient an *affine* function of a parameter vector ``p`` (``p[0] = 1``): a
constraint is a sum ``sum_k p[k] * E_k`` of ordinary :class:`~kinbox.formulation.system.Expr`
polynomials. The sparsity pattern of the expanded form (:class:`~kinbox.formulation.system.Compiled`)
is the union over ``k`` and is fixed; :meth:`Template.bind` makes the
:class:`~kinbox.formulation.system.Compiled` of one ``p`` with two small matrix products (no
expression is built again), so that binding a pose costs microseconds.

Which derived numbers are parameters (products of goal entries, say) is the builder's choice;
a product of two parameters is never formed here, so every coefficient is exact up to the
rounding of ``coef @ p``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import FormulationError
from ..interval import TINY
from .errfloat import err, num
from .system import SLACK, Compiled, Expr, System, terms_key

#: relative slack of the core rows (of the size of their terms, parameters counted at ``pmag``):
#: a coefficient is a few ulps off from the model's constants, and the parameters from the goal
#: pose are products of four poses (some tens of roundings in all), so this is about 90 ulps.
#: Like :data:`~kinbox.formulation.system.CORE_SLACK` it must stay small: Krawczyk widens its
#: "empty" verdicts by ``|J^-1|`` times it, and next to a near-singular root (two UR5
#: solutions 1e-3 apart, ``|J^-1|`` ~ 2e4) the derived rows' slack left every box around the
#: root unprovable, so the search split them without end
TEMPLATE_CORE_SLACK = 1e-14

#: a parametric expression: parameter index -> polynomial (index 0 is the constant 1)
PExpr = dict


def pexpr(e) -> PExpr:
    """``e`` (a float, an Expr or a PExpr) as a PExpr."""
    if isinstance(e, dict):
        return e
    return {0: e if isinstance(e, Expr) else Expr.const(num(e))}


def padd(*terms) -> PExpr:
    """Sum of PExprs (or floats / Exprs)."""
    out: dict[int, Expr] = {}
    for t in terms:
        for k, e in pexpr(t).items():
            out[k] = out[k] + e if k in out else (e if isinstance(e, Expr) else Expr.const(num(e)))
    return out


def pscale(k: int, e) -> PExpr:
    """``p[k] * e`` for an Expr or float ``e``."""
    return {k: e if isinstance(e, Expr) else Expr.const(num(e))}


def pneg(a: PExpr) -> PExpr:
    return {k: -e for k, e in pexpr(a).items()}


def _same_parts(a: PExpr, b: PExpr) -> bool:
    """Are ``a = 0`` and ``b = 0`` the same equation (``a = b`` or ``a = -b``)?"""
    if a.keys() != b.keys():
        return False
    return any(all(terms_key(a[k].terms, 1.0) == terms_key(b[k].terms, sign) for k in a) for sign in (1.0, -1.0))


@dataclass
class _Row:
    parts: PExpr
    name: str
    kind: str
    lp: bool = True  # held by the LP relaxation (:attr:`Compiled.lp_rows`)


@dataclass
class Template:
    """Variables (as in :class:`System`) and parametric constraints; see the module docstring."""

    nparams: int
    vars: System = field(default_factory=System)
    rows: list[_Row] = field(default_factory=list)
    _frozen: dict | None = field(default=None, repr=False)

    # -- building ---------------------------------------------------------------------------
    def add_var(self, name: str, lo: float, hi: float, tag: str = "") -> Expr:
        self._frozen = None
        return self.vars.add_var(name, lo, hi, tag)

    def _add(self, e: PExpr | Expr | float, name: str, kind: str, lp: bool = True) -> None:
        parts = {k: v for k, v in pexpr(e).items() if isinstance(v, Expr) and v.terms}
        for k, v in parts.items():
            if not 0 <= k < self.nparams:
                raise FormulationError(f"constraint {name!r}: parameter index {k} out of range")
            if v.degree > 2:
                raise FormulationError(f"constraint {name!r} has degree {v.degree} > 2")
        if not parts:
            return
        if kind == "redundant" and any(r.kind != "ineq" and _same_parts(r.parts, parts) for r in self.rows):
            return  # an equation the template has already (|u| = |v| = 1 of a planar chain's frame)
        self.rows.append(_Row(parts, name, kind, lp))
        self._frozen = None

    def add_eq(self, e, name: str = "", redundant: bool = False, lp: bool = True) -> None:
        """``e = 0``; ``lp=False`` (redundant rows only) leaves it out of the LP relaxation."""
        if not lp and not redundant:
            raise FormulationError(f"core row {name!r} must be in the LP relaxation")
        self._add(e, name, "redundant" if redundant else "core", lp)

    def add_ineq(self, e, name: str = "") -> None:
        """``e <= 0``."""
        self._add(e, name, "ineq")

    @property
    def n(self) -> int:
        return self.vars.n

    def count(self, kind: str) -> int:
        return sum(1 for r in self.rows if r.kind == kind)

    # -- the fixed pattern --------------------------------------------------------------------
    def freeze(self) -> dict:
        """The expanded pattern (built once): rows in solver order, monomials, and per stored
        entry its coefficient as a vector over the parameters."""
        if self._frozen is not None:
            return self._frozen
        n = self.vars.n
        order = [r for r in self.rows if r.kind == "core"]
        order += [r for r in self.rows if r.kind == "redundant"]
        order += [r for r in self.rows if r.kind == "ineq"]
        monos: dict[tuple[int, int], int] = {}
        entries: dict[tuple[int, int], np.ndarray] = {}
        errors: dict[tuple[int, int], np.ndarray] = {}
        const = np.zeros((len(order), self.nparams))
        const_err = np.zeros((len(order), self.nparams))
        lo, hi = self.vars.domain()
        xmag = np.maximum(np.abs(lo), np.abs(hi))
        xpad = xmag * (1.0 + 1e-9) + 1e-9  # over the search domain (padded by SLACK)
        # terms of zero value whose exact value is not (errfloat.EF): no entry of the pattern;
        # their error times the size of the monomial (and of its partial derivatives) per row
        zero_val = np.zeros((len(order), self.nparams))
        zero_grad = np.zeros((len(order), self.nparams))
        for r, row in enumerate(order):
            for k, e in row.parts.items():
                for key, v in e.terms.items():
                    if len(key) == 0:
                        const[r, k] += v
                        const_err[r, k] += err(v)
                        continue
                    if v == 0.0:
                        m, gm = _monomial_bounds(key, xpad)
                        zero_val[r, k] += err(v) * m
                        zero_grad[r, k] += err(v) * gm
                        continue
                    col = key[0] if len(key) == 1 else n + monos.setdefault(key, len(monos))
                    vec = entries.setdefault((r, col), np.zeros(self.nparams))
                    vec[k] += v
                    if err(v):
                        errors.setdefault((r, col), np.zeros(self.nparams))[k] += err(v)
        keys = sorted(entries)
        rows_ = np.array([k[0] for k in keys], dtype=np.int64)
        cols = np.array([k[1] for k in keys], dtype=np.int64)
        # sparse: most entries depend on one or two parameters (a template whose redundant rows
        # have a parameter per coefficient has hundreds of parameters)
        coef = sp.csr_matrix(np.array([entries[k] for k in keys]).reshape(len(keys), self.nparams))
        indptr = np.zeros(len(order) + 1, dtype=np.int64)
        np.add.at(indptr, rows_ + 1, 1)
        indptr = np.cumsum(indptr)
        mi = np.array([k[0] for k in monos], dtype=np.int64).reshape(-1)
        mj = np.array([k[1] for k in monos], dtype=np.int64).reshape(-1)
        zeros = np.zeros(self.nparams)
        coef_err = sp.csr_matrix(np.array([errors.get(k, zeros) for k in keys]).reshape(len(keys), self.nparams))
        zmag = np.concatenate([xmag, xmag[mi] * xmag[mj]]) if len(mi) else xmag
        n_core = sum(1 for r in order if r.kind == "core")
        n_eq = n_core + sum(1 for r in order if r.kind == "redundant")
        self._frozen = dict(
            rows=rows_,
            cols=cols,
            coef=coef,
            abscoef=abs(coef),
            const=const,
            indptr=indptr,
            mi=mi,
            mj=mj,
            zmag=zmag[cols] if len(cols) else np.zeros(0),
            n_core=n_core,
            n_eq=n_eq,
            names=[r.name for r in order],
            lp_rows=None if all(r.lp for r in order) else np.array([r.lp for r in order]),
            nz=n + len(monos),
            # per stored entry: the largest |d z / d x_i| over the domain (1 for x_i, |x_j| for
            # x_i x_j, 2 |x_i| for x_i^2), for the bound on the gradient of a coefficient's error
            gmag=_gradient_magnitudes(cols, n, mi, mj, xmag),
            # per stored entry and per row constant: the rounding of ``coef @ p`` (a sum of k
            # products), gamma(k); an entry of the constant parameter alone is exact (p[0] = 1)
            g_coef=_product_rounding(coef),
            # entries of one product c * p_k (most of them): their rounding is computed exactly
            single=_single_products(coef),
            g_const=_product_rounding(sp.csr_matrix(const)),
            # the template's own constants (errfloat.EF): per stored entry and per row constant,
            # per parameter, a bound on the distance to the coefficient of the model's exact
            # constants; and what terms of zero value add per row (value, partial derivatives)
            coef_err=coef_err,
            const_err=sp.csr_matrix(const_err),
            zero_val=sp.csr_matrix(zero_val),
            zero_grad=sp.csr_matrix(zero_grad),
        )
        return self._frozen

    def bind(self, p: np.ndarray, pmag: np.ndarray | None = None, prad: np.ndarray | None = None) -> BoundSystem:
        """The system at parameters ``p`` (``p[0]`` must be 1). ``pmag``: bounds on the size of
        each parameter and of the terms it was computed from (default ``|p|``), the scale of
        its rounding. ``prad``: the radius of each parameter's enclosure of its exact value
        (``|p_exact - p| <= prad``); given, the bound system carries ``merr`` and ``mgrad``
        (:class:`~kinbox.formulation.system.Compiled`): its proofs then hold for the exact
        parameters and the template's constants within their errors (:mod:`~kinbox.formulation.errfloat`)."""
        f = self.freeze()
        p = np.asarray(p, dtype=float)
        if p.shape != (self.nparams,) or p[0] != 1.0:
            raise FormulationError(f"template takes {self.nparams} parameters with p[0] = 1")
        ap = np.abs(p) if pmag is None else np.maximum(np.abs(p), np.asarray(pmag, dtype=float))
        data = f["coef"] @ p
        c = f["const"] @ p
        nrow = len(f["names"])
        A = sp.csr_matrix((data, f["cols"], f["indptr"]), shape=(nrow, f["nz"]))
        # the size of each row's terms over the domain, as Compiled.build computes it, but with
        # every coefficient counted before its parameters were summed (|coef| @ |p|): a sum that
        # cancels leaves rounding noise of the size of its parts
        mag = np.maximum(f["abscoef"] @ ap, TINY) * f["zmag"]
        scale = np.full(nrow, TINY) + np.abs(f["const"]) @ ap
        np.add.at(scale, f["rows"], mag)
        n_core = f["n_core"]
        floor = float(scale[:n_core].max(initial=0.0)) if n_core else float(scale.max(initial=0.0))
        slack = SLACK * np.maximum(scale, floor)
        slack[:n_core] = TEMPLATE_CORE_SLACK * scale[:n_core]
        merr, mgrad = np.zeros(0), np.zeros(0)
        if prad is not None:
            merr, mgrad = _model_error(f, p, ap, np.asarray(prad, dtype=float), nrow)
            # every row keeps the points where the input's rows vanish
            slack = np.maximum(slack, merr)
        comp = Compiled(
            n=self.vars.n,
            mi=f["mi"],
            mj=f["mj"],
            A=A,
            c=c,
            n_core=f["n_core"],
            n_eq=f["n_eq"],
            row_names=f["names"],
            slack=slack,
            lp_rows=f["lp_rows"],
            merr=merr,
            mgrad=mgrad,
        )
        return BoundSystem(self, comp)


def _single_products(coef: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows of ``coef`` with one non-zero (``c * p[k]``): (their indices, ``c``, ``k``)."""
    coef = coef.tocsr()
    one = np.flatnonzero(np.diff(coef.indptr) == 1)
    at = coef.indptr[:-1][one]
    return one, coef.data[at].astype(float), coef.indices[at].astype(np.int64)


def _two_product_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a * b - fl(a * b)`` exactly (Dekker's TwoProduct, with Veltkamp's splitting), plus the
    smallest normal number for a product near underflow, where the split is not exact."""
    h = a * b
    f = 134217729.0  # 2^27 + 1
    t = f * a
    ah = t - (t - a)
    al = a - ah
    t = f * b
    bh = t - (t - b)
    bl = b - bh
    err = ((ah * bh - h) + ah * bl + al * bh) + al * bl
    return np.abs(err) + TINY


def _product_rounding(coef: sp.csr_matrix) -> np.ndarray:
    """Per row of ``coef``: a bound, relative to ``|coef| @ |p|``, on the rounding of ``coef @
    p`` in binary64 (``gamma(2k - 1)`` for ``k`` products summed; 0 for the constant parameter alone, ``p[0] = 1``)."""
    from ..interval import gamma  # noqa: PLC0415 (kept beside its one use)

    coef = coef.tocsr()
    k = np.diff(coef.indptr)
    alone = np.zeros(len(k), dtype=bool)
    one = k == 1
    alone[one] = coef.indices[coef.indptr[:-1][one]] == 0
    g = np.asarray(gamma(np.maximum(2 * k - 1, 1)), dtype=float)
    g[alone | (k == 0)] = 0.0
    return g


def _monomial_bounds(key: tuple, xpad: np.ndarray) -> tuple[float, float]:
    """Bounds on ``|x_i x_j ...|`` over the domain and on each of its partial derivatives."""
    m = 1.0
    for i in key:
        m *= float(xpad[i])
    g = 0.0
    for i in set(key):
        rest = list(key)
        rest.remove(i)
        gi = float(key.count(i))
        for j in rest:
            gi *= float(xpad[j])
        g = max(g, gi)
    return m * (1.0 + 1e-12), g * (1.0 + 1e-12)


def _gradient_magnitudes(cols: np.ndarray, n: int, mi: np.ndarray, mj: np.ndarray, xmag: np.ndarray) -> np.ndarray:
    """Per stored entry (column ``cols``): the largest partial derivative of its monomial over
    the domain, widened by the search domain's padding."""
    g = np.ones(len(cols))
    quad = cols >= n
    k = cols[quad] - n
    xm = xmag * (1.0 + 1e-9) + 1e-9
    g[quad] = np.where(mi[k] == mj[k], 2.0 * xm[mi[k]], np.maximum(xm[mi[k]], xm[mj[k]]))
    return g


def _model_error(f: dict, p: np.ndarray, ap: np.ndarray, prad: np.ndarray, nrow: int) -> tuple[np.ndarray, np.ndarray]:
    """``(merr, mgrad)`` per row (:class:`Compiled`): bounds on the difference between the rows
    at the exact parameters with exact coefficients and the rows as bound, in value over the
    search domain and in every partial derivative. A stored coefficient ``coef @ p`` is off by
    ``|coef| @ prad`` (the parameters' enclosures), by the rounding of the product
    (``gamma(k) |coef| @ |p|``), and by the errors of the template's constants (``coef_err``,
    ``const_err``; terms of zero value: ``zero_val``, ``zero_grad``, :meth:`Template.freeze`)."""
    acoef, aconst = f["abscoef"], np.abs(f["const"])
    g_coef = f["g_coef"].copy()
    one, c1, k1 = f["single"]
    rad_round = g_coef * (acoef @ np.abs(p))
    rad_round[one] = np.abs(_two_product_error(c1, p[k1]))
    apr = ap + prad
    rad = acoef @ prad + rad_round + f["coef_err"] @ apr
    crad = aconst @ prad + f["g_const"] * (aconst @ np.abs(p)) + f["const_err"] @ apr
    zmag = f["zmag"] * (1.0 + 1e-9) + 1e-9  # over the search domain (padded by SLACK)
    gmag = f["gmag"]
    rows = f["rows"]
    merr = crad + f["zero_val"] @ apr
    np.add.at(merr, rows, rad * zmag)
    mgrad = f["zero_grad"] @ apr
    np.add.at(mgrad, rows, rad * gmag)
    # the sums above are of non-negative terms: a relative margin covers their rounding
    return np.nextafter(merr * (1.0 + 1e-12), np.inf) + TINY, np.nextafter(mgrad * (1.0 + 1e-12), np.inf) + TINY


def model_errors(f: dict, P: np.ndarray, AP: np.ndarray, PRAD: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_model_error` of ``N`` parameter vectors at once (rows of ``P``, ``AP`` the
    magnitudes, ``PRAD`` the radii): arrays ``(N, rows)`` (the closed-form batch certifies
    its roots with them, :mod:`kinbox.search.closed_form`; ``tests/formulation/test_enclosures.py``
    checks them against the one-pose bounds)."""
    P, AP, PRAD = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (P, AP, PRAD))
    acoef, aconst = f["abscoef"], sp.csr_matrix(np.abs(f["const"]))
    absP = np.abs(P).T
    rad_round = f["g_coef"][:, None] * (acoef @ absP)
    one, c1, k1 = f["single"]
    if len(one):
        rad_round[one] = np.abs(_two_product_error(c1[:, None], P[:, k1].T))
    APR = (AP + PRAD).T
    rad = acoef @ PRAD.T + rad_round + f["coef_err"] @ APR
    crad = aconst @ PRAD.T + f["g_const"][:, None] * (aconst @ absP) + f["const_err"] @ APR
    zmag = f["zmag"] * (1.0 + 1e-9) + 1e-9
    nrow, ne = len(f["names"]), len(f["rows"])
    S = sp.csr_matrix((np.ones(ne), (f["rows"], np.arange(ne))), shape=(nrow, ne))
    merr = crad + f["zero_val"] @ APR + S @ (rad * zmag[:, None])
    mgrad = f["zero_grad"] @ APR + S @ (rad * f["gmag"][:, None])
    merr, mgrad = np.asarray(merr).T, np.asarray(mgrad).T
    return np.nextafter(merr * (1.0 + 1e-12), np.inf) + TINY, np.nextafter(mgrad * (1.0 + 1e-12), np.inf) + TINY


class BoundSystem(System):
    """A :class:`System` whose expanded form was bound from a :class:`Template` (its constraints
    are not kept as expressions: only the compiled rows)."""

    def __init__(self, template: Template, comp: Compiled):
        v = template.vars
        super().__init__(names=v.names, lo=v.lo, hi=v.hi, tags=v.tags, ranks=v.ranks)
        self._counts = {k: template.count(k) for k in ("core", "redundant", "ineq")}
        self._compiled = comp

    def count(self, kind: str) -> int:
        return self._counts.get(kind, 0)

    def compile(self) -> Compiled:
        assert self._compiled is not None
        return self._compiled

    def __reduce__(self):  # pickled for parallel workers: the compiled rows are all it needs
        return (
            _rebuild_bound,
            (list(self.names), list(self.lo), list(self.hi), list(self.tags), list(self.ranks), dict(self._counts), self._compiled),
        )


def _rebuild_bound(names, lo, hi, tags, ranks, counts, comp) -> BoundSystem:
    s = BoundSystem.__new__(BoundSystem)
    System.__init__(s, names=names, lo=lo, hi=hi, tags=tags, ranks=ranks)
    s._counts = counts
    s._compiled = comp
    return s
