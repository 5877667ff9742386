/* lens: pbrt-v4's RealisticCamera lens system (cameras.cpp) with a dispersive glass in every
 * element. A lens file lists the interfaces from the scene side to the film, one a line:
 * curvature radius, thickness to the next interface, index n_d of the medium after it and
 * aperture diameter, in mm (radius 0: the aperture stop; n 0 or 1: air), optionally followed by
 * a glass of optics/glass.h's catalogue -- prismfarm's extension; a glass can also come from
 * the caller (Camera "string glasses"). Where neither names one, the element gets the
 * catalogue glass nearest in n_d, shifted to the file's n_d (lens_system_defaulted says so).
 * The film is at z = 0 of camera space and the lens in front of it (+z, towards the scene);
 * the last thickness is set so that a point at the focus distance is in focus at the d line
 * (587.56 nm), by pbrt-v4's thick-lens approximation, and the exit pupil is bounded for 64
 * film radii over the film's range of wavelengths. Immutable once made; thread-safe reads. */
#ifndef PRISMFARM_LENS_H
#define PRISMFARM_LENS_H

#include "dispersion.h"
#include "err.h"

#include <stddef.h>

#define LENS_MAX_ELEMENTS 64
#define LENS_PUPIL_INTERVALS 64
#define LENS_LAMBDA_D 587.5618 /* helium d line, nm */

typedef struct lens_element {
    double radius;          /* m; 0: the aperture stop */
    double thickness;       /* m, to the next interface (the last: to the film) */
    double aperture_radius; /* m */
    double eta_d;           /* the file's index of the medium after the interface; <= 1: air */
    int glass;              /* the medium after the interface is glass (eta_d > 1) */
    int defaulted;          /* its glass is the default (none was named) */
    ior_model_t ior;        /* its index (air: 1) */
    double ior_shift;       /* added to ior so that n(d line) is eta_d */
    char glass_name[32];    /* the catalogue glass ("" for air) */
} lens_element_t;

typedef struct lens_params {
    const char *file;           /* for messages */
    const char *const *glasses; /* NULL, or one name per element ("" / "-" / "air": none) */
    int nglasses;
    double aperture_diameter_mm;   /* the stop's opening (clamped to the file's) */
    double focus_distance;         /* m, from the film, > 0 */
    double film_diagonal;          /* m */
    int xres, yres;                /* the full film's resolution (its aspect) */
    double lambda_min, lambda_max; /* nm: the film's range, for the pupil bounds */
} lens_params_t;

typedef struct lens_system lens_system_t;

/* Parses the lens file text and builds the system. NULL with err naming file:line and what
 * was expected for bad input, an unknown glass, a focus distance the lens cannot reach, or a
 * lens no ray passes. */
lens_system_t *lens_system_new(const char *text, size_t len, const lens_params_t *params,
                               err_t *err);
void lens_system_destroy(lens_system_t **self_p);

int lens_system_count(const lens_system_t *self);
const lens_element_t *lens_system_element(const lens_system_t *self, int i);
/* Elements that took the default glass (no name given), and whether the stop was clamped to
 * the file's diameter (pbrt-v4 warns about both kinds of thing). */
int lens_system_defaulted(const lens_system_t *self);
int lens_system_clamped(const lens_system_t *self);
/* The medium's index after element i at lambda_nm (1 for air and the stop). */
double lens_element_eta(const lens_element_t *e, double lambda_nm);
/* z of the front and rear interfaces (m, camera space, > 0), the rear element's radius. */
double lens_system_front_z(const lens_system_t *self);
double lens_system_rear_z(const lens_system_t *self);
double lens_system_rear_radius(const lens_system_t *self);
/* Effective focal length and back focal distance (paraxial, m) at lambda_nm, by pbrt-v4's
 * cardinal points from a ray parallel to the axis at 0.001 of the film diagonal. */
int lens_system_focal_length(const lens_system_t *self, double lambda_nm, double *efl,
                             double *film_focus_z);

/* The ray from film point o (camera space, z = 0 side) along d through the lens at lambda_nm:
 * 1 and the ray leaving the front element (unit out_d), or 0 when an element or the stop
 * blocks it, it misses a surface, or it is totally reflected. Never NaN. */
int lens_trace_from_film(const lens_system_t *self, const double o[3], const double d[3],
                         double lambda_nm, double out_o[3], double out_d[3]);
/* The reverse: a ray from the scene (travelling towards -z) to the rear element. */
int lens_trace_from_scene(const lens_system_t *self, const double o[3], const double d[3],
                          double lambda_nm, double out_o[3], double out_d[3]);

/* The exit pupil's bounds [xmin, xmax, ymin, ymax] on the rear element's plane for film
 * radius interval i (a film point on +x); all zero when no ray passes. */
void lens_system_pupil(const lens_system_t *self, int i, double bounds[4]);

/* pbrt-v4 RealisticCamera::GenerateRay: raster (fx, fy) of a full film xres x yres, lens
 * sample (u1, u2), wavelength. The camera-space ray (org on the front element, unit dir) and
 * the weight cos^4(theta) area / rear_z^2 (0: vignetted or outside the pupil). The image is
 * flipped as pbrt-v4's film is (x mirrored), so that it comes out upright. */
double lens_system_ray(const lens_system_t *self, double fx, double fy, double u1, double u2,
                       double lambda_nm, double org[3], double dir[3]);

#endif
