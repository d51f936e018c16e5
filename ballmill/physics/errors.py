"""Exceptions raised by the physics library.

Every message names the offending value and what was expected, so that the
FMU adapters can pass it on to the importing tool unchanged.
"""


class ParameterError(ValueError):
    """A parameter or initial condition is outside its physical range."""


class InputError(ValueError):
    """An input sample (platform motion) is unusable, e.g. not finite."""


class FormulationLimitError(ArithmeticError):
    """A formulation's coordinates break down (the paper's xC, yC at the equator)."""


class StepFailure(ArithmeticError):
    """An integration step could not meet its tolerance or produced non-finite values."""
