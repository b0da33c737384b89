"""Marker sets -> the 19 key points of CONVENTIONS.

Marker labels are recognised by role (ASIS, lateral knee, heel ...) through alias tables that
cover Vicon Plug-in Gait and CGM2, Motion Analysis Helen Hayes, Qualisys, OpenSim example marker
sets and a French clinical set (Biogesta: G/D suffixes). A label is normalised before matching:
any "Subject:" prefix removed, punctuation dropped, upper case ("R.Knee.Lat" -> "RKNEELAT").
The documented mapping, per marker set, is in docs/mocap-readers.md.

:func:`markers_to_trajectory` is the pipeline every marker reader (C3D, TRC) ends with:
laboratory frame -> z up -> floor at 0 -> key points.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from gaitwatch.conventions import KP, N_KEYPOINTS
from gaitwatch.mocap import jointcentres as jc
from gaitwatch.mocap.common import (
    MocapFormatError,
    align_walking_to_x,
    detect_vertical,
    estimate_floor,
    floor_levelling,
    sort_events,
    to_z_up,
)
from gaitwatch.trajectory import Trajectory

log = logging.getLogger(__name__)


class MarkerMapOptions(BaseModel):
    """Geometric constants of the marker -> key point mapping (metres unless said otherwise)."""

    model_config = ConfigDict(extra="forbid")

    knee_offset_m: float = Field(
        0.057,
        ge=0,
        le=0.2,
        description="lateral knee marker -> knee centre: (knee width 100 mm "
        "+ marker diameter 14 mm) / 2, Plug-in Gait style, used without a medial marker",
    )
    ankle_offset_m: float = Field(
        0.042,
        ge=0,
        le=0.2,
        description="lateral malleolus marker -> ankle centre: (ankle width "
        "70 mm + marker diameter 14 mm) / 2, used without a medial marker",
    )
    shoulder_drop_m: float = Field(
        0.04,
        ge=0,
        le=0.2,
        description="acromion marker -> shoulder joint centre, along the "
        "trunk (neck -> sacrum) direction",
    )
    head_top_drop_m: float = Field(
        0.10,
        ge=0,
        le=0.3,
        description="top-of-head marker -> head centre, straight down",
    )
    heel_back_ratio: float = Field(
        0.45,
        ge=0,
        le=1.5,
        description="heel behind the ankle as a fraction of the ankle-toe "
        "distance (foot model used when there is no heel marker)",
    )
    max_gap_s: float = Field(
        0.0,
        ge=0,
        le=2.0,
        description="interpolate (linearly) marker gaps up to this long "
        "before mapping; 0 keeps every missing sample NaN (the default)",
    )
    trochanter_medial_fraction: float = Field(
        0.25,
        ge=0,
        le=0.5,
        description="hip centre medial to the greater trochanter, fraction of "
        "the inter-trochanter distance (only when there are no pelvis markers)",
    )


# Role -> alias templates. "{S}" is "L" or "R"; "{F}" is the French suffix "G" (gauche) or
# "D" (droit). Earlier aliases win. Names are matched after normalisation (see _norm).
SIDE_ROLES: dict[str, tuple[str, ...]] = {
    "ASI": ("{S}ASI", "{S}ASIS", "{S}IAS"),
    "PSI": ("{S}PSI", "{S}PSIS", "{S}IPS"),
    "TROCH": ("GT{F}", "{S}GTR", "{S}TROC", "{S}GT"),
    "KNE": ("{S}KNE", "{S}KNEE", "{S}KNEELAT", "{S}LKNE", "{S}LFC", "{S}LEPI", "CDE{F}"),
    "KNM": ("{S}KNM", "{S}MKNE", "{S}KNEEMED", "{S}KNEM", "{S}MFC", "{S}MEPI", "CDI{F}"),
    "ANK": ("{S}ANK", "{S}ANKLE", "{S}ANKLELAT", "{S}LMAL", "{S}LANK", "MAE{F}", "MALE{F}"),
    "MED": ("{S}MED", "{S}MMAL", "{S}ANKLEMED", "{S}MANK", "MAI{F}", "MALI{F}"),
    "HEE": ("{S}HEE", "{S}HEEL", "{S}CAL", "TLN{F}"),
    "TOE": ("{S}TOE", "{S}TO", "{S}MT2", "{S}2MT"),
    "MT1": ("{S}MT1", "{S}FMH", "{S}TOEMED", "{S}1MT", "MT1{F}"),
    "MT5": ("{S}MT5", "{S}VMH", "{S}TOELAT", "{S}5MT", "MT5{F}"),
    "TOETIP": ("{S}TOETIP", "{S}HLX", "{S}TIPTOE"),
    "SHO": ("{S}SHO", "{S}SHOULDER", "{S}ACROMIUM", "{S}ACROMION", "{S}ACR", "EPL{F}"),
    "CLAV": ("{S}CLAVICLE", "{S}CLAV"),
    "ELB": ("{S}ELB", "{S}ELBOW", "{S}LEL", "CD{F}"),
    "WRA": ("{S}WRA", "{S}WRISTMED", "{S}WRM", "{S}USP"),
    "WRB": ("{S}WRB", "{S}WRISTLAT", "{S}WRL", "{S}RSP"),
    "WRI": ("{S}WRI", "{S}WRIST", "PGT{F}"),
    "FHD": ("{S}FHD", "{S}TEMPLE", "TMP{F}"),
    "BHD": ("{S}BHD",),
}
CENTRAL_ROLES: dict[str, tuple[str, ...]] = {
    "SACR": ("SACR", "SACRUM", "VSAC", "VSACRAL", "S2", "SACRAL", "SAC"),
    "C7": ("C7", "CV7", "VC7"),
    "HEAD_FRONT": ("FHEA", "FHEAD", "GLAB"),
    "HEAD_REAR": ("RHEA", "BHEAD"),
    "HEAD_TOP": ("THEA", "TOPHEAD", "HEADTOP", "VERTEX", "THEAD"),
}
SIDES = {"left": ("L", "G"), "right": ("R", "D")}

# Roles that sit high on an upright body, and foot roles: they fix the vertical axis.
UPPER_ROLES = ("ASI", "PSI", "SHO", "SACR", "C7", "HEAD_TOP", "FHD", "HEAD_FRONT", "TROCH")
FOOT_ROLES = ("HEE", "TOE", "MT1", "MT5", "ANK", "MED", "TOETIP")


# Technical clusters on the thigh and shank (used for functional knee centres when there is no
# knee marker): "{S}" + one of these stems + an optional index or position word.
CLUSTER_STEMS = {
    "THIGH": ("THIGH", "TH", "THI", "THA"),
    "SHANK": ("SHANK", "SH", "SK", "TIB", "TIA", "SHA"),
}
_CLUSTER_SUFFIX = r"(\d+|UPPER|LOWER|FRONT|REAR|AP|AD|P|D|ANT|POST|PROX|DIST)?"


def resolve_clusters(markers: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Thigh and shank marker clusters: ``{"L_THIGH": (T, M, 3), ...}`` (M >= 3 only)."""
    out: dict[str, np.ndarray] = {}
    normed = {}
    for label, xyz in markers.items():
        xyz = np.asarray(xyz, float)
        if np.isfinite(xyz).all(axis=-1).any():
            normed.setdefault(_norm(label), xyz)
    for seg, stems in CLUSTER_STEMS.items():
        for side in ("L", "R"):
            pat = re.compile(rf"^{side}({'|'.join(stems)}){_CLUSTER_SUFFIX}$")
            members = [v for k, v in sorted(normed.items()) if pat.match(k)]
            if len(members) >= 3:
                out[f"{side}_{seg}"] = np.stack(members, axis=1)
    return out


def fill_gaps(xyz: np.ndarray, max_gap_frames: int) -> np.ndarray:
    """Linear interpolation of interior runs of missing frames no longer than ``max_gap_frames``.

    Parameters
    ----------
    xyz : ndarray, shape (T, 3)
        NaN where missing.
    max_gap_frames : int

    Returns
    -------
    ndarray, shape (T, 3)
        A copy; leading and trailing gaps and longer gaps stay NaN.
    """
    x = np.array(xyz, dtype=float)
    ok = np.isfinite(x).all(axis=-1)
    if max_gap_frames <= 0 or ok.all() or ok.sum() < 2:
        return x
    idx = np.arange(len(x))
    good = np.flatnonzero(ok)
    nxt = np.searchsorted(good, idx)
    interior = ~ok & (nxt > 0) & (nxt < len(good))
    nxt_c = np.clip(nxt, 1, len(good) - 1)
    gap = good[nxt_c] - good[nxt_c - 1] - 1
    fill = interior & (gap <= max_gap_frames)
    for c in range(3):
        x[fill, c] = np.interp(idx[fill], good, x[good, c])
    return x


def _norm(label: str) -> str:
    """'Subject:R.Knee.Lat ' -> 'RKNEELAT'."""
    return re.sub(r"[^A-Za-z0-9]", "", label.split(":")[-1]).upper()


def resolve_roles(markers: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Marker trajectories by role: keys like ``"L_ASI"``, ``"R_HEE"``, ``"SACR"``.

    Parameters
    ----------
    markers : mapping of label -> ndarray, shape (T, 3)
        Raw labels as in the file. When several labels normalise to the same name, the one with
        the most frames present wins.

    Returns
    -------
    dict
        Only roles that were found and have at least one frame present.
    """
    by_name: dict[str, np.ndarray] = {}
    for label, xyz in markers.items():
        name = _norm(label)
        if not name:
            continue
        xyz = np.asarray(xyz, float)
        have = np.isfinite(xyz).all(axis=-1).sum()
        if have == 0:
            continue
        if name not in by_name or have > np.isfinite(by_name[name]).all(axis=-1).sum():
            by_name[name] = xyz
    out: dict[str, np.ndarray] = {}
    for role, aliases in SIDE_ROLES.items():
        for side, (s, f) in SIDES.items():
            for a in aliases:
                name = a.replace("{S}", s).replace("{F}", f)
                if name in by_name:
                    out[f"{side[0].upper()}_{role}"] = by_name[name]
                    break
    for role, aliases in CENTRAL_ROLES.items():
        for a in aliases:
            if a in by_name:
                out[role] = by_name[a]
                break
    return out


def _pair(r: dict, role: str) -> tuple[np.ndarray | None, np.ndarray | None]:
    return r.get(f"L_{role}"), r.get(f"R_{role}")


def roles_vertical(r: dict[str, np.ndarray], source: str) -> tuple[int, int]:
    """Detect the laboratory vertical from resolved roles (see :func:`detect_vertical`)."""
    upper = [v for k, v in r.items() if k.split("_", 1)[-1] in UPPER_ROLES or k in UPPER_ROLES]
    lower = [v for k, v in r.items() if k.split("_", 1)[-1] in FOOT_ROLES]
    return detect_vertical(upper, lower, source)


def roles_to_keypoints(
    r: dict[str, np.ndarray],
    n_frames: int,
    options: MarkerMapOptions | None = None,
    clusters: dict[str, np.ndarray] | None = None,
) -> tuple[np.ndarray, dict]:
    """Key points from role markers already in the world frame (z up, floor at z = 0).

    Parameters
    ----------
    r : dict
        Output of :func:`resolve_roles`, rotated to z up and shifted to the floor.
    n_frames : int
    options : MarkerMapOptions, optional
    clusters : dict, optional
        Output of :func:`resolve_clusters` in the same frame: thigh and shank clusters give a
        functional knee centre (SCoRE hinge) when there is no knee marker.

    Returns
    -------
    positions : ndarray, shape (T, 19, 3)
        NaN for key points the markers cannot give.
    info : dict
        How each key point was obtained (``info["methods"][name]``) and fitted constants.
    """
    o = options or MarkerMapOptions()
    P = np.full((n_frames, N_KEYPOINTS, 3), np.nan)
    methods: dict[str, str] = {}
    info: dict = {"methods": methods}

    def put(name: str, xyz: np.ndarray | None, how: str) -> None:
        if xyz is not None:
            P[:, KP[name]] = xyz
            methods[name] = how

    # ---- pelvis, hips, sacrum ---------------------------------------------------------------
    lasi, rasi = _pair(r, "ASI")
    lpsi, rpsi = _pair(r, "PSI")
    posterior = None
    if lpsi is not None and rpsi is not None:
        posterior = jc.nanmid(lpsi, rpsi)
        put("sacrum", posterior, "mid-point of the PSIS markers")
    elif "SACR" in r:
        posterior = r["SACR"]
        put("sacrum", posterior, "sacrum marker")
    right_axis = None
    if lasi is not None and rasi is not None:
        lh, rh, hinfo = jc.harrington_hip_centres(lasi, rasi, posterior)
        put("left_hip", lh, hinfo["method"])
        put("right_hip", rh, hinfo["method"])
        info["pelvis"] = hinfo
        right_axis = jc.unit(rasi - lasi)
    else:
        lt, rt = _pair(r, "TROCH")
        if lt is not None and rt is not None:
            lh, rh = jc.hip_centres_from_trochanters(lt, rt, o.trochanter_medial_fraction)
            put("left_hip", lh, "greater trochanter moved medially")
            put("right_hip", rh, "greater trochanter moved medially")
            right_axis = jc.unit(rt - lt)
            if "sacrum" not in methods:
                # Mid-PSIS relative to the mid-hip point from Harrington's regression with
                # PW from the hip-centre distance and PD = 0.62 PW (typical adult ratio).
                hw = jc.nanmedian_scalar(np.linalg.norm(rh - lh, axis=-1)) * 1000.0
                pw = (hw / 2.0 - 7.3) / 0.33
                pd = 0.62 * pw
                mid = jc.nanmid(lh, rh)
                zax = jc.unit(rh - lh)
                yax = jc.unit(jc.Z - np.sum(jc.Z * zax, axis=-1, keepdims=True) * zax)
                xax = np.cross(yax, zax)
                put(
                    "sacrum",
                    mid + ((-0.76 * pd + 9.9) * xax + (0.30 * pw + 10.9) * yax) / 1000.0,
                    "estimated from the hip centres (no pelvis markers)",
                )
    if right_axis is None:
        # Fall back on any left/right marker pair for the subject's right direction.
        for role in ("KNE", "ANK", "HEE", "SHO", "TOE"):
            a, b = _pair(r, role)
            if a is not None and b is not None:
                right_axis = jc.unit(b - a)
                break

    # ---- legs -------------------------------------------------------------------------------
    for side in ("left", "right"):
        S = side[0].upper()
        kne, knm = r.get(f"{S}_KNE"), r.get(f"{S}_KNM")
        if kne is not None and knm is not None:
            put(f"{side}_knee", jc.nanmid(kne, knm), "mid-point of lateral and medial knee")
        elif kne is not None and right_axis is not None:
            put(
                f"{side}_knee",
                jc.offset_medially(kne, right_axis, side, o.knee_offset_m),
                f"lateral knee marker + {o.knee_offset_m * 1000:.0f} mm medially",
            )
        ank, med = r.get(f"{S}_ANK"), r.get(f"{S}_MED")
        if ank is not None and med is not None:
            put(f"{side}_ankle", jc.nanmid(ank, med), "mid-point of the malleoli")
        elif ank is not None and right_axis is not None:
            put(
                f"{side}_ankle",
                jc.offset_medially(ank, right_axis, side, o.ankle_offset_m),
                f"lateral malleolus + {o.ankle_offset_m * 1000:.0f} mm medially",
            )
        # Toe marker (2nd metatarsal head) or the mid-point of the 1st and 5th.
        toe_m, toe_how = r.get(f"{S}_TOE"), "toe marker"
        if toe_m is None and f"{S}_MT1" in r and f"{S}_MT5" in r:
            toe_m, toe_how = jc.nanmid(r[f"{S}_MT1"], r[f"{S}_MT5"]), "mid of 1st and 5th MT"
        if toe_m is None and f"{S}_TOETIP" in r:
            toe_m, toe_how = r[f"{S}_TOETIP"], "toe-tip marker"
        hee = r.get(f"{S}_HEE")
        toe_kp = None
        if toe_m is not None:
            toe_kp, drop = jc.lower_to_sole(
                toe_m, jc.sole_down(hee, toe_m) if hee is not None else jc.sole_down(toe_m, None)
            )
            put(f"{side}_toe", toe_kp, f"{toe_how} lowered {drop * 1000:.0f} mm to the sole")
        if hee is not None:
            heel_kp, drop = jc.lower_to_sole(hee, jc.sole_down(hee, toe_m))
            put(f"{side}_heel", heel_kp, f"heel marker lowered {drop * 1000:.0f} mm to the sole")
        if f"{side}_ankle" not in methods and hee is not None and toe_kp is not None:
            put(
                f"{side}_ankle",
                jc.ankle_from_heel_toe(P[:, KP[f"{side}_heel"]], toe_kp, right=right_axis),
                "foot model from heel and toe (no malleolus markers)",
            )
        if f"{side}_heel" not in methods and f"{side}_ankle" in methods and toe_kp is not None:
            put(
                f"{side}_heel",
                jc.heel_from_ankle_toe(
                    P[:, KP[f"{side}_ankle"]], toe_kp, o.heel_back_ratio, right_axis
                ),
                "foot model from ankle centre and toe (no heel marker)",
            )

    # ---- functional knees from thigh and shank clusters ---------------------------------
    for side in ("left", "right"):
        S = side[0].upper()
        if (
            f"{side}_knee" in methods
            or not clusters
            or f"{S}_THIGH" not in clusters
            or f"{S}_SHANK" not in clusters
            or f"{side}_hip" not in methods
            or f"{side}_ankle" not in methods
        ):
            continue
        R1, t1, _ = jc.segment_poses(clusters[f"{S}_THIGH"])
        R2, t2, _ = jc.segment_poses(clusters[f"{S}_SHANK"])
        knee = jc.hinge_centre(R1, t1, R2, t2, P[:, KP[f"{side}_hip"]], P[:, KP[f"{side}_ankle"]])
        if np.isfinite(knee).any():
            put(f"{side}_knee", knee, "functional: SCoRE hinge axis of thigh/shank clusters")

    # ---- trunk, head, arms ------------------------------------------------------------------
    lsho, rsho = _pair(r, "SHO")
    if "C7" in r:
        put("neck", r["C7"], "C7 marker")
    elif lsho is not None and rsho is not None:
        put("neck", jc.nanmid(lsho, rsho), "mid-point of the shoulder markers")
    else:
        lc, rc = _pair(r, "CLAV")
        if lc is not None and rc is not None:
            put("neck", jc.nanmid(lc, rc), "mid-point of the clavicle markers")
    lf, rf = _pair(r, "FHD")
    lb, rb = _pair(r, "BHD")
    ring = [m for m in (lf, rf, lb, rb, r.get("HEAD_FRONT"), r.get("HEAD_REAR")) if m is not None]
    if len(ring) >= 2:
        put("head", jc.nanmid(*ring), "mean of the head markers")
    elif "HEAD_TOP" in r:
        put("head", r["HEAD_TOP"] - o.head_top_drop_m * jc.Z, "top-of-head marker lowered")
    if "neck" in methods and "sacrum" in methods:
        trunk_down = jc.unit(P[:, KP["sacrum"]] - P[:, KP["neck"]])
        trunk_down = np.where(np.isfinite(trunk_down), trunk_down, -jc.Z)
    else:
        trunk_down = np.broadcast_to(-jc.Z, (n_frames, 3))
    for side in ("left", "right"):
        S = side[0].upper()
        if f"{S}_SHO" in r:
            put(
                f"{side}_shoulder",
                r[f"{S}_SHO"] + o.shoulder_drop_m * trunk_down,
                f"shoulder marker lowered {o.shoulder_drop_m * 1000:.0f} mm along the trunk",
            )
        if f"{S}_ELB" in r:
            put(f"{side}_elbow", r[f"{S}_ELB"], "elbow marker")
        if f"{S}_WRA" in r and f"{S}_WRB" in r:
            put(f"{side}_wrist", jc.nanmid(r[f"{S}_WRA"], r[f"{S}_WRB"]), "mid of wrist markers")
        elif f"{S}_WRI" in r:
            put(f"{side}_wrist", r[f"{S}_WRI"], "wrist marker")
    return P, info


def markers_to_trajectory(
    markers: Mapping[str, np.ndarray],
    times: np.ndarray,
    *,
    fps: float | None,
    source: str,
    events: list[dict] | None = None,
    vertical: tuple[int, int] | None = None,
    align_walking: bool = False,
    options: MarkerMapOptions | dict | None = None,
) -> Trajectory:
    """The common end of the marker readers: laboratory markers (metres) -> :class:`Trajectory`.

    Parameters
    ----------
    markers : mapping of label -> ndarray, shape (T, 3)
        Marker trajectories in the laboratory frame, metres, NaN where missing.
    times : ndarray, shape (T,)
        Seconds from the first frame.
    fps : float or None
    source : str
        File name, for messages and ``Trajectory.source``.
    events : list of dict, optional
        Laboratory events (side, type, time_s), times relative to the first frame.
    vertical : (axis, sign), optional
        The laboratory's up axis; detected from the markers when omitted.
    align_walking : bool
        Rotate about z so that the overall walking direction is +x.
    options : MarkerMapOptions or dict, optional
        Mapping constants (a dict is validated into :class:`MarkerMapOptions`).

    Returns
    -------
    Trajectory
        With ``info`` attached as ``traj.mapping_info`` (methods per key point, vertical axis,
        floor height in the laboratory frame).
    """
    o = (
        options
        if isinstance(options, MarkerMapOptions)
        else MarkerMapOptions.model_validate(options or {})
    )
    if o.max_gap_s > 0 and fps:
        n = int(round(o.max_gap_s * fps))
        markers = {k: fill_gaps(v, n) for k, v in markers.items()}
    r = resolve_roles(markers)
    if not r:
        raise MocapFormatError(f"{source}: no marker label matches a known marker set")
    axis, sign = vertical if vertical is not None else roles_vertical(r, source)
    r = {k: to_z_up(v, axis, sign) for k, v in r.items()}
    clusters = {k: to_z_up(v, axis, sign) for k, v in resolve_clusters(markers).items()}
    levelling, tilt = floor_levelling(
        [v for k, v in r.items() if k.split("_", 1)[-1] in FOOT_ROLES]
    )
    if levelling is not None:
        r = {k: levelling(v) for k, v in r.items()}
        clusters = {k: levelling(v) for k, v in clusters.items()}
        log.info("%s: floor tilted by %.2f degrees, levelled", source, tilt)
    foot = [v[..., 2] for k, v in r.items() if k.split("_", 1)[-1] in FOOT_ROLES]
    floor = estimate_floor(foot)
    for v in list(r.values()) + list(clusters.values()):
        v[..., 2] -= floor
    T = len(times)
    P, info = roles_to_keypoints(r, T, o, clusters)
    if align_walking:
        P, _ = align_walking_to_x(P)
    info.update(
        {
            "vertical_axis": "xyz"[axis],
            "vertical_sign": sign,
            "floor_lab_m": floor,
            "floor_tilt_deg": tilt,
            "floor_levelled": levelling is not None,
        }
    )
    missing = [k for k in KP if k not in info["methods"]]
    if missing:
        log.info("%s: no markers for %s (NaN)", source, ", ".join(missing))
    traj = Trajectory(
        positions=P, times=times, fps=fps, source=source, events=sort_events(events or [])
    )
    traj.mapping_info = info  # type: ignore[attr-defined]
    return traj
