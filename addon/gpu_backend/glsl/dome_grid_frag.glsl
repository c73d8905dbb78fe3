/* The dome's visibility at the grid's pixels (sky.upsampled's look-ups): each grid pixel's
 * centre is its anchor pixel's centre in the frame. */
void main()
{
  Surface s = surface_at(v_position, v_normal, v_geo, v_material);
  out_vis = vec4(dome_visibility(s.p, s.n, s.geo), 0.0, 0.0, 1.0);
  out_point = vec4(s.p, 1.0);
  out_normal = vec4(s.geo, 0.0);
}
