/* The contact occlusion's buffers: each pixel centre's view-space depth (z, the camera looking
 * along -z) and unit view-space normal (either side), over the frame and a margin of REACH
 * pixels around it (core/render/contact_occlusion.tile_ambient draws them the same way). */
void main()
{
  if ((v_flags & 1) != 0 && !gl_FrontFacing) {
    discard;
  }
  if ((v_flags & 2) != 0) { /* holdout objects are holes, not occluders */
    out_key = vec4(0.0);
    out_combined = vec4(0.0);
    return;
  }
  out_key = vec4((frame.world_to_camera * vec4(v_position, 1.0)).z, 0.0, 0.0, 1.0);
  vec3 n = mat3(frame.world_to_camera) * v_normal;
  out_combined = vec4(n / max(length(n), 1e-12), 1.0);
}
