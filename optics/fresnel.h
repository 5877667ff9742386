/* fresnel: specular reflection and refraction directions (Snell's law) and the unpolarised
 * Fresnel reflectance of a smooth dielectric interface, in the cosine form. Pure functions;
 * every result is finite for any finite input, including normal, grazing and critical-angle
 * incidence and light arriving from either side of the interface. */
#ifndef PRISMFARM_FRESNEL_H
#define PRISMFARM_FRESNEL_H

#include "vec3.h"

#include <stdbool.h>

/* Below this cos(theta_i) the incidence is grazing: R = 1 exactly (the limit of the cosine
 * form, whose numerator and denominator both vanish there). */
#define FRESNEL_GRAZING_COS 1e-6

/* Mirror direction of d (travelling towards the surface) about the normal n (unit, either
 * orientation): d - 2 (d.n) n (thesis eq. 3.1). */
vec3_t fresnel_reflect(vec3_t d, vec3_t n);

/* Refracts d (unit, travelling towards the surface) through an interface with unit normal n
 * (either orientation: it is flipped to face the incident side). eta_ratio = n_incident /
 * n_transmitted. Snell: n_i sin(theta_i) = n_t sin(theta_t). Returns true and the unit
 * refracted direction in *t, or false on total internal reflection, (eta sin theta_i)^2 >= 1,
 * with *t set to the zero vector. A non-finite or non-positive eta_ratio is treated as total
 * reflection. */
bool fresnel_refract(vec3_t d, vec3_t n, double eta_ratio, vec3_t *t);

/* Fresnel terms of one interface crossing (Born & Wolf, Principles of Optics, sec. 1.5.2):
 *   r_s = (n1 cos_i - n2 cos_t) / (n1 cos_i + n2 cos_t)
 *   r_p = (n2 cos_i - n1 cos_t) / (n2 cos_i + n1 cos_t)
 *   R = (r_s^2 + r_p^2) / 2,  T = 1 - R   (unpolarised light; thesis eq. 3.6, 3.11)
 * n1 is the index on the incident side, n2 on the other. */
typedef struct fresnel_terms {
    double rs, rp; /* amplitude reflection coefficients */
    double reflectance, transmittance;
    double cos_t;  /* cos(theta_t) >= 0, 0 under total internal reflection */
    double n1, n2; /* indices actually used: incident side, transmitted side */
    bool tir;      /* total internal reflection: R = 1 */
} fresnel_terms_t;

/* cos_theta_i = dot(w_i, n) where w_i points from the surface towards where the light comes
 * from and n points into the medium of index n_outside. cos_theta_i < 0 means the light
 * arrives from inside: the indices are swapped and |cos_theta_i| used. cos_theta_i slightly
 * outside [-1, 1] (rounding) is clamped. Equal indices give R = 0 (no interface); grazing
 * incidence (|cos| < FRESNEL_GRAZING_COS) R = 1; indices that are not finite and > 0 give
 * R = 1 (a mirror rather than a NaN). The thesis's tan/sin form (eq. 3.8) is never
 * evaluated: it is 0/0 at normal incidence. */
fresnel_terms_t fresnel_dielectric_terms(double cos_theta_i, double n_outside, double n_inside);

/* The reflectance R of fresnel_dielectric_terms. */
double fresnel_dielectric(double cos_theta_i, double n_outside, double n_inside);

/* Unpolarised reflectance of a conductor of complex relative index eta + i k (Born & Wolf
 * sec. 14.2; pbrt-v4 FrComplex): the cosine form above with a complex n2 / n1 and a complex
 * cos_t = sqrt(1 - sin^2_i / (eta + i k)^2). Light reaches a conductor only from outside, so
 * the side of cos_i is ignored (|cos_i|, clamped to 1). k = 0 is the dielectric case (eta < 1
 * reflects totally beyond its critical angle); eta = 0 with k > 0 is a perfect mirror, R = 1
 * at every angle; a result that is not finite (eta = k = 0, non-finite indices) reads as 1.
 * Always in [0, 1]. */
double fresnel_conductor(double cos_i, double eta, double k);

#endif
