#include "load_materials.h"

#include "files.h"
#include "glass.h"
#include "hair.h"
#include "load_textures.h"
#include "subsurface_load.h"
#include "microfacet.h"
#include "named_spectra.h"
#include "pbrt_parser.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

static int build_ior(scene_t *sc, const scene_ior_t *in, const char *material, ior_model_t *out,
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

/* A roughness input: NULL when it is the constant 0 (the smooth case needs no texture). */
static int roughness_input(loader_t *L, const scene_float_input_t *in, const texture_t **out,
                           err_t *err)
{
    *out = NULL;
    if (in->texture < 0 && in->value == 0.0)
        return 0;
    return (*out = loader_float_input(L, in, err)) ? 0 : -1;
}

/* A conductor's eta and k (or its reflectance, pbrt-v4's alternative). */
static int conductor_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
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

static int layer_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->maxdepth = dm->maxdepth;
    m->nsamples = dm->nsamples;
    return (m->thickness = loader_float_input(L, &dm->thickness, err)) &&
                   (m->g = loader_float_input(L, &dm->g, err)) &&
                   (m->albedo = loader_spectrum_input(L, &dm->albedo, SPEC_REFLECTANCE, err))
               ? 0
               : -1;
}

/* A uniaxial crystal: a smooth dielectric whose ior is the ordinary index (material_t). */
/* A crystal's indices (a uniaxial material's, a retarder plate's): the catalogue's, or the
 * given ones, which replace them. */
static int crystal_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
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
    if (dm->has_o && build_ior(L->sc, &dm->ior_o, m->name, &m->crystal.no, err))
        return -1;
    if (dm->has_e && build_ior(L->sc, &dm->ior_e, m->name, &m->crystal.ne, err))
        return -1;
    return 0;
}

static int uniaxial_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->kind = MATERIAL_DIELECTRIC;
    m->uniaxial = 1;
    if (crystal_inputs(L, dm, m, err))
        return -1;
    if (dm->has_sigma) {
        /* Constant coefficients replace the catalogue's table. */
        m->crystal.absorption = (crystal_absorption_t){
            .rows = 1, .lambda_nm = {550.0}, .o_per_mm = {dm->sigma_o}, .e_per_mm = {dm->sigma_e}};
    }
    m->ior = m->crystal.no;
    m->optic_axis =
        vec3_normalize(vec3_make(dm->optic_axis[0], dm->optic_axis[1], dm->optic_axis[2]));
    m->mm_per_unit = dm->mm_per_unit;
    return 0;
}

/* pbrt-v4 HairMaterial: the fibre's numbers and its absorption's source. Constant melanin
 * concentrations become one absorption spectrum, the uplift of pbrt-v4's RGB sum
 * (SigmaAFromConcentration); textured ones weigh each pigment's own spectrum per hit. */
static int hair_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if (!(m->hair.eta = loader_float_input(L, &dm->hair_eta, err)) ||
        !(m->hair.beta_m = loader_float_input(L, &dm->beta_m, err)) ||
        !(m->hair.beta_n = loader_float_input(L, &dm->beta_n, err)) ||
        !(m->hair.alpha = loader_float_input(L, &dm->hair_alpha, err)))
        return -1;
    if (dm->hair_from == SCENE_HAIR_SIGMA_A)
        return (m->hair.sigma_a = loader_spectrum_input(L, &dm->sigma_a, SPEC_UNBOUNDED, err)) ? 0
                                                                                               : -1;
    if (dm->hair_from == SCENE_HAIR_REFLECTANCE)
        return (m->hair.reflectance =
                    loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err))
                   ? 0
                   : -1;
    scene_spectrum_input_t in = {.texture = -1,
                                 .spectrum = {.kind = SCENE_SPECTRUM_RGB, .loc = dm->loc}};
    if (dm->eumelanin.texture < 0 && dm->pheomelanin.texture < 0) {
        hair_sigma_a_from_concentration(dm->eumelanin.value, dm->pheomelanin.value,
                                        in.spectrum.rgb);
        return (m->hair.sigma_a = loader_spectrum_input(L, &in, SPEC_UNBOUNDED, err)) ? 0 : -1;
    }
    if (!(m->hair.eumelanin = loader_float_input(L, &dm->eumelanin, err)) ||
        !(m->hair.pheomelanin = loader_float_input(L, &dm->pheomelanin, err)))
        return -1;
    hair_sigma_a_from_concentration(1.0, 0.0, in.spectrum.rgb);
    if (!(m->hair.eu_sigma = loader_spectrum_input(L, &in, SPEC_UNBOUNDED, err)))
        return -1;
    hair_sigma_a_from_concentration(0.0, 1.0, in.spectrum.rgb);
    return (m->hair.pheo_sigma = loader_spectrum_input(L, &in, SPEC_UNBOUNDED, err)) ? 0 : -1;
}

int load_materials_for_shape(loader_t *L, int idx, const transform_t *to_world, err_t *err)
{
    if (idx < 0 || (size_t)idx >= L->sc->nmaterials || !L->sc->materials[idx].uniaxial)
        return idx;
    material_t m = L->sc->materials[idx];
    const vec3_t a = vec3_normalize(transform_vector(to_world, m.optic_axis));
    if (a.x == m.optic_axis.x && a.y == m.optic_axis.y && a.z == m.optic_axis.z)
        return idx;
    m.optic_axis = a;
    return scene_add_material(L->sc, &m, err);
}

/* pbrt-v4's MeasuredMaterial: the .bsdf file, read once however many materials name it (as
 * pbrt-v4 does), its bytes bounded as any file a scene reads is. */
static int measured_input(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if ((m->measured = scene_find_measured(L->sc, dm->filename)))
        return 0;
    const pbrt_loc_t at = dm->filename_loc;
    uint8_t *bytes;
    size_t len;
    measured_t *md = NULL;
    if (files_read(dm->filename, PBRT_FILE_BYTES_MAX, &bytes, &len, err) == 0) {
        md = measured_new(bytes, len, dm->filename, err);
        free(bytes);
    }
    if (!md)
        return err_prefix(err, "%s:%d:%d: Material \"measured\": ", at.file, at.line, at.col);
    m->measured = md;
    return scene_own_measured(L->sc, md, dm->filename, err);
}

int load_materials(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    for (size_t i = 0; i < d->nmaterials; i++) {
        const scene_material_t *dm = &d->materials[i];
        material_t m = {0};
        if (dm->name) {
            snprintf(m.name, sizeof m.name, "%s", dm->name);
            m.named = 1;
        } else if (dm->loc.file && dm->loc.line > 0) {
            const char *base = strrchr(dm->loc.file, '/');
            snprintf(m.name, sizeof m.name, "%s:%d", base ? base + 1 : dm->loc.file, dm->loc.line);
        } else {
            snprintf(m.name, sizeof m.name, "(unnamed)");
        }
        m.remaproughness = dm->remaproughness;
        m.mix[0] = m.mix[1] = -1;
        const int has_roughness =
            dm->kind == MATERIAL_CONDUCTOR || dm->kind == MATERIAL_DIELECTRIC ||
            dm->kind == MATERIAL_COATED_DIFFUSE || dm->kind == MATERIAL_COATED_CONDUCTOR ||
            dm->kind == MATERIAL_SUBSURFACE;
        if (has_roughness && (roughness_input(L, &dm->uroughness, &m.uroughness, err) ||
                              roughness_input(L, &dm->vroughness, &m.vroughness, err)))
            return -1;
        if (dm->kind == MATERIAL_COATED_CONDUCTOR &&
            (roughness_input(L, &dm->base_uroughness, &m.base_uroughness, err) ||
             roughness_input(L, &dm->base_vroughness, &m.base_vroughness, err)))
            return -1;
        /* Uniaxial and subsurface set their own kind (material_kind.h). */
        m.kind = dm->kind;
        int rc = 0;
        switch (dm->kind) {
        case MATERIAL_DIFFUSE:
            rc = (m.reflectance = loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err))
                     ? 0
                     : -1;
            break;
        case MATERIAL_CONDUCTOR:
            rc = conductor_inputs(L, dm, &m, err);
            break;
        case MATERIAL_DIELECTRIC:
            rc = build_ior(L->sc, &dm->ior, m.name, &m.ior, err);
            break;
        case MATERIAL_THIN_DIELECTRIC:
            rc = build_ior(L->sc, &dm->ior, m.name, &m.ior, err);
            break;
        case MATERIAL_DIFFUSE_TRANSMISSION:
            m.scale = dm->scale;
            rc = (m.reflectance =
                      loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) &&
                         (m.transmittance =
                              loader_spectrum_input(L, &dm->transmittance, SPEC_REFLECTANCE, err))
                     ? 0
                     : -1;
            break;
        case MATERIAL_COATED_DIFFUSE:
            rc = (m.reflectance =
                      loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) &&
                         !build_ior(L->sc, &dm->ior, m.name, &m.ior, err) &&
                         !layer_inputs(L, dm, &m, err)
                     ? 0
                     : -1;
            break;
        case MATERIAL_COATED_CONDUCTOR:
            rc = conductor_inputs(L, dm, &m, err) ||
                         build_ior(L->sc, &dm->ior, m.name, &m.ior, err) ||
                         layer_inputs(L, dm, &m, err)
                     ? -1
                     : 0;
            break;
        case MATERIAL_MIX:
            m.mix[0] = dm->mix[0];
            m.mix[1] = dm->mix[1];
            rc = (m.amount = loader_float_input(L, &dm->amount, err)) ? 0 : -1;
            break;
        case MATERIAL_INTERFACE:
            break;
        case MATERIAL_UNIAXIAL:
            rc = uniaxial_inputs(L, dm, &m, err);
            break;
        case MATERIAL_HAIR:
            rc = hair_inputs(L, dm, &m, err);
            break;
        case MATERIAL_SUBSURFACE: /* scene/subsurface_load.h */
            rc = (m.sss.sigma_a = loader_spectrum_input(L, &dm->sigma_a, SPEC_UNBOUNDED, err)) &&
                         (m.sss.sigma_s =
                              loader_spectrum_input(L, &dm->sss_sigma_s, SPEC_UNBOUNDED, err)) &&
                         (m.sss.reflectance =
                              loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) &&
                         (m.sss.mfp = loader_spectrum_input(L, &dm->sss_mfp, SPEC_UNBOUNDED, err))
                     ? subsurface_load(L->sc, dm, &m, err)
                     : -1;
            break;
        case MATERIAL_POLARISER:
        case MATERIAL_RETARDER:
            m.sheet_angle = dm->sheet_angle * (PF_PI / 180.0);
            m.retardance = dm->retardance * (PF_PI / 180.0);
            m.retarder_mode = dm->kind == MATERIAL_RETARDER ? dm->retarder_mode : 0;
            m.retardation_nm = dm->retardation;
            m.plate_thickness_nm = dm->plate_thickness * 1000.0;
            m.plate_axial = dm->plate_axial;
            if (m.retarder_mode == RETARDER_PLATE)
                rc = crystal_inputs(L, dm, &m, err);
            break;
        case MATERIAL_MEASURED:
            rc = measured_input(L, dm, &m, err);
            break;
        }
        if (rc)
            return -1;
        /* A thin film on smooth glass or metal (the parser refuses one on a rough surface). */
        if (dm->film_thickness > 0.0 &&
            (dm->kind == MATERIAL_DIELECTRIC || dm->kind == MATERIAL_CONDUCTOR)) {
            m.film_thickness = dm->film_thickness;
            m.film_ior = ior_constant(dm->film_eta);
        }
        /* Smooth everywhere: constant roughness that pbrt-v4 calls effectively smooth. A
         * roughness texture may still be smooth at a hit; render decides there. */
        if ((m.kind == MATERIAL_CONDUCTOR || m.kind == MATERIAL_DIELECTRIC) &&
            dm->uroughness.texture < 0 && dm->vroughness.texture < 0) {
            microfacet_t mf =
                microfacet_make(dm->uroughness.value, dm->vroughness.value, dm->remaproughness);
            m.smooth = microfacet_smooth(&mf);
            m.rough = !m.smooth;
        }
        if (dm->normalmap && !(m.normalmap = load_textures_normal_map(L, dm, err)))
            return -1;
        if (!m.normalmap && dm->displacement.texture >= 0)
            m.displacement = L->tex[dm->displacement.texture];
        if (scene_add_material(L->sc, &m, err) < 0)
            return -1;
    }
    return 0;
}
