/* Ground-truth-based ambient occlusion (Jimenez, Wu, Pesce, Jarabo 2016): the GLSL form of
 * core/kernels/occlusion.py (gtao, blur; core/formulas/occlusion.py gives the method), held to
 * it by tests/gpu/test_stages.py. Buffer pixels are addressed top-first, (qx, qy) from the
 * buffer's top-left corner, as the kernel's; the textures are GPU-ordered (bottom-first).
 *
 * Reads: center_depth (R: view z, A: 1 where a surface was drawn), center_normal, with
 * AO_BLUR raw_ao (gtao's values), and
 * ao.rec (the kernel's rec), ao.params (radius, pixels per metre, orthographic, reach),
 * ao.origin (the buffer's origin in the frame; the region's origin in the buffer). */

#define AO_SLICES 2
#define AO_STEPS 8
#define AO_MIN_SPAN 4.0
#define HALF_PI 1.5707963267948966

const int AO_PATTERN[16] = int[16](0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5);

ivec2 buffer_texel(int qx, int qy)
{
  return ivec2(qx, textureSize(center_depth, 0).y - 1 - qy);
}

/* View-space position of buffer pixel (qx, qy)'s centre; w: 0 where nothing was drawn. */
vec4 ao_position(int qx, int qy)
{
  vec4 d = texelFetch(center_depth, buffer_texel(qx, qy), 0);
  float z = d.r;
  return vec4((ao.rec[0].x * float(qx) + ao.rec[0].y) * z + ao.rec[0].z * float(qx) + ao.rec[0].w,
              (ao.rec[1].x * float(qy) + ao.rec[1].y) * z + ao.rec[1].z * float(qy) + ao.rec[1].w,
              z, d.a);
}

vec3 ao_normal(int qx, int qy, vec3 p, bool ortho)
{
  vec3 n = texelFetch(center_normal, buffer_texel(qx, qy), 0).xyz;
  bool away = ortho ? n.z < 0.0 : dot(n, p) > 0.0;
  return away ? -n : n;
}

float ao_arc(float plen, float gamma, float c2, float c1)
{
  float h2 = acos(clamp(c2, -1.0, 1.0));
  float h1 = -acos(clamp(c1, -1.0, 1.0));
  h1 = gamma + max(h1 - gamma, -HALF_PI);
  h2 = gamma + min(h2 - gamma, HALF_PI);
  float cg = cos(gamma), sg = sin(gamma);
  return plen * (0.25 * (-cos(2.0 * h1 - gamma) + cg + 2.0 * h1 * sg) +
                 0.25 * (-cos(2.0 * h2 - gamma) + cg + 2.0 * h2 * sg));
}

/* kernels.occlusion.gtao at buffer pixel (qx, qy): 1 = open. */
float gtao(int qx, int qy)
{
  ivec2 bsize = textureSize(center_depth, 0);
  float radius = ao.params.x, scale = ao.params.y, reach = ao.params.w;
  bool ortho = ao.params.z > 0.5;
  vec4 p4 = ao_position(qx, qy);
  if (p4.w == 0.0) {
    return 1.0;
  }
  vec3 p = p4.xyz;
  vec3 n = ao_normal(qx, qy, p, ortho);
  vec3 v;
  float span;
  if (ortho) {
    v = vec3(0.0, 0.0, 1.0);
    span = radius * scale;
  }
  else {
    float d = length(p);
    if (d <= 1e-9 || p.z >= 0.0) {
      return 1.0;
    }
    v = -p / d;
    span = radius * scale / -p.z;
  }
  span = min(span, reach);
  if (span < AO_MIN_SPAN) {
    return 1.0;
  }
  float lift = ortho ? span / max(radius * scale, 1e-12) : -p.z / scale;
  p += n * lift;
  float sx = float(qx) + 0.5, sy = float(qy) + 0.5;
  int cell_x = (qx + ao.origin.x) & 3, cell_y = (qy + ao.origin.y) & 3;
  float turn = 3.141592653589793 / float(AO_SLICES);
  float jitter = (float(AO_PATTERN[cell_y * 4 + cell_x]) + 0.5) / 16.0;
  float step_jitter = (float(AO_PATTERN[cell_x * 4 + cell_y]) + 0.5) / 16.0;
  float dx = cos(jitter * turn), dy = sin(jitter * turn);
  float cs = cos(turn), ss = sin(turn);
  float r2 = radius * radius;
  float total = 0.0;
  for (int s = 0; s < AO_SLICES; s++) {
    if (s > 0) {
      float ndx = dx * cs - dy * ss;
      dy = dx * ss + dy * cs;
      dx = ndx;
    }
    float k = dx * v.x - dy * v.y;
    vec3 t = vec3(dx - k * v.x, -dy - k * v.y, -k * v.z);
    float tl = length(t);
    if (tl < 1e-9) {
      continue;
    }
    t /= tl;
    float an = dot(n, v), at = dot(n, t);
    float plen = sqrt(an * an + at * at);
    if (plen < 1e-9) {
      continue;
    }
    float c[2];
    for (int side = 0; side < 2; side++) {
      float sign = side == 0 ? 1.0 : -1.0;
      float best = -1.0;
      for (int step = 0; step < AO_STEPS; step++) {
        float tt = (float(step) + step_jitter) / float(AO_STEPS) * span + 0.5;
        int ax = int(floor(sx + sign * dx * tt));
        int ay = int(floor(sy + sign * dy * tt));
        if (ax < 0 || ay < 0 || ax >= bsize.x || ay >= bsize.y) {
          break;
        }
        vec4 w4 = ao_position(ax, ay);
        if (w4.w == 0.0) {
          continue;
        }
        vec3 w = w4.xyz - p;
        float d2 = dot(w, w);
        if (d2 < 1e-18 || d2 > r2) {
          continue;
        }
        best = max(best, dot(w, v) / sqrt(d2));
      }
      c[side] = best;
    }
    total += ao_arc(plen, atan(at, an), c[0], c[1]);
  }
  return clamp(total / float(AO_SLICES), 0.0, 1.0);
}

#ifdef AO_BLUR
/* kernels.occlusion.blur at buffer pixel (qx, qy): the mean of the raw values (raw_ao, the
 * region's pixels at ao.origin.zw in the buffer, GPU-ordered) over the 4 x 4 block around
 * it on its own surface. */
float ao_blur(int qx, int qy, float tolerance)
{
  ivec2 rsize = textureSize(raw_ao, 0);
  bool ortho = ao.params.z > 0.5;
  int rx = ao.origin.z, ry = ao.origin.w;
  float own = texelFetch(raw_ao, ivec2(qx - rx, rsize.y - 1 - (qy - ry)), 0).r;
  vec4 p4 = ao_position(qx, qy);
  if (p4.w == 0.0) {
    return own;
  }
  vec3 n = ao_normal(qx, qy, p4.xyz, ortho);
  float limit = tolerance * (ortho ? 1.0 : -p4.z);
  float total = 0.0, weight = 0.0;
  for (int a = qy - 2; a < qy + 2; a++) {
    for (int b = qx - 2; b < qx + 2; b++) {
      vec4 q4 = ao_position(b, a);
      if (q4.w == 0.0) {
        continue;
      }
      vec3 m = ao_normal(b, a, q4.xyz, ortho);
      if (dot(n, m) < 0.8) {
        continue;
      }
      if (abs(dot(q4.xyz - p4.xyz, n)) > limit) {
        continue;
      }
      total += texelFetch(raw_ao, ivec2(b - rx, rsize.y - 1 - (a - ry)), 0).r;
      weight += 1.0;
    }
  }
  return weight > 0.0 ? total / weight : own;
}
#endif
