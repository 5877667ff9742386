/* medium_presets: pbrt-v4's table of measured scattering properties that a homogeneous
 * medium's "preset" names (pbrt-v4 media.cpp GetMediumScatteringProperties; data from Jensen
 * et al. 2001 and Narasimhan et al. 2006, in mm^-1, as linear sRGB). Lookups are exact,
 * case-sensitive name matches, as in pbrt-v4. */
#ifndef PRISMFARM_MEDIUM_PRESETS_H
#define PRISMFARM_MEDIUM_PRESETS_H

#include <stdbool.h>

/* Fills sigma_s (pbrt-v4 uses the reduced sigma'_s as sigma_s) and sigma_a, three RGB values
 * each, for the preset name; false when there is none of that name. */
bool medium_preset_find(const char *name, double sigma_s[3], double sigma_a[3]);

#endif
