/* One sample's visible points shaded (depth test EQUAL after the pre-pass), once per pixel
 * and triangle as core/render/pipeline.render_tile does: the batch's first sample is shaded
 * into its own targets with its triangle (out_key: the triangle's number in two parts, the
 * low one plus 1); a later sample that sees the same triangle only counts itself (out_key.r
 * = 1) and is weighted into the first's shading by the compose pass; one that sees another
 * triangle (an edge) is shaded on its own. Lights come in batches (frame.counts.x of them;
 * frame.counts.z: the first batch, which also adds the surface's own terms). WRITE_TARGETS
 * (defined from Python) stores the values of TARGETS the targets drawn into hold; with
 * SURFACE_ONLY (targets that need no light) the lights are left out. */
void main()
{
  bool first_batch = frame.counts.z != 0;
  int mode = frame.counts.w;
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  out_key = vec4(0.0);
  if (mode == MODE_FIRST) {
    if (first_batch) {
      out_key = vec4(float(v_tri >> 12), float(v_tri & 4095) + 1.0, 0.0, 0.0);
    }
  }
  else if (mode == MODE_REST) {
    vec4 first = texelFetch(first_key, pixel, 0);
    if (first.g > 0.0 && int(first.r) * 4096 + int(first.g) - 1 == v_tri) {
      out_key = vec4(first_batch ? 1.0 : 0.0, 0.0, 0.0, 0.0);
      WRITE_TARGETS(vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));
      return;
    }
  }
  Surface s = surface_at(v_position, v_normal, v_geo, v_material);
  int row = frame.size.y - 1 - pixel.y;
  uvec3 seed = uvec3(uint(pixel.x) | (uint(row) << 16u), uint(v_tri), uint(frame.size.z));
  vec3 diffuse = vec3(0.0), specular = vec3(0.0);
#ifndef SURFACE_ONLY
  for (int i = 0; i < frame.counts.x; i++) {
    vec3 l, e;
    if (!incidence(lights[i], s.p, s.geo, l, e)) {
      continue;
    }
    float vis = lights[i].shadow < 0 ? 1.0 :
                                       shadow_visibility(lights[i].shadow, s.p, s.geo, seed);
    accumulate(s.n, s.v, l, e, vis, s.albedo, s.rf0, s.gloss, frame.counts.y, diffuse,
               specular);
  }
#endif
  vec3 emit = first_batch ? s.emission : vec3(0.0);
  WRITE_TARGETS(vec4((diffuse + specular) + emit, first_batch ? 1.0 : 0.0), vec4(diffuse, 0.0),
                vec4(specular, 0.0), vec4(emit, 0.0),
                first_batch ? vec4(s.albedo, s.gloss) : vec4(0.0),
                first_batch ? vec4(s.n, 1.0) : vec4(0.0));
}
