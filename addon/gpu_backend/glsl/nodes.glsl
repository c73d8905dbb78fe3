/* The operations of material programs: the GLSL form of core/scene/node_math (Cycles' SVM
 * formulas with their "safe" guards) and of core/scene/nodes, held to them node by node by
 * tests/gpu/test_materials.py. A value is a vec4 whatever its width (a float in .x, a colour or
 * vector in .xyz); the generated code (gpu_backend/materials.py) widens a float to vec4(x)
 * where NumPy would broadcast it. */

#define N_PI 3.141592653589793
#define N_FLT_EPSILON 1.1920929e-07

/* What a program reads at a point (core/scene/material.Points). */
struct MatPoint {
  vec3 position, normal, geo, view;  /* normal and geo face the viewer */
  float backfacing;
  vec2 window;
  int object;  /* the object instance */
  vec2 shift;  /* where the point is in the mix of the corner attributes' changes */
};

/* The talk's parameters a material gives at a point (core/scene/material.SurfaceParams) */
struct MatSurface {
  vec3 albedo, rf0, emission, normal;
  float gloss, alpha, occlusion, layer, layer_f0;
};

/* Given by the environment (gpu_backend/materials.py) */
MatPoint mp_moved(MatPoint p, int axis, float step);
vec4 mp_object(MatPoint p, int k);
vec3 mp_camera(vec3 position);
vec4 mp_image(int t, vec2 uv, float lod, int associate);
vec4 mat_const(int k);  /* row k of the programs' values (materials.Constants) */

/* The active UV map at a point: its value and change per axis, set by the environment */
vec3 mp_uv0;
vec3 mp_duv[2];

vec3 mp_uv(MatPoint p)
{
  return vec3((mp_uv0 + p.shift.x * mp_duv[0] + p.shift.y * mp_duv[1]).xy, 0.0);
}

float n_finite(float v)
{
  return (isnan(v) || isinf(v)) ? 0.0 : v;
}

vec4 n_finite(vec4 v)
{
  return vec4(n_finite(v.x), n_finite(v.y), n_finite(v.z), n_finite(v.w));
}

float n_safe_div(float a, float b)
{
  return b != 0.0 ? a / b : 0.0;
}

vec4 n_safe_div(vec4 a, vec4 b)
{
  return vec4(n_safe_div(a.x, b.x), n_safe_div(a.y, b.y), n_safe_div(a.z, b.z),
              n_safe_div(a.w, b.w));
}

/* np.power with Cycles' guard: a negative base to a non-integer exponent gives 0 */
float n_safe_pow(float a, float b)
{
  if (a < 0.0) {
    if (b != floor(b)) {
      return 0.0;
    }
    float m = pow(-a, b);
    return mod(b, 2.0) == 1.0 ? -m : m;
  }
  if (a == 0.0) {
    return b == 0.0 ? 1.0 : 0.0;  /* 0 to a negative power overflows: 0 */
  }
  return pow(a, b);
}

vec4 n_safe_pow(vec4 a, vec4 b)
{
  return vec4(n_safe_pow(a.x, b.x), n_safe_pow(a.y, b.y), n_safe_pow(a.z, b.z),
              n_safe_pow(a.w, b.w));
}

float n_safe_log(float a, float b)
{
  if (!(a > 0.0 && b > 0.0)) {
    return 0.0;
  }
  return n_finite(log(a) / log(b));
}

/* C's fmod (np.fmod), exact: the sign of a, less than |b|; a for an infinite b */
float n_fmod(float a, float b)
{
  if (b == 0.0 || isinf(a) || isnan(a) || isnan(b)) {
    return 0.0;
  }
  if (isinf(b)) {
    return a;
  }
  float q = trunc(a / b);
  /* a - b q exactly (an exact result: fmod's is representable), with b q as the rounded
   * product plus its error (Dekker's two-product; `precise`: no contraction or
   * reassociation) */
  precise float p = b * q;
  precise float tb = 4097.0 * b, tq = 4097.0 * q;
  precise float bh = tb - (tb - b), qh = tq - (tq - q);
  precise float bl = b - bh, ql = q - qh;
  precise float err = ((bh * qh - p) + bh * ql + bl * qh) + bl * ql;
  precise float r = (a - p) - err;
  float s = a < 0.0 ? -1.0 : 1.0, m = abs(b);
  if (r != 0.0 && (r < 0.0) != (a < 0.0)) {  /* the quotient rounded away from zero */
    r += s * m;
  }
  else if (abs(r) >= m) {  /* towards zero */
    r -= s * m;
  }
  return r;
}

vec4 n_fmod(vec4 a, vec4 b)
{
  return vec4(n_fmod(a.x, b.x), n_fmod(a.y, b.y), n_fmod(a.z, b.z), n_fmod(a.w, b.w));
}

float n_floored_mod(float a, float b)
{
  return b != 0.0 ? a - floor(a / b) * b : 0.0;
}

float n_wrap(float value, float top, float bottom)
{
  float range = top - bottom;
  return range != 0.0 ? value - range * floor((value - bottom) / range) : bottom;
}

vec4 n_wrap(vec4 v, vec4 t, vec4 b)
{
  return vec4(n_wrap(v.x, t.x, b.x), n_wrap(v.y, t.y, b.y), n_wrap(v.z, t.z, b.z),
              n_wrap(v.w, t.w, b.w));
}

float n_pingpong(float a, float b)
{
  if (b == 0.0) {
    return 0.0;
  }
  float x = (a - b) / (b * 2.0);
  return abs((x - floor(x)) * b * 2.0 - b);
}

float n_smoothmin(float a, float b, float c)
{
  if (c == 0.0) {
    return min(a, b);
  }
  float h = max(c - abs(a - b), 0.0) / c;
  return min(a, b) - h * h * h * c * (1.0 / 6.0);
}

vec4 n_snap(vec4 a, vec4 b)
{
  return floor(n_safe_div(a, b)) * b;
}

/* The Math node (core/scene/node_math.MATH); ops: its operation's number in MATH_OPS. */
float n_math(int op, float a, float b, float c)
{
  switch (op) {
    case 0: return a + b;
    case 1: return a - b;
    case 2: return a * b;
    case 3: return n_safe_div(a, b);
    case 4: return a * b + c;
    case 5: return n_safe_pow(a, b);
    case 6: return n_safe_log(a, b);
    case 7: return sqrt(max(a, 0.0));
    case 8: return n_safe_div(1.0, sqrt(max(a, 0.0)));
    case 9: return abs(a);
    case 10: return exp(a);
    case 11: return min(a, b);
    case 12: return max(a, b);
    case 13: return a < b ? 1.0 : 0.0;
    case 14: return a > b ? 1.0 : 0.0;
    case 15: return sign(a);
    case 16: return (a == b || abs(a - b) <= max(c, N_FLT_EPSILON)) ? 1.0 : 0.0;
    case 17: return n_smoothmin(a, b, c);
    case 18: return -n_smoothmin(-a, -b, c);
    case 19: return floor(a + 0.5);
    case 20: return floor(a);
    case 21: return ceil(a);
    case 22: return trunc(a);
    case 23: return a - floor(a);
    case 24: return n_fmod(a, b);
    case 25: return n_floored_mod(a, b);
    case 26: return n_wrap(a, b, c);
    case 27: return floor(n_safe_div(a, b)) * b;
    case 28: return n_pingpong(a, b);
    case 29: return sin(a);
    case 30: return cos(a);
    case 31: return tan(a);
    case 32: return asin(clamp(a, -1.0, 1.0));
    case 33: return acos(clamp(a, -1.0, 1.0));
    case 34: return atan(a);
    case 35: /* np.arctan2: +-pi on the negative axis by the zero's sign, atan(0, 0) = 0 */
      if (a == 0.0) {  /* b of -0.0 counts as negative */
        bool negative = b < 0.0 || (b == 0.0 && (floatBitsToUint(b) & 0x80000000u) != 0u);
        return negative ? ((floatBitsToUint(a) & 0x80000000u) != 0u ? -N_PI : N_PI) : a;
      }
      return atan(a, b);
    case 36: return sinh(a);
    case 37: return cosh(a);
    case 38: return tanh(clamp(a, -10.0, 10.0));  /* exp(+-2a) overflows in some drivers' */
    case 39: return a * (N_PI / 180.0);
    case 40: return a * (180.0 / N_PI);
  }
  return 0.0;
}

vec4 n_math(int op, vec4 a, vec4 b, vec4 c, bool use_clamp)
{
  vec4 r = n_finite(vec4(n_math(op, a.x, b.x, c.x), n_math(op, a.y, b.y, c.y),
                         n_math(op, a.z, b.z, c.z), n_math(op, a.w, b.w, c.w)));
  return use_clamp ? clamp(r, 0.0, 1.0) : r;
}

/* A normal input made unit (nodes.Evaluation.normal_arg) */
vec3 n_unit(vec3 v)
{
  float l = length(v);
  return l > 0.0 ? v / l : vec3(0.0);
}

vec3 n_normalize(vec3 a)
{
  float length_ = length(a);
  return length_ > 0.0 ? a / length_ : vec3(0.0);
}

/* The Vector Math node (node_math.VECTOR_MATH); op: its number in VECTOR_MATH_OPS. */
vec4 n_vector_math(int op, vec4 a, vec4 b, vec4 c, vec4 s)
{
  vec4 r = vec4(0.0);
  switch (op) {
    case 0: r = a + b; break;
    case 1: r = a - b; break;
    case 2: r = a * b; break;
    case 3: r = n_safe_div(a, b); break;
    case 4: r = a * b + c; break;
    case 5: r = vec4(cross(a.xyz, b.xyz), 0.0); break;
    case 6: {
      float d = dot(b.xyz, b.xyz);
      r = d != 0.0 ? vec4(dot(a.xyz, b.xyz) / d * b.xyz, 0.0) : vec4(0.0);
      break;
    }
    case 7: {
      vec3 n = n_normalize(b.xyz);
      r = vec4(a.xyz - 2.0 * dot(a.xyz, n) * n, 0.0);
      break;
    }
    case 8: {
      vec3 n = n_normalize(b.xyz);
      float d = dot(n, a.xyz), eta = s.x;
      float k = 1.0 - eta * eta * (1.0 - d * d);
      r = k < 0.0 ? vec4(0.0) : vec4(eta * a.xyz - (eta * d + sqrt(max(k, 0.0))) * n, 0.0);
      break;
    }
    case 9: r = dot(c.xyz, b.xyz) < 0.0 ? a : -a; break;
    case 10: r = vec4(dot(a.xyz, b.xyz)); break;
    case 11: r = vec4(length(a.xyz - b.xyz)); break;
    case 12: r = vec4(length(a.xyz)); break;
    case 13: r = a * s.x; break;
    case 14: r = vec4(n_normalize(a.xyz), 0.0); break;
    case 15: r = n_snap(a, b); break;
    case 16: r = floor(a); break;
    case 17: r = ceil(a); break;
    case 18: r = n_fmod(a, b); break;
    case 19: r = n_wrap(a, b, c); break;
    case 20: r = a - floor(a); break;
    case 21: r = abs(a); break;
    case 22: r = n_safe_pow(a, b); break;
    case 23: r = sign(a); break;
    case 24: r = min(a, b); break;
    case 25: r = max(a, b); break;
    case 26: r = sin(a); break;
    case 27: r = cos(a); break;
    case 28: r = tan(a); break;
  }
  return n_finite(r);
}

/* Colour models (Cycles util/color.h, node_math.rgb_to_hsv ...) */
vec3 n_rgb_to_hsv(vec3 rgb)
{
  float cmax = max(rgb.r, max(rgb.g, rgb.b)), cmin = min(rgb.r, min(rgb.g, rgb.b));
  float delta = cmax - cmin;
  float s = cmax != 0.0 ? delta / cmax : 0.0;
  float h = 0.0;
  if (s != 0.0) {
    float safe = delta != 0.0 ? delta : 1.0;
    vec3 c = (vec3(cmax) - rgb) / safe;
    h = (rgb.r == cmax ? c.b - c.g : (rgb.g == cmax ? 2.0 + c.r - c.b : 4.0 + c.g - c.r)) / 6.0;
    h = h < 0.0 ? h + 1.0 : h;
  }
  return vec3(h, s, cmax);
}

vec3 n_hsv_to_rgb(vec3 hsv)
{
  float h = hsv.x, s = hsv.y, v = hsv.z;
  if (s == 0.0) {
    return vec3(v);
  }
  h = (h == 1.0 ? 0.0 : h) * 6.0;
  float i = floor(h);
  float f = h - i;
  float p = v * (1.0 - s), q = v * (1.0 - s * f), t = v * (1.0 - s * (1.0 - f));
  int k = (i >= 0.0 && i <= 4.0) ? int(i) : 5;
  switch (k) {
    case 0: return vec3(v, t, p);
    case 1: return vec3(q, v, p);
    case 2: return vec3(p, v, t);
    case 3: return vec3(p, q, v);
    case 4: return vec3(t, p, v);
  }
  return vec3(v, p, q);
}

vec3 n_rgb_to_hsl(vec3 rgb)
{
  float cmax = max(rgb.r, max(rgb.g, rgb.b)), cmin = min(rgb.r, min(rgb.g, rgb.b));
  float lum = min(1.0, (cmax + cmin) / 2.0);
  if (cmax == cmin) {
    return vec3(0.0, 0.0, lum);
  }
  float d = cmax - cmin;
  float s = lum > 0.5 ? d / (2.0 - cmax - cmin) : d / (cmax + cmin);
  float h;
  if (cmax == rgb.r) {
    h = (rgb.g - rgb.b) / d + (rgb.g < rgb.b ? 6.0 : 0.0);
  }
  else if (cmax == rgb.g) {
    h = (rgb.b - rgb.r) / d + 2.0;
  }
  else {
    h = (rgb.r - rgb.g) / d + 4.0;
  }
  return vec3(h / 6.0, (isnan(s) || isinf(s)) ? 0.0 : s, lum);
}

vec3 n_hsl_to_rgb(vec3 hsl)
{
  float h = hsl.x, s = hsl.y, lum = hsl.z;
  vec3 n = vec3(abs(h * 6.0 - 3.0) - 1.0, 2.0 - abs(h * 6.0 - 2.0), 2.0 - abs(h * 6.0 - 4.0));
  float chroma = (1.0 - abs(2.0 * lum - 1.0)) * s;
  return (clamp(n, 0.0, 1.0) - 0.5) * chroma + lum;
}

/* Mix's colour blend modes (node_math.BLEND_MODES); mode: its number in BLEND_OPS. */
vec4 n_blend(int mode, float t, vec4 c1, vec4 c2, bool clamp_result)
{
  vec4 r = c1;
  float tm = 1.0 - t;
  switch (mode) {
    case 0: r = c1 + (c2 - c1) * t; break;
    case 1: r = c1 + t * c2; break;
    case 2: r = c1 * (tm + t * c2); break;
    case 3: r = 1.0 - (tm + t * (1.0 - c2)) * (1.0 - c1); break;
    case 4:
      for (int k = 0; k < 4; k++) {
        r[k] = c1[k] < 0.5 ? c1[k] * (tm + 2.0 * t * c2[k]) :
                             1.0 - (tm + 2.0 * t * (1.0 - c2[k])) * (1.0 - c1[k]);
      }
      break;
    case 5: r = c1 - t * c2; break;
    case 6:
      for (int k = 0; k < 4; k++) {
        r[k] = c2[k] != 0.0 ? tm * c1[k] + t * (c1[k] / c2[k]) : c1[k];
      }
      break;
    case 7: r = c1 + (abs(c1 - c2) - c1) * t; break;
    case 8: r = max(c1 + ((c1 + c2 - 2.0 * c1 * c2) - c1) * t, 0.0); break;
    case 9: r = c1 + (min(c1, c2) - c1) * t; break;
    case 10: r = c1 + (max(c1, c2) - c1) * t; break;
    case 11:
      for (int k = 0; k < 4; k++) {
        float tmp = 1.0 - t * c2[k];
        float v = tmp <= 0.0 ? 1.0 : min(c1[k] / tmp, 1.0);
        r[k] = c1[k] != 0.0 ? v : c1[k];
      }
      break;
    case 12:
      for (int k = 0; k < 4; k++) {
        float tmp = tm + t * c2[k];
        r[k] = tmp <= 0.0 ? 0.0 : clamp(1.0 - (1.0 - c1[k]) / tmp, 0.0, 1.0);
      }
      break;
    case 13: { /* hue */
      vec3 hsv2 = n_rgb_to_hsv(c2.rgb);
      vec3 hsv = n_rgb_to_hsv(c1.rgb);
      hsv.x = hsv2.x;
      r = hsv2.y != 0.0 ? vec4(c1.rgb + (n_hsv_to_rgb(hsv) - c1.rgb) * t, c1.a) : c1;
      break;
    }
    case 14: { /* saturation */
      vec3 hsv = n_rgb_to_hsv(c1.rgb);
      vec3 hsv2 = n_rgb_to_hsv(c2.rgb);
      if (hsv.y != 0.0) {
        hsv.y = hsv.y + (hsv2.y - hsv.y) * t;
        r = vec4(n_hsv_to_rgb(hsv), c1.a);
      }
      break;
    }
    case 15: { /* value */
      vec3 hsv = n_rgb_to_hsv(c1.rgb);
      vec3 hsv2 = n_rgb_to_hsv(c2.rgb);
      hsv.z = hsv.z + (hsv2.z - hsv.z) * t;
      r = vec4(n_hsv_to_rgb(hsv), c1.a);
      break;
    }
    case 16: { /* color */
      vec3 hsv2 = n_rgb_to_hsv(c2.rgb);
      vec3 hsv = n_rgb_to_hsv(c1.rgb);
      hsv.xy = hsv2.xy;
      r = hsv2.y != 0.0 ? vec4(c1.rgb + (n_hsv_to_rgb(hsv) - c1.rgb) * t, c1.a) : c1;
      break;
    }
    case 17: {
      vec4 scr = 1.0 - (1.0 - c2) * (1.0 - c1);
      r = tm * c1 + t * ((1.0 - c1) * c2 * c1 + c1 * scr);
      break;
    }
    case 18: r = c1 + t * (2.0 * c2 - 1.0); break;
  }
  r = n_finite(r);
  return clamp_result ? clamp(r, 0.0, 1.0) : r;
}

vec4 n_separate(int model, vec4 c)
{
  return vec4(model == 1 ? n_rgb_to_hsv(c.rgb) : (model == 2 ? n_rgb_to_hsl(c.rgb) : c.rgb),
              0.0);
}

vec4 n_combine(int model, float x, float y, float z)
{
  vec3 v = vec3(x, y, z);
  return vec4(model == 1 ? n_hsv_to_rgb(v) : (model == 2 ? n_hsl_to_rgb(v) : v), 0.0);
}

/* Rz Ry Rx of XYZ Euler angles (node_math.euler_xyz) */
mat3 n_euler_xyz(vec3 r)
{
  float cx = cos(r.x), cy = cos(r.y), cz = cos(r.z);
  float sx = sin(r.x), sy = sin(r.y), sz = sin(r.z);
  return transpose(mat3(cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz,
                        cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz,
                        -sy, cy * sx, cy * cx));
}

/* The Mapping node; kind 0 POINT, 1 TEXTURE, 2 VECTOR, 3 NORMAL */
vec4 n_mapping(int kind, vec4 v, vec4 loc, vec4 rot, vec4 scale)
{
  mat3 m = n_euler_xyz(rot.xyz);
  bool turn = any(notEqual(rot.xyz, vec3(0.0)));
  if (kind == 1) {
    vec3 d = v.xyz - loc.xyz;
    return vec4(n_safe_div(vec4(turn ? transpose(m) * d : d, 0.0), scale).xyz, 0.0);
  }
  if (kind == 3) {
    vec3 d = n_safe_div(v, scale).xyz;
    return vec4(n_normalize(turn ? m * d : d), 0.0);
  }
  vec3 d = v.xyz * scale.xyz;
  d = turn ? m * d : d;
  return vec4(kind == 0 ? d + loc.xyz : d, 0.0);
}

vec4 n_invert(vec4 f, vec4 c)
{
  return c + ((1.0 - c) - c) * f;
}

vec4 n_gamma(vec4 c, vec4 g)
{
  vec4 r;
  for (int k = 0; k < 4; k++) {
    r[k] = g[k] == 0.0 ? 1.0 : (c[k] > 0.0 ? pow(c[k], g[k]) : c[k]);
  }
  return n_finite(r);
}

vec4 n_bright_contrast(vec4 c, vec4 bright, vec4 contrast)
{
  return max((1.0 + contrast) * c + (bright - contrast * 0.5), 0.0);
}

vec4 n_hsv(float hue, float saturation, float value, float factor, vec4 color)
{
  vec3 c = color.rgb;
  vec3 hsv = n_rgb_to_hsv(c);
  float h = hsv.x + hue + 0.5;
  hsv.x = h - floor(h);
  hsv.y = clamp(hsv.y * saturation, 0.0, 1.0);
  hsv.z = hsv.z * value;
  return vec4(max(c + (n_hsv_to_rgb(hsv) - c) * factor, 0.0), 0.0);
}

float n_smoothstep(float e0, float e1, float x)
{
  if (x < e0) {
    return 0.0;
  }
  if (x >= e1) {
    return 1.0;
  }
  float t = (x - e0) / (e1 != e0 ? e1 - e0 : 1.0);
  return (3.0 - 2.0 * t) * t * t;
}

float n_smootherstep(float e0, float e1, float x)
{
  x = clamp(n_safe_div(x - e0, e1 - e0), 0.0, 1.0);
  return x * x * x * (x * (x * 6.0 - 15.0) + 10.0);
}

/* Map Range; kind 0 LINEAR, 1 STEPPED, 2 SMOOTHSTEP, 3 SMOOTHERSTEP */
float n_map_range(int kind, float value, float from_min, float from_max, float to_min,
                  float to_max, float steps, bool use_clamp)
{
  float factor;
  if (kind <= 1) {
    factor = n_safe_div(value - from_min, from_max - from_min);
    if (kind == 1) {
      factor = steps > 0.0 ? floor(factor * (steps + 1.0)) / steps : 0.0;
    }
  }
  else if (from_min > from_max) {
    factor = 1.0 - (kind == 2 ? n_smoothstep(from_max, from_min, value) :
                                n_smootherstep(from_max, from_min, value));
  }
  else {
    factor = kind == 2 ? n_smoothstep(from_min, from_max, value) :
                         n_smootherstep(from_min, from_max, value);
  }
  float result = to_min + factor * (to_max - to_min);
  if (use_clamp && kind <= 1) {
    result = to_max > to_min ? clamp(result, to_min, to_max) : clamp(result, to_max, to_min);
  }
  return n_finite(result);
}

vec4 n_map_range(int kind, vec4 v, vec4 a, vec4 b, vec4 c, vec4 d, vec4 s, bool use_clamp)
{
  vec4 r;
  for (int k = 0; k < 4; k++) {
    r[k] = n_map_range(kind, v[k], a[k], b[k], c[k], d[k], s[k], use_clamp);
  }
  return r;
}

vec4 n_clamp(int kind, vec4 v, vec4 lo, vec4 hi)
{
  if (kind == 1) {
    vec4 l = min(lo, hi);
    hi = max(lo, hi);
    lo = l;
  }
  return min(max(v, lo), hi);
}

/* The ramp position of f in a table of `size` entries: (index, fraction), f non-finite as 0 */
vec2 n_ramp_at(float f, int size)
{
  f = n_finite(f);
  float x = clamp(f, 0.0, 1.0) * float(size - 1);
  float i = clamp(floor(x), 0.0, float(size - 1));
  return vec2(i, x - i);
}

float n_fresnel_dielectric_cos(float cosi, float eta)
{
  float c = abs(cosi);
  float g = eta * eta - 1.0 + c * c;
  if (!(g > 0.0)) {
    return 1.0;
  }
  g = sqrt(g);
  float a = (g - c) / (g + c);
  float b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
  float r = 0.5 * a * a * (1.0 + b * b);
  return (isnan(r) || isinf(r)) ? 1.0 : r;
}

float n_fresnel(float ior, vec3 n, MatPoint p)
{
  ior = max(ior, 1e-5);
  float eta = p.backfacing > 0.5 ? 1.0 / ior : ior;
  return n_fresnel_dielectric_cos(dot(p.view, n), eta);
}

vec4 n_layer_weight(float blend, vec3 n, MatPoint p)
{
  float c = dot(p.view, n);
  float eta = max(1.0 - blend, 1e-5);
  eta = p.backfacing > 0.5 ? eta : 1.0 / eta;
  float fresnel = n_fresnel_dielectric_cos(c, eta);
  float b = clamp(blend, 0.0, 1.0 - 1e-5);
  float exponent = b < 0.5 ? 2.0 * b : 0.5 / (1.0 - b);
  float facing = blend == 0.5 ? abs(c) : (exponent == 0.0 ? 1.0 : pow(abs(c), exponent));
  return vec4(fresnel, 1.0 - facing, 0.0, 0.0);
}

/* The Normal Map node in tangent space (formulas/tangents.apply_normal_map) */
vec3 n_normal_map_tangent(vec3 n, vec4 t4, vec3 color, float strength, bool back)
{
  float flip = back ? -1.0 : 1.0;
  vec3 nn = n * flip, t = t4.xyz;
  float sign_ = t4.w < 0.0 ? -1.0 : 1.0;
  vec3 c = 2.0 * color - 1.0;
  vec2 cxy = c.xy * max(strength, 0.0);
  float cz = 1.0 + (c.z - 1.0) * clamp(strength, 0.0, 1.0);
  vec3 b = sign_ * cross(nn, t);
  vec3 o = cxy.x * t + cxy.y * b + cz * nn;
  float l = length(o);
  return (l > 1e-12 ? o / l : nn) * flip;
}

/* The Normal Map node in the object and world spaces (nodes._op_normal_map); space 1 OBJECT,
 * 2 WORLD, 3 BLENDER_OBJECT, 4 BLENDER_WORLD; to_world: the inverse transpose of the
 * object's matrix (world_to_object's 3 x 3, transposed) */
vec3 n_normal_map_space(int space, vec3 n, vec3 color, float strength, bool back,
                        mat3 to_world)
{
  vec3 c = 2.0 * color - 1.0;
  if (space >= 3) {
    c *= vec3(1.0, -1.0, -1.0);
  }
  if (space == 1 || space == 3) {
    c = to_world * c;
  }
  vec3 m = n_unit(c);
  m = back ? -m : m;
  return n_unit(n + (m - n) * max(strength, 0.0));
}

/* The Bump node (nodes._op_bump, Cycles svm_node_set_bump): the height h at the point and hx,
 * hy at the points px, py moved filter-width pixels right and down */
vec3 n_bump(float strength, float distance, bool invert, vec3 n, float h, float hx, float hy,
            vec3 p, vec3 px, vec3 py)
{
  float s = max(strength, 0.0);
  float d = invert ? -distance : distance;
  vec3 dpdx = px - p, dpdy = py - p;
  vec3 rx = cross(dpdy, n), ry = cross(n, dpdx);
  float det = dot(dpdx, rx);
  vec3 grad = (hx - h) * rx + (hy - h) * ry;
  vec3 o = n_unit(abs(det) * n - d * sign(det) * grad);
  bool ok = !any(isnan(o)) && !any(isinf(o)) && abs(o.x) + abs(o.y) + abs(o.z) > 0.0;
  o = n_unit(s * (ok ? o : n) + (1.0 - s) * n);
  return abs(o.x) + abs(o.y) + abs(o.z) > 0.0 ? o : n;
}

/* The mip level of a look-up whose UV changes by sx, sy over one pixel right and down
 * (kernels.textures.footprint_lod): log2 of the longer step in texels; +inf if unknown */
float n_footprint_lod(vec2 sx, vec2 sy, float w, float h)
{
  float ax = sx.x * w, ay = sx.y * h, bx = sy.x * w, by = sy.y * h;
  float rho2 = max(ax * ax + ay * ay, bx * bx + by * by);
  if (isnan(rho2) || isinf(rho2)) {
    return uintBitsToFloat(0x7f800000u);
  }
  return 0.5 * log2(max(rho2, 1e-37));
}

/* Object space: rows 0-2 of mp_object are world_to_object's, 3 and 4 the texture space's
 * start and size (Generated = (p_obj - start) / size) */
vec3 mp_object_point(MatPoint p, vec3 v)
{
  return vec3(dot(mp_object(p, 0).xyz, v) + mp_object(p, 0).w,
              dot(mp_object(p, 1).xyz, v) + mp_object(p, 1).w,
              dot(mp_object(p, 2).xyz, v) + mp_object(p, 2).w);
}

/* world_to_object's 3 x 3, transposed: what takes object-space normals to the world */
mat3 mp_to_world(MatPoint p)
{
  return mat3(mp_object(p, 0).xyz, mp_object(p, 1).xyz, mp_object(p, 2).xyz);
}

/* The Texture Coordinate node's outputs (nodes._op_texcoord) in materials.TEXCOORDS order */
vec4 mp_texcoord(MatPoint p, int which)
{
  if (which == 0) {
    vec3 size = mp_object(p, 4).xyz;
    vec3 g = (mp_object_point(p, p.position) - mp_object(p, 3).xyz) /
             mix(size, vec3(1.0), equal(size, vec3(0.0)));
    return n_finite(vec4(g, 0.0));
  }
  if (which == 1) {
    return vec4(mp_object_point(p, p.position), 0.0);
  }
  if (which == 2) {
    return vec4(n_unit(transpose(inverse(transpose(mp_to_world(p)))) * p.normal), 0.0);
  }
  if (which == 3) {
    vec3 c = mp_camera(p.position);
    return vec4(c.x, c.y, -c.z, 0.0);
  }
  if (which == 4) {
    return vec4(p.window, 0.0, 0.0);
  }
  return vec4(2.0 * dot(p.normal, p.view) * p.normal - p.view, 0.0);
}

/* The Principled BSDF in the talk's parameters (nodes.principled_to_talk, brdf's gloss) */
float n_roughness_to_gloss(float roughness)
{
  float r2 = clamp(roughness, 0.0, 1.0);
  r2 = r2 * r2;
  if (r2 == 0.0) {
    return 1.0;
  }
  float alpha = 2.0 / (r2 * r2) - 2.0;
  return alpha > 0.0 ? clamp(log2(alpha) / 13.0, 0.0, 1.0) : 0.0;
}

/* A shader socket's value (nodes.Closure), every field weighted */
struct Clo {
  vec3 albedo, rf0, emission, normal;
  float spec, gloss, nweight, transparent, weight, layer, layer_f0;
};

Clo n_closure(vec3 albedo, vec3 rf0, float spec, float gloss, vec3 emission, bool has_normal,
              vec3 normal, float transparent, bool is_transparent)
{
  Clo c;
  c.albedo = albedo;
  c.rf0 = rf0;
  c.spec = spec;
  c.gloss = gloss * spec;
  c.emission = emission;
  c.normal = has_normal ? normal : vec3(0.0);
  c.nweight = has_normal ? 1.0 : 0.0;
  c.transparent = is_transparent ? transparent : 0.0;
  c.weight = is_transparent ? 0.0 : 1.0;
  c.layer = 0.0;
  c.layer_f0 = 0.0;
  return c;
}

Clo n_scaled(Clo c, float w)
{
  c.albedo *= w;
  c.rf0 *= w;
  c.emission *= w;
  c.normal *= w;
  c.spec *= w;
  c.gloss *= w;
  c.nweight *= w;
  c.transparent *= w;
  c.weight *= w;
  c.layer *= w;
  c.layer_f0 *= w;
  return c;
}

Clo n_add(Clo a, Clo b)
{
  a.albedo += b.albedo;
  a.rf0 += b.rf0;
  a.emission += b.emission;
  a.normal += b.normal;
  a.spec += b.spec;
  a.gloss += b.gloss;
  a.nweight += b.nweight;
  a.transparent += b.transparent;
  a.weight += b.weight;
  a.layer += b.layer;
  a.layer_f0 += b.layer_f0;
  return a;
}

/* nodes._with_alpha: a surface of coverage alpha, mixed with a Transparent BSDF */
Clo n_with_alpha(Clo c, float alpha, bool opaque)
{
  if (opaque) {
    return c;
  }
  float a = clamp(alpha, 0.0, 1.0);
  Clo t = n_closure(vec3(0.0), vec3(0.0), 0.0, 0.0, vec3(0.0), false, vec3(0.0), 1.0, true);
  return n_add(n_scaled(c, a), n_scaled(t, 1.0 - a));
}

Clo n_principled(vec3 base, float metallic, float roughness, float ior, float level,
                 vec3 tint, float transmission, vec3 emission, bool has_normal, vec3 normal)
{
  metallic = clamp(metallic, 0.0, 1.0);
  ior = max(ior, 1.0);
  float f0 = ((ior - 1.0) / (ior + 1.0)) * ((ior - 1.0) / (ior + 1.0));
  vec3 dielectric = clamp(f0 * 2.0 * level * tint, 0.0, 1.0);
  vec3 albedo = base * (1.0 - metallic) * (1.0 - clamp(transmission, 0.0, 1.0));
  vec3 rf0 = dielectric + (base - dielectric) * metallic;
  Clo c = n_closure(max(albedo, 0.0), max(rf0, 0.0), 1.0, n_roughness_to_gloss(roughness),
                    emission, has_normal, normal, 0.0, false);
  c.layer = 1.0;
  c.layer_f0 = max(dielectric.r, max(dielectric.g, dielectric.b));
  return c;
}

/* The talk's parameters of a closure (core/scene/material.evaluate): albedo, rf0, emission,
 * gloss, alpha, the shading normal (n where no closure has one), the layered weight and its
 * rf0 (Closure.layer, layer_f0). */
void n_resolve(Clo c, vec3 n, out vec3 albedo, out vec3 rf0, out vec3 emission,
               out float gloss, out float alpha, out vec3 normal, out float layer,
               out float layer_f0)
{
  alpha = clamp(1.0 - c.transparent, 0.0, 1.0);
  float inv = alpha >= 1.0 ? 1.0 : (alpha > 0.0 ? 1.0 / alpha : 0.0);
  gloss = c.spec > 0.0 ? clamp(c.gloss / c.spec, 0.0, 1.0) : 0.0;
  albedo = n_finite(vec4(c.albedo * inv, 0.0)).xyz;
  rf0 = n_finite(vec4(clamp(c.rf0 * inv, 0.0, 1.0), 0.0)).xyz;
  emission = n_finite(vec4(c.emission * inv, 0.0)).xyz;
  gloss = n_finite(gloss);
  layer = clamp(n_finite(c.layer * inv), 0.0, 1.0);
  layer_f0 = clamp(n_finite(c.layer_f0 * inv), 0.0, 1.0);
  normal = n;
  if (c.nweight > 0.0) {
    float rest = max(c.weight - c.nweight, 0.0);
    vec3 mixed = c.normal + rest * n;
    vec3 u = n_unit(mixed);
    normal = dot(u, u) > 0.25 ? u : n;
  }
}
