"""The numpy safe LP bound that kinbox.search.relaxation._safe_lower (compiled) replaced, kept as the
reference the compiled kernel is tested against (tests/search/test_relaxation.py)."""

import numpy as np

from kinbox import interval as iv


def safe_lower(relax, cost, y) -> float:
    """A lower bound of ``cost^T z`` over ``relax``'s LP from row multipliers ``y`` (see
    ``kinbox.search.relaxation._safe_lower`` for the argument)."""
    y = np.where((y > 0) & ~np.isfinite(relax.row_lo), 0.0, y)
    y = np.where((y < 0) & ~np.isfinite(relax.row_hi), 0.0, y)
    GTy, err = relax._enclose_GTy(y)
    r = cost - GTy
    rad = err + iv.gamma(2) * np.abs(r)
    with np.errstate(invalid="ignore", over="ignore"):
        pz = np.nan_to_num(np.minimum(r * relax.zlo, r * relax.zhi), nan=0.0, posinf=np.inf, neginf=-np.inf)
        ez = np.nan_to_num(rad * relax.zmag, nan=0.0, posinf=np.inf)
        tz = pz - ez
        tw = np.where(y > 0, y * relax.row_lo, np.where(y < 0, y * relax.row_hi, 0.0))
    s = tz.sum() + tw.sum()
    if not np.isfinite(s):
        return -np.inf
    n = len(tz) + len(tw)
    e = iv.gamma(n + 4) * (np.abs(pz).sum() + ez.sum() + np.abs(tw).sum()) + 4 * n * iv.TINY
    return float(iv.down(s - e))
