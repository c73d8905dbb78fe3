/* Direct light: a light's incidence at a point and the talk's BRDF accumulated over the lights.
 *
 * The GLSL form of core/kernels/shading.py (incidence, accumulate), held to it by
 * tests/gpu/test_stages.py. Light units: core/lighting/shade.py. The BRDF: slides "Black Ops:
 * shading model" (Lambert plus microfacet specular), "Black Ops: Microfacet BRDF" (normalized
 * Blinn-Phong D = (a + 2) / 8 (n.h)^a, a = 2^(13 g)), the Schlick Fresnel and Schlick-Smith
 * visibility of the "reference" model, and the bonus slides of the Black Ops II terms
 * ("bo2": F = F0 + (1 - F0) 2^(-10 l.h), V = 1 / (k (v.h)^2 + 1 - k), k = min(1, g + 0.545)).
 * Float32 arithmetic (the CPU's is float64 inside a point). */

#define LIGHT_POINT 0
#define LIGHT_SPOT 1
#define LIGHT_SUN 2
#define LIGHT_AREA 3
#define N_DOT_V_MIN 1e-5
#define BRDF_EPS 1e-6
#define INV_PI 0.31830988618379067

float clip01(float x) { return isnan(x) ? x : clamp(x, 0.0, 1.0); }

/* Unit direction to the light (l), its irradiance on a surface facing it (e, W/m^2, 0 where
 * not lit); returns whether the geometric normal faces it and it gives light. */
bool incidence(LightData light, vec3 p, vec3 geo, out vec3 l, out vec3 e)
{
  float scale;
  if (light.kind == LIGHT_SUN) {
    l = -light.axis;
    scale = 1.0;
  }
  else {
    vec3 d = light.position - p;
    float d2 = d.x * d.x + d.y * d.y + d.z * d.z;
    l = d * (1.0 / max(sqrt(d2), 1e-20));
    float inv_d2 = 1.0 / max(d2, 1e-8);
    float cos_axis = -(l.x * light.axis.x + l.y * light.axis.y + l.z * light.axis.z);
    if (light.kind == LIGHT_AREA) {
      scale = max(0.0, cos_axis) * inv_d2 * INV_PI;
    }
    else {
      scale = inv_d2 * (0.25 * INV_PI);
      if (light.kind == LIGHT_SPOT) {
        if (light.blend > 0.0) {
          float x = clamp((cos_axis - light.cos_half) / ((1.0 - light.cos_half) * light.blend),
                          0.0, 1.0);
          scale *= x * x * (3.0 - 2.0 * x);
        }
        else if (!(cos_axis > light.cos_half)) {
          scale = 0.0;
        }
      }
    }
  }
  e = scale * light.color;
  bool lit = any(notEqual(e, vec3(0.0))) && dot(l, geo) > 0.0;
  if (!lit) {
    e = vec3(0.0);
  }
  return lit;
}

/* Adds one light's f(l, v) (n.l) E to diffuse and specular, E = e times the visibility. */
void accumulate(vec3 n, vec3 v, vec3 l, vec3 e, float shadow, vec3 albedo, vec3 rf0,
                float gloss, int model, inout vec3 diffuse, inout vec3 specular)
{
  vec3 ee = e * shadow;
  if (all(equal(ee, vec3(0.0)))) {
    return;
  }
  float n_dot_l = dot(n, l);
  if (!(n_dot_l > 0.0)) {
    return;
  }
  float n_dot_v = max(dot(n, v), N_DOT_V_MIN);
  vec3 h = l + v;
  h *= 1.0 / max(length(h), BRDF_EPS);
  float n_dot_h = dot(n, h);
  float l_dot_h = dot(l, h);
  float v_dot_h = dot(v, h);
  float g = clip01(gloss);
  float alpha = exp2(13.0 * g);
  float d_pl = (alpha + 2.0) * 0.125 * pow(clip01(n_dot_h), alpha);
  float f_weight, vis;
  if (model == 1) { /* BO2 Fresnel and visibility */
    f_weight = exp2(-10.0 * clip01(l_dot_h));
    float k = min(1.0, g + 0.545);
    float x = clamp(v_dot_h, BRDF_EPS, 1.0);
    vis = 1.0 / (k * (x * x) + (1.0 - k));
  }
  else {
    float t = 1.0 - clip01(l_dot_h);
    float t2 = t * t;
    f_weight = t2 * t2 * t;
    if (model == 0) { /* Schlick-Smith */
      float k = 2.0 / sqrt(3.14159265358979 * (alpha + 2.0));
      float one_k = 1.0 - k;
      vis = 1.0 / ((clip01(n_dot_l) * one_k + k) * (clip01(n_dot_v) * one_k + k));
    }
    else if (model == 2) {
      vis = 1.0;
    }
    else if (model == 3) { /* Cook-Torrance */
      float nl = clamp(n_dot_l, BRDF_EPS, 1.0);
      float nv = clamp(n_dot_v, BRDF_EPS, 1.0);
      float vh = clamp(v_dot_h, BRDF_EPS, 1.0);
      float two = 2.0 * clip01(n_dot_h) / vh;
      vis = min(1.0 / (nl * nv), min(two / nl, two / nv));
    }
    else { /* Kelemen */
      float x = clamp(l_dot_h, BRDF_EPS, 1.0);
      vis = 1.0 / (x * x);
    }
  }
  float s = d_pl * vis * n_dot_l * INV_PI;
  diffuse += albedo * (n_dot_l * INV_PI) * ee;
  specular += s * (rf0 + (1.0 - rf0) * f_weight) * ee;
}
