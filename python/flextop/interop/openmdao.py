"""A :class:`flextop.optimizers.Problem` as an OpenMDAO ``ExplicitComponent``.

    import openmdao.api as om
    from flextop.interop.openmdao import ProblemComponent

    model = om.Group()
    model.add_subsystem("arm", ProblemComponent(problem=problem), promotes=["*"])
    prob = om.Problem(model)
    prob.model.add_design_var("x", lower=problem.lower, upper=problem.upper)
    prob.model.add_objective("f")
    prob.model.add_constraint("g", upper=0.0)

Input ``x`` (the design), outputs ``f`` (the objective as the problem's optimizers see it)
and ``g`` (its constraints, feasible when ≤ 0). ``compute`` and ``compute_partials`` serve
one evaluation per design: the simulation and its exact (adjoint or direct) gradients run
once.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import openmdao.api as om

from .cache import Evaluations


class ProblemComponent(om.ExplicitComponent):
    """``x → (f, g)`` of the problem given as the ``problem`` option, with exact partials."""

    def initialize(self) -> None:
        self.options.declare("problem", desc="a flextop.optimizers.Problem (e.g. a TopologyProblem)")

    def setup(self) -> None:
        problem = self.options["problem"]
        self.evaluations = Evaluations(problem)
        self.add_input("x", val=0.5 * (problem.lower + problem.upper), shape=problem.n)
        self.add_output("f", val=0.0)
        self.add_output("g", val=np.zeros(problem.m), shape=problem.m)
        self.declare_partials("f", "x")
        self.declare_partials("g", "x")

    def compute(self, inputs: Any, outputs: Any) -> None:
        e = self.evaluations(inputs["x"])
        outputs["f"] = e.f0
        outputs["g"] = e.g

    def compute_partials(self, inputs: Any, partials: Any) -> None:
        e = self.evaluations(inputs["x"])
        partials["f", "x"] = e.df0[None, :]
        partials["g", "x"] = e.dg
