/* The depth a shadow map stores (core/render/shadows.py): a perspective face's clip w, found
 * nearest by a depth linear in w (along.w = 1 / far: the projection's own depth would hold
 * too few bits near a far plane thousands of times its near one); a cascade's depth along the
 * sun, nearest by the projection's depth, which is linear in it. */
void main()
{
#if ORTHO
  out_depth = v_along;
#else
  float w = 1.0 / gl_FragCoord.w;
  out_depth = w;
  gl_FragDepth = clamp(w * along.w, 0.0, 1.0);
#endif
}
