#!/usr/bin/env bash
# The viewer's frame rates on this machine (docs/viewer.md): each method live in a window of the
# default size (1120 x 640: an 800 x 640 image beside the panel) under Xvfb with Mesa's llvmpipe,
# 90 frames within the default 16.7 ms budget, a light moving every frame where the scene has
# one. Prints the median and mean milliseconds per frame and the median of each pass.
#   scripts/viewer-frame-rates.sh [build/bin]
set -euo pipefail
bin=${1:-build/bin}
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'kill "$xvfb" 2>/dev/null || true; rm -rf "$work"' EXIT
exec 3<> "$work/display"
Xvfb -displayfd 3 -screen 0 1280x1024x24 -nolisten tcp > /dev/null 2>&1 &
xvfb=$!
for _ in $(seq 100); do [ -s "$work/display" ] && break; sleep 0.1; done
export DISPLAY=":$(head -n1 "$work/display")"

# The Cornell box's walls and blocks lit by a point light that crosses the room.
python3 - "$root" "$work" <<'PY'
import json, sys
root, work = sys.argv[1], sys.argv[2]
parts = [("floor", "white"), ("ceiling", "white"), ("back", "white"), ("greenwall", "green"),
         ("redwall", "red"), ("smallbox", "white"), ("largebox", "white")]
scene = {"materials": {"white": {"reflectance": [0.725, 0.71, 0.68]},
                       "red": {"reflectance": [0.63, 0.065, 0.05]},
                       "green": {"reflectance": [0.14, 0.45, 0.091]}},
         "meshes": [{"file": f"{root}/scenes/cornell/{f}.obj", "material": m,
                     "transform": {"scale": 0.001}} for f, m in parts],
         "lights": [{"type": "point", "position": [0.12, 0.45, 0.2], "intensity": [0.5, 0.5, 0.5]}],
         "camera": {"position": [0.278, 0.273, -0.8], "look_at": [0.278, 0.273, 0.0],
                    "fov_deg": 39.3}}
json.dump(scene, open(f"{work}/box.json", "w"))
json.dump({"light_path": [[0.12, 0.45, 0.2], [0.44, 0.45, 0.35], [0.12, 0.45, 0.45]]},
          open(f"{work}/box_path.json", "w"))
json.dump({"light_path": [[-0.05, 0.25, -0.35], [0.3, 0.25, -0.2], [0.3, 0.25, 0.3]]},
          open(f"{work}/bunny_path.json", "w"))
PY

run() {  # method scene script
  "$bin/penumbra" view "$2" --method "$1" --live --frames 90 --script "$3" \
    --screenshot "$work/$1.png" --stats "$work/$1.json"
  python3 - "$work/$1.json" <<'PY'
import json, statistics, sys
j = json.load(open(sys.argv[1]))
f = j["frames"]
med = lambda k: statistics.median(x[k] for x in f)
mean = statistics.mean(x["frame_ms"] for x in f)
print(f'{j["method"]:12s} frame median {med("frame_ms"):6.1f} ms (mean {mean:6.1f}, '
      f'{1e3 / med("frame_ms"):5.1f} fps); solve {med("solve_ms"):5.1f}, view {med("view_ms"):5.1f}, '
      f'draw {med("draw_ms"):4.1f}; first build {max(x["build_ms"] for x in f):6.0f} ms; {j["renderer"]}')
PY
}
for m in pathtrace matrix progressive stochastic; do run "$m" "$work/box.json" "$work/box_path.json"; done
for m in sss lpv; do run "$m" "$m" "$work/bunny_path.json"; done
