/* The filtered ambient occlusion of the frame's pixels (the frame is ao.size.w pixels high,
 * at the buffer's margin ao.params.w). */
void main()
{
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  int m = int(ao.params.w);
  out_color = vec4(ao_blur(m + pixel.x, m + (int(ao.size.w) - 1 - pixel.y), ao.size.x));
}
