#include "subsurface.h"

#include "geometry.h"
#include "shading.h"

#include <math.h>

/* A probe crosses at most this many surfaces of any material (a bound on work in a mesh
 * folded many times over itself; pbrt-v4 has none). */
#define PROBE_HITS_MAX 64

/* Lane j's medium at sf: sigma_t and the single-scattering albedo (pbrt-v4
 * SubsurfaceMaterial::GetBSSRDF), from sigma_a and sigma_s, or from the diffuse reflectance and
 * mean free path by inverting the table's effective albedo (SubsurfaceFromDiffuse). */
static void medium_at(const material_t *m, const surface_t *sf, double lambda, double *sigma_t,
                      double *rho)
{
    const material_subsurface_t *sss = material_subsurface_of(m);
    double sa, ss;
    if (sss->sigma_a) {
        sa = fmax(0.0, sss->scale * shading_texture(sss->sigma_a, sf, lambda));
        ss = fmax(0.0, sss->scale * shading_texture(sss->sigma_s, sf, lambda));
    } else {
        const double mfp = fmax(0.0, sss->scale * shading_texture(sss->mfp, sf, lambda));
        double r = shading_texture(sss->reflectance, sf, lambda);
        r = r > 0.0 ? (r < 1.0 ? r : 1.0) : 0.0;
        const double a = bssrdf_rho_from_eff(material_subsurface_table(m), r);
        sa = mfp > 0.0 ? (1.0 - a) / mfp : 0.0;
        ss = mfp > 0.0 ? a / mfp : 0.0;
    }
    *sigma_t = sa + ss;
    *rho = *sigma_t > 0.0 && isfinite(*sigma_t) ? ss / *sigma_t : 0.0;
    if (!isfinite(*sigma_t))
        *sigma_t = 0.0;
}

bool subsurface_find_exit(const scene_t *scene, const material_t *m, const surface_t *sf,
                          const double *lambda, int n, int hero, const double *sel,
                          const double u[3], rng_stream_t *rng, subsurface_exit_t *out)
{
    double sigma_t[BSDF_MAX_LANES], rho[BSDF_MAX_LANES];
    for (int j = 0; j < n; j++)
        medium_at(m, sf, lambda[j], &sigma_t[j], &rho[j]);
    const bssrdf_table_t *t = material_subsurface_table(m);
    const vec3_t po = sf->p, ns = sf->ns;
    vec3_t p0, p1;
    out->rays = 0;
    if (!bssrdf_probe(t, sigma_t[hero], rho[hero], po, ns, u[0], u[1], u[2], &p0, &p1))
        return false;
    /* Walk the segment surface by surface, keeping one hit of m uniformly among those seen
     * (reservoir sampling: the k-th replaces the kept one with probability 1 / k). */
    vec3_t org = p0;
    const vec3_t d = vec3_sub(p1, p0);
    const double len = vec3_length(d);
    if (!(len > 0.0))
        return false;
    const vec3_t dir = vec3_scale(d, 1.0 / len);
    double left = len;
    int found = 0;
    for (int i = 0; i < PROBE_HITS_MAX && left > 0.0; i++) {
        hit_t h;
        out->rays++;
        if (!geometry_intersect(scene->geometry, org, dir, 0.0, left, &h))
            break;
        surface_t s;
        scene_surface(scene, &h, &s);
        /* The entry's own material, a mix as a mix: pbrt-v4 compares the materials the hits
         * carry. */
        if (s.material == sf->material) {
            found++;
            if (found == 1 || rng_stream_next(rng) * found < 1.0)
                out->sf = s;
        }
        const vec3_t next = geometry_offset(h.p, h.ng, dir);
        left -= vec3_dot(vec3_sub(next, org), dir);
        org = next;
    }
    if (!found)
        return false;
    /* The exit's shading normal as its material sees it (normal and bump maps). */
    shading_perturb(m, &out->sf);
    const vec3_t pi = out->sf.p, ni = out->sf.ng;
    const double r = vec3_length(vec3_sub(pi, po));
    double pdf[BSDF_MAX_LANES];
    for (int j = 0; j < n; j++)
        pdf[j] = bssrdf_pdf_sp(t, sigma_t[j], rho[j], po, ns, pi, ni);
    double mix = 0.0;
    if (sel) {
        for (int j = 0; j < n; j++)
            mix += sel[j] * pdf[j];
    } else {
        mix = hero >= 0 && hero < n ? pdf[hero] : 0.0;
    }
    if (!(mix > 0.0))
        return false;
    for (int j = 0; j < n; j++) {
        const double w = bssrdf_sr(t, sigma_t[j], rho[j], r) * found / mix;
        out->weight[j] = isfinite(w) ? w : 0.0;
    }
    return true;
}

void subsurface_exit_bsdf(const material_t *m, int n, bsdf_mode_t mode, bsdf_t *b)
{
    b->kind = BSDF_SSS_EXIT;
    b->mode = mode;
    b->n = n;
    b->film_nm = 0.0;
    const double eta = bssrdf_table_eta(material_subsurface_table(m));
    for (int j = 0; j < n; j++)
        b->eta[j] = eta;
}
