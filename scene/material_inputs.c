#include "material_inputs.h"

#include "glass.h"
#include "loader.h"
#include "named_spectra.h"
#include "pbrt_parser.h"

#include <math.h>
#include <stdio.h>

/* ---- loading ---- */

/* A tabulated index the scene owns: the pairs are copied into a spectrum the scene keeps, whose
 * arrays the model borrows (IOR_TABULATED's lifetime rule: as long as the scene). */
static int tabulated_ior(scene_t *sc, const double *lambda, const double *n, size_t count,
                         const pbrt_loc_t *loc, ior_model_t *out, err_t *err)
{
    spectrum_t *copy = spectrum_new_tabulated(lambda, n, count, err);
    if (!copy || scene_own_spectrum(sc, copy, err))
        return copy ? -1 : pbrt_error(err, *loc, "%s", err ? err->msg : "");
    size_t k;
    const double *l, *v;
    spectrum_tabulated_pairs(copy, &k, &l, &v);
    if (ior_tabulated(out, l, v, k, err))
        return pbrt_error(err, *loc, "%s", err ? err->msg : "");
    return 0;
}

int material_inputs_ior(scene_t *sc, const scene_ior_t *in, const char *material, ior_model_t *out,
                        err_t *err)
{
    switch (in->kind) {
    case SCENE_IOR_SPECTRUM: {
        const scene_spectrum_t *sp = &in->spectrum;
        if (sp->kind == SCENE_SPECTRUM_CONSTANT) {
            *out = ior_constant(sp->constant);
            return 0;
        }
        /* pbrt-v4's named spectra first (its glass-* tables), then prismfarm's catalogue names. */
        const named_spectrum_t *e =
            sp->kind == SCENE_SPECTRUM_NAMED || (sp->kind == SCENE_SPECTRUM_SAMPLED && sp->file)
                ? named_spectra_find(sp->name)
                : NULL;
        if (e && e->kind == NAMED_SPECTRUM_ILLUMINANT)
            return pbrt_error(
                err, in->loc,
                "material \"%s\": \"%s\" is an illuminant, not an index of refraction", material,
                sp->name);
        if (e) {
            if (ior_tabulated(out, e->lambda, e->value, e->count, err)) /* static tables */
                return pbrt_error(err, in->loc, "material \"%s\": %s", material,
                                  err ? err->msg : "");
            return 0;
        }
        if (sp->kind == SCENE_SPECTRUM_NAMED) {
            const glass_t *g = glass_find(sp->name);
            if (g) {
                *out = g->ior;
                return 0;
            }
            char names[1024];
            return pbrt_error(
                err, in->loc,
                "material \"%s\": \"%s\" is neither a named spectrum, a glass of the catalogue "
                "(prismfarm glass --list) nor a spectrum file (looked for %s); named spectra: %s",
                material, sp->name, sp->searched ? sp->searched : "no file",
                named_spectra_list(names, sizeof names));
        }
        if (sp->kind == SCENE_SPECTRUM_SAMPLED)
            return tabulated_ior(sc, sp->lambda, sp->value, sp->count, &in->loc, out, err);
        return pbrt_error(err, in->loc,
                          "material \"%s\": eta must be a number, (wavelength, n) pairs, a "
                          "spectrum file, a glass name, or "
                          "given by \"string glass\", \"float sellmeier\" or \"float cauchy\"",
                          material);
    }
    case SCENE_IOR_GLASS: {
        const glass_t *g = glass_find(in->glass);
        if (!g)
            return pbrt_error(err, in->loc,
                              "material \"%s\": unknown glass \"%s\" (see prismfarm glass --list)",
                              material, in->glass);
        *out = g->ior;
        return 0;
    }
    case SCENE_IOR_SELLMEIER: {
        double b[IOR_SELLMEIER_MAX_TERMS], c[IOR_SELLMEIER_MAX_TERMS];
        if (in->nterms > IOR_SELLMEIER_MAX_TERMS)
            return pbrt_error(err, in->loc, "material \"%s\": at most %d Sellmeier terms, got %zu",
                              material, IOR_SELLMEIER_MAX_TERMS, in->nterms);
        for (size_t i = 0; i < in->nterms; i++) {
            b[i] = in->sellmeier[2 * i];
            c[i] = in->sellmeier[2 * i + 1];
        }
        if (ior_sellmeier(out, 0.0, b, c, (int)in->nterms, err))
            return err_prefix(err, "%s:%d:%d: ", in->loc.file, in->loc.line, in->loc.col);
        return 0;
    }
    case SCENE_IOR_CAUCHY:
        *out = ior_cauchy(in->cauchy[0], in->cauchy[1]);
        return 0;
    }
    return err_set(err, "unknown index model");
}

int material_inputs_roughness(loader_t *L, const scene_float_input_t *in, const texture_t **out,
                              err_t *err)
{
    *out = NULL;
    if (in->texture < 0 && in->value == 0.0)
        return 0;
    return (*out = loader_float_input(L, in, err)) ? 0 : -1;
}

int material_inputs_conductor(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if (dm->use_reflectance)
        return (m->reflectance = loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err))
                   ? 0
                   : -1;
    if (dm->eta.texture >= 0 || dm->k.texture >= 0)
        return pbrt_error(err, dm->loc, "material \"%s\": textured eta/k are not supported",
                          m->name);
    return (m->eta = loader_owned_spectrum(L->sc, &dm->eta.spectrum, SPEC_UNBOUNDED, err)) &&
                   (m->k = loader_owned_spectrum(L->sc, &dm->k.spectrum, SPEC_UNBOUNDED, err))
               ? 0
               : -1;
}

int material_inputs_layer(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->maxdepth = dm->maxdepth;
    m->nsamples = dm->nsamples;
    return (m->thickness = loader_float_input(L, &dm->thickness, err)) &&
                   (m->g = loader_float_input(L, &dm->g, err)) &&
                   (m->albedo = loader_spectrum_input(L, &dm->albedo, SPEC_REFLECTANCE, err))
               ? 0
               : -1;
}

int material_inputs_crystal(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if (dm->crystal) {
        const crystal_t *c = crystal_lookup(dm->crystal, err);
        if (!c) {
            char why[sizeof err->msg]; /* err->msg cannot be its own argument */
            snprintf(why, sizeof why, "%s", err->msg);
            return pbrt_error(err, dm->loc, "material \"%s\": %s", m->name, why);
        }
        m->crystal = *c;
    } else {
        m->crystal = (crystal_t){.name = "(given)", .description = "", .source = "the scene file"};
    }
    if (dm->has_o && material_inputs_ior(L->sc, &dm->ior_o, m->name, &m->crystal.no, err))
        return -1;
    if (dm->has_e && material_inputs_ior(L->sc, &dm->ior_e, m->name, &m->crystal.ne, err))
        return -1;
    return 0;
}

/* ---- at a hit ---- */

double material_inputs_texture(const texture_t *t, const surface_t *sf, double lambda)
{
    const texture_point_t at = {sf->u, sf->v, sf->p, sf->ng};
    return texture_eval_at(t, &at, lambda);
}

void material_inputs_texture_lanes(const texture_t *t, const surface_t *sf, const double *lambda,
                                   int n, double *out)
{
    const texture_point_t at = {sf->u, sf->v, sf->p, sf->ng};
    texture_eval_lanes(t, &at, lambda, n, out);
}

void material_inputs_texture_lanes01(const texture_t *t, const surface_t *sf, const double *lambda,
                                     int n, double *out)
{
    material_inputs_texture_lanes(t, sf, lambda, n, out);
    for (int j = 0; j < n; j++)
        out[j] = material_inputs_clamp01(out[j]);
}

void material_inputs_conductor_index(const material_t *m, const surface_t *sf, double lambda,
                                     double *eta, double *k)
{
    if (m->eta && m->k) {
        *eta = spectrum_eval(m->eta, lambda);
        *k = spectrum_eval(m->k, lambda);
        return;
    }
    if (!m->reflectance) {
        /* eta 0 and k > 0: fresnel_conductor's R = 1. */
        *eta = 0.0;
        *k = 1.0;
        return;
    }
    double r = fmin(fmax(material_inputs_texture(m->reflectance, sf, lambda), 0.0), 0.9999);
    *eta = 1.0;
    *k = 2.0 * sqrt(r) / sqrt(1.0 - r);
}

void material_inputs_layer_at(const material_t *m, const surface_t *sf, const double *lambda, int n,
                              bsdf_t *b)
{
    double th = m->thickness ? material_inputs_texture(m->thickness, sf, 550.0) : 0.01;
    b->thickness = fmax(th, 1e-7); /* pbrt-v4: max(thickness, epsilon) */
    double g = m->g ? material_inputs_texture(m->g, sf, 550.0) : 0.0;
    b->g = fmin(fmax(g, -0.999), 0.999);
    b->maxdepth = m->maxdepth > 0 ? m->maxdepth : 10;
    b->nsamples = m->nsamples > 0 ? m->nsamples : 1;
    for (int j = 0; j < n; j++)
        b->albedo[j] =
            m->albedo ? material_inputs_clamp01(material_inputs_texture(m->albedo, sf, lambda[j]))
                      : 0.0;
}

double material_inputs_coat_eta(const material_t *m, double lambda)
{
    double e = ior_eval(&m->ior, lambda);
    return e > 0.0 ? e : 1.0;
}
