"""A port of the 88-line topology optimization code (Andreassen, Clausen, Schevenels, Lazarov
and Sigmund, "Efficient topology optimization in MATLAB using 88 lines of code", 2011) to
numpy and scipy, line for line: the half-MBB beam, modified SIMP with E_min, the sensitivity
(ft = 1) or density (ft = 2) filter and the optimality-criteria update. The reference that
flextop's own element, filters and optimizer are held to in ``test_top88.py``."""

import functools

import numpy as np
import scipy.sparse as sparse
from scipy.sparse.linalg import spsolve

_A11 = np.array([[12, 3, -6, -3], [3, 12, 3, 0], [-6, 3, 12, -3], [-3, 0, -3, 12]])
_A12 = np.array([[-6, -3, 0, 3], [-3, -6, -3, -6], [0, -3, -6, 3], [3, -6, 3, -6]])
_B11 = np.array([[-4, 3, -2, 9], [3, -4, -9, 4], [-2, -9, -4, -3], [9, 4, -3, -4]])
_B12 = np.array([[2, -3, 4, -9], [-3, 2, 9, -2], [4, 9, 2, 3], [-9, -2, 3, 2]])


def ke88(nu: float) -> np.ndarray:
    """The element stiffness of a unit square, E = 1 (the code's lines 8–13)."""
    return (np.block([[_A11, _A12], [_A12.T, _A11]]) + nu * np.block([[_B11, _B12], [_B12.T, _B11]])) / (24 * (1 - nu**2))


def top88(nelx: int, nely: int, volfrac: float, penal: float, rmin: float, ft: int, max_iter: int = 1000,
          bisection: float = 1e-3):
    """Runs the code; returns the compliance at every iteration and the final ``xPhys``
    (nely × nelx, row 0 at the top). ``bisection`` is the relative width at which the
    bisection on the volume's multiplier stops (the code's 1e-3). A run is made once per
    session (``test_linear.py`` and ``test_top88.py`` hold flextop to the same ones); each
    call gets copies of it."""
    history, x_phys = _top88(nelx, nely, volfrac, penal, rmin, ft, max_iter, bisection)
    return list(history), x_phys.copy()


@functools.cache
def _top88(nelx: int, nely: int, volfrac: float, penal: float, rmin: float, ft: int, max_iter: int, bisection: float):
    e0, emin, nu = 1.0, 1e-9, 0.3
    ke = ke88(nu)
    nodenrs = np.arange((1 + nelx) * (1 + nely)).reshape(1 + nelx, 1 + nely).T  # column-major, from the top
    n1 = nodenrs[:-1, :-1].flatten(order="F")  # each element's upper-left node, elements column-major
    n2 = n1 + nely + 1  # upper-right
    edof = np.stack([2 * (n1 + 1), 2 * (n1 + 1) + 1, 2 * (n2 + 1), 2 * (n2 + 1) + 1, 2 * n2, 2 * n2 + 1, 2 * n1, 2 * n1 + 1], axis=1)
    ik = np.kron(edof, np.ones((8, 1), int)).flatten()
    jk = np.kron(edof, np.ones((1, 8), int)).flatten()
    ndof = 2 * (nely + 1) * (nelx + 1)
    f = np.zeros(ndof)
    f[1] = -1.0
    fixed = np.union1d(np.arange(0, 2 * (nely + 1), 2), [ndof - 1])
    free = np.setdiff1d(np.arange(ndof), fixed)
    # The filter's weights (lines 36–54).
    rows, cols, weights = [], [], []
    reach = int(np.ceil(rmin)) - 1
    for i1 in range(nelx):
        for j1 in range(nely):
            e1 = i1 * nely + j1
            for i2 in range(max(i1 - reach, 0), min(i1 + reach + 1, nelx)):
                for j2 in range(max(j1 - reach, 0), min(j1 + reach + 1, nely)):
                    rows.append(e1)
                    cols.append(i2 * nely + j2)
                    weights.append(max(0.0, rmin - np.hypot(i1 - i2, j1 - j2)))
    h = sparse.csr_matrix((weights, (rows, cols)), shape=(nelx * nely, nelx * nely))
    hs = np.asarray(h.sum(axis=1)).ravel()
    x = np.full(nelx * nely, volfrac)
    x_phys = x.copy()
    change, history = 1.0, []
    while change > 0.01 and len(history) < max_iter:
        stiffness = emin + x_phys**penal * (e0 - emin)
        k = sparse.csr_matrix(((ke.flatten()[None, :] * stiffness[:, None]).flatten(), (ik, jk)), shape=(ndof, ndof))
        k = (k + k.T) / 2
        u = np.zeros(ndof)
        u[free] = spsolve(k[free][:, free].tocsc(), f[free])
        ce = np.einsum("ei,ij,ej->e", u[edof], ke, u[edof])
        history.append(float(np.sum(stiffness * ce)))
        dc = -penal * (e0 - emin) * x_phys ** (penal - 1) * ce
        dv = np.ones(nelx * nely)
        if ft == 1:
            dc = h @ (x * dc) / hs / np.maximum(1e-3, x)
        else:
            dc = h @ (dc / hs)
            dv = h @ (dv / hs)
        l1, l2, move = 0.0, 1e9, 0.2
        while (l2 - l1) / (l1 + l2) > bisection:
            lmid = 0.5 * (l2 + l1)
            x_new = np.maximum(0, np.maximum(x - move, np.minimum(1, np.minimum(x + move, x * np.sqrt(-dc / dv / lmid)))))
            x_phys = x_new if ft == 1 else h @ x_new / hs
            if x_phys.sum() > volfrac * nelx * nely:
                l1 = lmid
            else:
                l2 = lmid
        change = float(np.abs(x_new - x).max())
        x = x_new
    return history, x_phys.reshape(nelx, nely).T
