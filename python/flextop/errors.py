"""Exceptions raised by flextop.

Every error names its culprit: the scene entry (``joints[1] (elbow)``), the design
variable (``x[12] (link1/bar12)``), the setting (``h``) or the time of a failed step.
"""


class FlextopError(Exception):
    """Base class of flextop's errors."""


class SceneError(FlextopError, ValueError):
    """A scene that cannot be built: unknown key, non-physical or non-finite value,
    missing or duplicate node, degenerate geometry, over- or under-constrained mechanism."""


class SceneFileError(SceneError):
    """A scene file that cannot be read (missing, a directory, not UTF-8) or parsed as TOML:
    the message names the file and, for a syntax error, the line and column."""


class DesignError(FlextopError, ValueError):
    """A design vector of the wrong shape, length or type (not real numbers), non-finite, or
    outside ``[x_min, 1]`` (an optimization problem's bounds); or gradients of a design,
    handed to a filter, that are not finite or not one per variable."""


class SettingsError(FlextopError, ValueError):
    """Run settings out of range or missing (step size, spectral radius, responses, ...)."""


class SimulationError(FlextopError, RuntimeError):
    """A solve that failed: Newton did not converge (time, residual and iterations are in
    the message), a singular iteration matrix, or rigid kinematics that cannot be solved."""


class ToleranceError(SimulationError):
    """A tolerance that cannot be met within the named limits on elements per bar and
    steps: the message names the response and the error estimate reached."""


class ExecutionError(FlextopError, RuntimeError):
    """A task of a batch or a scenario evaluation that did not complete on its executor: its
    worker died, it could not be sent, or the cluster could not be reached. The message
    names the scenario or design."""


class CheckpointError(FlextopError, ValueError):
    """A checkpoint that cannot be resumed: unreadable, corrupt (its checksum or schema do
    not match), holding a design outside the bounds, or of a run that has finished."""


class MechanismWarning(UserWarning):
    """Joints that over-constrain the rigid mechanism (their rows depend on each other in
    the frames' rigid coordinates) but not the flexible model, which still runs: the rigid
    motion, and with it the tip deflection of Eq. 40, exists only where the redundant
    constraints agree. The message names the joints and counts the redundant rows."""


class SettingsWarning(UserWarning):
    """A setting the run had to change: a step ``h`` shortened by more than 1 % so that a
    whole number of steps ends exactly at ``t_end``; or one that does less than asked: a
    filter radius that reaches no neighbouring cell along a member."""


class PlausibilityWarning(UserWarning):
    """A result that completed but breaks a law it should obey: a run that created energy
    (kinetic plus strain energy above the work done on the structure), or a negative
    compliance under dead loads. The message gives the numbers; a smaller step or more load
    steps usually cure it."""
