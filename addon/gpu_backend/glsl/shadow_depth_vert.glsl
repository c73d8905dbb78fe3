/* A shadow map's face: the casters through the face's projection, row 0 of the map at the top
 * (the CPU's maps: core/kernels/raster.py), and a sun's depth along its direction. */
void main()
{
  vec4 clip = view_proj * vec4(pos, 1.0);
  clip.y = -clip.y;
#if !ORTHO
  /* the fragment writes its own depth: only w > 0 clips (the near plane lies in front of
   * every caster, the far one behind them all, so neither cuts one; a caster a float32
   * rounding beyond the far plane is kept) */
  clip.z = 0.0;
#endif
  v_along = dot(along.xyz, pos);
  gl_Position = clip;
}
