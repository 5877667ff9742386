/* pbrt_state: the parser's state and the token-level helpers every entity reader uses.
 * pbrt-v4's graphics state (CTM, ReverseOrientation, current material, area light, media and
 * Attribute defaults) is saved by AttributeBegin / ObjectBegin / Import and restored at their
 * end; parser_t holds it with the scene being built, the file being read, the confinement of
 * a confined parse and the queue of meshes made at the end. Internal to scenefile/: only the
 * pbrt_*.c files of the parser include it. Every function that fails fills P->err with
 * "file:line:col: message" and returns -1 (NULL). */
#ifndef PRISMFARM_PBRT_STATE_H
#define PRISMFARM_PBRT_STATE_H

#include "budget.h"
#include "err.h"
#include "mesh_import.h"
#include "params.h"
#include "pbrt_lexer.h"
#include "pbrt_limits.h"
#include "pbrt_names.h"
#include "scene_desc.h"
#include "transform.h"
#include "warnings.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

enum { FRAME_ATTRIBUTE, FRAME_OBJECT, FRAME_IMPORT };

/* The kinds of entity an `Attribute` directive gives defaults for, in pbrt-v4's words. */
enum { ATTR_SHAPE, ATTR_LIGHT, ATTR_MATERIAL, ATTR_MEDIUM, ATTR_TEXTURE, ATTR_KINDS };

/* One `Attribute` directive's parameters, in a chain from the newest to the oldest in effect.
 * Nodes are immutable and owned by the parser, so the graphics state holds plain pointers
 * and AttributeBegin/End save and restore them by copying the state. */
typedef struct attr_node {
    params_t *ps;
    const struct attr_node *older;
    struct attr_node *next_owned; /* the parser's list of every node, for freeing */
} attr_node_t;

typedef struct gstate {
    transform_t ctm;
    /* ActiveTransform EndTime: transforms apply only to the shutter's end, which prismfarm
     * does not render (no motion blur), so they leave the CTM alone. pbrt-v4 keeps the active
     * transform in the graphics state: AttributeEnd restores it. */
    bool end_time_only;
    bool reverse;
    int material;
    int area_light;
    /* MediumInterface: the current inside and outside media (indices into the scene's media,
     * -1 for none), which shapes and the camera take. */
    int inside_medium, outside_medium;
    /* The `Attribute` defaults in effect for each kind (NULL: none). */
    const attr_node_t *attr[ATTR_KINDS];
} gstate_t;

typedef struct frame {
    int kind;
    const char *what; /* the directive that opened it, for messages */
    pbrt_loc_t loc;
    gstate_t gs;
} frame_t;

typedef struct coordsys {
    char *name;
    transform_t t;
} coordsys_t;

/* A mesh whose making (a PLY file's decoding, a Loop subdivision) waits for the end of the
 * parse, when all of them run at once on the pool (pbrt_meshes_finish): the parse only reads
 * the directive and queues the work. The shape it fills is named by index, since the shape
 * arrays grow as the parse goes on. */
typedef enum {
    MESH_JOB_PLY_FILE,
    MESH_JOB_PLY_MEMORY,
    MESH_JOB_LOOP,
    MESH_JOB_PLY_SAME, /* a PLY file an earlier job of the queue decodes: its mesh, shared */
} mesh_job_kind_t;

/* The most PLY bytes (a confined parse's, read as their directives are) held in the queue. */
#define MESH_QUEUE_BYTES_MAX ((size_t)256 << 20)

typedef struct mesh_job {
    mesh_job_kind_t kind;
    bool in_object;
    size_t shape;
    pbrt_loc_t loc;   /* where a failure is reported (the PLY's "filename", the loopsubdiv) */
    const char *path; /* PLY: the file as opened (a scene_desc string) */
    char *buf;        /* PLY_MEMORY: the file's bytes, read (and inflated) by the parse */
    size_t len;
    double *P; /* LOOP: the control mesh, copied from the directive */
    uint32_t *idx;
    size_t nv, nt;
    int levels;
    size_t same; /* PLY_SAME: the job whose mesh this shape shares */
    int state;   /* 0 not run, 1 made (md), -1 failed (err) */
    mesh_data_t md;
    err_t err;
} mesh_job_t;

/* With a triangle budget, the budget is counted in file order once a mesh has been queued:
 * each count (a queued job's, known when it has run, or a shape's own) is noted here and
 * checked in order when the jobs have run, so the refusal names the same shape as a parse
 * that made every mesh at its directive would. */
typedef struct tri_count {
    long job; /* >= 0: the job's triangles; -1: n */
    uint64_t n;
    pbrt_loc_t loc;
} tri_count_t;

typedef struct parser {
    scene_desc_t *scene;
    err_t *err;
    gstate_t gs;
    frame_t *frames;
    size_t nframes, cap_frames;
    bool world;
    pbrt_loc_t world_loc;
    coordsys_t *cs;
    size_t ncs, cap_cs;
    int object;           /* the object being defined, or -1 */
    const char **pending; /* object name of each instance, resolved at the end */
    size_t cap_pending;
    char *open_files[PBRT_INCLUDE_DEPTH_MAX]; /* realpaths of the files being read */
    int nopen;
    size_t nfiles_read;
    pbrt_lexer_t *lex;
    const char *file;      /* the file being read, as named in messages */
    const char *main_name; /* the main file: the base of pbrt-v4's file name rule */
    /* A confined parse (pbrt_parse_file_confined): the root folder, absolute and lexically
     * normalised, and its realpath; both NULL when unconfined. */
    char *root_lex, *root_real;
    size_t bytes_charged; /* confined: bytes read and decoded so far (PBRT_TOTAL_BYTES_MAX) */
    const scene_budget_t *budget; /* NULL: none (budget.h) */
    uint64_t nshapes, ntriangles; /* counted against it */
    scene_budget_use_t used;      /* and its vertices and text (budget.c) */
    int threads;                  /* for the queued meshes (<= 0: all cores) */
    bool bundle;                  /* the bundle rule applies (pbrt_parse_opts_t.bundle) */
    mesh_job_t *jobs;             /* queued meshes, in file order */
    size_t njobs, cap_jobs;
    tri_count_t *counts; /* triangle counts noted after the first job, in file order */
    size_t ncounts, cap_counts;
    uint64_t ntriangles_ahead; /* the known counts among them: with ntriangles, a lower bound */
    bool resolving;            /* pbrt_meshes_finish is checking counts in order */
    size_t queued_bytes;       /* the queued jobs' file bytes */
    /* The queue's PLY jobs by path (open addressing, job index + 1; 0: empty), so that a file
     * named by several shapes is decoded once. */
    size_t *ply_slots;
    size_t ply_cap, nply;
    /* The other place locate() looked for the last name it resolved (the main file's folder),
     * when the name was found in neither: "" otherwise. For "cannot open" messages. */
    char also[512];
    /* Check mode (pbrt_parse_file_check): a refused directive is recorded here and the parse
     * goes on at the next directive; NULL: the first refusal ends the parse. */
    warnings_t *errors;
    attr_node_t *attr_owned; /* every Attribute node, newest first */
    /* Option "seed": the sampler's seed where the Sampler does not give one (pbrt-v4's
     * Options->seed is the default of the sampler's "integer seed"). */
    bool option_seed_set, sampler_seed_given;
    int option_seed;
} parser_t;

#define NAME_MAX_LEN 4096

typedef struct str_arg {
    char s[NAME_MAX_LEN];
    pbrt_loc_t loc;
} str_arg_t;

#define COUNT_OF(a) (sizeof(a) / sizeof((a)[0]))

bool pbrt_state_in_list(const char *s, const char **list, size_t n);

/* Looks the name s (written at loc) up in table[0..n) (pbrt_names.h, whose message it gives):
 * its value into *value. The one place an entity's "unsupported X" message is made. */
int pbrt_state_lookup(parser_t *P, const char *what, const char *s, pbrt_loc_t loc,
                      const pbrt_name_t *table, size_t n, int *value);

/* How a token reads in a message. */
void pbrt_state_describe(const pbrt_token_t *t, char *buf, size_t n);

/* A quoted string argument of a directive (the type, a name). */
int pbrt_state_read_string(parser_t *P, const char *directive, pbrt_loc_t dloc, const char *what,
                           str_arg_t *out);
int pbrt_state_read_numbers(parser_t *P, const char *directive, pbrt_loc_t dloc, double *out,
                            int n);
int pbrt_state_read_matrix(parser_t *P, const char *directive, pbrt_loc_t dloc, double out[16]);
params_t *pbrt_state_read_params(parser_t *P, const char *context);
int pbrt_state_need_world(parser_t *P, const char *directive, pbrt_loc_t loc);
int pbrt_state_need_options(parser_t *P, const char *directive, pbrt_loc_t loc);
int pbrt_state_check_transform(parser_t *P, const transform_t *t, const char *user, pbrt_loc_t loc);
int pbrt_state_push_frame(parser_t *P, int kind, const char *what, pbrt_loc_t loc);
int pbrt_state_set_coordsys(parser_t *P, const char *name, transform_t t, pbrt_loc_t loc);
__attribute__((format(printf, 3, 4))) int pbrt_state_fail_at(parser_t *P, const pbrt_loc_t *from,
                                                             const char *fmt, ...);
int pbrt_state_check_positive(parser_t *P, params_t *ps, const char *name, double v);
int pbrt_state_check_range(parser_t *P, params_t *ps, const char *name, double v, double lo,
                           double hi);
double *pbrt_state_copy_doubles(parser_t *P, const double *src, size_t n);
int pbrt_state_attr_apply(parser_t *P, params_t *ps, int kind);

#endif
