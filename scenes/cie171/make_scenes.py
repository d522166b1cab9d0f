#!/usr/bin/env python3
"""Writes the CIE 171:2006 analytical test scenes of this folder (README.md).

The rooms follow the report's section 5 in Penumbra's frame: y is up, CIE's (x, y, z) is
Penumbra's (x, z, y). Run it again after changing it; the scenes are committed as written.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))
LM_PER_W = 683.0  # lux and candela per W, Penumbra's photometric conversion


def write(name, text):
    with open(os.path.join(HERE, name), "w") as f:
        f.write(text)


def obj(name, quads, comment):
    """An OBJ of quads, each given by four corners counter-clockwise seen from its front."""
    lines = [f"# {comment}", f"o {name}"]
    for q in quads:
        for v in q:
            lines.append("v {:g} {:g} {:g}".format(*v))
    for k in range(len(quads)):
        b = 4 * k
        lines.append(f"f {b + 1} {b + 2} {b + 3} {b + 4}")
    return "\n".join(lines) + "\n"


def box_inside(x0, x1, y0, y1, z0, z1, ceiling=True):
    """The faces of a box wound to face its inside (floor, four walls, ceiling)."""
    q = [
        [(x0, y0, z0), (x0, y0, z1), (x1, y0, z1), (x1, y0, z0)],  # floor, facing +y
        [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],  # z = z0 wall, facing +z
        [(x1, y0, z1), (x0, y0, z1), (x0, y1, z1), (x1, y1, z1)],  # z = z1 wall, facing -z
        [(x0, y0, z1), (x0, y0, z0), (x0, y1, z0), (x0, y1, z1)],  # x = x0 wall, facing +x
        [(x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)],  # x = x1 wall, facing -x
    ]
    if ceiling:
        q.append([(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)][::-1])  # facing -y
    return q


def ceiling_with_hole(y, hole):
    """The 4 m x 4 m ceiling at height y facing down, less the square hole (a0, a1) x (a0, a1)."""
    a0, a1 = hole
    rects = [(0, a0, 0, 4), (a1, 4, 0, 4), (a0, a1, 0, a0), (a0, a1, a1, 4)]
    return [[(x0, y, z0), (x1, y, z0), (x1, y, z1), (x0, y, z1)] for x0, x1, z0, z1 in rects]


def box_outside(x0, x1, y0, y1, z0, z1):
    """A closed box wound to face out."""
    return [
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],  # bottom, facing -y
        [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)],  # top, facing +y
        [(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)],  # facing -z
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],  # facing +z
        [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],  # facing -x
        [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],  # facing +x
    ]


def points(named):
    return ",\n".join(
        '      {{"name": "{}", "position": [{:g}, {:g}, {:g}], "normal": [{:g}, {:g}, {:g}]}}'.format(
            n, *p, *d) for n, p, d in named)


def calc_points(name, named, measure="planar"):
    extra = f', "measure": "{measure}"' if measure != "planar" else ""
    return ('  "calculation": [\n    {{"name": "{}", "type": "points"{}, "points": [\n{}\n    ]}}\n  ]'
            .format(name, extra, points(named)))


# The points of cases 5.3 and 5.7: A-F on the wall CIE y = 0 (here z = 0, facing +z) at x = 2,
# heights 2.75 down to 0.25; G-N on the floor at x = 2, CIE y (here z) 0.25 to 3.75.
WALL = [(c, (2, 2.75 - 0.5 * k, 0), (0, 0, 1)) for k, c in enumerate("ABCDEF")]
FLOOR = [(c, (2, 0, 0.25 + 0.5 * k), (0, 1, 0)) for k, c in enumerate("GHIJKLMN")]

write("room.obj", obj("room", box_inside(0, 4, 0, 3, 0, 4, ceiling=False),
                      "CIE 171 rooms: floor and walls of the 4 m x 4 m x 3 m room, facing in"))
write("ceiling.obj", obj("ceiling", [box_inside(0, 4, 0, 3, 0, 4)[5]],
                         "CIE 171 rooms: the unbroken 4 m x 4 m ceiling at 3 m, facing down"))
write("ceiling_hole.obj", obj("ceiling", ceiling_with_hole(3, (1.5, 2.5)),
                              "CIE 171 rooms: the ceiling less a 1 m x 1 m hole in its middle"))
write("panel.obj", obj("panel", [[(1.5, 3, 1.5), (2.5, 3, 1.5), (2.5, 3, 2.5), (1.5, 3, 2.5)]],
                       "CIE 171 case 5.3: the 1 m x 1 m area source in the ceiling, facing down"))
write("cube.obj", obj("cube", box_inside(0, 4, 0, 4, 0, 4),
                      "CIE 171 case 5.8: the 4 m cube, facing in"))
write("floor.obj", obj("floor", [box_inside(0, 4, 0, 3, 0, 4)[0]],
                       "CIE 171 case 5.6: the 4 m x 4 m surface S2, facing up"))
write("wall_s2.obj", obj("s2", [box_inside(0, 4, 0, 3, 0, 4)[2]],
                         "CIE 171 case 5.7: the 4 m x 3 m wall S2 at CIE y = 4, facing the room"))
write("obstruction.obj", obj("obstruction", box_outside(0, 4, 0, 1, 2.5, 2.7),
                             "CIE 171 case 5.7: the 4 m x 1 m x 0.2 m obstruction"))

# 5.2: a Lambertian point source, I(gamma) = 1000 cd cos(gamma), 3 m above the floor.
angles = list(range(0, 91))
ies = ["IESNA:LM-63-2002",
       "[TEST] CIE 171:2006 case 5.2: a point source of Lambertian distribution, I = 1000 cd cos(gamma)",
       "[MANUFAC] Penumbra test data, written by scenes/cie171/make_scenes.py",
       "TILT=NONE",
       "1 -1 1 {} 1 1 2 0 0 0".format(len(angles)),
       "1.0 1.0 0",
       " ".join(str(a) for a in angles),
       "0",
       " ".join("{:.4f}".format(1000 * math.cos(math.radians(a))) for a in angles)]
write("lambertian_1000cd.ies", "\r\n".join(ies) + "\r\n")

BLACK = '"black": {"reflectance": [0, 0, 0]}'
room_meshes = ('    {"file": "room.obj", "material": "black", "name": "room"},\n'
               '    {"file": "ceiling.obj", "material": "black", "name": "room"}')

# 5.2 points: offsets (x, y) from the nadir, A-J.
OFFS = [("A", 0, 0), ("B", .5, 0), ("C", 1, 0), ("D", 1.5, 0), ("E", .5, .5), ("F", 1, .5),
        ("G", 1.5, .5), ("H", 1, 1), ("I", 1.5, 1), ("J", 1.5, 1.5)]
write("case_5_2.json", """{
  // CIE 171:2006 case 5.2: a point source of Lambertian intensity distribution (1000 cd on its
  // axis) 3 m above the floor of a black room; illuminance on the floor at A-J (offsets from the
  // nadir). Reference: E = I(gamma) cos(gamma) / d^2 (the report's Table 11).
  "materials": {%s},
  "meshes": [
%s
  ],
  "lights": [
    {"type": "luminaire", "file": "lambertian_1000cd.ies", "position": [2, 3, 2], "aim": [0, -1, 0]}
  ],
%s
}
""" % (BLACK, room_meshes, calc_points("floor", [(n, (2 + x, 0, 2 + y), (0, 1, 0)) for n, x, y in OFFS])))

L53 = 1000.0 / LM_PER_W  # 1000 cd/m^2
for name, ceiling in (("case_5_3.json", "ceiling_hole.obj"), ("case_5_3_on_ceiling.json", "ceiling.obj")):
    how = ("fills a hole in the ceiling" if ceiling == "ceiling_hole.obj"
           else "lies on the unbroken ceiling (the emitter wins: it is lifted off the ceiling)")
    write(name, """{
  // CIE 171:2006 case 5.3: a 1 m x 1 m Lambertian area source of 1000 cd/m^2 in the middle of
  // the ceiling of a black 4 m x 4 m x 3 m room; the panel %s.
  // Illuminance at A-F on a wall and G-N on the floor (the report's Table 12).
  "materials": {%s, "panel": {"reflectance": [0, 0, 0], "emission": [%.6f, %.6f, %.6f]}},
  "meshes": [
    {"file": "room.obj", "material": "black", "name": "room"},
    {"file": "%s", "material": "black", "name": "ceiling"},
    {"file": "panel.obj", "material": "panel", "name": "panel"}
  ],
%s
}
""" % (how, BLACK, L53, L53, L53, ceiling, calc_points("wall and floor", WALL + FLOOR)))

I54 = 10000.0 / (4 * math.pi) / LM_PER_W
write("case_5_4.json", """{
  // CIE 171:2006 case 5.4: flux conservation. An isotropic point source of 10,000 lm in a closed
  // black 4 m x 4 m x 3 m room: the illuminance averaged over the room's 80 m^2 must be
  // 10,000 / 80 = 125 lx.
  "materials": {%s},
  "meshes": [
%s
  ],
  "lights": [{"type": "point", "position": [2, 1.5, 2], "intensity": [%.6f, %.6f, %.6f]}],
  "calculation": [{"name": "room", "type": "surface", "mesh": "room", "spacing": 0.25}]
}
""" % (BLACK, room_meshes, I54, I54, I54))

# 5.6: S2 lit by a parallel beam at 35 degrees from its normal (E_hz = 1000 lx), rho = 0.5; the
# points face away from the beam, so they see only what S2 reflects.
E56 = 1000.0 / math.cos(math.radians(35)) / LM_PER_W
d56 = (0, -math.cos(math.radians(35)), math.sin(math.radians(35)))
WALL56 = [(c, (2, 2.75 - 0.5 * k, 0), (0, 0, 1)) for k, c in enumerate("FEDCB")]
CEIL56 = [(c, (2, 3, 0.25 + 0.5 * k), (0, -1, 0)) for k, c in enumerate("GHIJKLMN")]
write("case_5_6.json", """{
  // CIE 171:2006 case 5.6 (scenario 2): light reflected by a diffuse surface. S2, a 4 m x 4 m
  // Lambertian surface of reflectance 0.5, is lit evenly (E_hz = 1000 lx) by a parallel beam
  // at 35 degrees; calculation points on the vertical plane over its edge (B-F) and on the
  // plane 3 m above it (G-N) face away from the beam. Reference: E / (E_hz rho) x 100 is the
  // configuration factor from the point to S2 in percent (the report's Table 17). The planes
  // are calculation objects only, so they shade nothing.
  "materials": {"s2": {"reflectance": [0.5, 0.5, 0.5]}},
  "meshes": [{"file": "floor.obj", "material": "s2", "name": "s2"}],
  "lights": [{"type": "directional", "direction": [%g, %.6f, %.6f], "irradiance": [%.6f, %.6f, %.6f]}],
%s
}
""" % (d56[0], d56[1], d56[2], E56, E56, E56, calc_points("planes", WALL56 + CEIL56)))

L57 = 100.0 / math.pi / LM_PER_W  # rho E_v / pi for rho E_v = 100 lx
FLOOR57 = [(c, (2, 0, 0.25 + 0.5 * k), (0, 1, 0)) for k, c in enumerate("GHIJK")]
write("case_5_7.json", """{
  // CIE 171:2006 case 5.7: diffuse light past an internal obstruction. S2, a 4 m x 3 m wall, is
  // a uniform diffuse source of luminance rho E_v / pi with rho E_v = 100 lx (here as its
  // emission, which is what a uniformly lit Lambertian surface sends); a black 4 m x 1 m x
  // 0.2 m obstruction stands 1.3 m before it. Calculation points on the opposite wall (A-F) and
  // on the floor (G-K): E / (E_v rho) x 100 is the configuration factor to the part of S2 they
  // see (the report's Table 19 as corrected in later validations).
  "materials": {%s, "s2": {"reflectance": [0, 0, 0], "emission": [%.6f, %.6f, %.6f]}},
  "meshes": [
    {"file": "wall_s2.obj", "material": "s2", "name": "s2"},
    {"file": "obstruction.obj", "material": "black", "name": "obstruction"}
  ],
%s
}
""" % (BLACK, L57, L57, L57, calc_points("wall and floor", WALL + FLOOR57)))

I58 = 10000.0 / (4 * math.pi) / LM_PER_W
write("case_5_8.json", """{
  // CIE 171:2006 case 5.8: interreflection in a 4 m cube of uniform diffuse reflectance rho
  // (here 0.8), an isotropic point source of 10,000 lm in its middle. The interreflected
  // illuminance averaged over the 96 m^2 is rho Phi / (S (1 - rho)) (the report's eq. 16,
  // Table 20): 416.7 lx at rho = 0.8.
  "materials": {"paint": {"reflectance": [0.8, 0.8, 0.8]}},
  "meshes": [{"file": "cube.obj", "material": "paint", "name": "cube"}],
  "lights": [{"type": "point", "position": [2, 2, 2], "intensity": [%.6f, %.6f, %.6f]}],
  "calculation": [{"name": "cube", "type": "surface", "mesh": "cube", "spacing": 0.5}]
}
""" % (I58, I58, I58))

# Daylight, cases 5.9 and 5.11: a black room, an unglazed opening, a CIE general sky with the sun
# at 60 degrees (type 12 as written; the tests set each type), E_h = 10,000 lx, so that the lux
# at a point are 100 x its sky component in percent. Roof openings: the A-F wall faces the sun
# (north -z: the sun is south, +z). Facade openings: the window faces the sun (north +z).
def daylight(name, comment, meshes, opening, north, calc, ground=0.0, materials=None):
    write(name, """{
  // %s
  "materials": {%s},
  "meshes": [
%s
  ],
  "sky": {"type": 12, "horizontal_illuminance": 10000, "ground_reflectance": %g,
          "sun": {"elevation_deg": 60, "azimuth_deg": 180}, "north": [0, 0, %d]},
  "openings": [{"name": "opening", "corners": [%s]}],
%s
}
""" % (comment, materials or BLACK, meshes, ground, north,
       ", ".join("[{:g}, {:g}, {:g}]".format(*c) for c in opening), calc))


daylight("case_5_9_1x1.json",
         "CIE 171:2006 case 5.9: the sky component under a 1 m x 1 m unglazed roof opening\n"
         "  // (Tables B.1 and B.2): lux = 100 x SC %.",
         '    {"file": "room.obj", "material": "black", "name": "room"},\n'
         '    {"file": "ceiling_hole.obj", "material": "black", "name": "ceiling"}',
         [(1.5, 3, 1.5), (2.5, 3, 1.5), (2.5, 3, 2.5), (1.5, 3, 2.5)], -1,
         calc_points("wall and floor", WALL + FLOOR))
daylight("case_5_9_4x4.json",
         "CIE 171:2006 case 5.9: the sky component under a 4 m x 4 m unglazed roof opening (the\n"
         "  // whole ceiling; Tables B.3 and B.4): lux = 100 x SC %.",
         '    {"file": "room.obj", "material": "black", "name": "room"}',
         [(0, 3, 0), (4, 3, 0), (4, 3, 4), (0, 3, 4)], -1,
         calc_points("wall and floor", WALL + FLOOR))

# Facade openings (case 5.11): the window wall is z = 0, its outside -z; the points are on the
# wall opposite (A-F at z = 4, facing the window), on the floor (G at z = 3.75, farthest from the
# window, to N at 0.25) and on the ceiling (G'-N', facing down), x = 2.
faces = box_inside(0, 4, 0, 3, 0, 4)
write("facade_room.obj", obj("room", [faces[0], faces[2], faces[3], faces[4], faces[5]],
                             "CIE 171 facade cases: the room less its window wall z = 0"))
write("facade_wall_2x1.obj",
      obj("window wall", [[(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)]
                          for x0, x1, y0, y1 in ((0, 1, 0, 3), (3, 4, 0, 3), (1, 3, 0, 1), (1, 3, 2, 3))],
          "CIE 171 case 5.11: the window wall z = 0 less a 2 m x 1 m opening, sill at 1 m"))
BACK = [(c, (2, 2.75 - 0.5 * k, 4), (0, 0, -1)) for k, c in enumerate("ABCDEF")]
FLOOR11 = [(c, (2, 0, 3.75 - 0.5 * k), (0, 1, 0)) for k, c in enumerate("GHIJKLMN")]
CEIL11 = [(c + "'", (2, 3, 3.75 - 0.5 * k), (0, -1, 0)) for k, c in enumerate("GHIJKLMN")]
daylight("case_5_11_2x1.json",
         "CIE 171:2006 case 5.11: sky and externally reflected components through a 2 m x 1 m\n"
         "  // unglazed window (sill 1 m), ground reflectance 0.3 (Tables B.9-B.11): lux = 100 x %.",
         '    {"file": "facade_room.obj", "material": "black", "name": "room"},\n'
         '    {"file": "facade_wall_2x1.obj", "material": "black", "name": "window wall"}',
         [(1, 1, 0), (3, 1, 0), (3, 2, 0), (1, 2, 0)], 1,
         calc_points("wall floor ceiling", BACK + FLOOR11 + CEIL11), ground=0.3)
daylight("case_5_11_4x3.json",
         "CIE 171:2006 case 5.11: sky and externally reflected components through a 4 m x 3 m\n"
         "  // unglazed window (the whole wall), ground reflectance 0.3 (Tables B.12-B.14).",
         '    {"file": "facade_room.obj", "material": "black", "name": "room"}',
         [(0, 0, 0), (4, 0, 0), (4, 3, 0), (0, 3, 0)], 1,
         calc_points("wall floor ceiling", BACK + FLOOR11 + CEIL11), ground=0.3)

# Cases 5.10 and 5.12: the same openings glazed with 6 mm clear glass, as the report has it: its
# formula for the directional transmittance (the "clear_glass" fall-off), 0.8788 at normal
# incidence.
for src, dst in (("case_5_9_1x1.json", "case_5_10_1x1.json"), ("case_5_9_4x4.json", "case_5_10_4x4.json"),
                 ("case_5_11_2x1.json", "case_5_12_2x1.json"), ("case_5_11_4x3.json", "case_5_12_4x3.json")):
    text = open(os.path.join(HERE, src)).read()
    text = text.replace('"corners": [', '"glazing": {"transmittance": 0.8788, "falloff": "clear_glass"}, "corners": [')
    text = text.replace("unglazed", "glazed").replace("case 5.9", "case 5.10").replace("case 5.11", "case 5.12")
    write(dst, text)

# Cases 5.13 and 5.14: the 2 m x 1 m window of case 5.11 with a mask outside, floor points A (z =
# 3.75, farthest from the window) to H (z = 0.25). 5.13: a horizontal overhang at the top of the
# window wall (y = 3), reaching d = 0.5, 1 or 2 m out (-z), diffuse of reflectance 0.3 below,
# black above. 5.14: a vertical wall 6 m out (z = -6), facing the window, 3, 6 or 9 m high,
# diffuse of reflectance 0.3. Both masks run 100 m either side, as good as unbounded for points
# that see them through the window.
MASKED = BLACK + ', "mask": {"reflectance": [0.3, 0.3, 0.3]}'
# The building's facade around the window, black, 1 mm outside the window wall and 100 m either
# side: a window in a facade, as the report draws it. (A facade only as wide as the room would
# let the overhang's underside see the ground where a building stands, 8% brighter at H.)
write("facade_2x1.obj", obj(
    "facade", [[(x0, y0, -0.001), (x0, y1, -0.001), (x1, y1, -0.001), (x1, y0, -0.001)]
               for x0, x1, y0, y1 in ((-100, 1, 0, 3), (3, 104, 0, 3), (1, 3, 0, 1), (1, 3, 2, 3))],
    "CIE 171 cases 5.13 and 5.14: the facade around the 2 m x 1 m window, facing out"))
FACADE = '    {"file": "facade_2x1.obj", "material": "black", "name": "facade"},\n'
MASK_FLOOR = [(c, (2, 0, 3.75 - 0.5 * k), (0, 1, 0)) for k, c in enumerate("ABCDEFGH")]
for depth in (0.5, 1, 2):
    write(f"overhang_{depth:g}.obj", obj(
        "overhang",
        [[(-100, 3, -depth), (104, 3, -depth), (104, 3, 0), (-100, 3, 0)]],
        f"CIE 171 case 5.13: a {depth:g} m overhang over the window wall, its underside"))
    write(f"overhang_{depth:g}_top.obj", obj(
        "overhang top",
        [[(104, 3.001, 0), (104, 3.001, -depth), (-100, 3.001, -depth), (-100, 3.001, 0)]],
        f"CIE 171 case 5.13: the {depth:g} m overhang's upper side"))
    daylight(f"case_5_13_{depth:g}m.json",
             f"CIE 171:2006 case 5.13: sky and externally reflected components on the floor\n"
             f"  // through the 2 m x 1 m window under a {depth:g} m overhang of reflectance 0.3\n"
             f"  // (Tables B.21-B.23): lux = 100 x %.",
             '    {"file": "facade_room.obj", "material": "black", "name": "room"},\n'
             '    {"file": "facade_wall_2x1.obj", "material": "black", "name": "window wall"},\n'
             + FACADE +
             f'    {{"file": "overhang_{depth:g}.obj", "material": "mask", "name": "overhang"}},\n'
             f'    {{"file": "overhang_{depth:g}_top.obj", "material": "black", "name": "overhang top"}}',
             [(1, 1, 0), (3, 1, 0), (3, 2, 0), (1, 2, 0)], 1,
             calc_points("floor", MASK_FLOOR), ground=0.3, materials=MASKED)
for height in (3, 6, 9):
    write(f"mask_wall_{height}.obj", obj(
        "mask", [[(-100, 0, -6), (104, 0, -6), (104, height, -6), (-100, height, -6)]],
        f"CIE 171 case 5.14: a {height} m high wall 6 m in front of the window, facing it"))
    daylight(f"case_5_14_{height}m.json",
             f"CIE 171:2006 case 5.14: sky and externally reflected components on the floor\n"
             f"  // through the 2 m x 1 m window facing a {height} m high wall of reflectance 0.3,\n"
             f"  // 6 m away (Tables B.24-B.26): lux = 100 x %.",
             '    {"file": "facade_room.obj", "material": "black", "name": "room"},\n'
             '    {"file": "facade_wall_2x1.obj", "material": "black", "name": "window wall"},\n'
             + FACADE +
             f'    {{"file": "mask_wall_{height}.obj", "material": "mask", "name": "mask"}}',
             [(1, 1, 0), (3, 1, 0), (3, 2, 0), (1, 2, 0)], 1,
             calc_points("floor", MASK_FLOOR), ground=0.3, materials=MASKED)

# Case 5.5: the directional transmittance of clear glass. A black roof 3 m up with a 2 m x 2 m
# opening glazed with 6 mm clear glass, lit by a parallel beam of 1000 lx at normal incidence;
# the point 1 mm under the glass's centre, facing up, gets 1000 cos(theta) tau(theta) lx. The
# tests turn the beam (theta from the vertical, towards +x) and the glass's fall-off.
roof = [[(x0, 3, z0), (x1, 3, z0), (x1, 3, z1), (x0, 3, z1)]
        for x0, x1, z0, z1 in ((-5, -1, -5, 5), (1, 5, -5, 5), (-1, 1, -5, -1), (-1, 1, 1, 5))]
write("roof_2x2.obj", obj("roof", roof, "CIE 171 case 5.5: a black roof with a 2 m x 2 m opening"))
E55 = 1000.0 / LM_PER_W
write("case_5_5.json", """{
  // CIE 171:2006 case 5.5: the directional transmittance of clear glass. A parallel beam of
  // 1000 lx (at normal incidence) through a 2 m x 2 m opening glazed with 6 mm clear glass onto
  // the point 1 mm under its centre: 1000 cos(theta) tau(theta) lx, tau the report's formula for
  // clear glass (the glazing's "clear_glass" fall-off). The beam as written is vertical.
  "materials": {%s},
  "meshes": [{"file": "roof_2x2.obj", "material": "black", "name": "roof"}],
  "lights": [{"type": "directional", "direction": [0, -1, 0], "irradiance": [%.6f, %.6f, %.6f]}],
  "openings": [{"name": "glass", "corners": [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]],
                "glazing": {"transmittance": 0.8788, "falloff": "clear_glass"}}],
%s
}
""" % (BLACK, E55, E55, E55, calc_points("under the glass", [("P", (0, 2.999, 0), (0, 1, 0))])))
