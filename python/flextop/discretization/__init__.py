"""How a discretization is chosen, in one place: the elements per bar and the steps a run
uses, the tolerances that choose them, their error estimates and the refinement that
meets a tolerance.

- :mod:`.tolerance`: a discretization, step doubling's estimates, :func:`resolve`;
- :mod:`.accuracy`: presets (named tolerances) and :func:`split_by`;
- :mod:`.indicator`: each bar's need (its own frequency and mass) and the refinement
  graded by it, bar by bar;
- :mod:`.refinement`: the scene refined (:class:`Levels`, kept in :class:`Refined`), companion runs, and the loop of
  a run to a tolerance.

:mod:`flextop.modal` refines the eigen-analysis by the same levels; the problems'
rule (:mod:`flextop.problems`) moves a :class:`Discretization` forward where it measures
again, and holds the grid in between.
"""

from .accuracy import PRESETS, preset, split_by
from .refinement import Levels, Refined, companions_of, to_tolerance
from .tolerance import Discretization, ErrorEstimate

__all__ = ["PRESETS", "Discretization", "ErrorEstimate", "Levels", "Refined", "companions_of", "preset", "split_by", "to_tolerance"]
