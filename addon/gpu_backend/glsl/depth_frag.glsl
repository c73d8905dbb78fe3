/* The depth pre-pass: each pixel's nearest triangle (its number in two parts, the low one
 * plus 1; at equal depths the first drawn, the lower number, as the CPU's raster) and its
 * depth; faces culled from behind left out. Peeling (frame.flags.y): only at the pixels
 * peeled (peel_floor.a), and only behind the peeled surface (its depth, then its number). */
void main()
{
  if ((v_flags & 1) != 0 && !gl_FrontFacing) {
    discard;
  }
  if (frame.flags.y != 0) {
    vec4 f = texelFetch(peel_floor, ivec2(gl_FragCoord.xy), 0);
    int peeled = key_triangle(f);
    if (f.a == 0.0 || gl_FragCoord.z < f.b || (gl_FragCoord.z == f.b && v_tri <= peeled)) {
      discard;
    }
  }
  out_visible = vec4(float(v_tri >> 12), float(v_tri & 4095) + 1.0, gl_FragCoord.z, 0.0);
}
