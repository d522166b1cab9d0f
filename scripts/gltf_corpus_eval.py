#!/usr/bin/env python3
"""Real glTF files through Penumbra, as a new user would try them: each file of a corpus is
rendered at a few samples under a uniform environment (`render FILE --spp 2 --width 48
--height 48 --environment 1,1,1`), and the outcome classified:

  opens      exit 0, an image written
  refused    exit 2 with one line naming an extension or format Penumbra does not read (the
             reason's words below), or naming what is wrong in a file the Khronos validator also
             rejects
  empty      exit 2 with one line saying the scene has no triangles and why (points or lines
             only, an animation, an empty scene): nothing for a renderer of surfaces to draw
  misleading exit 2 on a file the validator accepts, for a reason that is not an unsupported
             extension or format: a message that blames a valid file
  breach     a signal, another exit code, a timeout, or more than one line on stderr

The corpus is a folder of .gltf/.glb files with a manifest.csv (path, validator_errors, ...), as
the evaluation corpus of the glTF work holds (docs/scene-format.md, "glTF files from the web").

    scripts/gltf_corpus_eval.py build/bin/penumbra CORPUS [--jobs 2] [--timeout 180]
        [--markdown FILE] [--only SUBSTRING]

Prints a summary and every file not opened; exits 1 when there is a misleading refusal or a
breach.
"""
import argparse
import collections
import concurrent.futures
import csv
import os
import subprocess
import sys
import tempfile
import time

# Words of a refusal that names something Penumbra does not implement, rather than blaming the
# file.
UNSUPPORTED = ("does not implement", "does not know", "Penumbra cannot decode",
               "no Debian library", "is not supported", "are not supported", "not implemented")
# Words of a refusal of a valid file that holds nothing Penumbra draws (points and lines only, an
# animation, an empty scene), saying so.
EMPTY = ("the scene has no triangles: ",)


def run(cli, path, timeout, out_dir):
    out = os.path.join(out_dir, "x.png")
    cmd = [cli, "render", path, "--spp", "2", "--width", "48", "--height", "48",
           "--environment", "1,1,1", "--threads", "1", "-o", out, "--quiet"]
    start = time.monotonic()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                           start_new_session=True)
        code, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired:
        code, err = "timeout", ""
    seconds = time.monotonic() - start
    lines = [l for l in err.splitlines() if l.strip() and "[warning]" not in l and
             "warning:" not in l.lower()[:40]]
    return code, lines, seconds, os.path.exists(out)


def classify(row, code, lines, wrote):
    valid = row.get("validator_errors", "0") in ("0", "")
    if code == 0 and wrote:
        return "opens", ""
    if code == 2 and len(lines) == 1:
        message = lines[0]
        if any(w in message for w in UNSUPPORTED):
            return "refused", message
        if any(w in message for w in EMPTY):
            return "empty", message
        return ("misleading" if valid else "refused"), message
    return "breach", f"exit {code}: " + " | ".join(lines[:3])


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cli")
    ap.add_argument("corpus")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=180)
    ap.add_argument("--markdown")
    ap.add_argument("--only")
    args = ap.parse_args()
    rows = list(csv.DictReader(open(os.path.join(args.corpus, "manifest.csv"))))
    if args.only:
        rows = [r for r in rows if args.only in r["path"]]
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        def one(i_row):
            i, row = i_row
            d = os.path.join(tmp, str(i))
            os.makedirs(d, exist_ok=True)
            return i, run(args.cli, os.path.join(args.corpus, row["path"]), args.timeout, d)
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            for i, r in pool.map(one, enumerate(rows)):
                results[i] = r
    counts = collections.Counter()
    by_source = collections.defaultdict(collections.Counter)
    interiors = collections.Counter()
    table = []
    for i, row in enumerate(rows):
        code, lines, seconds, wrote = results[i]
        kind, message = classify(row, code, lines, wrote)
        counts[kind] += 1
        by_source[row["path"].split("/")[0]][kind] += 1
        if row.get("interior") == "yes":
            interiors[kind] += 1
        if kind != "opens":
            table.append((kind, row["path"], message, seconds))
    total = len(rows)
    print(f"{total} files: " + ", ".join(f"{k} {counts[k]}" for k in
                                         ("opens", "refused", "empty", "misleading", "breach")))
    print(f"interiors ({sum(interiors.values())}): " +
          ", ".join(f"{k} {v}" for k, v in sorted(interiors.items())))
    for kind, path, message, seconds in sorted(table):
        print(f"{kind:10s} {path}: {message} ({seconds:.1f} s)")
    kinds = ("opens", "refused", "empty", "misleading", "breach")
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write("| collection | files | " + " | ".join(kinds) + " |\n")
            f.write("|---|---:|" + "---:|" * len(kinds) + "\n")
            for src in sorted(by_source):
                c = by_source[src]
                f.write(f"| {src} | {sum(c.values())} | " +
                        " | ".join(str(c[k]) for k in kinds) + " |\n")
            f.write(f"| **all** | {total} | " + " | ".join(str(counts[k]) for k in kinds) +
                    " |\n")
            f.write("\n| file | outcome | message |\n|---|---|---|\n")
            for kind, path, message, _ in sorted(table):
                f.write(f"| `{path}` | {kind} | {message.replace('|', '/')} |\n")
    return 1 if counts["misleading"] or counts["breach"] else 0


if __name__ == "__main__":
    sys.exit(main())
