/* pbrt-v4's HairMaterial: a hair fibre (bsdf/hair.h), its absorption from "sigma_a", else
 * "reflectance", else the melanin concentrations. */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

#include "hair.h"

#include <math.h>

/* pbrt-v4 HairMaterial: the fibre's numbers and its absorption's source. Constant melanin
 * concentrations become one absorption spectrum, the uplift of pbrt-v4's RGB sum
 * (SigmaAFromConcentration); textured ones weigh each pigment's own spectrum per hit. */
static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
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

/* pbrt-v4 HairMaterial::GetBxDF: the roughnesses clamped to [0.01, 1], the offset across the
 * fibre h = -1 + 2 v (a curve's v runs across its width), each lane's absorption >= 0. */
static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    b->kind = BSDF_HAIR;
    b->hair_h = fmin(1.0, fmax(-1.0, -1.0 + 2.0 * sf->v));
    b->hair_eta = material_inputs_texture(m->hair.eta, sf, 550.0);
    b->hair_eta = b->hair_eta > 0.0 ? b->hair_eta : 1.55;
    b->hair_beta_m = fmin(1.0, fmax(0.01, material_inputs_texture(m->hair.beta_m, sf, 550.0)));
    b->hair_beta_n = fmin(1.0, fmax(0.01, material_inputs_texture(m->hair.beta_n, sf, 550.0)));
    b->hair_alpha = material_inputs_texture(m->hair.alpha, sf, 550.0);
    double ce = 0.0, cp = 0.0;
    if (!m->hair.sigma_a && !m->hair.reflectance) {
        ce = fmax(0.0, material_inputs_texture(m->hair.eumelanin, sf, 550.0));
        cp = fmax(0.0, material_inputs_texture(m->hair.pheomelanin, sf, 550.0));
    }
    for (int j = 0; j < n; j++) {
        double sa;
        if (m->hair.sigma_a)
            sa = material_inputs_texture(m->hair.sigma_a, sf, lambda[j]);
        else if (m->hair.reflectance)
            sa = hair_sigma_a_from_reflectance(material_inputs_clamp01(material_inputs_texture(
                                                   m->hair.reflectance, sf, lambda[j])),
                                               b->hair_beta_n);
        else
            sa = ce * material_inputs_texture(m->hair.eu_sigma, sf, lambda[j]) +
                 cp * material_inputs_texture(m->hair.pheo_sigma, sf, lambda[j]);
        b->sigma_a[j] = isfinite(sa) && sa > 0.0 ? sa : 0.0;
    }
}

const material_class_t material_hair = {.load = load, .bsdf = bsdf};
