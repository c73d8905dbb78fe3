/* A visible point's surface: view direction, normals turned towards the camera, material.
 * The GLSL form of core/kernels/shading.surface and the constant material tables of
 * core/render/buffers (Frame.tables): per material four texels of `materials`:
 * (albedo, gloss), (rf0, alpha), (emission, occlusion), (pass index, layer, layer_f0, -); with
 * MATERIALS, the programs of the materials that vary over their surface (material_apply,
 * generated). With frame.flags.z, the albedo under a specular layer is weighted as
 * core/render/surfaces does. */

struct Surface {
  vec3 p, n, geo, v;
  vec3 albedo, rf0, emission;
  float gloss, occlusion, alpha, layer, layer_f0;
};

/* env_brdf.diffuse_layering: one less BO2's environment BRDF (slide "Final approximation") of
 * the layer's rf0, times the layered weight: 1 - saturate(layer a0 + layer_f0 (a1 - a0)). */
float diffuse_layering(float layer, float layer_f0, float gloss, float n_dot_v)
{
  float g = clamp(gloss, 0.0, 1.0);
  float nv = clamp(n_dot_v, 1e-4, 1.0); /* env_brdf.N_DOT_V_MIN */
  float a0 = g * (1.0 / 0.96) * min(g * 0.475, exp2(-9.28 * nv)) +
             (g * ((0.0275 - 0.25 * 0.04) / 0.96) + (0.015 - 0.75 * 0.04) / 0.96);
  float a1 = g * 0.25 + 0.75;
  return 1.0 - clamp(layer * a0 + layer_f0 * (a1 - a0), 0.0, 1.0);
}

#ifdef MATERIALS
void material_apply(int material, inout Surface s);
#endif

Surface surface_at(vec3 p, vec3 normal, vec3 geo, int material)
{
  Surface s;
  s.p = p;
  s.v = frame.ortho != 0 ? -frame.forward : normalize(frame.eye - p);
  s.n = normal / max(length(normal), 1e-20);
  s.geo = geo / max(length(geo), 1e-30);
  if (dot(s.geo, s.v) < 0.0) { /* seen from behind: shade the side facing the camera */
    s.n = -s.n;
    s.geo = -s.geo;
  }
  vec4 a = texelFetch(materials, ivec2(4 * material, 0), 0);
  vec4 b = texelFetch(materials, ivec2(4 * material + 1, 0), 0);
  vec4 c = texelFetch(materials, ivec2(4 * material + 2, 0), 0);
  s.albedo = a.rgb;
  s.gloss = a.a;
  s.rf0 = b.rgb;
  s.emission = c.rgb;
  s.occlusion = c.a;
  s.alpha = b.a;
  vec4 d = texelFetch(materials, ivec2(4 * material + 3, 0), 0);
  s.layer = d.g;
  s.layer_f0 = d.b;
#ifdef MATERIALS
  material_apply(material, s);
#endif
  if (frame.flags.z != 0 && s.layer > 0.0) {
    s.albedo *= diffuse_layering(s.layer, s.layer_f0, s.gloss, dot(s.n, s.v));
  }
  return s;
}
