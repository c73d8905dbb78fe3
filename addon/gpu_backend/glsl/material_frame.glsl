/* What material programs (gpu_backend/materials.py) read in a frame: the shaded point, points
 * moved in its triangle's plane (core/render/surfaces.material_points: the camera ray through
 * the moved window position met with the plane; the corner attributes there from their screen
 * derivatives, exact for the affine functions they are on a triangle), the object's rows of
 * `objects` and the material images of `mat_texels` (8-bit) and `mat_floats`. */

vec3 mp_dpos[2];  /* the position's change one pixel right and up (dFdx, dFdy) */
vec2 mp_pixel;  /* the sample's window position, pixels from the top-left corner */

MatPoint mp_moved(MatPoint p, int axis, float step)
{
  vec2 at = mp_pixel + (axis == 0 ? vec2(step, 0.0) : vec2(0.0, step));
  vec2 ndc = vec2(at.x * 2.0 / float(frame.size.x) - 1.0, 1.0 - at.y * 2.0 / float(frame.size.y));
  vec4 near_p = frame.clip_to_world * vec4(ndc, -1.0, 1.0);
  vec4 mid_p = frame.clip_to_world * vec4(ndc, 0.0, 1.0);
  vec3 o = near_p.xyz / near_p.w;
  vec3 d = mid_p.xyz / mid_p.w - o;
  MatPoint q = p;
  q.position = o + (dot(p.position - o, p.geo) / dot(d, p.geo)) * d;
  vec3 e = q.position - p.position;
  float xx = dot(mp_dpos[0], mp_dpos[0]), xy = dot(mp_dpos[0], mp_dpos[1]);
  float yy = dot(mp_dpos[1], mp_dpos[1]);
  float ex = dot(e, mp_dpos[0]), ey = dot(e, mp_dpos[1]);
  q.shift = vec2(yy * ex - xy * ey, xx * ey - xy * ex) / (xx * yy - xy * xy);
  q.window = vec2(at.x / float(frame.size.x), 1.0 - at.y / float(frame.size.y));
  return q;
}

vec4 mp_object(MatPoint p, int k)
{
  return texel_at(objects, textureSize(objects, 0).x, 5 * p.object + k);
}

vec4 mat_const(int k)
{
  int w = textureSize(mat_consts, 0).x;
  return texelFetch(mat_consts, ivec2(k % w, k / w), 0);
}

vec3 mp_camera(vec3 position)
{
  return (frame.world_to_camera * vec4(position, 1.0)).xyz;
}

vec4 mp_image(int t, vec2 uv, float lod, int associate)
{
  if (images[t].info2.y != 0) {
    return texture_sample(t, mat_texels, uv, lod, associate);
  }
  return texture_sample(t, mat_floats, uv, lod, associate);
}

/* The shaded point as a program reads it (s from surface_at) */
MatPoint mp_point(vec3 p, vec3 n, vec3 geo, vec3 v)
{
  MatPoint m;
  m.position = p;
  m.normal = n;
  m.geo = geo;
  m.view = v;
  m.backfacing = dot(v_geo, v) < 0.0 ? 1.0 : 0.0;
  m.window = vec2(mp_pixel.x / float(frame.size.x), 1.0 - mp_pixel.y / float(frame.size.y));
  m.object = v_object;
  m.shift = vec2(0.0);
  return m;
}
