"""Calibrated pinhole cameras: the CONVENTIONS camera file, and batched projection.

One YAML file per camera (``shared/CONVENTIONS.md``)::

    name: living-room
    image_size: [640, 480]     # width, height
    fps: 20
    K: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
    dist: [k1, k2, p1, p2, k3] # OpenCV coefficients; [] or omitted for none
    R: [[...], [...], [...]]   # world -> camera rotation
    t: [tx, ty, tz]            # X_cam = R @ X_world + t, metres

The projection follows OpenCV's model exactly (``cv2.projectPoints``) for 4, 5, 8, 12 or 14
distortion coefficients, vectorised in numpy over any batch shape.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from gaitwatch.errors import InputError


class CameraFileError(InputError):
    """A camera file that cannot be used; the message names the file and the field."""


_ORTHO_TOL = 1e-3


class CameraModel(BaseModel):
    """The content of one camera file, validated."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: Annotated[str, Field(min_length=1, description="Free text, unique per site")]
    image_size: Annotated[
        tuple[int, int], Field(description="Width and height in pixels of the frames")
    ]
    fps: Annotated[float, Field(gt=0, description="Nominal frame rate")] = 20.0
    K: Annotated[
        tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]],
        Field(description="Intrinsic matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]"),
    ]
    dist: Annotated[
        tuple[float, ...], Field(description="OpenCV distortion coefficients (0, 4, 5, 8, 12, 14)")
    ] = ()
    R: Annotated[
        tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]],
        Field(description="World -> camera rotation"),
    ]
    t: Annotated[tuple[float, float, float], Field(description="World -> camera translation, m")]

    @field_validator("image_size")
    @classmethod
    def _size_positive(cls, v: tuple[int, int]) -> tuple[int, int]:
        if v[0] <= 0 or v[1] <= 0:
            raise ValueError("width and height must be positive")
        return v

    @field_validator("dist", mode="before")
    @classmethod
    def _dist_none(cls, v: Any) -> Any:
        return () if v is None else v

    @field_validator("dist")
    @classmethod
    def _dist_len(cls, v: tuple[float, ...]) -> tuple[float, ...]:
        if len(v) not in (0, 4, 5, 8, 12, 14):
            raise ValueError(f"must have 0, 4, 5, 8, 12 or 14 coefficients, not {len(v)}")
        if not all(np.isfinite(v)):
            raise ValueError("coefficients must be finite")
        return v

    @field_validator("K")
    @classmethod
    def _k_valid(cls, v: Any) -> Any:
        k = np.asarray(v, dtype=float)
        if not np.all(np.isfinite(k)):
            raise ValueError("entries must be finite")
        if k[0, 0] <= 0 or k[1, 1] <= 0:
            raise ValueError(f"focal lengths must be positive (fx={k[0, 0]}, fy={k[1, 1]})")
        if (
            abs(k[1, 0]) > 1e-9
            or abs(k[2, 0]) > 1e-9
            or abs(k[2, 1]) > 1e-9
            or abs(k[2, 2] - 1) > 1e-9
        ):
            raise ValueError("must have the form [[fx, s, cx], [0, fy, cy], [0, 0, 1]]")
        return v

    @field_validator("R")
    @classmethod
    def _r_orthonormal(cls, v: Any) -> Any:
        r = np.asarray(v, dtype=float)
        if not np.all(np.isfinite(r)):
            raise ValueError("entries must be finite")
        err = float(np.abs(r @ r.T - np.eye(3)).max())
        if err > _ORTHO_TOL:
            raise ValueError(f"is not orthonormal (max |R R^T - I| = {err:.3g})")
        if np.linalg.det(r) < 0:
            raise ValueError("is a reflection (det R = -1), not a rotation")
        return v

    @field_validator("t")
    @classmethod
    def _t_finite(cls, v: Any) -> Any:
        if not np.all(np.isfinite(v)):
            raise ValueError("entries must be finite")
        return v

    @model_validator(mode="after")
    def _principal_point_inside(self) -> CameraModel:
        w, h = self.image_size
        cx, cy = self.K[0][2], self.K[1][2]
        if not (0 <= cx <= w and 0 <= cy <= h):
            raise ValueError(f"principal point ({cx}, {cy}) lies outside the {w}x{h} image")
        return self


class Camera:
    """A calibrated camera: projection of world points to pixels, batched.

    Build one with :func:`load_camera` or :meth:`Camera.from_model`; ``scaled`` gives the same
    camera at another image resolution (the likelihood runs at a reduced resolution).
    """

    def __init__(self, model: CameraModel, source: str = "") -> None:
        self.model = model
        self.source = source
        self.name = model.name
        self.width, self.height = model.image_size
        self.fps = float(model.fps)
        self.K = np.asarray(model.K, dtype=np.float64)
        self.dist = np.asarray(model.dist, dtype=np.float64)
        self.R = np.asarray(model.R, dtype=np.float64)
        self.t = np.asarray(model.t, dtype=np.float64)

    @classmethod
    def from_model(cls, model: CameraModel, source: str = "") -> Camera:
        return cls(model, source)

    @classmethod
    def from_params(
        cls,
        *,
        name: str,
        image_size: tuple[int, int],
        K: np.ndarray,
        R: np.ndarray,
        t: np.ndarray,
        dist: Sequence[float] = (),
        fps: float = 20.0,
    ) -> Camera:
        model = CameraModel(
            name=name,
            image_size=(int(image_size[0]), int(image_size[1])),
            fps=fps,
            K=np.asarray(K, dtype=float).tolist(),
            dist=[float(d) for d in dist],
            R=np.asarray(R, dtype=float).tolist(),
            t=np.asarray(t, dtype=float).tolist(),
        )
        return cls(model)

    @classmethod
    def look_at(
        cls,
        *,
        name: str,
        position: Sequence[float],
        target: Sequence[float],
        image_size: tuple[int, int] = (640, 480),
        hfov_deg: float = 60.0,
        fps: float = 20.0,
        dist: Sequence[float] = (),
    ) -> Camera:
        """A camera at ``position`` looking at ``target`` with the image's x axis horizontal."""
        c = np.asarray(position, dtype=float)
        z = np.asarray(target, dtype=float) - c
        z /= np.linalg.norm(z)
        up = np.array([0.0, 0.0, 1.0])
        x = np.cross(z, up)
        if np.linalg.norm(x) < 1e-6:  # looking straight down or up
            x = np.array([1.0, 0.0, 0.0])
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        R = np.stack([x, y, z])
        w, h = image_size
        f = 0.5 * w / np.tan(np.radians(hfov_deg) / 2)
        K = np.array([[f, 0, w / 2], [0, f, h / 2], [0, 0, 1]])
        return cls.from_params(
            name=name, image_size=image_size, K=K, R=R, t=-R @ c, dist=dist, fps=fps
        )

    # -- geometry ---------------------------------------------------------------------------
    @property
    def center(self) -> np.ndarray:
        """Optical centre in world coordinates, shape (3,)."""
        return -self.R.T @ self.t

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) -> camera coordinates (..., 3)."""
        return np.asarray(points, dtype=np.float64) @ self.R.T + self.t

    def project(self, points: np.ndarray) -> np.ndarray:
        """Project world points (..., 3) to pixels (..., 2) with OpenCV's distortion model.

        Points behind the camera (z_cam <= 0) project to NaN.
        """
        pc = self.to_camera(points)
        z = pc[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(z > 0, pc[..., 0] / z, np.nan)
            y = np.where(z > 0, pc[..., 1] / z, np.nan)
        x, y = distort(x, y, self.dist)
        K = self.K
        u = K[0, 0] * x + K[0, 1] * y + K[0, 2]
        v = K[1, 1] * y + K[1, 2]
        return np.stack([u, v], axis=-1)

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Depth along the optical axis (z in camera coordinates) of world points (..., 3)."""
        return self.to_camera(points)[..., 2]

    def pixel_rays(self, pixels: np.ndarray) -> np.ndarray:
        """Unit world-frame directions of the rays through pixels (..., 2), distortion undone."""
        import cv2

        px = np.asarray(pixels, dtype=np.float64).reshape(-1, 1, 2)
        und = cv2.undistortPoints(px, self.K, self.dist if self.dist.size else None).reshape(-1, 2)
        d = np.concatenate([und, np.ones((und.shape[0], 1))], axis=1) @ self.R
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return d.reshape(np.asarray(pixels).shape[:-1] + (3,))

    def pixel_to_floor(self, pixels: np.ndarray, height: float = 0.0) -> np.ndarray:
        """World points where the rays through pixels (..., 2) meet the plane z = ``height``.

        NaN where the ray does not reach the plane in front of the camera.
        """
        d = self.pixel_rays(pixels)
        c = self.center
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (height - c[2]) / d[..., 2]
        s = np.where(s > 0, s, np.nan)
        return c + s[..., None] * d

    def scaled(self, width: int, height: int) -> Camera:
        """The same camera for images resized to ``width`` x ``height`` pixels."""
        sx, sy = width / self.width, height / self.height
        K = self.K.copy()
        K[0, :] *= sx
        K[1, :] *= sy
        # Pixel centres: OpenCV's resize maps pixel centre (u + 0.5) * s - 0.5.
        K[0, 2] = (self.K[0, 2] + 0.5) * sx - 0.5
        K[1, 2] = (self.K[1, 2] + 0.5) * sy - 0.5
        cam = Camera.from_params(
            name=self.name,
            image_size=(width, height),
            K=K,
            R=self.R,
            t=self.t,
            dist=self.dist.tolist(),
            fps=self.fps,
        )
        cam.source = self.source
        return cam

    def to_dict(self) -> dict[str, Any]:
        """The camera file's content as plain Python types."""
        return camera_model_to_dict(self.model)

    def __repr__(self) -> str:
        return f"Camera({self.name!r}, {self.width}x{self.height}, centre={self.center.round(3)})"


def distort(x: np.ndarray, y: np.ndarray, dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Apply OpenCV's lens distortion to normalised image coordinates (any shape)."""
    n = dist.size
    if n == 0 or not np.any(dist):
        return x, y
    k = np.zeros(14)
    k[:n] = dist
    k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tx, ty = k
    if tx != 0 or ty != 0:
        raise NotImplementedError("tilted-sensor distortion (tauX, tauY) is not supported")
    r2 = x * x + y * y
    r4 = r2 * r2
    r6 = r4 * r2
    radial = (1 + k1 * r2 + k2 * r4 + k3 * r6) / (1 + k4 * r2 + k5 * r4 + k6 * r6)
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) + s1 * r2 + s2 * r4
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + s3 * r2 + s4 * r4
    return xd, yd


def camera_model_to_dict(model: CameraModel) -> dict[str, Any]:
    d = model.model_dump()
    return {
        "name": d["name"],
        "image_size": list(d["image_size"]),
        "fps": d["fps"],
        "K": [list(r) for r in d["K"]],
        "dist": list(d["dist"]),
        "R": [list(r) for r in d["R"]],
        "t": list(d["t"]),
    }


def _format_validation_error(path: str, err: ValidationError) -> str:
    parts = []
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "(file)"
        msg = e["msg"]
        if e["type"] == "missing":
            msg = "missing key"
        elif e["type"] == "extra_forbidden":
            msg = "unknown key"
        parts.append(f"{loc}: {msg}")
    return f"{path}: " + "; ".join(parts)


def parse_camera(data: Any, source: str = "<camera>") -> Camera:
    """Validate a camera file's parsed content; raises :class:`CameraFileError`."""
    if not isinstance(data, dict):
        raise CameraFileError(
            f"{source}: expected a mapping of camera fields, got {type(data).__name__}"
        )
    try:
        model = CameraModel.model_validate(data)
    except ValidationError as err:
        raise CameraFileError(_format_validation_error(source, err)) from None
    return Camera(model, source)


def load_camera(path: str | Path) -> Camera:
    """Load and validate a CONVENTIONS camera YAML file.

    Raises :class:`CameraFileError` with a message that names the file and the offending field
    (missing key, non-orthonormal R, non-positive focal length, ...).
    """
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise CameraFileError(f"{path}: no such file") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as err:
        raise CameraFileError(f"{path}: cannot read ({err.__class__.__name__})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise CameraFileError(f"{path}: not valid YAML ({err})") from None
    return parse_camera(data, str(path))


def save_camera(camera: Camera | CameraModel, path: str | Path) -> None:
    """Write a camera file in the CONVENTIONS format."""
    model = camera.model if isinstance(camera, Camera) else camera
    d = camera_model_to_dict(model)
    lines = [
        f"name: {json.dumps(d['name'])}",
        f"image_size: [{d['image_size'][0]}, {d['image_size'][1]}]",
        f"fps: {d['fps']:g}",
        "K: [" + ", ".join("[" + ", ".join(repr(float(v)) for v in r) + "]" for r in d["K"]) + "]",
        "dist: [" + ", ".join(repr(float(v)) for v in d["dist"]) + "]",
        "R: [" + ", ".join("[" + ", ".join(repr(float(v)) for v in r) + "]" for r in d["R"]) + "]",
        "t: [" + ", ".join(repr(float(v)) for v in d["t"]) + "]",
    ]
    Path(path).write_text("\n".join(lines) + "\n")


def load_cameras(paths: Sequence[str | Path]) -> list[Camera]:
    """Load several camera files; names must be unique."""
    cams = [load_camera(p) for p in paths]
    names = [c.name for c in cams]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise CameraFileError(
            f"camera names must be unique per site; repeated: {', '.join(sorted(dup))}"
        )
    return cams


def check_image_size(camera: Camera, width: int, height: int, what: str = "the video") -> None:
    """Raise :class:`CameraFileError` if frames of ``width`` x ``height`` do not fit the file."""
    if (width, height) != (camera.width, camera.height):
        raise CameraFileError(
            f"{camera.source or camera.name}: image_size: {camera.width}x{camera.height} does not "
            f"match {what} ({width}x{height})"
        )
