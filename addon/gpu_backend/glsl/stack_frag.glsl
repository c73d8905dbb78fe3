/* One step of a sample's blended stack (core/render/transparency.blend) at the surface each
 * pixel sees now (visible), where its stack goes on (stack_state.g; at the first step,
 * frame.counts.x = 0, where that surface is blended): a blended surface is taken as a layer
 * (its alpha), or peeled when its object shows once and shows already; a dithered one is
 * peeled where its alpha does not exceed the threshold of layer DITHER_LAYERS + the step;
 * any other surface ends the stack, and so does a blended one beyond BLEND_LAYERS (the stack
 * is cut there). out_record: (1 taken, 2 peeled, 3 ends here, 4 cut here; the alpha taken);
 * out_floor: the surface to look behind (peel_frag.glsl's). */
void main()
{
#ifdef MATERIALS
  material_derivatives();
#endif
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 nearest = texelFetch(visible, pixel, 0);
  if (key_triangle(nearest) != v_tri) {
    discard;
  }
  int step = frame.counts.x;
  vec4 st = texelFetch(stack_state, pixel, 0);
  if (step == 0 ? (v_flags & 32) == 0 : st.g == 0.0) {
    discard;  /* no stack, or it ended */
  }
  int count = int(st.r);
  bool take = (v_flags & 32) != 0, peel = false;
  float solo = take ? stack_order_of(v_tri).y : -1.0;
  for (int k = 0; k < count && solo >= 0.0; k++) {
    if (stack_order_of(int(stack_layer(pixel, k).x) - 1).y == solo) {
      take = false;  /* Transparency Overlap off: its nearest layer shows alone */
      peel = true;
      break;
    }
  }
  Surface s = surface_at(v_position, v_normal, v_geo, v_material);
  if (!take && !peel && (v_flags & 4) != 0) {
    ivec2 at = ivec2(pixel.x, frame.size.y - 1 - pixel.y);
    peel = !(s.alpha > dither_threshold(at, frame.size.z, DITHER_LAYERS + step));
  }
  float what = 3.0;
  if (take && count >= BLEND_LAYERS) {
    what = 4.0;
    take = false;
  }
  else if (take) {
    what = 1.0;
  }
  else if (peel) {
    what = 2.0;
  }
  out_record = vec4(what, take ? clamp(s.alpha, 0.0, 1.0) : 0.0, 0.0, 1.0);
  out_floor = take || peel ? vec4(nearest.rgb, 1.0) : vec4(0.0);
}
