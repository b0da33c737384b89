"""MCAP pose logs: writer, reader (indexed, cut short), Foxglove channels, `gaitwatch export`."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from scipy.spatial.transform import Rotation

from gaitwatch.conventions import BONE_INDICES, KEYPOINTS
from gaitwatch.trajectory import read_joints_csv
from service import poselog
from service.cli import main
from service.poselog import PoseLogError, PoseLogWriter, read_poselog
from tracker.camera import Camera

START_NS = 1_763_700_000_123_456_789  # 2025-11-21, a capture time


def _cameras() -> list[Camera]:
    return [
        Camera.look_at(name="hall", position=[4.0, 0.5, 2.2], target=[0.0, 0.0, 1.0]),
        Camera.look_at(
            name="kitchen",
            position=[-1.0, 3.5, 2.4],
            target=[0.5, 0.0, 0.9],
            image_size=(800, 600),
            hfov_deg=75.0,
            fps=25.0,
            dist=[-0.12, 0.03, 0.001, -0.0005, 0.0],
        ),
    ]


class Recorded:
    """What a test wrote, to compare with what the reader returns."""

    def __init__(self) -> None:
        self.frames: list[int] = []
        self.times: list[float] = []
        self.joints: list[np.ndarray] = []
        self.dofs: list[np.ndarray] = []
        self.weights: list[float] = []
        self.filters: list[str] = []
        self.leg_lengths: list[float] = []
        self.no_pose: list[tuple[int, float, str]] = []
        self.order: list[str] = []  # "pose" / "none" in writing order


def _write_log(
    path: Path,
    n_frames: int = 60,
    *,
    seed: int = 0,
    flush_every: int = 20,
    close: bool = True,
) -> tuple[Recorded, PoseLogWriter]:
    """Write ``n_frames`` frames at 20 fps with gaps, frames without a pose and a NaN joint."""
    rng = np.random.default_rng(seed)
    rec = Recorded()
    w = PoseLogWriter(
        path,
        cameras=_cameras(),
        body_height_m=1.68,
        filter_name="ipf",
        settings={"M": 81, "q": 3, "dofs": ["l_hip_flexion", "r_hip_flexion"], "sigma": 0.05},
        software_version="9.9.9-test",
        start_time_ns=START_NS,
        fps=20.0,
        flush_every=flush_every,
        flush_interval_s=None,  # chunk layout by frame count only: reproducible
    )
    frame = 3
    for i in range(n_frames):
        frame += 1 if i % 11 else 3  # gaps in the frame numbers
        t = frame / 20.0
        if i % 9 == 4:
            reason = f"no silhouette in frame {frame}"
            w.write_no_pose(frame, t, reason)
            rec.no_pose.append((frame, t, reason))
            rec.order.append("none")
            continue
        joints = rng.normal([0.0, 0.0, 1.0], 0.4, size=(19, 3))
        if i == 7:
            joints[5] = np.nan  # an unknown key point
        dofs = rng.normal(0.0, 0.3, size=31)
        weight = float(rng.uniform(0.1, 0.9))
        filt = "apf" if i % 13 == 0 else None
        legs = None if i % 5 == 0 else float(rng.uniform(0.9, 1.1))  # absent: read as 1.0
        w.write_frame(frame, t, joints, dofs, weight, filter_name=filt, leg_length=legs)
        rec.leg_lengths.append(1.0 if legs is None else legs)
        rec.frames.append(frame)
        rec.times.append(t)
        rec.joints.append(joints)
        rec.dofs.append(dofs)
        rec.weights.append(weight)
        rec.filters.append(filt or "ipf")
        rec.order.append("pose")
    if close:
        w.close()
    return rec, w


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Recorded]:
    path = tmp_path_factory.mktemp("poselog") / "poses.mcap"
    rec, _ = _write_log(path, flush_every=5)
    return path, rec


def _messages(path: Path, topic: str) -> list[dict]:
    with path.open("rb") as fh:
        reader = make_reader(fh)
        return [json.loads(m.data) for _, _, m in reader.iter_messages(topics=[topic])]


# -- round trip -------------------------------------------------------------------------------
def test_round_trip_reads_back_exactly(written: tuple[Path, Recorded]) -> None:
    path, rec = written
    log = read_poselog(path)
    assert not log.truncated
    traj = log.trajectory
    np.testing.assert_array_equal(traj.frames, rec.frames)
    np.testing.assert_array_equal(traj.times, rec.times)
    np.testing.assert_array_equal(traj.positions, np.stack(rec.joints))  # NaN == NaN here
    np.testing.assert_array_equal(log.dofs, np.stack(rec.dofs))
    np.testing.assert_array_equal(log.weights, rec.weights)
    assert log.filters == rec.filters
    np.testing.assert_array_equal(log.leg_lengths, rec.leg_lengths)
    assert log.no_pose == rec.no_pose
    assert traj.fps == 20.0
    assert traj.source == str(path)
    assert len(log) == len(rec.frames)
    # frames with a pose and frames without never share a frame number
    assert not set(traj.frames.tolist()) & {f for f, _, _ in log.no_pose}


def test_unknown_joint_round_trips_as_nan(written: tuple[Path, Recorded]) -> None:
    path, rec = written
    log = read_poselog(path)
    nan_rows = [i for i, j in enumerate(rec.joints) if np.isnan(j).any()]
    assert nan_rows, "the writer test data must contain an unknown key point"
    for i in nan_rows:
        assert np.isnan(log.trajectory.positions[i, 5]).all()
        assert np.isfinite(np.delete(log.trajectory.positions[i], 5, axis=0)).all()


def test_metadata_round_trip(written: tuple[Path, Recorded]) -> None:
    path, _ = written
    log = read_poselog(path)
    cams = _cameras()
    assert [c.name for c in log.cameras] == [c.name for c in cams]
    for got, want in zip(log.cameras, cams, strict=True):
        assert got.model == want.model  # every field of the camera file, exactly
        np.testing.assert_array_equal(got.R, want.R)
        np.testing.assert_array_equal(got.dist, want.dist)
    m = log.metadata
    assert m["body_height_m"] == 1.68
    assert m["filter"] == "ipf"
    assert m["settings"] == {
        "M": 81,
        "q": 3,
        "dofs": ["l_hip_flexion", "r_hip_flexion"],
        "sigma": 0.05,
    }
    assert m["software_version"] == "9.9.9-test"
    assert m["start_time_ns"] == START_NS
    assert m["fps"] == 20.0
    assert tuple(m["keypoints"]) == KEYPOINTS
    assert m["end"]["status"] == "complete"
    assert int(m["end"]["frames_with_pose"]) == len(log.trajectory)
    assert int(m["end"]["frames_without_pose"]) == len(log.no_pose)


def test_log_time_is_start_plus_time_s(written: tuple[Path, Recorded]) -> None:
    path, rec = written
    with path.open("rb") as fh:
        reader = make_reader(fh)
        got = [
            (json.loads(m.data)["frame"], m.log_time)
            for _, _, m in reader.iter_messages(topics=[poselog.TOPIC_POSE])
        ]
    want = [(f, START_NS + round(t * 1e9)) for f, t in zip(rec.frames, rec.times, strict=True)]
    assert got == want


def test_empty_log_and_notes(tmp_path: Path) -> None:
    path = tmp_path / "empty.mcap"
    with PoseLogWriter(
        path, cameras=[], body_height_m=1.5, filter_name="condensation", settings={}
    ) as w:
        w.write_note(0, 0.0, "starting")
    log = read_poselog(path)
    assert len(log) == 0 and log.trajectory.positions.shape == (0, 19, 3)
    assert log.dofs.shape == (0, 31)
    assert log.cameras == [] and log.no_pose == []
    assert log.notes == [(0, 0.0, "starting")]
    assert not log.truncated
    assert log.metadata["fps"] is None


def test_writer_rejects_bad_frames(tmp_path: Path) -> None:
    w = PoseLogWriter(
        tmp_path / "x.mcap", cameras=[], body_height_m=1.7, filter_name="ipf", settings={}
    )
    j, d = np.zeros((19, 3)), np.zeros(31)
    w.write_frame(5, 0.25, j, d, 1.0)
    with pytest.raises(ValueError, match="not after"):
        w.write_frame(5, 0.3, j, d, 1.0)
    with pytest.raises(ValueError, match="not after"):
        w.write_no_pose(6, 0.25, "x")
    with pytest.raises(ValueError, match="shape"):
        w.write_frame(7, 0.35, np.zeros((18, 3)), d, 1.0)
    with pytest.raises(ValueError, match="shape"):
        w.write_frame(7, 0.35, j, np.zeros(30), 1.0)
    for bad in (0.0, float("nan"), 3.0):
        with pytest.raises(ValueError, match="leg_length"):
            w.write_frame(7, 0.35, j, d, 1.0, leg_length=bad)
    w.close()
    with pytest.raises(ValueError, match="closed"):
        w.write_frame(8, 0.4, j, d, 1.0)
    assert len(read_poselog(tmp_path / "x.mcap")) == 1


# -- finalised on error, readable when cut short ----------------------------------------------
def test_writer_finalised_when_with_body_raises(tmp_path: Path) -> None:
    path = tmp_path / "err.mcap"
    with (
        pytest.raises(RuntimeError, match="video decode failed"),
        PoseLogWriter(
            path, cameras=_cameras(), body_height_m=1.7, filter_name="ipf", settings={}, fps=20
        ) as w,
    ):
        for f in range(7):
            w.write_frame(f, f / 20, np.full((19, 3), f * 0.1), np.zeros(31), 0.5)
        raise RuntimeError("video decode failed")
    assert w.closed
    data = path.read_bytes()
    assert data.endswith(poselog._MAGIC)  # footer and closing magic were written
    log = read_poselog(path)
    assert not log.truncated
    np.testing.assert_array_equal(log.trajectory.frames, np.arange(7))
    np.testing.assert_array_equal(log.trajectory.positions[:, 0, 0], np.arange(7) * 0.1)
    assert log.metadata["end"]["status"] == "error"
    assert "video decode failed" in log.metadata["end"]["error"]
    with path.open("rb") as fh:  # the summary (index) is there: the mcap library finds it
        summary = make_reader(fh).get_summary()
    assert summary is not None and summary.chunk_indexes


def _check_prefix(log: poselog.PoseLog, rec: Recorded) -> int:
    """The frames read are the first frames written, with exactly the written values."""
    n = len(log.trajectory)
    np.testing.assert_array_equal(log.trajectory.frames, rec.frames[:n])
    np.testing.assert_array_equal(log.trajectory.times, rec.times[:n])
    np.testing.assert_array_equal(
        log.trajectory.positions, np.array(rec.joints[:n]).reshape(-1, 19, 3)
    )
    np.testing.assert_array_equal(log.dofs, np.array(rec.dofs[:n]).reshape(-1, 31))
    np.testing.assert_array_equal(log.weights, rec.weights[:n])
    assert log.no_pose == rec.no_pose[: len(log.no_pose)]
    return n + len(log.no_pose)


def test_truncated_file_read_up_to_last_whole_message(
    written: tuple[Path, Recorded], tmp_path: Path
) -> None:
    path, rec = written
    data = path.read_bytes()
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert len(chunks) >= 5, "flush_every=5 must give several chunks"
    cut = tmp_path / "cut.mcap"

    # Cut exactly after each whole chunk (and its message index): the frames of every chunk
    # before the cut are read, with their values; cutting one byte earlier loses that chunk.
    counts = []
    for ch in chunks:
        end = ch.chunk_start_offset + ch.chunk_length
        cut.write_bytes(data[:end])
        full = read_poselog(cut)
        assert full.truncated
        n_full = _check_prefix(full, rec)
        cut.write_bytes(data[: end - 1])
        part = read_poselog(cut)
        assert part.truncated
        n_part = _check_prefix(part, rec)
        assert n_part < n_full
        counts.append(n_full)
        assert full.cameras and full.cameras[1].model == _cameras()[1].model
    assert counts == sorted(counts) and counts[-1] == len(rec.order)

    # Arbitrary offsets: always a prefix, never fewer frames for a longer file.
    first = chunks[0].chunk_start_offset + chunks[0].chunk_length
    offsets = sorted({first, *np.linspace(first, len(data) - 1, 17).astype(int).tolist()})
    prev = 0
    for off in offsets:
        cut.write_bytes(data[:off])
        log = read_poselog(cut)
        assert log.truncated
        n = _check_prefix(log, rec)
        assert n >= prev
        prev = n
    assert prev == len(rec.order)  # cut in the summary: every frame is still there


def test_killed_writer_loses_at_most_flush_every_frames(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    rec, w = _write_log(path, n_frames=23, flush_every=5, close=False)
    # The process dies now: what is on disk is what the OS has got so far.
    snapshot = tmp_path / "snapshot.mcap"
    shutil.copyfile(path, snapshot)
    w.close()
    log = read_poselog(snapshot)
    assert log.truncated
    n_read = _check_prefix(log, rec)  # frames with and without a pose
    n_written = len(rec.order)
    assert n_written - 5 < n_read <= n_written
    assert n_read == n_written - n_written % 5
    assert log.cameras and log.metadata["body_height_m"] == 1.68


def test_cut_before_any_content(written: tuple[Path, Recorded], tmp_path: Path) -> None:
    path, _ = written
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[:40])
    with pytest.raises(PoseLogError, match="cut short"):
        read_poselog(cut)
    cut.write_bytes(path.read_bytes()[:5])
    with pytest.raises(PoseLogError, match="cut short"):
        read_poselog(cut)


def test_not_mcap_errors_name_the_file(tmp_path: Path) -> None:
    text = tmp_path / "poses.mcap"
    text.write_text("frame,time_s,joint,x,y,z\n")
    with pytest.raises(PoseLogError, match=r"poses\.mcap: not an MCAP file"):
        read_poselog(text)
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(PoseLogError, match="empty.mcap: not an MCAP file"):
        read_poselog(empty)
    with pytest.raises(PoseLogError, match="missing.mcap: no such file"):
        read_poselog(tmp_path / "missing.mcap")
    with pytest.raises(PoseLogError, match="cannot read"):
        read_poselog(tmp_path)

    other = tmp_path / "other.mcap"
    with other.open("wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("x.Point", "jsonschema", b"{}")
        ch = w.register_channel("/points", "json", sid)
        w.add_message(ch, log_time=1, publish_time=1, data=b"{}")
        w.finish()
    with pytest.raises(PoseLogError, match=r"other\.mcap: .*not a gaitwatch pose log"):
        read_poselog(other)


# -- Foxglove channels --------------------------------------------------------------------------
def test_channels_and_schemas(written: tuple[Path, Recorded]) -> None:
    path, _ = written
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    by_topic = {c.topic: c for c in summary.channels.values()}
    want = {
        poselog.TOPIC_POSE: "gaitwatch.Pose",
        poselog.TOPIC_STATUS: "gaitwatch.Status",
        "/skeleton": "foxglove.SceneUpdate",
        "/tf": "foxglove.FrameTransforms",
        "/camera/hall/calibration": "foxglove.CameraCalibration",
        "/camera/kitchen/calibration": "foxglove.CameraCalibration",
    }
    assert set(by_topic) == set(want)
    for topic, schema_name in want.items():
        ch = by_topic[topic]
        schema = summary.schemas[ch.schema_id]
        assert ch.message_encoding == "json"
        assert schema.name == schema_name
        assert schema.encoding == "jsonschema"
        assert json.loads(schema.data)["title"] == schema_name


def _null_to_zero(value: object) -> object:
    """Unknown numbers are written as null (the schemas declare them as numbers)."""
    if value is None:
        return 0.0
    if isinstance(value, list):
        return [_null_to_zero(v) for v in value]
    if isinstance(value, dict):
        return {k: _null_to_zero(v) for k, v in value.items()}
    return value


def test_messages_validate_against_their_schemas(written: tuple[Path, Recorded]) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    path, _ = written
    with path.open("rb") as fh:
        reader = make_reader(fh)
        seen = set()
        validators = {}
        n_null = 0
        for schema, channel, message in reader.iter_messages():
            assert schema is not None
            if schema.id not in validators:
                spec = json.loads(schema.data)
                validators[schema.id] = jsonschema.validators.validator_for(spec)(spec)
            msg = json.loads(message.data)
            n_null += msg != _null_to_zero(msg)
            validators[schema.id].validate(_null_to_zero(msg))
            seen.add(channel.topic)
    assert len(seen) == 6
    assert n_null == 1  # the one pose with an unknown key point


_FOXGLOVE_SCALARS = {"boolean", "string", "number", "integer"}


def _check_foxglove_parsable(schema: dict, where: str) -> int:
    """The rules of Foxglove's JSON-schema parser (foxglove/studio, packages/mcap-support,
    parseJsonSchema.ts): objects need "type": "object" and "properties"; each field is a single
    scalar type, an object, an array whose items are a scalar or an object, or a "oneOf" of
    numeric constants. Returns the number of fields checked."""
    assert schema.get("type") == "object", f"{where}: type must be 'object'"
    assert isinstance(schema.get("properties"), dict), f"{where}: object without properties"
    n = 0
    for name, field in schema["properties"].items():
        here = f"{where}.{name}"
        n += 1
        if "oneOf" in field:
            assert all(isinstance(alt.get("const"), int) for alt in field["oneOf"]), here
            continue
        kind = field.get("type")
        assert isinstance(kind, str), f"{here}: one type per field, not {kind!r}"
        if kind == "object":
            n += _check_foxglove_parsable(field, here)
        elif kind == "array":
            item_kind = field["items"].get("type")
            assert isinstance(item_kind, str), f"{here}[]: one item type, not {item_kind!r}"
            if item_kind == "object":
                n += _check_foxglove_parsable(field["items"], here + "[]")
            else:
                assert item_kind in _FOXGLOVE_SCALARS, f"{here}[]: {item_kind!r}"
        else:
            assert kind in _FOXGLOVE_SCALARS, f"{here}: {kind!r}"
    return n


def test_schemas_parse_in_foxglove(written: tuple[Path, Recorded]) -> None:
    path, _ = written
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    for schema in summary.schemas.values():
        assert _check_foxglove_parsable(json.loads(schema.data), schema.name) >= 3


def test_skeleton_scene_update(written: tuple[Path, Recorded]) -> None:
    path, rec = written
    updates = _messages(path, "/skeleton")
    assert len(updates) == len(rec.order)
    poses = iter(zip(rec.frames, rec.times, rec.joints, strict=True))
    for kind, upd in zip(rec.order, updates, strict=True):
        if kind == "none":  # frames without a pose remove the skeleton
            assert upd["entities"] == []
            assert upd["deletions"][0]["id"] == "skeleton" and upd["deletions"][0]["type"] == 0
            continue
        frame, t, joints = next(poses)
        (ent,) = upd["entities"]
        assert ent["frame_id"] == "world" and ent["id"] == "skeleton"
        stamp = START_NS + round(t * 1e9)
        assert ent["timestamp"] == {"sec": stamp // 10**9, "nsec": stamp % 10**9}
        assert ent["lifetime"] == {"sec": 0, "nsec": 0} and ent["frame_locked"] is False
        known = np.isfinite(joints).all(axis=1)
        centres = np.array([[s["pose"]["position"][k] for k in "xyz"] for s in ent["spheres"]])
        np.testing.assert_allclose(centres, joints[known], atol=6e-5)
        for s in ent["spheres"]:
            assert set(s) == {"pose", "size", "color"}
            assert set(s["pose"]["orientation"]) == {"x", "y", "z", "w"}
            assert set(s["color"]) == {"r", "g", "b", "a"}
        (line,) = ent["lines"]
        assert line["type"] == 2  # LINE_LIST
        assert {
            "pose",
            "thickness",
            "scale_invariant",
            "points",
            "color",
            "colors",
            "indices",
        } <= set(line)
        bones = [(a, b) for a, b in BONE_INDICES if known[a] and known[b]]
        pts = np.array([[p[k] for k in "xyz"] for p in line["points"]]).reshape(-1, 2, 3)
        want = np.array([[joints[a], joints[b]] for a, b in bones])
        np.testing.assert_allclose(pts, want, atol=6e-5)
        assert len(bones) == (18 if known.all() else 18 - 2)  # left elbow: 2 bones


def test_camera_transforms_are_camera_to_world(written: tuple[Path, Recorded]) -> None:
    path, rec = written
    tfs = _messages(path, "/tf")
    # at the start, then again once per second of log time (so Foxglove shows them after a seek)
    stamps = [m["transforms"][0]["timestamp"] for m in tfs]
    ns = np.array([s["sec"] * 10**9 + s["nsec"] for s in stamps])
    assert ns[0] == START_NS
    frame_dt = np.diff(sorted(rec.times + [t for _, t, _ in rec.no_pose])).max()
    assert np.all(np.diff(ns) >= 10**9) and np.all(np.diff(ns) <= 10**9 + frame_dt * 1e9 + 1)
    last_t = max(rec.times[-1], rec.no_pose[-1][1])
    assert len(tfs) >= int(last_t)
    cams = {c.name: c for c in _cameras()}
    for msg in tfs:
        assert [t["child_frame_id"] for t in msg["transforms"]] == list(cams)
        for t in msg["transforms"]:
            cam = cams[t["child_frame_id"]]
            assert t["parent_frame_id"] == "world"
            rot = Rotation.from_quat([t["rotation"][k] for k in "xyzw"])
            trans = np.array([t["translation"][k] for k in "xyz"])
            # a point in camera coordinates maps to the world as the camera file says
            p_cam = np.array([0.3, -0.2, 2.0])
            np.testing.assert_allclose(rot.apply(p_cam) + trans, cam.R.T @ (p_cam - cam.t))
            np.testing.assert_allclose(trans, cam.center)
    calib = _messages(path, "/camera/kitchen/calibration")[0]
    cam = cams["kitchen"]
    assert calib["frame_id"] == "kitchen"
    assert (calib["width"], calib["height"]) == (800, 600)
    np.testing.assert_array_equal(np.reshape(calib["K"], (3, 3)), cam.K)
    np.testing.assert_array_equal(calib["D"], cam.dist)


# -- gaitwatch export --------------------------------------------------------------------------
def test_export_writes_csv_that_reads_back(
    written: tuple[Path, Recorded], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, rec = written
    out = tmp_path / "JOINTS.csv"
    assert main(["export", str(path), "--csv", str(out)]) == 0
    line = capsys.readouterr().out.strip()
    assert "\n" not in line and f"exported {len(rec.frames)} frames" in line
    assert f"{len(rec.no_pose)} without a pose" in line and "cut short" not in line
    traj = read_joints_csv(out)
    np.testing.assert_array_equal(traj.frames, rec.frames)
    np.testing.assert_allclose(traj.times, rec.times, atol=1e-6)
    np.testing.assert_allclose(traj.positions, np.stack(rec.joints), atol=1e-6)  # NaN in place
    assert traj.fps == pytest.approx(20.0)


def test_export_truncated_and_bad_input(
    written: tuple[Path, Recorded], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, rec = written
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    out = tmp_path / "JOINTS.csv"
    assert main(["export", str(cut), "--csv", str(out)]) == 0
    line = capsys.readouterr().out
    assert "cut short" in line
    n = len(read_joints_csv(out))
    assert 0 < n < len(rec.frames)

    out.write_text("keep me\n")
    bad = tmp_path / "bad.mcap"
    bad.write_text("not a pose log")
    assert main(["export", str(bad), "--csv", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("gaitwatch: error: ") and "bad.mcap" in err[0]
    assert out.read_text() == "keep me\n"  # nothing already stored is lost

    assert main(["export", str(path), "--csv", str(path)]) == 2  # would destroy the log
    assert path.read_bytes() == data

    empty = tmp_path / "nobody.mcap"
    with PoseLogWriter(empty, cameras=[], body_height_m=1.7, filter_name="ipf", settings={}) as w:
        w.write_no_pose(0, 0.0, "nobody in view")
    assert main(["export", str(empty), "--csv", str(out)]) == 2
    assert "no frame with a pose" in capsys.readouterr().err
    assert out.read_text() == "keep me\n"
