/* Stochastic transparency's thresholds (core/render/transparency.dither_thresholds, the same
 * numbers: 32-bit integer arithmetic, 24 bits kept). */

uint dither_hash(uint px, uint py, uint layer)
{
  uint h = (px * 0x9E3779B1u) ^ (py * 0x85EBCA77u) ^ (layer * 0xC2B2AE3Du);
  h ^= h >> 15u;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12u;
  h *= 0x297A2D39u;
  return h ^ (h >> 15u);
}

/* The threshold of pixel (px, py) (rows from the top) for a sample and a layer */
float dither_threshold(ivec2 pixel, int sample_number, int layer)
{
  uint turn = dither_hash(uint(pixel.x), uint(pixel.y), uint(layer)) +
              uint(sample_number) * 0x9E3779B9u;
  return float(turn >> 8u) / 16777216.0;
}
