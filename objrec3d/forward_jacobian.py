"""Forward-difference Jacobians in one batched evaluation, for the far-cylinder pass's least-squares fits
(``robust_fit``).

scipy's default Jacobian (``jac="2-point"``) calls the residual function once per parameter: seven calls for a
capped cylinder, nine for a box. On the few hundred points of a far object each call is mostly NumPy's fixed
cost per operation (about 95 microseconds for ``capped_residuals``, whatever the point count), so the
Jacobians were 60 % of the segment-then-fit pass's time. Residual functions written for a *batch* of parameter
vectors (a (k, p) array in, a (k, n) array out) evaluate all the shifted vectors in one call, at about the
price of two. The steps are scipy's own (square root of the machine epsilon, relative, sign of the parameter),
so the fits follow the same path as with ``jac="2-point"`` up to rounding.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: scipy's relative step for two-point differences in float64: the square root of the machine epsilon.
RELATIVE_STEP = float(np.finfo(np.float64).eps ** 0.5)


class BatchedResiduals:
    """``fun`` and ``jac`` for a least-squares solver from ``batch``, a function of a (k, p) array of parameter
    vectors that returns their (k, n) residuals. ``jac`` reuses the residuals of the last ``fun`` call when it
    is asked at the same parameters (a solver's next Jacobian is at the point it just accepted).
    ``evaluations`` counts calls of ``batch`` and ``vectors`` the parameter vectors they held."""

    def __init__(self, batch: Callable[[np.ndarray], np.ndarray]) -> None:
        self.batch = batch
        self.evaluations = 0
        self.vectors = 0
        self._last_x: np.ndarray | None = None
        self._last_f: np.ndarray | None = None

    def _eval(self, xs: np.ndarray) -> np.ndarray:
        self.evaluations += 1
        self.vectors += xs.shape[0]
        return self.batch(xs)

    def fun(self, x: np.ndarray) -> np.ndarray:
        """The residuals at ``x`` (one parameter vector)."""
        f = self._eval(np.asarray(x, dtype=np.float64)[None])[0]
        self._last_x, self._last_f = np.array(x, dtype=np.float64), f
        return f

    def jac(self, x: np.ndarray) -> np.ndarray:
        """The (n, p) forward-difference Jacobian at ``x``, scipy's two-point steps, one batched evaluation."""
        x = np.asarray(x, dtype=np.float64)
        if self._last_x is not None and np.array_equal(self._last_x, x):
            f0 = self._last_f
            shifted = x + np.diag(self._steps(x))
            f = self._eval(shifted)
        else:  # not asked at the last point: evaluate it along with the shifted ones
            shifted = x + np.diag(self._steps(x))
            both = self._eval(np.concatenate([x[None], shifted]))
            f0, f = both[0], both[1:]
        dx = np.diagonal(shifted) - x  # the step as represented (scipy's)
        return ((f - f0) / dx[:, None]).T

    @staticmethod
    def _steps(x: np.ndarray) -> np.ndarray:
        sign = (x >= 0).astype(np.float64) * 2.0 - 1.0
        return RELATIVE_STEP * sign * np.maximum(1.0, np.abs(x))
