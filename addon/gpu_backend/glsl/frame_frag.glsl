/* One sample's visible points shaded (the pre-pass's triangle, at its depth), once per pixel
 * and triangle as core/render/pipeline.render_tile does: the batch's first sample is shaded
 * into its own targets with its triangle (out_key: the triangle's number in two parts, the
 * low one plus 1); a later sample that sees the same triangle only counts itself (out_key.r
 * = 1) and is weighted into the first's shading by the compose pass; one that sees another
 * triangle (an edge), or a triangle that moves over the shutter (flag 64), is shaded on its
 * own. Lights come in batches (frame.counts.x of them;
 * frame.counts.z: the first batch, which also adds the surface's own terms). WRITE_TARGETS
 * (defined from Python) stores the values of TARGETS the targets drawn into hold; with
 * SURFACE_ONLY (targets that need no light) the lights are left out. With BLENDED, a blended
 * stack's front is not the sample's own surface: frame.options.x names the layer drawn
 * (stack.glsl; its share weighs every target), each on its own. */
void main()
{
#ifdef MATERIALS
  material_derivatives();  /* screen derivatives: before any fragment of the quad stops */
#endif
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 nearest = texelFetch(visible, pixel, 0);
  int seen = key_triangle(nearest);
  float stack_weight = 1.0;  /* the point's share of the sample (a blended stack's layer) */
#ifdef BLENDED
  if (!stack_drawn(pixel, v_tri, v_flags, seen, stack_weight)) {
    discard;
  }
#endif
  if (seen != v_tri) {
    discard;  /* culled, or another triangle at the same depth drew the pixel */
  }
  bool first_batch = frame.counts.z != 0;
  int mode = frame.counts.w;
  out_key = vec4(0.0);
  if ((v_flags & 2) != 0) { /* a holdout: nothing, alpha 0, and no sample reuses it; the
                             * Shadow Catcher pass counts it as no surface (the first
                             * sample's is counted once by compose_frag: out_key.b) */
    WRITE_ZEROS
    if (first_batch) {
      WRITE_CATCHER(vec4(stack_weight))
      out_key.b = mode == MODE_FIRST ? 1.0 : 0.0;
    }
    return;
  }
  if (mode == MODE_FIRST) {
    if (first_batch) {
      out_key = vec4(float(v_tri >> 12), float(v_tri & 4095) + 1.0, 0.0, 0.0);
    }
  }
  else if (mode == MODE_REST) {
    vec4 first = texelFetch(first_key, pixel, 0);
    if (first.g > 0.0 && key_triangle(first) == v_tri && (v_flags & 64) == 0) {
      out_key = vec4(first_batch ? 1.0 : 0.0, 0.0, 0.0, 0.0);
      WRITE_ZEROS
      return;
    }
  }
  Surface s = surface_at(v_position, v_normal, v_geo, v_material);
  int row = frame.size.y - 1 - pixel.y;
  uvec3 seed = uvec3(uint(pixel.x) | (uint(row) << 16u), uint(v_tri), uint(frame.size.z));
  vec3 diffuse = vec3(0.0), specular = vec3(0.0);
  vec3 held = vec3(0.0), free = vec3(0.0);  /* a shadow catcher's irradiance, shadowed or not */
#ifndef SURFACE_ONLY
  for (int i = 0; i < frame.counts.x; i++) {
    vec3 l, e;
    if ((lights[i].receivers > 0 && ((v_links >> lights[i].receivers) & 1) == 0) ||
        !incidence(lights[i], s.p, s.geo, l, e)) {
      continue; /* a linked light lights the meshes of its set alone */
    }
    float vis = lights[i].shadow < 0 ? 1.0 :
                                       shadow_visibility(lights[i].shadow, s.p, s.geo, seed);
    accumulate(s.n, s.v, l, e, vis, s.albedo, s.rf0, s.gloss, frame.counts.y, diffuse,
               specular);
    if ((v_flags & 16) != 0) {
      vec3 c = e * max(dot(s.n, l), 0.0);
      free += c;
      held += c * vis;
    }
  }
#endif
  vec3 diff_ind = vec3(0.0), gloss_ind = vec3(0.0);
  float ao_out = 1.0;  /* the AO pass: 1 where no contact occlusion is searched */
  vec3 lightmap_e = vec3(0.0), texels = vec3(0.0);  /* the Lightmap passes */
  vec2 window = vec2(float(pixel.x), float(row)) + frame.sample_offset;
  float occluded = 1.0;
#ifdef AMBIENT
  /* the contact occlusion of the pixel that holds the sample (render_tile's ao_tile) */
  ivec2 at = clamp(ivec2(floor(window)), ivec2(0), frame.size.xy - 1);
  occluded = texelFetch(ambient, ivec2(at.x, frame.size.y - 1 - at.y), 0).r;
  ao_out = occluded;
#endif
#ifdef INDIRECT
  if (first_batch) { /* the probes' light (core/render/shading.shade_points) */
    bool baked = v_lightmap >= 0;  /* a lightmap holds the light of its surface */
    float sky = 1.0;
#ifdef DOME
    float rho = dot(s.albedo, vec3(0.2126, 0.7152, 0.0722));
    if (indirect.flags.x >= 0) { /* what bounces off the occluders is in the bounce volume */
      rho *= 1.0 - volume_weight(indirect.flags.x, s.p);
    }
    if (!baked) {
      sky = world_seen(dome_upsampled(window, s.p, s.n, s.geo), occluded, rho);
    }
#endif
    vec3 psh[9];
    if (baked) {
      lightmap_sh(v_lightmap, v_lightmap_uv, psh);
      float y[9];
      sh_basis(s.n, y);
      for (int k = 0; k < 9; k++) {
        lightmap_e += y[k] * psh[k];
      }
      ivec4 m = lightmaps.maps[v_lightmap];
      float cell = mod(floor(v_lightmap_uv.x * float(m.y)) + floor((1.0 - v_lightmap_uv.y) *
                                                                   float(m.z)), 2.0);
      texels = LIGHTMAP_HUES[v_lightmap % LIGHTMAP_HUES.length()] * (0.45 + 0.55 * cell);
    }
    else {
      pixel_sh(s.p, s.n, s.v, sky, psh);
    }
    indirect_light(s.p, s.n, s.v, s.albedo, s.rf0, s.gloss, psh, sky, diff_ind, gloss_ind);
    diff_ind *= s.occlusion; /* the glTF importer's occlusion */
    gloss_ind *= s.occlusion;
#ifdef AMBIENT
    diff_ind *= baked ? vec3(1.0) : multi_bounce(occluded, s.albedo);
    if (frame.flags.x != 0) {
      gloss_ind *= specular_occlusion(occluded, dot(s.n, s.v), s.gloss);
    }
#endif
  }
#endif
  vec3 emit = first_batch && (v_flags & 8) == 0 ? s.emission : vec3(0.0);  /* 8: dark */
  vec3 reflections_view = vec3(0.2), volumes_view = vec3(0.2);  /* no probes: the world's */
#ifdef INDIRECT
  reflections_view = influence_colour(0, s.p);
  volumes_view = influence_colour(1, s.p);
#endif
  vec4 combined = vec4((((diffuse + specular) + diff_ind) + gloss_ind) + emit,
                       first_batch ? 1.0 : 0.0);
  vec4 caught = vec4(first_batch ? 1.0 : 0.0);  /* the Shadow Catcher pass: 1 but on catchers */
  if ((v_flags & 16) != 0) {
    /* a shadow catcher (core/render/shading.catch_shadows; the lights in one batch): the
     * world behind it times the share of light its shadows let through, or with a
     * transparent film (frame.flags.w) black of their opacity; nothing with the Shadow
     * Catcher pass (frame.options.y), which holds the share */
    vec3 share = clamp(mix(vec3(1.0), held / max(free, vec3(1e-30)),
                           greaterThan(free, vec3(0.0))), 0.0, 1.0);
    combined = frame.options.y != 0 ? vec4(0.0) :
               frame.flags.w != 0 ? vec4(0.0, 0.0, 0.0, 1.0 - (share.x + share.y + share.z) / 3.0)
                                  : vec4(frame.world.rgb * share, 1.0);
    caught = vec4(share, 0.0);
  }
  WRITE_TARGETS(combined,
                vec4(diffuse, 0.0), vec4(specular, 0.0), vec4(diff_ind, 0.0),
                vec4(gloss_ind, 0.0), vec4(emit, 0.0),
                first_batch ? vec4(s.albedo, s.gloss) : vec4(0.0),
                first_batch ? vec4(s.n, 1.0) : vec4(0.0),
                first_batch ? vec4(s.p, 0.0) : vec4(0.0), first_batch ? vec4(v_uv, 0.0) : vec4(0.0),
                first_batch ? vec4(s.rf0, 0.0) : vec4(0.0), vec4(first_batch ? ao_out : 0.0),
                vec4(lightmap_e, 0.0), vec4(texels, 0.0),
                first_batch ? vec4(reflections_view, 0.0) : vec4(0.0),
                first_batch ? vec4(volumes_view, 0.0) : vec4(0.0), caught);
}
