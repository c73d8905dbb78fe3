/* The dome's visibility at the grid's pixels (sky.upsampled's look-ups): each grid pixel's
 * centre is its anchor pixel's centre in the frame. */
void main()
{
  if ((v_flags & 1) != 0 && !gl_FrontFacing) {
    discard;
  }
  if ((v_flags & 2) != 0) { /* a holdout: not a point the dome is looked up for */
    out_vis = vec4(0.0);
    out_point = vec4(0.0);
    out_normal = vec4(0.0);
    return;
  }
  Surface s = surface_at(v_position, v_normal, v_geo, v_material);
  out_vis = vec4(dome_visibility(s.p, s.n, s.geo), 0.0, 0.0, 1.0);
  out_point = vec4(s.p, 1.0);
  out_normal = vec4(s.geo, 0.0);
}
