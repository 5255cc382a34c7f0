"""The two plots of docs/performance.md, drawn from a results dictionary (PNG, no display)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt

__all__ = ["plot_cell", "plot_wire"]


def plot_wire(wire: dict[str, Any], path: Path) -> None:
    """Item 3: measured time against the wire-time floor, per transfer."""
    cases = wire["cases"]
    names = list(cases)
    floors = [cases[n]["floor"] for n in names]
    measured = [cases[n]["seconds"] for n in names]
    fig, ax = plt.subplots(figsize=(7, 1.0 + 0.7 * len(names)), layout="constrained")
    y = range(len(names))
    ax.barh([i + 0.2 for i in y], floors, height=0.4, label="wire-time floor", color="#9aa7b8")
    ax.barh([i - 0.2 for i in y], measured, height=0.4, label="measured", color="#2c6fbb")
    raw = wire.get("raw_host")
    if raw:
        ax.scatter(
            [raw[n]["seconds"] for n in names],
            [i - 0.2 for i in y],
            marker="x",
            s=60,
            color="black",
            label="raw host, same simulator and line",
            zorder=3,
        )
    for i, n in enumerate(names):
        ax.annotate(
            f"+{cases[n]['over']:.0%}",
            (measured[i], i - 0.2),
            xytext=(4, 0),
            textcoords="offset points",
            va="center",
            fontsize=8,
        )
    sizes = {
        "FB upload": f"{wire['lines']} lines",
        "FA download": f"{wire['lines']} lines",
        "AA polls": f"× {wire['polls']}",
        "250-byte packets": f"KE × {wire.get('packets', '?')}",
    }
    labels = {}
    for n in names:
        transfer, _, line = n.partition(", ")
        labels[n] = f"{transfer}, {line or 'tcp'}\n{sizes.get(transfer, '')}"
    ax.set_yticks(list(y), [labels.get(n, n) for n in names])
    ax.invert_yaxis()
    ax.set_xlabel(f"seconds at {wire['baud']} baud (simulator pacing its line)")
    ax.set_title("Close to the wire: time against the wire-time floor")
    ax.legend(loc="lower right", fontsize=7)
    ax.grid(axis="x", alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_cell(cell: dict[str, Any], path: Path) -> None:
    """Item 5: achieved poll rate and latency p99 against the number of controllers."""
    by_n = cell["by_n"]
    ns = [e["controllers"] for e in by_n]
    fig, (rate_ax, lat_ax) = plt.subplots(1, 2, figsize=(9, 3.8), layout="constrained")
    rate_ax.plot(ns, [e["asked_polls_per_s"] for e in by_n], "--", color="#9aa7b8", label="asked")
    rate_ax.plot(ns, [e["polls_per_s"] for e in by_n], "o-", color="#2c6fbb", label="achieved")
    for e in by_n:
        rate_ax.annotate(
            f"{e['achieved']:.1%}",
            (e["controllers"], e["polls_per_s"]),
            xytext=(6, -12),
            textcoords="offset points",
            ha="left",
            fontsize=8,
        )
    rate_ax.set_xscale("log", base=2)
    rate_ax.set_yscale("log")
    rate_ax.set_xticks(ns, [str(n) for n in ns])
    rate_ax.set_xlabel("controllers (N)")
    rate_ax.set_ylabel(f"polls/s (AA + AC each, {cell['rate_hz']:g} Hz per controller)")
    rate_ax.set_title("Achieved rate")
    rate_ax.legend(fontsize=8)
    rate_ax.grid(alpha=0.3)
    lat_ax.plot(ns, [e["latency_p99_ms"] for e in by_n], "o-", color="#d9480f", label="p99")
    lat_ax.plot(ns, [e["latency_p50_ms"] for e in by_n], "o-", color="#2c6fbb", label="median")
    lat_ax.set_xscale("log", base=2)
    lat_ax.set_yscale("log")
    lat_ax.set_xticks(ns, [str(n) for n in ns])
    lat_ax.set_xlabel("controllers (N)")
    lat_ax.set_ylabel("ms from tick to second answer")
    lat_ax.set_title("Poll latency")
    lat_ax.legend(fontsize=8)
    lat_ax.grid(alpha=0.3)
    fig.suptitle("A whole cell from one asyncio process")
    fig.savefig(path, dpi=110)
    plt.close(fig)
