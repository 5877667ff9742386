/* texture: values that vary over a surface and with wavelength (reflectances, mix amounts).
 * Every texture evaluates to a double at (uv, lambda); a "float" texture simply ignores lambda.
 * Textures form an immutable DAG once built; evaluation is thread-safe and never NaN/Inf. */
#ifndef PRISMFARM_TEXTURE_H
#define PRISMFARM_TEXTURE_H

#include "err.h"
#include "spectrum.h"
#include "transform.h"
#include "vec3.h"

typedef struct texture texture_t;

/* The texture takes ownership of the spectrum. */
texture_t *texture_new_constant(spectrum_t *spectrum, err_t *err);
texture_t *texture_new_constant_value(double value, err_t *err);
/* pbrt-v4 "checkerboard" (2D, uv mapping): tex1 where floor(u*uscale) + floor(v*vscale) is
 * even, tex2 where it is odd. The inputs are borrowed: they must outlive this texture. */
texture_t *texture_new_checkerboard(const texture_t *tex1, const texture_t *tex2, double uscale,
                                    double vscale, err_t *err);
/* tex * scale (both borrowed). */
texture_t *texture_new_scale(const texture_t *tex, const texture_t *scale, err_t *err);
/* (1 - amount) * tex1 + amount * tex2 (all borrowed). */
texture_t *texture_new_mix(const texture_t *tex1, const texture_t *tex2, const texture_t *amount,
                           err_t *err);
/* pbrt-v4 ImageTexture's wrap modes (WrapMode): texel coordinates outside the image repeat,
 * read as black, clamp to the edge, or fold as the equal-area octahedral sphere does. */
typedef enum texture_wrap {
    TEXTURE_WRAP_REPEAT,
    TEXTURE_WRAP_BLACK,
    TEXTURE_WRAP_CLAMP,
    TEXTURE_WRAP_OCTAHEDRAL_SPHERE,
} texture_wrap_t;

/* pbrt-v4 MIPMap filters: the nearest texel and bilinear interpolation read level 0; trilinear
 * interpolates bilinear lookups of the two pyramid levels that a filter width selects
 * (texture_eval_width). pbrt-v4's "ewa" is read as trilinear (the loader warns). */
typedef enum texture_filter {
    TEXTURE_FILTER_POINT,
    TEXTURE_FILTER_BILINEAR,
    TEXTURE_FILTER_TRILINEAR,
} texture_filter_t;

typedef struct texture_image_opts {
    double uscale, vscale, udelta, vdelta; /* pbrt-v4 UVMapping: s = su u + du, t = sv v + dv */
    texture_wrap_t wrap;
    texture_filter_t filter;
    int grey;    /* a float texture: each texel is the average of its channels (pbrt-v4) */
    int threads; /* used while loading; <= 0: all cores */
} texture_image_opts_t;

/* uscale = vscale = 1, no delta, repeat, bilinear, RGB, all cores. */
texture_image_opts_t texture_image_opts_default(void);

/* An image texture (pbrt-v4 ImageTexture) from linear RGB values (w * h * 3 floats, row 0 at
 * the top; negative values read as 0). Each texel's colour becomes its rgb_uplift spectrum
 * once, at load, on opts->threads threads, so that a lookup costs one sigmoid per texel read
 * (a float texture keeps one value per texel). The lookup point is pbrt-v4's: (s, 1 - t) in
 * the image with texel centres at half-integers (t = 0 is the bottom row). Trilinear builds a
 * MIP pyramid by 2x2 box averages (pbrt-v4 first resamples a non-power-of-two image up to a
 * power of two; this pyramid halves with the edge texel repeated instead). */
texture_t *texture_new_image(const float *rgb, int w, int h, const texture_image_opts_t *opts,
                             err_t *err);

/* A tangent-space normal map (pbrt-v4 NormalMap): linear RGB in [0, 1] read as
 * 2 rgb - 1, bilinear with repeat, t flipped as for image textures. */
texture_t *texture_new_normalmap(const float *rgb, int w, int h, err_t *err);
/* The unit tangent-space normal at (u, v): x along dp/du, z the surface normal. (0, 0, 1)
 * where the map holds (0.5, 0.5, 0.5) or a zero vector. */
vec3_t texture_eval_normalmap(const texture_t *self, double u, double v);

/* ---- pbrt-v4's procedural textures (textures.h/.cpp), on Perlin noise (noise.h) ----
 * The 3D ones read the world point through to_texture (the inverse of the CTM at the Texture
 * directive: pbrt-v4's PointTransformMapping); the 2D ones map (u, v) to (s, t) = (su u + du,
 * sv v + dv) (pbrt-v4's UVMapping). Inputs are borrowed, as above. */
typedef struct texture_uv_map {
    double su, sv, du, dv;
} texture_uv_map_t;

/* "bilerp": (1-s)(1-t) v00 + s(1-t) v10 + (1-s)t v01 + st v11. */
texture_t *texture_new_bilerp(const texture_t *v00, const texture_t *v01, const texture_t *v10,
                              const texture_t *v11, texture_uv_map_t map, err_t *err);
/* "dots": inside where (s, t) falls in the polka dot of its cell (pbrt-v4 InsidePolkaDot:
 * cells centred on integer (s, t), a dot of radius 0.35 shifted by noise in cells whose noise
 * at the centre is positive), else outside. */
texture_t *texture_new_dots(const texture_t *inside, const texture_t *outside, texture_uv_map_t map,
                            err_t *err);
/* "checkerboard" "dimension" 3: tex1 where floor(x) + floor(y) + floor(z) of the texture-space
 * point is even, tex2 where it is odd. */
texture_t *texture_new_checkerboard3d(const texture_t *tex1, const texture_t *tex2,
                                      transform_t to_texture, err_t *err);
/* "fbm": noise_fbm(p, roughness, octaves); "wrinkled": noise_turbulence(p, roughness,
 * octaves); "windy": |fbm(0.1 p, 0.5, 3)| fbm(p, 0.5, 6). octaves 1..64. */
texture_t *texture_new_fbm(transform_t to_texture, int octaves, double roughness, err_t *err);
texture_t *texture_new_wrinkled(transform_t to_texture, int octaves, double roughness, err_t *err);
texture_t *texture_new_windy(transform_t to_texture, err_t *err);
/* "marble" (a spectrum texture): with q = scale p, m = q.y + variation fbm(q, roughness,
 * octaves) and t = 0.5 + 0.5 sin m, 1.5 times pbrt-v4's cubic Bezier spline of marble colours
 * at t, a linear sRGB reflectance taken to a spectrum by rgb_uplift (pbrt-v4's
 * RGBAlbedoSpectrum). */
texture_t *texture_new_marble(transform_t to_texture, int octaves, double roughness, double scale,
                              double variation, err_t *err);
/* "directionmix": with a = |n . dir| (n the geometric normal, dir unit, world space),
 * a tex1 + (1 - a) tex2. */
texture_t *texture_new_directionmix(const texture_t *tex1, const texture_t *tex2, vec3_t dir,
                                    err_t *err);

/* pbrt-v4's 2D mappings other than "uv" (SphericalMapping, CylindricalMapping, PlanarMapping),
 * from the hit point q in texture space (to_texture): spherical (s, t) = (theta / pi,
 * phi / 2 pi) of q's direction from the origin (theta from +z, phi from +x in [0, 2 pi));
 * cylindrical ((pi + atan2(q.y, q.x)) / 2 pi, q.z); planar (ds + q . vs, dt + q . vt). The
 * inner texture (a 2D one, made with the identity uv mapping) is looked up at u = s, v = t. */
typedef enum texture_mapping {
    TEXTURE_MAP_SPHERICAL,
    TEXTURE_MAP_CYLINDRICAL,
    TEXTURE_MAP_PLANAR,
} texture_mapping_t;
texture_t *texture_new_mapped(const texture_t *inner, texture_mapping_t mapping,
                              transform_t to_texture, vec3_t vs, vec3_t vt, double ds, double dt,
                              err_t *err);

void texture_destroy(texture_t **self_p);

/* Where a texture is looked up: the surface's (u, v), and for the 3D and direction textures
 * its world-space point p and unit geometric normal n. */
typedef struct texture_point {
    double u, v;
    vec3_t p, n;
} texture_point_t;

/* The texture at a surface point (filter width 0). texture_eval(t, u, v, lambda) is this with
 * p and n zero: the 2D textures give the same values, the 3D ones their value at the origin. */
double texture_eval_at(const texture_t *self, const texture_point_t *at, double lambda_nm);

/* texture_eval_at at n wavelengths at once: out[j] = texture_eval_at(self, at, lambda_nm[j]),
 * the same bits, with what does not depend on the wavelength (an image's texel addresses and
 * weights, a scale's or mix's branches) computed once for all lanes. */
void texture_eval_lanes(const texture_t *self, const texture_point_t *at, const double *lambda_nm,
                        int n, double *out);

double texture_eval(const texture_t *self, double u, double v, double lambda_nm);
/* The same with a filter width in (s, t) (pbrt-v4 MIPMap: twice the largest screen-space
 * derivative); texture_eval is width 0. Only a trilinear image texture reads it: prismfarm's
 * rays carry no differentials, so the renderer looks up level 0 (docs/scene-format.md). */
double texture_eval_width(const texture_t *self, double u, double v, double width,
                          double lambda_nm);

#endif
