#!/usr/bin/env python3
"""CIE 171:2006 analytical cases at default settings: every point against the report's figure.

    bench/cie171.py build/bin/penumbra [--methods progressive,pathtrace] [--cases 5.13,5.14]
                    [--out DIR]

Runs the scenes of scenes/cie171/ (their figures in scenes/cie171/reference.json) with each
method at its defaults and prints a Markdown table: per case the largest and the mean error over
its points and the seconds the render took. docs/lighting-design.md holds its output. Case 5.8 is
run at every reflectance of the report's Table 20 (its interreflected illuminance averaged over
the cube). The same criteria as tests/app/cie171_test.cpp: every point within 5%, each case's
mean error within 2%.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CIE = os.path.join(HERE, "..", "scenes", "cie171")


def render(penumbra, scene, method, out, extra=()):
    report = os.path.join(out, "report")
    stats = os.path.join(out, "stats.json")
    cmd = [penumbra, "render", scene, "--method", method, "--width", "16", "--height", "16",
           "--report", report, "--stats", stats, "-o", os.path.join(out, "x.png"), *extra]
    start = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.time() - start
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stdout}{r.stderr}")
    with open(stats) as f:
        return json.load(f)["illuminance"], report, seconds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("penumbra")
    ap.add_argument("--methods", default="progressive,pathtrace")
    ap.add_argument("--cases", default="", help="only the cases whose names start so")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    with open(os.path.join(CIE, "reference.json")) as f:
        cases = json.load(f)["cases"]
    out = args.out or tempfile.mkdtemp(prefix="cie171-")
    print("| case | method | points | largest error | mean error | seconds | passes |")
    print("|---|---|---|---|---|---|---|")
    failed = False
    wanted = [c for c in args.cases.split(",") if c]
    for case in cases:
        if wanted and not any(case["case"].startswith(w) for w in wanted):
            continue
        for method in args.methods.split(","):
            scene = os.path.join(CIE, case["scene"])
            work = os.path.join(out, re.sub(r"[^\w.-]", "_", case["case"]) + "-" + method)
            os.makedirs(work, exist_ok=True)
            if "interreflected" in case:
                spec = case["interreflected"]
                text = open(scene).read()
                for rho in spec["rho"]:
                    variant = os.path.join(work, f"cube-{rho}.json")
                    with open(variant, "w") as f:
                        f.write(text.replace("[0.8, 0.8, 0.8]", f"[{rho}, {rho}, {rho}]")
                                .replace('"cube.obj"', json.dumps(os.path.join(CIE, "cube.obj"))))
                    lux, _, seconds = render(args.penumbra, variant, method, work)
                    o = lux["objects"][0]
                    got = o["total"]["average_lux"] - o["direct"]["average_lux"]
                    ref = rho * spec["flux_lm"] / (spec["area_m2"] * (1 - rho))
                    err = abs(got - ref) / ref if ref > 0 else abs(got)
                    ok = err < 0.02 if ref > 0 else got < 0.01
                    failed |= not ok
                    shown = f"{100 * err:.2f}%" if ref > 0 else f"{got:.3f} lx"
                    print(f"| 5.8, rho {rho} | {method} | average | {shown} | {shown} | "
                          f"{seconds:.1f} | {'yes' if ok else 'NO'} |")
                continue
            if "sky_types" in case:
                text = open(scene).read()
                for sky_type, points in case["sky_types"].items():
                    variant = os.path.join(work, f"sky{sky_type}.json")
                    body = text.replace('"type": 12', f'"type": {sky_type}')
                    body = body.replace('"file": "', '"file": "' + CIE + "/")
                    with open(variant, "w") as f:
                        f.write(body)
                    lux, report, seconds = render(args.penumbra, variant, method, work)
                    with open(os.path.join(report, case["object"] + ".json")) as f:
                        values = {p.get("name", ""): p["total_lux"]
                                  for p in json.load(f)["point_values"]}
                    doubt = set(case.get("unverified", {}).get(sky_type, []))
                    errors = [abs(values[p] / r - 1) for p, r in points.items() if p not in doubt]
                    worst, mean = max(errors, default=0.0), sum(errors) / max(len(errors), 1)
                    ok = worst < 0.05 and mean < 0.02
                    failed |= not ok
                    note = ""
                    if doubt:
                        off = max(abs(values[p] / points[p] - 1) for p in doubt)
                        note = f" (and {len(doubt)} in doubt, up to {100 * off:.1f}%)"
                    print(f"| {case['case']}, sky {sky_type} | {method} | {len(errors)}{note} | "
                          f"{100 * worst:.2f}% | {100 * mean:.2f}% | {seconds:.1f} | "
                          f"{'yes' if ok else 'NO'} |")
                continue
            lux, report, seconds = render(args.penumbra, scene, method, work)
            if "average" in case:
                got = lux["objects"][0]["total"]["average_lux"]
                err = abs(got / case["average"] - 1)
                ok = err < 0.02
                failed |= not ok
                print(f"| {case['case']} | {method} | average | {100 * err:.2f}% | "
                      f"{100 * err:.2f}% | {seconds:.1f} | {'yes' if ok else 'NO'} |")
                continue
            with open(os.path.join(report, case["object"] + ".json")) as f:
                values = {p.get("name", ""): p["total_lux"] for p in json.load(f)["point_values"]}
            errors, ok = [], True
            for point, ref in case["points"].items():
                if ref == 0:
                    ok &= abs(values[point]) < 0.05
                    continue
                errors.append(abs(values[point] / ref - 1))
            worst, mean = max(errors), sum(errors) / len(errors)
            ok &= worst < 0.05 and mean < 0.02
            failed |= not ok
            print(f"| {case['case']} | {method} | {len(case['points'])} | {100 * worst:.2f}% | "
                  f"{100 * mean:.2f}% | {seconds:.1f} | {'yes' if ok else 'NO'} |")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
