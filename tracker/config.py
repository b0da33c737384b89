"""Configuration of the tracker: filters, origin search, initialisation and lost-track logic.

One tree of pydantic models, validated at the edge (``extra="forbid"``: an unknown key is an
error). Angles are given in degrees and distances in metres, like the joint-limit tables of
:mod:`tracker.dof`; the filters convert to radians internally. Motion magnitudes (interval widths,
noise sigmas, search ranges) are stated for 20 Hz footage (``reference_dt_s = 0.05``) and scaled
with the actual frame interval: widths and ranges linearly with ``dt / 0.05``, diffusion sigmas
with ``sqrt(dt / 0.05)`` for the random-walk filters and linearly for IPF (as the method scales
its intervals). The body-shape windows (``init.girth_frames``, ``part_girth_frames``,
``leg_length_frames``) are counted in frames at 20 Hz too and cover the same time at the cameras'
frame rate; the other frame counts are frames of the footage as it comes.

Defaults follow issue 3: IPF with M = 81 kept particles, q = 3 grid values over an interval of
10 degrees on the n = 4 "interesting" DOFs (both hips' and both knees' flexion), i.e. 6561
particles per frame; the baselines (Condensation, annealed particle filter) get the same number of
likelihood evaluations per frame. The IPF's defaults add, within that budget, a coarse-to-fine
second pass and a diverse selection (``refine_share=0``, ``max_per_group=0`` restore the published
method); velocity-centred and adaptively widened intervals are options, off by default
(``interval_centre="velocity"``, ``adaptive_width > 0``; see ``docs/tracker.md``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from gaitwatch.errors import InputError
from tracker.dof import DOF_NAMES, INTERESTING_DEFAULT, LIMIT_PROFILES, ROOT_DOFS
from tracker.segmentation import SegmentationConfig

FilterName = Literal["ipf", "apf", "condensation"]
FILTER_NAMES: tuple[str, ...] = ("ipf", "apf", "condensation")


class TrackerConfigError(InputError):
    """A tracker configuration file or option that cannot be used."""


def _default_sigmas() -> dict[str, float]:
    """Per-DOF random-walk sigma for one 20 Hz frame: metres for root_x/y/z, degrees otherwise."""
    s = {n: 2.0 for n in DOF_NAMES}
    s.update({"root_x": 0.02, "root_y": 0.02, "root_z": 0.01})
    s.update({"root_yaw": 3.0, "root_pitch": 1.5, "root_roll": 1.5})
    s.update({"trunk_flexion": 1.5, "trunk_lateral": 1.0, "trunk_rotation": 1.5})
    s.update({"neck_flexion": 1.5, "neck_rotation": 2.0})
    for side in ("l", "r"):
        s[f"{side}_shoulder_flexion"] = 4.0
        s[f"{side}_shoulder_abduction"] = 2.0
        s[f"{side}_shoulder_rotation"] = 2.0
        s[f"{side}_elbow_flexion"] = 4.0
        s[f"{side}_hip_flexion"] = 5.0
        s[f"{side}_hip_abduction"] = 1.5
        s[f"{side}_hip_rotation"] = 1.5
        s[f"{side}_knee_flexion"] = 7.0
        s[f"{side}_ankle_flexion"] = 4.0
        s[f"{side}_ankle_rotation"] = 1.5
    return s


def _ipf_default_sigmas() -> dict[str, float]:
    """The IPF's noise on R: :func:`_default_sigmas` with none on the root (the origin search
    sets it)."""
    return {**_default_sigmas(), **{DOF_NAMES[i]: 0.0 for i in ROOT_DOFS}}


def _check_dof_keys(v: dict[str, float], what: str) -> dict[str, float]:
    unknown = sorted(set(v) - set(DOF_NAMES))
    if unknown:
        raise ValueError(f"unknown DOF(s) in {what}: {', '.join(unknown)}")
    for name, val in v.items():
        if not val >= 0:
            raise ValueError(f"{what}[{name}] must be >= 0, not {val}")
    return v


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)


class IPFAnnealConfig(_Model):
    """The IPF's annealing stage (opt-in; docs/tracker.md, "Session 46"): after the grid passes, a
    share of the frame's evaluations goes to ``layers`` annealing layers, each resampled from
    the last weights raised to the power that gives ``survival_rate``, diffused on every DOF
    (the root too) and weighed, as the annealed particle filter's layers; the heaviest
    particle of all is the estimate. It moves the root, trunk, arms and legs together, which
    the origin search, the grid and the noise on R do one group at a time."""

    share: Annotated[
        float,
        Field(
            ge=0,
            lt=1,
            description="Share of the IPF's kept groups whose evaluations go to the annealing "
            "stage (rounded to whole groups; the frame's total stays kept * q^n). 0: off (the "
            'default and the method; 0.15 was measured: docs/tracker.md, "Session 46")',
        ),
    ] = 0.0
    min_cameras: Annotated[
        int,
        Field(
            ge=1,
            le=16,
            description="Anneal only with at least this many cameras: through one camera the "
            'lower limbs lost accuracy (docs/tracker.md, "Session 46")',
        ),
    ] = 2
    layers: Annotated[int, Field(ge=1, le=20, description="Annealing layers")] = 2
    move_interesting: Annotated[
        bool,
        Field(
            description="Diffuse the grid's DOFs (ipf.interesting) too; false: the layers "
            "keep their values and move every other DOF"
        ),
    ] = True
    sigma_scale: Annotated[
        float,
        Field(
            gt=0,
            le=10,
            description="First layer's noise: the random-walk sigmas of every DOF (the "
            "baselines' defaults, root included) times this, at 20 Hz",
        ),
    ] = 0.5
    survival_rate: Annotated[
        float,
        Field(
            gt=0,
            lt=1,
            description="Target survival rate of each layer's annealed weights; the noise "
            "shrinks by its square root per layer",
        ),
    ] = 0.5


class IPFConfig(_Model):
    """Interval Particle Filtering (issue 3)."""

    kept: Annotated[
        int, Field(ge=1, le=100_000, description="M: heaviest distinct particles kept per frame")
    ] = 81
    q: Annotated[int, Field(ge=1, le=15, description="Grid values per interesting DOF")] = 3
    interesting: Annotated[
        tuple[str, ...],
        Field(min_length=1, max_length=8, description="L: the DOFs explored on a grid"),
    ] = INTERESTING_DEFAULT
    interval_deg: Annotated[
        float, Field(ge=0, le=180, description="Interval width per L DOF at 20 Hz, degrees")
    ] = 10.0
    interval_overrides_deg: Annotated[
        dict[str, float], Field(description="Per-DOF interval width at 20 Hz, degrees")
    ] = {}
    sigma: Annotated[
        dict[str, float],
        Field(
            description="White noise on R per DOF at 20 Hz (m or degrees); root DOFs are set "
            "by the origin search and get no noise by default. DOFs not given keep their "
            "defaults"
        ),
    ] = Field(default_factory=_ipf_default_sigmas)
    interval_centre: Annotated[
        Literal["value", "velocity"],
        Field(
            description="Centre of each L interval: the particle's value (the method) or its "
            "value moved by the damped velocity of the estimate's L DOFs over the last frame"
        ),
    ] = "value"
    velocity_damping: Annotated[
        float, Field(ge=0, le=1, description="Factor on the velocity for interval_centre=velocity")
    ] = 0.7
    adaptive_width: Annotated[
        float,
        Field(
            ge=0,
            le=10,
            description="Widen each L interval to this factor times the L DOF's change over the "
            "last frame (the observed joint speed); interval_deg stays the minimum. 0: off",
        ),
    ] = 0.0
    max_interval_deg: Annotated[
        float, Field(gt=0, le=180, description="Upper bound of an adaptively widened interval")
    ] = 60.0
    refine_share: Annotated[
        float,
        Field(
            ge=0,
            lt=1,
            description="Coarse-to-fine: share of the M groups spent on a second, finer pass "
            "around the heaviest distinct particles of the first (same total evaluations). "
            "0: one pass (the method)",
        ),
    ] = 0.5
    coarse_factor: Annotated[
        float,
        Field(
            ge=1,
            le=10,
            description="With refine_share > 0: the first pass's intervals are this many times "
            "wider, the second pass's are the first pass's grid spacing",
        ),
    ] = 2.0
    max_per_group: Annotated[
        int,
        Field(
            ge=0,
            le=100_000,
            description="Selection keeps at most this many particles with the same R values "
            "(one group of the last frame) while others remain; 0: the M heaviest distinct",
        ),
    ] = 9
    factored: Annotated[
        bool,
        Field(description="Use the likelihood's left/right-leg factorisation when L allows it"),
    ] = True
    anneal: IPFAnnealConfig = Field(default_factory=IPFAnnealConfig)

    @field_validator("interesting")
    @classmethod
    def _interesting_known(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        unknown = [n for n in v if n not in DOF_NAMES]
        if unknown:
            raise ValueError(f"unknown DOF(s): {', '.join(unknown)}")
        if len(set(v)) != len(v):
            raise ValueError("DOFs must be distinct")
        return v

    @field_validator("interval_overrides_deg")
    @classmethod
    def _overrides(cls, v: dict[str, float]) -> dict[str, float]:
        return _check_dof_keys(v, "interval_overrides_deg")

    @field_validator("sigma")
    @classmethod
    def _sigma(cls, v: dict[str, float]) -> dict[str, float]:
        # A partial table overrides those DOFs; the others keep their defaults.
        return {**_ipf_default_sigmas(), **_check_dof_keys(v, "sigma")}

    @property
    def neighbours(self) -> int:
        """I = q^n neighbours per kept particle."""
        return self.q ** len(self.interesting)

    @property
    def evaluations(self) -> int:
        """N = M * I likelihood evaluations per frame (the annealing stage's included)."""
        return self.kept * self.neighbours

    @property
    def anneal_groups(self) -> int:
        """Kept groups whose evaluations the annealing stage takes (0: no stage)."""
        if self.anneal.share == 0 or self.kept < 2:
            return 0
        return min(self.kept - 1, max(1, round(self.anneal.share * self.kept)))


class CondensationConfig(_Model):
    """Condensation (Isard & Blake 1998): resample in proportion to weight, Gaussian diffusion."""

    sigma: Annotated[
        dict[str, float],
        Field(description="Diffusion sigma per DOF at 20 Hz (m or degrees); others: defaults"),
    ] = Field(default_factory=_default_sigmas)
    sigma_scale: Annotated[
        float, Field(gt=0, le=100, description="Multiplier applied to every sigma")
    ] = 1.0

    @field_validator("sigma")
    @classmethod
    def _sigma(cls, v: dict[str, float]) -> dict[str, float]:
        # A partial table overrides those DOFs; the others keep their defaults.
        return {**_default_sigmas(), **_check_dof_keys(v, "sigma")}


class APFConfig(_Model):
    """Annealed particle filter (Deutscher, Blake & Reid 2000)."""

    layers: Annotated[int, Field(ge=1, le=50, description="Annealing layers per frame")] = 5
    survival_rate: Annotated[
        float,
        Field(
            gt=0,
            lt=1,
            description="Target particle survival rate alpha; sets each layer's "
            "annealing exponent and shrinks the noise by sqrt(alpha) per layer",
        ),
    ] = 0.5
    sigma: Annotated[
        dict[str, float],
        Field(
            description="First-layer diffusion sigma per DOF at 20 Hz (m or degrees); "
            "others: defaults"
        ),
    ] = Field(default_factory=_default_sigmas)
    sigma_scale: Annotated[float, Field(gt=0, le=100)] = 1.5

    @field_validator("sigma")
    @classmethod
    def _sigma(cls, v: dict[str, float]) -> dict[str, float]:
        # A partial table overrides those DOFs; the others keep their defaults.
        return {**_default_sigmas(), **_check_dof_keys(v, "sigma")}


class OriginSearchConfig(_Model):
    """Hierarchical search of the body origin, one dimension at a time (x, y, z, yaw, tilts)."""

    enabled: bool = True
    steps: Annotated[int, Field(ge=3, le=41, description="Grid values per dimension (odd)")] = 7
    levels: Annotated[
        int, Field(ge=1, le=6, description="Refinements per dimension (range shrinks)")
    ] = 2
    shrink: Annotated[float, Field(gt=0, lt=1, description="Range factor per refinement")] = 0.35
    passes: Annotated[int, Field(ge=1, le=4, description="Sweeps over the dimensions")] = 1
    range_xy_m: Annotated[float, Field(gt=0, le=2, description="+- range of x, y at 20 Hz")] = 0.12
    range_z_m: Annotated[float, Field(ge=0, le=1, description="+- range of z at 20 Hz")] = 0.04
    range_yaw_deg: Annotated[float, Field(ge=0, le=180)] = 6.0
    range_tilt_deg: Annotated[float, Field(ge=0, le=90, description="pitch and roll")] = 5.0
    velocity_damping: Annotated[
        float,
        Field(ge=0, le=1, description="Constant-velocity prediction of x, y: 0 off, 1 full"),
    ] = 0.8
    after_filter: Annotated[
        bool,
        Field(
            description="Search the origin again after the body-part filter, holding the new "
            "legs (the sacrum estimate depends on them); adopted when it weighs more"
        ),
    ] = True
    after_filter_levels: Annotated[int, Field(ge=1, le=6)] = 1
    after_filter_range_scale: Annotated[
        float, Field(gt=0, le=4, description="Factor on the ranges of the second search")
    ] = 0.5


#: Allowed values of InitConfig's shape factors (tracker.body.BodyModel's own ranges: girth,
#: part_girths, leg_length as LEG_LENGTH_RANGE).
_SHAPE_FACTOR_RANGES: dict[str, tuple[float, float]] = {
    "girths": (0.5, 2.0),
    "part_girths": (0.5, 3.0),
    "leg_lengths": (0.8, 1.2),
}
#: Allowed hem lengths (thighs) and radii (heights): tracker.body.HEM_LENGTH_RANGE and
#: HEM_RADIUS_RANGE.
_HEM_RANGES: tuple[tuple[float, float], tuple[float, float]] = ((0.2, 1.5), (0.02, 0.2))


class InitConfig(_Model):
    """Exhaustive first-frame / re-initialisation search over plausible configurations."""

    headings: Annotated[int, Field(ge=1, le=72, description="Headings over the circle")] = 16
    position_step_m: Annotated[float, Field(gt=0, le=1)] = 0.15
    position_radius_m: Annotated[
        float,
        Field(ge=0, le=3, description="Half-width of the x, y grid around the blob's floor point"),
    ] = 0.30
    walking_phases: Annotated[int, Field(ge=0, le=32)] = 8
    flexed_phases: Annotated[
        int,
        Field(
            ge=0,
            le=32,
            description="Phases of a flexed (crouch or stooped) walk: the walking phases with "
            "the hips, knees, ankles and trunk flexed further (tracker.init.FLEXED_OFFSETS_DEG), "
            "so that a crouched walker is found facing the right way. 0: none",
        ),
    ] = 8
    seated: bool = True
    refine_best: Annotated[
        int, Field(ge=0, le=50, description="Best candidates refined by the origin search")
    ] = 4
    max_candidates: Annotated[int, Field(ge=10, le=1_000_000)] = 20_000
    both_headings: Annotated[
        bool,
        Field(
            description="Keep both heading hypotheses after an initialisation (a silhouette "
            "looks alike from the front and the back): the candidates facing within 90 deg of "
            "the best and the others each seed a filter and are tracked side by side until "
            "the walking direction (heading_check's source and criteria) decides, or the "
            "weight clearly does; until then the heavier one is the estimate",
        ),
    ] = False
    both_headings_ratio: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="both_headings: keep the opposite hypothesis when its best candidate "
            "weighs at least this fraction of the best",
        ),
    ] = 0.8
    both_headings_drop: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="both_headings: drop the lighter hypothesis when it weighs less than "
            "(1 - this) times the heavier",
        ),
    ] = 0.1
    both_headings_max_s: Annotated[
        float,
        Field(gt=0, le=60, description="both_headings: keep the heavier after this long"),
    ] = 2.0
    girths: Annotated[
        tuple[float, ...],
        Field(
            min_length=1,
            max_length=12,
            description="Body girth factors tried at the first initialisation (the one whose "
            "best configuration weighs most starts) and scored over the first girth_frames "
            "frames; the best is kept for the rest of the footage. One value: fixed girth",
        ),
    ] = (0.9, 1.0, 1.15, 1.3)
    girth_frames: Annotated[
        int,
        Field(
            ge=1,
            le=1000,
            description="Frames over which the girths are scored on the refined particles "
            "(after the first initialisation's choice); then the girth is fixed. Frames at "
            "20 Hz (reference_dt_s): the same time at the cameras' frame rate",
        ),
    ] = 5
    part_girths: Annotated[
        tuple[float, ...],
        Field(
            min_length=1,
            max_length=12,
            description="Factors tried on each body part's volumes (tracker.body.GIRTH_PARTS: "
            "trunk, head, arms, thighs, shanks, feet) over the first part_girth_frames frames, "
            "on top of the girth: each part takes the factor whose best particle weighs most, "
            "summed over those frames. One value: that factor on every part, nothing estimated",
        ),
    ] = (0.65, 0.8, 1.0, 1.25, 1.5, 1.8, 2.2)
    hems: Annotated[
        tuple[tuple[float, float], ...],
        Field(
            max_length=12,
            description="Hems of a skirt, dress or coat tried with the part factors (over "
            "part_girth_frames frames; no hem is always a candidate): (length in thigh "
            "lengths, radius in heights), one flared volume per thigh "
            "(tracker.body.hem_capsules). Empty: no hem, nothing estimated",
        ),
    ] = ()
    hem_margin: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="A hem is taken only when its summed best weights exceed no hem's by "
            "this fraction",
        ),
    ] = 0.01
    part_girth_max_multi_camera: Annotated[
        float | None,
        Field(
            ge=0.5,
            le=3.0,
            description="With two cameras or more, the part factors of part_girths above this "
            "are not tried (None: all are). Two views place the limbs; the fattest factors then "
            "only let a fat trunk with fat arms held in cover the trunk and arms together",
        ),
    ] = 1.5
    part_girth_frames: Annotated[
        int,
        Field(
            ge=1,
            le=1000,
            description="Frames over which the part factors are scored (from the first tracked "
            "frame); then they are fixed. Frames at 20 Hz (reference_dt_s): the same time at "
            "the cameras' frame rate",
        ),
    ] = 10
    leg_lengths: Annotated[
        tuple[float, ...],
        Field(
            min_length=1,
            max_length=12,
            description="Relative leg lengths (hip to ankle, at the same standing height; "
            "tracker.body.BodyModel leg_length, 0.8..1.2) scored over the first "
            "leg_length_frames tracked frames: the heaviest particles are moved onto each "
            "length and refitted by one filter step; the length whose refitted estimate weighs "
            "most, summed over those frames, is kept. One value: that leg length, nothing "
            "estimated",
        ),
    ] = (0.9, 0.95, 1.0, 1.05, 1.1)
    leg_length_min_cameras: Annotated[
        int,
        Field(
            ge=1,
            le=16,
            description="Estimate the leg length only with at least this many cameras (with "
            "fewer, several leg_lengths mean the table's, 1.0): through one camera the "
            "estimate was wrong often enough to cost more accuracy than it gained",
        ),
    ] = 2
    leg_length_frames: Annotated[
        int,
        Field(
            ge=1,
            le=1000,
            description="Frames over which the leg lengths are scored (from the first tracked "
            "frame); then the leg length is fixed. Frames at 20 Hz (reference_dt_s): the same "
            "time at the cameras' frame rate",
        ),
    ] = 10

    @field_validator("girths", "part_girths", "leg_lengths")
    @classmethod
    def _shape_factors(cls, v: tuple[float, ...], info: ValidationInfo) -> tuple[float, ...]:
        lo, hi = _SHAPE_FACTOR_RANGES[info.field_name]
        if any(not lo <= f <= hi for f in v):
            raise ValueError(f"{info.field_name} must be within {lo}..{hi}")
        return v

    @field_validator("hems")
    @classmethod
    def _hems(cls, v: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
        (l0, l1), (r0, r1) = _HEM_RANGES
        for length, radius in v:
            if not (l0 <= length <= l1 and r0 <= radius <= r1):
                raise ValueError(
                    f"hems: ({length}, {radius}) must be (length {l0}..{l1} thighs, "
                    f"radius {r0}..{r1} heights)"
                )
        return v


class RedetectConfig(_Model):
    """Per-frame re-detection: a small initial search around the silhouettes' floor point.

    After the filter (and the leg-swap check), the initialisation search of ``tracker.init`` runs
    on a reduced grid: every body configuration (standing, walking phases, seated; the flexed
    walking phases only with ``flexed_phases``) x positions
    within ``init.position_radius_m`` of the floor point under this frame's silhouettes x
    ``headings`` headings within ``span_deg`` of the estimate's; the ``refine_best`` best are
    refined by the origin search. When the best weighs more than the estimate by ``margin``, it
    becomes the estimate and the best few join the filter's particle set. It catches a track that
    slid away from the person (one camera's depth ambiguity, a fast turn) before it is lost.

    A coarse grid pose seldom outweighs an estimate the filter has refined over many frames, even
    when it lies in the right basin and the estimate does not. So when the search's best weighs
    at least ``refine_ratio`` times the estimate without outweighing it, the filter is seeded with
    the ``refine_candidates`` best candidates and stepped ``refine_steps`` times on this frame
    (then the origin search, as after the filter); the result replaces the estimate when heavier
    by ``margin``, else the particle set is restored. It costs up to ``refine_steps`` filter steps
    on the frames where it runs (the tracker goes from about 45 to 34 frames/s).
    """

    enabled: bool = True
    every_frames: Annotated[
        int, Field(ge=1, le=1000, description="Run on every n-th tracked frame")
    ] = 1
    headings: Annotated[int, Field(ge=1, le=72, description="Headings tried")] = 3
    span_deg: Annotated[
        float, Field(ge=0, le=180, description="Headings within +- this of the estimate's")
    ] = 30.0
    refine_best: Annotated[
        int, Field(ge=0, le=50, description="Best candidates refined by the origin search")
    ] = 1
    flexed_phases: Annotated[
        int | None,
        Field(
            ge=0,
            le=32,
            description="Flexed-walk phases in re-detection's body configurations (0: none, "
            "the per-frame search stays as cheap as before; None: init.flexed_phases)",
        ),
    ] = 0
    margin: Annotated[
        float,
        Field(ge=0, le=1, description="Adopt when heavier than the estimate by more than this"),
    ] = 0.01
    inject: Annotated[
        int, Field(ge=1, le=100, description="Best candidates added to the particle set")
    ] = 9
    stable_ratio: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Skip re-detection while the estimate weighs at least this fraction of "
            "the heaviest estimate of the last stable_frames tracked frames (a track that "
            "slides off loses weight); 0: never skip",
        ),
    ] = 0.98
    stable_frames: Annotated[
        int, Field(ge=1, le=100, description="Tracked frames the stable_ratio looks back over")
    ] = 5
    max_skipped: Annotated[
        int, Field(ge=0, le=1000, description="At most this many frames in a row skipped")
    ] = 3
    refine_steps: Annotated[
        int,
        Field(
            ge=0,
            le=10,
            description="Filter steps refining the search's candidates before they are "
            "compared with the estimate (see refine_ratio); 0: compare the grid's best as is",
        ),
    ] = 2
    refine_ratio: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Refine when the search's best weighs at least this fraction of the "
            "estimate (a candidate that could win once refined)",
        ),
    ] = 0.75
    refine_candidates: Annotated[
        int, Field(ge=1, le=1000, description="Best candidates seeding the refining filter")
    ] = 9
    trial_share: Annotated[
        float,
        Field(
            gt=0,
            le=1,
            description="Share of the filter's evaluations a trial refinement spends (these "
            "refinements, the heading checks' and the leg length's): a filter of the same kind "
            "with that share of the budget; 1: the tracker's own filter",
        ),
    ] = 1.0


class SeatedConfig(_Model):
    """Sitting down and getting up while the joint limits are the walking profile's.

    The walking ranges (``tracker.dof``) keep the search where gait is, but a seated body needs
    its hips and knees flexed beyond them and its pelvis lower. Wherever re-detection runs (it
    runs when the estimate loses weight, as it does when the person sits down), the seated
    configurations of ``tracker.init`` (upright and leaning) are also weighed, at ``headings``
    headings over the circle around this frame's floor point, under the seated limits: the
    profile's with ``tracker.dof.SEATED_DOFS`` widened to the general profile's ranges. When
    their best (refined by the origin search) outweighs the estimate by ``margin``, or does so
    after ``redetect.refine_steps`` filter steps from its best candidates (tried when it weighs
    at least ``redetect.refine_ratio`` times the estimate, as in re-detection), the track
    switches to the seated limits and adopts it: the filter, the origin search and re-detection
    (which then includes the seated configurations) all search the wider ranges. The search
    runs only while the person is lower than someone of the stature standing: in every camera
    the silhouette is shorter by ``lower_fraction`` than a standing body of the stature would
    be at the silhouette's floor point (the bottom of the silhouette on the floor: the feet
    give the depth, not the estimate, which through one camera slides away and shrinks to fit
    a seated silhouette). On the benchmark's true person masks (scene seed 0, each recording
    through one oblique, side and frontal camera) the walkers' silhouettes were 0.95-1.15 of
    that height, crouch gait's 0.80-1.06, and CMU 75_19 seated 0.48-0.77. The track
    returns to the profile's limits once its estimate has been within them for
    ``upright_frames`` frames in a row. Nothing changes when the profile already allows sitting
    (``limits_profile = "general"``).

    People sit down standing still, so the search also waits until the silhouettes' floor point
    has moved slower than ``max_floor_speed_m_s`` over the last ``speed_window_s`` (medians of
    the window's first and last thirds, which ride over the feet's alternation as the nearest;
    the silhouettes' own floor points, kept across re-initialisations of the estimate, not
    before they cover half the window). On the benchmark's footage where the
    height gate opened (session 23), CMU 75_19 sitting down measured 0-0.08 m/s, crouch gait
    0.49-1.14 m/s, a walk behind a sofa 1.06-1.14 m/s. Without it (session 22) the mode
    switched wrongly on a crouch-gait scene (crouch4, one oblique camera: 180.8 -> 342.5 mm), in
    the track's second frame.
    """

    enabled: bool = True
    headings: Annotated[
        int, Field(ge=1, le=72, description="Headings of the seated search over the circle")
    ] = 8
    lower_fraction: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Search only while every camera's silhouette is shorter than a "
            "standing body of the stature at the silhouette's floor point by this fraction",
        ),
    ] = 0.2
    refine_best: Annotated[
        int, Field(ge=0, le=50, description="Best candidates refined by the origin search")
    ] = 4
    margin: Annotated[
        float,
        Field(ge=0, le=1, description="Switch when heavier than the estimate by more than this"),
    ] = 0.02
    upright_frames: Annotated[
        int,
        Field(ge=1, le=1000, description="Frames within the profile's limits before returning"),
    ] = 3
    max_floor_speed_m_s: Annotated[
        float,
        Field(
            ge=0,
            description="Search only while the silhouettes' floor point moves slower than this "
            "(m/s, over the last speed_window_s; people sit down standing still)",
        ),
    ] = 0.25
    speed_window_s: Annotated[
        float,
        Field(gt=0, le=10, description="Time over which the floor point's speed is measured"),
    ] = 1.0


class HeadingCheckConfig(_Model):
    """Walking-direction check of the heading (a silhouette looks alike from front and back).

    When the body origin has moved faster than ``min_speed_m_s`` (least-squares velocity over
    the last ``window_s`` seconds, at least ``min_frames`` estimates over ``min_span_s``, along
    a path straight enough: ``min_straightness``; at most one check per ``cooldown_s``) in a
    direction more than ``max_angle_deg`` away from the estimated heading, the initial
    search is re-run with headings within ``span_deg`` of the walking direction at the current
    position; its result replaces the track when it weighs at least ``accept_ratio`` times the
    current estimate. People seldom walk backwards. The walking direction (``source``
    "auto") is the estimated origin's, or the silhouettes' floor point's when the estimate's
    path is not a walk: a track stuck facing the wrong way does not move with the person.
    When the silhouettes and the estimate have both walked that way for ``sustained_s``, the
    flip is sustained: its candidates are refined and adopted at ``sustained_ratio`` (a track
    refined facing the wrong way outweighs fresh candidates facing the right way).

    Face check (``facing_*``): when no walking direction is known (standing, stepping on the
    spot, a walk slower than ``min_speed_m_s``), the 2D detector's face decides instead: seen
    in profile, its nose lies ahead of its shoulders. When over ``facing_s`` the detections put
    the face behind the estimate's heading, the heading is checked facing the other way: the
    candidates are refined however light, as a sustained flip's, and adopted at
    ``facing_ratio``. Not in the seated mode.

    Swing check (``swing_*``): with no walking direction known and the face check silent, the
    feet decide: a raised foot moves forward relative to the pelvis, on a treadmill too
    (:mod:`tracker.swing`). When over ``swing_s`` the estimate's sacrum stayed (slower than
    ``min_speed_m_s``) and its raised feet moved more than ``max_angle_deg`` away from its
    heading, consistently (``swing_consistency``), the heading is checked facing the way they
    moved, as the face check does. Only on feet some camera sees; not in the seated mode.

    Turn following (``turn_*``): when the heading is more than ``turn_angle_deg`` (and at most
    ``max_angle_deg``) off the walking direction of the silhouettes' floor points, the reduced
    initial search runs at headings around the walking direction (centred ``turn_lead_deg``
    beyond it: the body turns ahead of its path); when its best weighs at least
    ``turn_trial_ratio`` times the estimate, one filter step refines those candidates and the
    result replaces the estimate if heavier by ``turn_margin`` (else the particle set is
    restored). No cooldown: a turn lasts several frames.
    """

    enabled: bool = True
    source: Annotated[
        Literal["auto", "silhouette", "estimate"],
        Field(
            description="Path giving the walking direction: the silhouettes' floor point (the "
            "bottom of each silhouette on the floor, median over cameras; independent of the "
            "estimated heading), the estimated body origin, or auto: the estimated origin's "
            "path, or the floor point's when that is not a walk (a track stuck while the "
            "person walks)"
        ),
    ] = "auto"
    window_s: Annotated[float, Field(gt=0, le=10)] = 0.4
    auto_min_span_s: Annotated[
        float,
        Field(
            ge=0,
            le=10,
            description="source auto: the silhouettes' path must span at least this long "
            "(the floor point is noisier than the estimate)",
        ),
    ] = 0.3
    min_frames: Annotated[int, Field(ge=2, le=1000)] = 3
    min_span_s: Annotated[
        float, Field(ge=0, le=10, description="The estimates must span at least this long")
    ] = 0.1
    min_straightness: Annotated[
        float, Field(ge=0, le=1, description="Net displacement / path length over the window")
    ] = 0.7
    cooldown_s: Annotated[
        float, Field(ge=0, le=60, description="No new check for this long after one")
    ] = 1.0
    min_speed_m_s: Annotated[float, Field(ge=0, le=5)] = 0.35
    max_angle_deg: Annotated[float, Field(ge=0, le=180)] = 110.0
    span_deg: Annotated[float, Field(ge=0, le=180)] = 40.0
    accept_ratio: Annotated[float, Field(ge=0, le=2)] = 0.85
    sustained_s: Annotated[
        float,
        Field(
            ge=0,
            le=60,
            description="A check that fires is sustained when, over this long (a path since "
            "the last check spanning at least 0.9 of it), the silhouettes' floor point and the "
            "estimate both walked more than max_angle_deg away from the heading (a walk: "
            "least-squares speed of at least min_speed_m_s, explaining half the path's "
            "scatter). Its candidates are then refined "
            "(redetect.refine_steps) however light, and adopted at sustained_ratio times the "
            "estimate's weight: a track refined for many frames facing the wrong way outweighs "
            "fresh candidates facing the right way. 0: off",
        ),
    ] = 1.0
    sustained_ratio: Annotated[
        float,
        Field(ge=0, le=2, description="Acceptance ratio of a sustained flip (see sustained_s)"),
    ] = 0.6
    leg_choice: Annotated[
        Literal["feet", "refine", "heaviest"],
        Field(
            description="Leg assignment after a flip. feet: of the distinct candidates weighing "
            "at least (1 - feet_tie) times the heaviest, the one whose ankles, heels and toes "
            "are nearest the backwards estimate's seeds the filter, with the candidates whose "
            "feet are within feet_margin_m as near. refine: split the candidates into two "
            "assignments (feet near the heaviest's, and the rest; mode_separation_m), refine "
            "each with one filter step, keep the heavier (ties within continuity_tie: the feet "
            "nearer the backwards estimate's). heaviest: one filter step seeded with every "
            "candidate (the former behaviour)",
        ),
    ] = "feet"
    facing_s: Annotated[
        float,
        Field(
            ge=0,
            le=10,
            description="Face check: when no walking direction is known (standing, stepping "
            "on the spot, a slow walk), the 2D detector's nose against its shoulders, seen in "
            "profile, tells the way the person faces (KeypointCue.facing). When over this "
            "window (at least min_frames frames spanning 0.9 of it) the detections put the "
            "face behind the estimate's heading, the heading is checked facing the other way: "
            "the initial search's candidates refined, adopted at facing_ratio. Not in the "
            "seated mode. 0: off",
        ),
    ] = 0.5
    facing_min_profile: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Face check: only cameras that see the body at least this much in "
            "profile (|sin| of the angle between its facing direction and the line of sight)",
        ),
    ] = 0.5
    facing_evidence: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Face check: the mean evidence over the window must be below minus "
            "this (the nose's offset along the facing direction, a fraction of the detected "
            "person's height; about +0.03 to +0.08 when the heading is right)",
        ),
    ] = 0.02
    facing_share: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Face check: and at least this share of the window's frames must put "
            "the face behind",
        ),
    ] = 0.8
    facing_ratio: Annotated[
        float,
        Field(
            ge=0,
            le=2,
            description="Face check: the candidates facing the other way, refined "
            "(redetect.refine_steps), are adopted when they weigh at least this fraction of "
            "the estimate (the detections can mislead too)",
        ),
    ] = 0.85
    swing_s: Annotated[
        float,
        Field(
            ge=0,
            le=10,
            description="Swing check: when no walking direction is known and the face check "
            "does not turn the heading, the way the estimate's raised feet moved relative to "
            "its sacrum over this window (at least min_frames frames spanning 0.9 of it; a "
            "swing phase and more) is the way the person faces (tracker.swing): the swing foot "
            "is carried forward, on a treadmill too. When the sacrum stayed (slower than "
            "min_speed_m_s) and that way is more than max_angle_deg off the heading, the "
            "heading is checked facing it: candidates refined, adopted at facing_ratio. Only "
            "on feet some camera sees; not in the seated mode. 0: off",
        ),
    ] = 0.6
    swing_consistency: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Swing check: the raised feet's weighted velocities must agree at "
            "least this much (their sum's length over the sum of their lengths; the "
            "estimate's feet are noisy: its walks give 0.1-0.3 where the truth's give 0.7-0.8, "
            "and the refined candidates' weight decides)",
        ),
    ] = 0.1
    turn_angle_deg: Annotated[
        float,
        Field(
            ge=0,
            le=180,
            description="Turn following: when the heading is more than this (and at most "
            "max_angle_deg) off the walking direction, search turn_headings headings within "
            "turn_span_deg of the walking direction (the re-detection grid); adopt a result "
            "heavier by turn_margin. 0: off",
        ),
    ] = 25.0
    turn_source: Annotated[
        Literal["auto", "silhouette", "estimate"],
        Field(description="Turn following: path giving the walking direction (as source)"),
    ] = "silhouette"
    turn_window_s: Annotated[
        float, Field(gt=0, le=10, description="Turn following: walking-direction window")
    ] = 0.4
    turn_lead_deg: Annotated[
        float,
        Field(
            ge=0,
            le=90,
            description="Turn following: the headings are centred this much beyond the walking "
            "direction, away from the estimate's heading (the body turns ahead of its path)",
        ),
    ] = 15.0
    turn_span_deg: Annotated[
        float, Field(ge=0, le=180, description="Turn following: +- headings around the centre")
    ] = 30.0
    turn_headings: Annotated[
        int, Field(ge=1, le=72, description="Turn following: headings tried")
    ] = 5
    turn_refine: Annotated[
        bool,
        Field(
            description="Turn following: refine the turned candidates with one filter step "
            "before comparing (the coarse grid's legs rarely beat the refined estimate); the "
            "particle set is restored when the turn is not adopted",
        ),
    ] = True
    turn_trial_ratio: Annotated[
        float,
        Field(
            ge=0,
            le=2,
            description="Turn following: refine (turn_refine) only when the grid's best weighs "
            "at least this fraction of the estimate (the refinement costs a filter step)",
        ),
    ] = 0.92
    turn_margin: Annotated[
        float,
        Field(ge=0, le=1, description="Turn following: adopt when heavier by more than this"),
    ] = 0.01
    feet_tie: Annotated[
        float, Field(ge=0, le=1, description="leg_choice feet: relative weight tolerance")
    ] = 0.2
    feet_candidates: Annotated[
        int, Field(ge=1, le=1000, description="leg_choice feet: distinct candidates considered")
    ] = 30
    feet_margin_m: Annotated[
        float,
        Field(
            ge=0,
            le=5,
            description="leg_choice feet: seed the filter with the candidates whose feet are at "
            "most this much farther (mean, metres) from the backwards estimate's than the "
            "chosen one's",
        ),
    ] = 0.1
    mode_separation_m: Annotated[
        float,
        Field(
            gt=0,
            le=2,
            description="Candidates whose ankles, heels and toes are farther than this (mean, "
            "metres) from the heaviest candidate's form the other leg assignment",
        ),
    ] = 0.3
    continuity_tie: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Refined leg assignments weighing within this fraction of each other "
            "are ties: the one whose feet are nearer the backwards estimate's wins (the "
            "silhouettes placed the feet, only the heading was wrong); 0: the heavier wins",
        ),
    ] = 0.02

    @model_validator(mode="after")
    def _auto_span_fits(self) -> HeadingCheckConfig:
        if "auto" in (self.source, self.turn_source):
            window = min(
                w
                for src, w in ((self.source, self.window_s), (self.turn_source, self.turn_window_s))
                if src == "auto"
            )
            if self.auto_min_span_s > window:
                raise ValueError(
                    f"auto_min_span_s ({self.auto_min_span_s} s) must not exceed the window of a "
                    f"source set to auto ({window} s): the silhouettes' path could never decide"
                )
        return self


class LegSwapConfig(_Model):
    """Left/right leg-swap check (the legs look alike, and a local search cannot cross them).

    After the filter step the ``candidates`` heaviest distinct particles are weighed with their
    left- and right-leg DOFs exchanged; when one outweighs the estimate it becomes the estimate
    and the swapped particles join the filter's set (so the next selection keeps them).
    """

    enabled: bool = True
    candidates: Annotated[int, Field(ge=1, le=1000)] = 9
    continuity_tie: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Candidates (the estimate, the heaviest particles and their leg-swapped "
            "versions) weighing at least (1 - continuity_tie) times the heaviest are ties; the "
            "one whose ankles, heels and toes are nearest the previous estimate's wins (a "
            "stance foot does not slide). 0: a swapped particle wins only when heavier",
        ),
    ] = 0.0


class RefineConfig(_Model):
    """Deterministic local refinement of the whole pose after the filter (:mod:`tracker.refine`).

    Coordinate search by body parts: every searched DOF is moved alone to ``offsets`` values
    within +- its range, the best move of each part is combined, only improvements are kept;
    the ranges shrink by ``shrink`` per level. The refined pose joins the filter's particles.
    """

    enabled: Annotated[bool, Field(description="Refine the estimate after the filter")] = False
    offsets: Annotated[
        int,
        Field(ge=2, le=12, description="Values per DOF and level (even: +-r, +-r/2, ...)"),
    ] = 2
    levels: Annotated[
        int, Field(ge=1, le=6, description="Refinements with shrinking ranges per sweep")
    ] = 2
    shrink: Annotated[float, Field(gt=0, lt=1, description="Range factor per level")] = 0.5
    sweeps: Annotated[int, Field(ge=1, le=4, description="Repeats of all levels")] = 1
    range_flexion_deg: Annotated[
        float, Field(ge=0, le=90, description="+- range of hip and knee flexion at 20 Hz")
    ] = 6.0
    range_leg_deg: Annotated[
        float,
        Field(
            ge=0,
            le=90,
            description="+- range of the other leg DOFs (abduction, rotation, ankle) at 20 Hz",
        ),
    ] = 6.0
    upper_body: Annotated[bool, Field(description="Also search the trunk, head and arm DOFs")] = (
        True
    )
    range_upper_deg: Annotated[
        float, Field(ge=0, le=90, description="+- range of trunk, head and arm DOFs at 20 Hz")
    ] = 6.0
    root: Annotated[bool, Field(description="Also search the root (after the body parts)")] = False
    range_root_m: Annotated[float, Field(ge=0, le=1, description="+- range of x, y, z")] = 0.02
    range_root_deg: Annotated[
        float, Field(ge=0, le=90, description="+- range of heading, pitch, roll")
    ] = 3.0
    range_overrides: Annotated[
        dict[str, float],
        Field(description="Per-DOF +- range (degrees; metres for root x, y, z); 0 = not searched"),
    ] = {}
    scale_with_dt: Annotated[
        bool, Field(description="Scale the ranges with dt / reference_dt_s")
    ] = False
    top_k: Annotated[
        int,
        Field(
            ge=1,
            le=16,
            description="Refine the k heaviest distinct particles (the heaviest result is kept)",
        ),
    ] = 1
    factored: Annotated[
        bool,
        Field(description="Weigh leg moves as left x right combinations (weights_factored)"),
    ] = True
    inject: Annotated[
        bool,
        Field(
            description="Add the refined pose to the filter's particles (the next frame starts "
            "from it); off: only the output is refined"
        ),
    ] = True

    @field_validator("range_overrides")
    @classmethod
    def _overrides(cls, v: dict[str, float]) -> dict[str, float]:
        return _check_dof_keys(v, "range_overrides")


class LegRefineConfig(_Model):
    """The legs' flexion refined on the silhouettes alone after the filter (on by default with
    two cameras or more and the 2D key-point cue on): each hip's and knee's flexion is searched
    locally (:func:`tracker.refine.refine_pose`: the combinations of one move per leg, ranges
    halved per level) on the weight without the key-point cue, whose detections under-read the
    knee's bend (docs/tracker.md, "Session 38"); the pose found is the frame's estimate when
    the silhouettes prefer it. The filter's particles are left as they are."""

    enabled: Annotated[
        bool, Field(description="Refine the legs' flexion on the silhouettes after the filter")
    ] = True
    min_cameras: Annotated[
        int,
        Field(
            ge=1,
            le=16,
            description="Only with this many cameras or more (one camera's silhouette is "
            "ambiguous without the cue)",
        ),
    ] = 2
    range_deg: Annotated[
        float, Field(gt=0, le=45, description="+- range of hip and knee flexion, degrees")
    ] = 8.0
    offsets: Annotated[
        int,
        Field(ge=2, le=12, description="Values per DOF and level (even: +-r, +-r/2, ...)"),
    ] = 4
    levels: Annotated[
        int, Field(ge=1, le=6, description="Searches with ranges halved each level")
    ] = 2

    def refine_config(self) -> RefineConfig:
        """The :class:`RefineConfig` of this search: hip and knee flexion only."""
        return RefineConfig(
            enabled=True,
            offsets=self.offsets,
            levels=self.levels,
            range_flexion_deg=self.range_deg,
            range_leg_deg=0.0,
            upper_body=False,
            root=False,
            top_k=1,
            inject=False,
        )


class ArmSearchConfig(_Model):
    """Grid search of each arm after the filter (:mod:`tracker.arms`): shoulder flexion,
    abduction and rotation and elbow flexion around their current values, the rest held."""

    enabled: Annotated[
        bool,
        Field(
            description="Search the arms after the filter, with at least min_cameras cameras "
            '(docs/tracker.md, "Arm search")'
        ),
    ] = True
    min_cameras: Annotated[
        int,
        Field(
            ge=1,
            le=16,
            description="Search only with at least this many cameras: through one camera the "
            "arms took silhouette pixels the legs and depth needed and the lower limbs lost "
            "accuracy (docs/tracker.md)",
        ),
    ] = 2
    flexion_values: Annotated[
        int, Field(ge=1, le=15, description="Shoulder flexion values per grid (odd: 0 is one)")
    ] = 7
    range_flexion_deg: Annotated[
        float, Field(ge=0, le=90, description="+- range of shoulder flexion")
    ] = 30.0
    range_abduction_deg: Annotated[
        float, Field(ge=0, le=90, description="+- range of shoulder abduction (0: not searched)")
    ] = 10.0
    range_rotation_deg: Annotated[
        float, Field(ge=0, le=90, description="+- range of shoulder rotation (0: not searched)")
    ] = 20.0
    range_elbow_deg: Annotated[
        float, Field(ge=0, le=90, description="+- range of elbow flexion (0: not searched)")
    ] = 25.0
    levels: Annotated[
        int,
        Field(
            ge=1,
            le=6,
            description="Searches with shrinking ranges per call (a second level gained "
            "nothing on the benchmark's probes for twice the cost: docs/tracker.md)",
        ),
    ] = 1
    shrink: Annotated[float, Field(gt=0, lt=1, description="Range factor per level")] = 0.5
    inject: Annotated[
        bool,
        Field(
            description="Add the searched pose to the filter's particles (the next frame starts "
            "from its arms); otherwise only the output carries them"
        ),
    ] = True

    @field_validator("flexion_values")
    @classmethod
    def _odd(cls, v: int) -> int:
        if v % 2 == 0:
            raise ValueError("flexion_values must be odd (the current value is one of them)")
        return v

    @property
    def grid_size(self) -> int:
        """Poses weighed per arm and level."""
        n = 3 ** sum(
            r > 0 for r in (self.range_abduction_deg, self.range_rotation_deg, self.range_elbow_deg)
        )
        return self.flexion_values * n


class OcclusionConfig(_Model):
    """Furniture in front of the walk, learned from the silhouettes (:mod:`tracker.occlusion`):
    regions of the empty scene's image that the silhouette's lower ends lie on, frame after
    frame, and that it does not enter. Model pixels there count neither for nor against a pose.
    Needs the background image; masks given to the tracker are used whatever this says.
    """

    learn: Annotated[
        bool, Field(description="Learn occluders from the silhouettes and the background")
    ] = True
    lower_fraction: Annotated[
        float,
        Field(gt=0, le=1, description="Lower ends counted in this lower part of the silhouette"),
    ] = 0.4
    min_ends_px: Annotated[
        int, Field(ge=1, description="Lower ends on a region for a frame to support it")
    ] = 4
    min_share: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Share of the frame's counted lower ends on the region (0: any share)",
        ),
    ] = 0.5
    floor_margin_m: Annotated[
        float | None,
        Field(
            ge=0,
            description="A frame also supports a region when min_ends_px of the lower ends "
            "that lie above the floor (their ray meets the floor this far beyond the person: "
            "the silhouette's top at the stature's height) lie on it, whatever share of all "
            "ends that is; None: off",
        ),
    ] = 0.25
    min_frames: Annotated[
        int, Field(ge=1, le=10000, description="Supporting frames before a region occludes")
    ] = 4
    max_entered: Annotated[
        float,
        Field(
            ge=0,
            description="Silhouette pixels inside the region, over the track, at most this "
            "times the lower ends that lay on it",
        ),
    ] = 0.25
    min_region_px: Annotated[
        int,
        Field(
            ge=1,
            description="Smallest occluder region, likelihood pixels (0.5 % of 160x120: what "
            "hides a leg is bigger than a leg)",
        ),
    ] = 100
    min_depth: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="Mean run of the region below the lower ends that lie on it, at least "
            "this fraction of the image height (a floorboard is thin, a table top is not)",
        ),
    ] = 0.04


class AppearanceConfig(_Model):
    """The colour cue (:mod:`tracker.appearance`): per-part reference colours learned online
    from the person; the silhouette weight is multiplied by ``(score / typical) ** beta``."""

    enabled: Annotated[
        bool, Field(description="Multiply the silhouette weight by the colour agreement")
    ] = True
    size: Annotated[
        tuple[int, int], Field(description="Width, height of the colour images (area-averaged)")
    ] = (160, 120)
    beta: Annotated[
        float, Field(gt=0, le=20, description="Exponent of the colour factor (its strength)")
    ] = 0.5
    lightness_weight: Annotated[
        float,
        Field(ge=0, le=1, description="Factor on Lab lightness (shading); chroma counts fully"),
    ] = 0.3
    sigma: Annotated[
        float,
        Field(
            gt=0,
            le=100,
            description="Lab distance added (in quadrature) to each part's learned spread: "
            "the width of the colour agreement kernel",
        ),
    ] = 8.0
    samples: Annotated[
        int, Field(ge=1, le=32, description="Points scored along each capsule's axis")
    ] = 5
    axis_margin: Annotated[
        float,
        Field(
            ge=0,
            lt=0.5,
            description="Fraction of the axis skipped at each end (near joints, occlusions)",
        ),
    ] = 0.2
    merge_sides: Annotated[
        bool, Field(description="Left and right limbs share one reference colour")
    ] = True
    parts: Annotated[
        tuple[str, ...] | None,
        Field(
            description="Parts scored (tracker.appearance.PART_CAPSULES names, without left_/"
            "right_ when merge_sides); None: all. Every part is learned either way"
        ),
    ] = None
    min_weight: Annotated[
        float,
        Field(ge=0, le=1, description="Learn only from estimates with this silhouette weight"),
    ] = 0.6
    min_points: Annotated[
        int, Field(ge=1, le=1000, description="Visible points a part needs to learn from a frame")
    ] = 4
    learn_frames: Annotated[
        int,
        Field(ge=1, le=1000, description="First frames whose median is the reference"),
    ] = 10
    min_frames: Annotated[
        int, Field(ge=1, le=1000, description="Frames learned before a part is scored")
    ] = 3
    rate: Annotated[
        float,
        Field(ge=0, le=1, description="Update rate of the reference after learn_frames frames"),
    ] = 0.05
    learn_every: Annotated[
        int,
        Field(ge=1, le=1000, description="After learn_frames frames, learn from every n-th frame"),
    ] = 4


def _image_size(v: tuple[int, int]) -> tuple[int, int]:
    """Validate an image size (width, height) of the tracker's working images."""
    if not (8 <= v[0] <= 4096 and 8 <= v[1] <= 4096):
        raise ValueError("width and height must be within 8..4096")
    return v


#: The pairs of key points ``keypoints.fuse_rays`` can name (tracker.triangulation.RAY_PAIRS).
RayPair = Literal["hips", "knees", "ankles", "heels", "toes", "shoulders", "elbows", "wrists"]


class KeypointConfig(_Model):
    """The 2D key-point cue (:mod:`tracker.keypoints2d`): the model's leg key points projected
    into each camera and scored against key points a 2D pose detector found in that frame
    (given to ``Tracker.process(..., keypoints=...)``, else found by the built-in detector,
    :mod:`tracker.detector2d`); the weight is multiplied by ``(score / typical) ** beta``. On
    by default (docs/tracker.md, "2D key-point cue")."""

    enabled: Annotated[
        bool, Field(description="Multiply the weight by the detected 2D key points' agreement")
    ] = True
    detector: Annotated[
        Literal["blazepose", "none"],
        Field(
            description="The detector run on each frame given no key points: blazepose (the "
            "built-in BlazePose GHUM model) or none (only key points given by the caller)"
        ),
    ] = "blazepose"
    crop_scale: Annotated[
        float,
        Field(
            ge=1,
            le=3,
            description="The detector's square crop over the silhouette box's longer side",
        ),
    ] = 1.3
    min_presence: Annotated[
        float,
        Field(ge=0, le=1, description="Below this presence score the detector found nobody"),
    ] = 0.5
    threads: Annotated[int, Field(ge=1, le=64, description="The detector's threads")] = 1
    heatmap_refine: Annotated[
        bool,
        Field(
            description="Move the built-in detector's landmarks to their heatmaps' local "
            'centre, as MediaPipe\'s pose pipeline does (docs/tracker.md, "Session 42")',
        ),
    ] = True
    mirror: Annotated[
        bool,
        Field(
            description="Run the built-in detector also on each frame mirrored and average "
            "its key points with the frame's (twice the detector's time), with at least "
            'mirror_min_cameras cameras (opt-in: docs/tracker.md, "Session 40"); points '
            "scored by heatmaps use the first inference's maps only",
        ),
    ] = False
    mirror_min_cameras: Annotated[
        int,
        Field(
            ge=1,
            le=16,
            description="The mirrored detection only with this many cameras or more (through "
            "one camera it cost accuracy)",
        ),
    ] = 2
    shadow_given_back: Annotated[
        bool,
        Field(
            description="Give back to the silhouette the pixels the shadow test removed where "
            "the built-in detector's person segmentation covers them (dark or grey clothes "
            "taken for a shadow), with at least shadow_given_back_min_cameras cameras; the "
            "detector's first inference's output, no inference added. On by default: with "
            "two cameras and person_threshold 0.8 the key points came 4.8 mm nearer over 96 "
            "runs; the knee's range of motion in whole recordings read 1.7 deg further off "
            '(docs/tracker.md, "Shadow pixels given back under the detector\'s person")',
        ),
    ] = True
    shadow_given_back_min_cameras: Annotated[
        int,
        Field(
            ge=1,
            le=16,
            description="Give the shadow pixels back only with this many cameras or more "
            "(through one camera it gained nothing)",
        ),
    ] = 2
    person_threshold: Annotated[
        float,
        Field(
            gt=0,
            lt=1,
            description="A pixel is the person's when the detector's person probability is "
            "at least this (shadow_given_back; at 0.5 the key points gained 1.5 mm over the "
            "96 runs where 0.8 gained 4.8)",
        ),
    ] = 0.8
    beta: Annotated[
        float, Field(gt=0, le=20, description="Exponent of the key-point factor (its strength)")
    ] = 1.0
    heatmap_beta: Annotated[
        float,
        Field(
            gt=0,
            le=20,
            description="Exponent of the key-point factor when the points are scored by "
            "heatmaps (their scores are sharper than the points' Gaussians)",
        ),
    ] = 0.5
    sigma_fraction: Annotated[
        float,
        Field(
            gt=0,
            le=1,
            description="Spread of a detected point, as a fraction of the detected person's "
            "height in the image",
        ),
    ] = 0.08
    score: Annotated[
        Literal["point", "heatmap"],
        Field(
            description="How a model point is scored with one camera: point (a Gaussian of its "
            "distance to the detected point) or heatmap (the built-in detector's heatmap of that "
            "landmark where the point projects; key points given by the caller are scored as "
            "points)",
        ),
    ] = "point"
    score_multi_camera: Annotated[
        Literal["point", "heatmap"] | None,
        Field(
            description="How a model point is scored with two cameras or more (None: as score; "
            'docs/tracker.md, "Session 43")',
        ),
    ] = "heatmap"

    def gives_back_shadows(self, n_cameras: int) -> bool:
        """Whether a tracker with ``n_cameras`` cameras gives the shadow pixels under the built-in
        detector's person back to the silhouette (``shadow_given_back``, the cue on, a
        detector, at least ``shadow_given_back_min_cameras`` cameras)."""
        return (
            self.enabled
            and self.detector != "none"
            and self.shadow_given_back
            and n_cameras >= self.shadow_given_back_min_cameras
        )

    def score_for(self, n_cameras: int) -> str:
        """How a model point is scored with ``n_cameras`` cameras (``score`` or
        ``score_multi_camera``)."""
        if n_cameras > 1 and self.score_multi_camera is not None:
            return self.score_multi_camera
        return self.score

    tolerance_fraction: Annotated[
        float,
        Field(
            ge=0,
            le=1,
            description="A detected point's distances up to this fraction of the detected "
            "person's height score as a match (the detector's own error); farther ones are "
            "scored from the tolerance's edge. 0: none",
        ),
    ] = 0.0
    parts: Annotated[
        tuple[Literal["legs", "arms", "hips"], ...],
        Field(
            min_length=1,
            description="Scored parts with one camera: legs (knees, ankles, heels, toes), arms "
            "(shoulders, elbows, wrists), hips (the hip joint centres; docs/tracker.md, "
            '"Session 44")',
        ),
    ] = ("legs", "hips")
    parts_multi_camera: Annotated[
        tuple[Literal["legs", "arms", "hips"], ...] | None,
        Field(
            min_length=1,
            description="Scored parts with two cameras or more (None: as parts)",
        ),
    ] = ("legs", "arms")
    min_sigma_px: Annotated[
        float, Field(gt=0, le=100, description="Least spread in pixels (a small, far person)")
    ] = 2.0
    min_confidence: Annotated[
        float, Field(ge=0, le=1, description="Detected points less confident than this are unused")
    ] = 0.5
    rate: Annotated[
        float, Field(gt=0, le=1, description="Update rate of the typical score of estimates")
    ] = 0.2
    fuse: Annotated[
        tuple[Literal["hips", "shoulders"], ...],
        Field(
            description="Pairs of written key points moved fuse_weight of the way to their "
            "detections triangulated across the cameras, with fuse_min_cameras cameras or more "
            "(tracker.triangulation.fuse_detections; the tracker's own pose keeps the model's). "
            'Empty: none (docs/tracker.md, "Session 48")',
        ),
    ] = ("hips", "shoulders")
    fuse_vertical: Annotated[
        tuple[Literal["hips", "shoulders"], ...],
        Field(
            description="Of the fused pairs (fuse and fuse_rays), these move along the vertical "
            "only: moved across, the hips turn the thighs and change the knee angles the gait "
            "analysis reads",
        ),
    ] = ("hips",)
    fuse_min_cameras: Annotated[
        int, Field(ge=2, le=16, description="Fuse the detections only with this many cameras")
    ] = 2
    fuse_weight: Annotated[
        float,
        Field(gt=0, le=1, description="How far a fused point moves to its triangulation"),
    ] = 0.5
    fuse_max_gap_m: Annotated[
        float,
        Field(
            gt=0,
            le=2,
            description="A triangulation farther than this from the written point is not used",
        ),
    ] = 0.15
    fuse_rays: Annotated[
        tuple[RayPair, ...],
        Field(
            description="With one camera: pairs of written key points moved fuse_weight of the "
            "way across the line of sight towards the rays through their detections (their "
            "distance from the camera stays the model's; tracker.triangulation.fuse_along_rays). "
            "Not the knees, nor the ankles: moved, they change the knee angles the gait analysis "
            'reads. Empty: none (docs/tracker.md, "Session 49")',
        ),
    ] = ("hips", "heels", "toes", "shoulders", "elbows", "wrists")
    fuse_rays_full: Annotated[
        tuple[RayPair, ...],
        Field(
            description="Of fuse_rays, the pairs moved all the way to their rays (weight 1): "
            "through one camera the model's arms are not searched (arms.min_cameras), and the "
            "detector's elbows and wrists lie far nearer the truth across the line of sight "
            '(docs/tracker.md, "Session 49")',
        ),
    ] = ("elbows", "wrists")
    fuse_ray_max_gap_m: Annotated[
        float,
        Field(
            gt=0,
            le=2,
            description="A ray farther than this from the written point is not used (one camera)",
        ),
    ] = 0.5
    initial: Annotated[
        bool,
        Field(
            description="Score the first initial search's candidates too, before any estimate "
            "gave the typical score (a provisional typical). Opt-in: it fixed a track that "
            "started facing backwards but lost a crouch walk and one camera's knee angles "
            '(docs/tracker.md, "Session 48")',
        ),
    ] = False


class EdgeConfig(_Model):
    """The edge cue (:mod:`tracker.edges`): the limbs' projected outlines scored against the
    frame's edges; the weight is multiplied by ``(score / typical) ** beta``. Off by default
    (docs/tracker.md, "Edge cue")."""

    enabled: Annotated[
        bool, Field(description="Multiply the weight by the edges' agreement with the outlines")
    ] = False
    size: Annotated[tuple[int, int], Field(description="Width, height of the edge maps")] = (
        320,
        240,
    )
    beta: Annotated[
        float, Field(gt=0, le=20, description="Exponent of the edge factor (its strength)")
    ] = 0.5
    parts: Annotated[
        tuple[str, ...],
        Field(
            min_length=1, description="Parts whose outlines are scored (tracker.edges.EDGE_PARTS)"
        ),
    ] = ("upper_arm", "forearm", "thigh", "shank")
    scope: Annotated[
        Literal["all", "arm_search", "output"],
        Field(
            description="all: every weight of the likelihood; arm_search: only the arm "
            "search's choice among its grid (tracker.arms), the filters' weights untouched; "
            "output: only the written pose's arms (an arm search ranked with the cue after "
            "each estimate; the tracker's own estimate keeps the silhouette's arms)"
        ),
    ] = "all"
    samples: Annotated[
        int, Field(ge=1, le=32, description="Points scored along each side of a capsule")
    ] = 5
    axis_margin: Annotated[
        float,
        Field(ge=0, lt=0.5, description="Fraction of the axis skipped at each end (joints)"),
    ] = 0.2
    lightness_weight: Annotated[
        float, Field(ge=0, le=1, description="Factor on Lab lightness (shading edges)")
    ] = 1.0
    blur_px: Annotated[
        float, Field(ge=0, le=10, description="Gaussian smoothing before the gradient, pixels")
    ] = 1.0
    margin_px: Annotated[
        int, Field(ge=0, le=20, description="Edges kept up to this far outside the silhouette")
    ] = 2
    scale_percentile: Annotated[
        float,
        Field(
            gt=0,
            lt=100,
            description="Percentile of the gradient magnitude inside the silhouette that "
            "scores 1 (edges at least this strong score 1)",
        ),
    ] = 90.0
    min_scale: Annotated[
        float,
        Field(
            gt=0,
            le=100,
            description="Least gradient (Lab units per pixel) that scores 1, whatever the "
            "percentile (sensor noise must not score)",
        ),
    ] = 2.0
    interior_px: Annotated[
        int,
        Field(
            ge=0,
            le=20,
            description="If > 0, only edges this many pixels inside the silhouette count (the "
            "outline against the room is left to the silhouette term)",
        ),
    ] = 0
    rate: Annotated[
        float, Field(gt=0, le=1, description="Update rate of the typical score of estimates")
    ] = 0.2

    @field_validator("parts")
    @classmethod
    def _parts(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        from tracker.edges import EDGE_PARTS

        unknown = sorted(set(v) - set(EDGE_PARTS))
        if unknown:
            raise ValueError(
                f"unknown part(s) {', '.join(unknown)}; known: {', '.join(EDGE_PARTS)}"
            )
        return v

    @field_validator("size")
    @classmethod
    def _size(cls, v: tuple[int, int]) -> tuple[int, int]:
        return _image_size(v)


class SmoothingConfig(_Model):
    """Fixed-lag smoothing of the key points written by ``gaitwatch track``
    (:mod:`tracker.smoothing`; ``Tracker.process`` itself returns each frame's own estimate)."""

    enabled: Annotated[
        bool, Field(description="Smooth the key points of each continuous track")
    ] = True
    window_s: Annotated[
        float,
        Field(
            gt=0,
            le=5,
            description="Window of the centred local polynomial fit, seconds (odd number of "
            "frames at the video's rate); the output lags the input by half of it",
        ),
    ] = 0.45
    order: Annotated[int, Field(ge=0, le=4, description="Polynomial order")] = 2
    feet_order: Annotated[
        int | None,
        Field(
            ge=0,
            le=4,
            description="Polynomial order for the ankles, heels and toes (None: ``order``). "
            "Their stop-and-go between stance and swing marks the gait events, which a "
            "quadratic over the window rounds off (heel strike late, double support short)",
        ),
    ] = 4
    max_gap_s: Annotated[
        float, Field(gt=0, le=10, description="A longer step between two frames ends a segment")
    ] = 0.5
    depth_window_s: Annotated[
        float,
        Field(
            ge=0,
            le=5,
            description="With one camera: the body's distance from it (its key points' centroid "
            "along the horizontal line of sight) is fitted over this longer window and each "
            "frame's key points are moved along the line of sight onto the fit; one view "
            "observes that distance worst. The output then lags by half of this window if it "
            "is the longer. 0: off",
        ),
    ] = 0.75
    depth_order: Annotated[
        int, Field(ge=0, le=4, description="Polynomial order of the distance's fit")
    ] = 1
    balance: Annotated[
        float,
        Field(
            ge=0,
            le=2,
            description="With one camera (and the depth stage on): the pelvis's sideways offset "
            "from the feet's centre, averaged over the depth window (frames whose feet are not "
            "seen count as none), is taken back along the line of sight by this share of its "
            "component there: the hips and the body above them move by it, the knees by half, "
            "the feet stay. A standing or walking body keeps its pelvis over its feet, and one "
            "view cannot see the offset along its line of sight. 0: off",
        ),
    ] = 1.0


class EnsembleConfig(_Model):
    """Several independent tracks of the same footage, their key points averaged
    (:mod:`tracker.ensemble`).

    Each track is a whole :class:`tracker.pipeline.Tracker` with its own random draws, on the
    same silhouettes, and gets ``1 / tracks`` of the filter's likelihood evaluations (the IPF's
    ``kept``, or ``evaluations``, divided), so the filters stay at equal evaluations among
    themselves. The tracks go astray in different frames and in different ways (a leg half a
    cycle behind, the body too near the camera), so their mean errs less than any one of them.
    """

    tracks: Annotated[
        int,
        Field(
            ge=1,
            le=8,
            description="Independent tracks whose key points are averaged (1: one tracker, "
            "no averaging)",
        ),
    ] = 1


class LegLabelConfig(_Model):
    """Which leg is which in the key points written by ``gaitwatch track``
    (:mod:`tracker.leglabels`): each frame keeps the tracker's labels or has the legs' key
    points exchanged, whichever makes the feet move most smoothly, decided ``lag_s`` later."""

    enabled: Annotated[
        bool, Field(description="Choose each frame's leg labelling by smooth motion")
    ] = True
    lag_s: Annotated[
        float,
        Field(ge=0, le=5, description="A frame's labelling is decided this long after it, s"),
    ] = 0.5
    swap_cost_m2: Annotated[
        float,
        Field(
            ge=0,
            le=10,
            description="Cost of each frame whose labels are exchanged (m^2; the motion cost is "
            "the summed squared second difference of 8 leg points, m^2)",
        ),
    ] = 0.03
    max_gap_s: Annotated[
        float, Field(gt=0, le=10, description="A longer step between two frames ends a segment")
    ] = 0.5
    single_camera: Annotated[
        Literal["auto", "on", "off"],
        Field(
            description="With one camera: 'auto' chooses the labels only when the 2D key-point "
            "cue has no detections to score (it is off, or its detector does not run), where "
            "smooth motion was measured to help; with the cue, one camera's own labels did "
            "better. Two cameras or more always choose them (when enabled)"
        ),
    ] = "auto"


class ReviseConfig(_Model):
    """Backward pass over the first frames of a track (``Tracker`` attaches the result to a
    later frame's :class:`tracker.pipeline.FrameResult` as ``revisions``).

    A track starts from the initial search's coarse grid and takes several frames to settle;
    a heading flip (``heading_check``) re-initialises it again. Once the track has run
    ``settle_s`` seconds since its last (re-)initialisation, a copy of the tracker in that
    settled state tracks the frames since the track began backwards in time (the filter's
    motion turned around, no heading check: the person walks backwards in reversed time), and
    its estimates replace those of the forward pass. Consumers that hold the results of the
    frames still open to revision (:class:`tracker.revision.ResultQueue`) write the revised
    ones; the output then lags the input by up to ``max_s``.
    """

    enabled: Annotated[bool, Field(description="Run the backward pass")] = True
    settle_s: Annotated[
        float,
        Field(
            gt=0,
            le=10,
            description="Seconds of tracking since the last (re-)initialisation after which the "
            "track counts as settled and the backward pass runs",
        ),
    ] = 0.9
    max_s: Annotated[
        float,
        Field(
            gt=0,
            le=60,
            description="At most this many seconds of frames are kept for the pass (the oldest "
            "are then final as tracked); bounds the output delay and the memory",
        ),
    ] = 4.0
    label_votes: Annotated[
        int,
        Field(
            ge=0,
            le=1000,
            description="Where the backward pass's legs are the forward pass's exchanged over a "
            "run of frames, the 2D key-point detections decide which leg is which: the run's "
            "legs are exchanged back when the detections favour the forward pass's labels on "
            "at least this many more of its frames than not (summed over the cameras' "
            "evidence per frame). Frames at 20 Hz (reference_dt_s): the same time at the "
            "cameras' frame rate. 0: the backward pass's labels stand (docs/tracker.md, "
            '"Session 51")',
        ),
    ] = 3
    label_votes_max_cameras: Annotated[
        int,
        Field(
            ge=1,
            le=16,
            description="label_votes decides only with at most this many cameras: with two "
            "the passes seldom disagree on the legs, and the one run of 48 where the votes "
            "decided was made worse (measured)",
        ),
    ] = 1

    @model_validator(mode="after")
    def _window(self) -> ReviseConfig:
        if self.max_s < self.settle_s:
            raise ValueError("max_s must be at least settle_s")
        return self


class CollisionConfig(_Model):
    """The non-penetration prior (:mod:`tracker.collision`): arms may not sink into the trunk
    or pelvis further than at rest. Off by default: measured neutral (docs/tracker.md)."""

    enabled: Annotated[
        bool, Field(description="Multiply the weight by the non-penetration factor")
    ] = False
    tolerance_m: Annotated[
        float,
        Field(ge=0, le=0.2, description="Depth allowed beyond a capsule pair's depth at rest, m"),
    ] = 0.01
    softness_m: Annotated[
        float,
        Field(gt=0, le=0.5, description="Further depth over which the factor falls to 0, m"),
    ] = 0.03


class TrackerConfig(_Model):
    """Everything the tracking pipeline needs besides cameras, footage and a seed."""

    filter: FilterName = "ipf"
    ipf: IPFConfig = Field(default_factory=IPFConfig)
    apf: APFConfig = Field(default_factory=APFConfig)
    condensation: CondensationConfig = Field(default_factory=CondensationConfig)
    evaluations: Annotated[
        int | None,
        Field(
            ge=1,
            description="Likelihood evaluations per frame for the baselines "
            "(default: the IPF's M * q^n)",
        ),
    ] = None
    origin: OriginSearchConfig = Field(default_factory=OriginSearchConfig)
    init: InitConfig = Field(default_factory=InitConfig)
    ensemble: EnsembleConfig = Field(default_factory=EnsembleConfig)
    leg_labels: LegLabelConfig = Field(default_factory=LegLabelConfig)
    smoothing: SmoothingConfig = Field(default_factory=SmoothingConfig)
    revise: ReviseConfig = Field(default_factory=ReviseConfig)
    redetect: RedetectConfig = Field(default_factory=RedetectConfig)
    seated: SeatedConfig = Field(default_factory=SeatedConfig)
    heading_check: HeadingCheckConfig = Field(default_factory=HeadingCheckConfig)
    leg_swap: LegSwapConfig = Field(default_factory=LegSwapConfig)
    refine: RefineConfig = Field(default_factory=RefineConfig)
    leg_refine: LegRefineConfig = Field(default_factory=LegRefineConfig)
    arms: ArmSearchConfig = Field(default_factory=ArmSearchConfig)
    appearance: AppearanceConfig = Field(default_factory=AppearanceConfig)
    edges: EdgeConfig = Field(default_factory=EdgeConfig)
    keypoints: KeypointConfig = Field(default_factory=KeypointConfig)
    collision: CollisionConfig = Field(default_factory=CollisionConfig)
    occlusion: OcclusionConfig = Field(default_factory=OcclusionConfig)
    limits_profile: Annotated[str, Field(description="tracker.dof limit profile")] = "walking"
    limits_overrides_deg: dict[str, tuple[float, float]] = {}
    reference_dt_s: Annotated[float, Field(gt=0, le=1)] = 0.05
    likelihood_size: Annotated[
        tuple[int, int], Field(description="Width, height of the likelihood images")
    ] = (160, 120)
    lost_weight: Annotated[
        float, Field(ge=0, description="Best weight below this counts as a bad frame")
    ] = 0.25
    lost_frames: Annotated[
        int, Field(ge=1, le=1000, description="Bad frames in a row before re-initialisation")
    ] = 5
    segmentation: Annotated[
        SegmentationConfig,
        Field(
            description="Background subtraction; its output_size is set to likelihood_size, "
            "and static mode without background images falls back to mog2"
        ),
    ] = Field(default_factory=SegmentationConfig)
    floor: Annotated[
        Literal["above", "contact", "off"],
        Field(
            description="Floor constraint on each estimate (root height moved, pose re-weighed): "
            "above = no key point below the floor; contact = the lowest key point on the floor "
            "(someone standing, walking or lying, not jumping); off"
        ),
    ] = "contact"
    floor_tolerance_m: Annotated[float, Field(ge=0, le=0.5)] = 0.02
    min_silhouette_px: Annotated[
        int,
        Field(
            ge=0,
            description="Fewer silhouette pixels (all cameras, likelihood "
            "resolution) means nobody in view",
        ),
    ] = 30
    part_box: Annotated[
        tuple[float, float],
        Field(
            description="Blob choice (several blobs in a camera, a track under way): a blob "
            "also counts as the followed person's when its centre lies inside the followed "
            "blob's box widened on each side by part_box[0] and extended downwards by "
            "part_box[1] times the box's height (feet cut off by legs the segmentation "
            "misses: bare legs over a floor of their colour, under a skirt). (0, 0): only "
            "blobs inside the track's model",
        ),
    ] = (0.25, 0.5)

    @field_validator("limits_profile")
    @classmethod
    def _profile(cls, v: str) -> str:
        if v not in LIMIT_PROFILES:
            raise ValueError(f"unknown profile {v!r}; known: {', '.join(LIMIT_PROFILES)}")
        return v

    @field_validator("likelihood_size")
    @classmethod
    def _size(cls, v: tuple[int, int]) -> tuple[int, int]:
        return _image_size(v)

    @field_validator("part_box")
    @classmethod
    def _part_box(cls, v: tuple[float, float]) -> tuple[float, float]:
        if not all(0.0 <= x <= 3.0 for x in v):
            raise ValueError("both factors must be within 0..3")
        return v

    @model_validator(mode="after")
    def _limits_keys(self) -> TrackerConfig:
        unknown = sorted(set(self.limits_overrides_deg) - set(DOF_NAMES))
        if unknown:
            raise ValueError(f"limits_overrides_deg: unknown DOF(s) {', '.join(unknown)}")
        return self

    def divided_budget(self, parts: float) -> TrackerConfig:
        """These settings with the filters' likelihood evaluations divided by ``parts`` (>= 1):
        the IPF's ``kept`` and, when set, the baselines' ``evaluations`` (rounded, at least 1;
        unset, they follow the IPF's). Several tracks share a budget so; so do the trials of
        ``redetect.trial_share``."""
        if not parts >= 1:
            raise ValueError(f"the budget is divided into at least 1 part, not {parts}")
        update: dict = {
            "ipf": self.ipf.model_copy(update={"kept": max(1, round(self.ipf.kept / parts))})
        }
        if self.evaluations is not None:
            update["evaluations"] = max(1, round(self.evaluations / parts))
        return self.model_copy(update=update)

    @property
    def evaluations_per_frame(self) -> int:
        """Likelihood evaluations per frame of the body-part filter (all filters)."""
        return self.evaluations if self.evaluations is not None else self.ipf.evaluations

    def joint_limits(self):  # -> tracker.dof.JointLimits
        from tracker.dof import JointLimits

        lim = JointLimits.profile(self.limits_profile)
        if self.limits_overrides_deg:
            lim = lim.with_overrides(self.limits_overrides_deg)
        return lim

    def seated_limits(self):  # -> tracker.dof.JointLimits
        """The limits of the seated mode (``seated``): :meth:`joint_limits` with
        ``tracker.dof.SEATED_DOFS`` widened to the general profile's ranges."""
        from tracker.dof import SEATED_DOFS, JointLimits

        return self.joint_limits().widened(JointLimits.profile("general"), SEATED_DOFS)


def _format(source: str, err: ValidationError) -> str:
    parts = []
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "(file)"
        msg = "unknown key" if e["type"] == "extra_forbidden" else e["msg"]
        parts.append(f"{loc}: {msg}")
    return f"{source}: " + "; ".join(parts)


def parse_tracker_config(data: Any, source: str = "<config>") -> TrackerConfig:
    """Validate a parsed configuration mapping; raises :class:`TrackerConfigError`."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise TrackerConfigError(f"{source}: expected a mapping, got {type(data).__name__}")
    try:
        return TrackerConfig.model_validate(data)
    except ValidationError as err:
        raise TrackerConfigError(_format(source, err)) from None


def load_tracker_config(path: str | Path) -> TrackerConfig:
    """Load a TOML (``.toml``) or YAML (anything else) tracker configuration file."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise TrackerConfigError(f"{path}: no such file") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as err:
        raise TrackerConfigError(f"{path}: cannot read ({err.__class__.__name__})") from None
    if path.suffix.lower() == ".toml":
        import tomllib

        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as err:
            raise TrackerConfigError(f"{path}: not valid TOML ({err})") from None
    else:
        import yaml

        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as err:
            raise TrackerConfigError(
                f"{path}: not valid YAML ({str(err).splitlines()[0]})"
            ) from None
    return parse_tracker_config(data, str(path))
