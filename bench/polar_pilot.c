/* bench_polar_pilot: what polarised transport changes and costs, per scene, for
 * docs/accuracy.md: render/polar_pilot.h's figure at the pilot's own 4 spp (the plan's
 * decision) and at more samples (its reference), and the wall-time ratio of the polarised to the
 * plain renders over the same samples (noisy under load: a ratio, not a timing).
 *
 * usage: bench_polar_pilot SPP SCENE.pbrt...   (prints a Markdown table) */
#include "polar_pilot.h"
#include "scene_load.h"

#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: bench_polar_pilot SPP SCENE.pbrt...\n");
        return 2;
    }
    const int spp = atoi(argv[1]);
    printf(
        "| scene | pilot (%d spp): change, 2 s.e. bound | reference (%d spp) | polarised / plain "
        "time |\n",
        POLAR_PILOT_SPP, spp);
    printf("| --- | --- | --- | --- |\n");
    for (int i = 2; i < argc; i++) {
        err_t err;
        scene_overrides_t ov = {.seed = -1};
        scene_t *s = scene_load_file(argv[i], &ov, &err);
        if (!s) {
            fprintf(stderr, "%s: %s\n", argv[i], err.msg);
            return 1;
        }
        polar_pilot_result_t p, r;
        if (polar_pilot_measure(s, POLAR_PILOT_GRID, POLAR_PILOT_TILE, POLAR_PILOT_SPP, &p, &err) ||
            polar_pilot_measure(s, POLAR_PILOT_GRID, POLAR_PILOT_TILE, spp, &r, &err)) {
            fprintf(stderr, "%s: %s\n", argv[i], err.msg);
            scene_destroy(&s);
            return 1;
        }
        printf("| %s | %.2f %%, %.2f %% | %.2f %% (%.2f %%) | %.2f (%.2f s / %.2f s) |\n", argv[i],
               100.0 * p.change, 100.0 * p.change_hi, 100.0 * r.change, 100.0 * r.change_hi,
               r.seconds_polarised / r.seconds_plain, r.seconds_polarised, r.seconds_plain);
        fflush(stdout);
        scene_destroy(&s);
    }
    return 0;
}
