"""Segment a cohort: every case of a manifest on dask.distributed.

    python3 -m ffseg.batch MANIFEST.csv --out DIR [--workers N | --scheduler ADDRESS]
                           [--force] [--timeout SECONDS] [--ffseg PATH] [-q]

MANIFEST.csv has a header row with the columns
    case               a name (letters, digits, '_', '-', '.'): the output folder DIR/CASE
    volume             the image (NIfTI, NRRD, MetaImage, or a DICOM series directory)
    spheres            objects as x,y,z,r in world mm, separated by ';'
    sphere_from_label  objects as LABELS:L (the PEERS protocol sphere), separated by ';'
and optionally target (intensity or binary), mesh_resolution, truth (a label map),
truth_labels (its label per object, separated by ';' or ',') and check (seed:
`--seed-check`, how far each contour moves under five perturbed spheres;
consensus: `--consensus`, that and consensus.* from the six runs). Every case
needs spheres or sphere_from_label (both: the spheres first). Relative paths are
relative to the manifest's folder.

Each case runs `ffseg segment` on a worker and writes what it writes into
DIR/CASE/ (meshes, label map, overlay.png, report.json); DIR/summary.csv gets one
row per case: status (ok, failed, or skipped when DIR/CASE/report.json is there
from an earlier run; --force runs it again), objects, volume_ml and dice per
object (';'-separated), steps, converged, seconds, error, output, and with a
check seed_check (each object's lowest Dice against its perturbed runs; below
0.85 the contour depends on where the sphere was put) and consensus_dice
(with a truth map and check=consensus). A case that fails (an
unreadable file, an engine error, a lost worker, the timeout) is recorded and
the others go on. Without --scheduler a local cluster of --workers processes
(default 2, one thread each) is started; with --scheduler the workers must see
the same files and the same ffseg tool path. Exit status: 0 when every case is
ok or skipped, 1 when a case failed, 2 for a bad command line or manifest.
"""
import argparse
import csv
import json
import os
import re
import shutil
import subprocess
import sys
import time

COLUMNS = ("case", "volume", "spheres", "sphere_from_label", "target", "mesh_resolution", "truth",
           "truth_labels", "check")
SUMMARY = ("case", "status", "objects", "volume_ml", "dice", "steps", "converged", "seconds", "error",
           "output", "seed_check", "consensus_dice")
_CHECKS = {"seed": "--seed-check", "consensus": "--consensus"}
_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}$")


class ManifestError(Exception):
    pass


def find_cli(explicit=None):
    """The ffseg tool: explicit, FFSEG_CLI, the source tree's build/ffseg, the
    installed one, or `ffseg` on PATH."""
    here = os.path.dirname(os.path.abspath(__file__))
    cands = [explicit, os.environ.get("FFSEG_CLI"),
             os.path.normpath(os.path.join(here, "..", "..", "..", "build", "ffseg"))]
    try:
        from ._install import CLI  # type: ignore
        cands.append(CLI)
    except ImportError:
        pass
    cands.append(shutil.which("ffseg"))
    for c in cands:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    if explicit:
        raise ManifestError(f"--ffseg {explicit}: not an executable file")
    raise ManifestError("the ffseg tool was not found: build it (make), or give --ffseg PATH or FFSEG_CLI")


def _case_args(row, base):
    """The `ffseg segment` arguments of one manifest row (ValueError: why not)."""
    def path(p):
        p = p.strip()
        return p if os.path.isabs(p) else os.path.normpath(os.path.join(base, p))
    args = [path(row["volume"])]
    n = 0
    for s in filter(None, (x.strip() for x in (row.get("spheres") or "").split(";"))):
        parts = s.split(",")
        if len(parts) != 4:
            raise ValueError(f"spheres: '{s}' is not x,y,z,r")
        for p in parts:
            float(p)  # ValueError names it
        args += ["--sphere", ",".join(p.strip() for p in parts)]
        n += 1
    for s in filter(None, (x.strip() for x in (row.get("sphere_from_label") or "").split(";"))):
        if ":" not in s:
            raise ValueError(f"sphere_from_label: '{s}' is not LABELS:L")
        labels, label = s.rsplit(":", 1)
        args += ["--sphere-from-label", f"{path(labels)}:{label.strip()}"]
        n += 1
    if n == 0:
        raise ValueError("no object: give spheres or sphere_from_label")
    if (row.get("target") or "").strip():
        args += ["--target", row["target"].strip()]
    if (row.get("mesh_resolution") or "").strip():
        args += ["--mesh-resolution", row["mesh_resolution"].strip()]
    if (row.get("truth") or "").strip():
        args += ["--truth", path(row["truth"])]
    if (row.get("truth_labels") or "").strip():
        if not (row.get("truth") or "").strip():
            raise ValueError("truth_labels needs a truth column")
        args += ["--truth-labels", ",".join(x.strip() for x in re.split("[;,]", row["truth_labels"]) if x.strip())]
    check = (row.get("check") or "").strip()
    if check:
        if check not in _CHECKS:
            raise ValueError(f"check: '{check}' is not one of {', '.join(_CHECKS)}")
        args.append(_CHECKS[check])
    return args


def read_manifest(path):
    """[(case, row dict, args or None, error or None)] in file order."""
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            header = [h.strip() for h in (reader.fieldnames or [])]
    except OSError as ex:
        raise ManifestError(f"cannot read the manifest {path}: {ex.strerror}") from None
    except (csv.Error, UnicodeDecodeError) as ex:
        raise ManifestError(f"{path}: not a CSV file ({ex})") from None
    if not rows:
        raise ManifestError(f"{path}: no case (a header row and one row per case are needed)")
    unknown = [c for c in header if c not in COLUMNS]
    if unknown:
        raise ManifestError(f"{path}: unknown column(s) {', '.join(map(repr, unknown))} "
                            f"(known: {', '.join(COLUMNS)})")
    for need in ("case", "volume"):
        if need not in header:
            raise ManifestError(f"{path}: the column '{need}' is missing")
    base = os.path.dirname(os.path.abspath(path))
    out, seen = [], set()
    for line, row in enumerate(rows, start=2):
        if None in row:
            raise ManifestError(f"{path}, line {line}: more fields than columns")
        row = {k.strip(): (v or "").strip() for k, v in row.items() if k is not None}
        case = row["case"]
        if not _NAME.match(case):
            raise ManifestError(f"{path}, line {line}: case '{case}' is not a valid name "
                                "(letters, digits, '_', '-', '.'; not starting with '.' or '-')")
        if case in seen:
            raise ManifestError(f"{path}, line {line}: case '{case}' is given twice")
        seen.add(case)
        try:
            if not row["volume"]:
                raise ValueError("volume is empty")
            out.append((case, row, _case_args(row, base), None))
        except ValueError as ex:
            out.append((case, row, None, f"manifest line {line}: {ex}"))
    return out


def summary_from_report(case, status, report, seconds, outdir):
    objs = report.get("objects", [])
    dice = [o.get("metrics", {}).get("dice") for o in objs]
    seeds = (report.get("seed_check") or {}).get("objects", [])
    cons = [o.get("metrics", {}).get("dice") for o in (report.get("consensus") or {}).get("objects", [])]
    return {"case": case, "status": status, "objects": len(objs),
            "volume_ml": ";".join("%.4f" % o["volume_ml"] for o in objs),
            "dice": _joined(dice), "steps": report.get("steps", ""), "converged": report.get("converged", ""),
            "seconds": "%.2f" % seconds, "error": "", "output": outdir,
            "seed_check": _joined([o.get("lowest_dice") for o in seeds]), "consensus_dice": _joined(cons)}


def _joined(values):
    """';'-joined with 4 decimals, '' for a missing one; '' when all are missing."""
    if not any(v is not None for v in values):
        return ""
    return ";".join("" if v is None else "%.4f" % v for v in values)


def failed(case, error, seconds=0.0, outdir=""):
    return {"case": case, "status": "failed", "objects": "", "volume_ml": "", "dice": "", "steps": "",
            "converged": "", "seconds": "%.2f" % seconds, "error": error, "output": outdir, "seed_check": "",
            "consensus_dice": ""}


def run_case(case, args, out, cli, timeout=None):
    """One case on a worker: `ffseg segment ARGS --out OUT/CASE`; its summary row."""
    outdir = os.path.join(out, case)
    t0 = time.monotonic()
    try:
        r = subprocess.run([cli, "segment", *args, "--out", outdir, "--force", "-q"],
                           capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return failed(case, f"timed out after {timeout} s", time.monotonic() - t0)
    except OSError as ex:
        return failed(case, f"cannot run {cli}: {ex.strerror}", time.monotonic() - t0)
    dt = time.monotonic() - t0
    if r.returncode != 0:
        lines = [l for l in r.stderr.strip().splitlines() if l.strip()]
        msg = lines[-1] if lines else ""
        msg = msg[len("ffseg: error: "):] if msg.startswith("ffseg: error: ") else msg
        how = f"killed by signal {-r.returncode}" if r.returncode < 0 else f"exit {r.returncode}"
        return failed(case, f"ffseg segment {how}: {msg}" if msg else f"ffseg segment {how}", dt)
    try:
        with open(os.path.join(outdir, "report.json")) as f:
            report = json.load(f)
    except (OSError, ValueError) as ex:
        return failed(case, f"no readable report.json: {ex}", dt, outdir)
    return summary_from_report(case, "ok", report, dt, outdir)


def write_summary(out, rows):
    tmp = os.path.join(out, ".summary.csv.tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=SUMMARY)
        w.writeheader()
        for r in rows:
            w.writerow(r)
    os.replace(tmp, os.path.join(out, "summary.csv"))


def run_batch(manifest, out, workers=2, scheduler=None, force=False, cli=None, timeout=None,
              client=None, runner=run_case, progress=None):
    """Runs every case; returns the summary rows (in manifest order) and
    writes DIR/summary.csv after every finished case."""
    from distributed import Client, LocalCluster, as_completed

    cases = read_manifest(manifest)
    cli = find_cli(cli)
    out = os.path.abspath(out)
    os.makedirs(out, exist_ok=True)
    say = progress or (lambda s: None)
    rows = {}
    todo = []
    for case, row, args, error in cases:
        rep = os.path.join(out, case, "report.json")
        if error:
            rows[case] = failed(case, error)
        elif not force and os.path.exists(rep):
            try:
                with open(rep) as f:
                    rows[case] = summary_from_report(case, "skipped", json.load(f), 0.0, os.path.join(out, case))
            except (OSError, ValueError):
                todo.append((case, args))
        else:
            todo.append((case, args))
    order = [c[0] for c in cases]
    current = lambda: [rows[c] for c in order if c in rows]  # noqa: E731
    write_summary(out, current())
    say(f"ffseg.batch: {len(cases)} cases, {len(todo)} to run, "
        f"{sum(r['status'] == 'skipped' for r in rows.values())} already done, "
        f"{sum(r['status'] == 'failed' for r in rows.values())} refused by the manifest")
    cluster = own_client = None
    t0 = time.monotonic()
    try:
        if todo:
            if client is None:
                if scheduler:
                    client = own_client = Client(scheduler, timeout="30s")
                else:
                    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                           dashboard_address=None)
                    client = own_client = Client(cluster)
            try:
                client.wait_for_workers(1, timeout=120)
            except Exception:
                raise ManifestError(f"no worker joined the scheduler {scheduler or ''} within 120 s") from None
            # At most one case per worker thread in flight: a case waits on the
            # client, not queued on a worker, so a lost worker loses its own case only.
            futures, pending, done = {}, list(todo), 0
            ac = as_completed()

            def submit_more():
                slots = max(1, sum(client.nthreads().values()))
                while pending and len(futures) < slots:
                    case, args = pending.pop(0)
                    # pure=False and a fresh key: a rerun is a new task; retries=0.
                    fut = client.submit(runner, case, args, out, cli, timeout, pure=False, retries=0,
                                        key=f"ffseg-segment-{case}-{time.time_ns()}")
                    futures[fut] = case
                    ac.add(fut)

            submit_more()
            for fut in ac:
                case = futures.pop(fut)
                try:
                    row = fut.result()
                except Exception as ex:  # KilledWorker, a lost connection, a runner error
                    name = type(ex).__name__
                    why = "worker lost" if name in ("KilledWorker", "CommClosedError") else name
                    row = failed(case, f"{why}: {ex}")
                rows[case] = row
                done += 1
                write_summary(out, current())
                say(f"[{done}/{len(todo)}] {case}: {row['status']}"
                    + (f" ({row['error']})" if row["error"] else f", {row['seconds']} s")
                    + f"  [{time.monotonic() - t0:.1f} s]")
                submit_more()
    finally:
        if own_client is not None:
            own_client.close()
        if cluster is not None:
            cluster.close()
    result = current()
    write_summary(out, result)
    n_ok = sum(r["status"] == "ok" for r in result)
    n_skip = sum(r["status"] == "skipped" for r in result)
    n_fail = sum(r["status"] == "failed" for r in result)
    say(f"ffseg.batch: {n_ok} ok, {n_skip} skipped, {n_fail} failed in {time.monotonic() - t0:.1f} s; "
        f"summary in {os.path.join(out, 'summary.csv')}")
    return result


def main(argv=None):
    p = argparse.ArgumentParser(prog="python3 -m ffseg.batch", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__.split("\n\n", 2)[2])
    p.add_argument("manifest")
    p.add_argument("--out", required=True, help="output folder (one sub-folder per case, summary.csv)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, default=2, help="local cluster size (default 2)")
    g.add_argument("--scheduler", help="address of a running dask scheduler (tcp://host:port)")
    p.add_argument("--force", action="store_true", help="run finished cases again")
    p.add_argument("--timeout", type=float, default=None, help="seconds allowed per case")
    p.add_argument("--ffseg", help="the ffseg tool (default: FFSEG_CLI, build/ffseg, installed, PATH)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    a = p.parse_args(argv)
    if a.workers < 1:
        p.error("--workers must be >= 1")
    try:
        rows = run_batch(a.manifest, a.out, a.workers, a.scheduler, a.force, a.ffseg, a.timeout,
                         progress=None if a.quiet else (lambda s: print(s, file=sys.stderr, flush=True)))
    except ManifestError as ex:
        print(f"ffseg.batch: error: {ex}", file=sys.stderr)
        return 2
    except OSError as ex:
        print(f"ffseg.batch: error: {ex}", file=sys.stderr)
        return 2
    return 1 if any(r["status"] == "failed" for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
