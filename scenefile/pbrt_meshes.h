/* pbrt_meshes: the meshes a parse makes (PLY files decoded, Loop subdivisions), queued as
 * the parse reads their directives and made together on the pool at the end, and the
 * budget (budget.h) of shapes and triangles they are counted against, in file order. */
#ifndef PRISMFARM_PBRT_MESHES_H
#define PRISMFARM_PBRT_MESHES_H

#include "pbrt_state.h"

int pbrt_meshes_budget_shape(parser_t *P, const char *what, pbrt_loc_t loc);
int pbrt_meshes_budget_refuse(parser_t *P, uint64_t n, pbrt_loc_t loc);
int pbrt_meshes_note_count(parser_t *P, long job, uint64_t n, pbrt_loc_t loc);
int pbrt_meshes_budget_triangles(parser_t *P, uint64_t n, pbrt_loc_t loc);
int pbrt_meshes_adopt(parser_t *P, scene_shape_t *s, mesh_data_t *md);
void pbrt_meshes_job_free(mesh_job_t *j);
int pbrt_meshes_queue(parser_t *P, const scene_shape_t *s, mesh_job_t *j);
int pbrt_meshes_finish(parser_t *P);

#endif
