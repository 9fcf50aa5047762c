"""Log-log plot of image error against run time, the bake beside Mitsuba 3,
from the rows benches/py/mitsuba_sphere.py and mitsuba_bunny.py keep.

Usage: plot_error_time.py OUT.png RESULTS.json [RESULTS.json ...]
Each file: {"reference_spp": N, "rows": [{"tool": "bake" | "bake, indirect" | "Mitsuba",
"setting": points or samples a pixel, "seconds", "rms", ...}]}; its name
(mitsuba_NAME.json) labels its curves.
"""
import json
import os
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    out, files = sys.argv[1], sys.argv[2:]
    fig, ax = plt.subplots(figsize=(8, 6), dpi=110)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, f in enumerate(files):
        data = json.loads(pathlib.Path(f).read_text())
        scene = pathlib.Path(f).stem.removeprefix("mitsuba_")
        for j, (tool, marker, style) in enumerate([("bake", "o", "-"), ("Mitsuba", "s", "--"),
                                                   ("bake, indirect", "^", "-.")]):
            rows = sorted((r for r in data["rows"] if r["tool"] == tool), key=lambda r: r["seconds"])
            if not rows:
                continue
            col = colours[(3 * k + j) % len(colours)]
            ax.plot([r["seconds"] for r in rows], [r["rms"] for r in rows], marker + style, color=col,
                    label=f"{scene}: {tool}")
            baked = tool.startswith("bake")
            unit = "k" if baked else " spp"
            for r in rows:
                s = r["setting"] // 1000 if baked else r["setting"]
                extra = "".join(" " + e.split("=")[-1] if e.startswith("WALKS") else "" for e in r.get("extra", []))
                label = f"{s}{unit}" + (f", {extra.strip()} walks" if extra else "")
                ax.annotate(label, (r["seconds"], r["rms"]), fontsize=7, color=col,
                            textcoords="offset points", xytext=(3, 3))
    ax.axhline(0.02, color="grey", lw=0.8, ls=":")
    ax.axhline(0.05, color="grey", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(os.environ.get("XLABEL", "wall time, seconds (2 cores; the bake: scatter to render)"))
    ax.set_ylabel("RMS relative error of the picture against Mitsuba's converged one")
    ax.set_title("Error against time: the physical bake and Mitsuba 3 (volpath)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main()
