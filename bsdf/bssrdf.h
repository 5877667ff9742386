/* bssrdf: pbrt-v4's tabulated BSSRDF (bssrdf.h TabulatedBSSRDF, BSSRDFTable) for the
 * "subsurface" material: the radial diffusion profile of a semi-infinite medium of
 * single-scattering albedo rho under a normally incident beam, by photon beam diffusion
 * (Habel, Christensen & Jarosz 2013: multiple scattering from a dipole integrated along the
 * refracted beam, plus single scattering), tabulated once per (g, eta) over 100 albedos and 64
 * optical radii, interpolated and sampled with Catmull-Rom splines (catmull_rom.h). A lane's
 * medium is (sigma_t, rho) in inverse scene units; the profile scales with sigma_t. The
 * surface point where light enters is found by probe rays (bssrdf_probe) along three axes,
 * with the multiple-importance density bssrdf_pdf_sp. docs/physics.md §18 has the equations.
 * Where the light leaves, the BSDF is pbrt-v4's NormalizedFresnelBxDF, the row
 * bsdf_model_sss_exit (BSDF_SSS_EXIT, bsdf_model.h) defined in bssrdf.c.
 *
 * Guarantees: every value returned is finite and >= 0 for sigma_t >= 0, rho in [0, 1] and any
 * radius (sigma_t = 0: no profile, no sample); the profile integrates over the plane to the
 * table's effective albedo bssrdf_rho_eff, and bssrdf_pdf_sr is the density of
 * bssrdf_sample_sr's radii (per unit area of the plane). */
#ifndef PRISMFARM_BSSRDF_H
#define PRISMFARM_BSSRDF_H

#include "vec3.h"

#include <stdbool.h>

#define BSSRDF_RHO_SAMPLES 100
#define BSSRDF_RADIUS_SAMPLES 64

typedef struct bssrdf_table bssrdf_table_t;

/* The profile table for HG asymmetry g (|g| < 1) and relative index eta (inside over outside,
 * > 0) computed as pbrt-v4's ComputeBeamDiffusionBSSRDF does (about 1.3 M exponentials: some
 * 20 ms). NULL when out of memory. */
bssrdf_table_t *bssrdf_table_new(double g, double eta);
void bssrdf_table_destroy(bssrdf_table_t **self_p);

double bssrdf_table_eta(const bssrdf_table_t *t);
double bssrdf_table_g(const bssrdf_table_t *t);

/* The effective albedo (the profile's integral over the plane) at single-scattering albedo
 * rho, interpolated; and its inverse, the rho that gives rho_eff (pbrt-v4
 * SubsurfaceFromDiffuse, for "reflectance"): rho_eff outside the table's range clamps. */
double bssrdf_rho_eff(const bssrdf_table_t *t, double rho);
double bssrdf_rho_from_eff(const bssrdf_table_t *t, double rho_eff);

/* S_r(r): the profile at distance r (scene units) for a lane of extinction sigma_t and
 * albedo rho; its integral over the plane (2 pi r dr) is bssrdf_rho_eff(rho). */
double bssrdf_sr(const bssrdf_table_t *t, double sigma_t, double rho, double r);

/* A radius drawn with density bssrdf_pdf_sr (per unit area) from u in [0, 1); -1 when none
 * (sigma_t = 0 or a profile of zero). */
double bssrdf_sample_sr(const bssrdf_table_t *t, double sigma_t, double rho, double u);
double bssrdf_pdf_sr(const bssrdf_table_t *t, double sigma_t, double rho, double r);

/* A probe segment p0 -> p1 through the exit point po with shading normal ns (unit), for a
 * lane's (sigma_t, rho): along ns with probability 1/2, else along one of the two tangents of
 * vec3_basis(ns) (1/4 each; u_axis chooses), at a radius from bssrdf_sample_sr(u_r) and
 * azimuth 2 pi u_phi about that axis, as long as the sphere of radius r_max =
 * bssrdf_sample_sr(0.999) (pbrt-v4's bound) is wide. False when nothing is sampled. */
bool bssrdf_probe(const bssrdf_table_t *t, double sigma_t, double rho, vec3_t po, vec3_t ns,
                  double u_axis, double u_r, double u_phi, vec3_t *p0, vec3_t *p1);

/* The density (per unit area) with which bssrdf_probe's three axes together find the point pi
 * with normal ni (unit) from po, ns: sum over the axes of P(axis) pdf_sr(radius about the
 * axis) |ni . axis| (pbrt-v4 PDF_Sp). */
double bssrdf_pdf_sp(const bssrdf_table_t *t, double sigma_t, double rho, vec3_t po, vec3_t ns,
                     vec3_t pi, vec3_t ni);

/* The building blocks, for tests: d'Eon and Irving's polynomial fits of the first two Fresnel
 * moments int_0^1 F_r(mu) mu^k dmu for light inside a medium of relative index eta (2011, "A
 * quantized-diffusion model for rendering translucent materials", as pbrt-v4 has them), and
 * the photon beam diffusion profile (multiple and single scattering) at radius r of a medium
 * with sigma_s, sigma_a in inverse units of r. */
double bssrdf_fresnel_moment1(double eta);
double bssrdf_fresnel_moment2(double eta);
double bssrdf_beam_diffusion_ms(double sigma_s, double sigma_a, double g, double eta, double r);
double bssrdf_beam_diffusion_ss(double sigma_s, double sigma_a, double g, double eta, double r);

#endif
