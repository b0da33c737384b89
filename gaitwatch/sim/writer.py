"""Write a synthetic scene to a folder.

Layout (``N`` cameras, ``i`` = 0 .. N-1)::

    camI.mp4               the video (OpenCV mp4v), or camI/000000.png ... with video_format=png
    camI.yaml              the camera file (CONVENTIONS format)
    camI-background.png    the empty scene at frame 0's lighting (its own sensor noise)
    camI-occluder.png      the furniture's pixels (255), when furniture is in view
    camI-masks/000000.png  the person's silhouette per frame (255 = person), with masks=True
    JOINTS.csv             ground truth at the video rate (CONVENTIONS format)
    scene.json             settings, seed, source motion, resolved body, room, light per frame
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from gaitwatch import __version__
from gaitwatch.errors import InputError
from gaitwatch.sim.synth import Scene, occluder_mask, render_background, render_frames
from gaitwatch.trajectory import write_joints_csv
from tracker.camera import save_camera

log = logging.getLogger(__name__)


class OutputFolderError(InputError):
    """The output folder cannot be used (it holds another scene, or is not a folder)."""


@dataclass
class SceneFiles:
    """Paths written by :func:`write_scene`."""

    folder: Path
    videos: list[Path] = field(default_factory=list)
    cameras: list[Path] = field(default_factory=list)
    backgrounds: list[Path] = field(default_factory=list)
    #: Per camera, the occluder mask written, or None (no furniture in view).
    occluders: list[Path | None] = field(default_factory=list)
    masks: list[Path] = field(default_factory=list)
    joints: Path | None = None
    scene_json: Path | None = None


def scene_metadata(scene: Scene, files: SceneFiles | None = None) -> dict:
    """The content of ``scene.json``."""
    cfg = scene.config
    room = scene.room
    cams = []
    for i, cam in enumerate(scene.cameras):
        entry: dict = {"name": cam.name, "center_m": [round(float(v), 4) for v in cam.center]}
        if files is not None:
            entry.update(
                camera=files.cameras[i].name,
                video=files.videos[i].name,
                background=files.backgrounds[i].name,
            )
            if files.masks:
                entry["masks"] = files.masks[i].name
            if files.occluders and files.occluders[i] is not None:
                entry["occluder"] = files.occluders[i].name
        cams.append(entry)
    return {
        "generator": f"gaitwatch simulate {__version__}",
        "source_motion": scene.source,
        "seed": cfg.seed,
        "fps": cfg.fps,
        "image_size": list(cfg.image_size),
        "n_frames": scene.n_frames,
        "config": cfg.model_dump(mode="json"),
        "body": scene.body.model_dump(mode="json"),
        "synthesised_keypoints": scene.synthesised,
        "cameras": cams,
        "room": {
            "bounds_m": [room.xmin, room.xmax, room.ymin, room.ymax, 0.0, room.height],
            "floor": room.floor_kind,
            "lamp_m": [round(float(v), 4) for v in room.lights.lamp],
            "furniture": [
                {"centre_m": list(b.centre), "size_m": list(b.size), "yaw_rad": b.yaw}
                for b in room.furniture
            ],
        },
        "lighting": {
            "gain": [round(float(g), 5) for g in scene.gain],
            "lamp_on": [round(float(v), 3) for v in scene.lamp_on],
        },
        "events": scene.truth.events,
    }


def write_scene(
    scene: Scene, out_dir: str | Path, *, overwrite: bool = False, progress: bool = True
) -> SceneFiles:
    """Render every frame of ``scene`` and write the scene folder (see the module docstring).

    Raises :class:`OutputFolderError` when ``out_dir`` already holds a ``scene.json`` and
    ``overwrite`` is false, so an earlier scene is not lost.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise OutputFolderError(f"{out}: exists and is not a folder")
    if (out / "scene.json").exists() and not overwrite:
        raise OutputFolderError(
            f"{out}: already holds a scene (scene.json); use --force to replace"
        )
    out.mkdir(parents=True, exist_ok=True)
    cfg = scene.config
    w, h = cfg.image_size
    files = SceneFiles(folder=out)
    writers: list[cv2.VideoWriter | None] = []
    for i, cam in enumerate(scene.cameras):
        yaml_path = out / f"cam{i}.yaml"
        save_camera(cam, yaml_path)
        files.cameras.append(yaml_path)
        bg_path = out / f"cam{i}-background.png"
        cv2.imwrite(str(bg_path), render_background(scene, i)[..., ::-1])
        files.backgrounds.append(bg_path)
        occ = occluder_mask(scene, i)
        occ_path = out / f"cam{i}-occluder.png"
        if occ is not None:
            cv2.imwrite(str(occ_path), occ.astype(np.uint8) * 255)
            files.occluders.append(occ_path)
        else:
            occ_path.unlink(missing_ok=True)  # a replaced scene's
            files.occluders.append(None)
        if cfg.video_format == "mp4":
            vp = out / f"cam{i}.mp4"
            vw = cv2.VideoWriter(str(vp), cv2.VideoWriter_fourcc(*"mp4v"), cfg.fps, (w, h))
            if not vw.isOpened():
                raise RuntimeError(f"{vp}: OpenCV cannot open an mp4v video writer")
            writers.append(vw)
        else:
            vp = out / f"cam{i}"
            vp.mkdir(exist_ok=True)
            writers.append(None)
        files.videos.append(vp)
        if cfg.masks:
            mp = out / f"cam{i}-masks"
            mp.mkdir(exist_ok=True)
            files.masks.append(mp)
    try:
        frames = render_frames(scene)
        for k, images, masks in tqdm(
            frames, total=scene.n_frames, desc="rendering", unit="frame", disable=not progress
        ):
            for i, img in enumerate(images):
                bgr = np.ascontiguousarray(img[..., ::-1])
                if writers[i] is not None:
                    writers[i].write(bgr)
                else:
                    cv2.imwrite(str(files.videos[i] / f"{k:06d}.png"), bgr)
                if cfg.masks:
                    cv2.imwrite(
                        str(files.masks[i] / f"{k:06d}.png"), masks[i].astype(np.uint8) * 255
                    )
    finally:
        for vw in writers:
            if vw is not None:
                vw.release()
    files.joints = out / "JOINTS.csv"
    write_joints_csv(scene.truth, files.joints)
    files.scene_json = out / "scene.json"
    files.scene_json.write_text(json.dumps(scene_metadata(scene, files), indent=1))
    log.info("wrote %d frames x %d cameras to %s", scene.n_frames, len(scene.cameras), out)
    return files
