"""The Python module against the binaries: same bits, same errors, arrays
in and out, the GIL released. Run by tests/it/python_module.rs (make
test), with PCSSS_BIN the folder of the release binaries."""

import os
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import pcsss

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("PCSSS_BIN", ROOT / "target" / "release"))
MESH = str(ROOT / "fixtures" / "mesh" / "bunny.obj")
LIGHTS = str(ROOT / "fixtures" / "lights" / "bunny.json")


def binary(stage, *args):
    r = subprocess.run([str(BIN / stage), *map(str, args)], capture_output=True, text=True)
    return r.returncode, r.stderr.strip()


def same(a, b):
    assert a.keys() == b.keys()
    for k in a.keys():
        x, y = a[k], b[k]
        assert x.dtype == y.dtype, k
        assert np.array_equal(x, y), k
    assert a.detail == b.detail
    assert a.elements() == b.elements()


@pytest.fixture(scope="module")
def lit(tmp_path_factory):
    d = tmp_path_factory.mktemp("lit")
    for args in (
        ("scatter", MESH, "--count", "4000", "--seed", "3", "-o", d / "s.ply"),
        ("facet", d / "s.ply", "--mesh", MESH, "-o", d / "f.ply"),
        ("illum", d / "f.ply", "--lights", LIGHTS, "--mesh", MESH, "-o", d / "i.ply"),
    ):
        code, err = binary(*args)
        assert code == 0, err
    return d


def test_a_stage_from_python_gives_the_binary_s_bits(lit):
    code, err = binary("ssmulti", lit / "i.ply", "--rd", "0.9,0.5,0.3", "--sd", "0.6", "--rgb",
                       "-o", lit / "bin.ply")
    assert code == 0, err
    cloud = pcsss.read(lit / "i.ply")
    out = pcsss.ssmulti(cloud, rd=(0.9, 0.5, 0.3), sd=0.6, rgb=True)
    same(out, pcsss.read(lit / "bin.ply"))
    # The input is left as it was.
    assert "ssM" not in cloud and "ssM" in out
    # Through a file written by the module, too.
    pcsss.write(out, lit / "py.ply")
    same(pcsss.read(lit / "py.ply"), pcsss.read(lit / "bin.ply"))


def test_the_whole_chain_from_python_equals_the_binaries(lit):
    mesh = pcsss.read(MESH)
    c = pcsss.scatter(mesh, count=4000, seed=3)
    c = pcsss.facet(c, mesh=MESH)
    c = pcsss.illum(c, lights=LIGHTS, mesh=MESH)
    same(c, pcsss.read(lit / "i.ply"))


def test_errors_are_the_binary_s_line(lit):
    cloud = pcsss.read(lit / "i.ply")
    code, err = binary("ssmulti", lit / "i.ply", "--sd", "-1", "-o", lit / "x.ply")
    assert code == 2
    with pytest.raises(pcsss.ParameterError) as e:
        pcsss.ssmulti(cloud, sd=-1)
    assert isinstance(e.value, ValueError)
    assert err == "ssmulti: " + str(e.value)
    code, err = binary("illum", lit / "i.ply", "--lights", lit / "none.json", "--no-shadows",
                       "-o", lit / "x.ply")
    assert code == 1
    with pytest.raises(pcsss.Error) as e:
        pcsss.illum(cloud, lights=lit / "none.json", no_shadows=True)
    assert not isinstance(e.value, ValueError)
    assert err == "illum: " + str(e.value)
    with pytest.raises(pcsss.ParameterError, match="--mesh"):
        pcsss.illum(cloud, lights=LIGHTS)
    with pytest.raises(pcsss.ParameterError, match="unexpected argument"):
        pcsss.ssmulti(cloud, no_such_option=1)
    # A missing attribute names the stage that makes it.
    with pytest.raises(pcsss.Error, match="illum"):
        pcsss.ssmulti(pcsss.read(lit / "f.ply"), sd=0.6)
    with pytest.raises(pcsss.Error, match="none.ply"):
        pcsss.read(lit / "none.ply")


def test_numpy_values_clouds_for_files_and_render(lit, tmp_path):
    cloud = pcsss.read(lit / "i.ply")
    want = pcsss.ssmulti(cloud, rd=(0.9, 0.5, 0.3), sd=0.6, rgb=True)
    # NumPy arrays and numbers wherever numbers go.
    same(pcsss.ssmulti(cloud, rd=np.array([0.9, 0.5, 0.3]), sd=np.float64(0.6), rgb=np.bool_(True)), want)
    # A mesh in memory for an option that takes a file.
    mesh = pcsss.read(MESH)
    f = pcsss.read(lit / "f.ply")
    s = pcsss.read(lit / "s.ply")
    same(pcsss.facet(s, mesh=mesh), f)
    # Errors name the keyword, and the input cloud, not a file of ours.
    with pytest.raises(pcsss.Error, match=r"mesh=<Cloud>") as e:
        pcsss.facet(s, mesh=s)
    assert "tmp" not in str(e.value)
    with pytest.raises(pcsss.Error, match="the input cloud"):
        pcsss.illum(pcsss.Cloud.from_arrays({"P": np.zeros((3, 3), np.float32)}), lights=LIGHTS, no_shadows=True)
    # render: the picture, as the binary makes it, returned as a cloud.
    cam = str(ROOT / "fixtures" / "cameras" / "bunny.json")
    code, err = binary("render", "--mesh", MESH, "--camera", cam, "--cloud", lit / "i.ply", "--rd", "0.9,0.5,0.3",
                       "--sd", "0.6", "--rgb", "--width", "64", "--height", "48", "-o", tmp_path / "bin.exr")
    assert code == 0, err
    img = pcsss.render(cloud, mesh=mesh, camera=cam, rd=(0.9, 0.5, 0.3), sd=0.6, rgb=True, width=64, height=48,
                       png=tmp_path / "py.png")
    same(img, pcsss.read(tmp_path / "bin.exr"))
    assert (tmp_path / "py.png").exists()
    assert len(img) > 0


def test_arrays_in_and_out():
    rng = np.random.default_rng(1)
    p = rng.random((1000, 3), dtype=np.float32)
    area = rng.random(1000)
    c = pcsss.Cloud.from_arrays({"P": p, "ptarea": area, "id": np.arange(1000, dtype=np.int32)})
    assert len(c) == 1000 and c.keys() == ["P", "ptarea", "id"]
    assert c["P"].shape == (1000, 3) and c["P"].dtype == np.float32
    assert np.array_equal(c["P"], p)
    assert c["ptarea"].dtype == np.float64 and np.array_equal(c["ptarea"], area)
    # A scalar column is the toolkit's own memory, read-only, kept
    # alive by the array.
    v = c["ptarea"]
    assert not v.flags.writeable and not v.flags.owndata
    assert v.ctypes.data == c["ptarea"].ctypes.data
    with pytest.raises(ValueError):
        v[0] = 1.0
    # Setting the attribute while a view of it exists leaves the view
    # on the values it showed (the cloud is copied on write).
    c["ptarea"] = np.zeros(1000)
    assert np.array_equal(v, area) and not c["ptarea"].any()
    del c
    assert v.sum() == area.sum()
    c = pcsss.Cloud.from_arrays({"P": p})
    # A 3-vector's columns, as views.
    x, y, z = c.components("P")
    assert np.array_equal(np.stack([x, y, z], axis=1), p)
    assert not x.flags.owndata and not x.flags.writeable
    assert x.ctypes.data == c.components("P")[0].ctypes.data
    c["Cd"] = np.ones((1000, 3), dtype=np.float32)
    assert "Cd" in c
    # A 3-vector as N x 3: a read-only view of the toolkit's own block,
    # the same memory at every access.
    q = c["P"]
    assert q.shape == (1000, 3) and not q.flags.owndata and not q.flags.writeable
    assert q.ctypes.data == c["P"].ctypes.data
    assert q.flags.c_contiguous and np.array_equal(q, p)
    assert c["Cd"].ctypes.data == c["Cd"].ctypes.data and (c["Cd"] == 1).all()
    with pytest.raises(ValueError):
        c["bad"] = np.ones(3)
    with pytest.raises(KeyError):
        c["none"]


def test_a_stage_s_3_vectors_are_views_and_a_file_s_too(lit, tmp_path):
    """What a stage makes is an N x 3 view from Python, and the next stage
    and the writers take it as it was; a binary file's x, y, z read from
    Python are a view of the file's records (no decode)."""
    cloud = pcsss.read(lit / "i.ply")
    p = cloud["P"]
    # The PLY's x, y, z are neighbours in each record: a strided view.
    assert not p.flags.owndata and p.strides[1] == 4 and p.strides[0] > 12
    assert np.array_equal(p, np.stack(cloud.components("P"), axis=1))
    out = pcsss.ssmulti(cloud, rd=(0.9, 0.5, 0.3), sd=0.6, rgb=True)
    m = out["ssM"]
    assert m.shape == (len(out), 3) and m.dtype == np.float32
    assert not m.flags.owndata and m.ctypes.data == out["ssM"].ctypes.data
    assert np.array_equal(m, np.stack(out.components("ssM"), axis=1))
    # The binary's bits, through a stage that reads ssM and a writer.
    code, err = binary("ssmulti", lit / "i.ply", "--rd", "0.9,0.5,0.3", "--sd", "0.6", "--rgb",
                       "-o", tmp_path / "m.ply")
    assert code == 0, err
    same(out, pcsss.read(tmp_path / "m.ply"))
    pcsss.write(out, tmp_path / "py.ply")
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "m.ply").read_bytes()
    # Records that are neither 4-byte rows nor aligned (a 13-byte row after
    # a header of odd length): still a view, with the values written.
    rng = np.random.default_rng(7)
    pts = rng.random((50, 3), dtype=np.float32)
    row = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("k", "u1")])
    rec = np.zeros(50, dtype=row)
    rec["x"], rec["y"], rec["z"], rec["k"] = pts[:, 0], pts[:, 1], pts[:, 2], 7
    head = ("ply\nformat binary_little_endian 1.0\ncomment odd\nelement vertex 50\n"
            "property float x\nproperty float y\nproperty float z\nproperty uchar k\nend_header\n")
    assert len(head) % 4 != 0
    (tmp_path / "odd.ply").write_bytes(head.encode() + rec.tobytes())
    odd = pcsss.read(tmp_path / "odd.ply")
    v = odd["P"]
    assert not v.flags.owndata and v.strides == (13, 4) and np.array_equal(v, pts)
    f = pcsss.filter(out, cloud=str(tmp_path / "m.ply"))
    code, err = binary("filter", tmp_path / "m.ply", "--cloud", tmp_path / "m.ply",
                       "-o", tmp_path / "f.ply")
    assert code == 0, err
    same(f, pcsss.read(tmp_path / "f.ply"))


def test_the_gil_is_released_while_a_stage_runs(lit):
    cloud = pcsss.read(lit / "i.ply")
    calls, spins = [], []
    done = threading.Event()

    def work():
        for _ in range(5):
            t0 = time.perf_counter()
            pcsss.ssmulti(cloud, rd=(0.9, 0.5, 0.3), sd=0.6, rgb=True)
            calls.append((t0, time.perf_counter()))
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        spins.append(time.perf_counter())
        time.sleep(0.0001)
    t.join()
    # Held, the GIL would keep this thread from running while a stage runs.
    inside = sum(any(a < s < b for a, b in calls) for s in spins)
    assert inside >= 5, (inside, len(spins), calls)


def test_integer_positions_become_floats_and_wide_integers_are_checked():
    # Positions given as int64 (np.arange's default) are positions, not
    # whole-number codes: converted to float64, exactly.
    p = np.arange(30, dtype=np.int64).reshape(10, 3) * 1000003
    c = pcsss.Cloud.from_arrays({"P": p, "Cd": np.ones((10, 3), dtype=np.int64)})
    assert c["P"].dtype == np.float64 and np.array_equal(c["P"], p.astype(np.float64))
    assert c["Cd"].dtype == np.float64
    # Other integers keep their values: int64 that fit become int32 ...
    c["id"] = np.arange(10, dtype=np.int64)
    assert c["id"].dtype == np.int32 and list(c["id"]) == list(range(10))
    # ... and ones past int32 are refused, not wrapped.
    with pytest.raises(ValueError, match="id2.*int32"):
        c["id2"] = np.arange(10, dtype=np.int64) + 2**40
    # Floats of any width: float16 as float32, longdouble as float64.
    c["h"] = np.ones(10, dtype=np.float16)
    assert c["h"].dtype == np.float32
    c["l"] = np.ones(10, dtype=np.longdouble)
    assert c["l"].dtype == np.float64
    # A 3 x N array names its shape and the fix.
    with pytest.raises(ValueError, match=r"\(3, 10\).*\.T"):
        pcsss.Cloud.from_arrays({"P": np.zeros((3, 10))})
