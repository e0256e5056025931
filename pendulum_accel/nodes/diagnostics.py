"""The estimator node's input health on /diagnostics: one DiagnosticStatus per report, named by the node."""

from __future__ import annotations

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from pendulum_accel.estimators.guard import GuardReport

HARDWARE_ID = "pendulum_accel"


def hardware_id_of(parameter: str, namespace: str) -> str:
    """The status's hardware_id: the parameter, else 'pendulum_accel' followed by a namespace ('/car1')."""
    return parameter or HARDWARE_ID + (namespace if namespace != "/" else "")


def status_name(fully_qualified_name: str) -> str:
    """The status's name: the node's fully qualified name without its leading '/' ('accel_estimator',
    'car1/accel_estimator'), as diagnostic_updater named a node's statuses (the full name's substr(1),
    ros/diagnostics#109) and as generated and golden bags name it, so a PlotJuggler layout's series
    (<hardware_id>/<name>/<key>) are the same in a live bag and a generated one; the namespace still tells
    two chains apart."""
    return fully_qualified_name.lstrip("/")


def diagnostic_array(
    report: GuardReport, method: str, stamp: Time, latency: float, name: str, hardware_id: str, lost: int = 0
) -> DiagnosticArray:
    """DiagnosticArray with one status named ``name`` (``status_name``: the node's full name, so an
    aggregator tells two chains apart): level and message from the guard, counters, method, latency (s)
    and the angles the middleware reported lost (a best-effort input)."""
    status = DiagnosticStatus(
        level=bytes([report.level]),
        name=name,
        message=f"{report.state.value}: {report.message}",
        hardware_id=hardware_id,
        values=[
            KeyValue(key="method", value=method),
            KeyValue(key="latency_s", value=f"{latency:g}"),
            KeyValue(key="state", value=report.state.value),
            KeyValue(key="lost", value=str(lost)),
        ]
        + [KeyValue(key=k, value=v) for k, v in report.values],
    )
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = stamp
    return msg
