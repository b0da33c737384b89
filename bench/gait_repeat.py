"""How steady the gait parameters' errors from video are: the same walks tracked again.

A trend compares a resident with their own baseline, so an error that stays the same for one
person cancels, and only its spread from one recording to the next blurs the trend. This reads
the folders that ``bench/gait_video.py --keep DIR`` writes (one per seed: the same recordings,
people's shapes and cameras; other clothes' colours and patterns, room texture, sensor noise and
tracker draws), compares each run's video with its truth as ``gait_video.compare`` does, and
prints per gait, camera set and parameter:

- runs: runs with strides matched to the truth's;
- bias: mean error (video - truth) over those runs;
- sd within: the spread of one footage's error between its runs (pooled standard deviation
  over the footage seen in at least two runs);
- sd between: the spread of the footage's mean errors (footage seen in at least two runs).

A "sd within" as large as the "sd between" means one recording's error is not a property of
the person: single recordings are noisy, and only the medians of many recordings make a trend.

Run::

    for s in 0 1 2; do python3 bench/gait_video.py --seed $s --keep /tmp/gv$s --no-out; done
    python3 bench/gait_repeat.py /tmp/gv0 /tmp/gv1 /tmp/gv2
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gait_video as G  # noqa: E402

from gait.analysis import GaitConfig  # noqa: E402
from gaitwatch.trajectory import read_joints_csv  # noqa: E402

#: (kind, label, unit): ``SceneResult.pct`` or ``.diff`` entries, as gait_video prints them.
PARAMETERS = (
    ("pct", "speed", "%"),
    ("pct", "cadence", "%"),
    ("pct", "stride length", "%"),
    ("diff", "stance", "pp"),
    ("diff", "double support", "pp"),
    ("diff", "step width", "mm"),
    ("diff", "knee ROM", "deg"),
    ("diff", "knee peak swing", "deg"),
)


@dataclass(frozen=True)
class Spread:
    """One parameter's errors over several footage, each run more than once."""

    runs: int
    bias: float
    sd_within: float
    sd_between: float
    footage: int


def spread(errors: dict[str, list[float]]) -> Spread:
    """Bias and spreads of the errors per footage (NaN entries are runs without a value).

    ``sd_within`` pools the footage's sample variances (weighted by their degrees of freedom);
    ``sd_between`` is the sample standard deviation of their means. Both use only footage with
    at least two values; NaN when fewer than two such footage (``sd_between``) or none
    (``sd_within``).
    """
    values = {k: [v for v in vs if math.isfinite(v)] for k, vs in errors.items()}
    every = [v for vs in values.values() for v in vs]
    repeated = [np.asarray(vs) for vs in values.values() if len(vs) >= 2]
    dof = sum(len(v) - 1 for v in repeated)
    within = (
        math.sqrt(sum(float(np.sum((v - v.mean()) ** 2)) for v in repeated) / dof)
        if dof
        else math.nan
    )
    means = [float(v.mean()) for v in repeated]
    between = float(np.std(means, ddof=1)) if len(means) >= 2 else math.nan
    return Spread(
        runs=len(every),
        bias=float(np.mean(every)) if every else math.nan,
        sd_within=within,
        sd_between=between,
        footage=len(repeated),
    )


def load(folders: list[Path], config: GaitConfig) -> dict[str, list[G.SceneResult]]:
    """Each footage's comparisons, one per folder that has it (keyed by the file stem)."""
    out: dict[str, list[G.SceneResult]] = {}
    for folder in folders:
        for truth_file in sorted(folder.glob("*_truth.csv")):
            stem = truth_file.name[: -len("_truth.csv")]
            video_file = folder / f"{stem}_video.csv"
            if not video_file.is_file():
                continue
            res = G.compare(read_joints_csv(truth_file), read_joints_csv(video_file), config)
            res.recording = next(
                (r for r in G.DEFAULT_RECORDINGS if stem.startswith(f"{r}_")), stem.split("_")[0]
            )
            res.view = stem[len(res.recording) + 1 :]
            res.ncams = 2 if "-" in res.view.split("_")[0] else 1
            out.setdefault(stem, []).append(res)
    return out


def table(results: dict[str, list[G.SceneResult]]) -> list[str]:
    """Markdown rows: per gait, camera set and parameter, the :class:`Spread`."""
    lines = [
        "| gait | cameras | parameter | runs | footage | bias | sd within | sd between |",
        "|---|---|---|---|---|---|---|---|",
    ]
    groups = sorted({(r.gait, r.ncams) for rs in results.values() for r in rs})
    for gait, ncams in groups:
        for kind, label, unit in PARAMETERS:
            errors = {
                stem: [
                    getattr(r, kind).get(label, math.nan)
                    if not r.error and r.matched > 0
                    else math.nan
                    for r in rs
                ]
                for stem, rs in results.items()
                if rs[0].gait == gait and rs[0].ncams == ncams
            }
            s = spread(errors)
            if s.runs == 0:
                continue
            lines.append(
                f"| {gait} | {ncams} | {label} ({unit}) | {s.runs} | {s.footage} | "
                f"{s.bias:+.1f} | {s.sd_within:.1f} | {s.sd_between:.1f} |"
            )
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="+", type=Path, help="folders of gait_video.py --keep")
    args = ap.parse_args(argv)
    missing = [str(f) for f in args.folders if not f.is_dir()]
    if missing:
        print(f"gait_repeat: not a folder: {', '.join(missing)}", file=sys.stderr)
        return 2
    results = load(args.folders, GaitConfig())
    if not results:
        print("gait_repeat: no REC_VIEW_truth.csv / _video.csv pairs found", file=sys.stderr)
        return 2
    print("\n".join(table(results)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
