/* Depth and IndexMA, from the sample nearest the pixel centre (pipeline.render_tile): the
 * view-axis distance and the material's pass index. */
void main()
{
  if ((v_flags & 1) != 0 && !gl_FrontFacing) {
    discard;
  }
  if ((v_flags & 2) != 0) { /* a holdout: no surface */
    out_central = vec4(1e10, 0.0, 0.0, 0.0);
    return;
  }
  float index = texelFetch(materials, ivec2(4 * v_material + 3, 0), 0).r;
  out_central = vec4(-(frame.world_to_camera * vec4(v_position, 1.0)).z, index, 0.0, 1.0);
}
