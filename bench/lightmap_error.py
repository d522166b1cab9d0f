#!/usr/bin/env python3
"""Time to a given lightmap error, per bake method, against a tight path-traced reference.

Every method bakes the same atlas (`--texel-density D`) over a sweep of its accuracy setting;
each lightmap is compared texel by texel with the reference (`bake --method pathtrace` at
`--ref-tolerance`, default 0.005): the luminance's RMS difference over the covered texels over
their mean. Prints, per method, every run (seconds as the bake's stats give them, excluding
loading and writing, and its RMS) and the first time it reaches 5%, 2% and 1%.

    bench/lightmap_error.py build/bin/penumbra OUT --scene cornell --density 20
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))

SWEEPS = {
    "pathtrace": ("--tolerance", ["0.2", "0.1", "0.05", "0.02", "0.01"]),
    "progressive": ("--tolerance", ["0.1", "0.03", "0.01", "0.003", "0.001", "0.0001"]),
    "stochastic": ("--iterations", ["10", "50", "200", "1000", "5000"]),
    "matrix": ("--elements", ["200", "1000", "5000", "20000"]),
}


def read_exr(path, build):
    sys.path.insert(0, os.path.join(build, "python"))
    import penumbra  # the module from the build tree reads EXR as the CLI does
    return np.asarray(penumbra.read_image(path), dtype=np.float64)


def luminance(a):
    return 0.2126 * a[..., 0] + 0.7152 * a[..., 1] + 0.0722 * a[..., 2]


def bake(cli, scene, method, density, extra, out):
    stats = out + ".json"
    args = [cli, "bake", scene, "--method", method, "--texel-density", str(density), "--quiet",
            "-o", out, "--stats", stats] + extra
    subprocess.run(args, check=True)
    with open(stats) as f:
        s = json.load(f)
    name = os.path.basename(scene) if os.path.exists(scene) else scene
    stem = os.path.splitext(name)[0]
    return os.path.join(out, stem + "_lightmap.exr"), s["seconds"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cli")
    ap.add_argument("out")
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--density", type=float, default=20.0)
    ap.add_argument("--ref-tolerance", default="0.005")
    ap.add_argument("--methods", default="pathtrace,progressive,stochastic,matrix")
    a = ap.parse_args()
    build = os.path.dirname(os.path.dirname(os.path.abspath(a.cli)))
    os.makedirs(a.out, exist_ok=True)
    ref_path, ref_seconds = bake(a.cli, a.scene, "pathtrace", a.density,
                                 ["--tolerance", a.ref_tolerance, "--texel-samples", "262144",
                                  "--seed", "7"], os.path.join(a.out, "reference"))
    ref = luminance(read_exr(ref_path, build))
    print("reference: pathtrace --tolerance %s, %.1f s" % (a.ref_tolerance, ref_seconds))
    for method in a.methods.split(","):
        option, values = SWEEPS[method]
        reached = {}
        for v in values:
            path, seconds = bake(a.cli, a.scene, method, a.density, [option, v],
                                 os.path.join(a.out, "%s-%s" % (method, v)))
            got = luminance(read_exr(path, build))
            mask = (ref > 0) | (got > 0)
            rms = float(np.sqrt(np.mean((got[mask] - ref[mask]) ** 2)) / ref[mask].mean())
            mean = float(got[mask].mean() / ref[mask].mean())
            print("  %-11s %s %-7s %7.2f s  mean %.4f  RMS %5.2f%%" % (method, option, v, seconds,
                                                                     mean, 100 * rms))
            for goal in (0.05, 0.02, 0.01):
                if rms <= goal and goal not in reached:
                    reached[goal] = seconds
        print("  %s reaches 5%% / 2%% / 1%% RMS in: %s" % (method, " / ".join(
            "%.2f s" % reached[g] if g in reached else "not reached" for g in (0.05, 0.02, 0.01))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
