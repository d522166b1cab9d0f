#!/usr/bin/python3
"""Scaling over MPI ranks (docs/scaling.md): each method's work on one process and over ranks.

For every case it runs the same `penumbra` command as one process with one thread (the baseline),
one process with every core, and `mpirun -np N` with one thread per rank for N = 2 ..
--max-ranks (ranks beyond the cores run oversubscribed: say so when quoting them), in
interleaved rounds, checks that the distributed outputs are the baseline's bytes (where
docs/scaling.md promises it), and prints a Markdown table of median wall times and speed-ups
over the baseline: of the whole command (wall, including starting the processes and loading the
scene on each), and of the work itself as --stats times it (path tracer: rendering; trace: build
and trace, over ranks from the scatter to the gathered answers; matrix: form factors and solve;
progressive: the solve).

  bench/mpi_scaling.py [--build build] [--out bench-out/mpi-scaling] [--rounds 3] [--max-ranks 2]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def cases(out):
    rays = os.path.join(out, "bunny_diffuse.bin")
    return [
        ("path tracer, Cornell box 256x256, 64 spp", "render",
         ["cornell", "--width", "256", "--height", "256", "--spp", "64", "-o", "{out}.pfm"],
         "{out}.pfm"),
        ("trace, bunny, 2M diffuse rays", "trace",
         ["scenes/bunny.json", "--rays", rays, "--device", "cpu", "-o", "{out}.bin"], "{out}.bin"),
        ("matrix radiosity (Jacobi), Cornell box, 4000 elements", "render",
         ["cornell", "--method", "matrix", "--solver", "jacobi", "--elements", "4000", "--width",
          "128", "--height", "128", "-o", "{out}.pfm"], "{out}.pfm"),
        ("progressive radiosity, room scan, 20000 texels", "bake",
         ["scenes/room.json", "--method", "progressive", "--elements", "20000", "-o", "{out}"],
         "{out}/room_lightmap.exr"),
    ]


def work_seconds(command, stats):
    """The work itself, from --stats (without starting the processes and loading the scene)."""
    if command == "trace":
        return stats["seconds"]  # one process: build + trace; ranks: scatter to gather
    if stats.get("method") == "matrix":
        return stats["form_factor_seconds"] + stats["solve_seconds"]
    if "solve_seconds" in stats:
        return stats["solve_seconds"]
    return stats["seconds"]


def mpirun():
    cmd = ["mpirun", "--oversubscribe"]
    if os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    return cmd


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--out", default=os.path.join(ROOT, "bench-out", "mpi-scaling"))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--max-ranks", type=int, default=2)
    args = ap.parse_args()
    cli = os.path.join(args.build, "bin", "penumbra")
    os.makedirs(args.out, exist_ok=True)
    rays = os.path.join(args.out, "bunny_diffuse.bin")
    if not os.path.exists(rays):
        subprocess.run([cli, "rays", "scenes/bunny.json", "--kind", "diffuse", "--count",
                        "2000000", "-o", rays, "--quiet"], check=True, cwd=ROOT)
    cores = os.cpu_count()
    configs = [("1 process, 1 thread", 1, 1), (f"1 process, {cores} threads", 1, cores)]
    configs += [(f"{n} ranks x 1 thread", n, 1) for n in range(2, args.max_ranks + 1)]
    rows = []
    for title, command, opts, product in cases(args.out):
        times = {c[0]: [] for c in configs}
        work = {c[0]: [] for c in configs}
        stats = {}
        outputs = {}
        for _ in range(args.rounds):
            for name, ranks, threads in configs:
                tag = os.path.join(args.out, f"{command}-{ranks}-{threads}")
                words = [w.replace("{out}", tag) for w in opts]
                cmd = [cli, command, *words, "--threads", str(threads), "--quiet", "--stats",
                       tag + ".json"]
                if ranks > 1:
                    cmd = mpirun() + ["-np", str(ranks)] + cmd
                t0 = time.monotonic()
                subprocess.run(cmd, check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
                times[name].append(time.monotonic() - t0)
                stats[name] = json.load(open(tag + ".json"))
                work[name].append(work_seconds(command, stats[name]))
                with open(product.replace("{out}", tag), "rb") as f:
                    outputs[name] = f.read()
        base = statistics.median(times[configs[0][0]])
        base_work = statistics.median(work[configs[0][0]])
        same = all(outputs[c[0]] == outputs[configs[0][0]] for c in configs)
        for name, ranks, threads in configs:
            t = statistics.median(times[name])
            w = statistics.median(work[name])
            rows.append((title, name, t, base / t, w, base_work / w, same, stats[name]))
    print("| case | run | wall s | speed-up | work s | speed-up | same bytes |")
    print("|---|---|---|---|---|---|---|")
    for title, name, t, s, w, ws, same, _ in rows:
        print(f"| {title} | {name} | {t:.2f} | {s:.2f}x | {w:.2f} | {ws:.2f}x | "
              f"{'yes' if same else 'NO'} |")
    json.dump([{"case": r[0], "run": r[1], "seconds": r[2], "speedup": r[3], "work_seconds": r[4],
                "work_speedup": r[5], "same": r[6], "stats": r[7]} for r in rows],
              open(os.path.join(args.out, "results.json"), "w"), indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
