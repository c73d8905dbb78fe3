/* One shader AOV (frame.counts.x: its number in the settings' list) of the sample's visible
 * points: what the material's AOV Output node gives there (material_aov: its colour and 1, or
 * its value), 0 for a material without one and for a holdout (pipeline.render_tile's AOV
 * columns, added up over the samples; a blended stack's layers weighted by their shares). */
void main()
{
#ifdef MATERIALS
  material_derivatives();
#endif
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 nearest = texelFetch(visible, pixel, 0);
  int seen = key_triangle(nearest);
  float weight = 1.0;
#ifdef BLENDED
  if (!stack_drawn(pixel, v_tri, v_flags, seen, weight)) {
    discard;  /* (frame_frag.glsl's blended stacks) */
  }
#endif
  if (seen != v_tri) {
    discard;  /* culled, behind, or peeled (the pre-pass's triangle) */
  }
  out_aov = vec4(0.0);
#ifdef MATERIALS
  if ((v_flags & 2) == 0) {
    Surface s = surface_at(v_position, v_normal, v_geo, v_material);
    out_aov = weight * material_aov(v_material, frame.counts.x, s);
  }
#endif
}
