"""Log-log plot of run time against error for benches/ssmulti.rs.

Usage: plot_ssmulti.py RESULTS.csv OUT.png
CSV columns: points,neighbours,method,tolerance,seconds,error (error: RMS
relative difference from the exact method; the exact method's rows carry
its f32 floor, 1e-7, and are drawn as stars).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    fig, ax = plt.subplots(figsize=(8, 6), dpi=110)
    series = {}
    for r in rows:
        key = (int(r["points"]), int(r["neighbours"]))
        series.setdefault(key, []).append(r)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (key, rs) in enumerate(sorted(series.items())):
        col = colours[k % len(colours)]
        label = f"{key[0] // 1000}k points, {key[1]} neighbours"
        approx = sorted((r for r in rs if r["method"] == "approx"), key=lambda r: float(r["tolerance"]))
        exact = [r for r in rs if r["method"] == "exact"]
        if approx:
            ax.plot([float(r["seconds"]) for r in approx], [max(float(r["error"]), 1e-7) for r in approx],
                    "o-", color=col, label=label)
            for r in approx:
                ax.annotate(r["tolerance"], (float(r["seconds"]), max(float(r["error"]), 1e-7)),
                            fontsize=7, color=col, textcoords="offset points", xytext=(3, 3))
        for r in exact:
            ax.plot([float(r["seconds"])], [1e-7], "*", color=col, markersize=12)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("ssmulti time, seconds (2 threads)")
    ax.set_ylabel("RMS relative error against the exact method")
    ax.set_title("pcsss ssmulti: time against error (stars: exact, drawn at 1e-7)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
