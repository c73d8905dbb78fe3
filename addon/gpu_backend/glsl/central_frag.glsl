/* Depth and IndexMA, from the sample nearest the pixel centre (pipeline.render_tile): the
 * view-axis distance and the material's pass index. */
void main()
{
  vec4 nearest = texelFetch(visible, ivec2(gl_FragCoord.xy), 0);
  if (key_triangle(nearest) != v_tri) {
    discard;  /* culled, behind, or peeled (the pre-pass's triangle) */
  }
  if ((v_flags & 2) != 0) { /* a holdout: no surface */
    out_central = vec4(1e10, 0.0, 0.0, 0.0);
    return;
  }
  float index = texelFetch(materials, ivec2(4 * v_material + 3, 0), 0).r;
#ifdef MOTION
  vec3 seen = v_moved;  /* where the sample's time draws it */
#else
  vec3 seen = v_position;
#endif
  out_central = vec4(-(frame.world_to_camera * vec4(seen, 1.0)).z, index, 0.0, 1.0);
}
