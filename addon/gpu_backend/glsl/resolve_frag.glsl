/* The viewport's image: the running total divided by the samples, as a look-dev view shows it
 * (core/render/viewport.view_pixels): RESOLVE_VIEW 0 the value, 1 a normal as 0.5 n + 0.5
 * where a surface is seen, 2 the alpha channel in grey, 3 the colour with alpha 1. */
void main()
{
  vec4 value = texelFetch(total, ivec2(gl_FragCoord.xy), 0) * scale;
#if RESOLVE_VIEW == 0
  out_color = value;
#elif RESOLVE_VIEW == 1
  out_color = value.a > 0.0 ? vec4(0.5 * value.rgb / value.a + 0.5, 1.0) : vec4(0.0, 0.0, 0.0, 1.0);
#elif RESOLVE_VIEW == 2
  out_color = vec4(value.aaa, 1.0);
#else
  out_color = vec4(value.rgb, 1.0);
#endif
}
