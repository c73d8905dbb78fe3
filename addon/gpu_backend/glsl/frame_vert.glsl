/* The frame's geometry through the camera, shifted by the sample's jitter (in NDC). A
 * triangle's flags: 1 culled when seen from behind (its material's Backface Culling), 2 a
 * holdout (it hides what is behind and is drawn as nothing), 4 its material may be
 * transparent (peel_frag.glsl), 8 its emission is left out (a light group's frame).
 * links: the light linking sets of its mesh (bit k: set k). */
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
  vec4 clip = frame.view_proj * vec4(pos, 1.0);
  clip.xy = clip.xy * frame.ndc_scale + frame.jitter * clip.w;
  gl_Position = clip;
}
