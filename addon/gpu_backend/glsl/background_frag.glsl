/* The world seen where no surface is (core/render/shading.background_radiance), added per
 * sample: its constant colour with alpha 1, or (WORLD_IMAGE) its equirect image along the
 * sample's ray (rotated by the world's mapping, at the background's level of detail) times
 * its strength, plus its sun's disc, times the background's opacity, which is the alpha;
 * nothing with a transparent film (frame.flags.w). The Shadow Catcher pass counts 1 there. */
void main()
{
  float weight = 1.0;
#ifdef BLENDED
  if (frame.options.x > 0) { /* the world behind the blended stacks, by their share */
    int tri = 0;
    weight = stack_share(ivec2(gl_FragCoord.xy), BLEND_LAYERS, tri);
    if (weight < 0.0 || tri >= 0) {
      discard;
    }
  }
  else
#endif
  if (texelFetch(visible, ivec2(gl_FragCoord.xy), 0).g > 0.0) {
    discard;  /* a surface (or a holdout) is seen */
  }
  out_key = vec4(0.0);
  vec4 color = frame.world;
#ifdef WORLD_IMAGE
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec2 window = vec2(float(pixel.x), float(frame.size.y - 1 - pixel.y)) + frame.sample_offset;
  vec2 ndc = vec2(window.x * 2.0 / float(frame.size.x) - 1.0,
                  1.0 - window.y * 2.0 / float(frame.size.y));
  vec4 near_p = world.clip_to_world * vec4(ndc, -1.0, 1.0);
  vec4 mid_p = world.clip_to_world * vec4(ndc, 0.0, 1.0);
  vec3 d = normalize(mid_p.xyz / mid_p.w - near_p.xyz / near_p.w);
  vec3 r = vec3(dot(world.rotation[0].xyz, d), dot(world.rotation[1].xyz, d),
                dot(world.rotation[2].xyz, d));
  vec2 uv = vec2(0.5 - atan(r.y, r.x) / (2.0 * 3.141592653589793),
                 0.5 + atan(r.z, length(r.xy)) / 3.141592653589793);
  vec3 radiance = texture_sample(0, world_texels, uv, world.params.z, 0).rgb * world.params.x;
  if (world.params.w != 0.0 && dot(d, world.sun.xyz) >= world.sun.w) {
    radiance += world.sun_color.rgb;
  }
  color = vec4(radiance * world.params.y, world.params.y);
#endif
  WRITE_ZEROS
  WRITE_COMBINED(frame.flags.w != 0 ? vec4(0.0) : color * weight)
  WRITE_CATCHER(vec4(weight))
}
