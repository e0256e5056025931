"""Exceptions whose message is one sentence a user can act on.

The CLI and the nodes print ``str(error)`` without a traceback.
"""


class PendulumAccelError(Exception):
    """Base of every error this package raises on purpose."""


class ParameterError(PendulumAccelError, ValueError):
    """An impossible physical or numerical parameter (NaN, inf, length <= 0, ...).

    ``path`` is the offending field's name relative to what was being read (e.g. ``'a'`` of an
    acceleration profile), when the raiser knows it; a caller nests it into its own path.
    """

    def __init__(self, message: str, *, path: str | None = None) -> None:
        """The one-line message, plus the field path as data (None: not tied to one field)."""
        super().__init__(message)
        self.path = path


class StabilityError(PendulumAccelError, ValueError):
    """A fixed step past the method's linear stability limit."""


class SceneError(PendulumAccelError, ValueError):
    """A scene file that is missing, malformed or fails validation."""


class BagError(PendulumAccelError):
    """A bag that cannot be read, written or repaired: the base of the bag library's own errors
    (``pendulum_accel.bag.errors``: ReaderError, WriterError, RepairError, ExportError)."""


class SeveralChainsError(BagError):
    """A bag holding several chains where one chain's topic is asked for; ``namespaces``: theirs."""

    def __init__(self, message: str, namespaces: list[str]) -> None:
        """BagError(message), remembering the chains' namespaces."""
        super().__init__(message)
        self.namespaces = namespaces


class RosMissingError(PendulumAccelError):
    """rclpy is not importable: the live chain cannot start."""


class OutputError(PendulumAccelError):
    """An output that cannot be written (disk full, read-only, a directory where a file goes)."""


class IllConditionedError(PendulumAccelError):
    """Inputs so ill-conditioned that one ulp of them moves θ by more than the accuracy target."""
