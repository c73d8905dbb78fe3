/* A peeled pixel takes the surface found behind it (the next layer's pre-pass), or none. */
void main()
{
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  if (texelFetch(peel_floor, pixel, 0).a == 0.0) {
    discard;
  }
  out_visible = texelFetch(next_visible, pixel, 0);
}
