"""Real-time scheduling of a node process, asked for through one environment variable.

No ROS import. ``nodes.runtime.run_node`` takes the priority for the thread that spins the executor
(every callback runs there) once the node exists; ``pendulum-accel run --rt-priority N`` sets the
variable for every node of a real-time run.
"""

from __future__ import annotations

import os

RT_PRIORITY_ENV = "PENDULUM_ACCEL_RT_PRIORITY"


def apply_rt_priority() -> str | None:
    """SCHED_FIFO at priority $PENDULUM_ACCEL_RT_PRIORITY (1–99) for the calling thread; None, or why not.

    Unset or 0: nothing. A node at normal priority waits behind whatever else is runnable when its sample
    arrives; at SCHED_FIFO it runs first (the 1 kHz chain's latency with and without it:
    docs/benchmarks/chain.md). Threads started later by this one inherit the policy.
    """
    value = os.environ.get(RT_PRIORITY_ENV, "").strip()
    if value in ("", "0"):
        return None
    try:
        priority = int(value)
    except ValueError:
        priority = 0
    if not 1 <= priority <= 99:
        return f"ignoring {RT_PRIORITY_ENV}={value!r}: not an integer from 1 to 99"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as err:
        return (
            f"cannot take real-time priority {priority} ({err.strerror}; needs root, CAP_SYS_NICE or an "
            f"rtprio limit): running at normal priority"
        )
    return None
