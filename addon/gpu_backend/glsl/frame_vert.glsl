/* The frame's geometry through the camera, shifted by the sample's jitter (in NDC). A
 * triangle's flags: 1 culled when seen from behind (its material's Backface Culling), 2 a
 * holdout (it hides what is behind and is drawn as nothing), 4 its material may be
 * transparent (peel_frag.glsl), 8 its emission is left out (a light group's frame), 16 a
 * shadow catcher (frame_frag.glsl), 32 blended (stack_frag.glsl), 64 it moves over the
 * shutter (its shading is never reused).
 * links: the light linking sets of its mesh (bit k: set k). With MOTION, the corners at the
 * shutter's steps m0..m2 (core/render/motion_blur.py): the sample is drawn where they are at
 * its time; it is shaded where the triangle is at the share of the shutter frame.options.z
 * names (its corners and normals there in share_corners, at its row of share_rows among the
 * frame.options.w moving triangles; core/render/pipeline.py's Frame.at_times), or at the
 * frame's own corners (pos) when that is 0. */
void main()
{
  v_position = pos;
  v_normal = nor;
  v_geo = geo;
  v_material = int(mat + 0.5);
  v_tri = tri;
  v_lightmap = lm;
  v_lightmap_uv = lm_uv;
  v_uv = uv;
  v_flags = flags;
  v_links = links;
#ifdef MATERIALS
  MATERIAL_VERTEX
#endif
#ifdef MOTION
  if (frame.options.z > 0) {
    int row = int(texelFetch(share_rows, ivec2(tri % SHARE_ROW, tri / SHARE_ROW), 0).x);
    if (row >= 0) {
      int first = ((frame.options.z - 1) * frame.options.w + row) * 6;
      vec3 c[3];
      for (int k = 0; k < 3; k++) {
        int i = first + 2 * k;
        c[k] = texelFetch(share_corners, ivec2(i % SHARE_ROW, i / SHARE_ROW), 0).xyz;
      }
      int corner = gl_VertexID % 3;
      int i = first + 2 * corner + 1;
      v_position = c[corner];
      v_normal = texelFetch(share_corners, ivec2(i % SHARE_ROW, i / SHARE_ROW), 0).xyz;
      v_geo = cross(c[1] - c[0], c[2] - c[0]);
    }
  }
#endif
  vec3 at = v_position; /* (the share's corners, where no sample's time is given) */
#ifdef MOTION
  if (frame.shutter.y > 0.0) { /* where the sample's time of the shutter sees it */
    float u = frame.shutter.x * 2.0;
    at = u < 1.0 ? mix(m0, m1, u) : mix(m1, m2, u - 1.0);
  }
  v_moved = at;
#endif
  vec4 clip = frame.view_proj * vec4(at, 1.0);
  clip.xy = clip.xy * frame.ndc_scale + frame.jitter * clip.w;
  gl_Position = clip;
}
