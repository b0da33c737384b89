"""Settings of a synthetic scene, validated at the edge (pydantic, unknown keys forbidden).

:class:`SceneConfig` is everything ``gaitwatch simulate`` needs besides the motion and the
cameras; it is written back into ``scene.json`` so a scene can be rebuilt exactly. Body-shape
presets (:data:`SHAPE_PRESETS`) and the random choice of clothing colours
(:func:`resolve_body`) live here too.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

ShapeName = Literal["default", "tall", "short", "heavy", "slim"]
ClothingStyle = Literal["fitted", "loose", "skirt", "coat"]
ViewName = Literal["side", "oblique", "frontal"]
RGB = tuple[int, int, int]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class BodyShape(_Model):
    """The rendered person's build (the motion's skeleton gives the pose)."""

    preset: Annotated[ShapeName, Field(description="Named variant, see SHAPE_PRESETS")] = "default"
    height_m: Annotated[
        float | None,
        Field(gt=0.8, lt=2.4, description="Stature to scale the motion to; None keeps its own"),
    ] = None
    girth: Annotated[
        float | None, Field(gt=0.5, lt=2.5, description="Width multiplier of trunk and limbs")
    ] = None
    belly: Annotated[
        float | None, Field(gt=0.5, lt=3.0, description="Extra depth of the abdomen")
    ] = None


# preset -> (height_m or None, girth, belly)
SHAPE_PRESETS: dict[str, tuple[float | None, float, float]] = {
    "default": (None, 1.0, 1.0),
    "tall": (1.92, 0.95, 1.0),
    "short": (1.55, 1.0, 1.05),
    "heavy": (None, 1.25, 1.35),
    "slim": (None, 0.82, 0.9),
}


class Clothing(_Model):
    """Clothing style and colours (RGB 0-255; None draws one from the scene's generator)."""

    style: Annotated[
        ClothingStyle,
        Field(
            description="fitted; loose (wider shirt and thighs, flared trousers); skirt (flared "
            "from the waist to below the knees); coat (wide trunk and sleeves, to mid-thigh)"
        ),
    ] = "fitted"
    long_sleeves: bool = True
    pattern: Annotated[
        Literal["plain", "stripes", "checks", "random"],
        Field(description="Pattern of the shirt (or coat): plain, stripes, checks, random"),
    ] = "random"
    shirt: RGB | None = None
    trousers: RGB | None = None
    skin: RGB | None = None
    shoes: RGB | None = None
    hair: RGB | None = None


class Lighting(_Model):
    """Light over time: a global gain drift and an optional ceiling lamp switching off."""

    mode: Annotated[
        Literal["steady", "drift", "switch"],
        Field(description="steady; drift (slow gain changes); switch (drift + lamp off mid-clip)"),
    ] = "drift"
    drift_amplitude: Annotated[
        float, Field(ge=0, le=0.5, description="Max relative gain change")
    ] = 0.08
    switch_time_s: Annotated[
        float | None, Field(ge=0, description="Lamp-off time for mode=switch; None = mid-clip")
    ] = None
    lamp_power: Annotated[float, Field(ge=0, le=5, description="Lamp strength (relative)")] = 1.0
    ambient: Annotated[float, Field(gt=0, le=2, description="Ambient light level")] = 0.55
    shadow_strength: Annotated[float, Field(ge=0, le=1)] = 0.6
    shadow_blur_px: Annotated[float, Field(ge=0, le=50)] = 3.0


class Noise(_Model):
    """Sensor effects applied to every frame and to the background images."""

    sigma_dn: Annotated[float, Field(ge=0, le=50, description="Gaussian noise, 8-bit units")] = 2.0
    blur_px: Annotated[float, Field(ge=0, le=5, description="Optical blur sigma, pixels")] = 0.6
    jpeg_quality: Annotated[
        int | None,
        Field(ge=5, le=100, description="JPEG round trip per frame (codec artefacts); None = off"),
    ] = None


class Room(_Model):
    """The room around the walk: procedural textures and furniture."""

    floor: Annotated[Literal["wood", "tiles", "random"], Field()] = "random"
    height_m: Annotated[float, Field(gt=2.0, le=5.0)] = 2.6
    margin_m: Annotated[float, Field(ge=0.5, le=10, description="Floor beyond the walk")] = 1.5
    occluder: Annotated[
        Literal["none", "table", "sofa", "chair"],
        Field(
            description="Furniture: a table or sofa between the first camera and the walk, "
            "hiding the legs; or a chair under each place where the person sits"
        ),
    ] = "none"


class SceneConfig(_Model):
    """Everything about a synthetic scene besides the motion and site cameras."""

    views: Annotated[
        list[ViewName], Field(min_length=1, description="Default camera placements")
    ] = ["side", "oblique", "frontal"]
    image_size: tuple[
        Annotated[int, Field(ge=32, le=4096)], Annotated[int, Field(ge=32, le=4096)]
    ] = (
        640,
        480,
    )
    fps: Annotated[float, Field(gt=1, le=240)] = 25.0
    seed: int = 0
    max_frames: Annotated[int | None, Field(ge=1)] = None
    hfov_deg: Annotated[float, Field(gt=20, lt=150, description="Default cameras' field")] = 70.0
    camera_height_m: Annotated[float, Field(gt=0.3, lt=5)] = 2.3
    body: BodyShape = BodyShape()
    clothing: Clothing = Clothing()
    lighting: Lighting = Lighting()
    noise: Noise = Noise()
    room: Room = Room()
    masks: Annotated[bool, Field(description="Also write the person's silhouette masks")] = False
    video_format: Annotated[Literal["mp4", "png"], Field(description="mp4v video or PNGs")] = "mp4"


class ResolvedBody(_Model):
    """The body actually rendered: numbers and colours fixed (written to scene.json)."""

    stature_m: float
    girth: float
    belly: float
    style: ClothingStyle
    long_sleeves: bool
    pattern: Literal["plain", "stripes", "checks"]
    pattern_period_m: float
    shirt: RGB
    trousers: RGB
    skin: RGB
    shoes: RGB
    hair: RGB


_SHIRTS: list[RGB] = [
    (40, 80, 160), (170, 40, 40), (50, 120, 70), (220, 220, 215), (120, 120, 125),
    (200, 150, 60), (110, 60, 130), (30, 140, 150),
]  # fmt: skip
_TROUSERS: list[RGB] = [
    (35, 45, 80), (30, 30, 32), (170, 150, 110), (90, 90, 95), (70, 50, 40), (60, 80, 110),
]  # fmt: skip
_SKINS: list[RGB] = [(235, 200, 175), (215, 170, 140), (180, 130, 100), (140, 95, 70), (95, 65, 50)]
_SHOES: list[RGB] = [(25, 25, 25), (230, 230, 230), (110, 70, 40), (60, 60, 70)]
_HAIR: list[RGB] = [(30, 25, 20), (90, 60, 35), (200, 170, 110), (170, 170, 170), (225, 225, 225)]


def resolve_body(
    shape: BodyShape, clothing: Clothing, motion_stature_m: float, rng: np.random.Generator
) -> ResolvedBody:
    """Fix the body's numbers and colours: preset, explicit overrides, then random colours."""
    p_height, p_girth, p_belly = SHAPE_PRESETS[shape.preset]
    stature = shape.height_m or p_height or motion_stature_m

    def pick(value: RGB | None, palette: list[RGB]) -> RGB:
        choice = palette[int(rng.integers(len(palette)))]  # always draw: stable streams
        return tuple(int(c) for c in value) if value is not None else choice

    patterns = ("plain", "plain", "stripes", "checks")
    pattern = patterns[int(rng.integers(len(patterns)))]
    period = float(rng.uniform(0.03, 0.09))
    return ResolvedBody(
        pattern=pattern if clothing.pattern == "random" else clothing.pattern,
        pattern_period_m=period,
        stature_m=float(stature),
        girth=float(shape.girth if shape.girth is not None else p_girth),
        belly=float(shape.belly if shape.belly is not None else p_belly),
        style=clothing.style,
        long_sleeves=clothing.long_sleeves,
        shirt=pick(clothing.shirt, _SHIRTS),
        trousers=pick(clothing.trousers, _TROUSERS),
        skin=pick(clothing.skin, _SKINS),
        shoes=pick(clothing.shoes, _SHOES),
        hair=pick(clothing.hair, _HAIR),
    )
