/* A pyramid level into the filter's list of rows (core/render/shadows.py: mip_layout; items
 * ordered face, row, column), MIPS_WIDTH items per texture row: span = (first item, items,
 * the level's side, -). */
void main()
{
  int k = int(gl_FragCoord.y) * MIPS_WIDTH + int(gl_FragCoord.x) - span.x;
  if (k < 0 || k >= span.y) {
    discard;
  }
  int per_face = span.z * span.z;
  int face = k / per_face, rest = k - face * per_face;
  out_row = texelFetch(level, ivec3(rest % span.z, rest / span.z, face), 0);
}
