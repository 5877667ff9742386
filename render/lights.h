/* lights: next-event estimation. Picks an emitter (a light, or one triangle of a mesh light) as
 * the scene's light sampler says -- the light BVH by importance as seen from the shading point,
 * by power, or uniformly (scene/emitters.h) --, samples a point or direction on it, and
 * evaluates emission, all with the pdfs that multiple importance sampling needs. Delta lights (point, spot, distant) are reached only
 * here; a collimated area light is delta in direction and reached by neither camera paths nor
 * light sampling (only by photons), as the thesis observed (fig. 6.7). */
#ifndef PRISMFARM_LIGHTS_H
#define PRISMFARM_LIGHTS_H

#include "scene.h"

typedef struct light_sample {
    int light;      /* index into scene->lights */
    size_t tri;     /* a mesh light's triangle that was sampled (else 0) */
    vec3_t wi;      /* unit direction from the shading point toward the light */
    double dist;    /* distance to the sampled point; INFINITY for distant and infinite lights */
    double pdf;     /* pmf of the light times the solid-angle pdf (delta lights: the pmf) */
    int is_delta;   /* point, spot, goniometric, projection or distant: no MIS, no BSDF
                     * sampling can hit it */
    vec3_t p_light; /* area lights: the sampled point */
    vec3_t n_light; /* area lights: the unit normal at the sampled point */
    size_t texel;   /* image infinite lights: the texel sampled; goniometric and projection
                     * lights: the texel the light's image sends toward the point */
    double uv[2];   /* image area lights: the texture coordinates of the sampled point */
} light_sample_t;

/* Where a light is sampled from, and what competes with the sample. */
typedef struct lights_at {
    vec3_t p;  /* the shading point */
    vec3_t n;  /* its unit shading normal; (0, 0, 0) at a point in a medium */
    int mis;   /* BSDF or phase sampling competes under MIS (image lights may then sample
                * their compensated distribution) */
} lights_at_t;

/* Samples a light for shading point at->p with four uniform numbers: u[0] picks the emitter
 * (a light, or one triangle of a mesh light: scene/emitters.h) as settings.light_sampler says
 * -- the light BVH by importance at (at->p, at->n) with the distant and infinite lights chosen
 * uniformly beside it, or by power, or uniformly, each as pbrt-v4 defines them --, u[1] a mesh
 * light's triangle under "power" (by area within the light), u[2] and u[3] the point or
 * direction. A triangle or disk is sampled uniformly by area; a sphere light seen from outside
 * uniformly in the cone of directions it subtends (pbrt-v4 Sphere::Sample: every sample lands
 * on the visible cap), an image environment by its texels' distribution (envmap.h) -- with
 * at->mis its compensated one (pbrt-v4's allowIncompletePDF), which leaves the directions at or
 * below the image's average to the competing strategy --, a uniform one uniformly over the
 * sphere. Returns 0 when nothing can be sampled (no lights, a collimated light, a zero-area
 * light, a point outside a projection light's frustum, no emitter of nonzero importance, a
 * degenerate configuration). */
int lights_sample(const scene_t *scene, const lights_at_t *at, const double u[4], light_sample_t *out);

/* The probability that lights_sample picks light l's emitter tri (the triangle of a mesh
 * light; ignored for other lights) at `at`: over every emitter it sums to 1 (or 0 where the
 * BVH finds nothing of nonzero importance). */
double lights_pmf(const scene_t *scene, const lights_at_t *at, int l, size_t tri);

/* The light's spectral value at lambda: its spectrum times its scale, the factor every
 * emission query multiplies in. A pure function of (l, lambda), so a caller may keep it
 * (render.c keeps it per lane: a path's wavelengths rarely change, a blackbody costs an expm1). */
double lights_value(const light_t *l, double lambda);

/* The emitted quantity that arrives at the shading point along the sample at wavelength
 * lambda, given the light's value = lights_value(light, lambda): radiance for area lights
 * (times their image at the point, lights_area_image) and infinite lights (an image's texel
 * times value), I/d^2 for point, spot (times the falloff),
 * goniometric and projection lights (times the texel's value, lights_image_value), the
 * irradiance-defining L for distant lights. */
double lights_sample_emission_of(const scene_t *scene, const light_sample_t *s, double value,
                                 double lambda);

/* Whether area light l emits toward wo (unit, away from the surface) at a point with unit
 * normal ng: a two-sided light always, a one-sided one on its front only. 0 for other kinds. */
int lights_area_faces(const light_t *l, vec3_t ng, vec3_t wo);

/* Uniform point on a shape by area with u0 (a mesh's triangle), u1 and u2: the point and its
 * unit normal, oriented as scene_surface orients a hit there (the shape's flip flag, and for a
 * mesh with vertex normals their side), so that emission seen by a hit, by a light sample and
 * by a photon agree; with uv non-NULL also the texture coordinates scene_surface gives a hit
 * there. The pdf is 1 / shape->area. Returns 0 for a shape of zero area (such a light emits
 * nothing: its power L pi A is 0) or a triangle whose edges give no normal; a sliver of any
 * positive width gets its unit normal. */
int lights_sample_shape(const shape_t *shape, double u0, double u1, double u2, vec3_t *p, vec3_t *n,
                        double uv[2]);

/* An area light's image factor at texture coordinates (u, v) and lambda: its radiance there is
 * lights_value(l, lambda) times this (1 for a light without an image). */
double lights_area_image(const light_t *l, double u, double v, double lambda);

/* The normalised Stokes vector s (s[0] = 1) of light l's emission travelling along unit k,
 * measured in the frame x (unit, perpendicular to k; y = k x x, polar/polar_frame.h):
 * (1, P cos 2psi, P sin 2psi, 0) with P the light's degree of polarisation and psi the angle
 * from x toward y of its polarisation axis made perpendicular to k (docs/physics.md §14.2);
 * (1, 0, 0, 0) for an unpolarised light. */
void lights_stokes(const light_t *l, vec3_t k, vec3_t x, double s[4]);

/* A spot light's falloff at the cosine of the angle to its axis: 1 inside the inner cone, 0
 * outside the outer one, pbrt-v4's smoothstep between. */
double lights_spot_falloff(const light_t *l, double cos_theta);

/* A goniometric or projection light's texel toward world direction w (from the light, any
 * length > 0; PROJMAP_OUTSIDE outside a projection's frustum), and that texel's factor at
 * lambda: the light emits intensity lights_value(l, lambda) * lights_image_value(l, texel,
 * lambda) along w (0 outside the frustum). */
size_t lights_image_texel(const light_t *l, vec3_t w);
double lights_image_value(const light_t *l, size_t texel, double lambda);

/* Environment radiance for a ray that left the scene: the sum over the uniform infinite lights
 * (image environments are lights_envmap_radiance's). */
double lights_environment(const scene_t *scene, double lambda);

/* An image infinite light's texel seen along world direction wi (unit), and the radiance
 * there at lambda given value = lights_value(light, lambda). */
size_t lights_envmap_texel(const light_t *l, vec3_t wi);
double lights_envmap_radiance(const light_t *l, size_t texel, double value, double lambda);

/* The pdf lights_sample would have had at `at` for reaching light l (triangle tri of a mesh
 * light, the hit's primitive; ignored otherwise) at point p_light with normal ng along unit wi
 * (area lights: the cone's for a sphere seen from outside), or along wi toward infinity
 * (infinite lights; an image's compensated distribution when at->mis, as lights_sample's):
 * lights_pmf times the point's or direction's pdf, the same numbers in the same order as
 * lights_sample, so the two agree to the last bit for the same sample. A BSDF-sampled ray's MIS
 * weight must ask with the `at` its vertex's next-event estimation used, so that both
 * strategies' pdfs are of the same distributions. */
double lights_pdf(const scene_t *scene, const lights_at_t *at, int l, size_t tri, vec3_t wi,
                  vec3_t p_light, vec3_t ng);

/* Lamp probes (docs/rendering.md, "Small lamps seen directly"): the world sphere area lights
 * (opaque, at most LIGHTS_PROBE_MAX of them) whose directly seen emission a render estimates
 * from several positions in the pixel, and a cheap test that says when a ray may hit one, so
 * that only such rays are traced. */
#define LIGHTS_PROBE_MAX 16
typedef struct lights_probes {
    int n; /* 0: the scene has none, or more than LIGHTS_PROBE_MAX, or a sphere light of
            * another kind (probing is then off) */
    int light[LIGHTS_PROBE_MAX];
    vec3_t centre[LIGHTS_PROBE_MAX];
    double r2[LIGHTS_PROBE_MAX]; /* the squared radius, widened by 1e-3 relative */
} lights_probes_t;

/* The scene's probe set into *out. */
void lights_probes_make(const scene_t *scene, lights_probes_t *out);

/* Whether light index `light` is one of the set's. */
int lights_probes_has(const lights_probes_t *pr, int light);

/* 0 when the ray from o along unit d certainly misses every sphere of the set (conservative:
 * the widened radius), 1 when it may hit one. */
int lights_probes_may_hit(const lights_probes_t *pr, vec3_t o, vec3_t d);

/* 0 when no ray from o whose direction lies within the cone about unit axis of half-angle
 * `half` (radians) can meet a sphere of the set (conservative), 1 otherwise. */
int lights_probes_in_cone(const lights_probes_t *pr, vec3_t o, vec3_t axis, double half);

#endif
