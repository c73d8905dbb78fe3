/* A sample's blended stack (core/render/transparency.blend) as stack_merge_frag.glsl keeps
 * it: stack_state (the layers taken, 1 while the stack goes on, 1 where it was cut, 1 where
 * it ends at a surface: the stack's visible texture holds it) and its BLEND_LAYERS layers,
 * two per texel of stack_slots0..3 (the triangle plus 1, its alpha); stack_order: per
 * triangle (its rank, its object when its layers show once, else -1) at texel
 * (t % ORDER_ROW, t / ORDER_ROW). */

vec2 stack_layer(ivec2 pixel, int k)
{
  vec4 v;
  switch (k >> 1) {
    case 0: v = texelFetch(stack_slots0, pixel, 0); break;
    case 1: v = texelFetch(stack_slots1, pixel, 0); break;
    case 2: v = texelFetch(stack_slots2, pixel, 0); break;
    default: v = texelFetch(stack_slots3, pixel, 0); break;
  }
  return (k & 1) == 0 ? v.xy : v.zw;
}

vec2 stack_order_of(int tri)
{
  return texelFetch(stack_order, ivec2(tri % ORDER_ROW, tri / ORDER_ROW), 0).xy;
}

/* The share of layer ``slot`` of the pixel's stack ("over", front to back by rank, then by
 * layer): its alpha times what the layers before it let through; slot BLEND_LAYERS: what
 * all let through, the share of the surface behind them or of the world. ``tri``: the
 * layer's triangle (behind: the surface's, unchanged, or -1 where the world shows). Negative
 * where the pixel has no such layer. */
float stack_share(ivec2 pixel, int slot, inout int tri)
{
  vec4 st = texelFetch(stack_state, pixel, 0);
  int count = int(st.r);
  if (count == 0 || (slot < BLEND_LAYERS && slot >= count)) {
    return -1.0;
  }
  float share = 1.0, rank = 0.0;
  if (slot < BLEND_LAYERS) {
    vec2 own = stack_layer(pixel, slot);
    tri = int(own.x) - 1;
    share = own.y;
    rank = stack_order_of(tri).x;
  }
  else if (st.a == 0.0) {
    tri = -1;
  }
  for (int k = 0; k < count; k++) {
    vec2 layer = stack_layer(pixel, k);
    float r = stack_order_of(int(layer.x) - 1).x;
    if (slot == BLEND_LAYERS || (k != slot && (r < rank || (r == rank && k < slot)))) {
      share *= 1.0 - layer.y;
    }
  }
  return share;
}

/* Whether triangle ``tri`` (its flags) is drawn at ``pixel``, whose surface is ``seen``:
 * with frame.options.x > 0, as the layer it names (its share: ``weight``; ``seen``: its
 * triangle, or the surface behind the stack, or -1 where none); else as the
 * sample's own surface, a stack's front left out (its layers draw it). */
bool stack_drawn(ivec2 pixel, int tri, int flags, inout int seen, out float weight)
{
  weight = 1.0;
  if (frame.options.x > 0) {
    weight = stack_share(pixel, frame.options.x - 1, seen);
    return weight >= 0.0 && seen == tri;
  }
  return (flags & 32) == 0 && seen == tri;
}
