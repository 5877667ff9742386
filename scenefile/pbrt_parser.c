#define _XOPEN_SOURCE 700 /* realpath, strdup, O_NOFOLLOW, O_CLOEXEC */

#include "pbrt_parser.h"

#include "integrators.h"
#include "medium_presets.h"

#include "gzip_data.h"
#include "loopsubdiv.h"
#include "mesh_import.h"
#include "shape_tess.h"
#include "params.h"
#include "pbrt_lexer.h"
#include "warnings.h"

#include "files.h"
#include "pool.h"
#include "suggest.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* fopen(path, "rb") for a regular file only: opened without blocking and checked with fstat, so
 * that a FIFO named by a scene, an Include or a texture is refused at once instead of blocking
 * the parse for ever (a device would never end). NULL with errno set, or EINVAL and *kind
 * naming what the path is (files_kind). */
static FILE *open_regular_file(const char *path, const char **kind)
{
    *kind = NULL;
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return NULL;
    struct stat st;
    int flags;
    FILE *f = NULL;
    if (fstat(fd, &st) != 0) {
    } else if (!S_ISREG(st.st_mode)) {
        *kind = files_kind(st.st_mode);
        errno = EINVAL;
    } else if ((flags = fcntl(fd, F_GETFL)) >= 0 && fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) == 0) {
        f = fdopen(fd, "rb");
    }
    if (!f) {
        int e = errno;
        (void)close(fd);
        errno = e;
    }
    return f;
}

/* The reason open_regular_file failed. */
static const char *open_failure(const char *kind, char *buf, size_t size)
{
    if (!kind)
        return strerror(errno);
    snprintf(buf, size, "it is %s, not a regular file", kind);
    return buf;
}

/* ------------------------------------------------------------------------------------------
 * Parser state: pbrt-v4's graphics state (CTM, ReverseOrientation, current material and area
 * light), saved by AttributeBegin / ObjectBegin / Import and restored at their end.
 * ------------------------------------------------------------------------------------------ */

enum { FRAME_ATTRIBUTE, FRAME_OBJECT, FRAME_IMPORT };

/* The kinds of entity an `Attribute` directive gives defaults for, in pbrt-v4's words. */
enum { ATTR_SHAPE, ATTR_LIGHT, ATTR_MATERIAL, ATTR_MEDIUM, ATTR_TEXTURE, ATTR_KINDS };
static const char *ATTR_KIND_NAMES[ATTR_KINDS] = {"shape", "light", "material", "medium",
                                                  "texture"};

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
 * parse, when all of them run at once on the pool (mesh_jobs_finish): the parse only reads
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
    mesh_job_t *jobs;             /* queued meshes, in file order */
    size_t njobs, cap_jobs;
    tri_count_t *counts; /* triangle counts noted after the first job, in file order */
    size_t ncounts, cap_counts;
    uint64_t ntriangles_ahead; /* the known counts among them: with ntriangles, a lower bound */
    bool resolving;            /* mesh_jobs_finish is checking counts in order */
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

static const char *SAMPLERS[] = {"halton", "independent", "paddedsobol", "pmj02bn",
                                 "sobol",  "stratified",  "zsobol"};

/* pbrt-v4 directives that prismfarm knows but does not support. */
static const char *UNSUPPORTED_DIRECTIVES[] = {"WorldEnd"};

#define COUNT_OF(a) (sizeof(a) / sizeof((a)[0]))

static bool in_list(const char *s, const char **list, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!strcmp(s, list[i]))
            return true;
    return false;
}

/* How a token reads in a message. */
static void describe(const pbrt_token_t *t, char *buf, size_t n)
{
    switch (t->kind) {
    case PBRT_TOKEN_EOF:
        snprintf(buf, n, "the end of the file");
        break;
    case PBRT_TOKEN_LBRACKET:
        snprintf(buf, n, "[");
        break;
    case PBRT_TOKEN_RBRACKET:
        snprintf(buf, n, "]");
        break;
    case PBRT_TOKEN_STRING:
        snprintf(buf, n, "\"%.60s%s\"", t->text, t->len > 60 ? "..." : "");
        break;
    case PBRT_TOKEN_WORD:
        snprintf(buf, n, "%.60s%s", t->text, t->len > 60 ? "..." : "");
        break;
    }
}

/* ------------------------------------------------------------------------------------------
 * Token-level helpers
 * ------------------------------------------------------------------------------------------ */

static int read_string(parser_t *P, const char *directive, pbrt_loc_t dloc, const char *what,
                       str_arg_t *out)
{
    pbrt_token_t t;
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind != PBRT_TOKEN_STRING) {
        char d[96];
        describe(&t, d, sizeof d);
        return pbrt_error(P->err, t.kind == PBRT_TOKEN_EOF ? dloc : t.loc,
                          "%s expects a quoted %s, got %s", directive, what, d);
    }
    if (t.len >= sizeof out->s)
        return pbrt_error(P->err, t.loc, "%s: the %s is longer than %d characters", directive, what,
                          NAME_MAX_LEN - 1);
    if (strlen(t.text) != t.len)
        return pbrt_error(P->err, t.loc, "%s: the %s contains a NUL byte", directive, what);
    memcpy(out->s, t.text, t.len + 1);
    out->loc = t.loc;
    return 0;
}

static int number_error(parser_t *P, const pbrt_token_t *t, pbrt_loc_t dloc, const char *directive,
                        int n, int i)
{
    char d[96];
    describe(t, d, sizeof d);
    if (t->kind == PBRT_TOKEN_WORD) {
        double v;
        if (pbrt_parse_number(t->text, &v) == -2)
            return pbrt_error(P->err, t->loc, "non-finite number %s in %s", d, directive);
    }
    return pbrt_error(P->err, t->kind == PBRT_TOKEN_EOF ? dloc : t->loc,
                      "%s expects %d numbers, got %s as number %d", directive, n, d, i + 1);
}

static int read_numbers(parser_t *P, const char *directive, pbrt_loc_t dloc, double *out, int n)
{
    for (int i = 0; i < n; i++) {
        pbrt_token_t t;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            return -1;
        if (t.kind != PBRT_TOKEN_WORD || pbrt_parse_number(t.text, &out[i]) != 0)
            return number_error(P, &t, dloc, directive, n, i);
    }
    return 0;
}

/* "[" 16 numbers "]", as Transform and ConcatTransform require. */
static int read_matrix(parser_t *P, const char *directive, pbrt_loc_t dloc, double out[16])
{
    pbrt_token_t t;
    char d[96];
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind != PBRT_TOKEN_LBRACKET) {
        describe(&t, d, sizeof d);
        return pbrt_error(P->err, t.kind == PBRT_TOKEN_EOF ? dloc : t.loc,
                          "%s expects [ and 16 numbers, got %s", directive, d);
    }
    for (int i = 0; i < 16; i++) {
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            return -1;
        if (t.kind == PBRT_TOKEN_RBRACKET)
            return pbrt_error(P->err, t.loc, "%s expects 16 numbers, got %d", directive, i);
        if (t.kind != PBRT_TOKEN_WORD || pbrt_parse_number(t.text, &out[i]) != 0)
            return number_error(P, &t, dloc, directive, 16, i);
    }
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind != PBRT_TOKEN_RBRACKET) {
        describe(&t, d, sizeof d);
        return pbrt_error(P->err, t.kind == PBRT_TOKEN_EOF ? dloc : t.loc,
                          "%s expects ] after 16 numbers, got %s", directive, d);
    }
    return 0;
}

static int add_value(parser_t *P, params_t *ps, param_t *p, const pbrt_token_t *t)
{
    char d[96];
    describe(t, d, sizeof d);
    bool is_bool_word =
        t->kind == PBRT_TOKEN_WORD && (!strcmp(t->text, "true") || !strcmp(t->text, "false"));
    switch (p->type) {
    case PARAM_STRING:
    case PARAM_TEXTURE:
        if (t->kind != PBRT_TOKEN_STRING)
            return pbrt_error(P->err, t->loc, "\"%s %s\" needs quoted strings, got %s",
                              p->type_name, p->name, d);
        if (strlen(t->text) != t->len)
            return pbrt_error(P->err, t->loc, "string value of \"%s %s\" contains a NUL byte",
                              p->type_name, p->name);
        return params_push_string(ps, p, t->text, P->err);
    case PARAM_BOOL:
        /* pbrt-v4 writes true/false bare; older files quote them. */
        if (is_bool_word || (t->kind == PBRT_TOKEN_STRING &&
                             (!strcmp(t->text, "true") || !strcmp(t->text, "false"))))
            return params_push_bool(ps, p, !strcmp(t->text, "true"), P->err);
        return pbrt_error(P->err, t->loc, "\"%s %s\" needs true or false, got %s", p->type_name,
                          p->name, d);
    case PARAM_SPECTRUM:
        if (t->kind == PBRT_TOKEN_STRING) {
            if (strlen(t->text) != t->len)
                return pbrt_error(P->err, t->loc, "string value of \"%s %s\" contains a NUL byte",
                                  p->type_name, p->name);
            return params_push_string(ps, p, t->text, P->err);
        }
        break;
    default:
        break;
    }
    if (t->kind != PBRT_TOKEN_WORD || is_bool_word)
        return pbrt_error(P->err, t->loc, "\"%s %s\" needs numbers, got %s", p->type_name, p->name,
                          d);
    if (p->type == PARAM_INTEGER) {
        int v;
        int rc = pbrt_parse_int(t->text, &v);
        if (rc == -2)
            return pbrt_error(P->err, t->loc, "%s is out of range for \"%s %s\" (32-bit integers)",
                              d, p->type_name, p->name);
        if (rc != 0)
            return pbrt_error(P->err, t->loc, "\"%s %s\" needs integers, got %s", p->type_name,
                              p->name, d);
        return params_push_number(ps, p, (double)v, P->err);
    }
    double v;
    int rc = pbrt_parse_number(t->text, &v);
    if (rc == -2)
        return pbrt_error(P->err, t->loc, "non-finite number %s in \"%s %s\"", d, p->type_name,
                          p->name);
    if (rc != 0)
        return pbrt_error(P->err, t->loc, "\"%s %s\" needs numbers, got %s", p->type_name, p->name,
                          d);
    return params_push_number(ps, p, v, P->err);
}

/* The parameter list after a directive: quoted "type name" declarations, each followed by one
 * value or a bracketed list. It ends at the first token that is not a quoted string. */
static params_t *read_params(parser_t *P, const char *context)
{
    params_t *ps = params_new(context, P->err);
    if (!ps)
        return NULL;
    for (;;) {
        pbrt_token_t t;
        if (pbrt_lexer_peek(P->lex, &t, P->err) != 0)
            goto fail;
        if (t.kind != PBRT_TOKEN_STRING)
            return ps;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            goto fail;
        if (strlen(t.text) != t.len) {
            pbrt_error(P->err, t.loc, "parameter declaration contains a NUL byte");
            goto fail;
        }
        param_t *p = params_declare(ps, t.text, t.loc, P->err);
        if (!p)
            goto fail;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            goto fail;
        if (t.kind == PBRT_TOKEN_LBRACKET) {
            pbrt_loc_t open = t.loc;
            for (;;) {
                if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
                    goto fail;
                if (t.kind == PBRT_TOKEN_RBRACKET)
                    break;
                if (t.kind == PBRT_TOKEN_EOF) {
                    pbrt_error(P->err, open, "unterminated [ after \"%s %s\"", p->type_name,
                               p->name);
                    goto fail;
                }
                if (t.kind == PBRT_TOKEN_LBRACKET) {
                    pbrt_error(P->err, t.loc, "unexpected [ inside the values of \"%s %s\"",
                               p->type_name, p->name);
                    goto fail;
                }
                if (add_value(P, ps, p, &t) != 0)
                    goto fail;
            }
        } else if (t.kind == PBRT_TOKEN_RBRACKET || t.kind == PBRT_TOKEN_EOF) {
            pbrt_error(P->err, p->loc, "missing value after \"%s %s\"", p->type_name, p->name);
            goto fail;
        } else if (add_value(P, ps, p, &t) != 0) {
            goto fail;
        }
    }
fail:
    params_destroy(&ps);
    return NULL;
}

/* ------------------------------------------------------------------------------------------
 * State helpers
 * ------------------------------------------------------------------------------------------ */

static int need_world(parser_t *P, const char *directive, pbrt_loc_t loc)
{
    if (!P->world)
        return pbrt_error(P->err, loc, "%s is only allowed after WorldBegin", directive);
    return 0;
}

static int need_options(parser_t *P, const char *directive, pbrt_loc_t loc)
{
    if (P->world)
        return pbrt_error(P->err, loc, "%s must come before WorldBegin (line %d)", directive,
                          P->world_loc.line);
    return 0;
}

/* A transform that a shape, light, camera or instance will use must be invertible, affine and
 * finite, or the renderer would meet NaN. */
static int check_transform(parser_t *P, const transform_t *t, const char *user, pbrt_loc_t loc)
{
    if (!transform_is_finite(t))
        return pbrt_error(P->err, loc,
                          "the current transform has non-finite entries, so %s "
                          "cannot use it",
                          user);
    if (!transform_is_affine(t))
        return pbrt_error(P->err, loc,
                          "the current transform is projective (its last row is not "
                          "0 0 0 1), so %s cannot use it",
                          user);
    if (t->singular)
        return pbrt_error(P->err, loc, "the current transform is singular, so %s cannot use it",
                          user);
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(t->m_inv[i][j]))
                return pbrt_error(P->err, loc,
                                  "the current transform is singular, so %s "
                                  "cannot use it",
                                  user);
    return 0;
}

static int push_frame(parser_t *P, int kind, const char *what, pbrt_loc_t loc)
{
    if (P->nframes == P->cap_frames) {
        size_t cap = P->cap_frames ? P->cap_frames * 2 : 16;
        if (cap > 1u << 20)
            return pbrt_error(P->err, loc, "%s nested more than a million deep", what);
        frame_t *f = realloc(P->frames, cap * sizeof *f);
        if (!f)
            return pbrt_error(P->err, loc, "out of memory");
        P->frames = f;
        P->cap_frames = cap;
    }
    P->frames[P->nframes++] = (frame_t){kind, what, loc, P->gs};
    return 0;
}

static int set_coordsys(parser_t *P, const char *name, transform_t t, pbrt_loc_t loc)
{
    for (size_t i = 0; i < P->ncs; i++)
        if (!strcmp(P->cs[i].name, name)) {
            P->cs[i].t = t;
            return 0;
        }
    if (P->ncs == P->cap_cs) {
        size_t cap = P->cap_cs ? P->cap_cs * 2 : 8;
        coordsys_t *c = realloc(P->cs, cap * sizeof *c);
        if (!c)
            return pbrt_error(P->err, loc, "out of memory");
        P->cs = c;
        P->cap_cs = cap;
    }
    char *copy = strdup(name);
    if (!copy)
        return pbrt_error(P->err, loc, "out of memory");
    P->cs[P->ncs++] = (coordsys_t){copy, t};
    return 0;
}

/* dir(base) + name, unless name is absolute or base has no folder. */
static char *resolve_path(const char *base, const char *name)
{
    const char *slash = strrchr(base, '/');
    if (name[0] == '/' || !slash)
        return strdup(name);
    size_t dlen = (size_t)(slash - base) + 1;
    char *out = malloc(dlen + strlen(name) + 1);
    if (!out)
        return NULL;
    memcpy(out, base, dlen);
    strcpy(out + dlen, name);
    return out;
}

/* The path a file name written in the current file is opened by: against the folder of the
 * current file; if nothing is there, against the main file's folder (pbrt-v4 resolves every
 * name against the main file's folder); if neither exists, the first (so that the error names
 * it). malloc'ed. */
static bool present(const parser_t *P, const char *path);

static char *locate(parser_t *P, const char *name)
{
    P->also[0] = '\0';
    char *first = resolve_path(P->file, name);
    if (!first || name[0] == '/' || present(P, first))
        return first;
    char *second = resolve_path(P->main_name, name);
    if (second && strcmp(second, first) != 0 && present(P, second)) {
        free(first);
        return second;
    }
    if (second && strcmp(second, first) != 0)
        snprintf(P->also, sizeof P->also, " (also looked for \"%.480s\")", second);
    free(second);
    return first;
}

/* Resolves a file name given in the current file into a scene-owned string. */
static const char *scene_path(parser_t *P, const char *name, pbrt_loc_t loc)
{
    char *path = locate(P, name);
    if (!path) {
        pbrt_error(P->err, loc, "out of memory");
        return NULL;
    }
    const char *s = scene_desc_strdup(P->scene, path, P->err);
    free(path);
    return s;
}

/* Splits a '/'-separated path into its components, lexically normalised: empty and "."
 * components dropped, "x/.." folded; a ".." that cannot fold is kept in a relative path and
 * dropped at the root of an absolute one. The components point into *copy (malloc'ed, as is
 * the returned array); NULL when out of memory. */
static char **split_path(const char *path, char **copy, size_t *count)
{
    *copy = strdup(path);
    char **parts = malloc((strlen(path) / 2 + 2) * sizeof *parts);
    if (!*copy || !parts) {
        free(*copy);
        free(parts);
        return NULL;
    }
    size_t n = 0;
    char *save = NULL;
    for (char *c = strtok_r(*copy, "/", &save); c; c = strtok_r(NULL, "/", &save)) {
        if (!strcmp(c, "."))
            continue;
        if (!strcmp(c, "..")) {
            if (n > 0 && strcmp(parts[n - 1], "..") != 0) {
                n--;
                continue;
            }
            if (path[0] == '/')
                continue;
        }
        parts[n++] = c;
    }
    *count = n;
    return parts;
}

/* Joins "../" times ups, then parts[from..n) with '/', after a leading '/' if absolute. */
static char *join_path(bool absolute, size_t ups, char **parts, size_t from, size_t n)
{
    size_t len = 2 + 3 * ups;
    for (size_t i = from; i < n; i++)
        len += strlen(parts[i]) + 1;
    char *out = malloc(len);
    if (!out)
        return NULL;
    out[0] = 0;
    if (absolute)
        strcat(out, "/");
    for (size_t k = 0; k < ups; k++)
        strcat(out, k + 1 < ups || from < n ? "../" : "..");
    for (size_t i = from; i < n; i++) {
        strcat(out, parts[i]);
        if (i + 1 < n)
            strcat(out, "/");
    }
    return out;
}

static char *normalise_path(const char *path)
{
    char *copy;
    size_t n;
    char **parts = split_path(path, &copy, &n);
    char *out = parts ? join_path(path[0] == '/', 0, parts, 0, n) : NULL;
    free(parts);
    free(copy);
    return out;
}

/* The folder part of a file name ("" when it has none). malloc'ed. */
static char *folder_of(const char *file)
{
    const char *slash = strrchr(file, '/');
    size_t n = slash ? (size_t)(slash - file) + (slash == file ? 1 : 0) : 0;
    char *d = malloc(n + 1);
    if (d) {
        memcpy(d, file, n);
        d[n] = 0;
    }
    return d;
}

/* An absolute version of a relative path, against the working folder. malloc'ed. */
static char *absolute_path(const char *path)
{
    char cwd[4096];
    if (path[0] == '/' || !getcwd(cwd, sizeof cwd))
        return strdup(path);
    char *out = malloc(strlen(cwd) + strlen(path) + 2);
    if (out)
        sprintf(out, "%s/%s", cwd, path);
    return out;
}

/* path relative to the folder dir, both relative or both absolute: as many ".." as dir has
 * components beyond what the two share, then the rest of path. */
static char *relative_to(const char *dir, const char *path)
{
    char *cd = NULL, *cp = NULL;
    size_t nd = 0, np = 0;
    char **d = split_path(dir, &cd, &nd), **p = split_path(path, &cp, &np);
    char *out = NULL;
    if (d && p) {
        size_t common = 0;
        while (common < nd && common < np && !strcmp(d[common], p[common]))
            common++;
        out = join_path(false, nd - common, p, common, np);
    }
    free(d);
    free(p);
    free(cd);
    free(cp);
    return out;
}

/* ------------------------------------------------------------------------------------------
 * Confinement. A scene that came over the network (a bundle extracted into a folder) may
 * name any path: "/etc/passwd", "../../x", a FIFO that blocks open() for ever, /dev/zero that
 * never ends, a symbolic link to any of those. A confined parse reads only regular files that
 * lie inside its root both lexically ("." and ".." folded) and after every symbolic link is
 * followed (realpath), checks each with realpath and stat before opening it (neither opens
 * the file), opens it without following a final link and without blocking, checks the open
 * descriptor again, and reads at most PBRT_FILE_BYTES_MAX bytes of one file and
 * PBRT_TOTAL_BYTES_MAX in all.
 * ------------------------------------------------------------------------------------------ */

/* A message at *from, or without a location for the main file (from NULL); returns -1. */
__attribute__((format(printf, 3, 4))) static int fail_at(parser_t *P, const pbrt_loc_t *from,
                                                         const char *fmt, ...)
{
    char msg[sizeof P->err->msg];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return from ? pbrt_error(P->err, *from, "%s", msg) : err_set(P->err, "%s", msg);
}

/* Whether path (absolute, normalised) is the folder dir (same form) or lies under it. */
static bool is_under(const char *dir, const char *path)
{
    size_t n = strlen(dir);
    return !strncmp(path, dir, n) &&
           (path[n] == 0 || path[n] == '/' || (n > 0 && dir[n - 1] == '/'));
}

/* The absolute, lexically normalised form of path. malloc'ed. */
static char *lexical_path(const char *path)
{
    char *a = absolute_path(path);
    char *n = a ? normalise_path(a) : NULL;
    free(a);
    return n;
}

/* -1: out of memory; 0: outside; 1: inside. Touches nothing on disk. */
static int lexically_inside(const parser_t *P, const char *path)
{
    char *n = lexical_path(path);
    int in = n ? is_under(P->root_lex, n) : -1;
    free(n);
    return in;
}

/* Whether a candidate file exists, without looking outside the root of a confined parse. */
static bool present(const parser_t *P, const char *path)
{
    return (!P->root_lex || lexically_inside(P, path) == 1) && access(path, F_OK) == 0;
}

/* Counts bytes against the confined parse's total. */
static int charge(parser_t *P, uint64_t bytes, const pbrt_loc_t *from)
{
    if (bytes > PBRT_TOTAL_BYTES_MAX - P->bytes_charged)
        return fail_at(P, from, "the scene reads more than %zu bytes in all", PBRT_TOTAL_BYTES_MAX);
    P->bytes_charged += (size_t)bytes;
    return 0;
}

/* Checks, without opening it, the file path (written as name at *from; the main file when
 * from is NULL; `what` says what it is, for messages): it must lie in the root lexically and
 * after realpath, be a regular file and hold at most PBRT_FILE_BYTES_MAX bytes. Returns its
 * real path (malloc'ed), or NULL with the message. */
static char *confine(parser_t *P, const char *path, const char *name, const pbrt_loc_t *from,
                     const char *what)
{
    int in = lexically_inside(P, path);
    if (in < 0) {
        fail_at(P, from, "out of memory");
        return NULL;
    }
    if (!in) {
        fail_at(P, from, "\"%s\" is outside the scene's folder", name);
        return NULL;
    }
    char *real = realpath(path, NULL);
    if (!real) {
        fail_at(P, from, "cannot open %s \"%s\": %s%s", what, path, strerror(errno), P->also);
        return NULL;
    }
    struct stat st;
    if (!is_under(P->root_real, real)) {
        fail_at(P, from, "\"%s\" is outside the scene's folder", name);
    } else if (stat(real, &st) != 0) {
        fail_at(P, from, "cannot open %s \"%s\": %s", what, path, strerror(errno));
    } else if (!S_ISREG(st.st_mode)) {
        fail_at(P, from, "\"%s\" is not a regular file", name);
    } else if ((uint64_t)st.st_size > PBRT_FILE_BYTES_MAX) {
        fail_at(P, from, "\"%s\" is larger than %zu bytes", name, PBRT_FILE_BYTES_MAX);
    } else {
        return real;
    }
    free(real);
    return NULL;
}

/* Opens a file confine() accepted, checking the open descriptor again (the folder could have
 * changed since): O_NOFOLLOW refuses a final symbolic link, O_NONBLOCK keeps a FIFO from
 * blocking the open. Returns the descriptor and the file's size, or -1 with the message. */
static int open_confined(parser_t *P, const char *real, const char *name, const char *path,
                         const pbrt_loc_t *from, const char *what, size_t *size)
{
    int fd = open(real, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return errno == ELOOP
                   ? fail_at(P, from, "\"%s\" is not a regular file", name)
                   : fail_at(P, from, "cannot open %s \"%s\": %s", what, path, strerror(errno));
    struct stat st;
    int rc = 0;
    if (fstat(fd, &st) != 0)
        rc = fail_at(P, from, "cannot open %s \"%s\": %s", what, path, strerror(errno));
    else if (!S_ISREG(st.st_mode))
        rc = fail_at(P, from, "\"%s\" is not a regular file", name);
    else if ((uint64_t)st.st_size > PBRT_FILE_BYTES_MAX)
        rc = fail_at(P, from, "\"%s\" is larger than %zu bytes", name, PBRT_FILE_BYTES_MAX);
    if (rc != 0) {
        close(fd);
        return -1;
    }
    *size = (size_t)st.st_size;
    return fd;
}

/* Reads a whole file confine() accepted (its size as fstat gives it, charged to the total). */
static char *read_confined(parser_t *P, const char *real, const char *name, const char *path,
                           const pbrt_loc_t *from, const char *what, size_t *len)
{
    size_t size;
    int fd = open_confined(P, real, name, path, from, what, &size);
    if (fd < 0)
        return NULL;
    if (charge(P, size, from) != 0) {
        close(fd);
        return NULL;
    }
    char *buf = malloc(size + 1);
    if (!buf) {
        close(fd);
        fail_at(P, from, "out of memory reading \"%s\"", path);
        return NULL;
    }
    size_t n = 0;
    while (n < size) {
        ssize_t got = read(fd, buf + n, size - n);
        if (got < 0 && errno == EINTR)
            continue;
        if (got <= 0) {
            fail_at(P, from, "cannot read %s \"%s\": %s", what, path,
                    got < 0 ? strerror(errno) : "it ended early");
            free(buf);
            close(fd);
            return NULL;
        }
        n += (size_t)got;
    }
    close(fd);
    *len = n;
    return buf;
}

/* A file that starts with gzip's magic bytes is inflated (pbrt-v4 reads ".gz" scene files
 * and PLYs through zlib) to at most limit bytes, and in a confined parse to what the scene may
 * still read, the inflated bytes charged like a file's: a small file that inflates to
 * gigabytes is refused once it passes the limit. Replaces *buf (which the caller still frees
 * on failure). */
static int inflate_if_gzip(parser_t *P, char **buf, size_t *len, size_t limit, const char *name,
                           const pbrt_loc_t *from)
{
    if (!gzip_data_is_gzip(*buf, *len))
        return 0;
    if (P->root_real && PBRT_TOTAL_BYTES_MAX - P->bytes_charged < limit)
        limit = PBRT_TOTAL_BYTES_MAX - P->bytes_charged;
    char *out;
    size_t n;
    err_t e;
    if (gzip_data_inflate(*buf, *len, limit, name, &out, &n, &e) != 0)
        return fail_at(P, from, "%s", e.msg);
    free(*buf);
    *buf = out;
    *len = n;
    return P->root_real ? charge(P, n, from) : 0;
}

/* An imagemap PNG in a confined parse: its IHDR (PNG specification 11.2.2: the 8-byte
 * signature, then a 13-byte chunk "IHDR" whose data begins with the width and height, 4 bytes
 * big-endian each) says how many pixels decoding makes, 64 bytes each (the 8-bit RGBA that
 * image_png decodes, the float RGB and alpha, and the texture's coefficients), charged with the file's own bytes
 * before anything decodes it. A file that is not a PNG is left to the PNG reader's message. */
static int check_png(parser_t *P, const char *real, const char *name, const char *path,
                     const pbrt_loc_t *from)
{
    size_t size;
    int fd = open_confined(P, real, name, path, from, "image", &size);
    if (fd < 0)
        return -1;
    unsigned char h[24];
    size_t n = 0;
    while (n < sizeof h) {
        ssize_t got = read(fd, h + n, sizeof h - n);
        if (got < 0 && errno == EINTR)
            continue;
        if (got <= 0)
            break;
        n += (size_t)got;
    }
    close(fd);
    uint64_t pixels = 0;
    static const unsigned char SIG[12] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13};
    if (n == sizeof h && !memcmp(h, SIG, sizeof SIG) && !memcmp(h + 12, "IHDR", 4)) {
        uint64_t w = (uint64_t)h[16] << 24 | (uint64_t)h[17] << 16 | (uint64_t)h[18] << 8 | h[19];
        uint64_t ht = (uint64_t)h[20] << 24 | (uint64_t)h[21] << 16 | (uint64_t)h[22] << 8 | h[23];
        pixels = w * ht; /* each below 2^32: no overflow */
    }
    if (pixels > (PBRT_TOTAL_BYTES_MAX - P->bytes_charged) / 64)
        return fail_at(P, from,
                       "image \"%s\" decodes to %llu pixels, more than the scene may "
                       "read (%zu bytes in all)",
                       name, (unsigned long long)pixels, PBRT_TOTAL_BYTES_MAX);
    return charge(P, size + 64 * pixels, from);
}

/* Records a file the scene read (once per relative path): its path as opened and its path
 * relative to the main file's folder. */
static int note_file(parser_t *P, scene_file_kind_t kind, const char *path, const char *name,
                     pbrt_loc_t loc)
{
    bool named_absolute = name[0] == '/';
    char *dir = folder_of(P->main_name), *rel = NULL;
    if (dir && named_absolute) {
        rel = normalise_path(path);
    } else if (dir && (path[0] == '/') != (dir[0] == '/')) {
        /* A relative name under an absolutely named folder, or the reverse: compare both as
         * absolute paths. */
        char *a = absolute_path(path), *b = absolute_path(dir);
        rel = a && b ? relative_to(b, a) : NULL;
        free(a);
        free(b);
    } else if (dir) {
        rel = relative_to(dir, path);
    }
    free(dir);
    if (!rel)
        return pbrt_error(P->err, loc, "out of memory");
    int rc = 0;
    if (scene_desc_find_file(P->scene, rel) < 0) {
        int idx = scene_desc_add_file(P->scene, P->err);
        const char *sp = idx >= 0 ? scene_desc_strdup(P->scene, path, P->err) : NULL;
        const char *sr = sp ? scene_desc_strdup(P->scene, rel, P->err) : NULL;
        if (!sr) {
            rc = -1;
        } else {
            scene_file_t *f = &P->scene->files[idx];
            f->kind = kind;
            f->path = sp;
            f->relative = sr;
            f->outside = named_absolute || !strcmp(rel, "..") || !strncmp(rel, "../", 3);
            f->loc = loc;
        }
    }
    free(rel);
    return rc;
}

/* ------------------------------------------------------------------------------------------
 * Spectra, float and spectrum inputs
 * ------------------------------------------------------------------------------------------ */

static scene_spectrum_t spectrum_constant(double v, pbrt_loc_t loc)
{
    return (scene_spectrum_t){.kind = SCENE_SPECTRUM_CONSTANT, .constant = v, .loc = loc};
}

static scene_spectrum_t spectrum_named(const char *name, pbrt_loc_t loc)
{
    return (scene_spectrum_t){.kind = SCENE_SPECTRUM_NAMED, .name = name, .loc = loc};
}

enum { SPECTRUM_ANY, SPECTRUM_ALBEDO };

/* A number of a spectrum file and the line it is on. */
typedef struct spd_number {
    double v;
    int line;
} spd_number_t;

/* pbrt-v4's spectrum file (util/file.cpp ReadFloatFile, spectrum.cpp
 * PiecewiseLinearSpectrum::Read): numbers -- a run of [0-9.eE+-] that starts with a digit,
 * '.', '+' or '-' -- separated by white space, '#' to the end of the line a comment; the
 * numbers are (wavelength nm, value) pairs, wavelengths strictly increasing. pbrt-v4 also
 * skips other text with a warning (so a comma separates numbers too); prismfarm accepts commas
 * and refuses any other text, naming the line. Fills out (SAMPLED, arrays in the scene). */
static int parse_spd(parser_t *P, const param_t *p, const char *path, const char *text, size_t len,
                     int use, scene_spectrum_t *out)
{
    size_t cap = 64, n = 0;
    spd_number_t *num = malloc(cap * sizeof *num);
    if (!num)
        return pbrt_error(P->err, p->loc, "out of memory reading spectrum file \"%s\"", path);
    int line = 1, rc = 0;
    for (size_t i = 0; i < len && rc == 0;) {
        char c = text[i];
        if (c == '\n') {
            line++;
            i++;
        } else if (c == '#') {
            while (i < len && text[i] != '\n')
                i++;
        } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v' || c == ',') {
            i++;
        } else if ((c >= '0' && c <= '9') || c == '.' || c == '+' || c == '-') {
            size_t j = i;
            while (j < len && ((text[j] >= '0' && text[j] <= '9') || text[j] == '.' ||
                               text[j] == 'e' || text[j] == 'E' || text[j] == '+' || text[j] == '-'))
                j++;
            char tok[64];
            size_t tl = j - i < sizeof tok - 1 ? j - i : sizeof tok - 1;
            memcpy(tok, text + i, tl);
            tok[tl] = 0;
            char *end = NULL;
            double v = j - i < sizeof tok - 1 ? strtod(tok, &end) : NAN;
            if (!end || *end || !isfinite(v)) {
                rc = pbrt_error(P->err, p->loc,
                                "spectrum file \"%s\", line %d: \"%s\" is not a finite number",
                                path, line, tok);
                break;
            }
            if (n == cap) {
                spd_number_t *grown = realloc(num, 2 * cap * sizeof *num);
                if (!grown) {
                    rc = pbrt_error(P->err, p->loc, "out of memory reading spectrum file \"%s\"",
                                    path);
                    break;
                }
                num = grown;
                cap *= 2;
            }
            num[n++] = (spd_number_t){v, line};
            i = j;
        } else {
            char shown[24];
            size_t k = 0;
            while (i + k < len && k < 16 && text[i + k] != '\n' && text[i + k] != '\r')
                k++;
            memcpy(shown, text + i, k);
            shown[k] = 0;
            rc = pbrt_error(P->err, p->loc,
                            "spectrum file \"%s\", line %d: unexpected text \"%s\" (expected "
                            "numbers, '#' comments, spaces or commas)",
                            path, line, shown);
        }
    }
    if (rc == 0 && n == 0)
        rc = pbrt_error(P->err, p->loc, "spectrum file \"%s\" holds no numbers", path);
    if (rc == 0 && n % 2 != 0)
        rc = pbrt_error(P->err, p->loc,
                        "spectrum file \"%s\" holds %zu numbers, an odd count: it needs "
                        "(wavelength, value) pairs (the last number is on line %d)",
                        path, n, num[n - 1].line);
    for (size_t i = 0; rc == 0 && i < n / 2; i++) {
        const spd_number_t *l = &num[2 * i], *v = &num[2 * i + 1];
        if (!(l->v > 0.0))
            rc = pbrt_error(P->err, p->loc,
                            "spectrum file \"%s\", line %d: wavelength %g nm is not positive",
                            path, l->line, l->v);
        else if (i > 0 && !(l->v > num[2 * i - 2].v))
            rc = pbrt_error(P->err, p->loc,
                            "spectrum file \"%s\", line %d: wavelength %g nm does not follow %g "
                            "nm (line %d): wavelengths must increase",
                            path, l->line, l->v, num[2 * i - 2].v, num[2 * i - 2].line);
        else if (use == SPECTRUM_ALBEDO && (v->v < 0.0 || v->v > 1.0))
            rc = pbrt_error(P->err, p->loc,
                            "spectrum file \"%s\", line %d: value %g is outside [0, 1] (a "
                            "reflectance)",
                            path, v->line, v->v);
    }
    double *lv = rc == 0 ? scene_desc_alloc(P->scene, n * sizeof *lv, P->err) : NULL;
    if (rc == 0 && !lv)
        rc = -1;
    if (rc == 0) {
        size_t pairs = n / 2;
        for (size_t i = 0; i < pairs; i++) {
            lv[i] = num[2 * i].v;
            lv[pairs + i] = num[2 * i + 1].v;
        }
        out->kind = SCENE_SPECTRUM_SAMPLED;
        out->count = pairs;
        out->lambda = lv;
        out->value = lv + pairs;
    }
    free(num);
    return rc;
}

/* Reads a whole spectrum file of the user's own (unconfined) scene. */
static char *read_file_unconfined(parser_t *P, const param_t *p, const char *path, const char *what,
                                  size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        pbrt_error(P->err, p->loc, "cannot open %s \"%s\": %s", what, path, strerror(errno));
        return NULL;
    }
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        if (cap > PBRT_FILE_BYTES_MAX) {
            free(buf);
            fclose(f);
            pbrt_error(P->err, p->loc, "\"%s\" is larger than %zu bytes", path, PBRT_FILE_BYTES_MAX);
            return NULL;
        }
        char *nb = realloc(buf, cap * 2);
        if (!nb)
            free(buf);
        buf = nb;
        cap *= 2;
    }
    int bad = ferror(f);
    fclose(f);
    if (!buf || bad) {
        free(buf);
        pbrt_error(P->err, p->loc, "cannot read %s \"%s\"", what, path);
        return NULL;
    }
    *len = n;
    return buf;
}

static char *read_spd_unconfined(parser_t *P, const param_t *p, const char *path, size_t *len)
{
    return read_file_unconfined(P, p, path, "spectrum file", len);
}

/* A string given for a spectrum (pbrt-v4 paramdict.cpp: a named spectrum, else a spectrum file
 * resolved like every file name). The parser cannot know the names (they live in spectral/,
 * which scenefile does not use), so: a name that is a file -- in the current file's folder,
 * else the main file's (pbrt-v4's rule), inside the root of a confined parse -- or that holds a
 * '/' is read as a spectrum file now, listed among the files read (so bundles carry it) and
 * confined like a PLY; any other string is kept as NAMED with the files looked for, and the
 * loader resolves it or names both. A file named like a named spectrum ("glass-BK7" with no
 * extension) is read, but the loader gives the named spectrum precedence, as pbrt-v4 does. */
static int spectrum_string(parser_t *P, const param_t *p, const char *name, int use,
                           scene_spectrum_t *out)
{
    char *first = resolve_path(P->file, name), *second = resolve_path(P->main_name, name);
    if (!first || !second) {
        free(first);
        free(second);
        return pbrt_error(P->err, p->loc, "out of memory");
    }
    bool two = name[0] != '/' && strcmp(first, second) != 0;
    const char *path = present(P, first) ? first : two && present(P, second) ? second : NULL;
    char searched[2 * NAME_MAX_LEN + 16];
    if (two)
        snprintf(searched, sizeof searched, "\"%s\" and \"%s\"", first, second);
    else
        snprintf(searched, sizeof searched, "\"%s\"", first);
    int rc = 0;
    if (!path && !strchr(name, '/')) {
        out->kind = SCENE_SPECTRUM_NAMED;
        out->name = scene_desc_strdup(P->scene, name, P->err);
        out->searched = out->name ? scene_desc_strdup(P->scene, searched, P->err) : NULL;
        rc = out->searched ? 0 : -1;
    } else if (!path && !(P->root_lex && lexically_inside(P, first) == 0)) {
        rc = pbrt_error(P->err, p->loc,
                        "\"%s\" is not a named spectrum, and no spectrum file is there (looked "
                        "for %s)",
                        name, searched);
    } else {
        /* Outside a confined parse's root, confine() refuses it with its usual message. */
        const char *use_path = path ? path : first;
        size_t len = 0;
        char *buf = NULL;
        if (P->root_real) {
            char *real = confine(P, use_path, name, &p->loc, "spectrum file");
            buf = real ? read_confined(P, real, name, use_path, &p->loc, "spectrum file", &len)
                       : NULL;
            free(real);
        } else {
            buf = read_spd_unconfined(P, p, use_path, &len);
        }
        rc = buf ? parse_spd(P, p, use_path, buf, len, use, out) : -1;
        free(buf);
        if (rc == 0) {
            out->name = scene_desc_strdup(P->scene, name, P->err);
            out->file = out->name ? scene_desc_strdup(P->scene, use_path, P->err) : NULL;
            rc = out->file ? note_file(P, SCENE_FILE_SPECTRUM, use_path, name, p->loc) : -1;
        }
    }
    free(first);
    free(second);
    return rc;
}

/* A spectrum-valued parameter in its raw form: float (constant), rgb, blackbody, or spectrum
 * given as (lambda, value) pairs or by name (pbrt-v4 paramdict.cpp extractSpectrumArray). */
static int spectrum_from_param(parser_t *P, params_t *ps, const param_t *p, int use,
                               scene_spectrum_t *out)
{
    memset(out, 0, sizeof *out);
    out->loc = p->loc;
    switch (p->type) {
    case PARAM_FLOAT:
        if (p->count != 1)
            return pbrt_error(P->err, p->loc, "expected 1 number after \"%s %s\", got %zu",
                              p->type_name, p->name, p->count);
        if (use == SPECTRUM_ALBEDO && (p->numbers[0] < 0.0 || p->numbers[0] > 1.0))
            return pbrt_error(P->err, p->loc, "\"%s %s\" must be within [0, 1], got %g",
                              p->type_name, p->name, p->numbers[0]);
        out->kind = SCENE_SPECTRUM_CONSTANT;
        out->constant = p->numbers[0];
        return 0;
    case PARAM_RGB:
        if (p->count != 3)
            return pbrt_error(P->err, p->loc, "expected 3 numbers after \"%s %s\", got %zu",
                              p->type_name, p->name, p->count);
        for (int i = 0; i < 3; i++) {
            if (p->numbers[i] < 0.0)
                return pbrt_error(P->err, p->loc, "\"%s %s\" has a negative component",
                                  p->type_name, p->name);
            if (use == SPECTRUM_ALBEDO && p->numbers[i] > 1.0)
                return pbrt_error(P->err, p->loc,
                                  "\"%s %s\" has a component above 1 (a "
                                  "reflectance is at most 1)",
                                  p->type_name, p->name);
            out->rgb[i] = p->numbers[i];
        }
        out->kind = SCENE_SPECTRUM_RGB;
        return 0;
    case PARAM_BLACKBODY:
        if (p->count != 1)
            return pbrt_error(P->err, p->loc,
                              "expected 1 number after \"%s %s\", got %zu "
                              "(pbrt-v4 takes only the temperature)",
                              p->type_name, p->name, p->count);
        if (!(p->numbers[0] > 0.0))
            return pbrt_error(P->err, p->loc, "\"%s %s\" needs a temperature above 0 K, got %g",
                              p->type_name, p->name, p->numbers[0]);
        out->kind = SCENE_SPECTRUM_BLACKBODY;
        out->temperature = p->numbers[0];
        return 0;
    case PARAM_SPECTRUM:
        if (p->values == PARAM_VALUES_STRINGS) {
            if (p->count != 1)
                return pbrt_error(P->err, p->loc, "expected 1 string after \"%s %s\", got %zu",
                                  p->type_name, p->name, p->count);
            const char *name = p->strings[0];
            if (!*name)
                return pbrt_error(P->err, p->loc, "empty spectrum name in \"%s %s\"", p->type_name,
                                  p->name);
            return spectrum_string(P, p, name, use, out);
        }
        if (p->count == 0)
            return pbrt_error(P->err, p->loc, "no values after \"%s %s\"", p->type_name, p->name);
        if (p->count % 2 != 0)
            return pbrt_error(P->err, p->loc,
                              "\"%s %s\" needs (wavelength, value) pairs, got %zu "
                              "numbers",
                              p->type_name, p->name, p->count);
        size_t n = p->count / 2;
        for (size_t i = 0; i < n; i++) {
            double l = p->numbers[2 * i], v = p->numbers[2 * i + 1];
            if (!(l > 0.0))
                return pbrt_error(P->err, p->loc,
                                  "\"%s %s\": wavelength %g in pair %zu is not "
                                  "positive",
                                  p->type_name, p->name, l, i + 1);
            if (i > 0 && !(l > p->numbers[2 * i - 2]))
                return pbrt_error(P->err, p->loc,
                                  "\"%s %s\": wavelengths must increase, but pair "
                                  "%zu has %g nm after %g nm",
                                  p->type_name, p->name, i + 1, l, p->numbers[2 * i - 2]);
            if (use == SPECTRUM_ALBEDO && (v < 0.0 || v > 1.0))
                return pbrt_error(P->err, p->loc,
                                  "\"%s %s\": value %g in pair %zu is outside "
                                  "[0, 1] (a reflectance)",
                                  p->type_name, p->name, v, i + 1);
        }
        double *lv = scene_desc_alloc(P->scene, 2 * n * sizeof *lv, P->err);
        if (!lv)
            return -1;
        for (size_t i = 0; i < n; i++) {
            lv[i] = p->numbers[2 * i];
            lv[n + i] = p->numbers[2 * i + 1];
        }
        out->kind = SCENE_SPECTRUM_SAMPLED;
        out->count = n;
        out->lambda = lv;
        out->value = lv + n;
        return 0;
    default:
        break;
    }
    char expected[256];
    snprintf(expected, sizeof expected,
             "\"spectrum %s\", \"rgb %s\", \"blackbody %s\" or \"float %s\"", p->name, p->name,
             p->name, p->name);
    return params_wrong_type(ps, p, expected, P->err);
}

static int get_spectrum(parser_t *P, params_t *ps, const char *name, scene_spectrum_t def, int use,
                        scene_spectrum_t *out)
{
    param_t *p = params_find(ps, name);
    if (!p) {
        *out = def;
        return 0;
    }
    return spectrum_from_param(P, ps, p, use, out);
}

static int texture_ref(parser_t *P, params_t *ps, const param_t *p, scene_texture_type_t type,
                       int *out)
{
    (void)ps;
    if (p->count != 1)
        return pbrt_error(P->err, p->loc, "expected 1 string after \"%s %s\", got %zu",
                          p->type_name, p->name, p->count);
    int t = scene_desc_find_texture(P->scene, p->strings[0], type);
    if (t >= 0) {
        *out = t;
        return 0;
    }
    const char *want = type == SCENE_TEXTURE_FLOAT ? "float" : "spectrum";
    const char *other = type == SCENE_TEXTURE_FLOAT ? "spectrum" : "float";
    if (scene_desc_find_texture(P->scene, p->strings[0],
                                type == SCENE_TEXTURE_FLOAT ? SCENE_TEXTURE_SPECTRUM
                                                            : SCENE_TEXTURE_FLOAT) >= 0)
        return pbrt_error(P->err, p->loc,
                          "texture \"%s\" is a %s texture, but \"%s\" needs a %s "
                          "texture",
                          p->strings[0], other, p->name, want);
    return pbrt_error(P->err, p->loc,
                      "%s texture \"%s\" is not defined (a Texture must come "
                      "before its use)",
                      want, p->strings[0]);
}

static int get_float_input(parser_t *P, params_t *ps, const char *name, double def,
                           scene_float_input_t *out)
{
    out->texture = -1;
    out->value = def;
    param_t *p = params_find(ps, name);
    if (!p)
        return 0;
    if (p->type == PARAM_TEXTURE)
        return texture_ref(P, ps, p, SCENE_TEXTURE_FLOAT, &out->texture);
    if (p->type != PARAM_FLOAT) {
        char expected[160];
        snprintf(expected, sizeof expected, "\"float %s\" or \"texture %s\"", name, name);
        return params_wrong_type(ps, p, expected, P->err);
    }
    if (p->count != 1)
        return pbrt_error(P->err, p->loc, "expected 1 number after \"%s %s\", got %zu",
                          p->type_name, p->name, p->count);
    out->value = p->numbers[0];
    return 0;
}

static int get_spectrum_input(parser_t *P, params_t *ps, const char *name, scene_spectrum_t def,
                              int use, scene_spectrum_input_t *out)
{
    out->texture = -1;
    out->spectrum = def;
    param_t *p = params_find(ps, name);
    if (!p)
        return 0;
    if (p->type == PARAM_TEXTURE)
        return texture_ref(P, ps, p, SCENE_TEXTURE_SPECTRUM, &out->texture);
    return spectrum_from_param(P, ps, p, use, &out->spectrum);
}

static int check_positive(parser_t *P, params_t *ps, const char *name, double v)
{
    if (v > 0.0)
        return 0;
    param_t *p = params_find(ps, name);
    return pbrt_error(P->err, p ? p->loc : (pbrt_loc_t){P->file, 0, 0},
                      "\"%s %s\" must be greater than 0, got %g", p ? p->type_name : "float", name,
                      v);
}

static int check_range(parser_t *P, params_t *ps, const char *name, double v, double lo, double hi)
{
    if (v >= lo && v <= hi)
        return 0;
    param_t *p = params_find(ps, name);
    return pbrt_error(P->err, p ? p->loc : (pbrt_loc_t){P->file, 0, 0},
                      "\"%s %s\" must be within [%g, %g], got %g", p ? p->type_name : "float", name,
                      lo, hi, v);
}

/* ------------------------------------------------------------------------------------------
 * Options: Camera, Film, Sampler, Integrator
 * ------------------------------------------------------------------------------------------ */

/* pbrt-v4's RealisticCamera parameters: the lens file (read here, resolved like every file
 * name and listed in files), the stop's diameter (mm) and the focus distance; prismfarm's
 * "string glasses" names a glass per lens-file line. The aperture image is not simulated. */
static int do_camera_lens(parser_t *P, params_t *ps, scene_camera_t *c, pbrt_loc_t loc)
{
    const char *name;
    param_t *glasses;
    if (params_get_string(ps, "lensfile", "", &name, P->err) != 0 ||
        params_get_float(ps, "aperturediameter", 1.0, &c->aperturediameter, P->err) != 0 ||
        params_get_float(ps, "focusdistance", 10.0, &c->focusdistance, P->err) != 0 ||
        params_get_array(ps, "glasses", PARAM_STRING, &glasses, P->err) != 0)
        return -1;
    if (check_positive(P, ps, "aperturediameter", c->aperturediameter) != 0 ||
        check_positive(P, ps, "focusdistance", c->focusdistance) != 0)
        return -1;
    param_t *lp = params_find(ps, "lensfile");
    if (!lp || !*name)
        return pbrt_error(P->err, loc, "Camera \"realistic\" needs \"string lensfile\"");
    const char *aperture;
    if (params_get_string(ps, "aperture", "", &aperture, P->err) != 0)
        return -1;
    if (*aperture && warnings_add(P->scene->warnings, params_find(ps, "aperture")->loc,
                                  "\"string aperture\" \"%s\" is not simulated: the stop is round", aperture))
        return err_set(P->err, "out of memory");
    if (glasses) {
        c->glasses = scene_desc_alloc(P->scene, glasses->count * sizeof *c->glasses, P->err);
        if (!c->glasses)
            return -1;
        for (size_t i = 0; i < glasses->count; i++)
            if (!(c->glasses[i] = scene_desc_strdup(P->scene, glasses->strings[i], P->err)))
                return -1;
        c->nglasses = (int)glasses->count;
        c->glasses_loc = glasses->loc;
    }
    char *first = resolve_path(P->file, name), *second = resolve_path(P->main_name, name);
    if (!first || !second) {
        free(first);
        free(second);
        return pbrt_error(P->err, lp->loc, "out of memory");
    }
    const char *path = present(P, first) ? first : present(P, second) ? second : first;
    size_t len = 0;
    char *buf = NULL;
    if (P->root_real) {
        char *real = confine(P, path, name, &lp->loc, "lens file");
        buf = real ? read_confined(P, real, name, path, &lp->loc, "lens file", &len) : NULL;
        free(real);
    } else {
        buf = read_file_unconfined(P, lp, path, "lens file", &len);
    }
    int rc = -1;
    if (buf) {
        c->lens_text = scene_desc_alloc(P->scene, len + 1, P->err);
        c->lens_path = c->lens_text ? scene_desc_strdup(P->scene, path, P->err) : NULL;
        if (c->lens_path) {
            memcpy(c->lens_text, buf, len);
            c->lens_text[len] = 0;
            c->lens_len = len;
            c->lens_loc = lp->loc;
            rc = note_file(P, SCENE_FILE_LENS, path, name, lp->loc);
        }
    }
    free(buf);
    free(first);
    free(second);
    return rc;
}

/* pbrt-v4's cameras.cpp: the perspective camera (fov, thin lens), the orthographic one
 * (thin lens too, no fov), the spherical one (mapping); the screen window and frame aspect of
 * the first two; the shutter, which prismfarm has no use for (no motion blur). */
static int do_camera(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    scene_camera_t *c = &P->scene->camera;
    static const char *TYPES[] = {"perspective", "orthographic", "spherical", "realistic"};
    size_t k = 0;
    while (k < COUNT_OF(TYPES) && strcmp(type->s, TYPES[k]) != 0)
        k++;
    if (k == COUNT_OF(TYPES))
        return pbrt_error(P->err, type->loc,
                          "unsupported camera \"%s\" (\"perspective\", \"orthographic\", "
                          "\"spherical\" or \"realistic\")",
                          type->s);
    if (check_transform(P, &P->gs.ctm, "Camera", loc) != 0)
        return -1;
    c->type = TYPES[k];
    c->loc = loc;
    double open_t, close_t;
    if (params_get_float(ps, "shutteropen", 0.0, &open_t, P->err) != 0 ||
        params_get_float(ps, "shutterclose", 1.0, &close_t, P->err) != 0)
        return -1;
    if (k == 3) {
        if (do_camera_lens(P, ps, c, loc) != 0)
            return -1;
    } else if (k == 2) {
        const char *mapping;
        if (params_get_string(ps, "mapping", "equalarea", &mapping, P->err) != 0)
            return -1;
        if (strcmp(mapping, "equalarea") != 0 && strcmp(mapping, "equirectangular") != 0)
            return pbrt_error(P->err, params_find(ps, "mapping")->loc,
                              "\"string mapping\" must be \"equalarea\" or \"equirectangular\", "
                              "got \"%s\"",
                              mapping);
        c->equirect = !strcmp(mapping, "equirectangular");
    } else {
        if ((k == 0 && params_get_float(ps, "fov", 90.0, &c->fov, P->err) != 0) ||
            params_get_float(ps, "lensradius", 0.0, &c->lensradius, P->err) != 0 ||
            params_get_float(ps, "focaldistance", 1e6, &c->focaldistance, P->err) != 0 ||
            params_get_float(ps, "frameaspectratio", 0.0, &c->frameaspectratio, P->err) != 0)
            return -1;
        param_t *w;
        if (params_get_array(ps, "screenwindow", PARAM_FLOAT, &w, P->err) != 0)
            return -1;
        if (w) {
            if (w->count != 4 || !(w->numbers[0] < w->numbers[1]) || !(w->numbers[2] < w->numbers[3]))
                return pbrt_error(P->err, w->loc,
                                  "\"float screenwindow\" needs 4 numbers x0 < x1, y0 < y1, got %zu",
                                  w->count);
            memcpy(c->screenwindow, w->numbers, sizeof c->screenwindow);
        }
        if (params_find(ps, "frameaspectratio") && !(c->frameaspectratio > 0.0))
            return check_positive(P, ps, "frameaspectratio", c->frameaspectratio);
        if (k == 0 && !(c->fov > 0.0 && c->fov < 180.0)) {
            param_t *p = params_find(ps, "fov");
            return pbrt_error(P->err, p->loc,
                              "\"float fov\" must be between 0 and 180 degrees, "
                              "got %g",
                              c->fov);
        }
        if (check_range(P, ps, "lensradius", c->lensradius, 0.0, INFINITY) != 0 ||
            check_positive(P, ps, "focaldistance", c->focaldistance) != 0)
            return -1;
    }
    if (open_t != close_t && (params_find(ps, "shutteropen") || params_find(ps, "shutterclose")) &&
        warnings_add(P->scene->warnings, loc,
                     "the shutter (%g to %g) is accepted, but motion blur is not simulated", open_t,
                     close_t))
        return err_set(P->err, "out of memory");
    /* pbrt-v4 scene.cpp: the CTM at Camera is camera-from-world, and the named coordinate
     * system "camera" is its inverse. */
    c->camera_from_world = P->gs.ctm;
    c->medium = P->gs.outside_medium;
    return set_coordsys(P, "camera", transform_inverse(P->gs.ctm), loc);
}

static int film_warn(parser_t *P, params_t *ps, const char *name, const char *text)
{
    param_t *p = params_find(ps, name);
    if (warnings_add(P->scene->warnings, p->loc, "%s", text) != 0)
        return err_set(P->err, "out of memory");
    return 0;
}

/* pbrt-v4's FilmBase and PixelSensor parameters (film.cpp): the sensor's imaging ratio, the
 * per-sample clamp, the part of the image rendered; what is not simulated warns. */
static int do_film_sensor(parser_t *P, params_t *ps, scene_film_t *f)
{
    const char *sensor;
    bool fp16;
    if (params_get_float(ps, "iso", 100.0, &f->iso, P->err) != 0 ||
        params_get_float(ps, "exposuretime", 1.0, &f->exposuretime, P->err) != 0 ||
        params_get_float(ps, "whitebalance", 0.0, &f->whitebalance, P->err) != 0 ||
        params_get_string(ps, "sensor", "cie1931", &sensor, P->err) != 0 ||
        params_get_float(ps, "maxcomponentvalue", INFINITY, &f->maxcomponentvalue, P->err) != 0 ||
        params_get_float(ps, "diagonal", 35.0, &f->diagonal, P->err) != 0 ||
        params_get_bool(ps, "savefp16", true, &fp16, P->err) != 0)
        return -1;
    if (check_range(P, ps, "iso", f->iso, 0.0, INFINITY) != 0 ||
        check_range(P, ps, "exposuretime", f->exposuretime, 0.0, INFINITY) != 0 ||
        check_range(P, ps, "whitebalance", f->whitebalance, 0.0, INFINITY) != 0 ||
        check_positive(P, ps, "diagonal", f->diagonal) != 0)
        return -1;
    if (params_find(ps, "maxcomponentvalue") && !(f->maxcomponentvalue > 0.0))
        return pbrt_error(P->err, params_find(ps, "maxcomponentvalue")->loc,
                          "\"float maxcomponentvalue\" must be positive, got %g", f->maxcomponentvalue);
    /* The sensor's name is checked by the loader against the sensors it has (spectral/sensor.h). */
    f->sensor = scene_desc_strdup(P->scene, sensor, P->err);
    if (!f->sensor)
        return -1;
    f->sensor_loc = params_find(ps, "sensor") ? params_find(ps, "sensor")->loc : f->loc;
    f->whitebalance_loc = params_find(ps, "whitebalance") ? params_find(ps, "whitebalance")->loc : f->loc;
    /* The EXR is always float32 (prismfarm's spectral layers); pbrt-v4's default is half. */
    if (params_find(ps, "savefp16") && fp16 &&
        film_warn(P, ps, "savefp16", "\"bool savefp16\" is not simulated: the EXR is written as float32") != 0)
        return -1;
    param_t *cw, *pb;
    if (params_get_array(ps, "cropwindow", PARAM_FLOAT, &cw, P->err) != 0 ||
        params_get_array(ps, "pixelbounds", PARAM_INTEGER, &pb, P->err) != 0)
        return -1;
    if (cw && cw->count != 4)
        return pbrt_error(P->err, cw->loc, "\"float cropwindow\" needs 4 values (x0 x1 y0 y1), got %zu", cw->count);
    if (pb && pb->count != 4)
        return pbrt_error(P->err, pb->loc, "\"integer pixelbounds\" needs 4 values (x0 x1 y0 y1), got %zu", pb->count);
    f->has_crop = cw != NULL;
    f->has_pixelbounds = pb != NULL;
    for (int i = 0; i < 4; i++) {
        if (cw)
            f->cropwindow[i] = cw->numbers[i];
        if (pb) {
            if (!(fabs(pb->numbers[i]) <= 65536.0))
                return pbrt_error(P->err, pb->loc, "\"integer pixelbounds\" value %g is out of range", pb->numbers[i]);
            f->pixelbounds[i] = (int)pb->numbers[i];
        }
    }
    if (cw && pb &&
        film_warn(P, ps, "pixelbounds",
                  "both \"pixelbounds\" and \"cropwindow\" are given: the crop window is used (pbrt-v4)") != 0)
        return -1;
    f->crop_loc = cw ? cw->loc : pb ? pb->loc : f->loc;
    return 0;
}

/* PixelFilter "type" (pbrt-v4 filters.cpp: xradius, yradius and each filter's own). */
static int do_pixelfilter(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    static const char *FILTERS[] = {"box", "gaussian", "mitchell", "sinc", "triangle"};
    static const double RADIUS[] = {0.5, 1.5, 2.0, 4.0, 2.0};
    size_t k = 0;
    while (k < COUNT_OF(FILTERS) && strcmp(FILTERS[k], type->s) != 0)
        k++;
    if (k == COUNT_OF(FILTERS))
        return pbrt_error(P->err, type->loc,
                          "unsupported filter \"%s\" (\"box\", \"gaussian\", \"mitchell\", \"sinc\" or "
                          "\"triangle\")",
                          type->s);
    scene_filter_t *f = &P->scene->filter;
    f->type = FILTERS[k];
    f->loc = loc;
    if (params_get_float(ps, "xradius", RADIUS[k], &f->xradius, P->err) != 0 ||
        params_get_float(ps, "yradius", RADIUS[k], &f->yradius, P->err) != 0 ||
        check_range(P, ps, "xradius", f->xradius, 1e-3, 64.0) != 0 ||
        check_range(P, ps, "yradius", f->yradius, 1e-3, 64.0) != 0)
        return -1;
    if (!strcmp(f->type, "gaussian"))
        return params_get_float(ps, "sigma", 0.5, &f->sigma, P->err) ||
               check_positive(P, ps, "sigma", f->sigma);
    if (!strcmp(f->type, "mitchell"))
        return params_get_float(ps, "B", 1.0 / 3.0, &f->b, P->err) ||
               params_get_float(ps, "C", 1.0 / 3.0, &f->c, P->err);
    if (!strcmp(f->type, "sinc"))
        return params_get_float(ps, "tau", 3.0, &f->tau, P->err) || check_positive(P, ps, "tau", f->tau);
    return 0;
}

static int do_film(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    scene_film_t *f = &P->scene->film;
    int nb_def;
    double lmin_def, lmax_def;
    if (!strcmp(type->s, "rgb")) {
        f->type = SCENE_FILM_RGB;
        nb_def = SCENE_RGB_NBUCKETS_DEFAULT;
        lmin_def = SCENE_RGB_LAMBDA_MIN_DEFAULT;
        lmax_def = SCENE_RGB_LAMBDA_MAX_DEFAULT;
    } else if (!strcmp(type->s, "gbuffer")) {
        /* pbrt-v4's GBufferFilm is an RGB film plus albedo, normal and depth layers. */
        f->type = SCENE_FILM_RGB;
        nb_def = SCENE_RGB_NBUCKETS_DEFAULT;
        lmin_def = SCENE_RGB_LAMBDA_MIN_DEFAULT;
        lmax_def = SCENE_RGB_LAMBDA_MAX_DEFAULT;
        const char *cs;
        if (params_get_string(ps, "coordinatesystem", "camera", &cs, P->err) != 0)
            return -1;
        if (warnings_add(P->scene->warnings, type->loc,
                         "Film \"gbuffer\" is rendered as \"rgb\": its albedo, normal and depth "
                         "layers are not written") != 0)
            return err_set(P->err, "out of memory");
    } else if (!strcmp(type->s, "spectral")) {
        f->type = SCENE_FILM_SPECTRAL;
        nb_def = SCENE_SPECTRAL_NBUCKETS_DEFAULT;
        lmin_def = SCENE_SPECTRAL_LAMBDA_MIN_DEFAULT;
        lmax_def = SCENE_SPECTRAL_LAMBDA_MAX_DEFAULT;
    } else {
        return pbrt_error(P->err, type->loc,
                          "unsupported film \"%s\" (\"rgb\", \"gbuffer\" or \"spectral\")", type->s);
    }
    f->loc = loc;
    const char *filename;
    if (params_get_int(ps, "xresolution", SCENE_FILM_XRES_DEFAULT, &f->xres, P->err) != 0 ||
        params_get_int(ps, "yresolution", SCENE_FILM_YRES_DEFAULT, &f->yres, P->err) != 0 ||
        params_get_string(ps, "filename", "pbrt.exr", &filename, P->err) != 0 ||
        params_get_int(ps, "nbuckets", nb_def, &f->nbuckets, P->err) != 0 ||
        params_get_float(ps, "lambdamin", lmin_def, &f->lambda_min, P->err) != 0 ||
        params_get_float(ps, "lambdamax", lmax_def, &f->lambda_max, P->err) != 0)
        return -1;
    if (check_range(P, ps, "xresolution", f->xres, 1, 65536) != 0 ||
        check_range(P, ps, "yresolution", f->yres, 1, 65536) != 0 ||
        check_range(P, ps, "nbuckets", f->nbuckets, 1, 1024) != 0 ||
        check_range(P, ps, "lambdamin", f->lambda_min, 1.0, 100000.0) != 0 ||
        check_range(P, ps, "lambdamax", f->lambda_max, 1.0, 100000.0) != 0)
        return -1;
    if (!(f->lambda_min < f->lambda_max))
        return pbrt_error(P->err, loc, "Film: \"lambdamin\" (%g) must be below \"lambdamax\" (%g)",
                          f->lambda_min, f->lambda_max);
    f->filename = scene_desc_strdup(P->scene, filename, P->err);
    if (!f->filename || do_film_sensor(P, ps, f) != 0)
        return -1;
    return 0;
}

static int do_sampler(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    scene_sampler_t *s = &P->scene->sampler;
    if (!in_list(type->s, SAMPLERS, COUNT_OF(SAMPLERS)))
        return pbrt_error(P->err, type->loc, "unsupported sampler \"%s\"", type->s);
    s->type = scene_desc_strdup(P->scene, type->s, P->err);
    if (!s->type)
        return -1;
    s->loc = loc;
    P->sampler_seed_given = params_find(ps, "seed") != NULL;
    if (params_get_int(ps, "seed", 0, &s->seed, P->err) != 0)
        return -1;
    if (!strcmp(type->s, "stratified")) {
        /* pbrt-v4's stratified sampler takes a grid of xsamples * ysamples samples per
         * pixel (sampler.c lays its 2D strata out as the squarest grid of that many). */
        int xs, ys;
        bool jitter;
        if (params_get_int(ps, "xsamples", 4, &xs, P->err) != 0 ||
            params_get_int(ps, "ysamples", 4, &ys, P->err) != 0 ||
            params_get_bool(ps, "jitter", true, &jitter, P->err) != 0 ||
            check_range(P, ps, "xsamples", xs, 1, 65536) != 0 ||
            check_range(P, ps, "ysamples", ys, 1, 65536) != 0)
            return -1;
        if ((long long)xs * ys > INT_MAX)
            return pbrt_error(P->err, loc, "Sampler: xsamples * ysamples is too large");
        s->pixelsamples = xs * ys;
        return 0;
    }
    if (params_get_int(ps, "pixelsamples", 16, &s->pixelsamples, P->err) != 0 ||
        check_range(P, ps, "pixelsamples", s->pixelsamples, 1, INT_MAX) != 0)
        return -1;
    return 0;
}

/* ------------------------------------------------------------------------------------------
 * Materials
 * ------------------------------------------------------------------------------------------ */

/* pbrt-v4 materials.cpp: "<prefix>uroughness"/"<prefix>vroughness" override
 * "<prefix>roughness" (default 0); the prefix is "" or a layer's ("interface.",
 * "conductor."). */
static int get_roughness(parser_t *P, params_t *ps, scene_material_t *m, const char *prefix,
                         scene_float_input_t *uout, scene_float_input_t *vout)
{
    char un[48], vn[48], rn[48];
    snprintf(un, sizeof un, "%suroughness", prefix);
    snprintf(vn, sizeof vn, "%svroughness", prefix);
    snprintf(rn, sizeof rn, "%sroughness", prefix);
    param_t *u = params_find(ps, un), *v = params_find(ps, vn);
    scene_float_input_t r = {-1, 0.0};
    if ((!u || !v) && get_float_input(P, ps, rn, 0.0, &r) != 0)
        return -1;
    *uout = r;
    *vout = r;
    if (u && get_float_input(P, ps, un, 0.0, uout) != 0)
        return -1;
    if (v && get_float_input(P, ps, vn, 0.0, vout) != 0)
        return -1;
    if ((uout->texture < 0 && !(uout->value >= 0.0)) || (vout->texture < 0 && !(vout->value >= 0.0)))
        return pbrt_error(P->err, m->loc, "%sroughness must not be negative", prefix);
    return 0;
}

/* The index of refraction of a dielectric or of a coating's interface: "<prefix>eta" (pbrt-v4)
 * or prismfarm's "<prefix>glass", "<prefix>sellmeier", "<prefix>cauchy". */
static int get_ior(parser_t *P, params_t *ps, scene_material_t *m, const char *prefix)
{
    static const char *NAMES[] = {"eta", "glass", "sellmeier", "cauchy"};
    char names[COUNT_OF(NAMES)][48];
    for (size_t i = 0; i < COUNT_OF(NAMES); i++)
        snprintf(names[i], sizeof names[i], "%s%s", prefix, NAMES[i]);
    param_t *given = NULL;
    for (size_t i = 0; i < COUNT_OF(NAMES); i++) {
        param_t *p = params_find(ps, names[i]);
        if (!p)
            continue;
        if (given)
            return pbrt_error(P->err, p->loc,
                              "give only one of \"%s\", \"%s\", \"%s\" "
                              "and \"%s\" for %s (\"%s\" is already given)",
                              names[0], names[1], names[2], names[3], params_context(ps),
                              given->name);
        given = p;
    }
    scene_ior_t *ior = &m->ior;
    ior->loc = given ? given->loc : m->loc;
    if (!given) {
        ior->kind = SCENE_IOR_SPECTRUM;
        ior->spectrum = spectrum_constant(1.5, m->loc); /* pbrt-v4's default eta */
        return 0;
    }
    const char *kind = given->name + strlen(prefix);
    if (!strcmp(kind, "eta")) {
        if (given->type == PARAM_TEXTURE)
            return pbrt_error(P->err, given->loc,
                              "unsupported parameter \"texture %s\": the "
                              "index of refraction cannot be a texture", given->name);
        if (given->type != PARAM_FLOAT && given->type != PARAM_SPECTRUM) {
            char expected[128];
            snprintf(expected, sizeof expected, "\"float %s\" or \"spectrum %s\"", given->name,
                     given->name);
            return params_wrong_type(ps, given, expected, P->err);
        }
        ior->kind = SCENE_IOR_SPECTRUM;
        if (spectrum_from_param(P, ps, given, SPECTRUM_ANY, &ior->spectrum) != 0)
            return -1;
        if (ior->spectrum.kind == SCENE_SPECTRUM_CONSTANT && !(ior->spectrum.constant > 0.0))
            return pbrt_error(P->err, given->loc, "\"float %s\" must be greater than 0, got %g",
                              given->name, ior->spectrum.constant);
        if (ior->spectrum.kind == SCENE_SPECTRUM_SAMPLED)
            for (size_t i = 0; i < ior->spectrum.count; i++)
                if (!(ior->spectrum.value[i] > 0.0))
                    return pbrt_error(P->err, given->loc,
                                      "\"spectrum eta\": index %g in pair %zu "
                                      "is not positive",
                                      ior->spectrum.value[i], i + 1);
        return 0;
    }
    if (!strcmp(kind, "glass")) {
        const char *name;
        if (params_get_string(ps, given->name, NULL, &name, P->err) != 0)
            return -1;
        if (!*name)
            return pbrt_error(P->err, given->loc, "\"string %s\" is empty", given->name);
        ior->kind = SCENE_IOR_GLASS;
        ior->glass = scene_desc_strdup(P->scene, name, P->err);
        return ior->glass ? 0 : -1;
    }
    if (given->type != PARAM_FLOAT) {
        char expected[64];
        snprintf(expected, sizeof expected, "\"float %s\"", given->name);
        return params_wrong_type(ps, given, expected, P->err);
    }
    if (!strcmp(kind, "sellmeier")) {
        /* n^2 = 1 + sum B_i l^2 / (l^2 - C_i), l in um (docs/physics.md §3.3). */
        if (given->count < 2 || given->count % 2 != 0)
            return pbrt_error(P->err, given->loc,
                              "\"float sellmeier\" needs (B, C) pairs, got "
                              "%zu numbers",
                              given->count);
        double *c = scene_desc_alloc(P->scene, given->count * sizeof *c, P->err);
        if (!c)
            return -1;
        memcpy(c, given->numbers, given->count * sizeof *c);
        ior->kind = SCENE_IOR_SELLMEIER;
        ior->nterms = given->count / 2;
        ior->sellmeier = c;
        return 0;
    }
    /* cauchy: n = A + B / l^2, l in um */
    if (given->count != 2)
        return pbrt_error(P->err, given->loc,
                          "expected 2 numbers after \"float cauchy\" (A B), "
                          "got %zu",
                          given->count);
    if (!(given->numbers[0] > 0.0))
        return pbrt_error(P->err, given->loc, "\"float cauchy\": A must be greater than 0, got %g",
                          given->numbers[0]);
    ior->kind = SCENE_IOR_CAUCHY;
    ior->cauchy[0] = given->numbers[0];
    ior->cauchy[1] = given->numbers[1];
    return 0;
}

/* A conductor's complex index or reflectance, as pbrt-v4's ConductorMaterial reads them
 * ("eta", "k", "reflectance") and CoatedConductorMaterial ("conductor.eta", "conductor.k",
 * "reflectance"). */
static int get_conductor(parser_t *P, params_t *ps, scene_material_t *m, const char *prefix)
{
    char en[48], kn[48];
    snprintf(en, sizeof en, "%seta", prefix);
    snprintf(kn, sizeof kn, "%sk", prefix);
    param_t *r = params_find(ps, "reflectance");
    if (r && (params_find(ps, en) || params_find(ps, kn)))
        return pbrt_error(P->err, r->loc, "%s: give either \"reflectance\" or \"%s\" and \"%s\", not both",
                          params_context(ps), en, kn);
    m->use_reflectance = r != NULL;
    return get_spectrum_input(P, ps, "reflectance", spectrum_constant(1.0, m->loc), SPECTRUM_ALBEDO,
                              &m->reflectance) ||
                   get_spectrum_input(P, ps, en, spectrum_named("metal-Cu-eta", m->loc), SPECTRUM_ANY,
                                      &m->eta) ||
                   get_spectrum_input(P, ps, kn, spectrum_named("metal-Cu-k", m->loc), SPECTRUM_ANY,
                                      &m->k)
               ? -1
               : 0;
}

/* The medium of pbrt-v4's layered materials (coateddiffuse, coatedconductor). */
static int get_layer(parser_t *P, params_t *ps, scene_material_t *m)
{
    if (get_float_input(P, ps, "thickness", 0.01, &m->thickness) != 0 ||
        get_float_input(P, ps, "g", 0.0, &m->g) != 0 ||
        get_spectrum_input(P, ps, "albedo", spectrum_constant(0.0, m->loc), SPECTRUM_ALBEDO,
                           &m->albedo) != 0 ||
        params_get_int(ps, "maxdepth", 10, &m->maxdepth, P->err) != 0 ||
        params_get_int(ps, "nsamples", 1, &m->nsamples, P->err) != 0 ||
        check_range(P, ps, "maxdepth", m->maxdepth, 1, 1000) != 0 ||
        check_range(P, ps, "nsamples", m->nsamples, 1, 1000) != 0)
        return -1;
    if (m->thickness.texture < 0 && !(m->thickness.value > 0.0))
        return check_positive(P, ps, "thickness", m->thickness.value);
    if (m->g.texture < 0 && !(m->g.value > -1.0 && m->g.value < 1.0))
        return check_range(P, ps, "g", m->g.value, -0.999, 0.999);
    return 0;
}

static int get_mix(parser_t *P, params_t *ps, scene_material_t *m)
{
    param_t *p = params_find(ps, "materials");
    if (!p)
        return pbrt_error(P->err, m->loc, "mix: \"string materials\" (two named materials) is missing");
    if (p->type != PARAM_STRING)
        return params_wrong_type(ps, p, "\"string materials\"", P->err);
    if (p->count != 2)
        return pbrt_error(P->err, p->loc, "expected 2 material names after \"string materials\", got %zu",
                          p->count);
    for (int i = 0; i < 2; i++) {
        m->mix[i] = scene_desc_find_material(P->scene, p->strings[i]);
        if (m->mix[i] < 0)
            return pbrt_error(P->err, p->loc,
                              "mix: named material \"%s\" is not defined (a MakeNamedMaterial must "
                              "come before the mix that uses it)",
                              p->strings[i]);
    }
    return get_float_input(P, ps, "amount", 0.5, &m->amount);
}

static int build_material(parser_t *P, params_t *ps, const char *type, pbrt_loc_t type_loc,
                          scene_material_t *m)
{
    if (!strcmp(type, "diffuse")) {
        m->type = SCENE_MATERIAL_DIFFUSE;
        return get_spectrum_input(P, ps, "reflectance", spectrum_constant(0.5, m->loc),
                                  SPECTRUM_ALBEDO, &m->reflectance);
    }
    if (!strcmp(type, "conductor")) {
        m->type = SCENE_MATERIAL_CONDUCTOR;
        return get_conductor(P, ps, m, "") ||
                       get_roughness(P, ps, m, "", &m->uroughness, &m->vroughness) ||
                       params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err)
                   ? -1
                   : 0;
    }
    if (!strcmp(type, "dielectric")) {
        m->type = SCENE_MATERIAL_DIELECTRIC;
        return get_ior(P, ps, m, "") || get_roughness(P, ps, m, "", &m->uroughness, &m->vroughness) ||
                       params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err)
                   ? -1
                   : 0;
    }
    if (!strcmp(type, "thindielectric")) {
        m->type = SCENE_MATERIAL_THINDIELECTRIC;
        return get_ior(P, ps, m, "");
    }
    if (!strcmp(type, "diffusetransmission")) {
        m->type = SCENE_MATERIAL_DIFFUSETRANSMISSION;
        if (get_spectrum_input(P, ps, "reflectance", spectrum_constant(0.25, m->loc), SPECTRUM_ALBEDO,
                               &m->reflectance) != 0 ||
            get_spectrum_input(P, ps, "transmittance", spectrum_constant(0.25, m->loc),
                               SPECTRUM_ALBEDO, &m->transmittance) != 0 ||
            params_get_float(ps, "scale", 1.0, &m->scale, P->err) != 0)
            return -1;
        return m->scale >= 0.0 ? 0 : check_range(P, ps, "scale", m->scale, 0.0, 1.0);
    }
    if (!strcmp(type, "coateddiffuse")) {
        m->type = SCENE_MATERIAL_COATEDDIFFUSE;
        return get_spectrum_input(P, ps, "reflectance", spectrum_constant(0.5, m->loc),
                                  SPECTRUM_ALBEDO, &m->reflectance) ||
                       get_ior(P, ps, m, "") ||
                       get_roughness(P, ps, m, "", &m->uroughness, &m->vroughness) ||
                       params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err) ||
                       get_layer(P, ps, m)
                   ? -1
                   : 0;
    }
    if (!strcmp(type, "coatedconductor")) {
        m->type = SCENE_MATERIAL_COATEDCONDUCTOR;
        return get_conductor(P, ps, m, "conductor.") || get_ior(P, ps, m, "interface.") ||
                       get_roughness(P, ps, m, "interface.", &m->uroughness, &m->vroughness) ||
                       get_roughness(P, ps, m, "conductor.", &m->base_uroughness,
                                     &m->base_vroughness) ||
                       params_get_bool(ps, "remaproughness", true, &m->remaproughness, P->err) ||
                       get_layer(P, ps, m)
                   ? -1
                   : 0;
    }
    if (!strcmp(type, "mix")) {
        m->type = SCENE_MATERIAL_MIX;
        return get_mix(P, ps, m);
    }
    /* pbrt-v4 reads "" and "none" as no material too (a boundary between media). */
    if (!strcmp(type, "interface") || !strcmp(type, "") || !strcmp(type, "none")) {
        m->type = SCENE_MATERIAL_INTERFACE;
        return 0;
    }
    return pbrt_error(P->err, type_loc,
                      "unsupported material \"%s\" (\"diffuse\", \"conductor\", \"dielectric\", "
                      "\"thindielectric\", \"diffusetransmission\", \"coateddiffuse\", "
                      "\"coatedconductor\", \"mix\" or \"interface\")",
                      type);
}

static int image_file(parser_t *P, const param_t *fp, const char *filename, const char **out);

/* pbrt-v4's "displacement" and "normalmap" of every material but mix and interface. */
static int surface_maps(parser_t *P, params_t *ps, scene_material_t *m)
{
    if (m->type == SCENE_MATERIAL_MIX || m->type == SCENE_MATERIAL_INTERFACE)
        return 0;
    const char *normalmap;
    if (get_float_input(P, ps, "displacement", 0.0, &m->displacement) != 0 ||
        params_get_string(ps, "normalmap", NULL, &normalmap, P->err) != 0)
        return -1;
    if (!normalmap)
        return 0;
    param_t *fp = params_find(ps, "normalmap");
    m->normalmap_loc = fp->loc;
    return image_file(P, fp, normalmap, &m->normalmap);
}

static int do_material(parser_t *P, params_t *ps, const str_arg_t *type, const char *name,
                       pbrt_loc_t loc, pbrt_loc_t type_loc)
{
    int idx = scene_desc_add_material(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_material_t *m = &P->scene->materials[idx];
    m->loc = loc;
    m->reflectance.texture = m->eta.texture = m->k.texture = -1;
    m->uroughness.texture = m->vroughness.texture = -1;
    m->base_uroughness.texture = m->base_vroughness.texture = -1;
    m->transmittance.texture = m->albedo.texture = -1;
    m->thickness.texture = m->g.texture = m->amount.texture = -1;
    m->mix[0] = m->mix[1] = -1;
    m->remaproughness = true;
    if (name) {
        m->name = scene_desc_strdup(P->scene, name, P->err);
        if (!m->name)
            return -1;
    }
    m->displacement.texture = -1;
    if (build_material(P, ps, type->s, type_loc, m) != 0 || surface_maps(P, ps, m) != 0)
        return -1;
    if (!name)
        P->gs.material = idx;
    return 0;
}

/* ------------------------------------------------------------------------------------------
 * Textures
 * ------------------------------------------------------------------------------------------ */

static int tex_input(parser_t *P, params_t *ps, scene_texture_t *t, const char *name, double def,
                     scene_float_input_t *f, scene_spectrum_input_t *s)
{
    if (t->type == SCENE_TEXTURE_FLOAT)
        return get_float_input(P, ps, name, def, f);
    return get_spectrum_input(P, ps, name, spectrum_constant(def, t->loc), SPECTRUM_ANY, s);
}

static bool ends_with_png(const char *s)
{
    size_t n = strlen(s);
    return n >= 4 && !strcasecmp(s + n - 4, ".png");
}

static int do_texture(parser_t *P, params_t *ps, const str_arg_t *name, const str_arg_t *type,
                      const str_arg_t *cls, pbrt_loc_t loc)
{
    scene_texture_type_t tt;
    if (!strcmp(type->s, "float"))
        tt = SCENE_TEXTURE_FLOAT;
    else if (!strcmp(type->s, "spectrum"))
        tt = SCENE_TEXTURE_SPECTRUM;
    else
        return pbrt_error(P->err, type->loc,
                          "texture type must be \"float\" or \"spectrum\", "
                          "got \"%s\"",
                          type->s);
    int prev = scene_desc_find_texture(P->scene, name->s, tt);
    if (prev >= 0)
        return pbrt_error(P->err, name->loc, "%s texture \"%s\" is already defined (line %d)",
                          type->s, name->s, P->scene->textures[prev].loc.line);
    static const struct {
        const char *name;
        scene_texture_class_t cls;
    } CLASSES[] = {{"constant", SCENE_TEX_CONSTANT},
                   {"checkerboard", SCENE_TEX_CHECKERBOARD},
                   {"imagemap", SCENE_TEX_IMAGEMAP},
                   {"scale", SCENE_TEX_SCALE},
                   {"mix", SCENE_TEX_MIX}};
    int cls_idx = -1;
    for (size_t i = 0; i < COUNT_OF(CLASSES); i++)
        if (!strcmp(cls->s, CLASSES[i].name))
            cls_idx = (int)i;
    /* pbrt-v4 "ptex" (per-face textures): no reader here; a constant 0.5 stands in. */
    bool ptex = !strcmp(cls->s, "ptex");
    if (ptex) {
        cls_idx = 0;
        param_t *fp = params_find(ps, "filename");
        (void)params_find(ps, "encoding");
        (void)params_find(ps, "scale");
        (void)params_find(ps, "invert");
        if (warnings_add(P->scene->warnings, fp ? fp->loc : cls->loc,
                         "Texture \"%s\": \"ptex\" is not read; the texture is the constant 0.5",
                         name->s))
            return pbrt_error(P->err, cls->loc, "out of memory");
    }
    if (cls_idx < 0)
        return pbrt_error(P->err, cls->loc,
                          "unsupported texture \"%s\" (\"constant\", "
                          "\"checkerboard\", \"imagemap\", \"scale\" or \"mix\")",
                          cls->s);
    if (check_transform(P, &P->gs.ctm, "Texture", loc) != 0)
        return -1;
    int idx = scene_desc_add_texture(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_texture_t *t = &P->scene->textures[idx];
    t->name = scene_desc_strdup(P->scene, name->s, P->err);
    if (!t->name)
        return -1;
    t->type = tt;
    t->cls = CLASSES[cls_idx].cls;
    t->loc = loc;
    t->to_world = P->gs.ctm;
    t->float_in1.texture = t->float_in2.texture = t->amount.texture = -1;
    t->spec_in1.texture = t->spec_in2.texture = -1;

    const char *mapping;
    if (params_get_string(ps, "mapping", "uv", &mapping, P->err) != 0)
        return -1;
    if (strcmp(mapping, "uv") != 0)
        return pbrt_error(P->err, params_find(ps, "mapping")->loc,
                          "unsupported texture mapping \"%s\" (only \"uv\")", mapping);
    if (params_get_float(ps, "uscale", 1.0, &t->uscale, P->err) != 0 ||
        params_get_float(ps, "vscale", 1.0, &t->vscale, P->err) != 0 ||
        params_get_float(ps, "udelta", 0.0, &t->udelta, P->err) != 0 ||
        params_get_float(ps, "vdelta", 0.0, &t->vdelta, P->err) != 0)
        return -1;

    if (ptex) {
        t->float_in1.value = 0.5;
        t->spec_in1.spectrum = spectrum_constant(0.5, t->loc);
        return 0;
    }
    /* Inputs and their defaults as pbrt-v4 textures.cpp creates them. */
    switch (t->cls) {
    case SCENE_TEX_CONSTANT:
        return tex_input(P, ps, t, "value", 1.0, &t->float_in1, &t->spec_in1);
    case SCENE_TEX_CHECKERBOARD: {
        int dim;
        if (params_get_int(ps, "dimension", 2, &dim, P->err) != 0)
            return -1;
        if (dim != 2)
            return pbrt_error(P->err, params_find(ps, "dimension")->loc,
                              "unsupported checkerboard dimension %d (only 2)", dim);
        return tex_input(P, ps, t, "tex1", 1.0, &t->float_in1, &t->spec_in1) != 0 ||
                       tex_input(P, ps, t, "tex2", 0.0, &t->float_in2, &t->spec_in2) != 0
                   ? -1
                   : 0;
    }
    case SCENE_TEX_SCALE:
        return tex_input(P, ps, t, "tex", 1.0, &t->float_in1, &t->spec_in1) != 0 ||
                       get_float_input(P, ps, "scale", 1.0, &t->amount) != 0
                   ? -1
                   : 0;
    case SCENE_TEX_MIX:
        return tex_input(P, ps, t, "tex1", 0.0, &t->float_in1, &t->spec_in1) != 0 ||
                       tex_input(P, ps, t, "tex2", 1.0, &t->float_in2, &t->spec_in2) != 0 ||
                       get_float_input(P, ps, "amount", 0.5, &t->amount) != 0
                   ? -1
                   : 0;
    case SCENE_TEX_IMAGEMAP:
        break;
    }
    const char *filename, *wrap, *filter, *encoding;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0 ||
        params_get_string(ps, "wrap", "repeat", &wrap, P->err) != 0 ||
        params_get_string(ps, "filter", "bilinear", &filter, P->err) != 0 ||
        params_get_string(ps, "encoding", "sRGB", &encoding, P->err) != 0 ||
        params_get_float(ps, "scale", 1.0, &t->image.scale, P->err) != 0 ||
        params_get_bool(ps, "invert", false, &t->image.invert, P->err) != 0)
        return -1;
    if (!filename)
        return pbrt_error(P->err, loc, "Texture \"imagemap\" needs \"string filename\"");
    param_t *fp = params_find(ps, "filename");
    static const char *WRAPS[] = {"repeat", "black", "clamp", "octahedralsphere"};
    static const char *FILTERS[] = {"point", "bilinear", "trilinear", "ewa"};
    if (!in_list(wrap, WRAPS, COUNT_OF(WRAPS)))
        return pbrt_error(P->err, params_find(ps, "wrap")->loc,
                          "unsupported wrap mode \"%s\" (\"repeat\", \"black\", \"clamp\" or "
                          "\"octahedralsphere\")",
                          wrap);
    if (!in_list(filter, FILTERS, COUNT_OF(FILTERS)))
        return pbrt_error(P->err, params_find(ps, "filter")->loc,
                          "unknown filter \"%s\" (\"point\", \"bilinear\", \"trilinear\" or "
                          "\"ewa\")",
                          filter);
    if (!strcmp(filter, "ewa") &&
        warnings_add(P->scene->warnings, params_find(ps, "filter")->loc,
                     "Texture \"%s\": filter \"ewa\" is read as \"trilinear\" (and, without ray "
                     "differentials, at the full resolution)",
                     name->s))
        return pbrt_error(P->err, loc, "out of memory");
    double gamma;
    char tail;
    if (strcmp(encoding, "sRGB") != 0 && strcmp(encoding, "linear") != 0 &&
        !(sscanf(encoding, "gamma %lf%c", &gamma, &tail) == 1 && isfinite(gamma) && gamma > 0.0))
        return pbrt_error(P->err, params_find(ps, "encoding")->loc,
                          "unknown encoding \"%s\" (\"sRGB\", \"linear\" or \"gamma G\")",
                          encoding);
    if (image_file(P, fp, filename, &t->image.filename) != 0)
        return -1;
    t->image.wrap = scene_desc_strdup(P->scene, wrap, P->err);
    t->image.filter = scene_desc_strdup(P->scene, filter, P->err);
    t->image.encoding = scene_desc_strdup(P->scene, encoding, P->err);
    return t->image.wrap && t->image.filter && t->image.encoding ? 0 : -1;
}

/* ------------------------------------------------------------------------------------------
 * Lights
 * ------------------------------------------------------------------------------------------ */

static int do_area_light(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    scene_area_light_type_t at;
    if (!strcmp(type->s, "diffuse"))
        at = SCENE_AREA_DIFFUSE;
    else if (!strcmp(type->s, "collimated"))
        at = SCENE_AREA_COLLIMATED;
    else
        return pbrt_error(P->err, type->loc,
                          "unsupported area light \"%s\" (\"diffuse\" or "
                          "\"collimated\")",
                          type->s);
    int idx = scene_desc_add_area_light(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_area_light_t *a = &P->scene->area_lights[idx];
    a->type = at;
    a->loc = loc;
    /* pbrt-v4 lights default to the colour space's illuminant (D65 for sRGB). */
    if (get_spectrum(P, ps, "L", spectrum_named("stdillum-D65", loc), SPECTRUM_ANY, &a->L) != 0 ||
        params_get_float(ps, "scale", 1.0, &a->scale, P->err) != 0 ||
        check_range(P, ps, "scale", a->scale, 0.0, INFINITY) != 0 ||
        params_get_float(ps, "power", -1.0, &a->power, P->err) != 0)
        return -1;
    if (at == SCENE_AREA_DIFFUSE &&
        params_get_bool(ps, "twosided", false, &a->twosided, P->err) != 0)
        return -1;
    const char *filename = NULL;
    if (at == SCENE_AREA_DIFFUSE && params_get_string(ps, "filename", NULL, &filename, P->err) != 0)
        return -1;
    if (filename && filename[0]) {
        /* pbrt-v4 DiffuseAreaLight::Create refuses both. */
        if (params_find(ps, "L"))
            return pbrt_error(P->err, params_find(ps, "L")->loc,
                              "AreaLightSource \"diffuse\": cannot have both \"L\" and \"filename\" "
                              "(pbrt-v4 refuses it too)");
        param_t *fp = params_find(ps, "filename");
        if (image_file(P, fp, filename, &a->filename) != 0)
            return -1;
        a->filename_loc = fp->loc;
    }
    P->gs.area_light = idx;
    return 0;
}

/* An image file named by fp (a texture, a normal map, an environment): the path to open
 * into *out (in a confined parse the checked real path, its bytes charged), listed among the
 * files read. A PNG in a confined parse is charged for its decoded pixels too (check_png). */
static int image_file(parser_t *P, const param_t *fp, const char *filename, const char **out)
{
    const char *path = scene_path(P, filename, fp->loc);
    if (!path)
        return -1;
    if (P->root_real) {
        char *real = confine(P, path, filename, &fp->loc, "image");
        if (!real)
            return -1;
        int rc;
        if (ends_with_png(filename)) {
            rc = check_png(P, real, filename, path, &fp->loc);
        } else {
            size_t size;
            int fd = open_confined(P, real, filename, path, &fp->loc, "image", &size);
            rc = fd < 0 ? -1 : charge(P, size, &fp->loc);
            if (fd >= 0)
                close(fd);
        }
        *out = rc == 0 ? scene_desc_strdup(P->scene, real, P->err) : NULL;
        free(real);
        if (!*out)
            return -1;
    } else {
        const char *kind;
        char why[96];
        FILE *f = open_regular_file(path, &kind);
        if (!f)
            return pbrt_error(P->err, fp->loc, "cannot open image \"%s\": %s", path,
                              open_failure(kind, why, sizeof why));
        fclose(f);
        *out = path;
    }
    return note_file(P, SCENE_FILE_IMAGE, path, filename, fp->loc);
}

/* LightSource "infinite": "string filename" names an equal-area environment image (read by
 * scene_load, which checks that it is square), "point3 portal" is accepted with a warning
 * (portals only guide sampling in pbrt-v4; sampling without them is unbiased). As in pbrt-v4
 * lights.cpp, "L" together with "filename" is an error. */
static int infinite_light_image(parser_t *P, params_t *ps, scene_light_t *l)
{
    const char *filename;
    param_t *portal;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0 ||
        params_get_array(ps, "portal", PARAM_POINT3, &portal, P->err) != 0)
        return -1;
    if (portal && warnings_add(P->scene->warnings, portal->loc,
                               "LightSource \"infinite\": \"portal\" is not used (the light is "
                               "sampled without it, which is unbiased but noisier indoors)"))
        return pbrt_error(P->err, portal->loc, "out of memory");
    if (!filename)
        return 0;
    param_t *fp = params_find(ps, "filename");
    if (params_find(ps, "L"))
        return pbrt_error(P->err, params_find(ps, "L")->loc,
                          "LightSource \"infinite\": cannot have both \"L\" and \"filename\" "
                          "(pbrt-v4 refuses it too)");
    const char *path = scene_path(P, filename, fp->loc);
    if (!path)
        return -1;
    if (P->root_real) {
        char *real = confine(P, path, filename, &fp->loc, "image");
        if (!real)
            return -1;
        size_t size;
        int fd = open_confined(P, real, filename, path, &fp->loc, "image", &size);
        int rc = fd < 0 ? -1 : charge(P, size, &fp->loc);
        if (fd >= 0)
            close(fd);
        l->filename = rc == 0 ? scene_desc_strdup(P->scene, real, P->err) : NULL;
        free(real);
        if (!l->filename)
            return -1;
    } else {
        const char *kind;
        char why[96];
        FILE *f = open_regular_file(path, &kind);
        if (!f)
            return pbrt_error(P->err, fp->loc, "cannot open image \"%s\": %s", path,
                              open_failure(kind, why, sizeof why));
        fclose(f);
        l->filename = path;
    }
    l->filename_loc = fp->loc;
    return note_file(P, SCENE_FILE_IMAGE, path, filename, fp->loc);
}

/* LightSource "goniometric" and "projection": "string filename" is required (pbrt-v4 refuses
 * a projection light without one; a goniometric light without one it warns about and renders
 * black, which prismfarm refuses as a likely mistake). The light sits at the CTM's origin; a
 * projection light's "float fov" (90) is the angle of the image's shorter axis, in (0, 180).
 * scene_load reads the image (and checks a goniometric one is square). */
static int image_light(parser_t *P, params_t *ps, scene_light_t *l, const char *kind, pbrt_loc_t loc)
{
    const char *filename;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0)
        return -1;
    if (l->type == SCENE_LIGHT_PROJECTION) {
        if (params_get_float(ps, "fov", 90.0, &l->fov, P->err) != 0)
            return -1;
        if (!(l->fov > 0.0 && l->fov < 180.0)) {
            param_t *fp = params_find(ps, "fov");
            return pbrt_error(P->err, fp ? fp->loc : loc,
                              "\"float fov\" must be strictly between 0 and 180 degrees, got %g",
                              l->fov);
        }
    }
    if (!filename || !filename[0])
        return pbrt_error(P->err, loc, "LightSource \"%s\" needs \"string filename\" (its image)",
                          kind);
    param_t *fp = params_find(ps, "filename");
    if (image_file(P, fp, filename, &l->filename) != 0)
        return -1;
    l->filename_loc = fp->loc;
    return 0;
}

static int do_light(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    static const struct {
        const char *name;
        scene_light_type_t type;
    } TYPES[] = {{"point", SCENE_LIGHT_POINT},
                 {"spot", SCENE_LIGHT_SPOT},
                 {"distant", SCENE_LIGHT_DISTANT},
                 {"infinite", SCENE_LIGHT_INFINITE},
                 {"goniometric", SCENE_LIGHT_GONIOMETRIC},
                 {"projection", SCENE_LIGHT_PROJECTION}};
    int ti = -1;
    for (size_t i = 0; i < COUNT_OF(TYPES); i++)
        if (!strcmp(type->s, TYPES[i].name))
            ti = (int)i;
    if (ti < 0)
        return pbrt_error(P->err, type->loc,
                          "unsupported light \"%s\" (\"point\", \"spot\", \"distant\", "
                          "\"infinite\", \"goniometric\" or \"projection\")",
                          type->s);
    if (check_transform(P, &P->gs.ctm, "LightSource", loc) != 0)
        return -1;
    int idx = scene_desc_add_light(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_light_t *l = &P->scene->lights[idx];
    l->type = TYPES[ti].type;
    l->loc = loc;
    l->to_world = P->gs.ctm;
    const int positional = l->type != SCENE_LIGHT_DISTANT && l->type != SCENE_LIGHT_INFINITE;
    const char *sname = positional ? "I" : "L";
    /* pbrt-v4 lights.cpp: point, spot, goniometric and projection lights take "power", distant
     * and infinite lights "illuminance"; a value <= 0 means "not given". */
    const char *pname = positional ? "power" : "illuminance";
    /* A projection light has no spectrum parameter: its image's colours are RGB illuminant
     * spectra of the colour space (pbrt-v4 ProjectionLight::Create reads no "I"). */
    if (l->type == SCENE_LIGHT_PROJECTION)
        l->spectrum = spectrum_named("stdillum-D65", loc);
    else if (get_spectrum(P, ps, sname, spectrum_named("stdillum-D65", loc), SPECTRUM_ANY,
                          &l->spectrum) != 0)
        return -1;
    if (params_get_float(ps, "scale", 1.0, &l->scale, P->err) != 0 ||
        check_range(P, ps, "scale", l->scale, 0.0, INFINITY) != 0 ||
        params_get_float(ps, pname, -1.0, &l->power, P->err) != 0)
        return -1;
    if (l->type == SCENE_LIGHT_INFINITE)
        return infinite_light_image(P, ps, l);
    if (l->type == SCENE_LIGHT_GONIOMETRIC || l->type == SCENE_LIGHT_PROJECTION)
        return image_light(P, ps, l, type->s, loc);
    if (params_get_point3(ps, "from", vec3_make(0, 0, 0), &l->from, P->err) != 0)
        return -1;
    if (l->type == SCENE_LIGHT_POINT)
        return 0;
    if (params_get_point3(ps, "to", vec3_make(0, 0, 1), &l->to, P->err) != 0)
        return -1;
    if (vec3_length(vec3_sub(l->to, l->from)) == 0.0)
        return pbrt_error(P->err, loc, "LightSource \"%s\": \"from\" and \"to\" are the same point",
                          type->s);
    if (l->type == SCENE_LIGHT_DISTANT)
        return 0;
    if (params_get_float(ps, "coneangle", 30.0, &l->coneangle, P->err) != 0 ||
        params_get_float(ps, "conedeltaangle", 5.0, &l->conedeltaangle, P->err) != 0 ||
        check_range(P, ps, "coneangle", l->coneangle, 0.0, 180.0) != 0 ||
        check_range(P, ps, "conedeltaangle", l->conedeltaangle, 0.0, l->coneangle) != 0)
        return -1;
    return 0;
}

/* ------------------------------------------------------------------------------------------
 * Shapes
 * ------------------------------------------------------------------------------------------ */

static double *copy_doubles(parser_t *P, const double *src, size_t n)
{
    double *d = scene_desc_alloc(P->scene, n * sizeof *d, P->err);
    if (d)
        memcpy(d, src, n * sizeof *d);
    return d;
}

/* Hands a mesh made here (PLY, subdivision, tessellation) to the shape and the scene. */
/* budget.h: one more shape or object instance. */
static int budget_shape(parser_t *P, const char *what, pbrt_loc_t loc)
{
    err_t late;
    if (scene_budget_check_time(P->budget, &late) != 0)
        return pbrt_error(P->err, loc, "%s", late.msg);
    if (!P->budget || !P->budget->shapes || ++P->nshapes <= P->budget->shapes)
        return 0;
    return pbrt_error(P->err, loc,
                      "%s: the scene has more than %llu shapes and object instances, the "
                      "master's budget (prismfarm master --max-shapes)",
                      what, (unsigned long long)P->budget->shapes);
}

/* budget.h: n more triangles (or patches). */
static int budget_refuse(parser_t *P, uint64_t n, pbrt_loc_t loc)
{
    return pbrt_error(P->err, loc,
                      "this shape's %llu triangles take the scene over %llu triangles, the "
                      "master's budget (prismfarm master --max-triangles)",
                      (unsigned long long)n, (unsigned long long)P->budget->triangles);
}

/* Notes a triangle count to check in order after the jobs (tri_count_t). */
static int note_count(parser_t *P, long job, uint64_t n, pbrt_loc_t loc)
{
    if (P->ncounts == P->cap_counts) {
        size_t cap = P->cap_counts ? 2 * P->cap_counts : 64;
        tri_count_t *c = realloc(P->counts, cap * sizeof *c);
        if (!c)
            return pbrt_error(P->err, loc, "out of memory");
        P->counts = c;
        P->cap_counts = cap;
    }
    P->counts[P->ncounts++] = (tri_count_t){job, n, loc};
    if (job < 0)
        P->ntriangles_ahead =
            n > UINT64_MAX - P->ntriangles_ahead ? UINT64_MAX : P->ntriangles_ahead + n;
    return 0;
}

static int budget_triangles(parser_t *P, uint64_t n, pbrt_loc_t loc)
{
    if (!P->budget || !P->budget->triangles)
        return 0;
    if (P->njobs > 0 && !P->resolving)
        return note_count(P, -1, n, loc);
    if (n <= P->budget->triangles - P->ntriangles && P->ntriangles <= P->budget->triangles) {
        P->ntriangles += n;
        return 0;
    }
    return budget_refuse(P, n, loc);
}

static int adopt_mesh(parser_t *P, scene_shape_t *s, mesh_data_t *md)
{
    scene_mesh_t *m = &s->mesh;
    m->nvertices = md->nvertices;
    m->ntriangles = md->ntriangles;
    m->P = md->P;
    m->N = md->N;
    m->uv = md->uv;
    m->indices = md->indices;
    /* adopt frees on failure, so hand over every block before checking */
    int rc = scene_desc_adopt(P->scene, md->P, P->err);
    rc |= scene_desc_adopt(P->scene, md->N, P->err);
    rc |= scene_desc_adopt(P->scene, md->uv, P->err);
    rc |= scene_desc_adopt(P->scene, md->indices, P->err);
    memset(md, 0, sizeof *md);
    return rc ? -1 : budget_triangles(P, m->ntriangles, s->loc);
}

/* trianglemesh (3 indices per triangle) or bilinearmesh (4 per patch: p00 p10 p01 p11, made
 * into triangles by shape_tess: a planar patch into (p00 p10 p11) and (p00 p11 p01), which
 * keeps pbrt-v4's normal cross(p10-p00, p01-p00) equal to the triangles' cross(p0-p2,
 * p1-p2); a twisted one into a grid that follows its curve). */
static int mesh_from_params(parser_t *P, params_t *ps, scene_shape_t *s, bool bilinear,
                            pbrt_loc_t loc)
{
    param_t *pp, *pi, *pn, *puv;
    if (params_get_array(ps, "P", PARAM_POINT3, &pp, P->err) != 0)
        return -1;
    if (!pp)
        return pbrt_error(P->err, loc, "Shape \"%s\" needs \"point3 P\"", s->kind);
    size_t nv = pp->count / 3;
    if (nv >= UINT32_MAX)
        return pbrt_error(P->err, pp->loc, "too many points in \"point3 P\"");
    if (params_get_array(ps, "indices", PARAM_INTEGER, &pi, P->err) != 0)
        return -1;
    size_t per = bilinear ? 4 : 3;
    size_t nprims;
    if (!pi) {
        /* pbrt-v4 allows omitting indices for a single triangle or patch. */
        if (nv != per)
            return pbrt_error(P->err, loc,
                              "Shape \"%s\" without \"integer indices\" needs exactly "
                              "%zu points in \"point3 P\", got %zu",
                              s->kind, per, nv);
        nprims = 1;
    } else {
        if (pi->count % per != 0)
            return pbrt_error(P->err, pi->loc,
                              "expected a multiple of %zu numbers after \"%s "
                              "%s\", got %zu",
                              per, pi->type_name, pi->name, pi->count);
        for (size_t i = 0; i < pi->count; i++)
            if (pi->numbers[i] < 0 || pi->numbers[i] >= (double)nv)
                return pbrt_error(P->err, pi->loc,
                                  "index %.0f (entry %zu of \"integer indices\") "
                                  "is out of range: \"point3 P\" has %zu points",
                                  pi->numbers[i], i + 1, nv);
        nprims = pi->count / per;
    }
    if (params_get_array(ps, "N", PARAM_NORMAL3, &pn, P->err) != 0 ||
        params_get_array(ps, "uv", PARAM_POINT2, &puv, P->err) != 0)
        return -1;
    if (pn && pn->count / 3 != nv)
        return pbrt_error(P->err, pn->loc,
                          "\"%s N\" has %zu normals but \"point3 P\" has %zu "
                          "points",
                          pn->type_name, pn->count / 3, nv);
    if (puv && puv->count / 2 != nv)
        return pbrt_error(P->err, puv->loc,
                          "\"%s uv\" has %zu entries but \"point3 P\" has %zu "
                          "points",
                          puv->type_name, puv->count / 2, nv);
    if (bilinear) {
        uint32_t *quads = malloc(4 * nprims * sizeof *quads);
        if (!quads)
            return pbrt_error(P->err, loc, "out of memory");
        for (size_t i = 0; i < 4 * nprims; i++)
            quads[i] = pi ? (uint32_t)pi->numbers[i] : (uint32_t)i;
        mesh_data_t md;
        err_t e;
        int rc = shape_tess_bilinear(pp->numbers, nv, quads, nprims, puv ? puv->numbers : NULL,
                                     pn ? pn->numbers : NULL, &md, &e);
        free(quads);
        if (rc != 0)
            return pbrt_error(P->err, loc, "Shape \"bilinearmesh\": %s", e.msg);
        return adopt_mesh(P, s, &md);
    }
    scene_mesh_t *m = &s->mesh;
    m->nvertices = nv;
    m->P = copy_doubles(P, pp->numbers, pp->count);
    if (!m->P)
        return -1;
    if (pn && !(m->N = copy_doubles(P, pn->numbers, pn->count)))
        return -1;
    if (puv && !(m->uv = copy_doubles(P, puv->numbers, puv->count)))
        return -1;
    m->ntriangles = bilinear ? 2 * nprims : nprims;
    if (budget_triangles(P, m->ntriangles, loc) != 0)
        return -1;
    uint32_t *idx = scene_desc_alloc(P->scene, m->ntriangles * 3 * sizeof *idx, P->err);
    if (!idx)
        return -1;
    for (size_t i = 0; i < nprims; i++) {
        uint32_t v[4];
        for (size_t k = 0; k < per; k++)
            v[k] = pi ? (uint32_t)pi->numbers[per * i + k] : (uint32_t)k;
        if (bilinear) {
            uint32_t *t = &idx[6 * i];
            t[0] = v[0], t[1] = v[1], t[2] = v[3];
            t[3] = v[0], t[4] = v[3], t[5] = v[2];
        } else {
            idx[3 * i] = v[0], idx[3 * i + 1] = v[1], idx[3 * i + 2] = v[2];
        }
    }
    m->indices = idx;
    return 0;
}

static int mesh_job_run(void *user, int index, err_t *err);
static int mesh_job_adopt(parser_t *P, mesh_job_t *j);

/* The job's inputs (the file's bytes, a loopsubdiv's control mesh), once it has run. */
static void mesh_job_free_inputs(mesh_job_t *j)
{
    free(j->buf);
    free(j->P);
    free(j->idx);
    j->buf = NULL;
    j->P = NULL;
    j->idx = NULL;
}

static void mesh_job_free(mesh_job_t *j)
{
    mesh_job_free_inputs(j);
    mesh_data_free(&j->md);
}

static int mesh_jobs_finish(parser_t *P);

static size_t path_hash(const char *path)
{
    uint64_t h = 1469598103934665603ull; /* FNV-1a */
    for (const unsigned char *c = (const unsigned char *)path; *c; c++)
        h = (h ^ *c) * 1099511628211ull;
    return (size_t)h;
}

/* The slot of path in P->ply_slots: the queued job that decodes it, or the empty slot where it
 * goes. */
static size_t *ply_slot(parser_t *P, const char *path)
{
    size_t mask = P->ply_cap - 1, i = path_hash(path) & mask;
    while (P->ply_slots[i] && strcmp(P->jobs[P->ply_slots[i] - 1].path, path) != 0)
        i = (i + 1) & mask;
    return &P->ply_slots[i];
}

/* A queued PLY job that decodes path (its index into *k), or false (and path is noted for the
 * job about to be queued at index P->njobs; false too when there is no memory to note it). */
static bool ply_queued(parser_t *P, const char *path, size_t *k)
{
    if (2 * (P->nply + 1) > P->ply_cap) {
        size_t cap = P->ply_cap ? 2 * P->ply_cap : 256;
        size_t *slots = calloc(cap, sizeof *slots), *old = P->ply_slots;
        if (!slots)
            return false;
        size_t oldcap = P->ply_cap;
        P->ply_slots = slots;
        P->ply_cap = cap;
        for (size_t i = 0; i < oldcap; i++)
            if (old[i])
                *ply_slot(P, P->jobs[old[i] - 1].path) = old[i];
        free(old);
    }
    size_t *slot = ply_slot(P, path);
    if (*slot) {
        *k = *slot - 1;
        return true;
    }
    *slot = P->njobs + 1;
    P->nply++;
    return false;
}

/* Queues a job for shape s (an element of the scene's shapes or object_shapes), or, in
 * check mode (whose refusals are recorded as the parse meets them), runs it now. The job's
 * buffers are the job's from here on, whatever the outcome. */
static int mesh_job_queue(parser_t *P, const scene_shape_t *s, mesh_job_t *j)
{
    bool in_object = P->object >= 0;
    j->in_object = in_object;
    j->shape = (size_t)(s - (in_object ? P->scene->object_shapes : P->scene->shapes));
    if (P->errors) {
        (void)mesh_job_run(j, 0, NULL);
        int rc = mesh_job_adopt(P, j);
        mesh_job_free(j);
        return rc;
    }
    if (P->njobs == P->cap_jobs) {
        size_t cap = P->cap_jobs ? 2 * P->cap_jobs : 64;
        mesh_job_t *a = realloc(P->jobs, cap * sizeof *a);
        if (!a) {
            mesh_job_free(j);
            return pbrt_error(P->err, j->loc, "out of memory");
        }
        P->jobs = a;
        P->cap_jobs = cap;
    }
    /* A file the queue decodes already: this shape shares that mesh (a confined parse has
     * read and charged the file again all the same, as pbrt_parser.h says). */
    size_t k;
    if ((j->kind == MESH_JOB_PLY_FILE || j->kind == MESH_JOB_PLY_MEMORY) &&
        ply_queued(P, j->path, &k)) {
        free(j->buf);
        j->buf = NULL;
        j->len = 0;
        j->kind = MESH_JOB_PLY_SAME;
        j->same = k;
    }
    P->jobs[P->njobs++] = *j;
    P->queued_bytes += j->len;
    if (P->budget && P->budget->triangles && note_count(P, (long)P->njobs - 1, 0, s->loc) != 0)
        return -1;
    /* The files' bytes wait in memory until their jobs run: past MESH_QUEUE_BYTES_MAX the
     * queue is made now (everything in it is before this point, so the order of failures is
     * kept). */
    return P->queued_bytes > MESH_QUEUE_BYTES_MAX ? mesh_jobs_finish(P) : 0;
}

/* One job, on a pool thread: its mesh into j->md (state 1), or its message into j->err
 * (state -1, and -1 so that the pool starts no later job: the first failure in file order
 * is then among those run). */
static int mesh_job_run(void *user, int index, err_t *err)
{
    mesh_job_t *j = &((mesh_job_t *)user)[index];
    int rc;
    switch (j->kind) {
    case MESH_JOB_PLY_FILE:
        rc = mesh_import_ply(j->path, &j->md, &j->err);
        break;
    case MESH_JOB_PLY_MEMORY:
        rc = mesh_import_ply_memory(j->buf, j->len, j->path, &j->md, &j->err);
        break;
    case MESH_JOB_PLY_SAME:
        rc = 0; /* made by job j->same */
        break;
    default:
        rc = loopsubdiv_mesh(j->P, j->nv, j->idx, j->nt, j->levels, &j->md, &j->err);
        if (rc != 0)
            err_prefix(&j->err, "Shape \"loopsubdiv\": ");
        break;
    }
    mesh_job_free_inputs(j);
    j->state = rc == 0 ? 1 : -1;
    if (rc != 0 && err)
        *err = j->err;
    return rc;
}

/* A job that has run, in file order: its failure reported at its location, or its mesh
 * given to its shape (and counted against the budget). */
static int mesh_job_adopt(parser_t *P, mesh_job_t *j)
{
    if (j->state != 1)
        return pbrt_error(P->err, j->loc, "%s",
                          j->state < 0 ? j->err.msg : "mesh not made (internal error)");
    scene_shape_t *s =
        j->in_object ? &P->scene->object_shapes[j->shape] : &P->scene->shapes[j->shape];
    j->state = 0;
    if (j->kind == MESH_JOB_PLY_SAME) {
        /* Job j->same is earlier in file order, so its shape holds the mesh by now (had it
         * failed, the walk would have stopped there). The scene owns the arrays once. */
        const mesh_job_t *from = &P->jobs[j->same];
        const scene_shape_t *f = from->in_object ? &P->scene->object_shapes[from->shape]
                                                 : &P->scene->shapes[from->shape];
        s->mesh.nvertices = f->mesh.nvertices;
        s->mesh.ntriangles = f->mesh.ntriangles;
        s->mesh.P = f->mesh.P;
        s->mesh.N = f->mesh.N;
        s->mesh.uv = f->mesh.uv;
        s->mesh.indices = f->mesh.indices;
        return budget_triangles(P, s->mesh.ntriangles, s->loc);
    }
    return adopt_mesh(P, s, &j->md);
}

/* Runs the queued jobs on the pool, then takes their results in file order, checking the
 * budget's triangle counts in that order too: the failure reported is the first in the
 * file, whatever the number of threads or the order in which the jobs ran. Called at the end
 * of a parse, when the queue holds too many bytes (mesh_job_queue), and when a parse fails
 * (whose own error stands only if nothing queued before it failed: every job and count is from
 * before the point where the parse stopped). Leaves the queue empty. */
static int mesh_jobs_finish(parser_t *P)
{
    int rc = 0;
    if (P->njobs > 0) {
        err_t ignored;
        (void)pool_for(P->threads, (int)P->njobs, mesh_job_run, P->jobs, &ignored);
        P->resolving = true;
        if (P->ncounts > 0) {
            for (size_t i = 0; i < P->ncounts && rc == 0; i++) {
                const tri_count_t *c = &P->counts[i];
                rc = c->job >= 0 ? mesh_job_adopt(P, &P->jobs[c->job])
                                 : budget_triangles(P, c->n, c->loc);
            }
        } else {
            for (size_t i = 0; i < P->njobs && rc == 0; i++)
                rc = mesh_job_adopt(P, &P->jobs[i]);
        }
    }
    for (size_t i = 0; i < P->njobs; i++)
        mesh_job_free(&P->jobs[i]);
    free(P->jobs);
    free(P->counts);
    P->jobs = NULL;
    P->counts = NULL;
    P->njobs = P->ncounts = P->cap_jobs = P->cap_counts = 0;
    P->queued_bytes = 0;
    P->ntriangles_ahead = 0;
    free(P->ply_slots);
    P->ply_slots = NULL;
    P->ply_cap = P->nply = 0;
    P->resolving = false;
    return rc;
}

static int mesh_from_ply(parser_t *P, params_t *ps, scene_shape_t *s, pbrt_loc_t loc)
{
    const char *filename;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0)
        return -1;
    if (!filename)
        return pbrt_error(P->err, loc, "Shape \"plymesh\" needs \"string filename\"");
    param_t *fp = params_find(ps, "filename");
    const char *path = scene_path(P, filename, fp->loc);
    if (!path)
        return -1;
    /* A confined parse reads the file here, in file order, so that the bytes it charges and
     * the files it refuses are the same whatever the threads; the decoding is queued. */
    mesh_job_t j = {.kind = MESH_JOB_PLY_FILE, .loc = fp->loc, .path = path};
    if (P->root_real) {
        size_t len;
        char *real = confine(P, path, filename, &fp->loc, "PLY file");
        char *buf =
            real ? read_confined(P, real, filename, path, &fp->loc, "PLY file", &len) : NULL;
        free(real);
        err_t over;
        if (buf && scene_budget_charge_ply_file(P->budget, &P->used, buf, len, path, &over)) {
            free(buf);
            return fail_at(P, &fp->loc, "%s", over.msg);
        }
        if (!buf || inflate_if_gzip(P, &buf, &len, MESH_PLY_BYTES_MAX, path, &fp->loc) != 0) {
            free(buf);
            return -1;
        }
        j.kind = MESH_JOB_PLY_MEMORY;
        j.buf = buf;
        j.len = len;
    }
    /* Listed here, in file order; in check mode (made at once) only once it is made, as a
     * refused directive adds nothing to the scene. */
    if (!P->errors && note_file(P, SCENE_FILE_PLY, path, filename, fp->loc) != 0) {
        mesh_job_free(&j);
        return -1;
    }
    if (mesh_job_queue(P, s, &j) != 0)
        return -1;
    return P->errors ? note_file(P, SCENE_FILE_PLY, path, filename, fp->loc) : 0;
}

/* pbrt-v4 Cylinder, tessellated (shape_tess.h): a mesh needs no new intersection, area
 * sampling or instancing code in scene/, and 512 segments a turn keep its area and silhouette
 * within 2.5e-5 of the analytic surface, far below a render's noise. */
static int cylinder_shape(parser_t *P, params_t *ps, scene_shape_t *s, pbrt_loc_t loc)
{
    double r, zmin, zmax, phimax;
    if (params_get_float(ps, "radius", 1.0, &r, P->err) != 0 ||
        check_positive(P, ps, "radius", r) != 0 ||
        params_get_float(ps, "zmin", -1.0, &zmin, P->err) != 0 ||
        params_get_float(ps, "zmax", 1.0, &zmax, P->err) != 0 ||
        params_get_float(ps, "phimax", 360.0, &phimax, P->err) != 0 ||
        check_range(P, ps, "phimax", phimax, 1e-6, 360.0) != 0)
        return -1;
    if (zmin == zmax)
        return pbrt_error(P->err, loc, "Shape \"cylinder\": zmin and zmax are both %g (no height)",
                          zmin);
    mesh_data_t md;
    err_t e;
    if (shape_tess_cylinder(r, zmin, zmax, phimax, &md, &e) != 0)
        return pbrt_error(P->err, loc, "Shape \"cylinder\": %s", e.msg);
    s->radius = r;
    return adopt_mesh(P, s, &md);
}

/* pbrt-v4 "loopsubdiv": "integer levels" (3), "point3 P", "integer indices" (3 per control
 * triangle), subdivided here into the mesh pbrt-v4 renders (loopsubdiv.h). */
static int loopsubdiv_shape(parser_t *P, params_t *ps, scene_shape_t *s, pbrt_loc_t loc)
{
    param_t *pp, *pi;
    int levels;
    if (params_get_int(ps, "levels", 3, &levels, P->err) != 0 ||
        check_range(P, ps, "levels", levels, 0.0, 12.0) != 0 ||
        params_get_array(ps, "P", PARAM_POINT3, &pp, P->err) != 0 ||
        params_get_array(ps, "indices", PARAM_INTEGER, &pi, P->err) != 0)
        return -1;
    if (!pp)
        return pbrt_error(P->err, loc, "Shape \"loopsubdiv\" needs \"point3 P\"");
    if (!pi)
        return pbrt_error(P->err, loc, "Shape \"loopsubdiv\" needs \"integer indices\"");
    size_t nv = pp->count / 3;
    if (nv >= UINT32_MAX)
        return pbrt_error(P->err, pp->loc, "too many points in \"point3 P\"");
    if (pi->count % 3 != 0 || pi->count == 0)
        return pbrt_error(P->err, pi->loc,
                          "expected a non-zero multiple of 3 numbers after \"%s %s\", got %zu",
                          pi->type_name, pi->name, pi->count);
    uint32_t *idx = malloc(pi->count * sizeof *idx);
    if (!idx)
        return pbrt_error(P->err, loc, "out of memory");
    for (size_t i = 0; i < pi->count; i++) {
        if (pi->numbers[i] < 0 || pi->numbers[i] >= (double)nv) {
            free(idx);
            return pbrt_error(P->err, pi->loc,
                              "index %.0f (entry %zu of \"integer indices\") is out of range: "
                              "\"point3 P\" has %zu points",
                              pi->numbers[i], i + 1, nv);
        }
        idx[i] = (uint32_t)pi->numbers[i];
    }
    /* Each level makes four triangles of one: counted before anything is subdivided. */
    uint64_t after = pi->count / 3;
    for (int l = 0; l < levels && after <= UINT64_MAX / 4; l++)
        after *= 4;
    if (P->budget && P->budget->triangles) {
        /* Queued meshes not yet made count as none: the bound is a lower one, so a refusal
         * here is right, and mesh_jobs_finish finds whether one of them failed first. */
        uint64_t lower = P->ntriangles + P->ntriangles_ahead;
        if (lower < P->ntriangles || lower > P->budget->triangles ||
            after > P->budget->triangles - lower) {
            free(idx);
            if (P->njobs > 0 && note_count(P, -1, after, loc) != 0)
                return -1;
            return budget_refuse(P, after, loc);
        }
    }
    mesh_job_t j = {.kind = MESH_JOB_LOOP,
                    .loc = loc,
                    .idx = idx,
                    .nv = nv,
                    .nt = pi->count / 3,
                    .levels = levels};
    if (!(j.P = malloc(pp->count * sizeof *j.P))) {
        free(idx);
        return pbrt_error(P->err, loc, "out of memory");
    }
    memcpy(j.P, pp->numbers, pp->count * sizeof *j.P);
    return mesh_job_queue(P, s, &j);
}

static int do_shape(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    static const struct {
        const char *name;
        scene_shape_type_t type;
    } KINDS[] = {{"sphere", SCENE_SHAPE_SPHERE},
                 {"disk", SCENE_SHAPE_DISK},
                 {"trianglemesh", SCENE_SHAPE_MESH},
                 {"plymesh", SCENE_SHAPE_MESH},
                 {"bilinearmesh", SCENE_SHAPE_MESH},
                 {"loopsubdiv", SCENE_SHAPE_MESH},
                 {"cylinder", SCENE_SHAPE_MESH}};
    int ki = -1;
    for (size_t i = 0; i < COUNT_OF(KINDS); i++)
        if (!strcmp(type->s, KINDS[i].name))
            ki = (int)i;
    if (ki < 0)
        return pbrt_error(P->err, type->loc,
                          "unsupported shape \"%s\" (\"sphere\", \"disk\", \"cylinder\", "
                          "\"trianglemesh\", \"plymesh\", \"bilinearmesh\" or \"loopsubdiv\")",
                          type->s);
    if (check_transform(P, &P->gs.ctm, "Shape", loc) != 0)
        return -1;
    bool in_object = P->object >= 0;
    if (in_object && P->gs.area_light >= 0)
        return pbrt_error(P->err, loc,
                          "area lights are not supported inside ObjectBegin "
                          "(AreaLightSource at line %d)",
                          P->scene->area_lights[P->gs.area_light].loc.line);
    if (budget_shape(P, "Shape", loc) != 0)
        return -1;
    int idx = scene_desc_add_shape(P->scene, in_object, P->err);
    if (idx < 0)
        return -1;
    scene_shape_t *s = in_object ? &P->scene->object_shapes[idx] : &P->scene->shapes[idx];
    s->type = KINDS[ki].type;
    s->kind = KINDS[ki].name;
    s->loc = loc;
    s->to_world = P->gs.ctm;
    s->reverse_orientation = P->gs.reverse;
    s->swaps_handedness = transform_swaps_handedness(&P->gs.ctm);
    s->flip_normals = s->reverse_orientation != s->swaps_handedness;
    s->material = P->gs.material;
    s->area_light = P->gs.area_light;
    s->inside_medium = P->gs.inside_medium;
    s->outside_medium = P->gs.outside_medium;
    if (get_float_input(P, ps, "alpha", 1.0, &s->alpha) != 0)
        return -1;
    s->has_alpha = s->alpha.texture >= 0 || s->alpha.value < 1.0;
    /* pbrt-v4 displaces triangle meshes by a texture at load time; prismfarm does not. */
    param_t *disp = params_find(ps, "displacement");
    if (disp) {
        (void)params_find(ps, "edgelength");
        if (warnings_add(P->scene->warnings, disp->loc,
                         "Shape \"%s\": \"displacement\" is not simulated (the surface is "
                         "rendered undisplaced)",
                         s->kind) != 0)
            return pbrt_error(P->err, disp->loc, "out of memory");
    }
    switch (s->type) {
    case SCENE_SHAPE_SPHERE: {
        double zmin, zmax, phimax;
        if (params_get_float(ps, "radius", 1.0, &s->radius, P->err) != 0 ||
            check_positive(P, ps, "radius", s->radius) != 0 ||
            params_get_float(ps, "zmin", -s->radius, &zmin, P->err) != 0 ||
            params_get_float(ps, "zmax", s->radius, &zmax, P->err) != 0 ||
            params_get_float(ps, "phimax", 360.0, &phimax, P->err) != 0 ||
            check_range(P, ps, "phimax", phimax, 1e-6, 360.0) != 0)
            return -1;
        if (fmin(zmin, zmax) <= -s->radius && fmax(zmin, zmax) >= s->radius && phimax >= 360.0)
            return 0; /* the whole sphere: analytic in Embree */
        if (fmin(fmax(zmin, zmax), s->radius) <= fmax(fmin(zmin, zmax), -s->radius))
            return pbrt_error(P->err, loc, "Shape \"sphere\": zmin %g and zmax %g leave nothing "
                                           "of a sphere of radius %g", zmin, zmax, s->radius);
        mesh_data_t md;
        err_t e;
        if (shape_tess_sphere(s->radius, zmin, zmax, phimax, &md, &e) != 0)
            return pbrt_error(P->err, loc, "Shape \"sphere\": %s", e.msg);
        s->type = SCENE_SHAPE_MESH;
        return adopt_mesh(P, s, &md);
    }
    case SCENE_SHAPE_DISK: {
        double inner;
        if (params_get_float(ps, "radius", 1.0, &s->radius, P->err) != 0 ||
            params_get_float(ps, "height", 0.0, &s->height, P->err) != 0 ||
            params_get_float(ps, "innerradius", 0.0, &inner, P->err) != 0 ||
            check_positive(P, ps, "radius", s->radius) != 0)
            return -1;
        if (inner != 0.0)
            return pbrt_error(P->err, params_find(ps, "innerradius")->loc,
                              "unsupported parameter value: \"float innerradius\" must be 0 "
                              "(annuli are not supported)");
        return 0;
    }
    case SCENE_SHAPE_MESH:
        if (!strcmp(s->kind, "plymesh"))
            return mesh_from_ply(P, ps, s, loc);
        if (!strcmp(s->kind, "cylinder"))
            return cylinder_shape(P, ps, s, loc);
        if (!strcmp(s->kind, "loopsubdiv"))
            return loopsubdiv_shape(P, ps, s, loc);
        return mesh_from_params(P, ps, s, !strcmp(s->kind, "bilinearmesh"), loc);
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------
 * Directives
 * ------------------------------------------------------------------------------------------ */

static int parse_file(parser_t *P, const char *path, const pbrt_loc_t *from, scene_file_kind_t kind,
                      const char *name);

/* Gives ps the `Attribute` defaults in effect for kind that it does not set itself; the
 * newest Attribute wins over older ones, as in pbrt-v4. */
static int attr_apply(parser_t *P, params_t *ps, int kind)
{
    for (const attr_node_t *n = P->gs.attr[kind]; n; n = n->older)
        if (params_add_defaults(ps, n->ps, P->err) != 0)
            return -1;
    return 0;
}

/* Attribute "shape" | "light" | "material" | "medium" | "texture" params: default parameter
 * values for the entities of that kind that follow, until the attribute block ends. */
static int do_attribute(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t target;
    if (read_string(P, "Attribute", loc, "attribute target", &target) != 0)
        return -1;
    int kind = -1;
    for (int k = 0; k < ATTR_KINDS; k++)
        if (!strcmp(target.s, ATTR_KIND_NAMES[k]))
            kind = k;
    if (kind < 0)
        return pbrt_error(P->err, target.loc,
                          "unknown Attribute target \"%s\" (expected \"shape\", \"light\", "
                          "\"material\", \"medium\" or \"texture\")",
                          target.s);
    char context[64];
    snprintf(context, sizeof context, "Attribute \"%.16s\"", target.s);
    params_t *ps = read_params(P, context);
    if (!ps)
        return -1;
    if (need_world(P, "Attribute", loc) != 0) {
        params_destroy(&ps);
        return -1;
    }
    attr_node_t *n = malloc(sizeof *n);
    if (!n) {
        params_destroy(&ps);
        return err_set(P->err, "out of memory");
    }
    n->ps = ps;
    n->older = P->gs.attr[kind];
    n->next_owned = P->attr_owned;
    P->attr_owned = n;
    P->gs.attr[kind] = n;
    return 0;
}

/* pbrt-v4's rendering options (its Options struct), as `Option "name" value` sets them; kind
 * says what value each takes. Only "seed" changes prismfarm's image; the others are debugging
 * or output switches of pbrt-v4 (or, for forcediffuse and the jitter switches, deliberate
 * departures from the scene) that are checked and warned. */
typedef enum { OPT_BOOL, OPT_FLOAT, OPT_STRING, OPT_INT } option_kind_t;
static const struct {
    const char *name;
    option_kind_t kind;
    const char *why; /* NULL: simulated */
} OPTIONS[] = {
    {"seed", OPT_INT, NULL},
    {"disablepixeljitter", OPT_BOOL, "samples stay jittered within their pixel"},
    {"disablewavelengthjitter", OPT_BOOL, "wavelengths stay jittered"},
    {"disabletexturefiltering", OPT_BOOL, "textures stay filtered"},
    {"forcediffuse", OPT_BOOL, "materials keep their own BSDFs"},
    {"displacementedgescale", OPT_FLOAT, "displacement is not simulated"},
    {"msereferenceimage", OPT_STRING, "use bench_accuracy_diff to compare with a reference"},
    {"msereferenceout", OPT_STRING, "use bench_accuracy_diff to compare with a reference"},
    {"rendercoordsys", OPT_STRING, "prismfarm renders in world space"},
    {"pixelstats", OPT_BOOL, "no per-pixel statistics images"},
    {"wavefront", OPT_BOOL, "prismfarm has one CPU renderer"},
};

/* Option "name" value (pbrt-v4: a bare true/false, a number or a quoted string). */
static int do_option(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name;
    if (read_string(P, "Option", loc, "option name", &name) != 0)
        return -1;
    int k = -1;
    for (size_t i = 0; i < COUNT_OF(OPTIONS); i++)
        if (!strcmp(name.s, OPTIONS[i].name))
            k = (int)i;
    if (k < 0) {
        char names[512] = "";
        for (size_t i = 0; i < COUNT_OF(OPTIONS); i++)
            snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s",
                     i ? ", " : "", OPTIONS[i].name);
        return pbrt_error(P->err, name.loc, "unknown option \"%s\" (pbrt-v4's options: %s)",
                          name.s, names);
    }
    pbrt_token_t t;
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    pbrt_loc_t vloc = t.kind == PBRT_TOKEN_EOF ? name.loc : t.loc;
    char *end = NULL;
    double v = 0.0;
    switch (OPTIONS[k].kind) {
    case OPT_BOOL:
        if (t.kind != PBRT_TOKEN_WORD || (strcmp(t.text, "true") && strcmp(t.text, "false")))
            return pbrt_error(P->err, vloc, "Option \"%s\" expects true or false", name.s);
        break;
    case OPT_STRING:
        if (t.kind != PBRT_TOKEN_STRING)
            return pbrt_error(P->err, vloc, "Option \"%s\" expects a quoted string", name.s);
        if (!strcmp(name.s, "rendercoordsys") && strcmp(t.text, "camera") &&
            strcmp(t.text, "cameraworld") && strcmp(t.text, "world"))
            return pbrt_error(P->err, vloc,
                              "Option \"rendercoordsys\" expects \"camera\", \"cameraworld\" "
                              "or \"world\", got \"%.64s\"",
                              t.text);
        break;
    case OPT_FLOAT:
    case OPT_INT:
        if (t.kind == PBRT_TOKEN_WORD)
            v = strtod(t.text, &end);
        if (t.kind != PBRT_TOKEN_WORD || end == t.text || *end || !isfinite(v) ||
            (OPTIONS[k].kind == OPT_INT && (v != floor(v) || fabs(v) > 2147483647.0)))
            return pbrt_error(P->err, vloc, "Option \"%s\" expects %s", name.s,
                              OPTIONS[k].kind == OPT_INT ? "an integer" : "a number");
        break;
    }
    if (!OPTIONS[k].why) { /* seed */
        P->option_seed_set = true;
        P->option_seed = (int)v;
        return 0;
    }
    /* Switching a debugging option off is what prismfarm does anyway: no warning. */
    if (OPTIONS[k].kind == OPT_BOOL && !strcmp(t.text, "false"))
        return 0;
    return warnings_add(P->scene->warnings, loc, "Option \"%s\" is not simulated (%s)", name.s,
                        OPTIONS[k].why)
               ? err_set(P->err, "out of memory")
               : 0;
}

/* Directives of the form: Name "type" params. */
static int param_directive(parser_t *P, const char *dir, pbrt_loc_t loc)
{
    str_arg_t type;
    const char *what = !strcmp(dir, "MakeNamedMaterial") ? "material name" : "type name";
    if (read_string(P, dir, loc, what, &type) != 0)
        return -1;
    char context[192];
    snprintf(context, sizeof context, "%s \"%.100s%s\"", dir, type.s,
             strlen(type.s) > 100 ? "..." : "");
    params_t *ps = read_params(P, context);
    if (!ps)
        return -1;
    int rc = -1;
    bool keep = false;
    int kind = !strcmp(dir, "Shape")                                              ? ATTR_SHAPE
               : !strcmp(dir, "Material") || !strcmp(dir, "MakeNamedMaterial")      ? ATTR_MATERIAL
               : !strcmp(dir, "LightSource") || !strcmp(dir, "AreaLightSource") ? ATTR_LIGHT
                                                                                  : -1;
    if (kind >= 0 && attr_apply(P, ps, kind) != 0)
        goto done;
    if (!strcmp(dir, "Camera")) {
        rc = need_options(P, dir, loc) || do_camera(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "Film")) {
        rc = need_options(P, dir, loc) || do_film(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "Sampler")) {
        rc = need_options(P, dir, loc) || do_sampler(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "PixelFilter")) {
        rc = need_options(P, dir, loc) || do_pixelfilter(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "Integrator")) {
        if (need_options(P, dir, loc) != 0)
            goto done;
        const integrator_name_t *named = integrators_find(type.s);
        if (!named) {
            char names[INTEGRATORS_LIST_MAX];
            integrators_list(false, names, sizeof names);
            const char *best = integrators_suggest(type.s);
            if (best)
                pbrt_error(P->err, type.loc, "unsupported integrator \"%s\" (did you mean \"%s\"? %s)",
                           type.s, best, names);
            else
                pbrt_error(P->err, type.loc, "unsupported integrator \"%s\" (%s)", type.s, names);
            goto done;
        }
        if (named->refused) {
            pbrt_error(P->err, type.loc, "unsupported integrator \"%s\": %s", type.s, named->refused);
            goto done;
        }
        scene_integrator_t *in = &P->scene->integrator;
        in->type = scene_desc_strdup(P->scene, type.s, P->err);
        if (!in->type)
            goto done;
        in->loc = loc;
        params_destroy(&in->params);
        in->params = ps; /* checked by the renderer, which knows what it uses */
        keep = true;
        rc = 0;
        goto done;
    } else if (!strcmp(dir, "Shape")) {
        rc = need_world(P, dir, loc) || do_shape(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "Material")) {
        rc = need_world(P, dir, loc) || do_material(P, ps, &type, NULL, loc, type.loc) ? -1 : 0;
    } else if (!strcmp(dir, "MakeNamedMaterial")) {
        if (need_world(P, dir, loc) != 0)
            goto done;
        int prev = scene_desc_find_material(P->scene, type.s);
        if (prev >= 0) {
            pbrt_error(P->err, type.loc, "named material \"%s\" is already defined (line %d)",
                       type.s, P->scene->materials[prev].loc.line);
            goto done;
        }
        const char *mtype;
        if (params_get_string(ps, "type", NULL, &mtype, P->err) != 0)
            goto done;
        if (!mtype) {
            pbrt_error(P->err, loc, "MakeNamedMaterial \"%s\" needs \"string type\"", type.s);
            goto done;
        }
        str_arg_t mt;
        snprintf(mt.s, sizeof mt.s, "%s", mtype);
        mt.loc = params_find(ps, "type")->loc;
        rc = do_material(P, ps, &mt, type.s, loc, mt.loc);
    } else if (!strcmp(dir, "AreaLightSource")) {
        rc = need_world(P, dir, loc) || do_area_light(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "LightSource")) {
        rc = need_world(P, dir, loc) || do_light(P, ps, &type, loc) ? -1 : 0;
    }
    if (rc == 0)
        rc = params_check_unused(ps, P->err);
done:
    if (!keep)
        params_destroy(&ps);
    return rc;
}

static int do_texture_directive(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name, type, cls;
    if (read_string(P, "Texture", loc, "texture name", &name) != 0 ||
        read_string(P, "Texture", loc, "texture type (\"float\" or \"spectrum\")", &type) != 0 ||
        read_string(P, "Texture", loc, "texture class", &cls) != 0)
        return -1;
    char context[192];
    snprintf(context, sizeof context, "Texture \"%.100s\"", cls.s);
    params_t *ps = read_params(P, context);
    if (!ps)
        return -1;
    int rc = attr_apply(P, ps, ATTR_TEXTURE) || need_world(P, "Texture", loc) ||
                     do_texture(P, ps, &name, &type, &cls, loc) ||
                     params_check_unused(ps, P->err)
                 ? -1
                 : 0;
    params_destroy(&ps);
    return rc;
}

static int end_frame(parser_t *P, int kind, const char *dir, pbrt_loc_t loc)
{
    if (P->nframes == 0)
        return pbrt_error(P->err, loc, "%s without a matching %s", dir,
                          kind == FRAME_OBJECT ? "ObjectBegin" : "AttributeBegin");
    frame_t *top = &P->frames[P->nframes - 1];
    if (top->kind == FRAME_IMPORT)
        return pbrt_error(P->err, loc, "%s without a matching %s in this imported file", dir,
                          kind == FRAME_OBJECT ? "ObjectBegin" : "AttributeBegin");
    if (top->kind != kind)
        return pbrt_error(P->err, loc, "%s closes %s at line %d (mismatched nesting)", dir,
                          top->what, top->loc.line);
    P->gs = top->gs;
    P->nframes--;
    return 0;
}

static int do_object_begin(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name;
    if (read_string(P, "ObjectBegin", loc, "object name", &name) != 0 ||
        need_world(P, "ObjectBegin", loc) != 0)
        return -1;
    if (P->object >= 0)
        return pbrt_error(P->err, loc, "ObjectBegin inside ObjectBegin \"%s\" (line %d)",
                          P->scene->objects[P->object].name, P->scene->objects[P->object].loc.line);
    int prev = scene_desc_find_object(P->scene, name.s);
    if (prev >= 0)
        return pbrt_error(P->err, name.loc, "object \"%s\" is already defined (line %d)", name.s,
                          P->scene->objects[prev].loc.line);
    if (push_frame(P, FRAME_OBJECT, "ObjectBegin", loc) != 0)
        return -1;
    int idx = scene_desc_add_object(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_object_t *o = &P->scene->objects[idx];
    o->name = scene_desc_strdup(P->scene, name.s, P->err);
    if (!o->name)
        return -1;
    o->loc = loc;
    o->first_shape = P->scene->nobject_shapes;
    P->object = idx;
    return 0;
}

static int do_object_end(parser_t *P, pbrt_loc_t loc)
{
    if (need_world(P, "ObjectEnd", loc) != 0)
        return -1;
    if (P->object < 0)
        return pbrt_error(P->err, loc, "ObjectEnd without a matching ObjectBegin");
    if (end_frame(P, FRAME_OBJECT, "ObjectEnd", loc) != 0)
        return -1;
    scene_object_t *o = &P->scene->objects[P->object];
    o->nshapes = P->scene->nobject_shapes - o->first_shape;
    P->object = -1;
    return 0;
}

static int do_object_instance(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name;
    if (read_string(P, "ObjectInstance", loc, "object name", &name) != 0 ||
        need_world(P, "ObjectInstance", loc) != 0)
        return -1;
    if (P->object >= 0)
        return pbrt_error(P->err, loc, "ObjectInstance inside ObjectBegin \"%s\" is not supported",
                          P->scene->objects[P->object].name);
    if (check_transform(P, &P->gs.ctm, "ObjectInstance", loc) != 0 ||
        budget_shape(P, "ObjectInstance", loc) != 0)
        return -1;
    int idx = scene_desc_add_instance(P->scene, P->err);
    if (idx < 0)
        return -1;
    if ((size_t)idx >= P->cap_pending) {
        size_t cap = P->scene->cap_instances;
        const char **p = realloc(P->pending, cap * sizeof *p);
        if (!p)
            return pbrt_error(P->err, loc, "out of memory");
        P->pending = p;
        P->cap_pending = cap;
    }
    scene_instance_t *in = &P->scene->instances[idx];
    in->object = -1;
    in->loc = loc;
    in->to_world = P->gs.ctm;
    in->swaps_handedness = transform_swaps_handedness(&P->gs.ctm);
    /* pbrt-v4 resolves instances at the end, so an object may be defined after its use. */
    P->pending[idx] = scene_desc_strdup(P->scene, name.s, P->err);
    return P->pending[idx] ? 0 : -1;
}

static int do_include(parser_t *P, bool import, pbrt_loc_t loc)
{
    const char *dir = import ? "Import" : "Include";
    str_arg_t name;
    if (read_string(P, dir, loc, "file name", &name) != 0)
        return -1;
    if (import && need_world(P, dir, loc) != 0)
        return -1;
    char *path = locate(P, name.s);
    if (!path)
        return pbrt_error(P->err, loc, "out of memory");
    /* Import reads the file with a copy of the graphics state: nothing it changes (CTM,
     * material, attributes) leaks back into the importing file (pbrt-v4 CopyForImport). */
    if (import && push_frame(P, FRAME_IMPORT, "Import", loc) != 0) {
        free(path);
        return -1;
    }
    const char *outer_file = P->file;
    pbrt_lexer_t *outer_lex = P->lex;
    int rc = parse_file(P, path, &name.loc, SCENE_FILE_INCLUDE, name.s);
    free(path);
    const char *inner_file = P->file;
    P->file = outer_file;
    P->lex = outer_lex;
    if (rc != 0 || !import)
        return rc;
    frame_t *top = &P->frames[P->nframes - 1];
    if (top->kind != FRAME_IMPORT)
        return pbrt_error(P->err, top->loc,
                          "%s has no matching end before the end of imported "
                          "file \"%s\"",
                          top->what, inner_file);
    P->gs = top->gs;
    P->nframes--;
    return 0;
}

static int do_transform_directive(parser_t *P, const char *dir, pbrt_loc_t loc)
{
    double v[16];
    transform_t t;
    err_t e;
    if (!strcmp(dir, "Translate")) {
        if (read_numbers(P, dir, loc, v, 3) != 0)
            return -1;
        t = transform_translate(vec3_make(v[0], v[1], v[2]));
    } else if (!strcmp(dir, "Scale")) {
        if (read_numbers(P, dir, loc, v, 3) != 0)
            return -1;
        t = transform_scale(v[0], v[1], v[2]);
    } else if (!strcmp(dir, "Rotate")) {
        if (read_numbers(P, dir, loc, v, 4) != 0)
            return -1;
        if (transform_rotate(v[0], vec3_make(v[1], v[2], v[3]), &t, &e) != 0)
            return pbrt_error(P->err, loc, "Rotate: %s", e.msg);
    } else if (!strcmp(dir, "LookAt")) {
        if (read_numbers(P, dir, loc, v, 9) != 0)
            return -1;
        if (transform_look_at(vec3_make(v[0], v[1], v[2]), vec3_make(v[3], v[4], v[5]),
                              vec3_make(v[6], v[7], v[8]), &t, &e) != 0)
            return pbrt_error(P->err, loc, "%s", e.msg);
    } else {
        if (read_matrix(P, dir, loc, v) != 0)
            return -1;
        t = transform_from_pbrt_array(v);
        if (!strcmp(dir, "Transform")) {
            P->gs.ctm = t;
            return 0;
        }
    }
    P->gs.ctm = transform_compose(P->gs.ctm, t);
    return 0;
}

/* ---- Directives prismfarm accepts without simulating them (each warns, as pbrt-v4 does for
 * what it ignores) ---- */

/* MakeNamedMedium "name" "string type" ... (pbrt-v4 media.cpp): "homogeneous" and
 * "uniformgrid" are read with pbrt-v4's parameters and defaults; "rgbgrid", "cloud" and
 * "nanovdb" are accepted with a warning and render as vacuum. Whether media are simulated at
 * all depends on the integrator (the loader says so). */
static int read_medium_common(parser_t *P, params_t *ps, scene_medium_t *m)
{
    pbrt_loc_t at = m->loc;
    m->sigma_a = spectrum_constant(1.0, at);
    m->sigma_s = spectrum_constant(1.0, at);
    const char *preset = NULL;
    if (m->type == SCENE_MEDIUM_HOMOGENEOUS &&
        params_get_string(ps, "preset", NULL, &preset, P->err) != 0)
        return -1;
    bool have_preset = false;
    if (preset && preset[0]) {
        double ss[3], sa[3];
        if (medium_preset_find(preset, ss, sa)) {
            have_preset = true;
            m->sigma_a = (scene_spectrum_t){.kind = SCENE_SPECTRUM_RGB, .rgb = {sa[0], sa[1], sa[2]}, .loc = params_find(ps, "preset")->loc};
            m->sigma_s = (scene_spectrum_t){.kind = SCENE_SPECTRUM_RGB, .rgb = {ss[0], ss[1], ss[2]}, .loc = params_find(ps, "preset")->loc};
        } else if (warnings_add(P->scene->warnings, params_find(ps, "preset")->loc,
                                "medium preset \"%s\" is not known (pbrt-v4's table of measured media); "
                                "\"sigma_a\" and \"sigma_s\" apply",
                                preset)) {
            return err_set(P->err, "out of memory");
        }
    }
    if (!have_preset && (get_spectrum(P, ps, "sigma_a", m->sigma_a, SPECTRUM_ANY, &m->sigma_a) != 0 ||
                         get_spectrum(P, ps, "sigma_s", m->sigma_s, SPECTRUM_ANY, &m->sigma_s) != 0))
        return -1;
    if (have_preset) {
        /* pbrt-v4 reads the preset instead: the two spectra are not looked at. */
        param_t *q;
        if ((q = params_find(ps, "sigma_a")))
            q->used = true;
        if ((q = params_find(ps, "sigma_s")))
            q->used = true;
    }
    if (params_get_float(ps, "scale", 1.0, &m->scale, P->err) != 0 ||
        check_range(P, ps, "scale", m->scale, 0.0, INFINITY) != 0 ||
        params_get_float(ps, "g", 0.0, &m->g, P->err) != 0)
        return -1;
    if (!(m->g > -1.0 && m->g < 1.0)) {
        param_t *q = params_find(ps, "g");
        return pbrt_error(P->err, q ? q->loc : at, "\"float g\" must be in (-1, 1), got %g", m->g);
    }
    if (params_find(ps, "Le")) {
        m->has_Le = true;
        if (get_spectrum(P, ps, "Le", spectrum_constant(0.0, at), SPECTRUM_ANY, &m->Le) != 0)
            return -1;
    }
    m->Le_scale = 1.0;
    if (m->type == SCENE_MEDIUM_HOMOGENEOUS &&
        (params_get_float(ps, "Lescale", 1.0, &m->Le_scale, P->err) != 0 ||
         check_range(P, ps, "Lescale", m->Le_scale, 0.0, INFINITY) != 0))
        return -1;
    return 0;
}

static int read_medium_grid(parser_t *P, params_t *ps, scene_medium_t *m)
{
    param_t *d = NULL, *temp = NULL, *les = NULL;
    if (params_get_array(ps, "density", PARAM_FLOAT, &d, P->err) != 0 ||
        params_get_array(ps, "temperature", PARAM_FLOAT, &temp, P->err) != 0 ||
        params_get_array(ps, "Lescale", PARAM_FLOAT, &les, P->err) != 0 ||
        params_get_int(ps, "nx", 1, &m->nx, P->err) != 0 ||
        params_get_int(ps, "ny", 1, &m->ny, P->err) != 0 ||
        params_get_int(ps, "nz", 1, &m->nz, P->err) != 0 ||
        params_get_point3(ps, "p0", vec3_make(0, 0, 0), &m->p0, P->err) != 0 ||
        params_get_point3(ps, "p1", vec3_make(1, 1, 1), &m->p1, P->err) != 0)
        return -1;
    if (!d)
        return pbrt_error(P->err, m->loc, "MakeNamedMedium \"%s\": a \"uniformgrid\" medium needs \"float density\" values", m->name);
    if (m->nx < 1 || m->ny < 1 || m->nz < 1)
        return pbrt_error(P->err, m->loc, "MakeNamedMedium \"%s\": \"nx\", \"ny\" and \"nz\" must be at least 1, got %d %d %d",
                          m->name, m->nx, m->ny, m->nz);
    if ((double)m->nx * m->ny * m->nz != (double)d->count)
        return pbrt_error(P->err, d->loc, "MakeNamedMedium \"%s\": %zu \"density\" values, expected nx*ny*nz = %d*%d*%d",
                          m->name, d->count, m->nx, m->ny, m->nz);
    for (size_t i = 0; i < d->count; i++)
        if (!(d->numbers[i] >= 0.0) || !isfinite(d->numbers[i]))
            return pbrt_error(P->err, d->loc, "MakeNamedMedium \"%s\": \"density\" value %zu is %g, expected a finite value >= 0",
                              m->name, i, d->numbers[i]);
    if (!(m->p1.x > m->p0.x && m->p1.y > m->p0.y && m->p1.z > m->p0.z))
        return pbrt_error(P->err, m->loc, "MakeNamedMedium \"%s\": \"p1\" must exceed \"p0\" on every axis", m->name);
    if (!(m->density = copy_doubles(P, d->numbers, d->count)))
        return -1;
    if (temp) {
        /* pbrt-v4 emits blackbody light from a temperature grid; prismfarm does not. */
        const char *extra[] = {"temperaturecutoff", "temperatureoffset", "temperaturescale"};
        for (size_t i = 0; i < COUNT_OF(extra); i++) {
            param_t *q = params_find(ps, extra[i]);
            if (q)
                q->used = true;
        }
        if (warnings_add(P->scene->warnings, temp->loc,
                         "the \"temperature\" grid of medium \"%s\" is not simulated: its blackbody "
                         "emission is missing from the image", m->name))
            return err_set(P->err, "out of memory");
    }
    if (les && les->count == 1) {
        m->Le_scale = les->numbers[0];
    } else if (les) {
        if (warnings_add(P->scene->warnings, les->loc,
                         "the per-voxel \"Lescale\" of medium \"%s\" is not simulated: the medium "
                         "does not emit", m->name))
            return err_set(P->err, "out of memory");
        m->has_Le = false;
    }
    if (!(m->Le_scale >= 0.0) || !isfinite(m->Le_scale))
        return pbrt_error(P->err, les->loc, "\"float Lescale\" must be finite and >= 0, got %g", m->Le_scale);
    return 0;
}

static int do_make_medium(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name;
    if (read_string(P, "MakeNamedMedium", loc, "medium name", &name) != 0)
        return -1;
    params_t *ps = read_params(P, "MakeNamedMedium");
    if (!ps)
        return -1;
    const char *type = NULL;
    int rc = attr_apply(P, ps, ATTR_MEDIUM);
    if (rc == 0)
        rc = params_get_string(ps, "type", NULL, &type, P->err);
    if (rc == 0 && !type)
        rc = pbrt_error(P->err, loc, "MakeNamedMedium \"%s\" needs \"string type\"", name.s);
    if (rc == 0 && scene_desc_find_medium(P->scene, name.s) >= 0)
        rc = pbrt_error(P->err, name.loc, "medium \"%s\" is already defined", name.s);
    scene_medium_type_t kind = SCENE_MEDIUM_IGNORED;
    if (rc == 0) {
        if (!strcmp(type, "homogeneous"))
            kind = SCENE_MEDIUM_HOMOGENEOUS;
        else if (!strcmp(type, "uniformgrid"))
            kind = SCENE_MEDIUM_GRID;
        else if (strcmp(type, "rgbgrid") && strcmp(type, "cloud") && strcmp(type, "nanovdb"))
            rc = pbrt_error(P->err, params_find(ps, "type")->loc,
                            "unknown medium type \"%s\" (\"homogeneous\", \"uniformgrid\", \"rgbgrid\", "
                            "\"cloud\" or \"nanovdb\")",
                            type);
    }
    if (rc == 0 && kind == SCENE_MEDIUM_GRID && check_transform(P, &P->gs.ctm, "MakeNamedMedium \"uniformgrid\"", loc) != 0)
        rc = -1;
    int idx = rc == 0 ? scene_desc_add_medium(P->scene, P->err) : -1;
    if (rc == 0 && idx < 0)
        rc = -1;
    if (rc == 0) {
        scene_medium_t *m = &P->scene->media[idx];
        m->type = kind;
        m->loc = loc;
        m->to_world = P->gs.ctm;
        if (!(m->name = scene_desc_strdup(P->scene, name.s, P->err)) ||
            !(m->type_name = scene_desc_strdup(P->scene, type, P->err)))
            rc = -1;
        if (!P->scene->media_loc.file)
            P->scene->media_loc = loc;
        if (rc == 0 && kind == SCENE_MEDIUM_IGNORED) {
            params_accept_all(ps);
            if (warnings_add(P->scene->warnings, loc,
                             "\"%s\" media are not simulated: medium \"%s\" renders as vacuum", type,
                             name.s))
                rc = err_set(P->err, "out of memory");
        } else if (rc == 0) {
            rc = read_medium_common(P, ps, m);
            if (rc == 0 && kind == SCENE_MEDIUM_GRID)
                rc = read_medium_grid(P, ps, m);
            if (rc == 0)
                rc = params_check_unused(ps, P->err);
        }
    }
    params_destroy(&ps);
    return rc;
}

/* MediumInterface "inside" ["outside"] (one name: both): the media that shapes from here on
 * separate, and the camera's (the outside one) at Camera. "" is vacuum. */
static int do_medium_interface(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t names[2];
    if (read_string(P, "MediumInterface", loc, "medium name", &names[0]) != 0)
        return -1;
    int n = 1;
    pbrt_token_t t;
    if (pbrt_lexer_peek(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind == PBRT_TOKEN_STRING) {
        if (read_string(P, "MediumInterface", loc, "medium name", &names[1]) != 0)
            return -1;
        n = 2;
    }
    int idx[2] = {-1, -1};
    for (int i = 0; i < n; i++)
        if (names[i].s[0] && (idx[i] = scene_desc_find_medium(P->scene, names[i].s)) < 0)
            return pbrt_error(P->err, names[i].loc,
                              "medium \"%s\" is not defined (MakeNamedMedium must come before its "
                              "use)",
                              names[i].s);
    P->gs.inside_medium = idx[0];
    P->gs.outside_medium = n == 2 ? idx[1] : idx[0];
    return 0;
}

/* ActiveTransform StartTime | EndTime | All. prismfarm renders the scene at the shutter's
 * opening (no motion blur): transforms given for the end time alone are ignored, with a
 * warning; All and StartTime apply them as usual. */
static int do_active_transform(parser_t *P, pbrt_loc_t loc)
{
    pbrt_token_t t;
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind != PBRT_TOKEN_WORD ||
        (strcmp(t.text, "StartTime") && strcmp(t.text, "EndTime") && strcmp(t.text, "All"))) {
        char d[96];
        describe(&t, d, sizeof d);
        return pbrt_error(P->err, t.kind == PBRT_TOKEN_EOF ? loc : t.loc,
                          "ActiveTransform expects StartTime, EndTime or All, got %s", d);
    }
    P->gs.end_time_only = !strcmp(t.text, "EndTime");
    /* StartTime or EndTime alone: what follows makes the start and end transforms differ. */
    if (strcmp(t.text, "All") != 0 &&
        warnings_add(P->scene->warnings, loc,
                     "motion blur is not simulated: the scene renders as at the shutter's "
                     "opening (the transforms for its end are ignored)"))
        return err_set(P->err, "out of memory");
    return 0;
}

static int directive(parser_t *P, const char *dir, pbrt_loc_t loc)
{
    static const char *PARAM_DIRECTIVES[] = {
        "Camera",     "Film",     "Sampler",           "Integrator",        "PixelFilter",
        "Shape",      "Material", "MakeNamedMaterial", "AreaLightSource",
        "LightSource"};
    static const char *TRANSFORMS[] = {"Translate", "Scale",     "Rotate",
                                       "LookAt",    "Transform", "ConcatTransform"};
    if (in_list(dir, PARAM_DIRECTIVES, COUNT_OF(PARAM_DIRECTIVES)))
        return param_directive(P, dir, loc);
    if (in_list(dir, TRANSFORMS, COUNT_OF(TRANSFORMS))) {
        if (!P->gs.end_time_only)
            return do_transform_directive(P, dir, loc);
        transform_t keep = P->gs.ctm; /* read (and check) it, then leave the start CTM */
        int rc = do_transform_directive(P, dir, loc);
        P->gs.ctm = keep;
        return rc;
    }
    if (!strcmp(dir, "Identity")) {
        if (!P->gs.end_time_only)
            P->gs.ctm = transform_identity();
        return 0;
    }
    if (!strcmp(dir, "MakeNamedMedium"))
        return do_make_medium(P, loc);
    if (!strcmp(dir, "Attribute"))
        return do_attribute(P, loc);
    if (!strcmp(dir, "Option"))
        return do_option(P, loc);
    if (!strcmp(dir, "MediumInterface"))
        return do_medium_interface(P, loc);
    if (!strcmp(dir, "ActiveTransform"))
        return do_active_transform(P, loc);
    if (!strcmp(dir, "TransformTimes")) {
        double v[2];
        if (read_numbers(P, dir, loc, v, 2) != 0)
            return -1;
        return warnings_add(P->scene->warnings, loc,
                            "TransformTimes %g %g is ignored (no motion blur)", v[0], v[1])
                   ? err_set(P->err, "out of memory")
                   : 0;
    }
    if (!strcmp(dir, "ColorSpace")) {
        str_arg_t name;
        if (read_string(P, dir, loc, "colour space name", &name) != 0)
            return -1;
        /* pbrt-v4's default, the only one prismfarm has. */
        if (strcmp(name.s, "srgb") != 0)
            return pbrt_error(P->err, name.loc,
                              "unsupported colour space \"%s\" (only \"srgb\", pbrt-v4's default)",
                              name.s);
        return 0;
    }
    if (!strcmp(dir, "Accelerator")) {
        /* How pbrt-v4 builds its BVH: no effect on the image; Embree builds its own. */
        str_arg_t type;
        if (read_string(P, dir, loc, "type name", &type) != 0)
            return -1;
        params_t *ps = read_params(P, "Accelerator");
        if (!ps)
            return -1;
        params_accept_all(ps);
        params_destroy(&ps);
        return 0;
    }
    if (!strcmp(dir, "Texture"))
        return do_texture_directive(P, loc);
    if (!strcmp(dir, "AttributeBegin") || !strcmp(dir, "TransformBegin"))
        /* pbrt-v4 reads the deprecated TransformBegin/End as AttributeBegin/End. */
        return need_world(P, dir, loc) ||
                       push_frame(P, FRAME_ATTRIBUTE,
                                  dir[0] == 'A' ? "AttributeBegin" : "TransformBegin", loc)
                   ? -1
                   : 0;
    if (!strcmp(dir, "AttributeEnd") || !strcmp(dir, "TransformEnd"))
        return need_world(P, dir, loc) || end_frame(P, FRAME_ATTRIBUTE, dir, loc) ? -1 : 0;
    if (!strcmp(dir, "ReverseOrientation")) {
        if (need_world(P, dir, loc) != 0)
            return -1;
        P->gs.reverse = !P->gs.reverse;
        return 0;
    }
    if (!strcmp(dir, "CoordinateSystem") || !strcmp(dir, "CoordSysTransform")) {
        str_arg_t name;
        if (read_string(P, dir, loc, "coordinate system name", &name) != 0)
            return -1;
        if (!strcmp(dir, "CoordinateSystem"))
            return set_coordsys(P, name.s, P->gs.ctm, loc);
        for (size_t i = 0; i < P->ncs; i++)
            if (!strcmp(P->cs[i].name, name.s)) {
                P->gs.ctm = P->cs[i].t;
                return 0;
            }
        return pbrt_error(P->err, name.loc, "unknown coordinate system \"%s\"", name.s);
    }
    if (!strcmp(dir, "WorldBegin")) {
        if (P->world)
            return pbrt_error(P->err, loc, "WorldBegin appears twice (first at line %d)",
                              P->world_loc.line);
        P->world = true;
        P->world_loc = loc;
        P->gs.ctm = transform_identity();
        return set_coordsys(P, "world", P->gs.ctm, loc);
    }
    if (!strcmp(dir, "Include") || !strcmp(dir, "Import"))
        return do_include(P, !strcmp(dir, "Import"), loc);
    if (!strcmp(dir, "ObjectBegin"))
        return do_object_begin(P, loc);
    if (!strcmp(dir, "ObjectEnd"))
        return do_object_end(P, loc);
    if (!strcmp(dir, "ObjectInstance"))
        return do_object_instance(P, loc);
    if (!strcmp(dir, "NamedMaterial")) {
        str_arg_t name;
        if (read_string(P, dir, loc, "material name", &name) != 0 || need_world(P, dir, loc) != 0)
            return -1;
        int m = scene_desc_find_material(P->scene, name.s);
        if (m < 0)
            return pbrt_error(P->err, name.loc,
                              "named material \"%s\" is not defined "
                              "(MakeNamedMaterial must come before its use)",
                              name.s);
        P->gs.material = m;
        return 0;
    }
    if (in_list(dir, UNSUPPORTED_DIRECTIVES, COUNT_OF(UNSUPPORTED_DIRECTIVES)))
        return pbrt_error(P->err, loc, "unsupported directive %s", dir);
    /* Every directive pbrt-v4's parser knows (the spelling is the file format's, so the list
     * is fixed), for the "did you mean" of a misspelt one: Integrater, Attributebegin. */
    static const char *const PBRT_DIRECTIVES[] = {
        "Accelerator", "ActiveTransform", "AreaLightSource", "Attribute", "AttributeBegin",
        "AttributeEnd", "Camera", "ColorSpace", "ConcatTransform", "CoordinateSystem",
        "CoordSysTransform", "Film", "Identity", "Import", "Include", "Integrator",
        "LightSource", "LookAt", "MakeNamedMaterial", "MakeNamedMedium", "Material",
        "MediumInterface", "NamedMaterial", "ObjectBegin", "ObjectEnd", "ObjectInstance",
        "Option", "PixelFilter", "ReverseOrientation", "Rotate", "Sampler", "Scale", "Shape",
        "Texture", "Transform", "TransformBegin", "TransformEnd", "TransformTimes",
        "Translate", "WorldBegin"};
    const char *best = suggest_nearest(dir, PBRT_DIRECTIVES, COUNT_OF(PBRT_DIRECTIVES));
    if (best)
        return pbrt_error(P->err, loc, "unknown directive %s (did you mean %s?)", dir, best);
    return pbrt_error(P->err, loc, "unknown directive %s", dir);
}

/* Check mode: records the refusal in P->err and skips to the next directive (a word that is
 * not a number: a directive's arguments are strings, numbers and brackets), so that every
 * refusal of a scene is found in one run. Returns 0 to go on, -1 to stop (not in check mode,
 * or the text itself cannot be read on: an unterminated string, a file that cannot be read). */
static int recover(parser_t *P)
{
    if (!P->errors || warnings_add_text(P->errors, P->err->msg) != 0)
        return -1;
    for (;;) {
        pbrt_token_t t;
        if (pbrt_lexer_peek(P->lex, &t, P->err) != 0)
            return -1;
        double number;
        if (t.kind == PBRT_TOKEN_EOF || (t.kind == PBRT_TOKEN_WORD && pbrt_parse_number(t.text, &number) == -1))
            return 0;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            return -1;
    }
}

static int parse_tokens(parser_t *P)
{
    for (;;) {
        pbrt_token_t t;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            return -1;
        if (t.kind == PBRT_TOKEN_EOF)
            return 0;
        if (t.kind != PBRT_TOKEN_WORD) {
            char d[96];
            describe(&t, d, sizeof d);
            return pbrt_error(P->err, t.loc, "expected a directive, got %s", d);
        }
        double number;
        if (pbrt_parse_number(t.text, &number) != -1)
            /* Most often one number too many after a transform ("Translate 1 2 3 4"). */
            return pbrt_error(P->err, t.loc,
                              "expected a directive, got the number %.40s (one too many for the "
                              "directive before it?)",
                              t.text);
        char dir[64];
        if (t.len >= sizeof dir) {
            return pbrt_error(P->err, t.loc, "unknown directive %.40s...", t.text);
        }
        memcpy(dir, t.text, t.len + 1);
        if (directive(P, dir, t.loc) != 0 && recover(P) != 0)
            return -1;
    }
}

/* Reads a whole file; a file that cannot be read names the Include that asked for it. */
static char *read_file(parser_t *P, const char *path, const pbrt_loc_t *from, size_t *len)
{
    const char *kind;
    char why[96];
    FILE *f = open_regular_file(path, &kind);
    if (!f) {
        if (from)
            pbrt_error(P->err, *from, "cannot open included file \"%s\": %s%s", path,
                       open_failure(kind, why, sizeof why), P->also);
        else
            err_set(P->err, "cannot open scene file \"%s\": %s", path,
                    open_failure(kind, why, sizeof why));
        return NULL;
    }
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (n < cap) {
            if (ferror(f)) {
                free(buf);
                buf = NULL;
                if (from)
                    pbrt_error(P->err, *from, "cannot read included file \"%s\"", path);
                else
                    err_set(P->err, "cannot read scene file \"%s\"", path);
                fclose(f);
                return NULL;
            }
            break;
        }
        /* The lexer counts lines and columns in int: a scene text is bounded. */
        if (cap > PBRT_FILE_BYTES_MAX) {
            free(buf);
            fclose(f);
            fail_at(P, from, "\"%s\" is larger than %zu bytes", path, PBRT_FILE_BYTES_MAX);
            return NULL;
        }
        size_t grown = cap * 2 < PBRT_FILE_BYTES_MAX + 1 ? cap * 2 : PBRT_FILE_BYTES_MAX + 1;
        char *nb = realloc(buf, grown);
        if (!nb)
            free(buf);
        buf = nb;
        cap = grown;
    }
    fclose(f);
    if (!buf) {
        err_set(P->err, "out of memory reading \"%s\"", path);
        return NULL;
    }
    *len = n;
    return buf;
}

static int parse_buffer(parser_t *P, const char *name, const char *text, size_t len)
{
    const char *file = scene_desc_strdup(P->scene, name, P->err);
    if (!file)
        return -1;
    P->lex = pbrt_lexer_new(file, text, len, P->err);
    if (!P->lex)
        return -1;
    P->file = file;
    int rc = parse_tokens(P);
    pbrt_lexer_destroy(&P->lex);
    return rc;
}

/* The most a scene file may inflate to: its own bound, or what the text budget leaves. */
#define TEXT_LEFT(P) ((size_t)scene_budget_text_left((P)->budget, &(P)->used, PBRT_FILE_BYTES_MAX))

/* Reads and parses one file: the main file (from NULL) or one named by Include/Import at
 * *from, as `name`. */
static int parse_file(parser_t *P, const char *path, const pbrt_loc_t *from, scene_file_kind_t kind,
                      const char *name)
{
    if (from && P->nopen >= PBRT_INCLUDE_DEPTH_MAX)
        return pbrt_error(P->err, *from, "Include/Import nested deeper than %d files",
                          PBRT_INCLUDE_DEPTH_MAX);
    if (from && ++P->nfiles_read > PBRT_FILES_MAX)
        return pbrt_error(P->err, *from, "the scene reads more than %d files", PBRT_FILES_MAX);
    size_t len;
    char *text, *real;
    if (P->root_real) {
        const char *what = from ? "included file" : "scene file";
        real = confine(P, path, name, from, what);
        text = real ? read_confined(P, real, name, path, from, what, &len) : NULL;
        if (!text || inflate_if_gzip(P, &text, &len, TEXT_LEFT(P), path, from) != 0) {
            free(text);
            free(real);
            return -1;
        }
    } else {
        text = read_file(P, path, from, &len);
        if (!text)
            return -1;
        if (inflate_if_gzip(P, &text, &len, TEXT_LEFT(P), path, from) != 0) {
            free(text);
            return -1;
        }
        real = realpath(path, NULL);
        if (!real) {
            free(text);
            return from ? pbrt_error(P->err, *from, "cannot resolve \"%s\": %s", path,
                                     strerror(errno))
                        : err_set(P->err, "cannot resolve \"%s\": %s", path, strerror(errno));
        }
    }
    for (int i = 0; i < P->nopen; i++)
        if (!strcmp(P->open_files[i], real)) {
            free(text);
            free(real);
            return pbrt_error(P->err, *from, "include cycle: \"%s\" is already being read", path);
        }
    P->open_files[P->nopen++] = real;
    pbrt_loc_t named = from ? *from : (pbrt_loc_t){P->main_name, 0, 0};
    err_t over;
    int rc = scene_budget_charge_text(P->budget, &P->used, len, path, &over) != 0
                 ? fail_at(P, from, "%s", over.msg)
                 : note_file(P, kind, path, name, named);
    if (rc == 0)
        rc = parse_buffer(P, path, text, len);
    free(text);
    free(P->open_files[--P->nopen]);
    return rc;
}

/* End of the scene: everything opened must be closed, and instances must name objects. */
static int finish(parser_t *P)
{
    if (P->option_seed_set && !P->sampler_seed_given)
        P->scene->sampler.seed = P->option_seed;
    if (P->nframes > 0) {
        frame_t *top = &P->frames[P->nframes - 1];
        return pbrt_error(P->err, top->loc, "%s has no matching end", top->what);
    }
    if (!P->world)
        return err_set(P->err, "%s: the scene has no WorldBegin", P->file ? P->file : "scene");
    for (size_t i = 0; i < P->scene->ninstances; i++) {
        scene_instance_t *in = &P->scene->instances[i];
        in->object = scene_desc_find_object(P->scene, P->pending[i]);
        if (in->object < 0)
            return pbrt_error(P->err, in->loc, "ObjectInstance: object \"%s\" is not defined",
                              P->pending[i]);
    }
    return 0;
}

static scene_desc_t *run(const char *name, const char *text, size_t len, const char *root,
                         const scene_budget_t *budget, warnings_t *errors, int threads, err_t *err)
{
    parser_t P = {0};
    P.err = err;
    P.threads = threads;
    P.budget = budget;
    P.errors = errors;
    if (root) {
        P.root_real = realpath(root, NULL);
        if (!P.root_real) {
            err_set(err, "cannot open the scene's folder \"%s\": %s", root, strerror(errno));
            return NULL;
        }
        P.root_lex = lexical_path(root);
        if (!P.root_lex) {
            free(P.root_real);
            err_set(err, "out of memory");
            return NULL;
        }
    }
    P.object = -1;
    P.scene = scene_desc_new(err);
    if (!P.scene) {
        free(P.root_real);
        free(P.root_lex);
        return NULL;
    }
    P.gs.ctm = transform_identity();
    P.gs.material = 0;
    P.gs.area_light = -1;
    P.gs.inside_medium = P.gs.outside_medium = -1;
    /* Defaults that no directive set point at line 0 of the main file. */
    const char *main_name = scene_desc_strdup(P.scene, name, err);
    if (!main_name) {
        scene_desc_destroy(&P.scene);
        free(P.root_real);
        free(P.root_lex);
        return NULL;
    }
    pbrt_loc_t none = {main_name, 0, 0};
    P.scene->camera.loc = P.scene->film.loc = P.scene->sampler.loc = none;
    P.scene->integrator.loc = none;
    P.scene->materials[0].loc = P.scene->materials[0].reflectance.spectrum.loc = none;
    P.main_name = main_name;
    int rc = text ? parse_buffer(&P, name, text, len)
                  : parse_file(&P, name, NULL, SCENE_FILE_MAIN, name);
    if (rc == 0) {
        rc = mesh_jobs_finish(&P);
    } else {
        err_t at_stop = *err;
        if (mesh_jobs_finish(&P) == 0)
            *err = at_stop; /* nothing before the point where the parse stopped failed */
    }
    if (rc == 0) {
        P.file = main_name;
        rc = finish(&P);
        if (rc != 0 && errors && warnings_add_text(errors, err->msg) == 0)
            rc = 0; /* recorded; the scene parsed as far as it could */
    } else if (errors && warnings_add_text(errors, err->msg) == 0) {
        rc = 0; /* the text could not be read on: what was parsed is kept for the loader */
    }
    for (size_t i = 0; i < P.ncs; i++)
        free(P.cs[i].name);
    free(P.cs);
    free(P.frames);
    free(P.pending);
    while (P.attr_owned) {
        attr_node_t *n = P.attr_owned;
        P.attr_owned = n->next_owned;
        params_destroy(&n->ps);
        free(n);
    }
    for (int i = 0; i < P.nopen; i++)
        free(P.open_files[i]);
    free(P.root_real);
    free(P.root_lex);
    if (rc != 0)
        scene_desc_destroy(&P.scene);
    return P.scene;
}

scene_desc_t *pbrt_parse_file(const char *path, err_t *err)
{
    return run(path, NULL, 0, NULL, NULL, NULL, 0, err);
}

scene_desc_t *pbrt_parse_file_check(const char *path, warnings_t *errors, err_t *err)
{
    return run(path, NULL, 0, NULL, NULL, errors, 0, err);
}

scene_desc_t *pbrt_parse_file_confined(const char *path, const char *root,
                                       const scene_budget_t *budget, err_t *err)
{
    if (!root)
        return err_set(err, "a confined parse needs the scene's folder"), NULL;
    return pbrt_parse_file_opts(path, &(pbrt_parse_opts_t){.root = root, .budget = budget}, err);
}

scene_desc_t *pbrt_parse_file_opts(const char *path, const pbrt_parse_opts_t *opts, err_t *err)
{
    pbrt_parse_opts_t none = {0};
    if (!opts)
        opts = &none;
    return run(path, NULL, 0, opts->root, opts->budget, NULL, opts->threads, err);
}

scene_desc_t *pbrt_parse_string(const char *text, size_t len, const char *name, err_t *err)
{
    return run(name ? name : "<string>", text ? text : "", text ? len : 0, NULL, NULL, NULL, 0,
               err);
}
