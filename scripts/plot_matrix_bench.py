#!/usr/bin/python3
"""Plots the matrix radiosity solver rates against N from radiosity_bench's JSON report (the
shape of Carr, Hall, Hart 2003, Fig. 4 on this machine).

Usage: scripts/plot_matrix_bench.py bench-out/radiosity_bench.json docs/images/matrix_fig4.png
Needs Debian's python3-matplotlib (scripts/install-deps.sh installs it).
"""
import json
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def medians(report):
    out = {}
    for b in report["benchmarks"]:
        if b.get("run_type") == "aggregate" and b.get("aggregate_name") != "median":
            continue
        if b.get("run_type") == "iteration" and b.get("repetitions", 1) > 1:
            continue
        name = b.get("run_name", b["name"])
        if "items_per_second" in b:
            out[name] = b["items_per_second"]
    return out


def series(rates, pattern):
    points = []
    for name, value in rates.items():
        m = re.fullmatch(pattern, name)
        if m:
            points.append((int(m.group(1)), value))
    return sorted(points)


def main():
    report = json.load(open(sys.argv[1]))
    rates = medians(report)
    jacobi = series(rates, r"jacobi/n:(\d+)/fp16:0(?:/repeats:\d+)?/real_time")
    jacobi16 = series(rates, r"jacobi/n:(\d+)/fp16:1(?:/repeats:\d+)?/real_time")
    gs = series(rates, r"gaussSeidel/n:(\d+)(?:/repeats:\d+)?/real_time")
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=120)
    for pts, label, style in ((jacobi, "Jacobi, fp32, 2 threads", "o-"),
                              (jacobi16, "Jacobi, fp16, 2 threads", "s--"),
                              (gs, "Gauss-Seidel, fp32, 1 thread", "^-")):
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], style, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("elements N")
    ax.set_ylabel("iterations per second")
    ax.set_title("Matrix radiosity on the CPU (cf. Carr et al. 2003, Fig. 4)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
