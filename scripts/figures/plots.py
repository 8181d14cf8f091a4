#!/usr/bin/python3
"""Plots of the benchmark tables in docs/benchmarks.md, for scripts/render-figures.

    scripts/figures/plots.py [--benchmarks docs/benchmarks.md] [--out docs/images]

- plot-error-vs-faces.png: Hausdorff distance against output faces, gaussmesh against
  meshopt_simplify and meshopt_simplifySloppy, from "Face targets against meshoptimizer";
- plot-size.png: seconds and peak RSS against input triangles under --memory 64M, from
  "Out-of-core simplify by input size".

The tables are the source: the plots change when a benchmark's table does. Debian's
python3-matplotlib, software rendering.
"""

import argparse
import os
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def table(markdown, heading):
    """The first table under `## heading`: a list of dicts by column name."""
    lines = markdown.split("\n")
    start = lines.index("## " + heading)
    rows, header = [], None
    for line in lines[start + 1:]:
        if line.startswith("## "):
            break
        if not line.startswith("|"):
            if header:
                break
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if header is None:
            header = cells
        elif not all(re.fullmatch(r"-+:?|:?-+", c) for c in cells):
            rows.append(dict(zip(header, cells)))
    return rows


def number(text):
    """The first number of a cell ("17.78–20.08 (22 runs)" -> 17.78, "980,876" -> 980876)."""
    match = re.search(r"[0-9][0-9,]*\.?[0-9]*", text or "")
    return float(match.group(0).replace(",", "")) if match else None


def span(text):
    """A cell's range "a–b" as (low, high), or (a, a)."""
    values = [float(v.replace(",", "")) for v in re.findall(r"[0-9][0-9,]*\.?[0-9]*", (text or "").split("(")[0])]
    return (min(values), max(values)) if values else None


TOOLS = [("gaussmesh", "tab:blue", "o"), ("meshopt_simplify", "tab:orange", "s"),
         ("meshopt_simplifySloppy", "tab:gray", "^")]


def error_vs_faces(rows, path):
    inputs = ["cow.off", "fandisk.off", "homer.off", "generated cow 1M"]
    fig, axes = plt.subplots(1, len(inputs), figsize=(13, 3.4))
    for ax, name in zip(axes, inputs):
        for tool, colour, marker in TOOLS:
            points = sorted((number(r["output faces"]), number(r["Hausdorff %"])) for r in rows
                            if r["input"] == name and r["tool"] == tool and number(r["Hausdorff %"]) is not None
                            and number(r["output faces"]))
            if points:
                ax.plot(*zip(*points), marker=marker, color=colour, label=tool, linewidth=1.2, markersize=4)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("output faces")
        ax.grid(True, which="both", linewidth=0.3)
    axes[0].set_ylabel("Hausdorff, % of diagonal")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def size_plot(rows, path):
    points = []
    for r in rows:
        first = r["input triangles"]
        if not re.fullmatch(r"[0-9,]+", first) or r["`--memory`"] != "64M":
            continue
        seconds = span(r["plain Release, s"]) or span(r["profile-guided, s"])
        if seconds is None or seconds == (None, None):
            seconds = span(r["profile-guided, s"])
        points.append((number(first), seconds, span(r["peak RSS MiB"])))
    points.sort()
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.4))
    n = [p[0] for p in points]
    for ax, index, label in ((left, 1, "seconds"), (right, 2, "peak RSS, MiB")):
        low = [p[index][0] for p in points]
        high = [p[index][1] for p in points]
        ax.fill_between(n, low, high, alpha=0.3, color="tab:blue")
        ax.plot(n, low, marker="o", color="tab:blue", label="gaussmesh, --memory 64M")
        ax.set_xscale("log")
        ax.set_xlabel("input triangles (refined cow)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", linewidth=0.3)
    left.set_yscale("log")
    right.axhline(64, color="tab:red", linewidth=1, linestyle="--", label="the budget")
    right.set_ylim(0, 80)
    right.legend(fontsize=8, loc="lower right")
    left.set_title("time, 2 cores", fontsize=10)
    right.set_title("peak resident memory", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--benchmarks", default=os.path.join(ROOT, "docs", "benchmarks.md"))
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "images"))
    args = parser.parse_args()
    with open(args.benchmarks) as f:
        markdown = f.read()
    error_vs_faces(table(markdown, "Face targets against meshoptimizer"), os.path.join(args.out, "plot-error-vs-faces.png"))
    size_plot(table(markdown, "Out-of-core simplify by input size"), os.path.join(args.out, "plot-size.png"))
    for name in ("plot-error-vs-faces.png", "plot-size.png"):
        print(os.path.join(args.out, name))


if __name__ == "__main__":
    main()
