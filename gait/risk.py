"""Fall-risk assessment: each indicator against a published threshold, combined into a level.

Every threshold is listed in :data:`THRESHOLDS` with its source (also in ``docs/gait.md``).
The level is ``high`` when any high-level reason applies or three or more moderate ones do,
``moderate`` with one or two moderate reasons, ``low`` when at least one indicator could be
evaluated and none applies, and ``unknown`` when nothing could be evaluated. Personal baselines
(change from a resident's own history) belong to the service, not here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gait.result import TUG, Fall, Reason, RiskAssessment, Summary


@dataclass(frozen=True)
class Threshold:
    indicator: str
    comparison: str
    threshold: float
    level: str
    source: str
    message: str


THRESHOLDS: tuple[Threshold, ...] = (
    Threshold(
        "walking_speed_m_s",
        "<",
        0.8,
        "high",
        "Abellan van Kan et al. 2009, J Nutr Health Aging 13:881-889 (IANA Task Force); "
        "Studenski et al. 2011, JAMA 305:50-58",
        "gait speed below 0.8 m/s",
    ),
    Threshold(
        "walking_speed_m_s",
        "<",
        1.0,
        "moderate",
        "Cesari et al. 2005, J Am Geriatr Soc 53:1675-1680 (Health ABC)",
        "gait speed below 1.0 m/s",
    ),
    Threshold(
        "tug_s",
        ">=",
        13.5,
        "high",
        "Shumway-Cook, Brauer & Woollacott 2000, Phys Ther 80:896-903",
        "Timed Up and Go of 13.5 s or more",
    ),
    Threshold(
        "stride_time_cv_pct",
        ">",
        3.0,
        "moderate",
        "Hausdorff et al. 2001, Arch Phys Med Rehabil 82:1050-1056; Hausdorff 2005, "
        "J NeuroEng Rehabil 2:19 (healthy adults about 1-3 %)",
        "stride-time variability above 3 %",
    ),
    Threshold(
        "double_support_pct",
        ">",
        30.0,
        "moderate",
        "Maki 1997, J Am Geriatr Soc 45:313-320; norms about 20-25 % of the stride "
        "(Perry & Burnfield 2010)",
        "double support above 30 % of the stride",
    ),
)

_OPS = {
    "<": lambda a, b: a < b,
    "<=": lambda a, b: a <= b,
    ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b,
}


def assess(summary: Summary, tugs: list[TUG], falls: list[Fall]) -> RiskAssessment:
    """Fall-risk level with the reasons, from a recording's summary, TUGs and falls."""
    values: dict[str, float | None] = {
        "walking_speed_m_s": summary.walking_speed_m_s,
        "stride_time_cv_pct": summary.stride_time_cv_pct if summary.n_strides >= 4 else None,
        "double_support_pct": summary.double_support_pct,
        "tug_s": max((t.duration_s for t in tugs), default=None),
    }
    reasons: list[Reason] = []
    evaluated = sorted(k for k, v in values.items() if v is not None and math.isfinite(v))
    done: set[str] = set()
    for th in THRESHOLDS:
        v = values.get(th.indicator)
        if v is None or not math.isfinite(v) or th.indicator in done:
            continue
        if _OPS[th.comparison](v, th.threshold):
            done.add(th.indicator)  # the most severe threshold of an indicator comes first
            reasons.append(
                Reason(
                    indicator=th.indicator,
                    value=v,
                    threshold=th.threshold,
                    comparison=th.comparison,  # type: ignore[arg-type]
                    level=th.level,  # type: ignore[arg-type]
                    source=th.source,
                    message=f"{th.message} ({v:.2f})",
                )
            )
    if falls:
        evaluated.append("falls")
        worst = max(falls, key=lambda f: f.on_floor_s)
        reasons.append(
            Reason(
                indicator="falls",
                value=float(len(falls)),
                threshold=1.0,
                comparison=">=",
                level="high",
                source="Tinetti, Speechley & Ginter 1988, N Engl J Med 319:1701-1707 "
                "(a previous fall is a leading risk factor)",
                message=f"{len(falls)} fall(s) seen"
                + (f", long lie of {worst.on_floor_s:.0f} s" if worst.long_lie else ""),
            )
        )
    n_high = sum(r.level == "high" for r in reasons)
    n_mod = sum(r.level == "moderate" for r in reasons)
    if n_high or n_mod >= 3:
        level = "high"
    elif n_mod:
        level = "moderate"
    elif evaluated:
        level = "low"
    else:
        level = "unknown"
    return RiskAssessment(level=level, reasons=reasons, evaluated=evaluated)  # type: ignore[arg-type]
