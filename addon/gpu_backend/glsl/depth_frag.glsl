/* The depth pre-pass: each pixel's nearest triangle (its number in two parts, the low one
 * plus 1; at equal depths the first drawn, the lower number, as the CPU's raster) and its
 * depth; faces culled from behind left out. */
void main()
{
  if ((v_flags & 1) != 0 && !gl_FrontFacing) {
    discard;
  }
  out_visible = vec4(float(v_tri >> 12), float(v_tri & 4095) + 1.0, 0.0, 0.0);
}
