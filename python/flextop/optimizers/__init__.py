"""Sequential convex programming optimizers: CONLIN, MMA and GCMMA; and the
optimality-criteria method for one volume constraint.

Solve  minimize f0(x)  s.t.  g_j(x) <= 0 (j = 1..m),  lower <= x <= upper
for many design variables and few constraints::

    from flextop.optimizers import FunctionProblem, optimize
    result = optimize(problem, x0, method="mma")   # or "gcmma", "conlin"

Modules: :mod:`.problem` (problem interface), :mod:`.conlin` and :mod:`.mma`
(the approximations), :mod:`.oc` (optimality criteria), :mod:`.dual` (the dual subproblem solver they share),
:mod:`.kkt` (the KKT residual that says whether a design is optimal),
:mod:`.driver` (outer loop, stopping rules, failure recovery) and
:mod:`.state` (resumable state).
"""

from .conlin import Conlin
from .driver import OptimizeResult, Status, optimize
from .kkt import kkt_estimate, kkt_residual
from .method import Method
from .mma import GCMMA, MMA
from .oc import OptimalityCriteria
from .problem import Evaluation, EvaluationError, FunctionProblem, Problem, Trial
from .state import IterationRecord, OptimizerState

__all__ = [
    "Conlin", "Evaluation", "EvaluationError", "FunctionProblem", "GCMMA", "IterationRecord",
    "MMA", "Method", "OptimalityCriteria", "OptimizeResult", "OptimizerState", "Problem", "Status", "Trial",
    "kkt_estimate", "kkt_residual", "optimize",
]
