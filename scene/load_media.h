/* load_media: MakeNamedMedium made into the scene's media in the description's order (shapes
 * and the camera name them by index); media the parser warned are not simulated stay vacuum. */
#ifndef PRISMFARM_LOAD_MEDIA_H
#define PRISMFARM_LOAD_MEDIA_H

#include "loader.h"

/* MakeNamedMedium into the scene's media, in the description's order (shapes and the camera
 * name them by index). The coefficients are unbounded spectra (pbrt-v4
 * SpectrumType::Unbounded); the emission Le is normalised as a light's spectrum is (pbrt-v4
 * divides Lescale by SpectrumToPhotometric(Le)), and a black Le is none. Media that are not
 * simulated (the parser warned) are NULL entries: vacuum. */
int load_media(loader_t *L, err_t *err);

#endif
