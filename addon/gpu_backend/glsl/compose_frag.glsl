/* A batch of samples added to the running total: what the later samples shaded on their own,
 * plus the first sample's shading weighted by the samples that reuse it (itself included;
 * a holdout's, first.b, is reused by none).
 * COMPOSE_TARGETS (defined from Python) does it for each target drawn into. */
void main()
{
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 first = texelFetch(first_key, pixel, 0);
  float weight = texelFetch(rest_key, pixel, 0).r + (first.g > 0.0 ? 1.0 : 0.0) + first.b;
  COMPOSE_TARGETS
}
