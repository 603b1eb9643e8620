"""ffseg.batch on dask.distributed: a two-worker local cluster on synthetic
cases (one corrupt file, one manifest row without an object, one lost worker),
reruns, and a scheduler with workers started as separate processes."""
import csv
import gzip
import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest

import imagefiles as F
from conftest import HERE, affine, ball

from ffseg import batch

PY = sys.executable
CENTRES = [(14.0, 12.0, 10.0), (12.0, 13.0, 11.0), (13.0, 11.5, 12.0)]


def env():
    e = dict(os.environ)
    e["PYTHONPATH"] = os.pathsep.join([os.path.dirname(HERE), HERE] + [p for p in [e.get("PYTHONPATH")] if p])
    return e


@pytest.fixture(scope="module")
def cohort(tmp_path_factory):
    """Three binary balls (NIfTI, NRRD, MetaImage) with truth maps, a corrupt
    file and a row without objects."""
    import nibabel
    d = tmp_path_factory.mktemp("cohort")
    rows = []
    for n, (c, radius) in enumerate(zip(CENTRES, (5.0, 6.0, 4.5))):
        A = affine((1.0, 1.0, 1.2), (-10.0 * n, 4.0, 0.0))
        vol = ball(shape=(28, 26, 24), centre=c, radius=radius / np.array([1, 1, 1.2]).min(), inside=1)
        world = (A @ np.array([*c, 1.0]))[:3]
        name = ["a.nii.gz", "b.nrrd", "c.mha"][n]
        if name.endswith(".nii.gz"):
            nibabel.save(nibabel.Nifti1Image(vol, A), str(d / name))
        elif name.endswith(".nrrd"):
            F.write_nrrd(str(d / name), vol, A)
        else:
            F.write_mha(str(d / name), vol, A)
        nibabel.save(nibabel.Nifti1Image((vol * 7).astype(np.uint8), A), str(d / f"truth{n}.nii.gz"))
        rows.append({"case": f"case{n}", "volume": name, "spheres": "%g,%g,%g,2" % tuple(world),
                     "target": "binary", "mesh_resolution": "8", "truth": f"truth{n}.nii.gz",
                     "truth_labels": "7", "check": ["consensus", "seed", ""][n]})
    good = (d / "a.nii.gz").read_bytes()
    (d / "corrupt.nii.gz").write_bytes(good[: len(good) // 3])  # a truncated gzip stream
    rows.append({"case": "corrupt", "volume": "corrupt.nii.gz", "spheres": rows[0]["spheres"],
                 "target": "binary", "mesh_resolution": "8"})
    rows.append({"case": "noobject", "volume": "a.nii.gz", "target": "binary"})
    with open(d / "manifest.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=batch.COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow(r)
    return d


def summary(out):
    with open(os.path.join(out, "summary.csv"), newline="") as f:
        return {r["case"]: r for r in csv.DictReader(f)}


def check_good(rows, status):
    for n in range(3):
        r = rows[f"case{n}"]
        assert r["status"] == status, r
        assert str(r["objects"]) == "1" and r["error"] == ""
        assert float(r["dice"]) > 0.85, r
        assert 0.2 < float(r["volume_ml"]) < 1.5
        assert int(str(r["steps"])) >= 1


def test_batch_on_a_local_cluster_then_reruns(cohort, tmp_path):
    out = str(tmp_path / "out")
    t0 = time.monotonic()
    r = subprocess.run([PY, "-m", "ffseg.batch", str(cohort / "manifest.csv"), "--out", out, "--workers", "2"],
                       capture_output=True, text=True, env=env(), timeout=300)
    wall = time.monotonic() - t0
    assert r.returncode == 1, r.stderr  # a case failed
    assert "[5/5]" in r.stderr or "[4/4]" in r.stderr, r.stderr  # progress lines
    rows = summary(out)
    assert list(rows) == ["case0", "case1", "case2", "corrupt", "noobject"]
    check_good(rows, "ok")
    assert rows["corrupt"]["status"] == "failed" and "gzip" in rows["corrupt"]["error"]
    assert rows["noobject"]["status"] == "failed" and "no object" in rows["noobject"]["error"]
    for n in range(3):
        files = sorted(os.listdir(os.path.join(out, f"case{n}")))
        assert "report.json" in files and "overlay.png" in files and "object1.ply" in files
        lab = {"case0": "labels.nii.gz", "case1": "labels.nrrd", "case2": "labels.mha"}[f"case{n}"]
        assert lab in files
        rep = json.load(open(os.path.join(out, f"case{n}", "report.json")))
        assert "%.4f" % rep["objects"][0]["metrics"]["dice"] == rows[f"case{n}"]["dice"]
    # check=consensus (case0) and check=seed (case1): a ball is found from every perturbed sphere.
    for n, check in enumerate(["consensus", "seed", ""]):
        r = rows[f"case{n}"]
        if check:
            assert float(r["seed_check"]) >= 0.85, r
        else:
            assert r["seed_check"] == "", r
        assert (r["consensus_dice"] != "") == (check == "consensus"), r
    assert float(rows["case0"]["consensus_dice"]) > 0.85
    assert os.path.exists(os.path.join(out, "case0", "consensus.nii.gz"))
    assert not os.path.exists(os.path.join(out, "case1", "consensus.nrrd"))
    assert not os.path.exists(os.path.join(out, "corrupt"))
    print(f"batch of 5 cases on 2 local workers: {wall:.1f} s wall")

    # A rerun skips the finished cases; --force runs them again.
    lines = []
    again = batch.run_batch(str(cohort / "manifest.csv"), out, workers=2, progress=lines.append)
    st = {r["case"]: r["status"] for r in again}
    assert st == {"case0": "skipped", "case1": "skipped", "case2": "skipped", "corrupt": "failed",
                  "noobject": "failed"}
    check_good(summary(out), "skipped")
    assert any("3 already done" in l for l in lines)
    forced = batch.run_batch(str(cohort / "manifest.csv"), out, workers=2, force=True)
    check_good({r["case"]: r for r in forced}, "ok")


def test_a_lost_worker_fails_its_case_only(cohort, tmp_path, monkeypatch):
    import dask
    from distributed import Client, LocalCluster
    man = tmp_path / "m.csv"
    text = (cohort / "manifest.csv").read_text().splitlines()
    rows = [text[0], text[1], text[2], text[1].replace("case0", "lost", 1)]
    man.write_text("\n".join(rows) + "\n")
    # Relative paths resolve beside the manifest: point them at the cohort.
    man.write_text(man.read_text().replace("a.nii.gz", str(cohort / "a.nii.gz"))
                   .replace("b.nrrd", str(cohort / "b.nrrd"))
                   .replace("truth0", str(cohort / "truth0")).replace("truth1", str(cohort / "truth1")))
    monkeypatch.setenv("PYTHONPATH", env()["PYTHONPATH"])
    import batch_helpers
    # No retry of a task whose worker died.
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cl, Client(cl) as c:
            res = batch.run_batch(str(man), str(tmp_path / "out"), client=c, runner=batch_helpers.dies_on_case_lost)
    st = {r["case"]: r for r in res}
    assert st["lost"]["status"] == "failed" and "worker lost" in st["lost"]["error"], st["lost"]
    assert st["case0"]["status"] == "ok" and st["case1"]["status"] == "ok"


def test_manifest_errors_exit_2(tmp_path):
    cases = {
        "nocase.csv": ("volume,spheres\na.nii.gz,\"1,2,3,4\"\n", "'case'"),
        "fields.csv": ("case,volume,spheres\nx,a.nii.gz,1,2,3,4\n", "more fields"),
        "unknown.csv": ("case,volume,colour\nx,a.nii.gz,red\n", "colour"),
        "twice.csv": ("case,volume,spheres\nx,a.nii.gz,\"1,2,3,4\"\nx,b.nii.gz,\"1,2,3,4\"\n", "twice"),
        "name.csv": ("case,volume,spheres\n../x,a.nii.gz,\"1,2,3,4\"\n", "valid name"),
        "empty.csv": ("case,volume\n", "no case"),
    }
    for name, (text, word) in cases.items():
        (tmp_path / name).write_text(text)
        r = subprocess.run([PY, "-m", "ffseg.batch", str(tmp_path / name), "--out", str(tmp_path / "o")],
                           capture_output=True, text=True, env=env(), timeout=60)
        assert r.returncode == 2 and word in r.stderr, (name, r.stderr)
    r = subprocess.run([PY, "-m", "ffseg.batch", str(tmp_path / "missing.csv"), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, env=env(), timeout=60)
    assert r.returncode == 2 and "cannot read the manifest" in r.stderr


def test_batch_on_a_scheduler_and_workers_started_apart(cohort, tmp_path):
    sched_file = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(subprocess.Popen([PY, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                       "--port", "0", "--no-dashboard", "--scheduler-file", str(sched_file)],
                                      env=env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        for _ in range(200):
            if sched_file.exists() and sched_file.stat().st_size > 0:
                break
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        for _ in range(2):
            procs.append(subprocess.Popen([PY, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                           "--no-dashboard", "--host", "127.0.0.1"],
                                          env=env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client
        with Client(address, timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        out = str(tmp_path / "out")
        r = subprocess.run([PY, "-m", "ffseg.batch", str(cohort / "manifest.csv"), "--out", out,
                            "--scheduler", address], capture_output=True, text=True, env=env(), timeout=300)
        assert r.returncode == 1, r.stderr
        rows = summary(out)
        check_good(rows, "ok")
        assert rows["corrupt"]["status"] == "failed"
    finally:
        for p in procs[::-1]:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_the_check_column_passes_the_seed_check_or_refuses_the_case(tmp_path):
    m = tmp_path / "m.csv"
    m.write_text('case,volume,spheres,check\nx,a.nii.gz,"1,2,3,4",consensus\ny,a.nii.gz,"1,2,3,4",seed\n'
                 'z,a.nii.gz,"1,2,3,4",\nw,a.nii.gz,"1,2,3,4",twice\n')
    got = {case: (args, err) for case, _, args, err in batch.read_manifest(str(m))}
    assert "--consensus" in got["x"][0] and "--seed-check" not in got["x"][0]
    assert "--seed-check" in got["y"][0]
    assert "--consensus" not in got["z"][0] and "--seed-check" not in got["z"][0]
    assert got["w"][0] is None and "check: 'twice' is not one of seed, consensus" in got["w"][1]
