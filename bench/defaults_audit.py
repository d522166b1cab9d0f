#!/usr/bin/env python3
"""Every method at its defaults against the path tracer (docs/performance.md, "Every method at its
defaults"): the Cornell box at 64 x 64 and scenes/room.json at 64 x 48, each method run with no
option but the image size, compared with a 4,096-spp path-traced reference by the mean luminance
and the relative error of the mean over each block of a 4 x 4 grid. The bar: the mean within 2%,
every block within 5%.

  defaults_audit.py PENUMBRA [OUT_DIR] [--seeds N] [--scenes NAME,...] [--methods NAME,...]
                    [--device cpu|gpu] [--scene NAME=PATH:WxH ...] [--light ARGS]
                    [--surfaces-only] [--reference-spp N]

--scene adds a scene file of one's own (a downloaded model, a scene file placing one) and
--light gives every run, the reference's included, the same lighting options ("--sky
overcast"). --surfaces-only compares the pixels both images draw (not black in either): the
radiosity views show the sky through openings as black, the path tracer shows the sky.

prints one row per method and scene (seconds from --stats, mean ratio, block RMS, worst block);
--seeds N repeats each method with --seed 0 .. N-1 and reports the worst of them. Needs numpy.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
SCENES = [("cornell", "cornell", 64, 64), ("room", os.path.join(ROOT, "scenes", "room.json"), 64, 48),
          ("textured", os.path.join(ROOT, "scenes", "textured_room", "room.glb"), 96, 64)]
METHODS = ["pathtrace", "whitted", "photons", "matrix", "progressive", "stochastic"]
REFERENCE_SPP = 4096


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    channels = 3 if kind == b"PF" else 1
    image = data[: width * height * channels].astype(np.float64).reshape(height, width, channels)
    return np.repeat(image, 3, axis=2) if channels == 1 else image


def luminance(image):
    return image @ np.array([0.2126, 0.7152, 0.0722])


def compare(path, reference, surfaces_only=False):
    a, r = luminance(read_pfm(path)), luminance(read_pfm(reference))
    if surfaces_only:
        drawn = (a > 0) & (r > 0)
        a, r = np.where(drawn, a, 0.0), np.where(drawn, r, 0.0)
    h, w = a.shape
    ys = np.linspace(0, h, 5).round().astype(int)
    xs = np.linspace(0, w, 5).round().astype(int)
    errors = np.array([a[ys[i]:ys[i + 1], xs[j]:xs[j + 1]].mean() /
                       r[ys[i]:ys[i + 1], xs[j]:xs[j + 1]].mean() - 1.0
                       for i in range(4) for j in range(4)])
    worst = errors[np.argmax(np.abs(errors))]
    return a.mean() / r.mean(), float(np.sqrt((errors ** 2).mean())), float(worst)


def render(penumbra, scene, width, height, out, args):
    stats = out + ".json"
    subprocess.run([penumbra, "render", scene, "--width", str(width), "--height", str(height),
                    "--quiet", "-o", out, "--stats", stats, *args], check=True)
    with open(stats) as f:
        return json.load(f).get("seconds", float("nan"))


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("penumbra")
    parser.add_argument("out_dir", nargs="?")
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument("--scenes", default=",".join(s[0] for s in SCENES))
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--device", default="", help="--device for the methods (not the reference)")
    parser.add_argument("--scene", action="append", default=[], help="NAME=PATH:WxH, repeatable")
    parser.add_argument("--light", default="", help="lighting options for every run")
    parser.add_argument("--surfaces-only", action="store_true")
    parser.add_argument("--reference-spp", type=int, default=REFERENCE_SPP)
    args = parser.parse_args(argv[1:])
    scenes = [s for s in SCENES if s[0] in args.scenes.split(",")] if not args.scene else []
    for given in args.scene:
        name, rest = given.split("=", 1)
        path, size = rest.rsplit(":", 1)
        width, height = map(int, size.split("x"))
        scenes.append((name, path, width, height))
    light = args.light.split()
    methods = [m for m in METHODS if m in args.methods.split(",")]
    penumbra, seeds = args.penumbra, args.seeds
    out_dir = args.out_dir or tempfile.mkdtemp(prefix="penumbra-audit-")
    os.makedirs(out_dir, exist_ok=True)
    print("| method | scene | seconds | mean / reference | 4 x 4 blocks: RMS | worst block | "
          "meets 2% / 5% |")
    print("|---|---|---|---|---|---|---|")
    for name, scene, width, height in scenes:
        reference = os.path.join(out_dir, f"ref_{name}.pfm")
        if not os.path.exists(reference):
            render(penumbra, scene, width, height, reference,
                   ["--spp", str(args.reference_spp)] + light)
        for method in methods:
            rows = []
            for seed in range(seeds):
                tag = f"_{args.device}" if args.device else ""
                out = os.path.join(out_dir, f"{method}{tag}_{name}_{seed}.pfm")
                extra = ["--device", args.device] if args.device else []
                seconds = render(penumbra, scene, width, height, out,
                                 ["--method", method, "--seed", str(seed)] + extra + light)
                rows.append((seconds, *compare(out, reference, args.surfaces_only)))
            # The worst seed: the largest worst block, then the mean furthest from 1.
            seconds, mean, rms, worst = max(rows, key=lambda r: (abs(r[3]), abs(r[1] - 1.0)))
            meets = abs(mean - 1.0) <= 0.02 and abs(worst) <= 0.05
            print(f"| {method} | {name} | {seconds:.2f} | {mean:.4f} | {100 * rms:.2f}% | "
                  f"{100 * worst:+.2f}% | {'yes' if meets else 'no'} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
