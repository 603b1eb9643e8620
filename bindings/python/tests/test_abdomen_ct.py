"""The shared abdominal CT's liver at 1 mm (issue 29): the mesh on a
scanner-resolution grid. The 3 mm scan of ../shared/data/abdomen_ct is
resampled to 1 mm by scripts/abdomen_ct.py (37 M voxels); the liver (label 5)
grows from its protocol sphere with the CLI.

What is asserted is what the engine promises there: the automatic
resolution refines the n = 12 mesh and never ends smaller or less accurate
than it, and a fixed fine resolution either reaches what n = 12 reaches or
says it stalled (exit 6, report.json "stalled") instead of calling its jam
convergence. And issue 29's bar: Dice >= 0.85 at n = 12, 24, 33, 49 and
automatic (0.871, 0.895, 0.898, 0.897 and 0.897 measured, since the model's
floor reads the noise as the scanner acquired it: BENCHMARKS section 12)."""
import json
import os
import sys

import pytest

from conftest import ROOT, run_cli, stored_values

sys.path.insert(0, os.path.join(ROOT, "scripts"))
import abdomen_ct  # noqa: E402

pytestmark = pytest.mark.skipif(not os.path.isdir(abdomen_ct.DATA),
                                reason=f"{abdomen_ct.DATA} is absent: the shared data beside the repository")


@pytest.fixture(scope="module")
def grid_1mm(tmp_path_factory):
    return abdomen_ct.resample(3, str(tmp_path_factory.mktemp("abdomen_ct")))


def liver(grid, out, resolution):
    lab = os.path.join(grid, "labels.nii.gz")
    args = ["segment", os.path.join(grid, "ct.nii.gz"), "--sphere-from-label", f"{lab}:5", "--truth", lab,
            "--names", "liver", "--out", out, "--quiet"]
    if resolution != "auto":
        args += ["--mesh-resolution", str(resolution)]
    r = run_cli(*args, check=False)
    assert r.returncode in (0, 6), r.stderr
    rep = json.load(open(os.path.join(out, "report.json")))
    o = rep["objects"][0]
    return r, rep, o


def test_liver_at_1mm_the_automatic_resolution_refines_n12_and_a_jam_is_never_convergence(grid_1mm, tmp_path):
    r12, rep12, o12 = liver(grid_1mm, str(tmp_path / "n12"), 12)
    d12, v12 = o12["metrics"]["dice"], o12["voxels"]
    assert r12.returncode == 0 and not o12["stalled"]
    assert d12 >= 0.85  # 0.871 measured (0.697 before the floor read the acquisition's noise: BENCHMARKS 12)

    ra, repa, oa = liver(grid_1mm, str(tmp_path / "auto"), "auto")
    assert ra.returncode == 0, ra.stderr
    assert repa["config"]["mesh_resolution"] > 12
    assert repa["config"]["refined_from_first_run"] is True
    assert not oa["stalled"] and repa["stalled_objects"] == 0
    assert oa["voxels"] >= 0.98 * v12
    assert oa["metrics"]["dice"] >= d12 - 0.01  # 0.897 against 0.871 measured
    assert oa["metrics"]["dice"] >= 0.85

    for n in (24, 33, 49):
        r, rep, o = liver(grid_1mm, str(tmp_path / f"n{n}"), n)
        reached = o["voxels"] >= 0.98 * v12
        print(f"n = {n}: {o['voxels']} voxels against {v12} at n = 12, Dice {o['metrics']['dice']:.3f}, "
              f"stalled {o['stalled']}, exit {r.returncode}")
        # Short of n = 12's liver only as a stall, warned about and exit 6,
        # never as convergence.
        assert reached or (o["stalled"] and r.returncode == 6 and "stalled" in r.stderr)
        assert rep["config"]["refined_from_first_run"] is True  # from its n = 12 mesh: from the sphere it jams
        assert not rep["converged"] or reached
        assert reached and o["metrics"]["dice"] >= 0.85  # 0.895, 0.898, 0.897 measured


def organ_3mm(organ, out, *extra):
    lab = os.path.join(abdomen_ct.DATA, "labels.nii.gz")
    r = run_cli("segment", os.path.join(abdomen_ct.DATA, "ct.nii.gz"), "--sphere-from-label", f"{lab}:{organ}",
                "--truth", lab, "--out", out, "--quiet", *extra, check=False)
    assert r.returncode in (0, 6), r.stderr
    o = json.load(open(os.path.join(out, "report.json")))["objects"][0]
    return o["metrics"]["dice"], o["volume_ml"] / o["metrics"]["truth_volume_ml"]


def test_the_portal_vein_at_3mm_is_segmented_not_refused_as_no_boundary(tmp_path):
    # Its sphere (4.5 mm) sees a box whose classes binning merges into one
    # broad class (-34 +- 40 HU) that beat the vein's own (41 +- 22) at its
    # mean: the model refused its own grey level and the tool said "no vertex
    # found a boundary" (exit 5). That class now counts as the vein's own.
    d, ratio = organ_3mm(9, str(tmp_path / "portal_vein"))
    print(f"portal vein: Dice {d:.3f}, volume {ratio:.2f}x the label's")
    assert d >= 0.4  # 0.484 measured


# Issue 30's choosing set at 3 mm, alone, CLI defaults: today's figures
# (BENCHMARKS section 11) less a margin. The gallbladder's floor is what the
# model's contrast scale within Tukey's fences bought (0.06 and 21x its
# volume before: a box with 6% air made the floor 44 HU wide); the leak
# ceiling guards against its return.
CHOOSING_3MM = {5: ("liver", 0.88), 1: ("spleen", 0.85), 3: ("kidney left", 0.85), 4: ("gallbladder", 0.45),
                7: ("aorta", 0.39), 102: ("iliopsoas left", 0.65), 96: ("gluteus medius left", 0.52)}


def test_choosing_set_at_3mm_holds_its_figures_and_the_gallbladder_stays_near_its_organ(tmp_path):
    dice = {}
    for organ, (name, floor) in CHOOSING_3MM.items():
        d, ratio = organ_3mm(organ, str(tmp_path / str(organ)))
        print(f"{name}: Dice {d:.3f}, volume {ratio:.2f}x the label's")
        dice[organ] = d
        assert d >= floor, name
        if organ == 4:
            assert ratio <= 3.5  # 2.8x measured (its n = 6 run); 21.5x before
    assert sum(dice.values()) / len(dice) >= 0.67  # 0.685 measured


def test_where_auto_keeps_n12_one_organ_re_spaces_in_a_second_pass_and_past_its_reach_leaks_less(tmp_path):
    """Where the automatic resolution keeps n = 12, one grey-level organ
    re-spaces its loops in a second pass at 12 from its first-run surface,
    within the same reach as a finer run (tools/cli/refinement_reach.h). The
    3 mm left kidney stays within it and fills the part its first run jammed
    short of (0.813 -> 0.873 measured). An organ that leaves it is a leaker:
    it is made again from its sphere at n = 6, and of that run and its first
    run, kept meanwhile, the one with fewer voxels stands, voxel for voxel
    the one run --mesh-resolution 6 or 12 makes, and the tool warns (also
    with --quiet) that it may hold part of a neighbour. The gallbladder's
    n = 6 run stands (161 -> 99 ml of 35 measured); the pancreas' is larger
    (255 against 247 ml), so its first run stands."""
    nib = pytest.importorskip("nibabel")
    import numpy as np
    lab = os.path.join(abdomen_ct.DATA, "labels.nii.gz")
    runs = {3: ("auto", "12"), 4: ("auto", "12", "6"), 10: ("auto", "12", "6")}
    reps, maps, said = {}, {}, {}
    for organ, tags in runs.items():
        for tag in tags:
            out = str(tmp_path / f"{organ}_{tag}")
            extra = () if tag == "auto" else ("--mesh-resolution", tag)
            r = run_cli("segment", os.path.join(abdomen_ct.DATA, "ct.nii.gz"), "--sphere-from-label", f"{lab}:{organ}",
                        "--truth", lab, "--out", out, *extra, check=False)
            assert r.returncode in (0, 6), r.stderr
            reps[organ, tag] = json.load(open(os.path.join(out, "report.json")))
            maps[organ, tag] = np.asarray(nib.load(os.path.join(out, "labels.nii.gz")).dataobj) != 0
            said[organ, tag] = ("its first run is kept" in r.stderr, "that run stands" in r.stderr,
                                "may hold part of a neighbour" in r.stderr)
    dice = {key: rep["objects"][0]["metrics"]["dice"] for key, rep in reps.items()}
    print({f"{organ} {tag}": round(d, 3) for (organ, tag), d in dice.items()})
    for organ, tags in runs.items():
        for tag in tags[1:]:
            assert reps[organ, tag]["passes"] == 1 and "finer_run_respaced" not in reps[organ, tag]["config"]
    kidney = reps[3, "auto"]
    assert kidney["passes"] == 2 and kidney["config"]["refined_from_first_run"] is True
    assert kidney["config"]["mesh_resolution"] == 12
    assert kidney["config"]["finer_run_respaced"] is True and kidney["config"]["first_run_stands"] is False
    assert "leaker_run" not in kidney["config"]
    assert dice[3, "auto"] >= 0.85 and dice[3, "auto"] >= dice[3, "12"] + 0.03
    assert said[3, "auto"] == (False, False, False) and "leak_suspected" not in kidney["objects"][0]
    for organ, stands in ((4, "6"), (10, "12")):
        rep = reps[organ, "auto"]
        cfg = rep["config"]
        assert rep["passes"] == 3 and said[organ, "auto"] == (True, stands == "6", True)
        assert rep["objects"][0]["leak_suspected"] is True
        assert cfg["finer_run_respaced"] is False and cfg["refined_from_first_run"] is False
        left = cfg["finer_run_left_reach"]
        assert left["volume_ml"] > left["reach_ml"] > 0
        leaker = cfg["leaker_run"]
        assert leaker["mesh_resolution"] == 6 and leaker["stands"] is (stands == "6")
        assert leaker["voxels"] == int(maps[organ, "6"].sum()) and leaker["first_run_voxels"] == int(maps[organ, "12"].sum())
        assert (leaker["voxels"] < leaker["first_run_voxels"]) is (stands == "6")
        assert cfg["first_run_stands"] is (stands == "12") and cfg["mesh_resolution"] == int(stands)
        assert rep["steps"] == reps[organ, stands]["steps"] < rep["steps_all_passes"]
        assert int((maps[organ, "auto"] != maps[organ, stands]).sum()) == 0 and int(maps[organ, "auto"].sum()) > 0
    assert dice[4, "auto"] >= dice[4, "12"] + 0.1  # 0.352 -> 0.498 measured
    # The suspected leak is said with --quiet too, as a stall is.
    r = run_cli("segment", os.path.join(abdomen_ct.DATA, "ct.nii.gz"), "--sphere-from-label", f"{lab}:4",
                "--out", str(tmp_path / "4_quiet"), "--quiet", check=False)
    assert r.returncode == 0 and "warning: object 1 (object1): its grey level goes on" in r.stderr, r.stderr


def test_liver_and_vena_cava_together_at_3mm_fig_6_5_share_no_voxel(tmp_path):
    """Thesis fig. 6.5's pair on the shared CT: the liver and the vena cava
    in one engine (chapter 6). What holds today is asserted: no shared voxel,
    and the liver within 0.04 of its Dice alone by the same runs (0.820
    against 0.849 measured). Alone its finer run now re-spaces its loops
    (tools/cli/refinement_reach.h: 0.900), which the tool does for one
    object only, so the pair is held to the liver alone without it
    (--param grey_respacing=2: the liver's first run is the same, its
    boundary not in view). The thesis' claim, the liver better with the vena
    cava than without, does not hold on this non-contrast CT, where the two
    are one grey level (41 +- 16 and 46 +- 17 HU): BENCHMARKS section 11."""
    lab = os.path.join(abdomen_ct.DATA, "labels.nii.gz")
    out = str(tmp_path / "pair")
    r = run_cli("segment", os.path.join(abdomen_ct.DATA, "ct.nii.gz"), "--sphere-from-label", f"{lab}:5",
                "--sphere-from-label", f"{lab}:8", "--truth", lab, "--names", "liver,vena_cava", "--out", out,
                "--quiet", check=False)
    assert r.returncode in (0, 6), r.stderr
    rep = json.load(open(os.path.join(out, "report.json")))
    assert rep["shared_voxels"] == 0
    liver, cava = rep["objects"]
    d_alone, _ = organ_3mm(5, str(tmp_path / "alone"), "--param", "grey_respacing=2")
    print(f"together: liver {liver['metrics']['dice']:.3f} (alone {d_alone:.3f}), "
          f"vena cava {cava['metrics']['dice']:.3f}")
    assert liver["metrics"]["dice"] >= d_alone - 0.04
    assert cava["metrics"]["dice"] >= 0.35  # 0.421 measured


def test_one_organs_finer_run_re_spaces_within_its_first_runs_reach_and_is_made_again_past_it(tmp_path):
    """The finer run from the first run's surface re-spaces its loops while
    it encloses no more than the first run's volume plus its area times its
    mean quad side (tools/cli/refinement_reach.h). The 3 mm liver (n = 24)
    stays within it and enters its left lobe (0.849 -> 0.900 measured, ASSD
    4.32 -> 2.28 mm). The gallbladder at n = 24 leaves it (272 ml against
    261 at step 10): the finer run is made again without re-spacing, voxel
    for voxel the run that never re-spaces, and Python's segment() takes the
    same path."""
    nib = pytest.importorskip("nibabel")
    import numpy as np
    import ffseg
    out = str(tmp_path / "liver")
    d, _ = organ_3mm(5, out)
    rep = json.load(open(os.path.join(out, "report.json")))
    o = rep["objects"][0]
    print(f"liver: Dice {d:.3f}, ASSD {o['metrics']['assd_mm']:.2f} mm, n = {rep['config']['mesh_resolution']}")
    assert rep["config"]["refined_from_first_run"] is True and rep["config"]["finer_run_respaced"] is True
    assert "finer_run_left_reach" not in rep["config"]
    assert d >= 0.89 and o["metrics"]["assd_mm"] <= 2.6
    img = nib.load(os.path.join(abdomen_ct.DATA, "ct.nii.gz"))
    raw, slope, inter = stored_values(img)
    masks = ffseg.segment(raw, img.affine, [(o["sphere"]["center_mm"], o["sphere"]["radius_mm"])],
                          mesh_resolution=24, rescale_slope=slope, rescale_intercept=inter)
    cli = np.asarray(nib.load(os.path.join(out, "labels.nii.gz")).dataobj) != 0
    assert int(((masks[0] != 0) != cli).sum()) == 0

    lab = os.path.join(abdomen_ct.DATA, "labels.nii.gz")
    outs, said = {}, {}
    for tag, extra in (("auto", ()), ("never", ("--param", "grey_respacing=2"))):
        outs[tag] = str(tmp_path / f"gallbladder_{tag}")
        r = run_cli("segment", os.path.join(abdomen_ct.DATA, "ct.nii.gz"), "--sphere-from-label", f"{lab}:4",
                    "--mesh-resolution", "24", "--out", outs[tag], *extra, check=False)
        assert r.returncode == 0, r.stderr
        said[tag] = "grew past its first run's reach" in r.stderr
    assert said == {"auto": True, "never": False}
    rep = json.load(open(os.path.join(outs["auto"], "report.json")))
    left = rep["config"]["finer_run_left_reach"]
    print(f"gallbladder: left its reach at step {left['step']}: {left['volume_ml']:.1f} ml > {left['reach_ml']:.1f}")
    assert rep["config"]["finer_run_respaced"] is False and left["object"] == 1
    assert left["volume_ml"] > left["reach_ml"] > 0
    auto, never = (np.asarray(nib.load(os.path.join(outs[t], "labels.nii.gz")).dataobj) for t in ("auto", "never"))
    assert int((auto != never).sum()) == 0 and int(auto.sum()) > 0

    sp = rep["objects"][0]["sphere"]
    masks = ffseg.segment(raw, img.affine, [(sp["center_mm"], sp["radius_mm"])], mesh_resolution=24,
                          rescale_slope=slope, rescale_intercept=inter)
    assert int(((masks[0] != 0) != (auto != 0)).sum()) == 0


def test_a_finer_run_from_the_sphere_does_not_re_space_in_the_tool_and_python(grid_1mm, tmp_path):
    """Label 11 on the 1 mm grid (kept aside: not in either set), a 2 mm
    sphere: the first run leaks (457 ml of 5) and its mesh resampled to
    n = 49 crosses itself, so the finer run starts from the sphere. The
    reach bounds a refinement of the first run's surface, so that run does
    not re-space (re-spaced, it stalled, could not be put back, and the
    first run's 490 ml stood; Dice 0.009 against 0.317). segment() takes
    the same runs, voxel for voxel."""
    nib = pytest.importorskip("nibabel")
    import numpy as np
    import ffseg
    lab = os.path.join(grid_1mm, "labels.nii.gz")
    out = str(tmp_path / "l11")
    r = run_cli("segment", os.path.join(grid_1mm, "ct.nii.gz"), "--sphere-from-label", f"{lab}:11",
                "--truth", lab, "--out", out, "--quiet", check=False)
    assert r.returncode == 0, r.stderr
    rep = json.load(open(os.path.join(out, "report.json")))
    o = rep["objects"][0]
    print(f"label 11: Dice {o['metrics']['dice']:.3f}, {o['volume_ml']:.1f} ml, n = {rep['config']['mesh_resolution']}")
    assert o["started_from"] == "sphere" and rep["config"]["mesh_resolution"] == 49
    assert rep["config"]["finer_run_respaced"] is False and "finer_run_left_reach" not in rep["config"]
    assert o["voxels"] < o["first_run_voxels"] // 10  # 10.5 ml against the first run's 457

    img = nib.load(os.path.join(grid_1mm, "ct.nii.gz"))
    raw, slope, inter = stored_values(img)
    masks = ffseg.segment(raw, img.affine, [(o["sphere"]["center_mm"], o["sphere"]["radius_mm"])],
                          mesh_resolution=49, rescale_slope=slope, rescale_intercept=inter)
    cli = np.asarray(nib.load(os.path.join(out, "labels.nii.gz")).dataobj) != 0
    assert int(((masks[0] != 0) != cli).sum()) == 0


def together(tmp_path, name, ids):
    """ids on the 3 mm CT in one engine (CLI defaults): report.json and each
    object's Dice."""
    lab = os.path.join(abdomen_ct.DATA, "labels.nii.gz")
    args = ["segment", os.path.join(abdomen_ct.DATA, "ct.nii.gz"), "--truth", lab, "--out", str(tmp_path / name),
            "--quiet"]
    for i in ids:
        args += ["--sphere-from-label", f"{lab}:{i}"]
    r = run_cli(*args, check=False)
    assert r.returncode in (0, 6), r.stderr
    rep = json.load(open(os.path.join(str(tmp_path / name), "report.json")))
    assert rep["shared_voxels"] == 0
    dice = [o["metrics"]["dice"] for o in rep["objects"]]
    print(f"{name} together:", " ".join(f"{i}:{d:.3f}" for i, d in zip(ids, dice)), f"mean {sum(dice) / len(dice):.3f}")
    return rep, dice


def placed_larger_first(rep):
    """What report.json says of a finer run: each object started from its
    first-run mesh, or from its sphere where the engine refused that mesh
    beside a larger neighbour's (the larger organs, by first-run volume, are
    placed first), so the largest always keeps its first-run mesh."""
    objs = rep["objects"]
    assert rep["passes"] == 2
    for o in objs:
        assert o["started_from"] in ("first run", "sphere")
        assert "fell_short_at_finer_run" not in o
    largest = max(objs, key=lambda o: o["first_run_voxels"])
    assert largest["started_from"] == "first run"
    return sum(o["started_from"] == "first run" for o in objs)


def test_nine_organs_together_refine_their_first_run(tmp_path):
    """Coarse to fine with several objects: the finer run starts from the
    first run's meshes, the larger organs placed first, the vena cava's
    (which crosses the gallbladder's once resampled) scaled by 0.99. 0.617
    from the protocol spheres (0.641 when the finer run grew from the
    spheres first, 0.604 with the vena cava from its sphere); over seven
    placements of every sphere 0.620 against 0.614 and 0.615 (BENCHMARKS
    section 12), at 3.5 s of stepping in all against 6.8."""
    rep, dice = together(tmp_path, "nine", (5, 1, 3, 4, 7, 2, 6, 8, 10))
    assert rep["config"]["refined_from_first_run"] is True
    assert placed_larger_first(rep) == len(dice)
    assert sum(dice) / len(dice) >= 0.60  # 0.617 measured
    assert dice[0] >= 0.79                # the liver: 0.807
    assert dice[7] >= 0.55                # the vena cava: 0.614 (0.527 from its sphere)


def test_sixteen_organs_together_place_the_larger_organs_first(tmp_path):
    """All 16 organs of both sets in one engine (issue 30's "together"): the
    finer run places the larger organs' first-run meshes first. 0.633 from
    the protocol spheres (0.640 against 0.637 over seven placements with the
    finer run from the spheres first; BENCHMARKS section 12), every organ's
    Dice alone 0.623 on average."""
    ids = (5, 1, 3, 4, 7, 102, 96, 2, 6, 8, 10, 104, 103, 97, 100, 101)
    rep, dice = together(tmp_path, "sixteen", ids)
    assert rep["config"]["refined_from_first_run"] is True
    placed_larger_first(rep)
    assert sum(dice) / len(dice) >= 0.62  # 0.633 measured
    assert dice[0] >= 0.80                # the liver: 0.810
    assert dice[3] >= 0.30                # the gallbladder: 0.337 (alone 0.352)


def test_an_organ_that_outgrows_the_memory_budget_is_segmented_with_more_not_refused(tmp_path):
    """--memory is where the workspace starts, not a cap (issue 30's budget):
    16 organs of the 1 mm CT outgrow the default 400 MB (a liver crop of 4.2 M
    voxels against 3.4 M) and ended with exit 4 after a minute's work. Here
    the same path on the 3 mm pair: 5 MB holds neither organ's crop nor region,
    so the run starts again with the budget doubled until the organs fit, says
    so, and gives the default run's result voxel for voxel. Sizes given on the
    command line stay fixed: an organ that outgrows them ends the run (exit 4)."""
    lab = os.path.join(abdomen_ct.DATA, "labels.nii.gz")
    base = ["segment", os.path.join(abdomen_ct.DATA, "ct.nii.gz"), "--sphere-from-label", f"{lab}:5",
            "--sphere-from-label", f"{lab}:8", "--truth", lab, "--quiet"]
    r0 = run_cli(*base, "--out", str(tmp_path / "default"), check=False)
    r5 = run_cli(*base, "--memory", "5", "--out", str(tmp_path / "small"), check=False)
    assert r0.returncode in (0, 6) and r5.returncode == r0.returncode, r5.stderr
    assert "outgrew the memory budget" in r5.stderr
    rep0 = json.load(open(tmp_path / "default" / "report.json"))
    rep5 = json.load(open(tmp_path / "small" / "report.json"))
    assert rep0["config"]["memory_budget_raised"] == 0
    assert rep5["config"]["memory_budget_raised"] >= 1
    assert rep5["config"]["memory_budget_bytes"] > 5_000_000
    for a, b in zip(rep0["objects"], rep5["objects"]):
        assert a["voxels"] == b["voxels"] and a["metrics"]["dice"] == b["metrics"]["dice"]
    rf = run_cli(*base, "--max-roi-voxels", "20000", "--out", str(tmp_path / "fixed"), check=False)
    assert rf.returncode == 4, rf.stderr
    assert "max_roi_voxels" in rf.stderr and not (tmp_path / "fixed" / "report.json").exists()


def test_python_segment_starts_again_with_more_memory_as_the_tool_does():
    nib = pytest.importorskip("nibabel")
    import numpy as np
    import ffseg
    img = nib.load(os.path.join(abdomen_ct.DATA, "ct.nii.gz"))
    ct = np.asarray(img.dataobj).astype(np.int16)
    sphere = ((65.04, 209.32, 361.30), 7.5)  # the gallbladder's protocol sphere
    ref = ffseg.segment(ct, img.affine, [sphere], mesh_resolution=12)
    with pytest.warns(RuntimeWarning, match="outgrew the memory budget"):
        small = ffseg.segment(ct, img.affine, [sphere], mesh_resolution=12, memory_bytes=2_000_000)
    assert np.array_equal(ref[0], small[0]) and ref[0].sum() > 0
    with pytest.raises(ffseg.Error) as ex:
        ffseg.segment(ct, img.affine, [sphere], mesh_resolution=12, max_roi_voxels=2000)
    assert ex.value.name == "ROI_TOO_LARGE"


def test_python_segment_places_a_refused_first_run_mesh_scaled_as_the_tool_does(tmp_path):
    """The nine organs at n = 22: resampled from n = 12, the vena cava's
    first-run mesh crosses the gallbladder's by a fraction of a voxel, and
    both the tool and segment() place it scaled by 0.99 about its centroid
    (report.json: first_run_scale) instead of from its sphere. segment()
    must give the tool's label map voxel for voxel, so its scaling is the
    tool's to the bit."""
    nib = pytest.importorskip("nibabel")
    import numpy as np
    import ffseg
    ids = (5, 1, 3, 4, 7, 2, 6, 8, 10)
    lab = os.path.join(abdomen_ct.DATA, "labels.nii.gz")
    out = str(tmp_path / "nine22")
    args = ["segment", os.path.join(abdomen_ct.DATA, "ct.nii.gz"), "--mesh-resolution", "22", "--out", out, "--quiet"]
    for i in ids:
        args += ["--sphere-from-label", f"{lab}:{i}"]
    r = run_cli(*args, check=False)
    assert r.returncode in (0, 6), r.stderr
    rep = json.load(open(os.path.join(out, "report.json")))
    scales = [o.get("first_run_scale") for o in rep["objects"]]
    assert all(o["started_from"] == "first run" for o in rep["objects"])
    assert any(s is not None and s < 1 for s in scales), scales  # the vena cava: 0.99

    img = nib.load(os.path.join(abdomen_ct.DATA, "ct.nii.gz"))
    raw, slope, inter = stored_values(img)
    spheres = [(o["sphere"]["center_mm"], o["sphere"]["radius_mm"]) for o in rep["objects"]]
    masks = ffseg.segment(raw, img.affine, spheres, mesh_resolution=22, rescale_slope=slope, rescale_intercept=inter)
    cli = np.asarray(nib.load(os.path.join(out, "labels.nii.gz")).dataobj)
    mine = np.zeros(cli.shape, cli.dtype)
    for label, m in reversed(list(zip(ids, masks))):  # a voxel inside two meshes: the first object's
        mine[m != 0] = label
    assert int((mine != cli).sum()) == 0


def test_a_finer_run_from_the_first_runs_surface_is_the_same_in_the_tool_and_python(grid_1mm, tmp_path):
    """The stomach (6) on the 1 mm grid at n = 22: a first run at n = 12,
    then n = 22 from its surface (re-spaced, past its first run's reach, so
    made again without), ending larger than the first run (a finer
    mesh never loses to it). segment() makes the same runs, voxel for voxel.
    (This stomach used to show a finer run that stalls and is put back on
    its first-run surface; since the partial-volume level is sought in the
    scan's acquired samples, BENCHMARKS section 12, no organ of this grid
    at n = 22-40, nor of the 3 mm scan at 16-40, reaches that path. The
    next one, a finer run given up, is the test below.)"""
    nib = pytest.importorskip("nibabel")
    import numpy as np
    import ffseg
    lab = os.path.join(grid_1mm, "labels.nii.gz")
    out = str(tmp_path / "s6")
    r = run_cli("segment", os.path.join(grid_1mm, "ct.nii.gz"), "--sphere-from-label", f"{lab}:6",
                "--mesh-resolution", "22", "--out", out, "--quiet", check=False)
    assert r.returncode == 0, r.stderr
    rep = json.load(open(os.path.join(out, "report.json")))
    o = rep["objects"][0]
    assert rep["config"]["finer_run_given_up"] is False and rep["config"]["refined_from_first_run"] is True
    # Its finer run re-spaced left its first run's reach (refinement_reach.h)
    # and was made again without: three passes.
    assert rep["config"]["mesh_resolution"] == 22 and rep["passes"] == 3
    assert rep["config"]["finer_run_respaced"] is False and rep["config"]["finer_run_left_reach"]["object"] == 1
    assert not o["stalled"] and not o["kept_first_run_surface"]
    assert o["voxels"] >= o["first_run_voxels"]

    img = nib.load(os.path.join(grid_1mm, "ct.nii.gz"))
    raw, slope, inter = stored_values(img)
    sphere = (o["sphere"]["center_mm"], o["sphere"]["radius_mm"])
    masks = ffseg.segment(raw, img.affine, [sphere], mesh_resolution=22, rescale_slope=slope,
                          rescale_intercept=inter)
    cli = np.asarray(nib.load(os.path.join(out, "labels.nii.gz")).dataobj) != 0
    assert int(((masks[0] != 0) != cli).sum()) == 0


def test_a_finer_run_that_stalls_and_cannot_be_put_back_is_given_up_in_the_tool_and_python(tmp_path):
    """The right kidney (2) on the scan with its slices alone resampled to
    1 mm (3 x 3 x 1 mm, `abdomen_ct.py --spacing 3x3x1`), from its protocol
    sphere moved by half its radius along +z (`--jitter`'s fifth sphere,
    the one that shows it): the first run rests at n = 12; at n = 49 it
    stalls, and its n = 12 surface resampled to 49 crosses itself, so it
    cannot be put back. The finer run is given up, said even with --quiet,
    and the first run goes on at 12 from its mesh: the object ends no
    smaller than its first run. segment() takes the same path, with a
    RuntimeWarning, voxel for voxel."""
    nib = pytest.importorskip("nibabel")
    import warnings
    import numpy as np
    import ffseg
    grid = abdomen_ct.resample(abdomen_ct.axis_factors("3x3x1"), str(tmp_path / "grid"))
    ct, lab = os.path.join(grid, "ct.nii.gz"), os.path.join(grid, "labels.nii.gz")
    probe = str(tmp_path / "probe")  # the protocol sphere, from one step
    run_cli("segment", ct, "--sphere-from-label", f"{lab}:2", "--mesh-resolution", "12", "--max-steps", "1",
            "--out", probe, "--quiet")
    sp = json.load(open(os.path.join(probe, "report.json")))["objects"][0]["sphere"]
    x, y, z, radius = abdomen_ct.moved_sphere(list(sp["center_mm"]) + [sp["radius_mm"]], 4)

    out = str(tmp_path / "k2")
    r = run_cli("segment", ct, "--sphere", f"{x!r},{y!r},{z!r},{radius!r}", "--mesh-resolution", "49",
                "--out", out, "--quiet", check=False)
    assert r.returncode == 0, r.stderr
    assert "stalled at mesh resolution 49 and cannot be put back" in r.stderr
    assert "the first run goes on at resolution 12" in r.stderr
    rep = json.load(open(os.path.join(out, "report.json")))
    o = rep["objects"][0]
    assert rep["config"]["finer_run_given_up"] is True and rep["config"]["refined_from_first_run"] is False
    assert rep["config"]["mesh_resolution"] == 12 and rep["passes"] == 3
    assert o["kept_first_run_surface"] and not o["stalled"]
    assert o["voxels"] >= o["first_run_voxels"]  # 36,789 against 35,452 measured

    img = nib.load(ct)
    raw, slope, inter = stored_values(img)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        masks = ffseg.segment(raw, img.affine, [((x, y, z), radius)], mesh_resolution=49, rescale_slope=slope,
                              rescale_intercept=inter)
    assert any(issubclass(w.category, RuntimeWarning) and "cannot be put back" in str(w.message) for w in caught)
    cli = np.asarray(nib.load(os.path.join(out, "labels.nii.gz")).dataobj) != 0
    assert int(((masks[0] != 0) != cli).sum()) == 0
