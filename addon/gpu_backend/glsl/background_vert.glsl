/* A full-screen triangle at the far plane: drawn where the pre-pass drew nothing. */
void main()
{
  gl_Position = vec4(corner, 1.0, 1.0);
}
