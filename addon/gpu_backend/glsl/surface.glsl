/* A visible point's surface: view direction, normals turned towards the camera, material.
 * The GLSL form of core/kernels/shading.surface and the constant material tables of
 * core/render/buffers (Frame.tables): per material four texels of `materials`:
 * (albedo, gloss), (rf0, alpha), (emission, occlusion), (pass index, -, -, -); with MATERIALS,
 * the programs of the materials that vary over their surface (material_apply, generated). */

struct Surface {
  vec3 p, n, geo, v;
  vec3 albedo, rf0, emission;
  float gloss, occlusion, alpha;
};

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
#ifdef MATERIALS
  material_apply(material, s);
#endif
  return s;
}
