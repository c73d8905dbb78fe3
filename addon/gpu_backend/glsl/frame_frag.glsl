/* The frame's shading of one sample's visible points (depth test EQUAL after the pre-pass):
 * the lights of this batch (direct.glsl, shadow_filter.glsl), and in the first batch the
 * surface's own terms. Outputs add up over the samples and batches (additive blending). */
void main()
{
  Surface s = surface_at(v_position, v_normal, v_geo, v_material);
  vec3 diffuse = vec3(0.0), specular = vec3(0.0);
  for (int i = 0; i < frame.counts.x; i++) {
    vec3 l, e;
    if (!incidence(lights[i], s.p, s.geo, l, e)) {
      continue;
    }
    float vis = lights[i].shadow < 0 ? 1.0 : shadow_visibility(lights[i].shadow, s.p, s.geo);
    accumulate(s.n, s.v, l, e, vis, s.albedo, s.rf0, s.gloss, frame.counts.y, diffuse,
               specular);
  }
  bool first = frame.counts.z != 0;
  vec3 emit = first ? s.emission : vec3(0.0);
  out_combined = vec4((diffuse + specular) + emit, first ? 1.0 : 0.0);
  out_diffuse = vec4(diffuse, 0.0);
  out_specular = vec4(specular, 0.0);
  out_surface = first ? vec4(s.albedo, s.gloss) : vec4(0.0);
  out_normal = first ? vec4(s.n, 1.0) : vec4(0.0);
  out_emit = vec4(emit, 0.0);
}
