#!/usr/bin/python3
"""Tubes and horns (issue 29): does the mesh travel along an elongated organ?

Two phantoms with a known answer, each grey-level (object 100, background 0,
Gaussian noise of sigma 10, a tenth of the contrast; intensity targets) and
binary (the mask itself; binary targets):
  tube  a quarter torus 8 mm across and 150 mm long along its axis (major
        radius 150 / (pi/2) = 95.5 mm), rounded ends;
  horn  a C: half a torus 8 mm across around a 25 mm major radius (a horn that
        bends back, like a lateral ventricle's), 79 mm along its axis.
Voxels of 1 mm and 0.5 mm. One sphere 6 mm across is placed on the axis at
the start of the arc, and the engine steps (Python binding, defaults, mesh
resolution --n) until it rests or --max-steps. Per step the reach: how far
along the arc the farthest vertex lies, as a share of the arc's length; at the
end the Dice of the rasterised mesh against the phantom and the outcome
(converged, stalled, or stopped at --max-steps). No flip and no crossing is
checked by the tests, not here.

usage: scripts/tube_phantom.py [--spacing 1,0.5] [--shapes tube,horn] [--n 12]
                               [--max-steps 200] [--param NAME=VALUE ...] [--every 10]
Needs /usr/bin/python3 with numpy; the library from build/ (FFSEG_LIBRARY to
override).
"""
import argparse
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "bindings", "python"))
import ffseg  # noqa: E402

TUBE_RADIUS = 4.0
SHAPES = {
    # name: (major radius mm, arc in radians)
    "tube": (150.0 / (math.pi / 2), math.pi / 2),
    "horn": (25.0, math.pi),
}


def phantom(shape, h, binary, seed=1):
    """(volume, truth mask, affine, major radius, arc): the torus arc from
    angle 0 to `arc` in the z = 0 plane around the origin, with hemispherical
    ends."""
    R, arc = SHAPES[shape]
    r, pad = TUBE_RADIUS, 8.0
    lo = np.array([-(R + r + pad), -(R + r + pad), -(r + pad)])
    hi = np.array([R + r + pad, R + r + pad, r + pad])
    if arc <= math.pi / 2:
        lo[0] = lo[1] = -pad
    elif arc <= math.pi:
        lo[1] = -pad
    n = np.ceil((hi - lo) / h).astype(int) + 1
    ax = [lo[a] + h * np.arange(n[a]) for a in range(3)]
    X, Y, Z = np.meshgrid(*ax, indexing="ij")
    ang = np.arctan2(Y, X)
    ang = np.where(ang < -1e-9, ang + 2 * math.pi, ang)
    inside = (np.hypot(np.hypot(X, Y) - R, Z) <= r) & (ang <= arc)
    for a in (0.0, arc):
        c = (R * math.cos(a), R * math.sin(a), 0.0)
        inside |= (X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2 <= r * r
    if binary:
        vol = inside.astype(np.uint8)
    else:
        rng = np.random.default_rng(seed)
        vol = (np.where(inside, 100.0, 0.0) + rng.normal(0.0, 10.0, inside.shape)).astype(np.float32)
    affine = np.diag([h, h, h, 1.0])
    affine[:3, 3] = lo
    return vol, inside, affine, R, arc


def arc_reach(xyz, R, arc):
    """The farthest vertex along the arc, as a share of its length."""
    ang = np.arctan2(xyz[:, 1], xyz[:, 0])
    ang = np.where(ang < -0.25 * math.pi, ang + 2 * math.pi, ang)
    return max(0.0, float(ang.max())) / arc


def run(shape, h, binary, args):
    vol, truth, affine, R, arc = phantom(shape, h, binary)
    e = ffseg.Engine(max_objects=1, mesh_resolution=args.n)
    e.set_volume(vol, affine)
    params = {"target_mode": "binary" if binary else "intensity"}
    for kv in args.param:
        k, v = kv.split("=", 1)
        params[k] = float(v)
    e.set_params(**params)
    e.init_sphere(0, (R, 0.0, 0.0), 3.0)
    trace, t0, outcome = [], time.perf_counter(), "max steps"
    for s in range(1, args.max_steps + 1):
        done = e.step()
        xyz, _ = e.extract_mesh(0)
        trace.append(arc_reach(xyz, R, arc))
        if done:
            flags = e.last_step_info.object_flags[0]
            outcome = "stalled" if flags & ffseg.OBJECT_STALLED else (
                "converged" if e.last_status == ffseg.CONVERGED else "degenerate")
            break
    seconds = time.perf_counter() - t0
    mask = e.rasterize(0) > 0
    dice = 2.0 * float((mask & truth).sum()) / float(mask.sum() + truth.sum())
    e.close()
    return trace, dice, outcome, seconds, float(truth.sum()) * h ** 3 / 1000.0, float(mask.sum()) * h ** 3 / 1000.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spacing", default="1,0.5")
    ap.add_argument("--shapes", default="tube,horn")
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--max-steps", type=int, default=200)
    ap.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--every", type=int, default=10, help="print the reach every this many steps")
    args = ap.parse_args()
    print("| phantom | voxel mm | targets | steps | outcome | reach | Dice | ml / truth ml | stepping s |")
    print("|---|---|---|---|---|---|---|---|---|")
    traces = []
    for shape in args.shapes.split(","):
        for h in (float(x) for x in args.spacing.split(",")):
            for binary in (False, True):
                trace, dice, outcome, secs, tml, ml = run(shape, h, binary, args)
                kind = "binary" if binary else "grey, noise 10%"
                print(f"| {shape} | {h:g} | {kind} | {len(trace)} | {outcome} | {100 * trace[-1]:.0f}% | "
                      f"{dice:.3f} | {ml:.2f} / {tml:.2f} | {secs:.2f} |", flush=True)
                traces.append((f"{shape} {h:g} mm {kind}", trace))
    print("\nreach per step (share of the arc):")
    for name, trace in traces:
        pts = [f"{i}: {100 * trace[i - 1]:.0f}%" for i in range(1, len(trace) + 1)
               if i == 1 or i % args.every == 0 or i == len(trace)]
        print(f"  {name}: " + ", ".join(pts))


if __name__ == "__main__":
    main()
