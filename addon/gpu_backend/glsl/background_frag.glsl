/* The world seen where no surface is: its constant colour and the background's opacity. */
void main()
{
  out_combined = frame.world;
  out_diffuse = vec4(0.0);
  out_specular = vec4(0.0);
  out_surface = vec4(0.0);
  out_normal = vec4(0.0);
  out_emit = vec4(0.0);
}
