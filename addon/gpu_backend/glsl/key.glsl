/* The triangle a pre-pass key names (depth_frag.glsl's out_visible: its number in two parts,
 * the low one plus 1), -1 for none. */
int key_triangle(vec4 key)
{
  return int(key.r) * 4096 + int(key.g) - 1;
}
