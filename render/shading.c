#include "shading.h"

#include "volume.h"

#include "material_class.h"
#include "material_inputs.h"
#include "material_mix.h"
#include "microfacet.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

/* pbrt-v4 nests mixes without a limit; a cycle cannot be written (a mix names materials
 * defined before it), so this only bounds a pathological chain. */
#define MIX_DEPTH_MAX 32

double shading_texture(const texture_t *t, const surface_t *sf, double lambda)
{
    return material_inputs_texture(t, sf, lambda);
}

void shading_texture_lanes(const texture_t *t, const surface_t *sf, const double *lambda, int n,
                           double *out)
{
    material_inputs_texture_lanes(t, sf, lambda, n, out);
}

const material_t *shading_resolve(const scene_t *scene, const material_t *m, const surface_t *sf,
                                  double u)
{
    for (int d = 0; m->kind == MATERIAL_MIX && d < MIX_DEPTH_MAX; d++) {
        const material_mix_t *mix = material_mix_of(m);
        if (!mix)
            break; /* a mix built in code without its materials */
        double a = mix->amount ? shading_texture(mix->amount, sf, 550.0) : 0.5;
        int second = a >= 1.0 || (a > 0.0 && u < a);
        /* Rescale u so that a nested mix gets a fresh uniform (stratification survives). */
        if (a > 0.0 && a < 1.0)
            u = second ? u / a : (u - a) / (1.0 - a);
        m = &scene->materials[mix->materials[second]];
    }
    return m;
}

static double roughness_at(const texture_t *t, const surface_t *sf)
{
    return t ? shading_texture(t, sf, 550.0) : 0.0;
}

static microfacet_t distribution(const texture_t *u, const texture_t *v, int remap,
                                 const surface_t *sf)
{
    return microfacet_make(roughness_at(u, sf), roughness_at(v, sf), remap);
}

int shading_is_delta(const material_t *m, const surface_t *sf)
{
    if (m->kind != MATERIAL_CONDUCTOR && m->kind != MATERIAL_DIELECTRIC)
        return 0;
    if (m->smooth || m->rough)
        return m->smooth;
    microfacet_t mf = distribution(m->uroughness, m->vroughness, m->remaproughness, sf);
    return microfacet_smooth(&mf);
}

void shading_conductor_index(const material_t *m, const surface_t *sf, double lambda, double *eta,
                             double *k)
{
    material_inputs_conductor_index(m, sf, lambda, eta, k);
}

void shading_bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n,
                  bsdf_mode_t mode, bsdf_t *b)
{
    b->mode = mode;
    b->n = n;
    b->mf = distribution(m->uroughness, m->vroughness, m->remaproughness, sf);
    /* Smooth; a coated conductor's class sets its base's own (material_coatedconductor.h). */
    b->mf_base = distribution(NULL, NULL, m->remaproughness, sf);
    /* A thin film on glass or metal (bsdf_types.h: the Airy reflectance at each microfacet). */
    b->film_nm = 0.0;
    if (m->film_thickness > 0.0 &&
        (m->kind == MATERIAL_CONDUCTOR || m->kind == MATERIAL_DIELECTRIC)) {
        b->film_nm = m->film_thickness;
        for (int j = 0; j < n; j++) {
            b->film_n[j] = ior_eval(&m->film_ior, lambda[j]);
            b->lambda[j] = lambda[j];
        }
    }
    /* The rest is the material's own (scene/material_<name>.c). */
    material_class_bsdf(m, sf, lambda, n, b);
}

shading_frame_t shading_frame_make(const surface_t *sf, vec3_t wo)
{
    shading_frame_t f;
    f.z = vec3_dot(wo, sf->ns) * vec3_dot(wo, sf->ng) > 0.0 ? sf->ns : sf->ng;
    /* x along dp/du (pbrt-v4's shading frame: "uroughness" is along u), made orthogonal to
     * z; any tangent where dp/du is undefined or along the normal. */
    vec3_t t = vec3_sub(sf->dpdu, vec3_scale(f.z, vec3_dot(f.z, sf->dpdu)));
    double len = vec3_length(t);
    if (len > 1e-9 * (vec3_length(sf->dpdu) + 1e-300) && isfinite(len) && len > 0.0) {
        f.x = vec3_scale(t, 1.0 / len);
        f.y = vec3_cross(f.z, f.x);
    } else {
        vec3_basis(f.z, &f.x, &f.y);
    }
    return f;
}

vec3_t shading_to_local(const shading_frame_t *f, vec3_t w)
{
    return vec3_make(vec3_dot(w, f->x), vec3_dot(w, f->y), vec3_dot(w, f->z));
}

vec3_t shading_to_world(const shading_frame_t *f, vec3_t w)
{
    return vec3_add(vec3_add(vec3_scale(f->x, w.x), vec3_scale(f->y, w.y)), vec3_scale(f->z, w.z));
}

/* pbrt-v4 BumpMap's step in u and v when the ray has no differentials. */
#define BUMP_DELTA 0.0005

static vec3_t gram_schmidt(vec3_t v, vec3_t w)
{
    return vec3_sub(v, vec3_scale(w, vec3_dot(v, w)));
}

void shading_perturb(const material_t *m, surface_t *sf)
{
    if (m->kind == MATERIAL_HAIR) {
        /* The fibre's model sees the normal only up to a rotation about the fibre (bsdf/hair.h),
         * so a "cylinder" curve's tilted normal changes nothing in it but would let the
         * renderer's geometric-side test cut its lobes (5 % of a fibre's light in a white
         * furnace): it shades with the geometric normal. */
        sf->ns = sf->ng;
        sf->smooth = 0;
        return;
    }
    if (!m->displacement && !m->normalmap)
        return;
    vec3_t n = sf->ns, ng = sf->ng;
    /* pbrt-v4's shading dp/du and dp/dv: with vertex normals ss = (ns x dp/du) x ns and
     * ts = ns x dp/du (Triangle::InteractionFromIntersection), else the geometric ones. */
    vec3_t ss = sf->dpdu, ts = sf->dpdv;
    if (sf->smooth) {
        ts = vec3_cross(n, sf->dpdu);
        ss = vec3_cross(ts, n);
    }
    if (!(vec3_dot(ss, ss) > 0.0) || !(vec3_dot(ts, ts) > 0.0)) {
        vec3_t x, y;
        vec3_basis(n, &x, &y);
        ss = vec3_dot(ss, ss) > 0.0 ? ss : x;
        ts = vec3_dot(ts, ts) > 0.0 ? ts : y;
    }
    vec3_t dpdu, dpdv, ns;
    if (m->normalmap) {
        vec3_t t = texture_eval_normalmap(m->normalmap, sf->u, sf->v);
        vec3_t x = gram_schmidt(ss, n);
        double lx = vec3_length(x);
        vec3_t y;
        if (lx > 0.0 && isfinite(lx)) {
            x = vec3_scale(x, 1.0 / lx);
            y = vec3_cross(n, x);
        } else {
            vec3_basis(n, &x, &y);
        }
        ns = vec3_normalize(vec3_add(vec3_add(vec3_scale(x, t.x), vec3_scale(y, t.y)), vec3_scale(n, t.z)));
        double ulen = vec3_length(ss), vlen = vec3_length(ts);
        dpdu = vec3_scale(vec3_normalize(gram_schmidt(ss, ns)), ulen);
        dpdv = vec3_scale(vec3_normalize(vec3_cross(ns, dpdu)), vlen);
    } else {
        /* pbrt-v4 BumpMap: the shifted lookups move p along the shading dp/du, dp/dv too, so
         * a 3D displacement (fbm, wrinkled) bumps as a 2D one does. */
        texture_point_t at = {sf->u, sf->v, sf->p, sf->ng};
        double d = texture_eval_at(m->displacement, &at, 550.0);
        at.u = sf->u + BUMP_DELTA;
        at.p = vec3_add(sf->p, vec3_scale(ss, BUMP_DELTA));
        double du = texture_eval_at(m->displacement, &at, 550.0);
        at.u = sf->u;
        at.v = sf->v + BUMP_DELTA;
        at.p = vec3_add(sf->p, vec3_scale(ts, BUMP_DELTA));
        double dv = texture_eval_at(m->displacement, &at, 550.0);
        dpdu = vec3_add(ss, vec3_scale(n, (du - d) / BUMP_DELTA));
        dpdv = vec3_add(ts, vec3_scale(n, (dv - d) / BUMP_DELTA));
        ns = vec3_normalize(vec3_cross(dpdu, dpdv));
    }
    if (!(vec3_dot(ns, ns) > 0.5) || !isfinite(ns.x + ns.y + ns.z))
        return; /* a degenerate perturbation: keep the surface as it is */
    sf->ns = vec3_dot(ns, ng) < 0.0 ? vec3_neg(ns) : ns;
    sf->dpdu = dpdu;
    sf->dpdv = dpdv;
    sf->smooth = 1;
}

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* pbrt-v4 HashFloat(r.o, r.d): a uniform number in [0, 1) from the ray's bits. */
static double ray_hash(vec3_t o, vec3_t d)
{
    double v[6] = {o.x, o.y, o.z, d.x, d.y, d.z};
    uint64_t h = 0x9e3779b97f4a7c15ULL;
    for (int i = 0; i < 6; i++) {
        uint64_t b;
        memcpy(&b, &v[i], sizeof b);
        h = mix64(h ^ b);
    }
    return (double)(h >> 11) * 0x1p-53;
}

int shading_alpha_pass(const surface_t *sf, vec3_t org, vec3_t dir)
{
    const texture_t *t = sf->shape->alpha;
    if (!t)
        return 0;
    double a = shading_texture(t, sf, 550.0);
    if (a >= 1.0)
        return 0;
    if (!(a > 0.0))
        return 1;
    return ray_hash(org, dir) > a;
}

/* Cut-outs a shadow ray may pass before it counts as blocked (a forest of leaves). */
#define ALPHA_PASSES_MAX 256

int shading_occluded(const scene_t *scene, vec3_t org, vec3_t dir, double tmin, double tmax)
{
    if (!scene->has_alpha && !scene->has_interface)
        return geometry_occluded(scene->geometry, org, dir, tmin, tmax);
    for (int k = 0; k < ALPHA_PASSES_MAX; k++) {
        hit_t h;
        if (!geometry_intersect(scene->geometry, org, dir, tmin, tmax, &h))
            return 0;
        const shape_t *sh = &scene->shapes[h.shape];
        /* An "interface" is no surface (a boundary between media): light passes it, as camera
         * and BSDF rays do. */
        const int interface = scene->materials[sh->material].kind == MATERIAL_INTERFACE;
        if (!sh->alpha && !interface)
            return 1;
        surface_t sf;
        scene_surface(scene, &h, &sf);
        if (!interface && !shading_alpha_pass(&sf, org, dir))
            return 1;
        /* On from the surface: what is left of the segment beyond it. */
        vec3_t o = geometry_offset(sf.p, sf.ng, dir);
        tmax -= vec3_dot(vec3_sub(o, org), dir);
        org = o;
        tmin = 0.0;
        if (!(tmax > 0.0))
            return 0;
    }
    return 1;
}

int shading_transmittance(const scene_t *scene, vec3_t org, vec3_t dir, double tmax, int medium,
                          const double *lambda, int n, rng_stream_t *rng, double *T)
{
    for (int j = 0; j < n; j++)
        T[j] = 1.0;
    volume_lanes_t k;
    int lanes_of = -2; /* the medium k holds the coefficients of */
    for (int pass = 0; pass < ALPHA_PASSES_MAX; pass++) {
        hit_t h;
        int hit = geometry_intersect(scene->geometry, org, dir, 0.0, tmax, &h);
        if (medium >= 0) {
            const medium_t *m = scene->media[medium];
            if (lanes_of != medium) {
                volume_lanes_make(m, lambda, n, &k);
                lanes_of = medium;
            }
            volume_transmittance(m, &k, org, dir, hit ? h.t : tmax, rng, T);
            double mx = 0.0;
            for (int j = 0; j < n; j++)
                mx = T[j] > mx ? T[j] : mx;
            if (!(mx > 0.0))
                return 0;
        }
        if (!hit)
            return 1;
        const shape_t *sh = &scene->shapes[h.shape];
        const int interface = scene->materials[sh->material].kind == MATERIAL_INTERFACE;
        if (!sh->alpha && !interface)
            return 0;
        surface_t sf;
        scene_surface(scene, &h, &sf);
        if (!interface && !shading_alpha_pass(&sf, org, dir))
            return 0;
        /* A cut-out is no surface at all (pbrt-v4 ignores the hit); an interface is a surface
         * without material, where the medium may change. */
        if (interface)
            medium = scene_medium_after(&sf, dir, medium);
        vec3_t o = geometry_offset(sf.p, sf.ng, dir);
        tmax -= vec3_dot(vec3_sub(o, org), dir);
        org = o;
        if (!(tmax > 0.0))
            return 1;
    }
    return 0;
}
