"""Paired comparison of two settings on the accuracy benchmark's runs.

One run of ``bench/accuracy.py`` tracks each scene once, and a scene's error moves by tens of
millimetres with the tracker's random draws, so a change is judged on runs paired with the
same scene, seeds and filter, over several draws. Write each draw's scores with ``--json``,
once per setting, then::

    for n in 0 1 2 3; do
      python3 bench/accuracy.py --seed $n --tracker-seed $((n + 900)) --no-out --json base_$n.json
      python3 bench/accuracy.py --seed $n --tracker-seed $((n + 900)) --no-out --json new_$n.json \
          --config new.toml
    done
    python3 bench/paired.py --base base_*.json --new new_*.json

A file written with ``--draws N`` holds N draws, each run with its own seeds::

    python3 bench/accuracy.py --seed 0 --tracker-seed 900 --draws 4 --no-out --json base.json

Runs pair on (scene seed, tracker seed, recording, view, filter); a run with no partner is
left out and counted. Per filter and view, and per filter and camera count, it prints the
runs, the base's and the new setting's means, and the paired difference (new - base, mean +-
standard error over the runs) with the number of runs the new setting made better, for the
all-joint and lower-limb errors (mm) and the knee flexion RMSE (deg); ``--scores`` names
other scores of the files (a joint group's error such as ``arms_mm``, or
``leg_length_err_pct``: how far the estimate's leg length is from the truth's, in per cent).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

SCORES = (
    ("all_mm", "all joints mm"),
    ("lower_mm", "lower limbs mm"),
    ("knee_rmse_deg", "knee deg"),
)

#: Titles of the other scores ``--scores`` can name (any key of the runs works; "new better"
#: counts the runs where the score fell, so name scores where lower is better).
TITLES = {
    "head_neck_mm": "head and neck mm",
    "trunk_mm": "trunk mm",
    "arms_mm": "arms mm",
    "hips_mm": "hips mm",
    "knees_mm": "knees mm",
    "ankles_feet_mm": "ankles and feet mm",
    "hip_rmse_deg": "hip deg",
    "swap_rate": "L/R swap rate",
    "leg_length_err_pct": "leg length error % (|est/true - 1|)",
}


def _key(doc: dict, run: dict) -> tuple:
    """A run's seeds are its own (``--draws``) or, in files from before them, the file's."""
    return (
        run.get("seed", doc["seed"]),
        run.get("tracker_seed", doc["tracker_seed"]),
        run["recording"],
        run["view"],
        run["filter"],
    )


def load(paths: list[Path]) -> dict[tuple, dict]:
    """Runs of ``--json`` files keyed by (scene seed, tracker seed, recording, view, filter).

    Raises ValueError for a file that is not such a file or a run found twice.
    """
    out: dict[tuple, dict] = {}
    for p in paths:
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
            runs = doc["runs"]
            keys = [_key(doc, r) for r in runs]
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise ValueError(f"{p}: not a bench/accuracy.py --json file ({err})") from None
        for k, r in zip(keys, runs, strict=True):
            if k in out:
                raise ValueError(f"{p}: run {k} is already in another file")
            out[k] = r
    return out


def environments(paths: list[Path]) -> set[str]:
    """The ``environment`` entries of ``--json`` files (processor and library versions; files
    written before session 22 have none)."""
    out = set()
    for p in paths:
        env = json.loads(p.read_text(encoding="utf-8")).get("environment")
        if env:
            out.add(env)
    return out


def paired(base: dict[tuple, dict], new: dict[tuple, dict], score: str) -> np.ndarray:
    """(n, 2) base and new values of ``score`` over the keys both have (either value None:
    left out)."""
    rows = [
        (base[k][score], new[k][score])
        for k in sorted(base.keys() & new.keys())
        if base[k].get(score) is not None and new[k].get(score) is not None
    ]
    return np.array(rows, dtype=float).reshape(-1, 2)


def row(label: str, values: np.ndarray) -> str:
    """``label``: runs, base mean, new mean, difference +- standard error, better."""
    n = len(values)
    if n == 0:
        return f"| {label} | 0 | | | | |"
    d = values[:, 1] - values[:, 0]
    se = f"{float(np.std(d, ddof=1) / math.sqrt(n)):.1f}" if n > 1 else "n/a"
    return (
        f"| {label} | {n} | {values[:, 0].mean():.1f} | {values[:, 1].mean():.1f} | "
        f"{d.mean():+.1f} +- {se} | {int(np.sum(d < 0))} |"
    )


def tables(
    base: dict[tuple, dict], new: dict[tuple, dict], scores: tuple[tuple[str, str], ...] = SCORES
) -> list[str]:
    """The markdown tables: per score, groups by (filter, view) then (filter, cameras)."""
    both = base.keys() & new.keys()
    groups: dict[str, set[tuple]] = defaultdict(set)
    for k in both:
        r = base[k]
        groups[f"{r['filter']}, {r['view']}"].add(k)
        groups[f"{r['filter']}, {r['cameras']} camera(s), all views"].add(k)
        groups[f"{r['filter']}, all runs"].add(k)
    lines = []
    for score, title in scores:
        lines += [
            f"### {title}",
            "",
            "| runs of | n | base | new | new - base | new better |",
            "|---|---|---|---|---|---|",
        ]
        for g in sorted(groups):
            keys = groups[g]
            b = {k: base[k] for k in keys}
            lines.append(row(g, paired(b, new, score)))
        lines.append("")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", nargs="+", type=Path, required=True, help="--json files, base")
    ap.add_argument("--new", nargs="+", type=Path, required=True, help="--json files, new")
    ap.add_argument(
        "--scores",
        help="comma list of the runs' scores to compare (default: all_mm,lower_mm,knee_rmse_deg; "
        "e.g. arms_mm,leg_length_err_pct)",
    )
    args = ap.parse_args(argv)
    scores = SCORES
    if args.scores:
        names = [n.strip() for n in args.scores.split(",") if n.strip()]
        if not names:
            print("paired: --scores names no score", file=sys.stderr)
            return 2
        known = dict(SCORES) | TITLES
        scores = tuple((n, known.get(n, n)) for n in names)
    try:
        base, new = load(args.base), load(args.new)
    except ValueError as err:
        print(f"paired: {err}", file=sys.stderr)
        return 2
    both = base.keys() & new.keys()
    if not both:
        print("paired: no run of --base has a partner in --new", file=sys.stderr)
        return 2
    envs = environments(args.base) | environments(args.new)
    if len(envs) > 1:
        print(
            "warning: the files come from different processors or library versions: the "
            "tracker's numerics differ, so a run's difference is not the settings' alone:\n  "
            + "\n  ".join(sorted(envs))
            + "\n"
        )
    print(
        f"{len(both)} paired runs; unpaired: {len(base.keys() - both)} base, "
        f"{len(new.keys() - both)} new\n"
    )
    missing = [n for n, _ in scores if not any(n in r for r in (*base.values(), *new.values()))]
    if missing:
        print(f"paired: no run has the score(s) {', '.join(missing)}", file=sys.stderr)
        return 2
    print("\n".join(tables(base, new, scores)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
