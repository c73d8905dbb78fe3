/* One level of a shadow map's reduction pyramid (core/kernels/raster.py: reduction): per block
 * of BLOCK x BLOCK texels of the source (cut by its edge), the least distance from the light,
 * the least and the greatest depth. FROM_DEPTHS: the source is the map's depths (layer
 * where.x), each texel's distance its depth times the length of its ray per unit of face-axis
 * depth (perspective faces, where.z), as core/render/shadows.py's _perspective_jobs; else the
 * level before (rgb as written here). where.y: the source's side. */
void main()
{
  ivec2 out_texel = ivec2(gl_FragCoord.xy);
  int side = where.y;
  float lo_d = 1.0 / 0.0, lo = 1.0 / 0.0, hi = -1.0 / 0.0;
  float inv = 2.0 / float(where.w);
  for (int r = out_texel.y * BLOCK; r < min(out_texel.y * BLOCK + BLOCK, side); r++) {
    for (int c = out_texel.x * BLOCK; c < min(out_texel.x * BLOCK + BLOCK, side); c++) {
#if FROM_DEPTHS
      float depth = texelFetch(source, ivec3(c, r, where.x), 0).r;
      float dist = depth;
      if (where.z != 0) {
        float x = (float(c) + 0.5) * inv - 1.0, y = (float(r) + 0.5) * inv - 1.0;
        dist = depth * sqrt(1.0 + tan_half * tan_half * (x * x + y * y));
      }
      lo_d = min(lo_d, dist);
      lo = min(lo, depth);
      hi = max(hi, depth);
#else
      vec4 v = texelFetch(source, ivec3(c, r, where.x), 0);
      lo_d = min(lo_d, v.r);
      lo = min(lo, v.g);
      hi = max(hi, v.b);
#endif
    }
  }
  out_level = vec4(lo_d, lo, hi, 0.0);
}
