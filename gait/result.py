"""Result models of gait analysis (pydantic), and their JSON form.

Field names are a stable contract (the service stores :class:`GaitReport` JSON; see
``docs/gait.md``). Units are in the names: ``_s`` seconds, ``_m`` metres, ``_m_s`` m/s,
``_deg`` degrees, ``_pct`` percent, ``_steps_min`` steps per minute. A value that cannot be
computed is ``None`` (``null`` in JSON); NaN never appears in a model.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

from gaitwatch.conventions import GAIT_JSON_FIELDS


def _nan_to_none(v: object) -> object:
    if v is None:
        return None
    try:
        f = float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return v
    return None if not math.isfinite(f) else f


Num = Annotated[float | None, BeforeValidator(_nan_to_none)]
"""A float that is ``None`` when unknown (NaN and infinities become ``None``)."""

Side = Literal["left", "right"]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Event(_Model):
    """A gait event (CONVENTIONS): heel strike or toe off of one foot."""

    side: Side
    type: Literal["heel_strike", "toe_off"]
    time_s: float = Field(description="seconds from the first frame")


class GaitParameters(_Model):
    """Spatiotemporal parameters over a set of strides (a bout, or the whole recording).

    The first ten fields are CONVENTIONS ``GAIT_JSON_FIELDS``.
    """

    walking_speed_m_s: Num = Field(None, description="total stride length / total stride time")
    cadence_steps_min: Num = Field(None, description="120 / mean stride time")
    stride_length_m: Num = Field(None, description="mean heel-to-heel distance of one foot")
    step_length_m: Num = Field(None, description="mean step length along the stride direction")
    step_width_m: Num = Field(None, description="mean step width across the stride direction")
    stride_time_s: Num = Field(None, description="mean heel strike to next heel strike, one foot")
    stance_pct: Num = Field(None, description="mean stance phase, % of stride")
    swing_pct: Num = Field(None, description="mean swing phase, % of stride")
    double_support_pct: Num = Field(None, description="mean double support, % of stride")
    stride_time_cv_pct: Num = Field(None, description="coefficient of variation of stride time")
    step_time_s: Num = None
    stride_time_sd_s: Num = None
    stride_length_sd_m: Num = None
    stride_length_cv_pct: Num = None
    step_length_sd_m: Num = None
    step_length_cv_pct: Num = None
    step_width_sd_m: Num = None
    step_width_cv_pct: Num = None
    step_length_symmetry_pct: Num = Field(
        None, description="100 |L - R| / mean(L, R) of mean step lengths (0 = symmetric)"
    )
    step_time_symmetry_pct: Num = Field(None, description="as above, for step times")
    stance_symmetry_pct: Num = Field(None, description="as above, for stance percentages")
    n_strides: int = 0
    n_steps: int = 0


class KinematicsSummary(_Model):
    """Joint-angle and trunk indicators averaged over strides (degrees)."""

    knee_peak_swing_flexion_deg: Num = None
    knee_min_stance_flexion_deg: Num = None
    knee_flexion_at_heel_strike_deg: Num = None
    knee_rom_deg: Num = None
    hip_rom_deg: Num = None
    hip_peak_extension_deg: Num = Field(None, description="minimum hip flexion (negative=ext.)")
    hip_peak_flexion_deg: Num = None
    trunk_lean_deg: Num = Field(None, description="mean forward lean of the trunk from vertical")
    trunk_sway_ml_deg: Num = Field(None, description="SD of sideways trunk lean")
    trunk_sway_ap_deg: Num = Field(None, description="SD of forward trunk lean")
    trunk_sway_ml_range_deg: Num = None
    trunk_sway_ap_range_deg: Num = None
    knee_curve_left_deg: list[Num] | None = Field(
        None, description="mean knee flexion over the stride, 101 samples 0..100 %"
    )
    knee_curve_right_deg: list[Num] | None = None
    hip_curve_left_deg: list[Num] | None = None
    hip_curve_right_deg: list[Num] | None = None


class BalanceSummary(_Model):
    """Margin of stability (Hof et al. 2005) over the steps of a bout, metres."""

    mos_ml_mean_m: Num = None
    mos_ml_min_m: Num = None
    mos_ml_sd_m: Num = None
    mos_ap_mean_m: Num = None
    mos_ap_min_m: Num = None
    n_steps: int = 0


class Stride(_Model):
    """One stride: heel strike of ``side`` to its next heel strike."""

    side: Side
    start_s: float
    end_s: float
    bout: int | None = Field(None, description="index into ``bouts``; None outside bouts")
    stride_time_s: Num = None
    stride_length_m: Num = None
    walking_speed_m_s: Num = None
    stance_pct: Num = None
    swing_pct: Num = None
    double_support_pct: Num = None
    step_length_m: Num = Field(None, description="step ending at the contralateral heel strike")
    step_width_m: Num = None
    step_time_s: Num = None
    turn_deg: Num = Field(None, description="change of walking direction over the stride")
    knee_peak_swing_flexion_deg: Num = None
    knee_min_stance_flexion_deg: Num = None
    knee_rom_deg: Num = None
    hip_rom_deg: Num = None
    mos_ml_m: Num = Field(None, description="mediolateral margin of stability at this heel strike")
    mos_ap_m: Num = Field(None, description="anteroposterior margin of stability at heel strike")


class Bout(GaitParameters):
    """A walking bout: consecutive straight strides (>= 2). Carries ``GAIT_JSON_FIELDS``."""

    start_s: float
    end_s: float
    distance_m: Num = None
    kinematics: KinematicsSummary = Field(default_factory=KinematicsSummary)
    balance: BalanceSummary = Field(default_factory=BalanceSummary)


class Activity(_Model):
    """A segment of the recording with one activity."""

    type: Literal["walking", "turning", "standing", "sitting", "lying", "transfer", "unknown"]
    start_s: float
    end_s: float


class Transfer(_Model):
    """A sit-to-stand or stand-to-sit movement."""

    type: Literal["sit_to_stand", "stand_to_sit"]
    start_s: float
    end_s: float
    duration_s: float


class TUG(_Model):
    """A Timed-Up-and-Go-like sequence found in free living: rise, walk, (turn), walk, sit."""

    start_s: float
    end_s: float
    duration_s: float
    walk_distance_m: Num = None
    turn_deg: Num = None
    includes_turn: bool = False


class Fall(_Model):
    """A fall: fast descent of sacrum and head ending near the floor."""

    start_s: float
    impact_s: float
    peak_descent_speed_m_s: float
    on_floor_s: float = Field(description="how long the person stayed on the floor after it")
    long_lie: bool
    got_up: bool


class Reason(_Model):
    """One indicator compared with its published threshold."""

    indicator: str
    value: Num
    threshold: float
    comparison: Literal["<", "<=", ">", ">="]
    level: Literal["moderate", "high"]
    source: str
    message: str


class RiskAssessment(_Model):
    """Fall-risk level from the indicators with the reasons that raised it."""

    level: Literal["unknown", "low", "moderate", "high"]
    reasons: list[Reason] = Field(default_factory=list)
    evaluated: list[str] = Field(
        default_factory=list, description="indicators that could be evaluated"
    )


class Summary(GaitParameters):
    """The whole recording: parameters over the strides of all bouts, and recording facts."""

    n_bouts: int = 0
    walking_time_s: float = 0.0
    duration_s: float = 0.0
    fps: Num = None
    kinematics: KinematicsSummary = Field(default_factory=KinematicsSummary)
    balance: BalanceSummary = Field(default_factory=BalanceSummary)


class GaitReport(_Model):
    """Everything :func:`gait.analysis.analyse` finds in one recording.

    ``bouts``, ``events`` and ``summary`` are the CONVENTIONS ``gait --json`` object; the other
    keys are extras documented in ``docs/gait.md``.
    """

    bouts: list[Bout] = Field(default_factory=list)
    events: list[Event] = Field(default_factory=list)
    summary: Summary = Field(default_factory=Summary)
    strides: list[Stride] = Field(default_factory=list)
    activities: list[Activity] = Field(default_factory=list)
    transfers: list[Transfer] = Field(default_factory=list)
    tug: list[TUG] = Field(default_factory=list)
    falls: list[Fall] = Field(default_factory=list)
    risk: RiskAssessment = Field(default_factory=lambda: RiskAssessment(level="unknown"))
    source: str = ""
    version: int = Field(1, description="schema version of this report")

    def to_json_dict(self) -> dict:
        """The JSON-ready dict (``None`` for unknown values)."""
        return self.model_dump(mode="json")

    def to_json(self, indent: int | None = 2) -> str:
        return self.model_dump_json(indent=indent)


assert all(f in GaitParameters.model_fields for f in GAIT_JSON_FIELDS)
