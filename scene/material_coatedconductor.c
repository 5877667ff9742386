/* pbrt-v4's CoatedConductorMaterial: a dielectric interface ("interface.*") over a medium over
 * a conductor ("conductor.*", its own roughness) (bsdf/layered.h). */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if (material_inputs_roughness(L, &dm->uroughness, &m->uroughness, err) ||
        material_inputs_roughness(L, &dm->vroughness, &m->vroughness, err) ||
        material_inputs_roughness(L, &dm->base_uroughness, &m->base_uroughness, err) ||
        material_inputs_roughness(L, &dm->base_vroughness, &m->base_vroughness, err))
        return -1;
    return material_inputs_conductor(L, dm, m, err) ||
                   material_inputs_ior(L->sc, &dm->ior, m->name, &m->ior, err) ||
                   material_inputs_layer(L, dm, m, err)
               ? -1
               : 0;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    b->kind = BSDF_COATED_CONDUCTOR;
    material_inputs_layer_at(m, sf, lambda, n, b);
    for (int j = 0; j < n; j++) {
        b->eta[j] = material_inputs_coat_eta(m, lambda[j]);
        /* pbrt-v4 CoatedConductorMaterial: the conductor's index relative to the coat. */
        material_inputs_conductor_index(m, sf, lambda[j], &b->cond_eta[j], &b->cond_k[j]);
        b->cond_eta[j] /= b->eta[j];
        b->cond_k[j] /= b->eta[j];
    }
}

const material_class_t material_coatedconductor = {.load = load, .bsdf = bsdf};
