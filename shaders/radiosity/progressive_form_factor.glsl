// Form factors of the progressive shooting step, the GLSL twins of the CPU solver's
// (src/penumbra/radiosity/progressive.cpp, kernels/form_factor.h), in single precision.

const float kPi = 3.14159265358979;

// Wallner eq. 2 with one disc (m = 1): from a receiver point to a shooter element of area
// `shooter_area` at squared distance d2, given both cosines.
float discFormFactor(float shooter_area, float cos_shooter, float cos_receiver, float d2) {
  return shooter_area * cos_shooter * cos_receiver / (kPi * d2 + shooter_area);
}

// Lambert's point-to-polygon form factor (kernels/form_factor.h, pointToPolygonFormFactor): from
// a differential area at x with unit normal n to the convex polygon `poly` (8 corners; repeat
// the last corner to pad a smaller one: a zero-length edge adds nothing), the part below the
// tangent plane of x clipped away. The clip is done edge by edge (the CPU clips the polygon
// first, Sutherland-Hodgman): an edge leaving the half-space ends at its crossing, one entering
// starts at its crossing, and the crossings are joined by the closing edge along the plane; the
// same edges, so the same sum. Fixed-size loops without dynamic indexing, which a SIMD
// rasteriser runs much faster than the CPU's variable-length arrays.
float edgeTerm(vec3 x, vec3 n, vec3 a, vec3 b) {
  const vec3 r0 = a - x, r1 = b - x;
  const vec3 c = cross(r0, r1);
  const float len = length(c);
  return len > 0.0 ? atan(len, dot(r0, r1)) * dot(n, c) / len : 0.0;  // x on the edge's line: 0
}

float pointToPolygonFormFactor(vec3 x, vec3 n, vec3 poly[8]) {
  // A polygon lying in the tangent plane (the other side of the receiver's own surface)
  // subtends no projected solid angle; Lambert's sum would count it as the whole hemisphere.
  float height = 0.0, extent = 0.0;
  for (int k = 0; k < 8; ++k) {
    height = max(height, dot(n, poly[k] - x));
    extent = max(extent, length(poly[k] - x));
  }
  if (height <= 1e-4 * extent) return 0.0;
  float sum = 0.0;
  vec3 exit_point = vec3(0.0), entry_point = vec3(0.0);
  bool exits = false, enters = false;
  for (int k = 0; k < 8; ++k) {
    const vec3 a = poly[k], b = poly[(k + 1) & 7];
    const float da = dot(n, a - x), db = dot(n, b - x);
    const bool ka = da >= 0.0, kb = db >= 0.0;
    const vec3 p = ka != kb ? a + (b - a) * (da / (da - db)) : a;
    if (ka && kb) sum += edgeTerm(x, n, a, b);
    if (ka && !kb) {
      sum += edgeTerm(x, n, a, p);
      exit_point = p;
      exits = true;
    }
    if (!ka && kb) {
      sum += edgeTerm(x, n, p, b);
      entry_point = p;
      enters = true;
    }
  }
  if (exits && enters) sum += edgeTerm(x, n, exit_point, entry_point);
  return abs(sum) / (2.0 * kPi);
}
