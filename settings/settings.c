#include "settings.h"

#include <stdio.h>

scene_overrides_t settings_to_overrides(const proto_settings_t *s)
{
    return (scene_overrides_t){.spp = s->spp,
                               .xres = s->xres,
                               .yres = s->yres,
                               .seed = s->seed,
                               .integrator = s->integrator,
                               .dispersion = s->dispersion};
}

void settings_scene_key(const char *hash, const char *main, const proto_settings_t *s,
                        char key[SETTINGS_KEY_SIZE])
{
    /* NULL (the file's) is "-", a name is quoted: they never meet. A name is cut at 64
     * characters, past the longest the loader knows, so a cut name is one it refuses. */
    char integ[70] = "-", disp[70] = "-";
    if (s->integrator)
        snprintf(integ, sizeof integ, "\"%.64s\"", s->integrator);
    if (s->dispersion)
        snprintf(disp, sizeof disp, "\"%.64s\"", s->dispersion);
    /* main last: a bundle path may hold spaces, and nothing follows it to be confused with. */
    snprintf(key, SETTINGS_KEY_SIZE,
             "%s spp=%d res=%dx%d seed=%lld integrator=%s dispersion=%s main=%.*s", hash, s->spp,
             s->xres, s->yres, (long long)s->seed, integ, disp, PROTO_MAX_STRING, main);
}
