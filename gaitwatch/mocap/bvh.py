"""BVH reader: a generic HIERARCHY/MOTION parser, forward kinematics over all frames at once,
and the mapping of CMU-like (and other common) skeletons to the 19 key points.

Conventions of the format, as implemented:

* Each joint's ``CHANNELS`` list gives the order of the values in a MOTION row and, for the
  rotation channels, the order of composition: ``Zrotation Yrotation Xrotation`` means
  ``R_local = Rz @ Ry @ Rx`` (angles in degrees) acting on column vectors, so a point ``p`` in
  the joint's frame is ``R_local @ p + t_local`` in its parent's frame.
* ``t_local`` is the joint's OFFSET; position channels, where a joint has them (the root, or
  every joint in some exporters), replace the corresponding OFFSET component.
* ``End Site`` blocks become leaf joints named ``<parent>_End`` without channels.

Units: the CMU conversions use the ASF length unit, 0.056444 m (README of the CMU database
mirror); other skeletons are scaled from their standing height (see :func:`guess_scale`).
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitwatch.conventions import KP, N_KEYPOINTS
from gaitwatch.mocap import jointcentres as jc
from gaitwatch.mocap.common import (
    MocapFormatError,
    detect_vertical,
    estimate_floor,
    floor_levelling,
    to_z_up,
)
from gaitwatch.mocap.common import align_walking_to_x as _align_walking
from gaitwatch.trajectory import Trajectory

log = logging.getLogger(__name__)

CMU_SCALE_M = 0.056444

#: CMU skeleton: the sacrum (mid-point of the posterior iliac spines) is this fraction of the leg
#: length (thigh + shank) behind the mid-point of the hip joint centres. The skeleton has no such
#: point: its root (Hips) sits at the pelvis centre, 37 mm behind the hip joints. The marker
#: recordings of ../shared/data put the mid-PSIS 115-158 mm behind the hip joint centres, 0.13,
#: 0.18 and 0.21 of their leg lengths; 0.17 is the mean.
CMU_SACRUM_BEHIND_HIPS_PER_LEG = 0.17
_AXIS = {"x": 0, "y": 1, "z": 2}


@dataclass
class BVHJoint:
    """One joint of the hierarchy."""

    name: str
    parent: int  # index into the joint list, -1 for the root
    offset: np.ndarray  # (3,)
    channels: list[str] = field(default_factory=list)
    first_channel: int = 0  # column of its first channel in the MOTION rows


@dataclass
class BVH:
    """A parsed BVH file.

    Attributes
    ----------
    joints : list of BVHJoint
        Parents come before their children.
    motion : ndarray, shape (T, C)
        The MOTION rows, file units and degrees.
    frame_time : float
        Seconds per frame.
    """

    joints: list[BVHJoint]
    motion: np.ndarray
    frame_time: float

    @property
    def names(self) -> list[str]:
        return [j.name for j in self.joints]

    def index(self, name: str) -> int:
        return self.names.index(name)


def _tokens(text: str):
    for lineno, line in enumerate(text.splitlines(), start=1):
        for tok in line.split():
            yield lineno, tok


def parse_bvh(text: str, source: str = "<bvh>") -> BVH:
    """Parse the text of a BVH file.

    Raises
    ------
    MocapFormatError
        With the source name and line number of the first problem.
    """
    toks = list(_tokens(text))
    pos = 0

    def err(msg: str, at: int | None = None) -> MocapFormatError:
        i = min(pos if at is None else at, len(toks) - 1)
        line = toks[i][0] if toks else 1
        return MocapFormatError(f"{source}:{line}: {msg}")

    def take() -> str:
        nonlocal pos
        if pos >= len(toks):
            raise err("unexpected end of file")
        pos += 1
        return toks[pos - 1][1]

    def expect(word: str) -> None:
        tok = take()
        if tok.upper() != word.upper():
            raise err(f"expected {word!r}, found {tok!r}", pos - 1)

    def number() -> float:
        tok = take()
        try:
            return float(tok)
        except ValueError:
            raise err(f"expected a number, found {tok!r}", pos - 1) from None

    joints: list[BVHJoint] = []
    n_channels = 0

    def joint_body(name: str, parent: int) -> None:
        nonlocal n_channels
        expect("{")
        expect("OFFSET")
        offset = np.array([number(), number(), number()])
        j = BVHJoint(name=name, parent=parent, offset=offset, first_channel=n_channels)
        idx = len(joints)
        joints.append(j)
        while True:
            tok = take()
            up = tok.upper()
            if up == "CHANNELS":
                n = int(number())
                chans = [take() for _ in range(n)]
                for c in chans:
                    if c.lower() not in {
                        "xposition",
                        "yposition",
                        "zposition",
                        "xrotation",
                        "yrotation",
                        "zrotation",
                    }:
                        raise err(f"joint {name}: unknown channel {c!r}", pos - 1)
                j.channels = [c.lower() for c in chans]
                j.first_channel = n_channels
                n_channels += n
            elif up == "JOINT":
                joint_body(take(), idx)
            elif up == "END":
                expect("Site")
                expect("{")
                expect("OFFSET")
                end_off = np.array([number(), number(), number()])
                expect("}")
                joints.append(
                    BVHJoint(name=f"{name}_End", parent=idx, offset=end_off, first_channel=0)
                )
            elif up == "}":
                return
            else:
                raise err(f"joint {name}: unexpected {tok!r}", pos - 1)

    if not toks or toks[0][1].upper() != "HIERARCHY":
        raise MocapFormatError(f"{source}:1: expected 'HIERARCHY': not a BVH file")
    pos = 1
    expect("ROOT")
    joint_body(take(), -1)
    expect("MOTION")
    expect("Frames:")
    n_frames = int(number())
    expect("Frame")
    expect("Time:")
    frame_time = number()
    if not frame_time > 0:
        raise err(f"Frame Time {frame_time} is not positive", pos - 1)
    values = toks[pos:]
    if len(values) < n_frames * n_channels:
        raise err(
            f"MOTION has {len(values)} values, expected {n_frames} frames x {n_channels} channels"
        )
    try:
        motion = np.array([float(t) for _, t in values[: n_frames * n_channels]], dtype=float)
    except ValueError as exc:
        raise MocapFormatError(f"{source}: MOTION: a value is not a number ({exc})") from None
    return BVH(joints=joints, motion=motion.reshape(n_frames, n_channels), frame_time=frame_time)


def read_bvh(path: str | Path) -> BVH:
    """Parse a BVH file (see :func:`parse_bvh`)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    return parse_bvh(path.read_text(errors="replace"), str(path))


def _axis_rotation(axis: int, deg: np.ndarray) -> np.ndarray:
    """Rotation matrices (T, 3, 3) about one coordinate axis by ``deg`` degrees."""
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((len(a), 3, 3))
    i, j = (axis + 1) % 3, (axis + 2) % 3
    R[:, axis, axis] = 1.0
    R[:, i, i] = c
    R[:, j, j] = c
    R[:, i, j] = -s
    R[:, j, i] = s
    return R


def forward_kinematics(bvh: BVH, frames: slice | np.ndarray | None = None) -> np.ndarray:
    """Global joint positions for every frame, in file units and file axes.

    Parameters
    ----------
    bvh : BVH
    frames : slice or index array, optional
        Subset of frames (all by default).

    Returns
    -------
    ndarray, shape (T, J, 3)
        Positions of all joints (End Sites included), same order as ``bvh.joints``.
    """
    M = bvh.motion if frames is None else bvh.motion[frames]
    T = M.shape[0]
    J = len(bvh.joints)
    pos = np.zeros((T, J, 3))
    rot = np.zeros((T, J, 3, 3))
    eye = np.broadcast_to(np.eye(3), (T, 3, 3))
    for k, j in enumerate(bvh.joints):
        t_local = np.broadcast_to(j.offset, (T, 3)).copy()
        R_local = eye.copy()
        for c_i, ch in enumerate(j.channels):
            col = M[:, j.first_channel + c_i]
            ax = _AXIS[ch[0]]
            if ch.endswith("position"):
                t_local[:, ax] = col
            else:
                R_local = R_local @ _axis_rotation(ax, col)
        if j.parent < 0:
            pos[:, k] = t_local
            rot[:, k] = R_local
        else:
            Rp = rot[:, j.parent]
            pos[:, k] = pos[:, j.parent] + np.einsum("tij,tj->ti", Rp, t_local)
            rot[:, k] = Rp @ R_local
    return pos


# Key point -> joint-name aliases (normalised: lower case, no punctuation, any "xxx:" prefix
# dropped). Earlier aliases win; "{s}" is "left" or "right", "{c}" is "l" or "r".
BVH_ALIASES: dict[str, tuple[str, ...]] = {
    "sacrum": ("hips", "pelvis", "hip", "root"),
    "neck": ("neck", "neck1", "neckbase"),
    "head": ("head",),
    "shoulder": ("{s}arm", "{s}upperarm", "{c}humerus", "{s}shoulder", "{c}shoulder"),
    "elbow": ("{s}forearm", "{s}lowerarm", "{s}elbow", "{c}radius", "{c}elbow"),
    "wrist": ("{s}hand", "{s}wrist", "{c}wrist", "{c}hand"),
    "hip": ("{s}upleg", "{s}thigh", "{s}hip", "{s}upperleg", "{c}femur", "{c}hip", "{c}thigh"),
    "knee": ("{s}leg", "{s}knee", "{s}shin", "{s}lowerleg", "{c}tibia", "{c}knee", "{c}shin"),
    "ankle": ("{s}foot", "{s}ankle", "{c}foot", "{c}ankle"),
    "toe": ("{s}toebase", "{s}toe", "{s}toes", "{c}toes", "{c}toe", "{s}ball"),
}


def _norm(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.split(":")[-1].lower())


def map_joints(names: list[str]) -> dict[str, int]:
    """Key point -> joint index for a skeleton's joint names (only those found).

    The head key point is handled by :func:`bvh_keypoints` (mid-point of the Head joint and its
    End Site when present).
    """
    norm = {}
    for i, n in enumerate(names):
        norm.setdefault(_norm(n), i)
    out: dict[str, int] = {}
    for kp, aliases in BVH_ALIASES.items():
        sides = [("", "")] if "{" not in "".join(aliases) else [("left", "l"), ("right", "r")]
        for s, c in sides:
            key = f"{s}_{kp}" if s else kp
            for a in aliases:
                n = a.replace("{s}", s).replace("{c}", c)
                if n in norm:
                    out[key] = norm[n]
                    break
    return out


def is_cmu_skeleton(names: list[str]) -> bool:
    """True for the CMU database skeleton (LHipJoint, LowerBack ... joints)."""
    s = {_norm(n) for n in names}
    return {"lhipjoint", "rhipjoint", "lowerback", "leftupleg"} <= s


def guess_scale(height_units: float) -> float:
    """Metres per file unit for a non-CMU skeleton from its standing height in file units.

    1-2.5 -> metres, 100-250 -> centimetres, 1000-2500 -> millimetres, 40-100 -> inches;
    anything else is scaled so the skeleton is 1.7 m tall (with a warning).
    """
    h = float(height_units)
    for lo, hi, s in ((1.0, 2.5, 1.0), (100.0, 250.0, 0.01), (1000.0, 2500.0, 0.001)):
        if lo <= h <= hi:
            return s
    if 40.0 <= h <= 100.0:
        return 0.0254
    log.warning("BVH skeleton %.3g units tall: unknown unit, scaled to 1.7 m", h)
    return 1.7 / h if h > 0 else 1.0


def _rest_height(bvh: BVH) -> float:
    """Height of the skeleton in its rest pose (offsets only), along its largest extent."""
    J = len(bvh.joints)
    p = np.zeros((J, 3))
    for k, j in enumerate(bvh.joints):
        p[k] = j.offset if j.parent < 0 else p[j.parent] + j.offset
    return float(np.max(np.ptp(p, axis=0)))


def bvh_keypoints(bvh: BVH, G: np.ndarray) -> tuple[np.ndarray, dict[str, str]]:
    """Raw key points (file axes and units, before floor and sole corrections).

    Parameters
    ----------
    bvh : BVH
    G : ndarray, shape (T, J, 3)
        Output of :func:`forward_kinematics`.

    Returns
    -------
    positions : ndarray, shape (T, 19, 3)
        NaN where the skeleton has no matching joint; heel is left NaN (derived later).
    methods : dict
        Key point -> the joint it came from.
    """
    idx = map_joints(bvh.names)
    T = G.shape[0]
    P = np.full((T, N_KEYPOINTS, 3), np.nan)
    methods: dict[str, str] = {}
    for kp, j in idx.items():
        if kp in KP:
            P[:, KP[kp]] = G[:, j]
            methods[kp] = f"joint {bvh.names[j]}"
    if "head" in idx:
        h = idx["head"]
        ends = [k for k, jt in enumerate(bvh.joints) if jt.parent == h and jt.name.endswith("_End")]
        if ends:
            P[:, KP["head"]] = 0.5 * (G[:, h] + G[:, ends[0]])
            methods["head"] = f"mid-point of {bvh.names[h]} and its end site"
    return P, methods


def _cmu_neck(P: np.ndarray, G: np.ndarray, names: list[str], methods: dict[str, str]) -> None:
    """The CMU skeleton's neck as CONVENTIONS define it (base of the neck, C7 level), in place.

    The Neck1 joint: CMU's Neck joint is the top of the thorax, 5 cm below the shoulder joints;
    Neck1 is 3 cm above them, as C7 is.
    """
    norm = {_norm(n): i for i, n in enumerate(names)}
    if "neck1" in norm:
        P[:, KP["neck"]] = G[:, norm["neck1"]]
        methods["neck"] = "joint Neck1 (C7 level; CMU's Neck joint is the top of the thorax)"


def _cmu_sacrum(P: np.ndarray, methods: dict[str, str]) -> None:
    """The CMU skeleton's sacrum as CONVENTIONS define it, in place (z up).

    * **sacrum** (mid-point of the posterior iliac spines): the root (Hips) moved horizontally
      backwards, along the pelvis's forward direction (perpendicular to the hip line), to
      :data:`CMU_SACRUM_BEHIND_HIPS_PER_LEG` of the leg length behind the hip joint centres; its
      height is the root's (about 10 cm above the hip joint centres, as on the marker recordings).
    """
    lh, rh = P[:, KP["left_hip"]], P[:, KP["right_hip"]]
    across = lh - rh
    across[:, 2] = 0.0
    forward = np.cross(jc.unit(across), np.array([0.0, 0.0, 1.0]))
    mid = 0.5 * (lh + rh)

    def bone(a: str, b: str) -> float:
        return float(np.median(np.linalg.norm(P[:, KP[a]] - P[:, KP[b]], axis=1)))

    # thigh + shank (bones of a rigid skeleton: the same whatever the knee angle)
    leg = float(
        np.mean(
            [
                bone(f"{s}_hip", f"{s}_knee") + bone(f"{s}_knee", f"{s}_ankle")
                for s in ("left", "right")
            ]
        )
    )
    sac = P[:, KP["sacrum"]]
    ahead = np.einsum("ti,ti->t", sac - mid, forward)  # the root's distance ahead of the hips
    shift = -(ahead + CMU_SACRUM_BEHIND_HIPS_PER_LEG * leg)
    P[:, KP["sacrum"]] = sac + shift[:, None] * forward
    methods["sacrum"] = (
        f"joint Hips moved {np.median(-shift) * 1000:.0f} mm backwards, to "
        f"{CMU_SACRUM_BEHIND_HIPS_PER_LEG} leg lengths behind the hip joints (mid-PSIS)"
    )


def load_bvh(
    path: str | Path,
    *,
    scale: float | None = None,
    align_walking_to_x: bool = False,
    vertical: tuple[int, int] | None = None,
    drop_rest_frame: bool | None = None,
    heel_back_ratio: float = 0.45,
) -> Trajectory:
    """A BVH recording as a :class:`Trajectory` of the 19 key points (z up, floor at 0).

    Parameters
    ----------
    path : str or Path
    scale : float, optional
        Metres per file unit. Default: 0.056444 for the CMU skeleton, else guessed from the
        skeleton's rest height (:func:`guess_scale`).
    align_walking_to_x : bool
        Rotate about z so that the subject walks along +x.
    vertical : (axis, sign), optional
        The file's up axis; detected from head/neck versus feet when omitted (CMU: y up).
    drop_rest_frame : bool, optional
        Drop a first frame that is a reference pose (CMU conversions start with one: its joints
        jump by far more than any later frame-to-frame motion). None = detect.
    heel_back_ratio : float
        Foot model constant for the heel (see ``jointcentres.heel_from_ankle_toe``).

    Returns
    -------
    Trajectory
        Heel from the ankle and toe joints by the foot model; toe joint lowered to the sole;
        ``mapping_info`` says which joint gave each key point.
    """
    path = Path(path)
    bvh = read_bvh(path)
    names = bvh.names
    cmu = is_cmu_skeleton(names)
    if scale is None:
        scale = CMU_SCALE_M if cmu else guess_scale(_rest_height(bvh))
    if not scale > 0:
        raise MocapFormatError(f"{path}: scale must be positive, got {scale}")
    G = forward_kinematics(bvh) * scale
    T = G.shape[0]
    first = 0
    if T >= 3 and drop_rest_frame is not False:
        step = np.linalg.norm(np.diff(G, axis=0), axis=-1).max(axis=1)  # (T-1,)
        jump0, typical = step[0], float(np.median(step[1:]))
        if drop_rest_frame or (jump0 > 0.05 and jump0 > 10 * max(typical, 1e-6)):
            first = 1
            log.info("%s: first frame is a reference pose, dropped", path)
    G = G[first:]
    P, methods = bvh_keypoints(bvh, G)
    if cmu:
        _cmu_neck(P, G, names, methods)
    idx = map_joints(names)
    need = {"left_ankle", "right_ankle", "left_hip", "right_hip"}
    if not need <= set(idx):
        raise MocapFormatError(
            f"{path}: HIERARCHY: no joints for {', '.join(sorted(need - set(idx)))} "
            "(expected names like LeftUpLeg/LeftLeg/LeftFoot or LeftHip/LeftKnee/LeftAnkle)"
        )
    if vertical is None:
        upper = [P[:, KP[k]] for k in ("head", "neck", "sacrum", "left_hip", "right_hip")]
        lower = [P[:, KP[k]] for k in ("left_ankle", "right_ankle", "left_toe", "right_toe")]
        vertical = detect_vertical(
            [u for u in upper if np.isfinite(u).any()],
            [v for v in lower if np.isfinite(v).any()],
            str(path),
        )
    axis, sign = vertical
    P = to_z_up(P, axis, sign)
    feet = ("left_ankle", "right_ankle", "left_toe", "right_toe")
    levelling, tilt = floor_levelling([P[:, KP[k]] for k in feet])
    if levelling is not None:
        P = levelling(P)
        log.info("%s: floor tilted by %.2f degrees, levelled", path, tilt)
    foot = [P[:, KP[k], 2] for k in feet]
    floor = estimate_floor(foot)
    P[..., 2] -= floor
    for side in ("left", "right"):
        toe = P[:, KP[f"{side}_toe"]]
        ankle = P[:, KP[f"{side}_ankle"]]
        if np.isfinite(toe).any():
            toe, drop = jc.lower_to_sole(toe, jc.sole_down(toe, None))
            P[:, KP[f"{side}_toe"]] = toe
            methods[f"{side}_toe"] += f", lowered {drop * 1000:.0f} mm to the sole"
            right = P[:, KP["right_hip"]] - P[:, KP["left_hip"]]
            P[:, KP[f"{side}_heel"]] = jc.heel_from_ankle_toe(ankle, toe, heel_back_ratio, right)
            methods[f"{side}_heel"] = "foot model from the ankle and toe joints"
    if cmu:
        _cmu_sacrum(P, methods)
    if align_walking_to_x:
        P, _ = _align_walking(P)
    fps = 1.0 / bvh.frame_time
    if abs(fps - round(fps)) < 0.01:  # "Frame Time: .0083333" is 120 Hz
        fps = float(round(fps))
    traj = Trajectory(positions=P, times=np.arange(len(P)) / fps, fps=fps, source=str(path))
    traj.mapping_info = {  # type: ignore[attr-defined]
        "methods": methods,
        "vertical_axis": "xyz"[axis],
        "vertical_sign": sign,
        "floor_lab_m": floor,
        "floor_tilt_deg": tilt,
        "floor_levelled": levelling is not None,
        "scale_m_per_unit": scale,
        "cmu_skeleton": cmu,
        "dropped_first_frame": bool(first),
    }
    return traj
