/* The world's occlusion: the fraction of the world's light that reaches a point through the
 * dome of shadow maps (core/render/sky.visibility), looked up on a grid of pixels and blended
 * across each surface (sky.upsampled's joint bilateral upsampling; where the grid holds too
 * little of a point's surface, the point's own look-up), then joined with the contact
 * occlusion (core/render/world_occlusion.world_visibility). Held to them by
 * tests/gpu/test_frame.py.
 *
 * Reads: dome (DomeData), the shadow maps of shadow_filter.glsl (the dome's at dome.maps),
 * and in the shading pass (DOME_SHADING) the grid's textures: dome_grid (per grid pixel: the
 * visibility, -, -, 1 where a surface was seen), dome_points (its position), dome_normals
 * (its geometric normal). */

#define DOME_SAME_NORMAL 0.95
#define DOME_SAME_PLANE 0.2
#define DOME_ENOUGH 0.5

/* sky.visibility of one point: shading normal n for the directions' weights, geometric
 * normal geo for the maps (no disc rotation). */
float dome_visibility(vec3 p, vec3 n, vec3 geo)
{
  float total = 0.0, seen = 0.0;
  for (int k = 0; k < dome.counts.x; k++) {
    vec4 d = dome.dirs[k];
    float w = max(n.x * d.x + n.y * d.y + n.z * d.z, 0.0) * d.w;
    total += w;
    int s = dome.maps[k >> 2][k & 3];
    if (w > 0.0 && s >= 0) {
      seen += w * shadow_visibility(s, p, geo, uvec3(0u));
    }
    else {
      seen += w;
    }
  }
  return total > 1e-12 ? clamp(seen / total, 0.0, 1.0) : 1.0;
}

#ifdef DOME_SHADING
/* sky.upsampled at the point of window position (sx, sy) (top-first), or its own look-up. */
float dome_upsampled(vec2 window, vec3 p, vec3 n, vec3 geo)
{
  int stride = dome.counts.z, half_ = dome.counts.w;
  ivec2 grid = dome.grid.xy;
  if (stride <= 1) {
    return dome_visibility(p, n, geo);
  }
  ivec2 xi = ivec2(floor(window));
  vec2 f = (vec2(xi - half_)) / float(stride);
  ivec2 c0 = ivec2(floor(f));
  vec2 t = f - vec2(c0);
  float total = 0.0, value = 0.0;
  for (int k = 0; k < 4; k++) {
    ivec2 dk = ivec2(k & 1, k >> 1);
    float w = (dk.x != 0 ? t.x : 1.0 - t.x) * (dk.y != 0 ? t.y : 1.0 - t.y);
    ivec2 g = c0 + dk;
    if (any(lessThan(g, ivec2(0))) || any(greaterThanEqual(g, grid))) {
      continue;
    }
    ivec2 texel = ivec2(g.x, grid.y - 1 - g.y);
    vec4 v = texelFetch(dome_grid, texel, 0);
    if (v.a == 0.0) {
      continue;
    }
    vec3 q = texelFetch(dome_points, texel, 0).xyz;
    vec3 qn = texelFetch(dome_normals, texel, 0).xyz;
    vec3 step = p - q;
    if (dot(geo, qn) >= DOME_SAME_NORMAL && abs(dot(step, qn)) <= DOME_SAME_PLANE * length(step)) {
      total += w;
      value += w * v.r;
    }
  }
  return total >= DOME_ENOUGH ? value / total : dome_visibility(p, n, geo);
}

/* world_occlusion.world_visibility: the dome's visibility joined with the contact occlusion
 * (the darker of the two, with the light between the occluders put back), over the
 * contact occlusion's own. */
float world_seen(float vis, float occluded, float rho)
{
  float both = multi_bounce(min(vis, occluded), vec3(rho)).x;
  return both / max(multi_bounce(occluded, vec3(rho)).x, 1e-3);
}
#endif
