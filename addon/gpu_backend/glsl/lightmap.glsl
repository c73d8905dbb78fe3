/* A baked lightmap's light at a point (core/render/shading.lightmap_sh and
 * core/lighting/lightmap.sample, as_sh): the bilinear look-up of lightmap k at uv (row 0 at
 * v = 1, clamped to the image), as the radiance SH the indirect light reads: an irradiance
 * lightmap's constant term alone (pi Y00 L00 = E), a directional one's L1 SH.
 *
 * Reads: lightmaps (LightmapData), lightmap_texels (rows of RGB texels, ROW_WIDTH per row;
 * a directional lightmap's pixel is four of them). */

vec3 lightmap_texel(int at)
{
  return texelFetch(lightmap_texels, ivec2(at % ROW_WIDTH, at / ROW_WIDTH), 0).rgb;
}

void lightmap_sh(int k, vec2 uv, out vec3 out_sh[9])
{
  ivec4 m = lightmaps.maps[k];
  int w = m.y, h = m.z, per = m.w / 3;
  float fx = uv.x * float(w) - 0.5;
  float fy = (1.0 - uv.y) * float(h) - 0.5;
  float x0 = clamp(floor(fx), 0.0, float(w - 1));
  float y0 = clamp(floor(fy), 0.0, float(h - 1));
  float tx = clamp(fx - x0, 0.0, 1.0), ty = clamp(fy - y0, 0.0, 1.0);
  int ix0 = int(x0), iy0 = int(y0);
  int ix1 = min(ix0 + 1, w - 1), iy1 = min(iy0 + 1, h - 1);
  int taps[4] = int[4](iy0 * w + ix0, iy0 * w + ix1, iy1 * w + ix0, iy1 * w + ix1);
  float wgt[4] = float[4]((1.0 - tx) * (1.0 - ty), tx * (1.0 - ty), (1.0 - tx) * ty, tx * ty);
  for (int j = 0; j < 9; j++) {
    out_sh[j] = vec3(0.0);
  }
  for (int j = 0; j < per; j++) {
    vec3 value = vec3(0.0);
    for (int q = 0; q < 4; q++) {
      value += wgt[q] * lightmap_texel(m.x + taps[q] * per + j);
    }
    out_sh[j] = per == 1 ? value / LIGHTMAP_SH_SCALE : value;
  }
}
