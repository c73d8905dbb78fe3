/* Indirect light's occlusion terms (core/formulas/occlusion.py). */

/* occlusion.multi_bounce: the occlusion with the light between the occluders put back. */
vec3 multi_bounce(float x, vec3 rho)
{
  vec3 a = 2.0404 * rho - 0.3324, b = -4.7951 * rho + 0.6417, c = 2.7552 * rho + 0.6903;
  return max(vec3(x), ((x * a + b) * x + c) * x);
}

/* occlusion.specular (Lagarde and de Rousiers 2014) with occlusion.roughness of the gloss. */
float specular_occlusion(float x, float n_dot_v, float gloss)
{
  float alpha = pow(8192.0, gloss);
  float r = pow(2.0 / (alpha + 2.0), 0.25);
  float power = exp2(-16.0 * r - 1.0);
  return clamp(pow(clamp(n_dot_v, 0.0, 1.0) + x, power) - 1.0 + x, 0.0, 1.0);
}
