"""Solving a conic program with Clarabel, robustly: assembled directly, or built by cvxpy.

The planner's subproblems are assembled as :class:`ConicForm` (min cᵀx s.t. b − Ax ∈ K, rows
written as affine expressions of the variables), so a plan pays no cvxpy compile and memory
grows with the constraints' non-zeros. Their cvxpy statements are kept as the readable models
and as test oracles (:func:`solve`).

Clarabel occasionally stops with "InsufficientProgress" on these nearly degenerate SCA
subproblems (e.g. when Σδ = T and an active power budget are almost parallel). The same problem
then solves with a shorter interior-point step or without equilibration, so those are tried in
turn before a step is given up.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import clarabel
import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    import cvxpy as cp

# An SCA step needs no more than 1e-7: the exact objective judges it afterwards, and NFZ
# constraints carry a 2 cm margin. (Clarabel's default 1e-8 costs ~10 % more iterations.)
# Iterative refinement of each KKT solve buys accuracy far below that at 30 % of the solve
# time: without it the sample and ten benchmark sites kept every paper-model min rate.
_TOLERANCE: dict[str, Any] = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7, "tol_feas": 1e-7,
                              "iterative_refinement_enable": False}
_ATTEMPTS: tuple[dict[str, Any], ...] = (
    {},
    {"max_step_fraction": 0.9},
    {"equilibrate_enable": False},
    {"max_step_fraction": 0.8, "equilibrate_enable": False},
)
_SOLVED = (clarabel.SolverStatus.Solved, clarabel.SolverStatus.AlmostSolved)


@dataclass(frozen=True)
class Csc:
    """A compressed-sparse-column matrix in the attributes Clarabel reads from a scipy
    ``csc_matrix`` (sorted row indices, no duplicates).

    Assembled with numpy alone: importing scipy.sparse costs a plan process 0.3-0.4 s, a tenth
    of the sample's whole run, for one conversion per solve.
    """

    data: NDArray[np.float64]
    indices: NDArray[np.int64]
    indptr: NDArray[np.int64]
    shape: tuple[int, int]
    has_canonical_format: bool = True

    @classmethod
    def from_entries(
        cls, rows: NDArray[np.int64], cols: NDArray[np.int64], vals: NDArray[np.float64],
        shape: tuple[int, int],
    ) -> Csc:
        """The matrix with Σ vals at each (row, col); repeated entries are summed in order."""
        order = np.lexsort((rows, cols))  # stable: duplicates keep their order when summed
        rows, cols, vals = rows[order], cols[order], vals[order]
        first = np.ones(rows.size, dtype=bool)
        first[1:] = (rows[1:] != rows[:-1]) | (cols[1:] != cols[:-1])
        starts = np.flatnonzero(first)
        data = np.add.reduceat(vals, starts) if starts.size else vals
        per_col = np.bincount(cols[starts], minlength=shape[1])
        indptr = np.concatenate(([0], np.cumsum(per_col))).astype(np.int64)
        return cls(data, rows[starts], indptr, shape)


@dataclass
class ConicForm:
    """min cᵀx s.t. s = b − A x in a product of cones, built one block of rows at a time.

    A block of R rows is ``const`` (R,) plus Σ coef · x[col] over its terms, where each term is
    a (cols, coefs) pair of arrays broadcast to R: the row's slack s itself, which must lie in
    the block's cone. Cones of dimension d take their rows in groups of d (C order of a
    (count, d) array).
    """

    num_vars: int
    c: NDArray[np.float64] = field(init=False)
    _rows: list[NDArray[np.int64]] = field(default_factory=list)
    _cols: list[NDArray[np.int64]] = field(default_factory=list)
    _vals: list[NDArray[np.float64]] = field(default_factory=list)
    _b: list[NDArray[np.float64]] = field(default_factory=list)
    _cones: list[Any] = field(default_factory=list)
    _height: int = 0

    def __post_init__(self) -> None:
        self.c = np.zeros(self.num_vars)

    def _block(
        self,
        const: ArrayLike,
        terms: list[tuple[ArrayLike, ArrayLike]],
        entries: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    ) -> int:
        b = np.asarray(const, dtype=float).ravel()
        rows = self._height + np.arange(b.size)
        if entries is not None:  # any number of (row in block, col, coef) entries per row
            self._rows.append(self._height + np.asarray(entries[0], dtype=np.int64))
            self._cols.append(np.asarray(entries[1], dtype=np.int64))
            self._vals.append(-np.asarray(entries[2], dtype=float))
        for cols, coefs in terms:
            col = np.broadcast_to(np.asarray(cols, dtype=np.int64), np.shape(const)).ravel()
            val = np.broadcast_to(np.asarray(coefs, dtype=float), np.shape(const)).ravel()
            keep = val != 0.0
            self._rows.append(rows[keep])
            self._cols.append(col[keep])
            self._vals.append(-val[keep])  # s = b − A x
        self._b.append(b)
        self._height += b.size
        return b.size

    def zero(
        self,
        const: ArrayLike,
        *terms: tuple[ArrayLike, ArrayLike],
        entries: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    ) -> None:
        """Rows that must equal 0; ``entries`` (row, col, coef) add terms row by row."""
        self._cones.append(clarabel.ZeroConeT(self._block(const, list(terms), entries)))

    def nonneg(
        self,
        const: ArrayLike,
        *terms: tuple[ArrayLike, ArrayLike],
        entries: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    ) -> None:
        """Rows that must be ≥ 0; ``entries`` (row, col, coef) add terms row by row."""
        self._cones.append(clarabel.NonnegativeConeT(self._block(const, list(terms), entries)))

    def soc(self, const: ArrayLike, *terms: tuple[ArrayLike, ArrayLike]) -> None:
        """(count, d) rows: each row group (t, x) with ‖x‖ ≤ t."""
        count, dim = np.shape(const)
        self._block(const, list(terms))
        self._cones += [clarabel.SecondOrderConeT(dim)] * count

    def exp(self, const: ArrayLike, *terms: tuple[ArrayLike, ArrayLike]) -> None:
        """(count, 3) rows: each row group (x, y, z) with y·exp(x/y) ≤ z, y > 0."""
        count, _ = np.shape(const)
        self._block(const, list(terms))
        self._cones += [clarabel.ExponentialConeT()] * count

    def solve(self) -> NDArray[np.float64] | None:
        """The optimal x, or None when every attempt fails."""
        a = Csc.from_entries(
            np.concatenate(self._rows), np.concatenate(self._cols), np.concatenate(self._vals),
            (self._height, self.num_vars),
        )
        b = np.concatenate(self._b)
        none = np.zeros(0, dtype=np.int64)  # no quadratic term: P = 0
        p = Csc.from_entries(none, none, np.zeros(0), (self.num_vars, self.num_vars))
        for attempt in _ATTEMPTS:
            settings = clarabel.DefaultSettings()
            settings.verbose = False
            for name, value in {**_TOLERANCE, **attempt}.items():
                setattr(settings, name, value)
            result = clarabel.DefaultSolver(p, self.c, a, b, self._cones, settings).solve()
            if result.status in _SOLVED:
                return np.asarray(result.x, dtype=float)
        return None


def solve(problem: cp.Problem) -> bool:
    """Solve a cvxpy ``problem`` with Clarabel; True when a (possibly inaccurate) optimum was
    found."""
    import cvxpy as cp

    accepted = (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)
    for settings in _ATTEMPTS:
        try:
            with warnings.catch_warnings():
                # The status is judged below; cvxpy's "may be inaccurate" warning adds nothing.
                warnings.simplefilter("ignore", UserWarning)
                # warm_start=False: cvxpy would otherwise update the previous Clarabel instance
                # in place, whose results then depend on what it solved before.
                problem.solve(solver=cp.CLARABEL, warm_start=False, **_TOLERANCE, **settings)
        except cp.SolverError:
            continue
        if problem.status in accepted:
            return True
    return False
