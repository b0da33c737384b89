"""Alert life cycle: open -> acknowledged -> resolved, recording who, when and a note.

An open alert may also be resolved directly. Anything else (acknowledging a resolved alert,
resolving twice) is refused with :class:`AlertTransitionError`; the rules that raise alerts are
in ``service.db.rules``.
"""

from __future__ import annotations

from gaitwatch.errors import InputError
from service.db.models import Alert, AlertState, utcnow

TRANSITIONS: dict[str, dict[str, AlertState]] = {
    "acknowledge": {AlertState.open.value: AlertState.acknowledged},
    "resolve": {
        AlertState.open.value: AlertState.resolved,
        AlertState.acknowledged.value: AlertState.resolved,
    },
}


class AlertTransitionError(InputError):
    """The alert is not in a state that allows the action."""


def apply(alert: Alert, action: str, *, who: str, note: str | None) -> Alert:
    """Acknowledge or resolve ``alert`` (the caller commits).

    Raises
    ------
    AlertTransitionError
        The action is not allowed from the alert's current state (nothing changes).
    """
    allowed = TRANSITIONS.get(action)
    if allowed is None:
        raise ValueError(f"unknown alert action {action!r}")
    new = allowed.get(alert.state)
    if new is None:
        raise AlertTransitionError(f"alert {alert.id} is {alert.state}: cannot {action} it")
    now = utcnow()
    if new is AlertState.acknowledged:
        alert.acknowledged_by, alert.acknowledged_at, alert.acknowledge_note = who, now, note
    else:
        alert.resolved_by, alert.resolved_at, alert.resolve_note = who, now, note
    alert.state = new.value
    return alert
