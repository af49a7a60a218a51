"""The arm template's core rows bound at one pose, in compiled code: what the closed form's
batch (:func:`kinbox.search.closed_form.solve_batch_kernel`) and the general 6R arm's
certificate (:func:`kinbox.search.eigen6r.certify_kernel`) both need around Krawczyk
(:func:`kinbox.search.certify._krawczyk_full`) on the system
(:class:`kinbox.search.closed_form.TemplateCertifier` holds the arrays)."""

from __future__ import annotations

from . import jit as nb


@nb.njit(cache=True)
def bind_rows(
    p, pm, merr, const, coef_indptr, coef_indices, coef_data, zmag, rows_of, cols, nonlin, core_slack, tiny,
    ap, c, slack, data, Ax, t_coef, t_abs,
):  # fmt: skip
    """Bind the core rows at parameters ``p`` (magnitudes at least ``pm``): constants ``c``,
    entries ``data``, the linear part ``Ax``, the bilinear terms' coefficients ``t_coef`` and
    their magnitudes ``t_abs``, and each row's slack (:meth:`kinbox.formulation.template.Template.bind`),
    at least ``merr`` (the model's and the pose's errors; zeros where there are none). ``ap``:
    scratch of ``p``'s size."""
    n = Ax.shape[1]
    n_core = const.shape[0]
    ne = zmag.shape[0]
    npar = p.shape[0]
    for j in range(npar):
        ap[j] = max(abs(p[j]), pm[j])
    for r in range(n_core):
        acc = 0.0
        sc = tiny
        for j in range(npar):
            acc += const[r, j] * p[j]
            sc += abs(const[r, j]) * ap[j]
        c[r] = acc
        slack[r] = sc
    for e in range(ne):
        acc = 0.0
        mag = 0.0
        for q in range(coef_indptr[e], coef_indptr[e + 1]):
            acc += coef_data[q] * p[coef_indices[q]]
            mag += abs(coef_data[q]) * ap[coef_indices[q]]
        data[e] = acc
        slack[rows_of[e]] += max(mag, tiny) * zmag[e]
    for r in range(n_core):
        slack[r] = max(slack[r] * core_slack, merr[r])
    Ax[:, :] = 0.0
    for e in range(ne):
        if cols[e] < n:
            Ax[rows_of[e], cols[e]] += data[e]
    h = nonlin.shape[0]
    for q in range(h):
        t_coef[q] = data[nonlin[q]]
        t_coef[q + h] = data[nonlin[q]]
    for q in range(2 * h):
        t_abs[q] = abs(t_coef[q])


@nb.njit(cache=True)
def core_row(r, c, data, x, indptr, cols, mi, mj):
    """Core row ``r`` of the bound system at the point ``x`` (floats, rounded)."""
    n = x.shape[0]
    acc = c[r]
    for q in range(indptr[r], indptr[r + 1]):
        col = cols[q]
        if col < n:
            acc += data[q] * x[col]
        else:
            acc += data[q] * x[mi[col - n]] * x[mj[col - n]]
    return acc


@nb.njit(cache=True)
def boxes_apart(lo_out, hi_out, prev, lo, hi):
    """Is the box ``[lo, hi]`` disjoint from row ``prev`` of the boxes ``lo_out``, ``hi_out``?
    Two roots proven each unique in disjoint boxes are distinct."""
    for i in range(lo.shape[0]):
        if lo_out[prev, i] > hi[i] or lo[i] > hi_out[prev, i]:
            return True
    return False
