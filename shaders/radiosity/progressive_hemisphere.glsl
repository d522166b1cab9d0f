// The shooter's view of the scene (Wallner sec. 3, after Coombe et al. 2003): a hemispherical
// stereographic projection around the shooter point's normal, with the linear depth of the
// paper's Algorithm 1 between the front plane fp = 0 (the shooter point) and the back plane
// bp = `far` (the scene's diagonal): depth = distance / bp in [0, 1].
//
// Only vertices go through the projection (the paper's source of error near the equator), so
// both passes work on the same small pieces: every triangle is split into a k x k grid of
// sub-triangles in its barycentric parameters (w1, w2) (k = GpuProgressiveTriangle.tessellation)
// and each sub-triangle is clipped against the shooter's plane before projecting (the paper
// culls triangles behind the plane; the clip keeps the part of a straddling one in front, with
// its new corners on the equator). The depth pass rasterises the clipped pieces; the
// receiver pass back-projects an element by interpolating the images of the corners of the very
// piece that contains it, which is exactly what the rasteriser interpolated there (sec. 3: "this
// way the same error occurs during back projection as observed in the creation of the
// visibility texture").
//
// Needs GpuProgressiveTriangle (progressive_layout.glsl).

struct Hemisphere {
  vec3 origin;      // the shooter point (m)
  vec3 tangent;     // image x axis
  vec3 bitangent;   // image y axis
  vec3 normal;      // the shooter's unit front normal: the pole
  float inv_far;    // 1 / bp
  float on_plane;   // points at most this far in front of the plane count as on it (m)
};

// The depth maps of a batch of shooter points share one depth texture, tile k of a
// tiles x tiles grid holding point k's hemisphere: image (x, y) in [-1, 1]^2 maps to
// ((x, y) * 0.5 + 0.5 + tile) / tiles in texture coordinates.
vec2 tileOrigin(uint k, uint tiles) {
  return vec2(float(k % tiles), float(k / tiles));
}

// Stereographic image (x, y) in the unit disc and linear depth of a point on or in front of
// the shooter's plane.
vec3 hemisphereProject(Hemisphere h, vec3 p) {
  const vec3 d = p - h.origin;
  const float dist = length(d);
  if (!(dist > 0.0)) return vec3(0.0);
  const vec3 dir = d / dist;
  const float z = max(dot(dir, h.normal), 0.0);  // clipped points lie on or in front
  const vec2 s = vec2(dot(dir, h.tangent), dot(dir, h.bitangent)) / (1.0 + z);
  return vec3(s, dist * h.inv_far);
}

// Sub-triangle code: i | j << 8 | down << 16 in the k x k grid of a triangle's parameters.
uint subTriangleCode(int i, int j, bool down) {
  return uint(i) | (uint(j) << 8) | (down ? (1u << 16) : 0u);
}

// Barycentric parameters (w1, w2) of the corners of sub-triangle `code`: the upright one at
// (i, j) has corners (i, j), (i+1, j), (i, j+1); the inverted one (i+1, j), (i+1, j+1), (i, j+1);
// all divided by k.
void subTriangleCorners(uint code, uint k, out vec2 q[3]) {
  const float i = float(code & 0xffu), j = float((code >> 8) & 0xffu);
  const float inv = 1.0 / float(k);
  if ((code >> 16) == 0u) {
    q[0] = vec2(i, j) * inv;
    q[1] = vec2(i + 1.0, j) * inv;
    q[2] = vec2(i, j + 1.0) * inv;
  } else {
    q[0] = vec2(i + 1.0, j) * inv;
    q[1] = vec2(i + 1.0, j + 1.0) * inv;
    q[2] = vec2(i, j + 1.0) * inv;
  }
}

vec3 trianglePoint(GpuProgressiveTriangle t, vec2 q) {
  return t.p0 + q.x * (t.p1 - t.p0) + q.y * (t.p2 - t.p0);
}

// A sub-triangle clipped to the open half-space in front of the shooter's plane: up to 4
// corners, each with its parameters and its image (x, y, depth). Drawn as the fan (0, 1, 2),
// (0, 2, 3). Points on the plane (within `on_plane`, the float rounding of coplanar geometry)
// count as behind it: the shooter's own triangle and its coplanar neighbours would otherwise
// project their corners onto the equator as a large inscribed triangle of near depth.
struct ClippedPiece {
  int count;
  vec2 param[4];
  vec3 image[4];
};

ClippedPiece clipSubTriangle(Hemisphere h, GpuProgressiveTriangle t, uint code) {
  vec2 q[3];
  subTriangleCorners(code, t.tessellation, q);
  vec3 w[3];
  float dist[3];
  for (int c = 0; c < 3; ++c) {
    w[c] = trianglePoint(t, q[c]);
    dist[c] = dot(h.normal, w[c] - h.origin) - h.on_plane;
  }
  // Rotate the corners so that the one alone on its side of the plane (if any) comes first,
  // keeping their cyclic order; then there are four cases, all with fixed indices (no
  // variable-length arrays: a SIMD rasteriser runs these much faster).
  const bool f0 = dist[0] > 0.0, f1 = dist[1] > 0.0, f2 = dist[2] > 0.0;
  const int odd = f1 != f0 && f1 != f2 ? 1 : (f2 != f0 && f2 != f1 ? 2 : 0);
  const int ib = (odd + 1) % 3, ic = (odd + 2) % 3;
  const vec2 qa = odd == 0 ? q[0] : (odd == 1 ? q[1] : q[2]);
  const vec2 qb = ib == 0 ? q[0] : (ib == 1 ? q[1] : q[2]);
  const vec2 qc = ic == 0 ? q[0] : (ic == 1 ? q[1] : q[2]);
  const vec3 wa = odd == 0 ? w[0] : (odd == 1 ? w[1] : w[2]);
  const vec3 wb = ib == 0 ? w[0] : (ib == 1 ? w[1] : w[2]);
  const vec3 wc = ic == 0 ? w[0] : (ic == 1 ? w[1] : w[2]);
  const float da = odd == 0 ? dist[0] : (odd == 1 ? dist[1] : dist[2]);
  const float db = ib == 0 ? dist[0] : (ib == 1 ? dist[1] : dist[2]);
  const float dc = ic == 0 ? dist[0] : (ic == 1 ? dist[1] : dist[2]);
  const bool a_front = da > 0.0, bc_front = db > 0.0;  // b and c are on the same side
  // Crossings of the edges a-b and a-c with the plane (used only when a is alone).
  const float sb = da / (da - db), sc = da / (da - dc);
  const vec2 qab = mix(qa, qb, sb), qac = mix(qa, qc, sc);
  const vec3 wab = mix(wa, wb, sb), wac = mix(wa, wc, sc);
  // Wholly in front: a, b, c. Only a in front: a, ab, ac. Only a behind: the quadrilateral
  // ab, b, c, ac. Wholly behind: nothing. (Selected, then projected once each.)
  const bool all = a_front && bc_front, only_a = a_front && !bc_front;
  const bool quad = !a_front && bc_front;
  ClippedPiece piece;
  piece.count = all || only_a ? 3 : (quad ? 4 : 0);
  piece.param[0] = quad ? qab : qa;
  piece.param[1] = only_a ? qab : qb;
  piece.param[2] = only_a ? qac : qc;
  piece.param[3] = quad ? qac : piece.param[2];
  const vec3 p0 = quad ? wab : wa, p1 = only_a ? wab : wb, p2 = only_a ? wac : wc;
  piece.image[0] = hemisphereProject(h, p0);
  piece.image[1] = hemisphereProject(h, p1);
  piece.image[2] = hemisphereProject(h, p2);
  piece.image[3] = quad ? hemisphereProject(h, wac) : piece.image[2];
  return piece;
}

// Barycentric coordinates of p in the 2-D triangle (a, b, c).
vec3 planarBarycentric(vec2 p, vec2 a, vec2 b, vec2 c) {
  const vec2 e1 = b - a, e2 = c - a, r = p - a;
  const float det = e1.x * e2.y - e1.y * e2.x;
  if (det == 0.0) return vec3(1.0, 0.0, 0.0);
  const float u = (r.x * e2.y - r.y * e2.x) / det, v = (e1.x * r.y - e1.y * r.x) / det;
  return vec3(1.0 - u - v, u, v);
}

// The back projection of the point with barycentric parameters q = (w1, w2) of triangle t:
// its image (x, y, depth) interpolated over the clipped sub-triangle that contains it, as the
// depth pass rasterised it. False when that piece lies wholly behind the plane.
bool backProject(Hemisphere h, GpuProgressiveTriangle t, vec2 q, out vec3 image) {
  const int k = int(t.tessellation);
  const vec2 a = q * float(k);
  const int i = clamp(int(floor(a.x)), 0, k - 1);
  const int j = clamp(int(floor(a.y)), 0, k - 1 - i);
  const vec2 f = a - vec2(float(i), float(j));
  const bool down = f.x + f.y > 1.0 && i + j < k - 1;
  const ClippedPiece piece = clipSubTriangle(h, t, subTriangleCode(i, j, down));
  // The fan triangle containing q: the second one when q lies past the first's edge 0-2.
  const vec3 l1 = planarBarycentric(q, piece.param[0], piece.param[1], piece.param[2]);
  const vec3 l2 = planarBarycentric(q, piece.param[0], piece.param[2], piece.param[3]);
  const bool second = piece.count == 4 && l1.y < 0.0;
  image = second ? l2.x * piece.image[0] + l2.y * piece.image[2] + l2.z * piece.image[3]
                 : l1.x * piece.image[0] + l1.y * piece.image[1] + l1.z * piece.image[2];
  return piece.count >= 3;
}
