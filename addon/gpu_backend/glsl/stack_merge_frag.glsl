/* A step of the blended stacks recorded (stack_frag.glsl's stack_record) into the next
 * stack_state and layers (stack.glsl), and the surfaces peeled replaced by the ones found
 * behind them (peel_floor, next_visible), as merge_frag.glsl does. */
void main()
{
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 seen = texelFetch(visible, pixel, 0);
  vec4 st = texelFetch(stack_state, pixel, 0);
  vec4 slots[4] = vec4[4](texelFetch(stack_slots0, pixel, 0), texelFetch(stack_slots1, pixel, 0),
                          texelFetch(stack_slots2, pixel, 0), texelFetch(stack_slots3, pixel, 0));
  vec4 rec = texelFetch(stack_record, pixel, 0);
  int what = int(rec.r);
  if (frame.counts.x == 0 ? what != 0 : st.g != 0.0) { /* the stack went on to this step */
    st.g = what == 1 || what == 2 ? 1.0 : 0.0;
    st.b = what == 4 ? 1.0 : 0.0;
    st.a = what >= 3 ? 1.0 : 0.0;
    if (what == 1) {
      int k = int(st.r);
      vec2 layer = vec2(float(key_triangle(seen) + 1), rec.g);
      if ((k & 1) == 0) {
        slots[k >> 1].xy = layer;
      }
      else {
        slots[k >> 1].zw = layer;
      }
      st.r += 1.0;
    }
  }
  out_state = st;
  out_slots0 = slots[0];
  out_slots1 = slots[1];
  out_slots2 = slots[2];
  out_slots3 = slots[3];
  out_visible = texelFetch(peel_floor, pixel, 0).a != 0.0 ? texelFetch(next_visible, pixel, 0)
                                                        : seen;
}
