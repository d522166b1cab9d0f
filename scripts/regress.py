#!/usr/bin/env python3
"""Outputs before and after a change: a fixed set of renders, bakes and traces (every method, both
devices), small enough to run in a few minutes, whose output files are hashed.

  regress.py record PENUMBRA OUT.json   run every command with the CLI PENUMBRA, store the hashes
  regress.py compare PENUMBRA OUT.json  run them again and list every file whose bytes differ
                                        (exit 1 if any does)
  regress.py list                       print the commands

Stats files are not hashed (they hold timings); the images, lightmaps, glTF files, CSV grids and
hit files are. GPU commands run on whatever context EGL gives (Mesa llvmpipe here)."""
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
SMALL = ["--width", "48", "--height", "48", "--quiet"]

# (name, arguments); {out} is the command's output folder.
COMMANDS = []
for device in ("cpu", "gpu"):
    d = ["--device", device]
    COMMANDS += [
        (f"pathtrace-{device}", ["render", "cornell", "--method", "pathtrace", "--spp", "8",
                                 "-o", "{out}/img.pfm", *d, *SMALL]),
        (f"matrix-{device}", ["render", "cornell", "--method", "matrix", "--elements", "400",
                              "-o", "{out}/img.pfm", *d, *SMALL]),
        (f"progressive-{device}", ["render", "cornell", "--method", "progressive", "--elements",
                                   "3000", "-o", "{out}/img.pfm", *d, *SMALL]),
        (f"progressive-adaptive-{device}", ["render", "cornell", "--method", "progressive",
                                            "--elements", "3000", "--adaptive", "--iterations",
                                            "40", "-o", "{out}/img.pfm", *d, *SMALL]),
        (f"stochastic-{device}", ["render", "cornell", "--method", "stochastic", "--elements",
                                  "3000", "--iterations", "60", "-o", "{out}/img.pfm", *d,
                                  *SMALL]),
        (f"sss-{device}", ["render", "sss", "--method", "sss", "--lightmap-size", "128",
                           "--no-cache", "-o", "{out}/img.pfm", *d, *SMALL]),
        (f"lpv-{device}", ["render", "lpv", "--method", "lpv", "--grid", "16", "--surface-samples",
                           "1024", "-o", "{out}/img.pfm", *d, *SMALL]),
        (f"whitted-{device}", ["render", "scenes/cornell-glass.json", "--method", "whitted",
                               "--spp", "2", "-o", "{out}/img.pfm", *d, *SMALL]),
        (f"photons-{device}", ["render", "scenes/cornell-glass.json", "--method", "photons",
                               "--spp", "1", "--photons", "20000", "--caustic-photons", "20000",
                               "--final-gather", "4", "-o", "{out}/img.pfm", *d, *SMALL]),
        (f"bake-progressive-{device}", ["bake", "cornell", "--method", "progressive",
                                        "--elements", "3000", "-o", "{out}", *d, "--quiet"]),
    ]
COMMANDS += [
    ("matrix-relight", ["render", "cornell", "--method", "matrix", "--elements", "300",
                        "--relight-frames", "2", "-o", "{out}/img.pfm", "--device", "cpu",
                        *SMALL]),
    ("matrix-lux", ["render", "scenes/room.json", "--method", "matrix", "--elements", "400",
                    "--output-quantity", "illuminance", "--work-plane", "0.8", "--grid-csv",
                    "{out}/grid.csv", "-o", "{out}/img.pfm", "--device", "cpu", *SMALL]),
    ("pathtrace-room-png", ["render", "scenes/room.json", "--spp", "4", "-o", "{out}/img.png",
                            "--device", "cpu", *SMALL]),
    ("bake-matrix", ["bake", "cornell", "--method", "matrix", "--elements", "400", "-o", "{out}",
                     "--quiet"]),
    ("bake-stochastic", ["bake", "cornell", "--method", "stochastic", "--elements", "3000",
                         "--iterations", "60", "-o", "{out}", "--quiet"]),
    ("rays-camera", ["rays", "tests/data/bunny.ply", "--kind", "camera", "--width", "64",
                     "--height", "64", "-o", "{out}/rays.bin"]),
]
for device in ("cpu", "gpu", "hybrid"):
    COMMANDS.append((f"trace-{device}", ["trace", "tests/data/bunny.ply", "--rays",
                                         "{work}/rays.bin", "-o", "{out}/hits.bin", "--device",
                                         device]))


def run_all(penumbra):
    hashes = {}
    work = tempfile.mkdtemp(prefix="penumbra-regress-")
    try:
        # The trace commands read the rays the `rays` command writes.
        subprocess.run([penumbra, "rays", "tests/data/bunny.ply", "--kind", "diffuse", "--count",
                        "20000", "-o", os.path.join(work, "rays.bin")], cwd=ROOT, check=True)
        for name, args in COMMANDS:
            out = os.path.join(work, name)
            os.makedirs(out, exist_ok=True)
            argv = [penumbra] + [a.replace("{out}", out).replace("{work}", work) for a in args]
            env = dict(os.environ, PENUMBRA_CACHE_DIR=os.path.join(work, "cache"))
            r = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
            if r.returncode != 0:
                hashes[name] = {"exit": r.returncode, "stderr": r.stderr.strip()[-300:]}
                print(f"{name}: exit {r.returncode}: {r.stderr.strip()[-300:]}", file=sys.stderr)
                continue
            files = {}
            for folder, _, names in os.walk(out):
                for f in sorted(names):
                    if f.endswith(".json") and not f.endswith(".gltf"):
                        continue
                    p = os.path.join(folder, f)
                    with open(p, "rb") as fh:
                        files[os.path.relpath(p, out)] = hashlib.sha256(fh.read()).hexdigest()
            hashes[name] = files
            print(f"{name}: {len(files)} file(s)", file=sys.stderr)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return hashes


def main(argv):
    if len(argv) == 2 and argv[1] == "list":
        for name, args in COMMANDS:
            print(name + ": penumbra " + " ".join(args))
        return 0
    if len(argv) != 4 or argv[1] not in ("record", "compare"):
        print(__doc__, file=sys.stderr)
        return 2
    mode, penumbra, path = argv[1], os.path.abspath(argv[2]), argv[3]
    hashes = run_all(penumbra)
    if mode == "record":
        with open(path, "w") as f:
            json.dump(hashes, f, indent=1, sort_keys=True)
        return 0
    with open(path) as f:
        before = json.load(f)
    differ = 0
    for name in sorted(set(before) | set(hashes)):
        a, b = before.get(name), hashes.get(name)
        if a == b:
            print(f"same      {name}")
            continue
        differ += 1
        if not isinstance(a, dict) or not isinstance(b, dict) or "exit" in a or "exit" in b:
            print(f"DIFFERENT {name}: before {a}, after {b}")
            continue
        changed = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
        print(f"DIFFERENT {name}: {', '.join(changed)}")
    print(f"{len(set(before) | set(hashes)) - differ} same, {differ} different")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
