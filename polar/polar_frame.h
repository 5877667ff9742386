/* polar_frame: the Stokes carrier of a path traced from the camera -- per spectral lane a 4x4
 * Mueller matrix T that takes the Stokes vector of light arriving at the path's current vertex
 * to what the camera records -- and the reference frames it is measured in along the path.
 *
 * Frames: light travelling along the unit vector k has its Stokes vector measured in a frame
 * (x, y) with x a unit vector perpendicular to k and y = k x x (so x, y, k are right-handed, as
 * stokes.h's angles from x toward y assume). A path stores one x for all its lanes (they share
 * the direction). A camera path travels along d, so the light it meets travels along k = -d.
 *
 * The carrier: the camera records S_cam = T S, S the light arriving along the path's last
 * segment in the frame x. An event that takes light arriving along k_in (frame x_in) to light
 * leaving along k_out (frame x_out) with Mueller matrix M makes T <- T R M, R the frame change
 * from x_out to the path's x about k_out, and the path's x becomes x_in (Wilkie & Weidlich,
 * "Polarised Light in Computer Graphics", SIGGRAPH Asia 2016 course, §5: a Mueller matrix is
 * only meaningful with its entry and exit frames; Mitsuba 3 likewise rotates the Stokes basis
 * of every matrix into the one the path carries). Camera paths are traced backward, so the
 * matrices multiply on the right.
 *
 * Guarantees: every frame vector is unit and perpendicular to its k (a fallback basis where a
 * cross product vanishes, at normal incidence), every matrix finite for finite input. */
#ifndef PRISMFARM_POLAR_FRAME_H
#define PRISMFARM_POLAR_FRAME_H

#include "stokes.h"
#include "vec3.h"

/* x made perpendicular to the unit k and unit; when x is (nearly) parallel to k, a fixed
 * perpendicular (vec3_basis's), so that the result is always a valid frame. */
vec3_t polar_frame_perp(vec3_t x, vec3_t k);

/* The Mueller matrix that re-expresses light along k measured in the frame x_from in the
 * frame x_to (both perpendicular to k): stokes.h's mueller_rotator by the angle from x_from to
 * x_to about k. */
mueller_t polar_frame_change(vec3_t x_from, vec3_t x_to, vec3_t k);

/* An event's frames: light arrives along k_in measured in x_in and leaves along k_out in
 * x_out. */
typedef struct polar_event {
    vec3_t k_in, x_in, k_out, x_out;
} polar_event_t;

/* The s-p frames of a smooth interface with normal n (either side) for light arriving along
 * k_in and leaving along k_out (reflected or refracted): x = s = k_in x n normalised, the
 * same on both sides, so that y = k x s is p (polar_fresnel.h's matrices are in this frame;
 * it is Born & Wolf's convention, r_p = -r_s at normal incidence). At normal incidence, where
 * the plane of incidence is undefined, s is the path's frame hint made perpendicular. */
polar_event_t polar_event_interface(vec3_t k_in, vec3_t k_out, vec3_t n, vec3_t hint);

/* The matrix m of an event given in the frames of `from` re-expressed in those of `to` (the same
 * k_in and k_out): R(from.x_out -> to.x_out) m R(to.x_in -> from.x_in). Lanes whose events
 * differ only in their frames (a rough dispersive refraction, each lane's microfacet its own)
 * are carried together in one pair of frames this way. */
mueller_t polar_event_rebase(const mueller_t *m, const polar_event_t *from,
                             const polar_event_t *to);

/* A thin sheet crossed straight along k: both frames have x along the sheet's axis (made
 * perpendicular to k), so that an element "at angle 0" (mueller_polariser(0),
 * mueller_retarder(0, delta)) acts along the axis. */
polar_event_t polar_event_sheet(vec3_t k, vec3_t axis);

/* The carrier update T <- T R M for lanes [0, n) (stride apart in t) sharing frame *x,
 * which becomes ev->x_in. m: one matrix per lane (m_stride 1) or one for all (m_stride 0). */
void polar_carrier_apply(mueller_t *t, int n, vec3_t *x, const polar_event_t *ev,
                         const mueller_t *m, int m_stride);

/* An ideal depolariser (diffuse and rough surfaces, media): T <- T D, D = diag(1, 0, 0, 0):
 * only T's first column is kept; the frame becomes any one perpendicular to k_in. */
void polar_carrier_depolarise(mueller_t *t, int n, vec3_t *x, vec3_t k_in);

/* M / M[0][0]: the polarising part of an element whose scalar M[0][0] (its effect on
 * unpolarised light) the caller carries as a weight; the identity when M[0][0] is not
 * positive (such a branch carries weight 0). */
mueller_t mueller_normalised(const mueller_t *m);

#endif
