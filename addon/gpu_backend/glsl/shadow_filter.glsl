/* Shadow filter: the fraction of a light that reaches a point, from its shadow maps.
 *
 * The GLSL form of core/kernels/shadows.py (visibility and its helpers; the method is
 * core/render/shadow_filter.py's docstring: PCF, Reeves, Salesin & Cook 1987; PCSS, Fernando
 * 2005; receiver-plane depth; normal offset, Holbert 2011), held to it by
 * tests/gpu/test_stages.py. Float32 arithmetic in the kernel's order.
 *
 * Reads: shadows[] (ShadowData, uniforms), shadow_depth (R32F 2D array: every map's faces,
 * each in the top-left res x res of its layer), shadow_mips (RGBA32F rows of every map's
 * pyramid, MIPS_WIDTH per texture row), shadow_rotations (RG32F, the disc rotations).
 * Defines from Python: P_* and the discs (BLOCKER_DISC, PCF_DISC, HARD_DISC, *_TAPS,
 * PCF_REACH, HARD_REACH). */

#define MAP_CUBE 0
#define MAP_PERSPECTIVE 1
#define MAP_ORTHO 2
#define NEG_TINY -1e-30

struct Setup {
  float cx, ry, jc1, jc2, jr1, jr2, w0, dist, texel, k, a, b, c, bias, l1c, l1r, jc, jr;
  float dr, du, nr, nu, nf, xw, yw, ac, bc, ar, br, cs, sn;
  int m;
};

float mn(float a, float b) { return (a <= b || isnan(a)) ? a : b; }
float mx(float a, float b) { return (a >= b || isnan(a)) ? a : b; }

float fp(int s, int i) { return shadows[s].fp[i >> 2][i & 3]; }
int rects_count(int s) { return shadows[s].ints.w; }

/* max(ceil(log2(width)), first) of an integer-valued width >= 1. */
int level_of(float width, int first)
{
  int iw = int(width);
  return max(iw > 1 ? findMSB(iw - 1) + 1 : 0, first);
}

vec3 unit_normal(vec3 n, vec3 a)
{
  float len = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
  if (!(len > 1e-6)) {
    float inv = -1.0 / mx(sqrt(a.x * a.x + a.y * a.y + a.z * a.z), 1e-12);
    return a * inv;
  }
  float scale = (n.x * a.x + n.y * a.y + n.z * a.z) > 0.0 ? -len : len;
  return n / scale;
}

/* Cube face (+X, -X, +Y, -Y, +Z, -Z) of a direction; sel: (fx, fy, fz, sign). */
int cube_face(vec3 d, out vec4 sel)
{
  vec3 ad = abs(d);
  int axis;
  float major;
  if (ad.x >= ad.y && ad.x >= ad.z) {
    axis = 0; sel.xyz = vec3(1.0, 0.0, 0.0); major = d.x;
  }
  else if (ad.y >= ad.z) {
    axis = 1; sel.xyz = vec3(0.0, 1.0, 0.0); major = d.y;
  }
  else {
    axis = 2; sel.xyz = vec3(0.0, 0.0, 1.0); major = d.z;
  }
  bool neg = major < 0.0;
  sel.w = neg ? -1.0 : 1.0;
  return 2 * axis + (neg ? 1 : 0);
}

vec3 to_face(vec4 f, vec3 d)
{
  return vec3(((f.y - f.z) * d.x - f.x * d.y) * f.w, d.y * f.z + d.z * (f.x + f.y),
              (d.x * f.x + d.y * f.y + d.z * f.z) * f.w);
}

int find_cascade(int s, float x, float y)
{
  for (int c = 0; c < rects_count(s); c++) {
    vec4 r = shadows[s].rects[c];
    if (abs(x - r.x) <= r.z && abs(y - r.y) <= r.z) {
      return c;
    }
  }
  return -1;
}

void plane_in_texels(inout Setup f, int s, float nf, float bx, float by)
{
  float inv = fp(s, P_INV);
  f.a = (nf + bx * fp(s, P_HALF_INV)) + by * fp(s, P_ONE_HALF_INV);
  f.b = bx * inv;
  f.c = -by * inv;
}

bool setup_perspective(inout Setup f, int s, vec3 p, vec3 n)
{
  bool cube = shadows[s].kind == MAP_CUBE;
  float sc = fp(s, P_TAN), h = fp(s, P_HALF_RES);
  vec3 b0 = shadows[s].basis[0].xyz, b1 = shadows[s].basis[1].xyz, b2 = shadows[s].basis[2].xyz;
  vec3 d = p - vec3(fp(s, P_OX), fp(s, P_OY), fp(s, P_OZ));
  float w;
  if (cube) {
    w = mx(mx(abs(d.x), abs(d.y)), abs(d.z));
  }
  else {
    w = mx(d.x * b2.x + d.y * b2.y + d.z * b2.z, 0.0);
  }
  n = unit_normal(n, d);
  w = w * fp(s, P_OFFSET);
  d = d + n * w;
  float dr, du, nr, nu, nf;
  int face = 0;
  if (cube) {
    vec4 sel;
    face = cube_face(d, sel);
    vec3 t = to_face(sel, d);
    dr = t.x; du = t.y; w = t.z;
    vec3 tn = to_face(sel, n);
    nr = tn.x; nu = tn.y; nf = tn.z;
  }
  else {
    dr = d.x * b0.x + d.y * b0.y + d.z * b0.z;
    du = d.x * b1.x + d.y * b1.y + d.z * b1.z;
    w = d.x * b2.x + d.y * b2.y + d.z * b2.z;
    nr = n.x * b0.x + n.y * b0.y + n.z * b0.z;
    nu = n.x * b1.x + n.y * b1.y + n.z * b1.z;
    nf = n.x * b2.x + n.y * b2.y + n.z * b2.z;
  }
  float dist = sqrt(dr * dr + du * du + w * w);
  if (!(dist > fp(s, P_NEAR2))) {
    return false;
  }
  float inv_sw = 1.0 / (sc * w);
  float x0 = dr * inv_sw;
  float y0 = du * inv_sw;
  if (!cube && !(w > fp(s, P_NEAR) && abs(x0) <= 1.0 && abs(y0) <= 1.0)) {
    return false;
  }
  f.m = face;
  f.cx = (x0 + 1.0) * h;
  f.ry = (1.0 - y0) * h;
  float inv_d = 1.0 / dist;
  float er = dr * inv_d, eu = du * inv_d, ef = w * inv_d;
  float g = h * inv_sw;
  float q = g / (ef * (1.0 + ef));
  f.jc2 = er * eu * q;
  f.jc1 = g + er * er * q;
  f.jr1 = -f.jc2;
  f.jr2 = -(g + eu * eu * q);
  f.w0 = w;
  f.dist = dist;
  f.texel = fp(s, P_TEXEL) * w;
  f.k = dr * nr + du * nu + w * nf;
  plane_in_texels(f, s, nf, sc * nr, sc * nu);
  f.bias = fp(s, P_BIAS_REL) * w + fp(s, P_BIAS_TEXELS) * f.texel;
  f.l1c = abs(f.jc1) + abs(f.jc2);
  f.l1r = abs(f.jr1) + abs(f.jr2);
  f.dr = dr; f.du = du; f.nr = nr; f.nu = nu; f.nf = nf;
  return true;
}

bool setup_ortho(inout Setup f, int s, vec3 p, vec3 n)
{
  float h = fp(s, P_HALF_RES);
  vec3 b0 = shadows[s].basis[0].xyz, b1 = shadows[s].basis[1].xyz, b2 = shadows[s].basis[2].xyz;
  n = unit_normal(n, b2);
  int casc = find_cascade(s, p.x * b0.x + p.y * b0.y + p.z * b0.z,
                          p.x * b1.x + p.y * b1.y + p.z * b1.z);
  float off = shadows[s].rects[max(casc, 0)].z * fp(s, P_OFFSET);
  p = p + n * off;
  float x = p.x * b0.x + p.y * b0.y + p.z * b0.z;
  float y = p.x * b1.x + p.y * b1.y + p.z * b1.z;
  float z = p.x * b2.x + p.y * b2.y + p.z * b2.z;
  casc = find_cascade(s, x, y);
  if (casc < 0) {
    return false;
  }
  vec4 r = shadows[s].rects[casc];
  float cx = r.x, cy = r.y, half_side = r.z;
  f.m = casc;
  float g = h / half_side;
  f.cx = (x - cx) * g + h;
  f.ry = h - (y - cy) * g;
  f.jc1 = g; f.jc2 = 0.0; f.jr1 = 0.0; f.jr2 = -g;
  f.w0 = z;
  f.k = 0.0;
  f.texel = fp(s, P_INV) * half_side;
  float nr = n.x * b0.x + n.y * b0.y + n.z * b0.z;
  float nu = n.x * b1.x + n.y * b1.y + n.z * b1.z;
  float nf = mn(n.x * b2.x + n.y * b2.y + n.z * b2.z, -1e-6);
  float inv_nf = 1.0 / nf;
  float z0 = z - ((cx - x) * nr + (cy - y) * nu) * inv_nf;
  plane_in_texels(f, s, z0, -half_side * nr * inv_nf, -half_side * nu * inv_nf);
  f.bias = fp(s, P_BIAS_REL) * abs(z - r.w) + fp(s, P_BIAS_TEXELS) * f.texel;
  f.xw = x; f.yw = y; f.nr = nr; f.nu = nu; f.nf = nf;
  f.l1c = g;
  f.l1r = g;
  return true;
}

/* One of 1024 disc rotations from a hash of the position's float32 bits ("lowbias32"). */
int rotation_index(uvec3 bits)
{
  uint h = bits.x * 0x9E3779B1u;
  h ^= bits.y * 0x85EBCA77u;
  h ^= bits.z * 0xC2B2AE3Du;
  h ^= h >> 16u;
  h *= 0x7FEB352Du;
  h ^= h >> 15u;
  h *= 0x846CA68Bu;
  h ^= h >> 16u;
  return int(h >> 22u);
}

float depth_at(int s, int m, int row, int col)
{
  return texelFetch(shadow_depth, ivec3(col, row, shadows[s].ints.z + m), 0).r;
}

int mip_row(int s, int m, int level, int col, int row)
{
  int li = level - MIP_FIRST_LEVEL;
  int side = shadows[s].sides[li >> 2][li & 3];
  return shadows[s].offsets[li >> 2][li & 3] + (m * side + (row >> level)) * side +
         (col >> level);
}

vec4 mip_at(int s, int row)
{
  int k = shadows[s].ints2.x + row;
  return texelFetch(shadow_mips, ivec2(k % MIPS_WIDTH, k / MIPS_WIDTH), 0);
}

float receiver_depth(float t, float k, float lo, float hi, bool persp)
{
  if (persp) {
    t = k / mn(t, NEG_TINY);
  }
  return mn(mx(t, lo), hi);
}

float footprint_min(Setup f, int s, float radius)
{
  int res = shadows[s].ints.y, levels = shadows[s].ints2.y;
  float neg_inf = -1.0 / 0.0;
  if (levels == 0) {
    return neg_inf;
  }
  float rc = radius * f.l1c;
  float rr = radius * f.l1r;
  float c0 = floor(f.cx - rc), c1 = floor(f.cx + rc);
  float r0 = floor(f.ry - rr), r1 = floor(f.ry + rr);
  float fres = float(res);
  if (!(c0 >= 0.0 && c1 < fres && r0 >= 0.0 && r1 < fres)) {
    return neg_inf;
  }
  int level = level_of(mx(c1 - c0, r1 - r0) + 1.0, MIP_FIRST_LEVEL);
  if (level > MIP_FIRST_LEVEL + levels - 1) {
    return neg_inf;
  }
  int a = int(c0), b = int(c1), c = int(r0), d = int(r1);
  float best = mip_at(s, mip_row(s, f.m, level, a, c)).x;
  best = mn(best, mip_at(s, mip_row(s, f.m, level, b, c)).x);
  best = mn(best, mip_at(s, mip_row(s, f.m, level, a, d)).x);
  return mn(best, mip_at(s, mip_row(s, f.m, level, b, d)).x);
}

/* The least distance of the map's casters from the light (cascades: depth along the sun):
 * P_MIN_DEPTH, or for a map drawn on the GPU (ints.x faces) the least of its pyramid's tops,
 * one item per face: the same number, a minimum being exact. */
float min_depth(int s)
{
  int faces = shadows[s].ints.x;
  if (faces == 0) {
    return fp(s, P_MIN_DEPTH);
  }
  int top = shadows[s].ints2.y - 1;
  int first = shadows[s].offsets[top >> 2][top & 3];
  float best = mip_at(s, first).x;
  for (int k = 1; k < faces; k++) {
    best = mn(best, mip_at(s, first + k).x);
  }
  return best;
}

float search_radius(Setup f, int s)
{
  float size = fp(s, P_SIZE);
  bool ortho = shadows[s].kind == MAP_ORTHO;
  float d_near = min_depth(s);
  float d_r;
  if (ortho) {
    d_r = f.w0;
  }
  else {
    d_r = f.dist;
    d_near = mx(d_near, fp(s, P_NEAR_FLOOR));
  }
  float cap = fp(s, P_CAP) * f.texel;
  float radius = cap;
  for (int it = 0; it <= SEARCH_REFINEMENTS; it++) {
    float gap = mx(d_r - d_near, 0.0);
    radius = mn(ortho ? size * gap : size * gap / d_near, cap);
    if (it < SEARCH_REFINEMENTS) {
      d_near = mx(d_near, footprint_min(f, s, radius));
    }
  }
  return radius;
}

vec4 footprint(Setup f, int s, float radius, float reach)
{
  float ec = radius * (reach * f.jc) + fp(s, P_SLACK);
  float er = radius * (reach * f.jr) + fp(s, P_SLACK);
  return vec4(floor(f.cx - ec), floor(f.cx + ec), floor(f.ry - er), floor(f.ry + er));
}

/* (lit, dark) of a footprint inside its map, proven by the pyramid and the receiver plane. */
bvec2 block_test(Setup f, int s, vec4 box, float lo, float hi, float dark_cap)
{
  bool persp = shadows[s].kind != MAP_ORTHO;
  float b0 = box.x * f.b, b1 = box.y * f.b;
  float g0 = box.z * f.c, g1 = box.w * f.c;
  float t0 = (mn(b0, b1) + f.a) + mn(g0, g1);
  float t1 = (mx(b0, b1) + f.a) + mx(g0, g1);
  t0 = receiver_depth(t0, f.k, lo, hi, persp);
  t1 = receiver_depth(t1, f.k, lo, hi, persp);
  float t_lo = mn(t0, t1), t_hi = mx(t0, t1);
  t_lo = mn(t_lo, dark_cap);
  int level = level_of(mx(mx(box.y - box.x, box.w - box.z), 1.0), MIP_FIRST_LEVEL);
  if (level > MIP_FIRST_LEVEL + shadows[s].ints2.y - 1) {
    return bvec2(false, false);
  }
  int a = int(box.x), b = int(box.y), c = int(box.z), d = int(box.w);
  vec4 q0 = mip_at(s, mip_row(s, f.m, level, a, c));
  vec4 q1 = mip_at(s, mip_row(s, f.m, level, b, c));
  vec4 q2 = mip_at(s, mip_row(s, f.m, level, a, d));
  vec4 q3 = mip_at(s, mip_row(s, f.m, level, b, d));
  float lo_d = mn(mn(mn(q0.y, q1.y), q2.y), q3.y);
  float hi_d = mx(mx(mx(q0.z, q1.z), q2.z), q3.z);
  return bvec2(lo_d + f.bias >= t_hi, hi_d + f.bias < t_lo);
}

/* A tap that leaves its point's map, looked up exactly: (stored, receiver depth). */
vec2 outside_tap(Setup f, int s, float u, float v, float r, float span)
{
  int kind = shadows[s].kind, res = shadows[s].ints.y;
  float inf = 1.0 / 0.0;
  if (kind == MAP_PERSPECTIVE) {
    return vec2(inf, inf);
  }
  float h = fp(s, P_HALF_RES), inv = fp(s, P_INV);
  float top = float(res - 1);
  if (kind == MAP_CUBE) {
    float er = f.dr / f.dist, eu = f.du / f.dist, ef = f.w0 / f.dist;
    float k = -1.0 / (1.0 + ef);
    float ou = r * u, ov = r * v;
    float lr = f.dr + ou * (1.0 + er * er * k) + ov * (er * eu * k);
    float lu = f.du + ou * (er * eu * k) + ov * (1.0 + eu * eu * k);
    float lf = f.w0 - ou * er - ov * eu;
    vec4 sel;
    int fm = f.m;
    /* the face's selectors, as core/render/shadow_filter._FACES */
    sel.x = (fm >> 1) == 0 ? 1.0 : 0.0;
    sel.y = (fm >> 1) == 1 ? 1.0 : 0.0;
    sel.z = (fm >> 1) == 2 ? 1.0 : 0.0;
    sel.w = (fm & 1) == 1 ? -1.0 : 1.0;
    float fyz = sel.y - sel.z, fxy = sel.x + sel.y;
    float wx = (sel.x * lf + fyz * lr) * sel.w;
    float wy = (sel.y * lf - sel.x * lr) * sel.w + sel.z * lu;
    float wz = fxy * lu + sel.w * sel.z * lf;
    float mx_ = (sel.x * f.nf + fyz * f.nr) * sel.w;
    float my_ = (sel.y * f.nf - sel.x * f.nr) * sel.w + sel.z * f.nu;
    float mz_ = fxy * f.nu + sel.w * sel.z * f.nf;
    vec4 gsel;
    int g = cube_face(vec3(wx, wy, wz), gsel);
    vec3 t = to_face(gsel, vec3(wx, wy, wz));
    vec3 tn = to_face(gsel, vec3(mx_, my_, mz_));
    float col = mn(mx(floor((t.x / t.z + 1.0) * h), 0.0), top);
    float row = mn(mx(floor((1.0 - t.y / t.z) * h), 0.0), top);
    float stored = depth_at(s, g, int(row), int(col));
    float xc = (col + 0.5) * inv - 1.0, yc = 1.0 - (row + 0.5) * inv;
    float den = mn(tn.z + xc * tn.x + yc * tn.y, NEG_TINY);
    return vec2(stored, mn(mx(f.k / den, t.z - span), t.z + span));
  }
  float xw = f.xw + r * u;
  float yw = f.yw + r * v;
  int c = find_cascade(s, xw, yw);
  if (c < 0) {
    return vec2(inf, inf);
  }
  vec4 rc = shadows[s].rects[c];
  float col = mn(mx(floor(((xw - rc.x) / rc.z + 1.0) * h), 0.0), top);
  float row = mn(mx(floor((1.0 - (yw - rc.y) / rc.z) * h), 0.0), top);
  float stored = depth_at(s, c, int(row), int(col));
  float xs = rc.x + ((col + 0.5) * inv - 1.0) * rc.z - f.xw;
  float ys = rc.y + (1.0 - (row + 0.5) * inv) * rc.z - f.yw;
  float z = f.w0 - (xs * f.nr + ys * f.nu) / f.nf;
  return vec2(stored, mn(mx(z, f.w0 - span), f.w0 + span));
}

vec2 disc_tap(int disc, int k)
{
  if (disc == 0) {
    return BLOCKER_DISC[k];
  }
  return disc == 1 ? PCF_DISC[k] : HARD_DISC[k];
}

int disc_taps(int disc)
{
  return disc == 0 ? BLOCKER_TAPS : (disc == 1 ? PCF_TAPS : HARD_TAPS);
}

/* Blocked taps of a disc scaled to radius, and (measure) their blocker measure's sum. */
int taps(Setup f, int s, float radius, int disc, bool measure, bool check, out float acc)
{
  int res = shadows[s].ints.y;
  bool persp = shadows[s].kind != MAP_ORTHO;
  float fres = float(res);
  float ac = radius * f.ac, bc = radius * f.bc;
  float ar = radius * f.ar, br = radius * f.br;
  float span = fp(s, P_MAX_SLOPE) * (radius + f.texel);
  float lo = f.w0 - span, hi = f.w0 + span;
  int count = 0;
  acc = 0.0;
  for (int k = 0; k < disc_taps(disc); k++) {
    vec2 ab = disc_tap(disc, k);
    float colf = floor((ac * ab.x + f.cx) + bc * ab.y);
    float rowf = floor((ar * ab.x + f.ry) + br * ab.y);
    float stored, t;
    if (check && (min(colf, rowf) < 0.0 || max(colf, rowf) >= fres)) {
      vec2 st = outside_tap(f, s, ab.x * f.cs - ab.y * f.sn, ab.x * f.sn + ab.y * f.cs, radius,
                            span);
      stored = st.x;
      t = st.y;
    }
    else {
      stored = depth_at(s, f.m, int(rowf), int(colf));
      t = receiver_depth((colf * f.b + f.a) + rowf * f.c, f.k, lo, hi, persp);
    }
    if (stored + f.bias < t) {
      count += 1;
      if (measure) {
        acc += persp ? stored / t : t - stored;
      }
    }
  }
  return count;
}

float pcf(Setup f, int s, float radius, int disc, float reach)
{
  int res = shadows[s].ints.y;
  float fres = float(res);
  vec4 box = footprint(f, s, radius, reach);
  float scale = 1.0 / float(disc_taps(disc));
  float unused;
  if (!(box.x >= 0.0 && box.z >= 0.0 && box.y < fres && box.w < fres)) {
    return 1.0 - float(taps(f, s, radius, disc, false, true, unused)) * scale;
  }
  float span = fp(s, P_MAX_SLOPE) * (radius + f.texel);
  float lo = f.w0 - span, hi = f.w0 + span;
  if (mx(box.y - box.x, box.w - box.z) < 4.0) {
    bool persp = shadows[s].kind != MAP_ORTHO;
    int blocked = 0, cells = 0;
    for (int row = int(box.z); row <= int(box.w); row++) {
      for (int col = int(box.x); col <= int(box.y); col++) {
        float t = (float(col) * f.b + f.a) + float(row) * f.c;
        t = receiver_depth(t, f.k, lo, hi, persp);
        if (depth_at(s, f.m, row, col) + f.bias < t) {
          blocked += 1;
        }
        cells += 1;
      }
    }
    if (blocked == 0) {
      return 1.0;
    }
    if (blocked == cells) {
      return 0.0;
    }
  }
  else {
    bvec2 ld = block_test(f, s, box, lo, hi, hi);
    if (ld.y) {
      return 0.0;
    }
    if (ld.x) {
      return 1.0;
    }
  }
  return 1.0 - float(taps(f, s, radius, disc, false, false, unused)) * scale;
}

float pcss(Setup f, int s, float r_search, float r_min)
{
  float fres = float(shadows[s].ints.y);
  vec4 box = footprint(f, s, r_search, 1.0);
  bool inside = box.x >= 0.0 && box.z >= 0.0 && box.y < fres && box.w < fres;
  if (inside) {
    float span = fp(s, P_MAX_SLOPE) * (r_search + f.texel);
    float cap = f.w0 + fp(s, P_MAX_SLOPE) * (r_min + f.texel);
    bvec2 ld = block_test(f, s, box, f.w0 - span, f.w0 + span, cap);
    if (ld.y) {
      return 0.0;
    }
    if (ld.x) {
      return 1.0;
    }
  }
  float acc;
  int count = taps(f, s, r_search, 0, true, !inside, acc);
  if (count == 0) {
    return 1.0;
  }
  float mean = acc / float(count);
  float size = fp(s, P_SIZE);
  float radius;
  if (shadows[s].kind == MAP_ORTHO) {
    radius = size * mean;
  }
  else {
    radius = size * (1.0 - mean) / mx(mean, 1e-6);
  }
  radius = mn(mx(radius, r_min), r_search);
  return pcf(f, s, radius, 1, PCF_REACH);
}

/* Fraction of light reaching point p (geometric normal n) from shadow map s, its taps turned
 * by the hash of the three words of seed (core/render/shadow_filter.pixel_seeds); 1 outside
 * every map and for non-finite input. */
float shadow_visibility(int s, vec3 p, vec3 n, uvec3 seed)
{
  if (s < 0 || isnan(p.x + p.y + p.z + n.x + n.y + n.z) ||
      isinf(p.x + p.y + p.z + n.x + n.y + n.z)) {
    return 1.0;
  }
  Setup f;
  bool ok = shadows[s].kind == MAP_ORTHO ? setup_ortho(f, s, p, n) :
                                           setup_perspective(f, s, p, n);
  if (!ok) {
    return 1.0;
  }
  f.jc = sqrt(f.jc1 * f.jc1 + f.jc2 * f.jc2);
  f.jr = sqrt(f.jr1 * f.jr1 + f.jr2 * f.jr2);
  float c = 1.0, sn = 0.0;
  if (shadows[s].ints2.z != 0) {
    vec2 rot = texelFetch(shadow_rotations, ivec2(rotation_index(seed), 0), 0).xy;
    c = rot.x;
    sn = rot.y;
  }
  f.ac = c * f.jc1 + sn * f.jc2;
  f.bc = c * f.jc2 - sn * f.jc1;
  f.ar = c * f.jr1 + sn * f.jr2;
  f.br = c * f.jr2 - sn * f.jr1;
  f.cs = c;
  f.sn = sn;
  float r_min = fp(s, P_MIN_FILTER) * f.texel;
  if (fp(s, P_SIZE) > 0.0) {
    float r_search = search_radius(f, s);
    if (r_search > 1.5 * r_min) {
      return pcss(f, s, mx(r_search, r_min), r_min);
    }
  }
  return pcf(f, s, r_min, 2, HARD_REACH);
}
