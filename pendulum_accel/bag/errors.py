"""The bag library's errors: what reading, writing, repairing or exporting a bag raises.

As rosbags keeps ``ReaderError`` and ``WriterError`` in ``rosbag2/errors.py``, bag/ raises its own
types, each with a one-line message a user can act on. Their base is the package's ``BagError``
(``pendulum_accel.errors``), re-exported here: ``except BagError`` catches every one of them, and so
does the CLI's one handler of ``PendulumAccelError`` (one line, exit code 2). This module is the bag
library's only seam to the package around it; lifted out alone, it would define ``BagError`` itself.
"""

from __future__ import annotations

from pendulum_accel.errors import BagError, ParameterError, SeveralChainsError

__all__ = [
    "BagError",
    "ExportError",
    "MalformedRecordError",
    "NotIndexedError",
    "ParameterError",
    "ReaderError",
    "RepairError",
    "SeveralChainsError",
    "WriterError",
]


class ReaderError(BagError):
    """A bag that cannot be read: missing, not MCAP, a topic it lacks, a file changed since it was read."""


class MalformedRecordError(ReaderError):
    """A malformed MCAP record (framing, lengths, a CRC, an unknown channel): the reader notes the damage
    and keeps what is intact; it never reaches a caller of ``read_bag``."""


class NotIndexedError(ReaderError):
    """The bag has no summary with a chunk index (a killed recording): it cannot be streamed."""


class WriterError(BagError):
    """A bag that cannot be written: it exists, is being recorded, or a topic or time is invalid."""


class RepairError(BagError):
    """A bag that cannot be repaired (not a bag directory, nothing a repair can rebuild)."""


class ExportError(BagError):
    """Export impossible: a missing optional dependency, an unknown format or topic."""
