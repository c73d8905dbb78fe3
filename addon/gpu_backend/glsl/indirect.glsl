/* Indirect light: the SH irradiance and the normalized, prefiltered reflections of a point.
 *
 * The GLSL form of core/kernels/indirect.py (indirect, volume_blend, sample_chain, _env_brdf)
 * and of core/lighting/probes.py (_pixel_sh, the probes' weights), held to them by
 * tests/gpu/test_stages.py. The method and its slides: probes.py's docstring (the talk's
 * "Environment lighting: split approximation", "Black Ops: environment map pre-filtering",
 * "Black Ops: normalization algorithm", "Improved normalization algorithm", "Black Ops:
 * environment map 'Fresnel'" and "Final approximation").
 *
 * Reads: indirect (IndirectData), reflections[] (ReflectionData; the world's chain and SH
 * after the probes, at index counts.x), volumes[] (VolumeData; the bounce volume after them),
 * chains (RGBA32F rows: every level of every chain with its one-texel border, RGB),
 * volume_sh (RGBA32F rows: 9 per volume sample, RGB, the sample's validity in the first's A),
 * volume_depth (RGBA32F rows: each volume sample's depth moments, six faces with their
 * one-texel border, mean and mean square in RG; sample_visibility.py),
 * env_table (RG32F: the ground-truth table, gloss rows x n.v columns; its axes in
 * env_axes, row 0 gloss, row 1 n.v). ROW_WIDTH: texels per row of the rows textures;
 * EXTRAPOLATION_LOW, EXTRAPOLATION_HIGH: probes.EXTRAPOLATION; NEAREST:
 * kernels.indirect.NEAREST; CHOSEN: the reflection probes a block holds, plus the world and
 * NEAREST. */

#define NORM_NONE 0
#define NORM_BO1 1
#define NORM_BO2 2
#define ENV_TABLE 0
#define ENV_BO1 1
#define ENV_BO2 2
#define ENV_FIT 3
#define LUMINANCE vec3(0.2126, 0.7152, 0.0722)

vec4 row_at(sampler2D rows, int k)
{
  return texelFetch(rows, ivec2(k % ROW_WIDTH, k / ROW_WIDTH), 0);
}

/* sh.basis of a direction times the band factors. */
void sh_basis(vec3 d, out float y[9])
{
  y[0] = 0.28209479177387814 * indirect.band[0].x;
  y[1] = 0.4886025119029199 * d.y * indirect.band[0].y;
  y[2] = 0.4886025119029199 * d.z * indirect.band[0].z;
  y[3] = 0.4886025119029199 * d.x * indirect.band[0].w;
  y[4] = 1.0925484305920792 * d.x * d.y * indirect.band[1].x;
  y[5] = 1.0925484305920792 * d.y * d.z * indirect.band[1].y;
  y[6] = 0.31539156525252005 * (3.0 * d.z * d.z - 1.0) * indirect.band[1].z;
  y[7] = 1.0925484305920792 * d.x * d.z * indirect.band[1].w;
  y[8] = 0.5462742152960396 * (d.x * d.x - d.y * d.y) * indirect.band[2].x;
}

/* cubemap._bilinear_padded: a padded level (side + 2 per face, at texel `base`). */
vec3 chain_bilinear(int base, int size, int face, float x, float y)
{
  float s = float(size);
  float fx = x - 0.5, fy = y - 0.5;
  float x0 = clamp(floor(fx), -1.0, s - 1.0);
  float y0 = clamp(floor(fy), -1.0, s - 1.0);
  float tx = clamp(fx - x0, 0.0, 1.0);
  float ty = clamp(fy - y0, 0.0, 1.0);
  int xi = int(x0) + 1, yi = int(y0) + 1;
  int row = size + 2;
  int at = base + (face * row + yi) * row + xi;
  vec3 top = row_at(chains, at).rgb * (1.0 - tx) + row_at(chains, at + 1).rgb * tx;
  vec3 bottom = row_at(chains, at + row).rgb * (1.0 - tx) + row_at(chains, at + row + 1).rgb * tx;
  return top * (1.0 - ty) + bottom * ty;
}

/* kernels.indirect._face_uv: the cube face of direction d and u, v in [0, 1] on it. */
void cube_face_uv(vec3 d, out int face, out float u, out float v)
{
  if (isnan(d.x + d.y + d.z) || isinf(d.x + d.y + d.z) || !(max(abs(d.x), max(abs(d.y), abs(d.z))) > 0.0)) {
    d = vec3(1.0, 0.0, 0.0);
  }
  vec3 a = abs(d);
  int axis;
  float depth, comp;
  if (a.x >= a.y && a.x >= a.z) {
    axis = 0; depth = a.x; comp = d.x;
  }
  else if (a.y >= a.z) {
    axis = 1; depth = a.y; comp = d.y;
  }
  else {
    axis = 2; depth = a.z; comp = d.z;
  }
  face = 2 * axis + (comp < 0.0 ? 1 : 0);
  u = (clamp(dot(d, CUBE_U[face]) / depth, -1.0, 1.0) + 1.0) * 0.5;
  v = (1.0 - clamp(dot(d, CUBE_V[face]) / depth, -1.0, 1.0)) * 0.5;
}

/* cubemap.sample of chain c along d at lod = top - g top (trilinear, seamless). */
vec3 sample_chain(int c, vec3 d, float gloss)
{
  int top = reflections[c].counts.x - 1;
  if (top < 0) {
    return vec3(0.0);
  }
  int face;
  float u, v;
  cube_face_uv(d, face, u, v);
  float g = isnan(gloss) ? gloss : clamp(gloss, 0.0, 1.0);
  float lod = float(top) - g * float(top);
  if (isnan(lod)) {
    lod = float(top);
  }
  lod = clamp(lod, 0.0, float(top));
  int base = int(floor(lod));
  float frac = lod - float(base);
  vec3 out_ = vec3(0.0);
  for (int k = base; k <= min(base + 1, top); k++) {
    float w = k == base ? 1.0 - frac : frac;
    if (!(w > 0.0)) {
      continue;
    }
    int size = reflections[c].sides[k >> 2][k & 3];
    int offset = reflections[c].offsets[k >> 2][k & 3];
    out_ += w * chain_bilinear(offset, size, face, u * float(size), v * float(size));
  }
  return out_;
}

/* Where the reflected ray leaves probe k's proxy (Lagarde and Zanuttini 2012), or 0. */
float parallax(int k, vec3 x, vec3 r)
{
  vec3 q = vec3(dot(reflections[k].proxy[0], vec4(x, 1.0)), dot(reflections[k].proxy[1], vec4(x, 1.0)),
                dot(reflections[k].proxy[2], vec4(x, 1.0)));
  vec3 d = vec3(dot(reflections[k].proxy[0].xyz, r), dot(reflections[k].proxy[1].xyz, r),
                dot(reflections[k].proxy[2].xyz, r));
  if (reflections[k].counts.y == 1) {
    float a = dot(d, d);
    float b = dot(q, d);
    float c = dot(q, q) - 1.0;
    float disc = b * b - a * c;
    if (!(a > 0.0 && disc >= 0.0)) {
      return 0.0;
    }
    float t = (-b + sqrt(disc)) / a;
    return t > 0.0 ? t : 0.0;
  }
  float t = 1.0 / 0.0;
  for (int i = 0; i < 3; i++) {
    if (d[i] > 0.0) {
      t = min(t, (1.0 - q[i]) / d[i]);
    }
    else if (d[i] < 0.0) {
      t = min(t, (-1.0 - q[i]) / d[i]);
    }
    else if (abs(q[i]) > 1.0) {
      return 0.0;
    }
  }
  return (t > 0.0 && !isinf(t)) ? t : 0.0;
}

/* np.interp(x, axis, arange(n)) over env_axes row `axis_row` of n entries. */
float axis_position(int axis_row, int n, float x)
{
  if (isnan(x)) {
    return x;
  }
  if (x <= texelFetch(env_axes, ivec2(0, axis_row), 0).r) {
    return 0.0;
  }
  if (x >= texelFetch(env_axes, ivec2(n - 1, axis_row), 0).r) {
    return float(n - 1);
  }
  int lo = 0, hi = n - 1;
  while (hi - lo > 1) {
    int mid = (lo + hi) / 2;
    if (texelFetch(env_axes, ivec2(mid, axis_row), 0).r <= x) {
      lo = mid;
    }
    else {
      hi = mid;
    }
  }
  float a = texelFetch(env_axes, ivec2(lo, axis_row), 0).r;
  float b = texelFetch(env_axes, ivec2(lo + 1, axis_row), 0).r;
  return float(lo) + (x - a) / (b - a);
}

vec2 table_parts(float fg, float fn)
{
  ivec2 size = textureSize(env_table, 0);
  int i0 = clamp(isnan(fg) ? 0 : int(floor(fg)), 0, size.y - 2);
  int j0 = clamp(isnan(fn) ? 0 : int(floor(fn)), 0, size.x - 2);
  float tg = fg - float(i0), tn = fn - float(j0);
  vec2 top = texelFetch(env_table, ivec2(j0, i0), 0).rg * (1.0 - tn) +
             texelFetch(env_table, ivec2(j0 + 1, i0), 0).rg * tn;
  vec2 bottom = texelFetch(env_table, ivec2(j0, i0 + 1), 0).rg * (1.0 - tn) +
                texelFetch(env_table, ivec2(j0 + 1, i0 + 1), 0).rg * tn;
  return top * (1.0 - tg) + bottom * tg;
}

/* env_brdf.environment_brdf of the model in indirect.counts.w. */
vec3 env_brdf(float gloss, float n_dot_v, vec3 rf0)
{
  int model = indirect.counts.w;
  float g = isnan(gloss) ? gloss : clamp(gloss, 0.0, 1.0);
  float nv = isnan(n_dot_v) ? n_dot_v : clamp(n_dot_v, indirect.limits.z, 1.0);
  float a0 = 0.0, a1 = 0.0;
  if (model == ENV_TABLE) {
    ivec2 size = textureSize(env_table, 0);
    vec2 parts = table_parts(axis_position(0, size.y, g), axis_position(1, size.x, nv));
    a0 = parts.x;
    a1 = parts.y;
  }
  else if (model == ENV_BO2) {
    float tx = g * (1.0 / 0.96);
    float ty = g * 0.475;
    float tz = g * ((0.0275 - 0.25 * 0.04) / 0.96) + (0.015 - 0.75 * 0.04) / 0.96;
    a0 = tx * min(ty, exp2(-9.28 * nv)) + tz;
    a1 = g * 0.25 + 0.75;
  }
  else if (model == ENV_FIT) {
    vec4 f0 = indirect.fit[0], f1 = indirect.fit[1], f2 = indirect.fit[2];
    float m = min(f0.z * g + f0.w, exp2(f1.z * nv));
    a0 = (f0.x * g + f0.y) * m + (f1.x * g + f1.y);
    a1 = min(f2.y * m + (f1.w * g + f2.x), 1.0);
  }
  vec3 f = clamp(rf0, 0.0, 1.0);
  if (model == ENV_BO1) {
    float t = 1.0 - nv;
    return f + (1.0 - f) * (t * t) * (t * t) * t / (4.0 - 3.0 * g);
  }
  if (model == ENV_TABLE) {
    return a0 * (1.0 - f) + a1 * f;
  }
  return clamp(a0 + f * (a1 - a0), 0.0, 1.0);
}

/* IrradianceVolume.weight of volume k at p. */
float volume_weight(int k, vec3 p)
{
  vec3 q = vec3(dot(volumes[k].to_local[0], vec4(p, 1.0)), dot(volumes[k].to_local[1], vec4(p, 1.0)),
                dot(volumes[k].to_local[2], vec4(p, 1.0)));
  float dist = length(max(abs(q) - 1.0, vec3(0.0)));
  float influence = volumes[k].params.x;
  if (influence <= 0.0) {
    return dist <= 0.0 ? 1.0 : 0.0;
  }
  float fac = 1.0 / max(volumes[k].params.y, 1e-4);
  return clamp(fac * (1.0 - dist / influence), 0.0, 1.0);
}

/* kernels.indirect._moment: the (mean, mean square) of the padded moments (faces of size + 2
 * texels square) of the sample whose first texel is `base` in volume_depth, on `face` at texel
 * coordinates x, y in [0, size]. */
vec2 moment_at(int base, int size, int face, float x, float y)
{
  int side = size + 2;
  float fx = x - 0.5, fy = y - 0.5;
  float x0 = clamp(floor(fx), -1.0, float(size) - 1.0);
  float y0 = clamp(floor(fy), -1.0, float(size) - 1.0);
  float tx = clamp(fx - x0, 0.0, 1.0);
  float ty = clamp(fy - y0, 0.0, 1.0);
  int at = base + (face * side + int(y0) + 1) * side + int(x0) + 1;
  vec2 top = row_at(volume_depth, at).rg * (1.0 - tx) + row_at(volume_depth, at + 1).rg * tx;
  vec2 bottom = row_at(volume_depth, at + side).rg * (1.0 - tx) +
                row_at(volume_depth, at + side + 1).rg * tx;
  return top * (1.0 - ty) + bottom * ty;
}

/* kernels.indirect._visibility: the weight of the sample at sample_p (its moments at `base`,
 * `size` texels square, clamped at `far` metres) for the point p; floor_: the smallest
 * variance, m^2. */
float sample_visibility(int base, int size, float floor_, float far, vec3 sample_p, vec3 p)
{
  vec3 d = p - sample_p;
  float r = min(length(d), far);
  int face;
  float u, v;
  cube_face_uv(d, face, u, v);
  vec2 m = moment_at(base, size, face, u * float(size), v * float(size));
  if (r <= m.x) {
    return 1.0;
  }
  float var = max(m.y - m.x * m.x, floor_);
  float bound = var / (var + (r - m.x) * (r - m.x));
  return bound * bound * bound;
}

/* kernels.indirect._blend: add the blend of volume k's eight samples around grid
 * coordinates f (within [0, res - 1]) at p, normal n, to acc. */
void volume_blend_at(int k, vec3 f, vec3 p, vec3 n, inout vec3 acc[9])
{
  ivec3 res = volumes[k].res.xyz;
  bool facing = volumes[k].facing.y != 0.0;
  bool has_validity = volumes[k].facing.z != 0.0;
  bool visible = indirect.flags.y != 0 && volumes[k].visibility.x >= 0.0;
  ivec3 i0;
  vec3 t;
  for (int a = 0; a < 3; a++) {
    i0[a] = max(min(int(floor(f[a])), res[a] - 2), 0);
    t[a] = f[a] - float(i0[a]);
  }
  float w_plain[8], w_kept[8], validity[8];
  int rows[8];
  float kept_sum = 0.0, valid_sum = 0.0, plain_sum = 0.0;
  for (int c = 0; c < 8; c++) {
    float w = 1.0;
    int idx = 0;
    ivec3 cell;
    for (int a = 0; a < 3; a++) {
      int bit = (c >> a) & 1;
      int j = min(i0[a] + bit, res[a] - 1);
      cell[a] = j;
      idx = idx * res[a] + j;
      w *= bit != 0 ? t[a] : 1.0 - t[a];
    }
    rows[c] = volumes[k].res.w + 9 * idx;
    w_plain[c] = w;
    validity[c] = has_validity ? row_at(volume_sh, rows[c]).a : 1.0;
    float kept = w * validity[c];
    vec3 local = (vec3(cell) + 0.5) / vec3(res) * 2.0 - 1.0;
    vec3 sample_p = vec3(dot(volumes[k].to_world[0], vec4(local, 1.0)),
                         dot(volumes[k].to_world[1], vec4(local, 1.0)),
                         dot(volumes[k].to_world[2], vec4(local, 1.0)));
    if (facing) {
      vec3 d = sample_p - p;
      float len = max(length(d), 1e-6);
      kept *= max(dot(d, n) / len + volumes[k].facing.x, 0.0);
    }
    if (visible && kept > 0.0) {
      int size = int(volumes[k].visibility.z);
      int base = int(volumes[k].visibility.x) + idx * 6 * (size + 2) * (size + 2);
      kept *= sample_visibility(base, size, volumes[k].visibility.y, volumes[k].visibility.w,
                                sample_p, p);
    }
    w_kept[c] = kept;
    kept_sum += kept;
    valid_sum += w * validity[c];
    plain_sum += w;
  }
  for (int c = 0; c < 8; c++) {
    float b;
    if (kept_sum > 1e-6) {
      b = w_kept[c] / kept_sum;
    }
    else if (has_validity && valid_sum > 1e-6) {
      b = w_plain[c] * validity[c] / valid_sum;
    }
    else {
      b = w_plain[c] / max(plain_sum, 1e-30);
    }
    if (b != 0.0) {
      for (int j = 0; j < 9; j++) {
        acc[j] += b * row_at(volume_sh, rows[c] + j).rgb;
      }
    }
  }
}

/* IrradianceVolume.sample_sh (kernels.indirect.volume_blend) of volume k at p, normal n, view v:
 * within the outermost samples their blend; up to the box's faces, held or (indirect.limits.w)
 * scaled by the extrapolated luminance of its DC term. */
void volume_sh_at(int k, vec3 p, vec3 n, vec3 v, out vec3 out_sh[9])
{
  ivec3 res = volumes[k].res.xyz;
  p = p + volumes[k].params.z * n + volumes[k].params.w * v;
  vec3 q = vec3(dot(volumes[k].to_local[0], vec4(p, 1.0)), dot(volumes[k].to_local[1], vec4(p, 1.0)),
                dot(volumes[k].to_local[2], vec4(p, 1.0)));
  vec3 grid = (q + 1.0) * 0.5 * vec3(res) - 0.5;
  vec3 f = clamp(grid, vec3(0.0), vec3(res - 1));
  vec3 past = vec3(0.0);
  for (int a = 0; a < 3; a++) {
    if (res[a] > 1) {
      past[a] = clamp(grid[a], -0.5, float(res[a]) - 0.5) - f[a];
    }
  }
  for (int j = 0; j < 9; j++) {
    out_sh[j] = vec3(0.0);
  }
  volume_blend_at(k, f, p, n, out_sh);
  if (past == vec3(0.0) || indirect.limits.w == 0.0) {
    return;
  }
  float luma = dot(out_sh[0], LUMINANCE);
  if (luma <= 0.0) {
    return;
  }
  float extra = 0.0;
  vec3 inward[9];
  for (int a = 0; a < 3; a++) {
    if (past[a] == 0.0) {
      continue;
    }
    vec3 g = f;
    g[a] += past[a] < 0.0 ? 1.0 : -1.0;
    for (int j = 0; j < 9; j++) {
      inward[j] = vec3(0.0);
    }
    volume_blend_at(k, g, p, n, inward);
    extra += abs(past[a]) * (luma - dot(inward[0], LUMINANCE));
  }
  float scale = clamp(1.0 + extra / luma, EXTRAPOLATION_LOW, EXTRAPOLATION_HIGH);
  for (int j = 0; j < 9; j++) {
    out_sh[j] *= scale;
  }
}

/* probes._pixel_sh: the volumes' blend, the bounce where they leave weight, the world's SH
 * times the share they leave and the fraction of the world's light that reaches the point. */
void pixel_sh(vec3 p, vec3 n, vec3 v, float sky, out vec3 out_sh[9])
{
  float total = 0.0;
  for (int j = 0; j < 9; j++) {
    out_sh[j] = vec3(0.0);
  }
  vec3 part[9];
  for (int k = 0; k < indirect.counts.y; k++) {
    float w = volume_weight(k, p);
    if (w > 0.0) {
      volume_sh_at(k, p, n, v, part);
      for (int j = 0; j < 9; j++) {
        out_sh[j] += w * part[j];
      }
      total += w;
    }
  }
  if (total > 1.0) {
    for (int j = 0; j < 9; j++) {
      out_sh[j] /= total;
    }
  }
  float share = max(1.0 - total, 0.0);
  int bounce = indirect.flags.x;
  if (bounce >= 0) {
    float w = volume_weight(bounce, p) * share;
    if (w > 0.0) {
      volume_sh_at(bounce, p, n, v, part);
      for (int j = 0; j < 9; j++) {
        out_sh[j] += w * part[j];
      }
    }
  }
  if (share > 0.0) {
    share *= sky;
  }
  for (int j = 0; j < 9; j++) {
    out_sh[j] += share * indirect.world_sh[j].rgb;
  }
}

/* kernels.indirect._chain_radiance: chain c's radiance along r at p (a probe's, or the world's:
 * c == counts.x), normalized. */
vec3 chain_radiance(int c, vec3 p, vec3 r, float gloss, vec3 e, float y[9], vec3 psh[9])
{
  int probes_count = indirect.counts.x;
  int normalization = indirect.counts.z;
  float eps = indirect.limits.x, max_ratio = indirect.limits.y;
  vec3 s;
  if (c == probes_count && indirect.world_color.w != 0.0) {
    s = indirect.world_color.rgb;
  }
  else {
    float t = 0.0;
    vec3 d = c < probes_count ? p - reflections[c].position : vec3(0.0);
    if (c < probes_count && reflections[c].counts.y != 0) {
      t = parallax(c, p, r);
    }
    s = t > 0.0 ? sample_chain(c, d + t * r, gloss) : sample_chain(c, r, gloss);
  }
  if (normalization == NORM_BO2) {
    float probe_e = 0.0;
    for (int k = 0; k < 9; k++) {
      probe_e += y[k] * reflections[c].scalar[k >> 2][k & 3];
    }
    s *= clamp((e + eps) / (probe_e * reflections[c].tint.rgb + eps), 0.0, max_ratio);
  }
  else if (normalization == NORM_BO1) {
    s *= clamp((psh[0] + eps) / reflections[c].dc_eps.rgb, 0.0, max_ratio);
  }
  return s;
}

/* kernels.indirect._nearest_weights: the NEAREST probes nearest p into near and their weights,
 * summing to 1, into weights; returns how many. */
int nearest_weights(vec3 p, out int near[NEAREST + 1], out float weights[NEAREST])
{
  float near_d[NEAREST + 1];
  int count = 0;
  for (int q = 0; q < indirect.counts.x; q++) {
    vec3 d = p - reflections[q].position;
    float dq = dot(d, d);
    int j = min(count, NEAREST + 1);
    while (j > 0 && near_d[j - 1] > dq) {
      if (j < NEAREST + 1) {
        near[j] = near[j - 1];
        near_d[j] = near_d[j - 1];
      }
      j--;
    }
    if (j < NEAREST + 1) {
      near[j] = q;
      near_d[j] = dq;
      count = min(count + 1, NEAREST + 1);
    }
  }
  int k = min(count, NEAREST);
  float beyond = count > k ? 1.0 / max(near_d[k], 1e-12) : 0.0;
  float total = 0.0;
  for (int j = 0; j < k; j++) {
    weights[j] = 1.0 / max(near_d[j], 1e-12) - beyond;
    total += weights[j];
  }
  for (int j = 0; j < k; j++) {
    weights[j] = total > 0.0 ? weights[j] / total : 1.0 / float(k);
  }
  return k;
}

/* kernels.indirect.indirect of one point, its SH given, the world's seen fraction `seen`:
 * diffuse and specular radiance. */
void indirect_light(vec3 p, vec3 n, vec3 v, vec3 albedo, vec3 rf0, float gloss, vec3 psh[9],
                    float seen, out vec3 diffuse, out vec3 specular)
{
  float y[9];
  sh_basis(n, y);
  vec3 e = vec3(0.0);
  for (int k = 0; k < 9; k++) {
    e += y[k] * psh[k];
  }
  diffuse = albedo * e * INV_PI;
  float n_dot_v = dot(n, v);
  vec3 r = 2.0 * n_dot_v * n - v;
  int probes_count = indirect.counts.x;
  int chosen[CHOSEN];  /* the chains that reflect, and their weights */
  float chosen_w[CHOSEN];
  int count = 0;
  float weight_sum = 0.0;
  for (int c = 0; c < probes_count; c++) {
    float w = clamp((reflections[c].radius - length(p - reflections[c].position)) /
                    reflections[c].fade, 0.0, 1.0);
    if (w > 0.0) {
      chosen[count] = c;
      chosen_w[count] = w;
      count++;
      weight_sum += w;
    }
  }
  if (weight_sum > 1.0) {
    for (int j = 0; j < count; j++) {
      chosen_w[j] /= weight_sum;
    }
  }
  float left = max(1.0 - weight_sum, 0.0);
  if (left > 0.0) {
    float shown = probes_count == 0 || indirect.flags.z == 0 || isnan(seen) ? 1.0 :
                  clamp(seen, 0.0, 1.0);
    if (shown > 0.0) {
      chosen[count] = probes_count;
      chosen_w[count] = left * shown;
      count++;
    }
    float hidden = left * (1.0 - shown);
    if (hidden > 0.0) {
      int near[NEAREST + 1];
      float near_w[NEAREST];
      int found = nearest_weights(p, near, near_w);
      for (int j = 0; j < found; j++) {
        chosen[count] = near[j];
        chosen_w[count] = hidden * near_w[j];
        count++;
      }
    }
  }
  vec3 acc = vec3(0.0);
  for (int j = 0; j < count; j++) {
    acc += chosen_w[j] * chain_radiance(chosen[j], p, r, gloss, e, y, psh);
  }
  specular = acc * env_brdf(gloss, n_dot_v, rf0);
}

/* The influence views (core/render/viewport.probe_influence): each reflection probe's (kind 0)
 * or irradiance volume's (1) colour by its weight at p, the world's grey where they leave
 * weight. */
vec3 influence_colour(int kind, vec3 p)
{
  int count = kind == 0 ? indirect.counts.x : indirect.counts.y;
  vec3 colour = vec3(0.0);
  float total = 0.0;
  for (int k = 0; k < count; k++) {
    float w;
    if (kind == 0) {
      w = clamp((reflections[k].radius - length(p - reflections[k].position)) /
                reflections[k].fade, 0.0, 1.0);
    }
    else {
      w = volume_weight(k, p);
    }
    colour += w * PALETTE[k % PALETTE.length()];
    total += w;
  }
  if (total > 1.0) {
    colour /= total;
  }
  return colour + max(1.0 - total, 0.0) * WORLD_GREY;
}
