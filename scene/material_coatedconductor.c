/* pbrt-v4's CoatedConductorMaterial: a dielectric interface ("interface.*") over a medium over
 * a conductor ("conductor.*", its own roughness) (bsdf/layered.h). */
#include "material_coatedconductor.h"
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

static int load(material_params_t *mp, material_t *m)
{
    material_coatedconductor_t *cc = mp->data;
    scene_float_input_t u, v, bu, bv;
    return material_inputs_load_conductor(mp, "conductor.", m) ||
                   material_inputs_load_ior(mp, "interface.", &m->ior) ||
                   material_inputs_load_roughness(mp, "interface.", &u, &v, &m->uroughness,
                                                  &m->vroughness) ||
                   material_inputs_load_roughness(mp, "conductor.", &bu, &bv, &cc->base_uroughness,
                                                  &cc->base_vroughness) ||
                   material_inputs_load_remap(mp, m) || material_inputs_load_layer(mp, &cc->layer)
               ? -1
               : 0;
}

static double base_roughness(const texture_t *t, const surface_t *sf)
{
    return t ? material_inputs_texture(t, sf, 550.0) : 0.0;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    const material_coatedconductor_t *cc = material_coatedconductor_of(m);
    b->kind = BSDF_COATED_CONDUCTOR;
    /* The base's own microfacets (shading_bsdf set a smooth base for every kind). */
    if (cc)
        b->mf_base = microfacet_make(base_roughness(cc->base_uroughness, sf),
                                     base_roughness(cc->base_vroughness, sf), m->remaproughness);
    material_inputs_layer_at(cc ? &cc->layer : NULL, sf, lambda, n, b);
    for (int j = 0; j < n; j++) {
        b->eta[j] = material_inputs_coat_eta(m, lambda[j]);
        /* pbrt-v4 CoatedConductorMaterial: the conductor's index relative to the coat. */
        material_inputs_conductor_index(m, sf, lambda[j], &b->cond_eta[j], &b->cond_k[j]);
        b->cond_eta[j] /= b->eta[j];
        b->cond_k[j] /= b->eta[j];
    }
}

const material_class_t material_coatedconductor = {.name = "coatedconductor",
                                                   .data_size = sizeof(material_coatedconductor_t),
                                                   .load = load,
                                                   .bsdf = bsdf};
