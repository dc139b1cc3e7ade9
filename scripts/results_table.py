#!/usr/bin/python3
"""Writes docs/results.md and the README's results table from docs/results/rows.tsv.

rows.tsv is written by bench/results.sh, one row per measured run (date, dataset, frames, mode,
mask, ate_cm, psnr_db (keyframes), view_psnr_db and coverage_pct (every 10th frame), ms_per_frame,
posed, machine, commit, command). Nothing here is typed by
hand: edit the runs, not the tables. The page's last section, each part of tracking on and off,
comes from docs/results/ablation.tsv, which bench/precision_ablation.sh writes (OUT/ablation.tsv:
one row per run).

Usage: scripts/results_table.py [--check]
  --check  exit 1 (and say which) when docs/results.md or the README's table differ from what
           rows.tsv gives; writes nothing. CI runs this.
"""
import collections
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROWS = os.path.join(ROOT, "docs", "results", "rows.tsv")
ABLATION = os.path.join(ROOT, "docs", "results", "ablation.tsv")
RESULTS_MD = os.path.join(ROOT, "docs", "results.md")
README = os.path.join(ROOT, "README.md")
BEGIN, END = "<!-- results:begin -->", "<!-- results:end -->"
MODES = ["offline", "runner 1x", "graph 1x"]
MODE_TEXT = {
    "offline": "offline: every frame, as fast as it goes (`dypho_run_dataset`)",
    "runner 1x": "live at 1x in one process (`dypho_run_dataset --realtime`): frames at their stamps, late ones dropped",
    "graph 1x": "live at 1x through the ROS graph (`tum_bag.launch`, `rosbag play` at rate 1.0)",
}


def read_rows(path):
    with open(path) as f:
        lines = [l.rstrip("\n") for l in f if l.strip()]
    header = lines[0].split("\t")
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        cells = line.split("\t")
        if len(cells) != len(header):
            sys.exit(f"results_table: {path}:{number}: {len(cells)} cells, the header has {len(header)}")
        rows.append(dict(zip(header, cells)))
    return rows


def num(text, digits=2):
    """A measured number as the tables show it (2 decimals), or the text as it is ('-')."""
    try:
        return f"{float(text):.{digits}f}"
    except ValueError:
        return text


def ate(row):
    """ATE as the tables show it: the median and, over several runs, the range."""
    if row.get("runs", "1") not in ("", "1") and row.get("ate_range_cm", "-") != "-":
        return f"{num(row['ate_cm'])} ({row['ate_range_cm']}, {row['runs']} runs)"
    return num(row["ate_cm"])


def fps(ms):
    try:
        return f"{1000.0 / float(ms):.1f}"
    except (ValueError, ZeroDivisionError):
        return "-"


def sort_key(row):
    mode = MODES.index(row["mode"]) if row["mode"] in MODES else len(MODES)
    return (mode, row["mask"], row["machine"])


SEQUENCE_TEXT = collections.OrderedDict([
    ("fr1_flow", "fr1/rpy 150, flow"),
    ("fr1_none", "fr1/rpy 150, no mask"),
    ("bonn_flow", "Bonn 200, flow"),
    ("bonn_detector", "Bonn 200, YOLOX-nano"),
    ("synth_hard", "generator kinect-fast 300"),
    ("synth_long", "generator kinect-fast 900"),
])
DROPS = ["whole", "every15", "random10"]


def ablation_md(rows):
    """Each configuration of bench/precision_ablation.sh against every sequence it ran on."""
    configs = collections.OrderedDict()
    for row in rows:
        configs.setdefault(row["config"], {})[(row["sequence"], row["drop"])] = row
    sequences = [s for s in SEQUENCE_TEXT if any(r["sequence"] == s for r in rows)]
    sequences += sorted({r["sequence"] for r in rows} - set(sequences))
    out = [
        "", "## Tracking: each part on and off", "",
        "`bench/precision_ablation.sh` (offline runner, `--no-map`, deterministic; mask flow unless the",
        "column says otherwise). Each configuration changes the defaults by the options shown. A cell is",
        "the ATE (cm) of the whole sequence / every 15th frame removed / 10 % removed at random (seed 7).",
        "Generator: `dypho_synth --hard-case kinect-fast --people 2` (fast hand-held turns, 15 ms blur,",
        "30 ms rolling shutter, Kinect depth noise), 300 frames seed 1 and 900 frames seed 4.",
        "ms/frame: the median tracking time per frame on the whole fr1 / Bonn window (flow).",
        "A row changes the defaults of the commit it was measured at (its commit column), which may be",
        "older than the `features` row's.",
        "Reproduce a row: `DYPHO_ABLATION_CONFIGS=NAME DYPHO_ABLATION_SEQUENCES=\"" +
        " ".join(sequences) + "\" bench/precision_ablation.sh build OUT`.",
        "",
        "| configuration | options | " + " | ".join(SEQUENCE_TEXT.get(s, s) for s in sequences) +
        " | ms/frame | machine | commit | date |",
        "|---|---|" + "---|" * len(sequences) + "---|---|---|---|",
    ]
    for name, runs in configs.items():
        cells = []
        for seq in sequences:
            values = [num(runs[(seq, d)]["ate_cm"]) if (seq, d) in runs else "-" for d in DROPS]
            cells.append(" / ".join(values))
        ms = " / ".join(num(runs[(seq, "whole")]["track_ms"], 1) if (seq, "whole") in runs else "-"
                        for seq in ("fr1_flow", "bonn_flow"))
        first = next(iter(runs.values()))
        machines = sorted({r["machine"] for r in runs.values()})
        commits = sorted({r["commit"] for r in runs.values()})
        dates = sorted({r["date"] for r in runs.values()})
        out.append(f"| {name} | `{first['options']}` | " + " | ".join(cells) +
                   f" | {ms} | {', '.join(machines)} | {', '.join(commits)} | {', '.join(dates)} |")
    return out


def results_md(rows, ablation_rows=None):
    by_dataset = collections.OrderedDict()
    for row in rows:
        by_dataset.setdefault(row["dataset"], []).append(row)
    out = [
        "# Results",
        "",
        "Every number here comes from `bench/results.sh` (the last section: `bench/precision_ablation.sh`)",
        "on the machine named in its row and is rendered by `scripts/results_table.py` from",
        "[results/rows.tsv](results/rows.tsv) and [results/ablation.tsv](results/ablation.tsv); CI checks",
        "that this page matches those files. The history of how the numbers got here is in the",
        "[journal](journal/benchmarks-2026.md).",
        "",
        "Modes:",
    ]
    out += [f"- **{m}**: {MODE_TEXT[m]}." for m in MODES]
    out += [
        "",
        "Metrics: ATE is the RMSE of the final trajectory after a rigid alignment to the ground truth",
        "(Bonn: with the dataset's marker-to-camera correction). The live modes are not repeatable:",
        "their rows are the median of several runs, with the ATE's range. Map PSNR and coverage: the",
        "saved map rendered at the final pose of every 10th frame and scored on that frame's static",
        "pixels (the system's mask, dilated 5 px; for the graph, the offline mask of the same frames);",
        "coverage is the share of those pixels where the map's opacity is >= 0.5, so holes count",
        "(`dypho_run_dataset --eval-every`, `dypho_evaluate_map`). Keyframe PSNR: the older figure, at",
        "the keyframes the map was trained on, at training resolution. ms/frame is the median work per frame",
        "(mask + tracking + mapping; at 1x it includes waiting for a core); frames/s offline is the",
        "inverse. Posed: frames that got a pose (the graph: a tracking status).",
        "`+changes` after a commit: the run had uncommitted changes to code, parameters or scripts.",
        "",
        "Reproduce a row: `bash scripts/build.sh && bench/results.sh --only NAME` (names:",
        "`bench/results.sh --list`).",
    ]
    for dataset, drows in by_dataset.items():
        drows = sorted(drows, key=sort_key)
        frames = drows[0]["frames"]
        out += ["", f"## {dataset}", "", f"{frames} frames.", ""]
        out += ["### Trajectory", "", "| mode | mask | ATE (cm) | posed | machine | commit | date | command |",
                "|---|---|---|---|---|---|---|---|"]
        out += [f"| {r['mode']} | {r['mask']} | {ate(r)} | {r['posed']} | {r['machine']} | {r['commit']} | "
                f"{r['date']} | `{command(r)}` |" for r in drows]
        out += ["", "### Map and speed", "",
                "| mode | mask | map PSNR (dB) | coverage (%) | keyframe PSNR (dB) | ms/frame | frames/s offline | "
                "machine | commit | command |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        out += [f"| {r['mode']} | {r['mask']} | {num(r['view_psnr_db'])} | {num(r['coverage_pct'], 1)} | "
                f"{num(r['psnr_db'])} | {num(r['ms_per_frame'], 1)} | "
                f"{fps(r['ms_per_frame']) if r['mode'] == 'offline' else '-'} | {r['machine']} | "
                f"{r['commit']} | `{command(r)}` |" for r in drows]
    if ablation_rows:
        out += ablation_md(ablation_rows)
    return "\n".join(out) + "\n"


def command(row):
    return " ".join(row["command"].split())


def readme_table(rows):
    """One line per dataset: the default mask (flow) offline, at 1x in the runner and the graph."""
    by_dataset = collections.OrderedDict()
    for row in rows:
        by_dataset.setdefault(row["dataset"], {})[(row["mode"], row["mask"])] = row
    out = ["| dataset | ATE offline / live 1x (cm) | map PSNR / coverage offline | frames/s offline | posed live 1x "
           "| machine |",
           "|---|---|---|---|---|---|"]
    for dataset, runs in by_dataset.items():
        off = runs.get(("offline", "flow"))
        live = runs.get(("graph 1x", "flow")) or runs.get(("runner 1x", "flow"))
        if not off:
            continue
        live_ate = "-"
        if live:
            live_ate = num(live["ate_cm"]) + (f" (median of {live['runs']})" if live.get("runs", "1") != "1" else "")
        posed = f"{live['posed']} ({'graph' if live['mode'] == 'graph 1x' else 'runner'})" if live else "-"
        view = f"{num(off['view_psnr_db'])} dB / {num(off['coverage_pct'], 1)} %" if off["view_psnr_db"] != "-" else "-"
        out.append(f"| {dataset} | {num(off['ate_cm'])} / {live_ate} | {view} | {fps(off['ms_per_frame'])} | "
                   f"{posed} | {off['machine']} |")
    return "\n".join(out) + "\n"


def with_readme_table(text, table):
    if BEGIN not in text or END not in text:
        sys.exit(f"results_table: README.md has no {BEGIN} ... {END} block")
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return head + BEGIN + "\n" + table + END + tail


def main():
    check = "--check" in sys.argv[1:]
    if any(a in ("-h", "--help") for a in sys.argv[1:]):
        print(__doc__.strip())
        return 0
    rows = read_rows(ROWS)
    ablation_rows = read_rows(ABLATION) if os.path.exists(ABLATION) else None
    wanted = {RESULTS_MD: results_md(rows, ablation_rows)}
    with open(README) as f:
        wanted[README] = with_readme_table(f.read(), readme_table(rows))
    stale = []
    for path, text in wanted.items():
        current = open(path).read() if os.path.exists(path) else None
        if current == text:
            continue
        if check:
            stale.append(os.path.relpath(path, ROOT))
        else:
            tmp = path + ".tmp"
            with open(tmp, "w") as f:
                f.write(text)
            os.replace(tmp, path)
            print(f"results_table: wrote {os.path.relpath(path, ROOT)}")
    if stale:
        print("results_table: out of date with docs/results/rows.tsv: " + ", ".join(stale) +
              " (run scripts/results_table.py)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
