#!/usr/bin/env python3
"""Time to a given lightmap error, per bake method, against a tight path-traced reference.

Every method bakes the same atlas (`--texel-density D`) over a sweep of its accuracy setting;
each lightmap is compared texel by texel with the reference (`bake --method pathtrace` at
`--ref-tolerance`, default 0.005, averaged over `--ref-seeds` bakes): the luminance's RMS
difference over the texels that carry surface, each weighted by its share of surface
(bench/lightmap_texels.py: gutters and the holes of cut-outs weigh nothing), over their mean. Prints, per method, every run (seconds as the bake's stats give them, excluding
loading and writing, and its RMS) and the first time it reaches 5%, 2% and 1%.

    bench/lightmap_error.py build/bin/penumbra OUT --scene cornell --density 20
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

import lightmap_texels

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
    # Density 0: the bake's own default for the scene.
    args = [cli, "bake", scene, "--method", method, "--quiet", "-o", out, "--stats", stats]
    args += (["--texel-density", str(density)] if density > 0 else []) + extra
    subprocess.run(args, check=True)
    with open(stats) as f:
        s = json.load(f)
    name = os.path.basename(scene) if os.path.exists(scene) else scene
    stem = os.path.splitext(name)[0]
    return os.path.join(out, stem + "_lightmap.exr"), s["seconds"], s["atlas"]["texel_density"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cli")
    ap.add_argument("out")
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--density", type=float, default=20.0,
                    help="lightmap texels per metre (0: the bake's default for the scene)")
    ap.add_argument("--ref-tolerance", default="0.005")
    ap.add_argument("--ref-seeds", type=int, default=1,
                    help="reference bakes with seeds 7, 8, ... averaged")
    ap.add_argument("--ref-samples", default="262144", help="the reference's --texel-samples")
    ap.add_argument("--methods", default="pathtrace,progressive,stochastic,matrix")
    a = ap.parse_args()
    build = os.path.dirname(os.path.dirname(os.path.abspath(a.cli)))
    os.makedirs(a.out, exist_ok=True)
    refs, ref_seconds = [], 0.0
    for k in range(a.ref_seeds):
        ref_path, seconds, density = bake(a.cli, a.scene, "pathtrace", a.density,
                                 ["--tolerance", a.ref_tolerance, "--texel-samples", a.ref_samples,
                                  "--seed", str(7 + k)], os.path.join(a.out, "reference%d" % k))
        refs.append(luminance(read_exr(ref_path, build)))
        ref_seconds += seconds
    ref = sum(refs) / len(refs)
    # Every bake on the reference's atlas (with density 0 the scene's default, which matrix
    # radiosity would raise with --elements).
    a.density = density
    gltf = os.path.splitext(ref_path)[0][:-len("_lightmap")] + ".gltf"
    weights = lightmap_texels.texel_weights(gltf, ref.shape[1], ref.shape[0])
    print("reference: pathtrace --tolerance %s, %d seed(s), %.1f s; %.0f texels of surface" %
          (a.ref_tolerance, a.ref_seeds, ref_seconds, weights.sum()))
    if len(refs) > 1:
        rms, _ = lightmap_texels.rms_over_surface(refs[0], refs[1], weights)
        print("  two reference seeds differ by %.2f%% RMS (the average's own noise is about "
              "%.2f%%)" % (100 * rms, 100 * rms / np.sqrt(2 * len(refs))))
    for method in a.methods.split(","):
        option, values = SWEEPS[method]
        reached = {}
        for v in values:
            path, seconds, _ = bake(a.cli, a.scene, method, a.density, [option, v],
                                 os.path.join(a.out, "%s-%s" % (method, v)))
            got = luminance(read_exr(path, build))
            rms, mean = lightmap_texels.rms_over_surface(got, ref, weights)
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
