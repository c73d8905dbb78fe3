/* Raw ambient occlusion of the region at ao.origin.zw in the buffer (one pixel each; the
 * region is ao.size.y pixels high). */
void main()
{
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  out_color = vec4(gtao(ao.origin.z + pixel.x, ao.origin.w + (int(ao.size.y) - 1 - pixel.y)));
}
