/* Stochastic transparency, one layer's test (core/render/transparency.dither): where the
 * pixel's surface may be transparent and its alpha does not exceed the pixel's threshold for
 * the sample (frame.size.z) and the layer (frame.counts.x), the surface is peeled: out_floor
 * holds it (its triangle, its depth, 1) for the next layer's pre-pass to look behind. After
 * the first layer only the pixels peeled by the layer before (peel_prev.a) are tested: a
 * surface kept stays. */
void main()
{
#ifdef MATERIALS
  material_derivatives();
#endif
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 nearest = texelFetch(visible, pixel, 0);
  if (key_triangle(nearest) != v_tri || (v_flags & 4) == 0 ||
      (frame.counts.x > 0 && texelFetch(peel_prev, pixel, 0).a == 0.0)) {
    discard;
  }
  Surface s = surface_at(v_position, v_normal, v_geo, v_material);
  ivec2 at = ivec2(pixel.x, frame.size.y - 1 - pixel.y);
  if (s.alpha > dither_threshold(at, frame.size.z, frame.counts.x)) {
    discard;  /* kept */
  }
  out_floor = vec4(nearest.rgb, 1.0);
}
