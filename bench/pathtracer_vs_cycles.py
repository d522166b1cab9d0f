#!/usr/bin/python3
"""The reference path tracer against Blender's Cycles at equal error (design doc sec. 7).

For each scene, both renderers render it at a ladder of sample counts (same size, two threads,
box pixel filter) and once at 4096 samples per pixel as their own converged reference. The
error of an image is its relative RMS error per pixel against the reference:
sqrt(mean((x - ref)^2)) / mean(ref) over all pixels and channels. The time to reach 3% and 1%
is interpolated in log-log between the ladder's points (time, error), or extrapolated from its
last point at the Monte Carlo rate, error ~ time^(-1/2), where the ladder stops short (marked).
The ratio is Cycles' time over Penumbra's (above 1: Penumbra faster).

Time is measured two ways, the same way for both renderers:
  process  from starting the program to the image written: Blender's start-up, its building
           of the scene, Cycles' scene sync and BVH build, the render and the EXR write;
           Penumbra's start-up, scene load, BVH build, render and PFM write.
  render   the path tracing alone: Cycles from its first sample to "Finished" (its own log's
           clock, 10 ms resolution), Penumbra its `seconds` statistic.
Writes a Markdown table per way to stdout, the measurements as JSON and a plot of error against
render time per scene (docs/images/pathtracer_vs_cycles.png).

Needs Debian's `blender` (Cycles 3.4) and python3-matplotlib; neither is a dependency of the
build or the tests.

  bench/pathtracer_vs_cycles.py [--scenes cornell,room] [--size 256] [--ladder 16,32,...]
      [--reference-spp 4096] [--out bench-out/pathtracer-vs-cycles] [--plot FILE]
  bench/pathtracer_vs_cycles.py --calibrate    (Cycles' point light against the closed form)
"""

import argparse
import json
import os
import re
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENES = {"cornell": "scenes/cornell.json", "room": "scenes/room.json"}
REFERENCE_SEED = 1000003  # the ladder renders with seed 0


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), "<f4" if scale < 0 else ">f4")
    channels = 3 if kind == b"PF" else 1
    return data.reshape(h, w, channels)[::-1].astype(np.float32)


def penumbra(build, scene, out, spp, size, seed=0, sampler="sobol"):
    stats = out + ".json"
    cmd = [os.path.join(build, "bin", "penumbra"), "render", scene, "--method", "pathtrace",
           "--spp", str(spp), "--width", str(size), "--height", str(size), "--threads", "2",
           "--seed", str(seed), "--sampler", sampler, "-o", out, "--stats", stats, "--quiet"]
    t0 = time.time()
    subprocess.run(cmd, check=True)
    process = time.time() - t0
    return read_pfm(out), {"render": json.load(open(stats))["seconds"], "process": process}


def cycles(blender, scene, out, spp, size, seed=0):
    cmd = [blender, "-b", "--factory-startup", "-noaudio", "-P",
           os.path.join(HERE, "cycles", "render_in_cycles.py"), "--", scene, out, "--spp",
           str(spp), "--width", str(size), "--height", str(size), "--threads", "2", "--seed",
           str(seed)]
    t0 = time.time()
    r = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    process = time.time() - t0
    line = [l for l in r.stdout.splitlines() if l.startswith('{"seconds"')][-1]
    # Cycles' log: "| Time:MM:SS.ss | ... | Sample 0/N" when path tracing starts, "| Finished".
    clock = {}
    for l in r.stdout.splitlines():
        m = re.search(r"\| Time:(\d+):(\d+\.\d+) \|.*\| (Sample 0/\d+|Finished)$", l)
        if m:
            clock.setdefault(m.group(3).split("/")[0], 60 * int(m.group(1)) + float(m.group(2)))
    if "Sample 0" not in clock or "Finished" not in clock:
        sys.exit(f"Cycles' log has no start or end of sampling for {out}")
    return np.load(out), {"render": clock["Finished"] - clock["Sample 0"], "process": process,
                          "call": json.loads(line)["seconds"]}


def rel_rms(x, ref):
    return float(np.sqrt(np.mean((x.astype(np.float64) - ref) ** 2)) / np.mean(ref))


def time_to(points, e):
    """Render time at which the error reaches e: log-log interpolation between the ladder points
    that bracket it, or extrapolation from the last one (then marked)."""
    pts = sorted(points)
    lt = np.log([p[1] for p in pts])
    le = np.log([p[2] for p in pts])
    target = np.log(e)
    for k in range(len(pts) - 1):
        if le[k] >= target >= le[k + 1]:
            f = (target - le[k]) / (le[k + 1] - le[k])
            return float(np.exp(lt[k] + f * (lt[k + 1] - lt[k]))), False
    # Past the ladder: the Monte Carlo rate from the last point, error ~ time^(-1/2) (both
    # renderers alike; a low-discrepancy sampler converges at least this fast).
    return float(np.exp(lt[-1] + 2.0 * (le[-1] - target))), True


def calibrate(blender, out):
    """A point light of 1 W/sr, 1 m over a large floor of reflectance 0.5: the floor below it
    has radiance 0.5 / pi. Checks Cycles' point-light units (render_in_cycles.py)."""
    os.makedirs(out, exist_ok=True)
    floor = os.path.join(out, "floor.obj")
    open(floor, "w").write("v -50 0 -50\nv 50 0 -50\nv 50 0 50\nv -50 0 50\nf 1 3 2\nf 1 4 3\n")
    scene = os.path.join(out, "calibrate.json")
    json.dump({"materials": {"grey": {"reflectance": [0.5, 0.5, 0.5]}},
               "meshes": [{"file": "floor.obj", "material": "grey"}],
               "lights": [{"type": "point", "position": [0, 1, 0], "intensity": [1, 1, 1]}],
               "camera": {"position": [0, 0.5, 0.001], "look_at": [0, 0, 0], "up": [0, 0, -1],
                          "fov_deg": 2}}, open(scene, "w"))
    img, _ = cycles(blender, scene, os.path.join(out, "calibrate.npy"), 64, 16)
    expected = 0.5 / np.pi
    print(f"Cycles: floor radiance under a 1 W/sr point light at 1 m: {img.mean():.5f}, closed "
          f"form {expected:.5f} (ratio {img.mean() / expected:.4f})")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--out", default=os.path.join(ROOT, "bench-out", "pathtracer-vs-cycles"))
    ap.add_argument("--scenes", default="cornell,room")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--ladder", default="16,32,64,128,256,512,1024")
    ap.add_argument("--references-only", action="store_true",
                    help="render the references and stop (they need no quiet machine)")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--plot", default=os.path.join(ROOT, "docs", "images", "pathtracer_vs_cycles.png"))
    ap.add_argument("--calibrate", action="store_true")
    ap.add_argument("--reuse", action="store_true",
                    help="reuse ladder images already in --out (e.g. Cycles' when only Penumbra changed)")
    ap.add_argument("--sampler", default="sobol", help="Penumbra's --sampler for the ladder")
    ap.add_argument("--tag", default="", help="suffix for Penumbra's ladder files (comparing versions)")
    a = ap.parse_args()
    if a.calibrate:
        calibrate(a.blender, a.out)
        return
    os.makedirs(a.out, exist_ok=True)
    ladder = [int(s) for s in a.ladder.split(",")]
    results = {}
    for name in a.scenes.split(","):
        scene = os.path.join(ROOT, SCENES[name])
        res = {}
        for who, fn, ext in (("penumbra", lambda o, s, seed=0: penumbra(
                                  a.build, scene, o, s, a.size, seed=seed, sampler=a.sampler), "pfm"),
                             ("cycles", lambda o, s, seed=0: cycles(a.blender, scene, o, s, a.size,
                                                                    seed=seed), "npy")):
            # The reference has a seed of its own: with the ladder's seed its first samples would
            # be the ladder's images (both renderers' samplers are progressive), and the error
            # measured against it too small.
            tag = f"ref{a.reference_spp}-seed{REFERENCE_SEED}"
            ref_path = os.path.join(a.out, f"{name}-{who}-{tag}.{ext}")
            ref_time = os.path.join(a.out, f"{name}-{who}-{tag}.seconds")
            if os.path.exists(ref_path) and os.path.exists(ref_time):
                ref = read_pfm(ref_path) if ext == "pfm" else np.load(ref_path)
            else:
                ref, secs = fn(ref_path, a.reference_spp, REFERENCE_SEED)
                json.dump(secs, open(ref_time, "w"))
            if a.references_only:
                continue
            points = []
            for spp in ladder:
                path = os.path.join(a.out, f"{name}-{who}{a.tag if who == 'penumbra' else ''}-{spp}.{ext}")
                # Reused when asked, unless kept by an older version of this script (a bare
                # number of seconds, without the process time).
                kept = (json.load(open(path + ".seconds"))
                        if a.reuse and os.path.exists(path) and os.path.exists(path + ".seconds")
                        else None)
                if isinstance(kept, dict):
                    img = read_pfm(path) if ext == "pfm" else np.load(path)
                    secs = kept
                else:
                    img, secs = fn(path, spp)
                    json.dump(secs, open(path + ".seconds", "w"))
                # (spp, render seconds, error, process seconds)
                points.append((spp, secs["render"], rel_rms(img, ref), secs["process"]))
                print(f"{name} {who} {spp} spp: render {secs['render']:.2f} s, process "
                      f"{secs['process']:.2f} s, error {points[-1][2] * 100:.2f}%",
                      file=sys.stderr, flush=True)
            res[who] = {"points": points, "reference_mean": float(ref.mean())}
        results[name] = res
    if a.references_only:
        return
    json.dump(results, open(os.path.join(a.out, "results.json"), "w"), indent=1)

    for way, column in (("render", 1), ("process", 3)):
        print(f"\nTime: {way} ({'path tracing alone' if way == 'render' else 'program start to image written'})\n")
        print(f"| scene | renderer | s per spp (at {ladder[-1]}) | error at 64 / {ladder[-1]} spp | time to 3% | "
              "time to 1% | Cycles / Penumbra at 3% | at 1% |")
        print("|---|---|---|---|---|---|---|---|")
        for name, res in results.items():
            pts = {who: [(p[0], p[column], p[2]) for p in r["points"]] for who, r in res.items()}
            # Process time = the render's time + what does not grow with the samples (start-up,
            # loading, sync, BVH, writing): the median of that difference over the ladder.
            over = {who: (float(np.median([p[3] - p[1] for p in r["points"]])) if way == "process"
                          else 0.0) for who, r in res.items()}
            t = {}
            for who, r in res.items():
                q = [(p[0], p[1], p[2]) for p in r["points"]]
                t[who] = tuple((v[0] + over[who], v[1]) for v in (time_to(q, 0.03), time_to(q, 0.01)))
            for who, q in pts.items():
                by = {p[0]: p for p in q}
                ratio = (f"**{t['cycles'][0][0] / t['penumbra'][0][0]:.2f}x** | "
                         f"**{t['cycles'][1][0] / t['penumbra'][1][0]:.2f}x**") if who == "penumbra" else " | "
                mark = lambda v: f"{v[0]:.1f} s" + (" (extrapolated)" if v[1] else "")
                print(f"| {name} | {who} | {by[max(by)][1] / max(by):.4f} | "
                      f"{by.get(64, (0, 0, 0))[2] * 100:.2f}% / {by[max(by)][2] * 100:.2f}% | "
                      f"{mark(t[who][0])} | {mark(t[who][1])} | {ratio} |")
    for name, res in results.items():
        print(f"(means of the references, {name}: Penumbra {res['penumbra']['reference_mean']:.4f}, "
              f"Cycles {res['cycles']['reference_mean']:.4f})", file=sys.stderr)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(results), figsize=(5.5 * len(results), 4.2), squeeze=False)
    for ax, (name, res) in zip(axes[0], results.items()):
        for who, colour in (("penumbra", "tab:blue"), ("cycles", "tab:orange")):
            pts = sorted((p[0], p[1], p[2]) for p in res[who]["points"])
            ax.loglog([p[1] for p in pts], [p[2] * 100 for p in pts], "o-", color=colour,
                      label=f"{who}: {pts[0][0]} to {pts[-1][0]} spp")
            t1, _ = time_to(pts, 0.01)
            ax.loglog([pts[-1][1], t1], [pts[-1][2] * 100, 1.0], ":", color=colour)
        for e in (3, 1):
            ax.axhline(e, color="grey", lw=0.5, ls=":")
        ax.set_xlabel("render time alone, s (2 threads; dotted: extrapolated to 1%)")
        ax.set_ylabel("relative RMS error per pixel, %")
        ax.set_title(f"{name}, {a.size} x {a.size}")
        ax.legend(fontsize=7)
        ax.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    fig.savefig(a.plot, dpi=110)


if __name__ == "__main__":
    main()
