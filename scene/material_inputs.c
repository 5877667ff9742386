#include "material_inputs.h"

#include "glass.h"
#include "loader.h"
#include "material_params.h"
#include "microfacet.h"
#include "named_spectra.h"
#include "pbrt_parser.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

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

/* ---- reading ---- */

int material_inputs_read_ior(material_params_t *mp, const char *prefix, scene_ior_t *ior)
{
    static const char *NAMES[] = {"eta", "glass", "sellmeier", "cauchy"};
    enum { N = sizeof NAMES / sizeof NAMES[0] };
    char names[N][48];
    for (size_t i = 0; i < N; i++)
        snprintf(names[i], sizeof names[i], "%s%s", prefix, NAMES[i]);
    params_t *ps = mp->ps;
    err_t *err = mp->err;
    param_t *given = NULL;
    for (size_t i = 0; i < N; i++) {
        param_t *p = params_find(ps, names[i]);
        if (!p)
            continue;
        if (given)
            return pbrt_error(err, p->loc,
                              "give only one of \"%s\", \"%s\", \"%s\" "
                              "and \"%s\" for %s (\"%s\" is already given)",
                              names[0], names[1], names[2], names[3], params_context(ps),
                              given->name);
        given = p;
    }
    memset(ior, 0, sizeof *ior);
    ior->loc = given ? given->loc : mp->dm->loc;
    if (!given) {
        ior->kind = SCENE_IOR_SPECTRUM;
        ior->spectrum = material_params_constant(1.5, mp->dm->loc); /* pbrt-v4's default eta */
        return 0;
    }
    const char *kind = given->name + strlen(prefix);
    if (!strcmp(kind, "eta")) {
        if (given->type == PARAM_TEXTURE)
            return pbrt_error(err, given->loc,
                              "unsupported parameter \"texture %s\": the "
                              "index of refraction cannot be a texture",
                              given->name);
        if (given->type != PARAM_FLOAT && given->type != PARAM_SPECTRUM) {
            char expected[128];
            snprintf(expected, sizeof expected, "\"float %s\" or \"spectrum %s\"", given->name,
                     given->name);
            return params_wrong_type(ps, given, expected, err);
        }
        ior->kind = SCENE_IOR_SPECTRUM;
        if (material_params_spectrum(mp, given, SPEC_UNBOUNDED, &ior->spectrum) != 0)
            return -1;
        if (ior->spectrum.kind == SCENE_SPECTRUM_CONSTANT && !(ior->spectrum.constant > 0.0))
            return pbrt_error(err, given->loc, "\"float %s\" must be greater than 0, got %g",
                              given->name, ior->spectrum.constant);
        if (ior->spectrum.kind == SCENE_SPECTRUM_SAMPLED)
            for (size_t i = 0; i < ior->spectrum.count; i++)
                if (!(ior->spectrum.value[i] > 0.0))
                    return pbrt_error(err, given->loc,
                                      "\"spectrum eta\": index %g in pair %zu "
                                      "is not positive",
                                      ior->spectrum.value[i], i + 1);
        return 0;
    }
    if (!strcmp(kind, "glass")) {
        const char *name;
        if (params_get_string(ps, given->name, NULL, &name, err) != 0)
            return -1;
        if (!*name)
            return pbrt_error(err, given->loc, "\"string %s\" is empty", given->name);
        ior->kind = SCENE_IOR_GLASS;
        ior->glass = name;
        return 0;
    }
    if (given->type != PARAM_FLOAT) {
        char expected[64];
        snprintf(expected, sizeof expected, "\"float %s\"", given->name);
        return params_wrong_type(ps, given, expected, err);
    }
    if (!strcmp(kind, "sellmeier")) {
        /* n^2 = 1 + sum B_i l^2 / (l^2 - C_i), l in um (docs/physics.md §3.3). */
        if (given->count < 2 || given->count % 2 != 0)
            return pbrt_error(err, given->loc,
                              "\"float sellmeier\" needs (B, C) pairs, got "
                              "%zu numbers",
                              given->count);
        ior->kind = SCENE_IOR_SELLMEIER;
        ior->nterms = given->count / 2;
        ior->sellmeier = given->numbers;
        return 0;
    }
    /* cauchy: n = A + B / l^2, l in um */
    if (given->count != 2)
        return pbrt_error(err, given->loc,
                          "expected 2 numbers after \"float cauchy\" (A B), "
                          "got %zu",
                          given->count);
    if (!(given->numbers[0] > 0.0))
        return pbrt_error(err, given->loc, "\"float cauchy\": A must be greater than 0, got %g",
                          given->numbers[0]);
    ior->kind = SCENE_IOR_CAUCHY;
    ior->cauchy[0] = given->numbers[0];
    ior->cauchy[1] = given->numbers[1];
    return 0;
}

int material_inputs_load_ior(material_params_t *mp, const char *prefix, ior_model_t *out)
{
    scene_ior_t in;
    return material_inputs_read_ior(mp, prefix, &in) ||
                   material_inputs_ior(mp->L->sc, &in, mp->name, out, mp->err)
               ? -1
               : 0;
}

/* pbrt-v4 materials.cpp: "<prefix>uroughness"/"<prefix>vroughness" override
 * "<prefix>roughness" (default 0); the prefix is "" or a layer's ("interface.",
 * "conductor."). */
int material_inputs_load_roughness(material_params_t *mp, const char *prefix,
                                   scene_float_input_t *uout, scene_float_input_t *vout,
                                   const texture_t **tu, const texture_t **tv)
{
    char un[48], vn[48], rn[48];
    snprintf(un, sizeof un, "%suroughness", prefix);
    snprintf(vn, sizeof vn, "%svroughness", prefix);
    snprintf(rn, sizeof rn, "%sroughness", prefix);
    param_t *u = params_find(mp->ps, un), *v = params_find(mp->ps, vn);
    scene_float_input_t r = {-1, 0.0};
    if ((!u || !v) && material_params_float(mp, rn, 0.0, &r) != 0)
        return -1;
    *uout = r;
    *vout = r;
    if (u && material_params_float(mp, un, 0.0, uout) != 0)
        return -1;
    if (v && material_params_float(mp, vn, 0.0, vout) != 0)
        return -1;
    if ((uout->texture < 0 && !(uout->value >= 0.0)) ||
        (vout->texture < 0 && !(vout->value >= 0.0)))
        return pbrt_error(mp->err, mp->dm->loc, "%sroughness must not be negative", prefix);
    return material_inputs_roughness(mp->L, uout, tu, mp->err) ||
                   material_inputs_roughness(mp->L, vout, tv, mp->err)
               ? -1
               : 0;
}

int material_inputs_load_remap(material_params_t *mp, material_t *m)
{
    bool remap;
    if (params_get_bool(mp->ps, "remaproughness", true, &remap, mp->err) != 0)
        return -1;
    m->remaproughness = remap;
    return 0;
}

void material_inputs_smoothness(material_t *m, const scene_float_input_t *u,
                                const scene_float_input_t *v)
{
    if (u->texture >= 0 || v->texture >= 0)
        return;
    microfacet_t mf = microfacet_make(u->value, v->value, m->remaproughness);
    m->smooth = microfacet_smooth(&mf);
    m->rough = !m->smooth;
}

/* As pbrt-v4's ConductorMaterial reads them ("eta", "k", "reflectance") and
 * CoatedConductorMaterial ("conductor.eta", "conductor.k", "reflectance"). */
int material_inputs_load_conductor(material_params_t *mp, const char *prefix, material_t *m)
{
    char en[48], kn[48];
    snprintf(en, sizeof en, "%seta", prefix);
    snprintf(kn, sizeof kn, "%sk", prefix);
    params_t *ps = mp->ps;
    const pbrt_loc_t loc = mp->dm->loc;
    param_t *r = params_find(ps, "reflectance");
    if (r && (params_find(ps, en) || params_find(ps, kn)))
        return pbrt_error(mp->err, r->loc,
                          "%s: give either \"reflectance\" or \"%s\" and \"%s\", not both",
                          params_context(ps), en, kn);
    if (r)
        return (m->reflectance = material_params_spectrum_texture(
                    mp, "reflectance", material_params_constant(1.0, loc), SPEC_REFLECTANCE))
                   ? 0
                   : -1;
    scene_spectrum_input_t eta, k;
    if (material_params_spectrum_input(mp, en, material_params_named("metal-Cu-eta", loc),
                                       SPEC_UNBOUNDED, &eta) ||
        material_params_spectrum_input(mp, kn, material_params_named("metal-Cu-k", loc),
                                       SPEC_UNBOUNDED, &k))
        return -1;
    if (eta.texture >= 0 || k.texture >= 0)
        return pbrt_error(mp->err, loc, "material \"%s\": textured eta/k are not supported",
                          m->name);
    return (m->eta = loader_owned_spectrum(mp->L->sc, &eta.spectrum, SPEC_UNBOUNDED, mp->err)) &&
                   (m->k = loader_owned_spectrum(mp->L->sc, &k.spectrum, SPEC_UNBOUNDED, mp->err))
               ? 0
               : -1;
}

int material_inputs_load_layer(material_params_t *mp, material_layer_t *layer)
{
    scene_float_input_t thickness, g;
    scene_spectrum_input_t albedo;
    params_t *ps = mp->ps;
    if (material_params_float(mp, "thickness", 0.01, &thickness) != 0 ||
        material_params_float(mp, "g", 0.0, &g) != 0 ||
        material_params_spectrum_input(mp, "albedo", material_params_constant(0.0, mp->dm->loc),
                                       SPEC_REFLECTANCE, &albedo) != 0 ||
        params_get_int(ps, "maxdepth", 10, &layer->maxdepth, mp->err) != 0 ||
        params_get_int(ps, "nsamples", 1, &layer->nsamples, mp->err) != 0 ||
        material_params_range(mp, "maxdepth", layer->maxdepth, 1, 1000) != 0 ||
        material_params_range(mp, "nsamples", layer->nsamples, 1, 1000) != 0)
        return -1;
    if (thickness.texture < 0 && !(thickness.value > 0.0))
        return material_params_positive(mp, "thickness", thickness.value);
    if (g.texture < 0 && !(g.value > -1.0 && g.value < 1.0))
        return material_params_range(mp, "g", g.value, -0.999, 0.999);
    return (layer->thickness = loader_float_input(mp->L, &thickness, mp->err)) &&
                   (layer->g = loader_float_input(mp->L, &g, mp->err)) &&
                   (layer->albedo =
                        loader_spectrum_input(mp->L, &albedo, SPEC_REFLECTANCE, mp->err))
               ? 0
               : -1;
}

/* A thin film on glass or metal, smooth (bsdf/delta) or rough (the Airy reflectance at each
 * microfacet, bsdf/lobe). */
int material_inputs_load_film(material_params_t *mp, material_t *m)
{
    double thickness, eta;
    if (params_get_float(mp->ps, "filmthickness", 0.0, &thickness, mp->err) != 0 ||
        params_get_float(mp->ps, "filmeta", 1.33, &eta, mp->err) != 0 ||
        material_params_range(mp, "filmthickness", thickness, 0.0, 1e5) != 0 ||
        material_params_range(mp, "filmeta", eta, 1.0, 5.0) != 0)
        return -1;
    if (thickness > 0.0) {
        m->film_thickness = thickness;
        m->film_ior = ior_constant(eta);
    }
    return 0;
}

static const char *CRYSTAL_IOR_KINDS[] = {"eta", "glass", "sellmeier", "cauchy"};
enum { NCRYSTAL_IOR_KINDS = sizeof CRYSTAL_IOR_KINDS / sizeof CRYSTAL_IOR_KINDS[0] };

bool material_inputs_names_crystal(material_params_t *mp)
{
    if (params_find(mp->ps, "crystal"))
        return true;
    for (size_t i = 0; i < 2 * NCRYSTAL_IOR_KINDS; i++) {
        char name[16];
        snprintf(name, sizeof name, "%s%s", i % 2 ? "e." : "o.", CRYSTAL_IOR_KINDS[i / 2]);
        if (params_find(mp->ps, name))
            return true;
    }
    return false;
}

int material_inputs_load_crystal(material_params_t *mp, const char *what, crystal_t *out)
{
    const char *pre[2] = {"o.", "e."};
    bool has[2] = {false, false};
    scene_ior_t ior[2];
    const char *crystal;
    err_t *err = mp->err;
    if (params_get_string(mp->ps, "crystal", NULL, &crystal, err) != 0)
        return -1;
    for (int w = 0; w < 2; w++) {
        for (size_t i = 0; i < NCRYSTAL_IOR_KINDS; i++) {
            char name[16];
            snprintf(name, sizeof name, "%s%s", pre[w], CRYSTAL_IOR_KINDS[i]);
            has[w] |= params_find(mp->ps, name) != NULL;
        }
        if (!has[w] && !crystal)
            return pbrt_error(err, mp->dm->loc,
                              "Material \"%s\" needs \"string crystal\" or both indices "
                              "(\"float o.eta\", \"float e.eta\" or their glass, sellmeier, "
                              "cauchy forms)",
                              what);
        if (has[w] && material_inputs_read_ior(mp, pre[w], &ior[w]) != 0)
            return -1;
    }
    if (crystal) {
        const crystal_t *c = crystal_lookup(crystal, err);
        if (!c) {
            char why[sizeof err->msg]; /* err->msg cannot be its own argument */
            snprintf(why, sizeof why, "%s", err->msg);
            return pbrt_error(err, mp->dm->loc, "material \"%s\": %s", mp->name, why);
        }
        *out = *c;
    } else {
        *out = (crystal_t){.name = "(given)", .description = "", .source = "the scene file"};
    }
    if (has[0] && material_inputs_ior(mp->L->sc, &ior[0], mp->name, &out->no, err))
        return -1;
    if (has[1] && material_inputs_ior(mp->L->sc, &ior[1], mp->name, &out->ne, err))
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

void material_inputs_layer_at(const material_layer_t *layer, const surface_t *sf,
                              const double *lambda, int n, bsdf_t *b)
{
    static const material_layer_t DEFAULTS = {0};
    const material_layer_t *m = layer ? layer : &DEFAULTS;
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
