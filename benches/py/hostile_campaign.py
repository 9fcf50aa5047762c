"""A hostile campaign over every reader and writer: inputs an attacker or a
careless pipeline would give, run through the binaries that read them, each
under a 2 GiB address-space limit and a time limit.

Readers and the binaries that read them:
- a cloud or mesh (PLY, OBJ, OpenEXR, USD text, crate and package): pcinfo,
  pcconvert, measure;
- a lights file (and the dome map it names): illum;
- a camera file: render;
- a material file: ssmulti --material;
- a texture image (PNG, OpenEXR): texture;
- a tile manifest: pctile merge.

Inputs: mutations of the project's fixtures (bytes flipped, runs of bytes
set to large values, truncated at every tenth of the file, a block
repeated), a fixed number a seed file from a fixed random seed, and special
files (empty, /dev/zero, /dev/null, a directory, a link loop). Writers:
outputs that are inputs (by name, through a link, as stdout), links into
/dev, unknown extensions, closed and /dev/null standard output.

Each run is classified:
- handled: exit 0, or exit 1 or 2 with exactly one line on stderr; and no
  input changed;
- misbehaved: anything else: a signal (abort, stack overflow), exit 101
  (a panic), a timeout, an error of more than one line or none, "panicked"
  on stderr, an input file changed.

Usage: python3 benches/py/hostile_campaign.py [--bin target/release]
  [--per-seed 40] [--out benches/results/hostile_campaign.json]
Prints a table by reader and writes the counts and every misbehaving case.
"""

import argparse
import hashlib
import json
import os
import random
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LIMIT_AS = 2 << 30
TIMEOUT = 60


def limit():
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT_AS, LIMIT_AS))


def digest(paths):
    out = {}
    for p in paths:
        p = Path(p)
        if p.is_file() and not p.is_symlink():
            out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def run(argv, cwd, watch=(), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL):
    """Runs argv; returns (verdict, detail)."""
    before = digest(watch)
    try:
        p = subprocess.run(
            argv,
            cwd=cwd,
            stdin=stdin,
            stdout=stdout,
            stderr=subprocess.PIPE,
            preexec_fn=limit,
            timeout=TIMEOUT,
        )
    except subprocess.TimeoutExpired:
        return "misbehaved", "timeout"
    err = p.stderr.decode("utf-8", "replace")
    lines = [l for l in err.splitlines() if l.strip()]
    changed = [k for k, v in digest(watch).items() if before.get(k) != v]
    if changed:
        return "misbehaved", f"changed {changed}"
    if p.returncode < 0:
        return "misbehaved", f"signal {-p.returncode}: {err[-300:]}"
    if "panicked" in err or p.returncode not in (0, 1, 2):
        return "misbehaved", f"exit {p.returncode}: {err[-300:]}"
    if p.returncode != 0 and len(lines) != 1:
        return "misbehaved", f"exit {p.returncode} with {len(lines)} lines: {err[-300:]}"
    return "handled", f"exit {p.returncode}"


def mutations(data, n, rng):
    """n mutations of data: flips, large values, truncations, repeats."""
    out = []
    size = len(data)
    for k in range(n):
        b = bytearray(data)
        kind = k % 5
        if kind == 0 and size:
            for _ in range(rng.randint(1, 8)):
                i = rng.randrange(size)
                b[i] ^= 1 << rng.randrange(8)
        elif kind == 1 and size >= 8:
            i = rng.randrange(size - 8) & ~3
            v = rng.choice([0xFFFFFFFF, 0x7FFFFFFF, 0x80000000, 1 << 40, 1 << 62, 0])
            b[i : i + 8] = struct.pack("<Q", v & (2**64 - 1))
        elif kind == 2:
            b = b[: size * (k % 10) // 10]
        elif kind == 3 and size:
            i = rng.randrange(size)
            j = min(size, i + rng.randint(1, 64))
            b[i:i] = b[i:j] * rng.randint(2, 50)
        else:
            # Text: a number made huge or not a number.
            text = bytes(b)
            digits = [i for i, c in enumerate(text) if 48 <= c <= 57]
            if digits:
                i = rng.choice(digits)
                b[i : i + 1] = rng.choice([b"99999999999999999999", b"1e39", b"nan", b"-1", b"inf"])
        out.append(bytes(b))
    return out


def png_bytes(w=2, h=2):
    raw = b"".join(b"\x00" + bytes([200, 100, 50] * w) for _ in range(h))

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b"")
    )


SEAM_OBJ = (
    "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\n"
    "vt 0 0\nvt 0.5 0\nvt 0 1\nvt 0.5 1\nvt 0 0\nvt 0.5 0\nvt 0 1\nvt 0.5 1\n"
    "f 1/1 2/2 5/4 4/3\nf 2/5 3/6 6/8 5/7\n"
)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=str(ROOT / "target/release"))
    ap.add_argument("--per-seed", type=int, default=40)
    ap.add_argument("--out", default=str(ROOT / "benches/results/hostile_campaign.json"))
    a = ap.parse_args()
    b = lambda n: str(Path(a.bin) / n)
    rng = random.Random(56)
    work = Path(tempfile.mkdtemp(prefix="hostile-"))
    results = []

    def record(reader, case, verdict, detail):
        results.append({"reader": reader, "case": case, "verdict": verdict, "detail": detail})

    # Valid pieces the runs need beside the hostile one.
    (work / "seam.obj").write_text(SEAM_OBJ)
    subprocess.run(f"{b('measure')} seam.obj | {b('promote')} --class face --attr area --method sum --as Tarea -o mesh.ply",
                   shell=True, cwd=work, check=True)
    subprocess.run([b("scatter"), "mesh.ply", "-n", "200", "--seed", "1", "-q", "-o", "pts.ply"], cwd=work, check=True)
    subprocess.run(
        f"{b('facet')} pts.ply --mesh seam.obj | {b('promote')} --normalize -o cloud.ply",
        shell=True, cwd=work, check=True,
    )
    (work / "sun.json").write_text('{"lights": [{"name": "sun", "type": "distant", "direction": [0, 0, -1]}]}')
    subprocess.run([b("illum"), "cloud.ply", "--lights", "sun.json", "--no-shadows", "-o", "lit.ply"], cwd=work, check=True)
    subprocess.run([b("ssmulti"), "lit.ply", "--sd", "0.3", "-o", "ss.ply"], cwd=work, check=True)
    subprocess.run([b("pctile"), "split", "lit.ply", "--tiles", "2", "--for", "ssmulti",
                    "--stage-args", "--sd 0.3", "-o", "tiles"], cwd=work, check=True)
    for t in sorted((work / "tiles").glob("tile_*.ply")):
        subprocess.run([b("ssmulti"), str(t), "--sd", "0.3", "-o", str(work / "tiles" / ("out_" + t.name))], check=True)
    (work / "cam.json").write_text(json.dumps(
        {"position": [1, 0.5, 3], "look_at": [1, 0.5, 0], "up": [0, 1, 0], "fov": 40, "width": 16, "height": 8}))
    (work / "mat.json").write_text('{"albedo": [0.8, 0.6, 0.4], "mfp": [0.1, 0.05, 0.02], "g": 0.3, "eta": 1.3}')
    (work / "tex.png").write_bytes(png_bytes())
    subprocess.run([b("pcconvert"), "ss.ply", "-o", "ss.exr"], cwd=work, check=True)

    seeds = {
        "cloud": [
            ROOT / "fixtures/ply/valid/all_kinds_ascii.ply",
            work / "ss.ply",
            work / "ss.exr",
            ROOT / "fixtures/mesh/cube.obj",
            ROOT / "fixtures/usd/box.usda",
            ROOT / "fixtures/usd/box.usdc",
            ROOT / "fixtures/usd/box.usdz",
        ],
        "lights": [ROOT / "fixtures/lights/three.json", work / "sun.json"],
        "camera": [work / "cam.json"],
        "material": [work / "mat.json"],
        "texture": [work / "tex.png", work / "ss.exr"],
        "manifest": [work / "tiles/manifest.json"],
    }

    def readers(kind, path):
        """The runs that read `path` as `kind`: (argv, watched files)."""
        p = str(path)
        if kind == "cloud":
            return [[b("pcinfo"), p], [b("pcconvert"), p, "-o", "o.ply"], [b("measure"), p, "-o", "o.ply"]]
        if kind == "lights":
            return [[b("illum"), "cloud.ply", "--lights", p, "--no-shadows", "-o", "o.ply"]]
        if kind == "camera":
            return [[b("render"), "--mesh", "seam.obj", "--camera", p, "--cloud", "ss.ply", "-o", "o.exr"]]
        if kind == "material":
            return [[b("ssmulti"), "lit.ply", "--material", p, "-o", "o.ply"]]
        if kind == "texture":
            return [[b("texture"), "pts.ply", "--mesh", "seam.obj", "--image", p, "--as", "Cd", "-o", "o.ply"]]
        if kind == "manifest":
            return [[b("pctile"), "merge", str(Path(p).parent), "--from", str(work / "tiles"), "-o", "o.ply"]]
        raise ValueError(kind)

    n = 0
    for kind, files in seeds.items():
        for seed in files:
            data = Path(seed).read_bytes()
            for k, m in enumerate(mutations(data, a.per_seed, rng)):
                if kind == "manifest":
                    d = work / f"mtiles{n}"
                    d.mkdir()
                    path = d / "manifest.json"
                else:
                    path = work / f"in{n}{Path(seed).suffix}"
                n += 1
                path.write_bytes(m)
                for argv in readers(kind, path):
                    v, detail = run(argv, work, watch=[path])
                    record(kind, f"{Path(seed).name} mutation {k}: {Path(argv[0]).name}", v, detail)
            # Special files in the place of this kind's input.
            if seed == files[0]:
                os.symlink("loop", work / f"loop{kind}") if not (work / f"loop{kind}").exists() else None
                (work / "emptydir").mkdir(exist_ok=True)
                (work / "empty").write_bytes(b"")
                for special in ["empty", "/dev/zero", "/dev/null", "emptydir", f"loop{kind}"]:
                    for argv in readers(kind, special if special.startswith("/") else work / special):
                        v, detail = run(argv, work)
                        record(kind, f"{special}: {Path(argv[0]).name}", v, detail)

    # A dome map the lights file names, mutated (from an OpenEXR image
    # render writes and from a PNG).
    subprocess.run([b("render"), "--mesh", "seam.obj", "--camera", "cam.json", "--cloud", "ss.ply", "-o", "seed_map.exr"],
                   cwd=work, check=True)
    k = 0
    for seed in [work / "seed_map.exr", work / "tex.png"]:
        for m in mutations(seed.read_bytes(), a.per_seed, rng):
            mp = work / f"map{k}{seed.suffix}"
            mp.write_bytes(m)
            lj = work / f"dome{k}.json"
            lj.write_text(json.dumps({"lights": [{"name": "sky", "type": "dome", "map": mp.name, "samples": 4}]}))
            v, detail = run([b("illum"), "cloud.ply", "--lights", lj.name, "--no-shadows", "-o", "o.ply"], work, watch=[mp, lj])
            record("dome map", f"{seed.name} mutation {k}", v, detail)
            k += 1

    # Writers: outputs that are inputs or lead elsewhere.
    shutil.copy(work / "lit.ply", work / "keep.ply")
    os.symlink("keep.ply", work / "keep_link.ply")
    (work / "dome_out.json").write_text('{"lights": [{"name": "sky", "type": "dome", "map": "keep.exr", "samples": 4}]}')
    shutil.copy(work / "ss.exr", work / "keep.exr")
    writer_cases = [
        ("out is in", [b("ssmulti"), "keep.ply", "--sd", "0.3", "-o", "keep.ply"], {}),
        ("out is in by a link", [b("ssmulti"), "keep.ply", "--sd", "0.3", "-o", "keep_link.ply"], {}),
        ("out is a dome map read", [b("illum"), "cloud.ply", "--lights", "dome_out.json", "--no-shadows", "-o", "keep.exr"], {}),
        ("out is a dome map read (render)", [b("render"), "--mesh", "seam.obj", "--camera", "cam.json", "--cloud", "ss.ply",
                                             "--direct", "dome_out.json", "-o", "keep.exr"], {}),
        ("stdout is the input", [b("ssmulti"), "keep.ply", "--sd", "0.3"], {"stdout": "keep.ply"}),
        ("stdin is the output", [b("ssmulti"), "--sd", "0.3", "-o", "keep.ply"], {"stdin": "keep.ply"}),
        ("unknown extension .usdc", [b("pcconvert"), "keep.ply", "-o", "x.usdc"], {}),
        ("unknown extension .bgeo", [b("ssmulti"), "keep.ply", "--sd", "0.3", "-o", "x.bgeo"], {}),
        ("unknown extension .vdb", [b("pcconvert"), "keep.ply", "-o", "x.vdb"], {}),
        ("-o /dev/stdout to a file", [b("pcconvert"), "keep.ply", "-o", "/dev/stdout"], {"stdout_new": "via_stdout.ply"}),
        ("stdout /dev/null read-write", [b("pcconvert"), "keep.ply"], {"devnull_rw": True}),
        ("stdout closed", [b("pcconvert"), "keep.ply"], {"closed": True}),
        ("-o into a missing directory", [b("pcconvert"), "keep.ply", "-o", "no/such/dir/x.ply"], {}),
        ("-o a directory", [b("pcconvert"), "keep.ply", "-o", "emptydir"], {}),
    ]
    watch = [work / "keep.ply", work / "keep.exr"]
    for name, argv, how in writer_cases:
        if "stdout" in how:
            with open(work / how["stdout"], "r+b") as f:
                v, detail = run(argv, work, watch=watch, stdout=f)
        elif "stdin" in how:
            with open(work / how["stdin"], "rb") as f:
                v, detail = run(argv, work, watch=watch, stdin=f)
        elif "stdout_new" in how:
            with open(work / how["stdout_new"], "wb") as f:
                v, detail = run(argv, work, watch=watch, stdout=f)
            if v == "handled" and not (work / how["stdout_new"]).read_bytes().startswith(b"ply"):
                v, detail = "misbehaved", "the file stdout names stayed empty"
        elif how.get("devnull_rw"):
            fd = os.open("/dev/null", os.O_RDWR)
            v, detail = run(argv, work, watch=watch, stdout=fd)
            os.close(fd)
            if detail != "exit 0":
                v, detail = "misbehaved", "refused /dev/null opened on purpose: " + detail
        elif how.get("closed"):
            p = subprocess.run(f"{' '.join(argv)} >&-", shell=True, cwd=work, stderr=subprocess.PIPE)
            lines = p.stderr.decode().splitlines()
            v, detail = ("handled", "refused") if p.returncode == 1 and len(lines) == 1 else ("misbehaved", p.stderr.decode())
        else:
            v, detail = run(argv, work, watch=watch)
        record("writer", name, v, detail)

    shutil.rmtree(work, ignore_errors=True)
    by = {}
    for r in results:
        c = by.setdefault(r["reader"], {"handled": 0, "misbehaved": 0})
        c[r["verdict"]] += 1
    total = {"handled": sum(c["handled"] for c in by.values()), "misbehaved": sum(c["misbehaved"] for c in by.values())}
    print(f"{'reader':10} {'runs':>6} {'handled':>8} {'misbehaved':>10}")
    for k, c in by.items():
        print(f"{k:10} {c['handled'] + c['misbehaved']:6} {c['handled']:8} {c['misbehaved']:10}")
    print(f"{'all':10} {total['handled'] + total['misbehaved']:6} {total['handled']:8} {total['misbehaved']:10}")
    bad = [r for r in results if r["verdict"] == "misbehaved"]
    for r in bad[:40]:
        print("MISBEHAVED", r["reader"], r["case"], r["detail"][:300])
    Path(a.out).write_text(json.dumps(
        {"machine": os.uname().nodename, "address_limit": LIMIT_AS, "timeout_s": TIMEOUT,
         "per_seed": a.per_seed, "by_reader": by, "total": total, "misbehaved": bad}, indent=1) + "\n")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
