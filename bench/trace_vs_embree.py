#!/usr/bin/python3
"""`penumbra trace` against Embree on ray files the project did not generate.

Makes a 1.1M-triangle scene (16 bunnies on a floor) and ray sets with bench/external_rays.py,
then, for every (scene, ray set, query), runs `penumbra trace --stats` (its trace_seconds, one
run per process, as a user meets it) and bench's `embree_trace` (Embree 3, the better of
rtcIntersect1/rtcIntersect8 or rtcOccluded1/rtcOccluded8, median of 3 passes after a warm-up:
the peer's best case) in interleaved rounds, checks that the answers agree, and prints a
Markdown table of medians and ratios (Penumbra's speed over Embree's; above 1 is faster), with
the memory per triangle of both acceleration structures. The "library" column is Penumbra's
RayEngine timed like Embree, in embree_trace's process (median of 3 passes after a warm-up).
Scenes: the bunny, 16 bunnies on a floor, a city of boxes and a noise-displaced sphere (the last
two were added after the kernels were tuned, with the short and long ray sets, and are not
tuned on).

  bench/trace_vs_embree.py [--build build] [--out bench-out/trace-vs-embree] [--rounds 5]
      [--scenes bunny,big,city,rock]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# (ray set, query); shadow rays are occlusion queries, the others closest hit and, for the
# surface sets, occlusion too (ambient occlusion, visibility).
CASES = [
    ("camera", "closest"),
    ("diffuse", "closest"),
    ("diffuse", "occlusion"),
    ("ao", "closest"),
    ("ao", "occlusion"),
    ("shadow", "occlusion"),
    ("outside", "closest"),
    ("short", "closest"),
    ("long", "closest"),
]


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({r.returncode}):\n{r.stdout}{r.stderr}")
    return r.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--out", default=os.path.join(ROOT, "bench-out", "trace-vs-embree"))
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--scenes", default="bunny,big,city,rock")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    penumbra = os.path.join(a.build, "bin", "penumbra")
    embree = os.path.join(a.build, "bin", "embree_trace")
    gen = [sys.executable, os.path.join(HERE, "external_rays.py")]
    bunny = os.path.join(ROOT, "tests", "data", "bunny.ply")
    scenes = {"bunny": bunny, "big": os.path.join(a.out, "bunnies-1m.ply"),
              "city": os.path.join(a.out, "city.ply"), "rock": os.path.join(a.out, "rock.ply")}
    if "big" in a.scenes and not os.path.exists(scenes["big"]):
        run(gen + ["scene", bunny, scenes["big"]])
    for name in ("city", "rock"):
        if name in a.scenes and not os.path.exists(scenes[name]):
            run(gen + [name, scenes[name]])
    rows = []
    for name in a.scenes.split(","):
        mesh = scenes[name]
        for kind in sorted({k for k, _ in CASES}):
            path = os.path.join(a.out, f"{name}-{kind}.bin")
            if not os.path.exists(path):
                run(gen + ["rays", mesh, kind, path])
        for kind, query in CASES:
            rays = os.path.join(a.out, f"{name}-{kind}.bin")
            hits = os.path.join(a.out, f"{name}-{kind}-{query}.out")
            stats = os.path.join(a.out, "stats.json")
            occ = ["--occlusion"] if query == "occlusion" else []
            ours, theirs, library, mismatches = [], [], [], 0
            bytes_ours = bytes_theirs = triangles = 0
            for _ in range(a.rounds):
                run([penumbra, "trace", mesh, "--rays", rays, "-o", hits, "--stats", stats,
                     "--device", "cpu", "--quiet"] + occ)
                s = json.load(open(stats))
                ours.append(s["trace_seconds"])
                bytes_ours, triangles = s["bvh_bytes"], s["triangles"]
                e = json.loads(run([embree, mesh, rays, "--reps", "3", "--check", hits,
                                    "--penumbra"] + occ))
                theirs.append(e["seconds_best"])
                library.append(e["seconds_penumbra"])
                mismatches = e["mismatches"]
                bytes_theirs = e["bytes"]
            mo, me = statistics.median(ours), statistics.median(theirs)
            ml = statistics.median(library)
            rows.append((name, kind, query, triangles, mo, me, me / mo, min(theirs) / max(ours),
                         max(theirs) / min(ours), mismatches, bytes_ours / triangles,
                         bytes_theirs / triangles, me / ml))
            print(f"{name} {kind} {query}: penumbra {mo * 1e3:.1f} ms, embree {me * 1e3:.1f} ms, "
                  f"ratio {me / mo:.2f}", file=sys.stderr, flush=True)
    print("| scene | rays | query | Penumbra ms | Embree ms | ratio (median) | ratio range | "
          "library, same process | answers differing | bytes/triangle Penumbra / Embree |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} ({r[3]:,} tri) | {r[1]} | {r[2]} | {r[4] * 1e3:.1f} | {r[5] * 1e3:.1f} | "
              f"**{r[6]:.2f}x** | {r[7]:.2f}-{r[8]:.2f} | {r[12]:.2f}x | {r[9]} of 1,048,576 | "
              f"{r[10]:.1f} / {r[11]:.1f} |")
    worst = min(rows, key=lambda r: r[6])
    print(f"\nworst: {worst[0]} {worst[1]} {worst[2]} {worst[6]:.2f}x")


if __name__ == "__main__":
    main()
