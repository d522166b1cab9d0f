#!/usr/bin/python3
"""Scenes and ray files made without Penumbra's code, for comparing `penumbra trace` with Embree
on input the project did not generate (bench/trace_vs_embree.sh).

Every set is in the ray file layout of docs/cli.md (8 little-endian float32 per ray:
ox oy oz tmin dx dy dz tmax), in the order a user's program would write it (random order for
the incoherent sets, no sorting).

  external_rays.py scene BUNNY.ply OUT.ply [--copies 16]   16 bunnies on a floor, 1.1M triangles
  external_rays.py city OUT.ply [--blocks 40]              a city of boxes: 40 x 40 blocks of
                                                            16 towers, 307k triangles
  external_rays.py rock OUT.ply [--level 8]                a noise-displaced sphere of 524k
                                                            triangles, dense and irregular as
                                                            a scan
  external_rays.py rays MESH.ply KIND OUT.bin [--count N] [--seed S]

KIND:
  camera     N = W*W pinhole rays (W = sqrt N), 45 degree view, rows from the bottom, tmin 0,
             unit directions, tmax +inf
  diffuse    random surface points (by area), cosine about either side's normal, tmin 1e-4 of
             the scene diagonal, tmax +inf
  shadow     segments between two random surface points: direction = q - p (not unit),
             tmin 1e-4, tmax 1 - 1e-4 (occlusion rays)
  ao         as diffuse, but tmax 2% of the diagonal, tmin 1e-3 of it (short rays)
  short      as ao but 0.2% of the diagonal long: rays that end near where they start
  long       segments between two random points on the scene's bounding sphere, closest hit
  outside    origins on a sphere of twice the scene's radius, towards uniform points in its
             box, tmin 0, unnormalised directions of length 0.5 to 5
"""

import argparse
import sys

import numpy as np


def read_ply(path):
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline()
            if not line:
                sys.exit(f"{path}: no end_header")
            line = line.decode("ascii").strip()
            header.append(line)
            if line == "end_header":
                break
        fmt = next(h.split()[1] for h in header if h.startswith("format"))
        nv = int(next(h.split()[2] for h in header if h.startswith("element vertex")))
        nf = int(next(h.split()[2] for h in header if h.startswith("element face")))
        vprops = []
        in_vertex = False
        for h in header:
            if h.startswith("element"):
                in_vertex = h.startswith("element vertex")
            elif h.startswith("property") and in_vertex:
                vprops.append(h.split()[1])
        if fmt == "ascii":
            rest = f.read().decode("ascii").split()
            vals = np.array(rest[: nv * len(vprops)], dtype=np.float64).reshape(nv, len(vprops))
            verts = vals[:, :3].astype(np.float32)
            pos = nv * len(vprops)
            faces = []
            for _ in range(nf):
                n = int(rest[pos])
                idx = [int(x) for x in rest[pos + 1 : pos + 1 + n]]
                pos += 1 + n
                faces += [(idx[0], idx[k], idx[k + 1]) for k in range(1, n - 1)]
            return verts, np.array(faces, dtype=np.int64)
        sizes = {"float": "<f4", "double": "<f8", "uchar": "u1", "int": "<i4", "uint": "<u4"}
        vdt = np.dtype([(f"p{i}", sizes[t]) for i, t in enumerate(vprops)])
        vraw = np.frombuffer(f.read(vdt.itemsize * nv), dtype=vdt)
        verts = np.stack([vraw["p0"], vraw["p1"], vraw["p2"]], axis=1).astype(np.float32)
        data = f.read()
        # Faces as uchar count + int32 indices; triangles take the fast path.
        tri = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
        if len(data) >= tri.itemsize * nf:
            f3 = np.frombuffer(data[: tri.itemsize * nf], dtype=tri)
            if np.all(f3["n"] == 3):
                return verts, f3["i"].astype(np.int64)
        sys.exit(f"{path}: only triangle faces are read by this script")


def write_ply(path, verts, faces):
    with open(path, "wb") as f:
        f.write(
            (
                "ply\nformat binary_little_endian 1.0\n"
                f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
                f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
            ).encode("ascii")
        )
        f.write(np.ascontiguousarray(verts, dtype="<f4").tobytes())
        rec = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
        rec["n"] = 3
        rec["i"] = faces
        f.write(rec.tobytes())


def make_scene(bunny, out, copies, seed):
    v, f = read_ply(bunny)
    rng = np.random.default_rng(seed)
    lo, hi = v.min(0), v.max(0)
    size = float((hi - lo).max())
    centre = np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2], np.float32)
    grid = int(np.ceil(np.sqrt(copies)))
    all_v, all_f = [], []
    base = 0
    for c in range(copies):
        ang = rng.uniform(0, 2 * np.pi)
        rot = np.array(
            [[np.cos(ang), 0, np.sin(ang)], [0, 1, 0], [-np.sin(ang), 0, np.cos(ang)]], np.float32
        )
        scale = rng.uniform(0.6, 1.4)
        offset = np.array(
            [(c % grid) * size * 0.9 + rng.uniform(-0.2, 0.2) * size, 0.0,
             (c // grid) * size * 0.9 + rng.uniform(-0.2, 0.2) * size],
            np.float32,
        )
        all_v.append(((v - centre) @ rot.T) * scale + offset)
        all_f.append(f + base)
        base += len(v)
    verts = np.concatenate(all_v)
    faces = np.concatenate(all_f)
    # A floor under them: two triangles.
    lo, hi = verts.min(0), verts.max(0)
    m = 0.2 * size
    floor = np.array(
        [[lo[0] - m, lo[1], lo[2] - m], [hi[0] + m, lo[1], lo[2] - m],
         [hi[0] + m, lo[1], hi[2] + m], [lo[0] - m, lo[1], hi[2] + m]],
        np.float32,
    )
    faces = np.concatenate([faces, np.array([[base, base + 2, base + 1], [base, base + 3, base + 2]])])
    verts = np.concatenate([verts, floor])
    write_ply(out, verts, faces)
    print(f"{out}: {len(verts)} vertices, {len(faces)} triangles")


def box_mesh(lo, hi):
    """The 12 triangles of an axis-aligned box, outward."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                  [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], np.float32)
    f = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                  [3, 7, 6], [3, 6, 2], [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]], np.int64)
    return v, f


def make_city(out, blocks, seed):
    """Blocks of towers on a ground plane: many boxes of very different heights, long streets
    between them (a ray set's worst case for trees of long thin boxes)."""
    rng = np.random.default_rng(seed)
    all_v, all_f, base = [], [], 0
    block, street = 100.0, 20.0
    for bx in range(blocks):
        for bz in range(blocks):
            x0, z0 = bx * (block + street), bz * (block + street)
            # 4 x 4 lots of towers per block, heights log-normal (a few skyscrapers).
            for lx in range(4):
                for lz in range(4):
                    w = rng.uniform(12.0, 24.0)
                    d = rng.uniform(12.0, 24.0)
                    h = float(np.clip(rng.lognormal(3.3, 0.7), 5.0, 400.0))
                    cx, cz = x0 + 12.5 + 25.0 * lx, z0 + 12.5 + 25.0 * lz
                    v, f = box_mesh((cx - w / 2, 0.0, cz - d / 2), (cx + w / 2, h, cz + d / 2))
                    all_v.append(v)
                    all_f.append(f + base)
                    base += len(v)
    size = blocks * (block + street)
    g, gf = box_mesh((-street, -1.0, -street), (size, 0.0, size))
    all_v.append(g)
    all_f.append(gf + base)
    verts, faces = np.concatenate(all_v), np.concatenate(all_f)
    write_ply(out, verts, faces)
    print(f"{out}: {len(verts)} vertices, {len(faces)} triangles")


def make_rock(out, level, seed):
    """A sphere subdivided `level` times from an octahedron (8 x 4^level triangles), pushed in
    and out along its normals by a sum of random waves: an irregular surface of small triangles,
    as a scan is."""
    rng = np.random.default_rng(seed)
    n = 2 ** level
    # Each face of the octahedron as a triangular grid, vertices projected to the sphere.
    verts, faces = [], []
    corners = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, -1]], float)
    octa = [(0, 1, 2), (1, 3, 2), (3, 4, 2), (4, 0, 2), (1, 0, 5), (3, 1, 5), (4, 3, 5), (0, 4, 5)]
    base = 0
    ii, jj = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = ii + jj <= n
    ii, jj = ii[keep], jj[keep]
    index = -np.ones((n + 1, n + 1), np.int64)
    index[ii, jj] = np.arange(len(ii))
    tri = []
    for i in range(n):
        for j in range(n - i):
            tri.append((index[i, j], index[i + 1, j], index[i, j + 1]))
            if j < n - i - 1:
                tri.append((index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]))
    tri = np.array(tri, np.int64)
    for a, b, c in octa:
        pa, pb, pc = corners[a], corners[b], corners[c]
        p = pa + (ii[:, None] / n) * (pb - pa) + (jj[:, None] / n) * (pc - pa)
        verts.append(p / np.linalg.norm(p, axis=1)[:, None])
        faces.append(tri + base)
        base += len(p)
    v = np.concatenate(verts)
    f = np.concatenate(faces)
    # Waves of random direction, frequency (1 to 40 per radius) and amplitude ~ 1/frequency.
    r = np.ones(len(v))
    for _ in range(48):
        k = rng.normal(size=3)
        k /= np.linalg.norm(k)
        freq = np.exp(rng.uniform(0.0, np.log(40.0)))
        r += 0.25 / freq * np.sin(freq * (v @ k) + rng.uniform(0, 2 * np.pi))
    v = (v * r[:, None] * 100.0).astype(np.float32)
    write_ply(out, v, f)
    print(f"{out}: {len(v)} vertices, {len(f)} triangles")


def surface_points(v, f, n, rng):
    p0, p1, p2 = v[f[:, 0]].astype(np.float64), v[f[:, 1]].astype(np.float64), v[f[:, 2]].astype(np.float64)
    cross = np.cross(p1 - p0, p2 - p0)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    keep = area > 0
    cdf = np.cumsum(area)
    t = np.searchsorted(cdf, rng.uniform(0, cdf[-1], n), side="right").clip(0, len(f) - 1)
    t = np.where(keep[t], t, np.argmax(area))
    r1, r2 = rng.uniform(size=n), rng.uniform(size=n)
    s = np.sqrt(r1)
    b0, b1, b2 = 1 - s, s * (1 - r2), s * r2
    p = b0[:, None] * p0[t] + b1[:, None] * p1[t] + b2[:, None] * p2[t]
    normal = cross[t] / np.linalg.norm(cross[t], axis=1)[:, None]
    return p, normal


def cosine_about(normal, rng):
    n = len(normal)
    # Orthonormal frame by the branchless construction of Duff et al. (JCGT 2017).
    sign = np.where(normal[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + normal[:, 2])
    b = normal[:, 0] * normal[:, 1] * a
    t = np.stack([1 + sign * normal[:, 0] ** 2 * a, sign * b, -sign * normal[:, 0]], 1)
    bt = np.stack([b, sign + normal[:, 1] ** 2 * a, -normal[:, 1]], 1)
    r1, r2 = rng.uniform(size=n), rng.uniform(size=n)
    r = np.sqrt(r1)
    phi = 2 * np.pi * r2
    x, y, z = r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0.0, 1 - r1))
    return x[:, None] * t + y[:, None] * bt + z[:, None] * normal


def make_rays(mesh, kind, out, count, seed):
    v, f = read_ply(mesh)
    rng = np.random.default_rng(seed)
    lo, hi = v.min(0).astype(np.float64), v.max(0).astype(np.float64)
    diag = float(np.linalg.norm(hi - lo))
    centre = (lo + hi) / 2
    rays = np.zeros((count, 8), np.float32)
    if kind == "camera":
        w = int(round(np.sqrt(count)))
        if w * w != count:
            sys.exit("camera: --count must be a square")
        eye = centre + diag * np.array([0.35, 0.25, 0.9])
        fwd = centre - eye
        fwd /= np.linalg.norm(fwd)
        right = np.cross(fwd, [0.0, 1.0, 0.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        half = np.tan(np.radians(45.0) / 2)
        ys, xs = np.mgrid[0:w, 0:w]
        sx = ((xs + 0.5) / w * 2 - 1) * half
        sy = ((ys + 0.5) / w * 2 - 1) * half  # row 0 at the bottom
        d = fwd + sx.reshape(-1, 1) * right + sy.reshape(-1, 1) * up
        d /= np.linalg.norm(d, axis=1)[:, None]
        rays[:, 0:3] = eye
        rays[:, 3] = 0
        rays[:, 4:7] = d
        rays[:, 7] = np.inf
    elif kind in ("diffuse", "ao", "short"):
        p, normal = surface_points(v, f, count, rng)
        side = np.where(rng.uniform(size=count) < 0.5, 1.0, -1.0)[:, None]
        rays[:, 0:3] = p
        rays[:, 4:7] = cosine_about(normal * side, rng)
        if kind == "diffuse":
            rays[:, 3] = 1e-4 * diag
            rays[:, 7] = np.inf
        elif kind == "ao":
            rays[:, 3] = 1e-3 * diag
            rays[:, 7] = 0.02 * diag
        else:
            rays[:, 3] = 1e-4 * diag
            rays[:, 7] = 0.002 * diag
    elif kind == "long":
        u = rng.normal(size=(count, 3))
        u /= np.linalg.norm(u, axis=1)[:, None]
        w = rng.normal(size=(count, 3))
        w /= np.linalg.norm(w, axis=1)[:, None]
        o = centre + diag / 2 * u
        rays[:, 0:3] = o
        rays[:, 3] = 0
        rays[:, 4:7] = centre + diag / 2 * w - o
        rays[:, 7] = 1
    elif kind == "shadow":
        p, _ = surface_points(v, f, count, rng)
        q, _ = surface_points(v, f, count, rng)
        rays[:, 0:3] = p
        rays[:, 3] = 1e-4
        rays[:, 4:7] = q - p
        rays[:, 7] = 1 - 1e-4
        same = np.all(rays[:, 4:7] == 0, axis=1)
        rays[same, 4:7] = [0, 1, 0]
    elif kind == "outside":
        radius = diag / 2
        u = rng.normal(size=(count, 3))
        u /= np.linalg.norm(u, axis=1)[:, None]
        o = centre + 2 * radius * u
        target = lo + rng.uniform(size=(count, 3)) * (hi - lo)
        d = target - o
        d *= (rng.uniform(0.5, 5.0, count) / np.linalg.norm(d, axis=1))[:, None]
        rays[:, 0:3] = o
        rays[:, 3] = 0
        rays[:, 4:7] = d
        rays[:, 7] = np.inf
    else:
        sys.exit(f"unknown kind '{kind}'")
    rays.astype("<f4").tofile(out)
    print(f"{out}: {count} {kind} rays")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("city")
    c.add_argument("out")
    c.add_argument("--blocks", type=int, default=40)
    c.add_argument("--seed", type=int, default=5)
    k = sub.add_parser("rock")
    k.add_argument("out")
    k.add_argument("--level", type=int, default=8)
    k.add_argument("--seed", type=int, default=7)
    s = sub.add_parser("scene")
    s.add_argument("bunny")
    s.add_argument("out")
    s.add_argument("--copies", type=int, default=16)
    s.add_argument("--seed", type=int, default=3)
    r = sub.add_parser("rays")
    r.add_argument("mesh")
    r.add_argument("kind")
    r.add_argument("out")
    r.add_argument("--count", type=int, default=1 << 20)
    r.add_argument("--seed", type=int, default=11)
    a = ap.parse_args()
    if a.cmd == "scene":
        make_scene(a.bunny, a.out, a.copies, a.seed)
    elif a.cmd == "city":
        make_city(a.out, a.blocks, a.seed)
    elif a.cmd == "rock":
        make_rock(a.out, a.level, a.seed)
    else:
        make_rays(a.mesh, a.kind, a.out, a.count, a.seed)


if __name__ == "__main__":
    main()
