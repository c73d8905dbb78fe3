/* Filtered texture look-ups: the GLSL form of core/kernels/textures.sample (Williams 1983
 * trilinear filtering with Blender's UV conventions and Cycles' wrap functions, closest and
 * cubic B-spline filters, sRGB decoding after the interpolation, associated alpha), held to it
 * by tests/gpu/test_stages.py.
 *
 * A texture's texels are rows of a texture (one texel per pixel, its C channels in RGBA): level
 * k starts at texel images[t].levels[k].x, its rows top-first (h = .y, w = .z). 8-bit images
 * keep their codes (RGBA8: the code / 255 as the kernel reads it), and the sRGB channels of
 * their levels after 0 hold codes decoded through srgb_table. */

#define TEX_REPEAT 0
#define TEX_EXTEND 1
#define TEX_CLIP 2
#define TEX_MIRROR 3
#define TEX_LINEAR 0
#define TEX_CLOSEST 1
#define TEX_CUBIC 2

float srgb_formula(float v)
{
  return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

float srgb_decode(float v)
{
  if (!(v > 0.0)) {
    return isnan(v) ? v : 0.0;
  }
  return srgb_formula(v);
}

/* Texel index i wrapped into [0, n) (Cycles' wrap functions); ok: inside the image (CLIP). */
int tex_wrap(int i, int n, int extension, out bool ok)
{
  ok = true;
  if (extension == TEX_REPEAT) {  /* (% of a negative number is undefined in GLSL) */
    return i - n * (i >= 0 ? i / n : -((-i + n - 1) / n));
  }
  if (extension == TEX_MIRROR) {
    int m = abs(i + (i < 0 ? 1 : 0)) % (2 * n);
    return m >= n ? 2 * n - m - 1 : m;
  }
  ok = extension != TEX_CLIP || (i >= 0 && i < n);
  return clamp(i, 0, n - 1);
}

vec4 texel_at(sampler2D texels, int width, int at)
{
  return texelFetch(texels, ivec2(at % width, at / width), 0);
}

/* One stored texel of level k at (row, col), top-first; decoded: an 8-bit level after 0
 * whose sRGB channels hold codes (decoded through srgb_table). */
vec4 tex_fetch(int t, sampler2D texels, int k, int row, int col)
{
  ivec4 lv = images[t].levels[k];
  vec4 v = texel_at(texels, images[t].info2.z, lv.x + (lv.y - 1 - row) * lv.z + col);
  if (k > 0 && images[t].info2.y != 0) {
    for (int c = 0; c < min(images[t].info2.x, 3); c++) {
      v[c] = texelFetch(srgb_table, ivec2(int(v[c] * 255.0 + 0.5), 0), 0).r;
    }
  }
  return v;
}

/* texture.sample of image t at uv (Blender's: v up); lod < 0: level 0 without mips. */
vec4 texture_sample(int t, sampler2D texels, vec2 uv, float lod, int associate)
{
  int levels = images[t].info.x, channels = images[t].info.y;
  int extension = images[t].info.z, mode = images[t].info.w;
  int decode = images[t].info2.x;
  bool assoc = associate > 0 && channels == 4;
  bool straight = assoc && associate == 2;
  float uu = (isnan(uv.x) || isinf(uv.x)) ? 0.0 : uv.x;
  float vv = (isnan(uv.y) || isinf(uv.y)) ? 0.0 : uv.y;
  vec4 out_ = vec4(0.0);
  int top = levels - 1;
  int base = 0;
  float frac = 0.0;
  if (mode == TEX_CLOSEST) {
    ivec4 lv = images[t].levels[0];
    bool col_ok, row_ok;
    int col = tex_wrap(int(floor(uu * float(lv.z))), lv.z, extension, col_ok);
    int row = tex_wrap(int(floor(vv * float(lv.y))), lv.y, extension, row_ok);
    vec4 vals = (col_ok && row_ok) ? tex_fetch(t, texels, 0, row, col) : vec4(0.0);
    if (assoc) {
      vals.rgb *= vals.a;
    }
    base = -1;  /* done */
    out_ = vals;
  }
  else if (lod >= 0.0 || isnan(lod)) {
    float level = isnan(lod) ? float(top) : clamp(lod, 0.0, float(top));
    base = int(floor(level));
    frac = level - float(base);
  }
  if (base >= 0) {
    for (int k = base; k <= min(base + 1, top); k++) {
      float weight = k == base ? 1.0 - frac : frac;
      if (!(weight > 0.0)) {
        continue;
      }
      ivec4 lv = images[t].levels[k];
      float x = uu * float(lv.z) - 0.5, y = vv * float(lv.y) - 0.5;
      float x0 = floor(x), y0 = floor(y);
      float tx = x - x0, ty = y - y0;
      vec4 vals = vec4(0.0);
      if (mode == TEX_CUBIC && k == 0) {
        vec4 wx = vec4((((-1.0 / 6.0) * tx + 0.5) * tx - 0.5) * tx + 1.0 / 6.0,
                       ((0.5 * tx - 1.0) * tx) * tx + 2.0 / 3.0,
                       ((-0.5 * tx + 0.5) * tx + 0.5) * tx + 1.0 / 6.0, (1.0 / 6.0) * tx * tx * tx);
        vec4 wy = vec4((((-1.0 / 6.0) * ty + 0.5) * ty - 0.5) * ty + 1.0 / 6.0,
                       ((0.5 * ty - 1.0) * ty) * ty + 2.0 / 3.0,
                       ((-0.5 * ty + 0.5) * ty + 0.5) * ty + 1.0 / 6.0, (1.0 / 6.0) * ty * ty * ty);
        for (int j = 0; j < 4; j++) {
          bool row_ok;
          int row = tex_wrap(int(y0) - 1 + j, lv.y, extension, row_ok);
          if (!row_ok) {
            continue;
          }
          vec4 line = vec4(0.0);
          for (int m = 0; m < 4; m++) {
            bool col_ok;
            int col = tex_wrap(int(x0) - 1 + m, lv.z, extension, col_ok);
            if (col_ok) {
              vec4 tap = tex_fetch(t, texels, 0, row, col);
              if (assoc) {
                tap.rgb *= tap.a;
              }
              line += wx[m] * tap;
            }
          }
          vals += wy[j] * line;
        }
      }
      else {
        bool ok0, ok1, okr0, okr1;
        int c0 = tex_wrap(int(x0), lv.z, extension, ok0);
        int c1 = tex_wrap(int(x0) + 1, lv.z, extension, ok1);
        int r0 = tex_wrap(int(y0), lv.y, extension, okr0);
        int r1 = tex_wrap(int(y0) + 1, lv.y, extension, okr1);
        vec4 taps[4] = vec4[4](tex_fetch(t, texels, k, r0, c0), tex_fetch(t, texels, k, r0, c1),
                               tex_fetch(t, texels, k, r1, c0), tex_fetch(t, texels, k, r1, c1));
        float w[4] = float[4]((okr0 && ok0) ? (1.0 - tx) * (1.0 - ty) : 0.0,
                              (okr0 && ok1) ? tx * (1.0 - ty) : 0.0,
                              (okr1 && ok0) ? (1.0 - tx) * ty : 0.0,
                              (okr1 && ok1) ? tx * ty : 0.0);
        for (int q = 0; q < 4; q++) {
          vec4 tap = taps[q];
          if (assoc) {
            tap.rgb *= tap.a;
          }
          vals += w[q] * tap;
        }
      }
      if (straight) {
        vals.rgb = vals.a > 0.0 ? vals.rgb / vals.a : vec3(0.0);
      }
      for (int c = 0; c < (k == 0 ? decode : 0); c++) {
        vals[c] = srgb_decode(vals[c]);
      }
      out_ += weight * vals;
    }
  }
  else {
    if (straight) {
      out_.rgb = out_.a > 0.0 ? out_.rgb / out_.a : vec3(0.0);
    }
    for (int c = 0; c < decode; c++) {
      out_[c] = srgb_decode(out_[c]);
    }
  }
  return out_;
}
