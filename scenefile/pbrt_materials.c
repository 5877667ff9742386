#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_materials.h"

#include "medium_presets.h"
#include "pbrt_inputs.h"
#include "pbrt_upgrade.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* pbrt-v4 materials.cpp: "<prefix>uroughness"/"<prefix>vroughness" override
 * "<prefix>roughness" (default 0); the prefix is "" or a layer's ("interface.",
 * "conductor."). */
static int get_roughness(parser_t *P, params_t *ps, scene_material_t *m, const char *prefix,
                         scene_float_input_t *uout, scene_float_input_t *vout)
{
    char un[48], vn[48], rn[48];
    snprintf(un, sizeof un, "%suroughness", prefix);
    snprintf(vn, sizeof vn, "%svroughness", prefix);
    snprintf(rn, sizeof rn, "%sroughness", prefix);
    param_t *u = params_find(ps, un), *v = params_find(ps, vn);
    scene_float_input_t r = {-1, 0.0};
    if ((!u || !v) && pbrt_inputs_float(P, ps, rn, 0.0, &r) != 0)
        return -1;
    *uout = r;
    *vout = r;
    if (u && pbrt_inputs_float(P, ps, un, 0.0, uout) != 0)
        return -1;
    if (v && pbrt_inputs_float(P, ps, vn, 0.0, vout) != 0)
        return -1;
    if ((uout->texture < 0 && !(uout->value >= 0.0)) ||
        (vout->texture < 0 && !(vout->value >= 0.0)))
        return pbrt_error(P->err, m->loc, "%sroughness must not be negative", prefix);
    return 0;
}

/* The index of refraction of a dielectric or of a coating's interface: "<prefix>eta" (pbrt-v4)
 * or prismfarm's "<prefix>glass", "<prefix>sellmeier", "<prefix>cauchy". */
static int get_ior(parser_t *P, params_t *ps, scene_material_t *m, const char *prefix)
{
    static const char *NAMES[] = {"eta", "glass", "sellmeier", "cauchy"};
    char names[COUNT_OF(NAMES)][48];
    for (size_t i = 0; i < COUNT_OF(NAMES); i++)
        snprintf(names[i], sizeof names[i], "%s%s", prefix, NAMES[i]);
    param_t *given = NULL;
    for (size_t i = 0; i < COUNT_OF(NAMES); i++) {
        param_t *p = params_find(ps, names[i]);
        if (!p)
            continue;
        if (given)
            return pbrt_error(P->err, p->loc,
                              "give only one of \"%s\", \"%s\", \"%s\" "
                              "and \"%s\" for %s (\"%s\" is already given)",
                              names[0], names[1], names[2], names[3], params_context(ps),
                              given->name);
        given = p;
    }
    scene_ior_t *ior = &m->ior;
    ior->loc = given ? given->loc : m->loc;
    if (!given) {
        ior->kind = SCENE_IOR_SPECTRUM;
        ior->spectrum = pbrt_inputs_constant(1.5, m->loc); /* pbrt-v4's default eta */
        return 0;
    }
    const char *kind = given->name + strlen(prefix);
    if (!strcmp(kind, "eta")) {
        if (given->type == PARAM_TEXTURE)
            return pbrt_error(P->err, given->loc,
                              "unsupported parameter \"texture %s\": the "
                              "index of refraction cannot be a texture",
                              given->name);
        if (given->type != PARAM_FLOAT && given->type != PARAM_SPECTRUM) {
            char expected[128];
            snprintf(expected, sizeof expected, "\"float %s\" or \"spectrum %s\"", given->name,
                     given->name);
            return params_wrong_type(ps, given, expected, P->err);
        }
        ior->kind = SCENE_IOR_SPECTRUM;
        if (pbrt_inputs_spectrum_param(P, ps, given, SPECTRUM_ANY, &ior->spectrum) != 0)
            return -1;
        if (ior->spectrum.kind == SCENE_SPECTRUM_CONSTANT && !(ior->spectrum.constant > 0.0))
            return pbrt_error(P->err, given->loc, "\"float %s\" must be greater than 0, got %g",
                              given->name, ior->spectrum.constant);
        if (ior->spectrum.kind == SCENE_SPECTRUM_SAMPLED)
            for (size_t i = 0; i < ior->spectrum.count; i++)
                if (!(ior->spectrum.value[i] > 0.0))
                    return pbrt_error(P->err, given->loc,
                                      "\"spectrum eta\": index %g in pair %zu "
                                      "is not positive",
                                      ior->spectrum.value[i], i + 1);
        return 0;
    }
    if (!strcmp(kind, "glass")) {
        const char *name;
        if (params_get_string(ps, given->name, NULL, &name, P->err) != 0)
            return -1;
        if (!*name)
            return pbrt_error(P->err, given->loc, "\"string %s\" is empty", given->name);
        ior->kind = SCENE_IOR_GLASS;
        ior->glass = scene_desc_strdup(P->scene, name, P->err);
        return ior->glass ? 0 : -1;
    }
    if (given->type != PARAM_FLOAT) {
        char expected[64];
        snprintf(expected, sizeof expected, "\"float %s\"", given->name);
        return params_wrong_type(ps, given, expected, P->err);
    }
    if (!strcmp(kind, "sellmeier")) {
        /* n^2 = 1 + sum B_i l^2 / (l^2 - C_i), l in um (docs/physics.md §3.3). */
        if (given->count < 2 || given->count % 2 != 0)
            return pbrt_error(P->err, given->loc,
                              "\"float sellmeier\" needs (B, C) pairs, got "
                              "%zu numbers",
                              given->count);
        double *c = scene_desc_alloc(P->scene, given->count * sizeof *c, P->err);
        if (!c)
            return -1;
        memcpy(c, given->numbers, given->count * sizeof *c);
        ior->kind = SCENE_IOR_SELLMEIER;
        ior->nterms = given->count / 2;
        ior->sellmeier = c;
        return 0;
    }
    /* cauchy: n = A + B / l^2, l in um */
    if (given->count != 2)
        return pbrt_error(P->err, given->loc,
                          "expected 2 numbers after \"float cauchy\" (A B), "
                          "got %zu",
                          given->count);
    if (!(given->numbers[0] > 0.0))
        return pbrt_error(P->err, given->loc, "\"float cauchy\": A must be greater than 0, got %g",
                          given->numbers[0]);
    ior->kind = SCENE_IOR_CAUCHY;
    ior->cauchy[0] = given->numbers[0];
    ior->cauchy[1] = given->numbers[1];
    return 0;
}

/* A conductor's complex index or reflectance, as pbrt-v4's ConductorMaterial reads them
 * ("eta", "k", "reflectance") and CoatedConductorMaterial ("conductor.eta", "conductor.k",
 * "reflectance"). */
static int get_conductor(parser_t *P, params_t *ps, scene_material_t *m, const char *prefix)
{
    char en[48], kn[48];
    snprintf(en, sizeof en, "%seta", prefix);
    snprintf(kn, sizeof kn, "%sk", prefix);
    param_t *r = params_find(ps, "reflectance");
    if (r && (params_find(ps, en) || params_find(ps, kn)))
        return pbrt_error(P->err, r->loc,
                          "%s: give either \"reflectance\" or \"%s\" and \"%s\", not both",
                          params_context(ps), en, kn);
    m->use_reflectance = r != NULL;
    return pbrt_inputs_spectrum_input(P, ps, "reflectance", pbrt_inputs_constant(1.0, m->loc),
                                      SPECTRUM_ALBEDO, &m->reflectance) ||
                   pbrt_inputs_spectrum_input(P, ps, en, pbrt_inputs_named("metal-Cu-eta", m->loc),
                                              SPECTRUM_ANY, &m->eta) ||
                   pbrt_inputs_spectrum_input(P, ps, kn, pbrt_inputs_named("metal-Cu-k", m->loc),
                                              SPECTRUM_ANY, &m->k)
               ? -1
               : 0;
}

/* The medium of pbrt-v4's layered materials (coateddiffuse, coatedconductor). */
static int get_layer(parser_t *P, params_t *ps, scene_material_t *m)
{
    if (pbrt_inputs_float(P, ps, "thickness", 0.01, &m->thickness) != 0 ||
        pbrt_inputs_float(P, ps, "g", 0.0, &m->g) != 0 ||
        pbrt_inputs_spectrum_input(P, ps, "albedo", pbrt_inputs_constant(0.0, m->loc),
                                   SPECTRUM_ALBEDO, &m->albedo) != 0 ||
        params_get_int(ps, "maxdepth", 10, &m->maxdepth, P->err) != 0 ||
        params_get_int(ps, "nsamples", 1, &m->nsamples, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "maxdepth", m->maxdepth, 1, 1000) != 0 ||
        pbrt_state_check_range(P, ps, "nsamples", m->nsamples, 1, 1000) != 0)
        return -1;
    if (m->thickness.texture < 0 && !(m->thickness.value > 0.0))
        return pbrt_state_check_positive(P, ps, "thickness", m->thickness.value);
    if (m->g.texture < 0 && !(m->g.value > -1.0 && m->g.value < 1.0))
        return pbrt_state_check_range(P, ps, "g", m->g.value, -0.999, 0.999);
    return 0;
}

static int get_mix(parser_t *P, params_t *ps, scene_material_t *m)
{
    param_t *p = params_find(ps, "materials");
    if (!p)
        return pbrt_error(P->err, m->loc,
                          "mix: \"string materials\" (two named materials) is missing");
    if (p->type != PARAM_STRING)
        return params_wrong_type(ps, p, "\"string materials\"", P->err);
    if (p->count != 2)
        return pbrt_error(P->err, p->loc,
                          "expected 2 material names after \"string materials\", got %zu",
                          p->count);
    for (int i = 0; i < 2; i++) {
        m->mix[i] = scene_desc_find_material(P->scene, p->strings[i]);
        if (m->mix[i] < 0)
            return pbrt_error(P->err, p->loc,
                              "mix: named material \"%s\" is not defined (a MakeNamedMaterial must "
                              "come before the mix that uses it)",
                              p->strings[i]);
    }
    return pbrt_inputs_float(P, ps, "amount", 0.5, &m->amount);
}

/* A thin film on glass or metal (scene_material_t.film_thickness), smooth (bsdf/delta) or
 * rough (the Airy reflectance at each microfacet, bsdf/lobe). */
static int get_film(parser_t *P, params_t *ps, scene_material_t *m)
{
    if (params_get_float(ps, "filmthickness", 0.0, &m->film_thickness, P->err) != 0 ||
        params_get_float(ps, "filmeta", 1.33, &m->film_eta, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "filmthickness", m->film_thickness, 0.0, 1e5) != 0 ||
        pbrt_state_check_range(P, ps, "filmeta", m->film_eta, 1.0, 5.0) != 0)
        return -1;
    return 0;
}

/* A uniaxial crystal (scene_material_t.crystal ...): a catalogue crystal, or both indices
 * given with the "o." and "e." prefixes of get_ior (which override the catalogue's), the optic
 * axis and the absorption. The catalogue name is checked by the loader, which owns it. */
static const char *CRYSTAL_IOR_KINDS[] = {"eta", "glass", "sellmeier", "cauchy"};

/* Whether the parameters name a crystal or an "o." or "e." index (a retarder's plate mode). */
static bool names_crystal(params_t *ps)
{
    if (params_find(ps, "crystal"))
        return true;
    for (size_t i = 0; i < 2 * COUNT_OF(CRYSTAL_IOR_KINDS); i++) {
        char name[16];
        snprintf(name, sizeof name, "%s%s", i % 2 ? "e." : "o.", CRYSTAL_IOR_KINDS[i / 2]);
        if (params_find(ps, name))
            return true;
    }
    return false;
}

/* A crystal's principal indices: "string crystal" from the catalogue, or both indices with
 * the "o." and "e." prefixes of get_ior (which override the catalogue's). what names the
 * material in the error. */
static int get_crystal_indices(parser_t *P, params_t *ps, scene_material_t *m, const char *what)
{
    const char *pre[2] = {"o.", "e."};
    bool *has[2] = {&m->has_o, &m->has_e};
    scene_ior_t *out[2] = {&m->ior_o, &m->ior_e};
    if (params_get_string(ps, "crystal", NULL, &m->crystal, P->err) != 0)
        return -1;
    if (m->crystal && !(m->crystal = scene_desc_strdup(P->scene, m->crystal, P->err)))
        return -1;
    for (int w = 0; w < 2; w++) {
        for (size_t i = 0; i < COUNT_OF(CRYSTAL_IOR_KINDS); i++) {
            char name[16];
            snprintf(name, sizeof name, "%s%s", pre[w], CRYSTAL_IOR_KINDS[i]);
            *has[w] |= params_find(ps, name) != NULL;
        }
        if (!*has[w] && !m->crystal)
            return pbrt_error(P->err, m->loc,
                              "Material \"%s\" needs \"string crystal\" or both indices "
                              "(\"float o.eta\", \"float e.eta\" or their glass, sellmeier, "
                              "cauchy forms)",
                              what);
        if (*has[w] && get_ior(P, ps, m, pre[w]) != 0)
            return -1;
        *out[w] = m->ior;
    }
    return 0;
}

static int get_uniaxial(parser_t *P, params_t *ps, scene_material_t *m)
{
    if (get_crystal_indices(P, ps, m, "uniaxial") != 0)
        return -1;
    param_t *axis;
    if (params_get_array(ps, "opticaxis", PARAM_VECTOR3, &axis, P->err) != 0)
        return -1;
    m->optic_axis[0] = m->optic_axis[1] = 0.0;
    m->optic_axis[2] = 1.0;
    if (axis) {
        if (axis->count != 3)
            return pbrt_error(P->err, axis->loc,
                              "expected 3 numbers after \"vector3 opticaxis\", got %zu",
                              axis->count);
        const double *a = axis->numbers;
        if (!(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] > 0.0) || !isfinite(a[0] + a[1] + a[2]))
            return pbrt_error(P->err, axis->loc,
                              "\"vector3 opticaxis\" must be a finite non-zero vector");
        memcpy(m->optic_axis, a, sizeof m->optic_axis);
    }
    m->has_sigma = params_find(ps, "sigma_o") || params_find(ps, "sigma_e");
    return params_get_float(ps, "sigma_o", 0.0, &m->sigma_o, P->err) ||
                   params_get_float(ps, "sigma_e", 0.0, &m->sigma_e, P->err) ||
                   params_get_float(ps, "mmperunit", 1.0, &m->mm_per_unit, P->err) ||
                   params_get_bool(ps, "coherent", false, &m->coherent, P->err) ||
                   pbrt_state_check_range(P, ps, "sigma_o", m->sigma_o, 0.0, 1e6) ||
                   pbrt_state_check_range(P, ps, "sigma_e", m->sigma_e, 0.0, 1e6) ||
                   pbrt_state_check_range(P, ps, "mmperunit", m->mm_per_unit, 1e-12, 1e12)
               ? -1
               : 0;
}

/* pbrt-v4's MeasuredMaterial: "string filename", an RGL .bsdf file, found, confined and listed
 * like every file a scene names (so a bundle carries it); the loader reads it. */
static int get_measured(parser_t *P, params_t *ps, scene_material_t *m)
{
    const char *filename;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0)
        return -1;
    if (!filename || !*filename)
        return pbrt_error(P->err, m->loc,
                          "Material \"measured\" needs \"string filename\" (an RGL .bsdf file)");
    const param_t *fp = params_find(ps, "filename");
    m->filename_loc = fp->loc;
    return pbrt_inputs_data_file(P, fp, filename, "measured BSDF", SCENE_FILE_BSDF, &m->filename);
}

/* pbrt-v4 HairMaterial::Create: the absorption from "sigma_a", else from "reflectance" (or its
 * older name "color"), else from the melanin concentrations, brown hair (eumelanin 1.3) when
 * none is given; what the first given one overrides is ignored with a warning, as in pbrt-v4. */
static int get_hair(parser_t *P, params_t *ps, scene_material_t *m)
{
    param_t *sa = params_find(ps, "sigma_a"), *refl = params_find(ps, "reflectance");
    if (!refl)
        refl = params_find(ps, "color");
    param_t *eu = params_find(ps, "eumelanin"), *ph = params_find(ps, "pheomelanin");
    m->hair_from = sa ? SCENE_HAIR_SIGMA_A : refl ? SCENE_HAIR_REFLECTANCE : SCENE_HAIR_MELANIN;
    const param_t *given = sa ? sa : refl ? refl : NULL;
    const param_t *other[3] = {refl, eu, ph};
    for (int i = sa ? 0 : 1; given && i < 3; i++)
        if (other[i] && warnings_add(P->scene->warnings, other[i]->loc,
                                     "Material \"hair\": \"%s\" is ignored since \"%s\" is given",
                                     other[i]->name, given->name))
            return pbrt_error(P->err, other[i]->loc, "out of memory");
    const bool melanin = eu || ph;
    if (pbrt_inputs_float(P, ps, "eta", 1.55, &m->hair_eta) != 0)
        return -1;
    if (m->hair_eta.texture < 0 && !(m->hair_eta.value > 0.0))
        return pbrt_state_check_positive(P, ps, "eta", m->hair_eta.value);
    return pbrt_inputs_spectrum_input(P, ps, "sigma_a", pbrt_inputs_constant(0.0, m->loc),
                                      SPECTRUM_ANY, &m->sigma_a) ||
                   pbrt_inputs_spectrum_input(P, ps, refl ? refl->name : "reflectance",
                                              pbrt_inputs_constant(0.5, m->loc), SPECTRUM_ALBEDO,
                                              &m->reflectance) ||
                   pbrt_inputs_float(P, ps, "eumelanin", melanin ? 0.0 : 1.3, &m->eumelanin) ||
                   pbrt_inputs_float(P, ps, "pheomelanin", 0.0, &m->pheomelanin) ||
                   pbrt_inputs_float(P, ps, "beta_m", 0.3, &m->beta_m) ||
                   pbrt_inputs_float(P, ps, "beta_n", 0.3, &m->beta_n) ||
                   pbrt_inputs_float(P, ps, "alpha", 2.0, &m->hair_alpha)
               ? -1
               : 0;
}

/* pbrt-v4 SubsurfaceMaterial::Create: the medium's coefficients one of four mutually exclusive
 * ways (a named measured medium; "sigma_a" with "sigma_s"; "reflectance" with "mfp"; else
 * pbrt-v4's defaults, RGB (.0011, .0024, .014) and (2.55, 3.21, 3.77) per mm), then "scale",
 * "eta", "g" and the roughness of the dielectric boundary. */
static int get_subsurface(parser_t *P, params_t *ps, scene_material_t *m)
{
    const char *name = NULL;
    if (params_get_string(ps, "name", NULL, &name, P->err) != 0 ||
        params_get_float(ps, "g", 0.0, &m->sss_g, P->err) != 0 ||
        params_get_float(ps, "eta", 1.33, &m->sss_eta, P->err) != 0 ||
        params_get_float(ps, "scale", 1.0, &m->scale, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "scale", m->scale, 0.0, INFINITY) != 0 ||
        get_roughness(P, ps, m, "", &m->uroughness, &m->vroughness) != 0 ||
        params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err) != 0)
        return -1;
    /* The Fresnel moments' polynomial fits (bsdf/bssrdf.h) hold over this range; pbrt-v4 takes
     * any index and goes wrong outside it. */
    if (!(m->sss_eta >= 0.5 && m->sss_eta <= 3.0))
        return pbrt_state_check_range(P, ps, "eta", m->sss_eta, 0.5, 3.0);
    if (!(m->sss_g > -1.0 && m->sss_g < 1.0))
        return pbrt_state_check_range(P, ps, "g", m->sss_g, -0.999, 0.999);
    m->sigma_a.texture = m->sss_sigma_s.texture = m->sss_mfp.texture = -1;
    m->sss_mfp.spectrum = pbrt_inputs_constant(1.0, m->loc);
    if (name && *name) {
        const param_t *np = params_find(ps, "name");
        double ss[3], sa[3];
        if (!medium_preset_find(name, ss, sa))
            return pbrt_error(P->err, np->loc,
                              "Material \"subsurface\": named medium \"%s\" is not in pbrt-v4's "
                              "table of measured media (e.g. \"Skin1\", \"Ketchup\", \"Apple\", "
                              "\"Wholemilk\"; docs/scene-format.md lists them)",
                              name);
        const param_t *gp = params_find(ps, "g");
        if (m->sss_g != 0.0 &&
            warnings_add(P->scene->warnings, gp->loc,
                         "Material \"subsurface\": \"g\" is ignored with a named medium (its "
                         "coefficients are reduced ones, so g is 0), as in pbrt-v4"))
            return pbrt_error(P->err, gp->loc, "out of memory");
        m->sss_g = 0.0;
        m->sigma_a.spectrum = (scene_spectrum_t){
            .kind = SCENE_SPECTRUM_RGB, .rgb = {sa[0], sa[1], sa[2]}, .loc = np->loc};
        m->sss_sigma_s.spectrum = (scene_spectrum_t){
            .kind = SCENE_SPECTRUM_RGB, .rgb = {ss[0], ss[1], ss[2]}, .loc = np->loc};
        return 0;
    }
    const param_t *pa = params_find(ps, "sigma_a"), *pss = params_find(ps, "sigma_s");
    if ((pa != NULL) != (pss != NULL))
        return pbrt_error(P->err, (pa ? pa : pss)->loc,
                          "Material \"subsurface\": \"%s\" is given without \"%s\"",
                          pa ? "sigma_a" : "sigma_s", pa ? "sigma_s" : "sigma_a");
    if (pa)
        return pbrt_inputs_spectrum_input(P, ps, "sigma_a", pbrt_inputs_constant(0.0, m->loc),
                                          SPECTRUM_ANY, &m->sigma_a) ||
                       pbrt_inputs_spectrum_input(P, ps, "sigma_s",
                                                  pbrt_inputs_constant(0.0, m->loc), SPECTRUM_ANY,
                                                  &m->sss_sigma_s)
                   ? -1
                   : 0;
    if (params_find(ps, "reflectance")) {
        m->sss_from_reflectance = true;
        return pbrt_inputs_spectrum_input(P, ps, "reflectance", pbrt_inputs_constant(0.5, m->loc),
                                          SPECTRUM_ALBEDO, &m->reflectance) ||
                       pbrt_inputs_spectrum_input(P, ps, "mfp", pbrt_inputs_constant(1.0, m->loc),
                                                  SPECTRUM_ANY, &m->sss_mfp)
                   ? -1
                   : 0;
    }
    m->sigma_a.spectrum =
        (scene_spectrum_t){.kind = SCENE_SPECTRUM_RGB, .rgb = {.0011, .0024, .014}, .loc = m->loc};
    m->sss_sigma_s.spectrum =
        (scene_spectrum_t){.kind = SCENE_SPECTRUM_RGB, .rgb = {2.55, 3.21, 3.77}, .loc = m->loc};
    return 0;
}

/* A retarder's retardation, one of three ways (docs/physics.md §14.1): "float retardance" in
 * degrees, the same at every wavelength (90 by default); "float retardation" Gamma in nm, the
 * optical path difference of a dispersion-free plate (delta = 2 pi Gamma / lambda, as the
 * Michel-Levy chart assumes); or a crystal plate, "string crystal" or "o."/"e." indices with
 * "float thickness" in micrometres, whose retardance follows the indices' dispersion and the
 * angle of incidence (polar/waveplate.h). */
static int get_retarder(parser_t *P, params_t *ps, scene_material_t *m)
{
    const bool deg = params_find(ps, "retardance") != NULL;
    const bool nm = params_find(ps, "retardation") != NULL;
    const bool plate = names_crystal(ps);
    if (deg + nm + plate > 1)
        return pbrt_error(P->err, m->loc,
                          "Material \"retarder\": give one of \"float retardance\" (degrees), "
                          "\"float retardation\" (nm) or a crystal plate (\"string crystal\" or "
                          "indices, with \"float thickness\" in micrometres)");
    if (params_get_float(ps, "retardance", 90.0, &m->retardance, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "retardance", m->retardance, 0.0, 360.0) != 0 ||
        params_get_float(ps, "retardation", 0.0, &m->retardation, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "retardation", m->retardation, -1e6, 1e6) != 0 ||
        params_get_float(ps, "thickness", 0.0, &m->plate_thickness, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "thickness", m->plate_thickness, 0.0, 1e5) != 0)
        return -1;
    m->retarder_mode = nm ? 1 : plate ? 2 : 0;
    if (!plate) {
        if (params_find(ps, "thickness"))
            return pbrt_error(P->err, params_find(ps, "thickness")->loc,
                              "Material \"retarder\": \"float thickness\" needs a crystal "
                              "(\"string crystal\" or \"o.\" and \"e.\" indices)");
        return 0;
    }
    if (get_crystal_indices(P, ps, m, "retarder") != 0 ||
        params_get_bool(ps, "axial", false, &m->plate_axial, P->err) != 0)
        return -1;
    if (!params_find(ps, "thickness"))
        return pbrt_error(P->err, m->loc,
                          "Material \"retarder\" with a crystal needs \"float thickness\" (in "
                          "micrometres)");
    return 0;
}

static int build_material(parser_t *P, params_t *ps, const char *type, pbrt_loc_t type_loc,
                          scene_material_t *m)
{
    int t;
    size_t nnames;
    const pbrt_name_t *names = material_kind_names(&nnames);
    const char *v4 = pbrt_upgrade_v3_material(type);
    if (v4)
        return pbrt_error(P->err, type_loc, "pbrt-v3's material \"%s\" (pbrt-v4's \"%s\"): %s",
                          type, v4, PBRT_UPGRADE_HINT);
    if (pbrt_state_lookup(P, "unsupported material", type, type_loc, names, nnames, &t) != 0)
        return -1;
    m->kind = (material_kind_t)t;
    if (m->kind == MATERIAL_DIFFUSE) {
        return pbrt_inputs_spectrum_input(P, ps, "reflectance", pbrt_inputs_constant(0.5, m->loc),
                                          SPECTRUM_ALBEDO, &m->reflectance);
    }
    if (m->kind == MATERIAL_CONDUCTOR) {
        return get_conductor(P, ps, m, "") ||
                       get_roughness(P, ps, m, "", &m->uroughness, &m->vroughness) ||
                       params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err) ||
                       get_film(P, ps, m)
                   ? -1
                   : 0;
    }
    if (m->kind == MATERIAL_DIELECTRIC) {
        return get_ior(P, ps, m, "") ||
                       get_roughness(P, ps, m, "", &m->uroughness, &m->vroughness) ||
                       params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err) ||
                       get_film(P, ps, m)
                   ? -1
                   : 0;
    }
    if (m->kind == MATERIAL_THIN_DIELECTRIC) {
        return get_ior(P, ps, m, "");
    }
    if (m->kind == MATERIAL_DIFFUSE_TRANSMISSION) {
        if (pbrt_inputs_spectrum_input(P, ps, "reflectance", pbrt_inputs_constant(0.25, m->loc),
                                       SPECTRUM_ALBEDO, &m->reflectance) != 0 ||
            pbrt_inputs_spectrum_input(P, ps, "transmittance", pbrt_inputs_constant(0.25, m->loc),
                                       SPECTRUM_ALBEDO, &m->transmittance) != 0 ||
            params_get_float(ps, "scale", 1.0, &m->scale, P->err) != 0)
            return -1;
        return m->scale >= 0.0 ? 0 : pbrt_state_check_range(P, ps, "scale", m->scale, 0.0, 1.0);
    }
    if (m->kind == MATERIAL_COATED_DIFFUSE) {
        return pbrt_inputs_spectrum_input(P, ps, "reflectance", pbrt_inputs_constant(0.5, m->loc),
                                          SPECTRUM_ALBEDO, &m->reflectance) ||
                       get_ior(P, ps, m, "") ||
                       get_roughness(P, ps, m, "", &m->uroughness, &m->vroughness) ||
                       params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err) ||
                       get_layer(P, ps, m)
                   ? -1
                   : 0;
    }
    if (m->kind == MATERIAL_COATED_CONDUCTOR) {
        return get_conductor(P, ps, m, "conductor.") || get_ior(P, ps, m, "interface.") ||
                       get_roughness(P, ps, m, "interface.", &m->uroughness, &m->vroughness) ||
                       get_roughness(P, ps, m, "conductor.", &m->base_uroughness,
                                     &m->base_vroughness) ||
                       params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err) ||
                       get_layer(P, ps, m)
                   ? -1
                   : 0;
    }
    if (m->kind == MATERIAL_MIX) {
        return get_mix(P, ps, m);
    }
    if (m->kind == MATERIAL_UNIAXIAL) {
        return get_uniaxial(P, ps, m);
    }
    if (m->kind == MATERIAL_MEASURED) {
        return get_measured(P, ps, m);
    }
    if (m->kind == MATERIAL_HAIR) {
        return get_hair(P, ps, m);
    }
    if (m->kind == MATERIAL_SUBSURFACE) {
        return get_subsurface(P, ps, m);
    }
    if (m->kind == MATERIAL_POLARISER || m->kind == MATERIAL_RETARDER) {
        /* Thin polarising sheets (docs/physics.md §14): the axis angle in degrees, and a
         * retarder's retardance in degrees (90 a quarter wave, 180 a half wave). */
        if (params_get_float(ps, "angle", 0.0, &m->sheet_angle, P->err) != 0 ||
            pbrt_state_check_range(P, ps, "angle", m->sheet_angle, -360.0, 360.0) != 0)
            return -1;
        if (m->kind == MATERIAL_POLARISER)
            return 0;
        return get_retarder(P, ps, m);
    }
    return 0; /* interface */
}

/* pbrt-v4's "displacement" and "normalmap" of every material but mix and interface. */
static int surface_maps(parser_t *P, params_t *ps, scene_material_t *m)
{
    if (m->kind == MATERIAL_MIX || m->kind == MATERIAL_INTERFACE)
        return 0;
    const char *normalmap;
    if (pbrt_inputs_float(P, ps, "displacement", 0.0, &m->displacement) != 0 ||
        params_get_string(ps, "normalmap", NULL, &normalmap, P->err) != 0)
        return -1;
    if (!normalmap)
        return 0;
    param_t *fp = params_find(ps, "normalmap");
    m->normalmap_loc = fp->loc;
    return pbrt_inputs_image_file(P, fp, normalmap, &m->normalmap);
}

int pbrt_materials_read(parser_t *P, params_t *ps, const str_arg_t *type, const char *name,
                        pbrt_loc_t loc, pbrt_loc_t type_loc)
{
    int idx = scene_desc_add_material(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_material_t *m = &P->scene->materials[idx];
    m->loc = loc;
    m->reflectance.texture = m->eta.texture = m->k.texture = -1;
    m->uroughness.texture = m->vroughness.texture = -1;
    m->base_uroughness.texture = m->base_vroughness.texture = -1;
    m->transmittance.texture = m->albedo.texture = -1;
    m->thickness.texture = m->g.texture = m->amount.texture = -1;
    m->mix[0] = m->mix[1] = -1;
    m->remaproughness = true;
    if (name) {
        m->name = scene_desc_strdup(P->scene, name, P->err);
        if (!m->name)
            return -1;
    }
    m->displacement.texture = -1;
    if (build_material(P, ps, type->s, type_loc, m) != 0 || surface_maps(P, ps, m) != 0)
        return -1;
    if (!name)
        P->gs.material = idx;
    return 0;
}

/* MakeNamedMaterial "name" "string type" ...: a material defined once, by name. */
int pbrt_materials_read_named(parser_t *P, params_t *ps, const str_arg_t *name, pbrt_loc_t loc)
{
    int prev = scene_desc_find_material(P->scene, name->s);
    if (prev >= 0)
        return pbrt_error(P->err, name->loc, "named material \"%s\" is already defined (line %d)",
                          name->s, P->scene->materials[prev].loc.line);
    const char *mtype;
    if (params_get_string(ps, "type", NULL, &mtype, P->err) != 0)
        return -1;
    if (!mtype)
        return pbrt_error(P->err, loc, "MakeNamedMaterial \"%s\" needs \"string type\"", name->s);
    str_arg_t mt;
    snprintf(mt.s, sizeof mt.s, "%s", mtype);
    mt.loc = params_find(ps, "type")->loc;
    return pbrt_materials_read(P, ps, &mt, name->s, loc, mt.loc);
}
