"""OpenSim ``.mot`` / ``.sto`` tables, and foot-contact events from ground reaction forces.

A ``.mot`` file is a header (free text lines, ``key=value`` lines such as ``inDegrees=yes``)
closed by ``endheader``, then a line of column names and rows of numbers. Joint-angle files
(``hip_flexion_r``, ``knee_angle_r`` ... in degrees) and ground-reaction files (``*_vx``,
``*_vy``, ``*_vz`` force, ``*_px``, ``*_py``, ``*_pz`` centre of pressure) share the format.

Contact events: a foot is on a plate while the plate's vertical force (OpenSim y up) exceeds
``threshold_n`` (20 N by default); the rising edge is a heel strike, the falling edge a toe
off. Which foot loads which force series comes from the column name when it says so
(``ground_force_r_vy`` / ``l_ground_force_vy``) and otherwise from the markers: the centre of
pressure lies under the foot that stands on the plate.
"""

from __future__ import annotations

import logging
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitwatch.mocap.common import MocapFormatError, sort_events
from gaitwatch.mocap.mapping import resolve_roles
from gaitwatch.trajectory import Trajectory

log = logging.getLogger(__name__)


@dataclass
class MotTable:
    """A ``.mot`` table: column names, the numbers, and the header's ``key=value`` entries."""

    columns: list[str]
    data: np.ndarray
    header: dict[str, str] = field(default_factory=dict)

    def column(self, name: str) -> np.ndarray:
        try:
            return self.data[:, self.columns.index(name)]
        except ValueError:
            raise KeyError(f"no column {name!r}") from None

    @property
    def time(self) -> np.ndarray:
        return self.column("time")


def read_mot_table(path: str | Path) -> MotTable:
    """Read a ``.mot`` file with its header.

    Raises
    ------
    MocapFormatError
        Naming the file and line for a malformed file. FileNotFoundError for a missing one.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    lines = path.read_text(errors="replace").splitlines()
    header: dict[str, str] = {}
    end = None
    for i, line in enumerate(lines):
        s = line.strip()
        if s.lower() == "endheader":
            end = i
            break
        if "=" in s:
            k, v = s.split("=", 1)
            header[k.strip()] = v.strip()
    if end is None:
        raise MocapFormatError(f"{path}: no 'endheader' line: not an OpenSim .mot file")
    names_i = end + 1
    while names_i < len(lines) and not lines[names_i].strip():
        names_i += 1
    if names_i >= len(lines):
        raise MocapFormatError(f"{path}: no column names after 'endheader'")
    columns = lines[names_i].split()
    rows = []
    for lineno, line in enumerate(lines[names_i + 1 :], start=names_i + 2):
        if not line.strip():
            continue
        f = line.split()
        if len(f) != len(columns):
            raise MocapFormatError(
                f"{path}:{lineno}: {len(f)} fields, expected {len(columns)} (one per column)"
            )
        try:
            rows.append([float(v) for v in f])
        except ValueError:
            raise MocapFormatError(f"{path}:{lineno}: a field is not a number") from None
    if not rows:
        raise MocapFormatError(f"{path}: no data rows")
    return MotTable(columns=columns, data=np.asarray(rows, dtype=float), header=header)


def read_mot(path: str | Path) -> tuple[list[str], np.ndarray]:
    """Column names and data (shape (rows, columns)) of an OpenSim ``.mot`` file.

    The first column is normally ``time`` (seconds). Angles stay in the file's units (see the
    header's ``inDegrees``; :func:`read_mot_table` returns the header too).
    """
    t = read_mot_table(path)
    return t.columns, t.data


_VY = re.compile(r"^(?P<prefix>.*?)(?P<kind>force)_(?P<side>[rl]_)?vy$", re.IGNORECASE)


@dataclass
class ForceSeries:
    """One force plate's (or foot's) vertical force and centre of pressure."""

    name: str
    vy: np.ndarray
    cop: np.ndarray | None  # (n, 3) laboratory frame, file units
    side: str | None


def force_series(table: MotTable) -> list[ForceSeries]:
    """The vertical-force series of a ground-reaction table, with their centres of pressure.

    A column ``<p>force_vy`` or ``<p>force_<s>_vy`` is a vertical force; ``<p>force_px/py/pz``
    (same prefix and side) its centre of pressure. The side is read from ``_r_``/``_l_`` in the
    name or an ``r_``/``l_`` prefix, else left None.
    """
    out = []
    for name in table.columns:
        m = _VY.match(name)
        if not m:
            continue
        base = name[: -len("vy")]
        cop = None
        if all(base + c in table.columns for c in ("px", "py", "pz")):
            cop = np.stack([table.column(base + c) for c in ("px", "py", "pz")], axis=1)
        side = None
        tag = (m.group("side") or "").lower()
        pre = m.group("prefix").lower()
        if tag == "r_" or pre.startswith(("r_", "right")):
            side = "right"
        elif tag == "l_" or pre.startswith(("l_", "left")):
            side = "left"
        out.append(ForceSeries(name=name, vy=table.column(name), cop=cop, side=side))
    return out


def contact_intervals(
    time: np.ndarray, force: np.ndarray, threshold_n: float = 20.0, min_duration_s: float = 0.05
) -> list[tuple[float, float, bool, bool]]:
    """Intervals where ``force > threshold_n``.

    Gaps shorter than ``min_duration_s`` are bridged and contacts shorter than it dropped (noise
    at the threshold). Returns ``(start_s, end_s, starts_in_recording, ends_in_recording)``:
    a contact already under way at the first sample or still under way at the last has no
    observed heel strike or toe off there.
    """
    on = np.asarray(force, float) > threshold_n
    if on.size == 0:
        return []
    d = np.diff(on.astype(np.int8))
    starts = list(np.flatnonzero(d == 1) + 1)
    ends = list(np.flatnonzero(d == -1) + 1)
    if on[0]:
        starts.insert(0, 0)
    if on[-1]:
        ends.append(on.size)
    iv = [[s, e] for s, e in zip(starts, ends, strict=True)]
    merged: list[list[int]] = []
    for s, e in iv:
        if merged and time[s] - time[merged[-1][1] - 1] < min_duration_s:
            merged[-1][1] = e
        else:
            merged.append([s, e])
    out = []
    for s, e in merged:
        if time[e - 1] - time[s] < min_duration_s:
            continue
        out.append((float(time[s]), float(time[e - 1]), s > 0, e < on.size))
    return out


def _assign_sides(
    series: list[ForceSeries],
    time: np.ndarray,
    threshold_n: float,
    feet: dict[str, np.ndarray] | None,
    foot_times: np.ndarray | None,
) -> None:
    """Fill in ``side`` of series that lack it, from where the feet are during contact."""
    todo = [s for s in series if s.side is None]
    if not todo:
        return
    if feet is None or foot_times is None:
        names = ", ".join(s.name for s in todo)
        raise MocapFormatError(
            f"cannot tell which foot loads {names}: the column names do not say; "
            "give the markers (load_trc_with_grf) so the centre of pressure can decide"
        )
    for s in todo:
        if s.cop is None:
            raise MocapFormatError(f"{s.name}: no centre-of-pressure columns to assign a foot")
        on = s.vy > threshold_n
        # Sample the contact at most ~200 times.
        idx = np.flatnonzero(on)[:: max(1, int(on.sum() // 200))]
        if idx.size == 0:
            s.side = None
            continue
        cost = {}
        for side, foot in feet.items():
            fi = np.clip(np.searchsorted(foot_times, time[idx]), 0, len(foot_times) - 1)
            best = np.inf
            for scale in (1.0, 0.001):  # centre of pressure in m or mm
                cop = s.cop[idx] * scale
                d = np.linalg.norm((cop - foot[fi])[:, [0, 2]], axis=1)  # horizontal (y up)
                if np.isfinite(d).any():
                    best = min(best, float(np.nanmedian(d)))
            cost[side] = best
        s.side = min(cost, key=cost.get)
        log.info("%s: loads the %s foot (median COP-foot distance %s)", s.name, s.side, cost)
    sides = [s.side for s in series if s.side]
    if len(series) == 2 and len(set(sides)) == 1:
        log.warning("both force series were assigned to the %s foot", sides[0])


def grf_contact_events(
    table: MotTable,
    threshold_n: float = 20.0,
    *,
    feet: dict[str, np.ndarray] | None = None,
    foot_times: np.ndarray | None = None,
    time_offset_s: float = 0.0,
) -> list[dict]:
    """Heel strikes and toe offs from the vertical ground reaction forces.

    Parameters
    ----------
    table : MotTable
        A ground-reaction ``.mot`` (OpenSim: y is vertical).
    threshold_n : float
        Contact while the vertical force exceeds it (newtons).
    feet : dict, optional
        ``{"left": (T, 3), "right": (T, 3)}`` foot positions (e.g. heel-toe mid-points) in the
        same laboratory frame as the force file, metres; needed when the column names do not
        say which foot loads which series.
    foot_times : ndarray, shape (T,), optional
        Times of ``feet`` on the force file's clock.
    time_offset_s : float
        Subtracted from the event times (the time of the first marker frame).

    Returns
    -------
    list of dict
        ``{"side", "type", "time_s"}`` sorted by time; only edges inside the recording.
    """
    series = force_series(table)
    if not series:
        raise MocapFormatError("no vertical force column (*force_vy) in the table")
    time = table.time
    _assign_sides(series, time, threshold_n, feet, foot_times)
    events = []
    for s in series:
        if s.side is None:
            continue
        for t0, t1, has_start, has_end in contact_intervals(time, s.vy, threshold_n):
            if has_start:
                events.append({"side": s.side, "type": "heel_strike", "time_s": t0 - time_offset_s})
            if has_end:
                events.append({"side": s.side, "type": "toe_off", "time_s": t1 - time_offset_s})
    return sort_events(events)


def load_trc_with_grf(
    trc: str | Path, grf: str | Path, threshold_n: float = 20.0, **kw
) -> Trajectory:
    """A TRC recording with foot-contact events from its ground-reaction ``.mot`` file.

    Events outside the marker recording are dropped; event times are relative to the first
    marker frame (the TRC's first Time value is the common zero of both files).

    Parameters
    ----------
    trc, grf : str or Path
    threshold_n : float
        Vertical force (N) above which a foot is in contact.
    **kw
        Passed to :func:`gaitwatch.mocap.trc.load_trc`.
    """
    from gaitwatch.mocap.trc import load_trc, read_trc

    m = read_trc(trc)
    r = resolve_roles(m.markers())
    feet = {}
    for side in ("left", "right"):
        S = side[0].upper()
        pts = [
            r[f"{S}_{k}"] for k in ("HEE", "TOE", "MT1", "MT5", "TOETIP", "ANK") if f"{S}_{k}" in r
        ]
        if pts:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # all markers missing
                feet[side] = np.nanmean(np.stack(pts), axis=0)
    try:
        table = read_mot_table(grf)
        events = grf_contact_events(
            table,
            threshold_n,
            feet=feet or None,
            foot_times=m.times,
            time_offset_s=float(m.times[0]),
        )
    except MocapFormatError as exc:
        if str(exc).startswith(str(grf)):
            raise
        raise MocapFormatError(f"{grf}: {exc}") from None
    duration = (m.frames[-1] - m.frames[0]) / m.rate
    events = [e for e in events if -0.5 / m.rate <= e["time_s"] <= duration + 0.5 / m.rate]
    for e in events:
        e["time_s"] = float(np.clip(e["time_s"], 0.0, duration))
    return load_trc(trc, events=events, **kw)


__all__ = [
    "ForceSeries",
    "MotTable",
    "contact_intervals",
    "force_series",
    "grf_contact_events",
    "load_trc_with_grf",
    "read_mot",
    "read_mot_table",
]
