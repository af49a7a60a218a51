"""Exceptions raised by kinbox. Every one names the problem in its message."""


class KinboxError(Exception):
    """Base class of all kinbox errors: bad input or a problem kinbox cannot formulate."""


class ModelError(KinboxError):
    """A robot or mechanism could not be loaded: unknown name, malformed file, bad numbers."""


class NameNotFound(KinboxError):
    """An unknown frame, joint, link or robot name."""


class FormulationError(KinboxError):
    """A mechanism cannot be turned into a polynomial system (unsupported joint, bad closure)."""


class InputError(KinboxError):
    """A malformed argument: non-finite numbers, non-unit quaternion, wrong vector length."""
