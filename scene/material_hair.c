/* pbrt-v4's HairMaterial: a hair fibre (bsdf/hair.h), its absorption from "sigma_a", else
 * "reflectance", else the melanin concentrations. */
#include "material_hair.h"
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

#include "pbrt_parser.h"

#include "hair.h"

#include <math.h>

/* pbrt-v4 HairMaterial::Create: the absorption from "sigma_a", else from "reflectance" (or its
 * older name "color"), else from the melanin concentrations, brown hair (eumelanin 1.3) when
 * none is given; what the first given one overrides is ignored with a warning, as in pbrt-v4.
 * Constant melanin concentrations become one absorption spectrum, the uplift of pbrt-v4's RGB
 * sum (SigmaAFromConcentration); textured ones weigh each pigment's own spectrum per hit. */
static int load(material_params_t *mp, material_t *m)
{
    (void)m;
    material_hair_t *hair = mp->data;
    params_t *ps = mp->ps;
    const pbrt_loc_t loc = mp->dm->loc;
    param_t *sa = params_find(ps, "sigma_a"), *refl = params_find(ps, "reflectance");
    if (!refl)
        refl = params_find(ps, "color");
    param_t *eu = params_find(ps, "eumelanin"), *ph = params_find(ps, "pheomelanin");
    const param_t *given = sa ? sa : refl ? refl : NULL;
    const param_t *other[3] = {refl, eu, ph};
    for (int i = sa ? 0 : 1; given && i < 3; i++)
        if (other[i] && warnings_add(mp->L->sc->warnings, other[i]->loc,
                                     "Material \"hair\": \"%s\" is ignored since \"%s\" is given",
                                     other[i]->name, given->name))
            return pbrt_error(mp->err, other[i]->loc, "out of memory");
    const bool melanin = eu || ph;
    scene_float_input_t eta;
    if (material_params_float(mp, "eta", 1.55, &eta) != 0)
        return -1;
    if (eta.texture < 0 && !(eta.value > 0.0))
        return material_params_positive(mp, "eta", eta.value);
    scene_spectrum_input_t sigma_a, reflectance;
    scene_float_input_t ce, cp;
    if (material_params_spectrum_input(mp, "sigma_a", material_params_constant(0.0, loc),
                                       SPEC_UNBOUNDED, &sigma_a) ||
        material_params_spectrum_input(mp, refl ? refl->name : "reflectance",
                                       material_params_constant(0.5, loc), SPEC_REFLECTANCE,
                                       &reflectance) ||
        material_params_float(mp, "eumelanin", melanin ? 0.0 : 1.3, &ce) ||
        material_params_float(mp, "pheomelanin", 0.0, &cp) ||
        !(hair->eta = loader_float_input(mp->L, &eta, mp->err)) ||
        !(hair->beta_m = material_params_float_texture(mp, "beta_m", 0.3)) ||
        !(hair->beta_n = material_params_float_texture(mp, "beta_n", 0.3)) ||
        !(hair->alpha = material_params_float_texture(mp, "alpha", 2.0)))
        return -1;
    loader_t *L = mp->L;
    err_t *err = mp->err;
    if (sa)
        return (hair->sigma_a = loader_spectrum_input(L, &sigma_a, SPEC_UNBOUNDED, err)) ? 0 : -1;
    if (refl)
        return (hair->reflectance = loader_spectrum_input(L, &reflectance, SPEC_REFLECTANCE, err))
                   ? 0
                   : -1;
    scene_spectrum_input_t in = {.texture = -1,
                                 .spectrum = {.kind = SCENE_SPECTRUM_RGB, .loc = loc}};
    if (ce.texture < 0 && cp.texture < 0) {
        hair_sigma_a_from_concentration(ce.value, cp.value, in.spectrum.rgb);
        return (hair->sigma_a = loader_spectrum_input(L, &in, SPEC_UNBOUNDED, err)) ? 0 : -1;
    }
    if (!(hair->eumelanin = loader_float_input(L, &ce, err)) ||
        !(hair->pheomelanin = loader_float_input(L, &cp, err)))
        return -1;
    hair_sigma_a_from_concentration(1.0, 0.0, in.spectrum.rgb);
    if (!(hair->eu_sigma = loader_spectrum_input(L, &in, SPEC_UNBOUNDED, err)))
        return -1;
    hair_sigma_a_from_concentration(0.0, 1.0, in.spectrum.rgb);
    return (hair->pheo_sigma = loader_spectrum_input(L, &in, SPEC_UNBOUNDED, err)) ? 0 : -1;
}

/* pbrt-v4 HairMaterial::GetBxDF: the roughnesses clamped to [0.01, 1], the offset across the
 * fibre h = -1 + 2 v (a curve's v runs across its width), each lane's absorption >= 0. */
static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    static const material_hair_t NO_HAIR = {0}; /* a hair built in code without a record */
    const material_hair_t *hair = material_hair_of(m) ? material_hair_of(m) : &NO_HAIR;
    b->kind = BSDF_HAIR;
    b->hair_h = fmin(1.0, fmax(-1.0, -1.0 + 2.0 * sf->v));
    b->hair_eta = material_inputs_texture(hair->eta, sf, 550.0);
    b->hair_eta = b->hair_eta > 0.0 ? b->hair_eta : 1.55;
    b->hair_beta_m = fmin(1.0, fmax(0.01, material_inputs_texture(hair->beta_m, sf, 550.0)));
    b->hair_beta_n = fmin(1.0, fmax(0.01, material_inputs_texture(hair->beta_n, sf, 550.0)));
    b->hair_alpha = material_inputs_texture(hair->alpha, sf, 550.0);
    double ce = 0.0, cp = 0.0;
    if (!hair->sigma_a && !hair->reflectance) {
        ce = fmax(0.0, material_inputs_texture(hair->eumelanin, sf, 550.0));
        cp = fmax(0.0, material_inputs_texture(hair->pheomelanin, sf, 550.0));
    }
    for (int j = 0; j < n; j++) {
        double sa;
        if (hair->sigma_a)
            sa = material_inputs_texture(hair->sigma_a, sf, lambda[j]);
        else if (hair->reflectance)
            sa = hair_sigma_a_from_reflectance(
                material_inputs_clamp01(material_inputs_texture(hair->reflectance, sf, lambda[j])),
                b->hair_beta_n);
        else
            sa = ce * material_inputs_texture(hair->eu_sigma, sf, lambda[j]) +
                 cp * material_inputs_texture(hair->pheo_sigma, sf, lambda[j]);
        b->sigma_a[j] = isfinite(sa) && sa > 0.0 ? sa : 0.0;
    }
}

const material_class_t material_hair = {
    .name = "hair", .data_size = sizeof(material_hair_t), .load = load, .bsdf = bsdf};
