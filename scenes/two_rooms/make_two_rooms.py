#!/usr/bin/env python3
"""Writes the two-rooms scene: two rooms side by side sharing a 2 cm wall, one lit by a bright
ceiling panel, the other by a panel a hundred times dimmer. The floor and the ceiling run as one
quad each under and over the shared wall, so the lightmap's texels there straddle it: the scene
that measures light leaking through a wall (docs/performance.md, "Leaks, seams and padding").

    scenes/two_rooms/make_two_rooms.py scenes/two_rooms
"""
import json
import os
import sys

# The dark room's width (x), the lit room's, the depth (z), the height, half the wall's thickness.
# The widths put the wall 2 cm off a texel's centre at 10 texels per metre, whichever end the
# floor's chart is laid out from, so one texel there covers 6 cm of the dark room, the wall and
# 2 cm of the lit room.
WA, WB, D, H, T = 1.96, 2.02, 3.0, 2.5, 0.01


def quad(v, a, b, c, d):
    """Appends a quad's corners (counter-clockwise seen from the front) and returns its faces."""
    base = len(v) + 1
    v.extend([a, b, c, d])
    return [(base, base + 1, base + 2), (base, base + 2, base + 3)]


def write_obj(path, v, f):
    with open(path, "w") as out:
        out.write("# written by make_two_rooms.py\n")
        for p in v:
            out.write("v %g %g %g\n" % p)
        for t in f:
            out.write("f %d %d %d\n" % t)


def main(out):
    os.makedirs(out, exist_ok=True)
    x0, x1 = -WA - T, WB + T
    # Floor (facing +y) and ceiling (facing -y), each one quad over both rooms.
    v, f = [], []
    f += quad(v, (x0, 0, D), (x1, 0, D), (x1, 0, 0), (x0, 0, 0))
    f += quad(v, (x0, H, 0), (x1, H, 0), (x1, H, D), (x0, H, D))
    write_obj(os.path.join(out, "floor_ceiling.obj"), v, f)
    # The outer walls facing in, and the shared wall (a slab 2T thick, both faces and its ends).
    v, f = [], []
    f += quad(v, (x0, 0, 0), (x1, 0, 0), (x1, H, 0), (x0, H, 0))  # back, facing +z
    f += quad(v, (x1, 0, D), (x0, 0, D), (x0, H, D), (x1, H, D))  # front, facing -z
    f += quad(v, (x0, 0, D), (x0, 0, 0), (x0, H, 0), (x0, H, D))  # left, facing +x
    f += quad(v, (x1, 0, 0), (x1, 0, D), (x1, H, D), (x1, H, 0))  # right, facing -x
    f += quad(v, (-T, 0, 0), (-T, 0, D), (-T, H, D), (-T, H, 0))  # shared, facing -x
    f += quad(v, (T, 0, D), (T, 0, 0), (T, H, 0), (T, H, D))      # shared, facing +x
    write_obj(os.path.join(out, "walls.obj"), v, f)
    # Ceiling panels, 0.6 m square, 1 cm below the ceiling, facing down.
    for name, cx in (("panel_lit.obj", WB / 2 + T), ("panel_dark.obj", -WA / 2 - T)):
        v, f = [], []
        y, s = H - 0.01, 0.3
        f += quad(v, (cx - s, y, D / 2 - s), (cx + s, y, D / 2 - s), (cx + s, y, D / 2 + s),
                  (cx - s, y, D / 2 + s))
        write_obj(os.path.join(out, name), v, f)
    scene = {
        "materials": {
            "plaster": {"reflectance": [0.7, 0.7, 0.7]},
            "lit": {"reflectance": [0.8, 0.8, 0.8], "emission": [20, 20, 20], "two_sided": False},
            "dim": {"reflectance": [0.8, 0.8, 0.8], "emission": [0.2, 0.2, 0.2], "two_sided": False},
        },
        "meshes": [
            {"file": "floor_ceiling.obj", "material": "plaster", "name": "floor_ceiling"},
            {"file": "walls.obj", "material": "plaster", "name": "walls"},
            {"file": "panel_lit.obj", "material": "lit", "name": "panel_lit"},
            {"file": "panel_dark.obj", "material": "dim", "name": "panel_dim"},
        ],
        "camera": {"position": [-1.6, 1.6, D - 0.2], "look_at": [0, 0.2, 0.8], "fov_deg": 70},
    }
    with open(os.path.join(out, "two_rooms.json"), "w") as out_file:
        json.dump(scene, out_file, indent=2)
        out_file.write("\n")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__)))
