#include "settings.h"

scene_overrides_t settings_to_overrides(const proto_settings_t *s)
{
    return (scene_overrides_t){.spp = s->spp,
                               .xres = s->xres,
                               .yres = s->yres,
                               .seed = s->seed,
                               .integrator = s->integrator,
                               .dispersion = s->dispersion};
}

proto_settings_t settings_from_overrides(const scene_overrides_t *ov)
{
    return (proto_settings_t){.spp = ov->spp,
                              .xres = ov->xres,
                              .yres = ov->yres,
                              .seed = ov->seed,
                              .integrator = ov->integrator,
                              .dispersion = ov->dispersion};
}
