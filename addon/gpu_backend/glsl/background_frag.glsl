/* The world seen where no surface is: its constant colour (alpha 1), added per sample. */
void main()
{
  out_key = vec4(0.0);
  WRITE_TARGETS(frame.world, vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0),
                vec4(0.0));
}
