#include "loopsubdiv.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

/* The mesh of one level, by index: face f has corners v[3f..3f+2] and, across its edge k
 * (from corner k to corner k+1), the neighbour nb[3f+k] (-1 on a boundary). Each vertex keeps
 * one face it belongs to (start) and whether it lies on the boundary. */
typedef struct level {
    size_t nv, nf;
    double *p; /* 3 per vertex */
    int32_t *start;
    bool *boundary;
    uint32_t *v;
    int64_t *nb;
} level_t;

#define NEXT(i) (((i) + 1) % 3)
#define PREV(i) (((i) + 2) % 3)

static void level_free(level_t *l)
{
    free(l->p);
    free(l->start);
    free(l->boundary);
    free(l->v);
    free(l->nb);
    memset(l, 0, sizeof *l);
}

static int level_alloc(level_t *l, size_t nv, size_t nf)
{
    l->nv = nv;
    l->nf = nf;
    l->p = malloc(3 * nv * sizeof *l->p);
    l->start = malloc(nv * sizeof *l->start);
    l->boundary = calloc(nv, sizeof *l->boundary);
    l->v = malloc(3 * nf * sizeof *l->v);
    l->nb = malloc(3 * nf * sizeof *l->nb);
    return l->p && l->start && l->boundary && l->v && l->nb ? 0 : -1;
}

/* The corner of face f that is vertex x (the mesh is checked, so it is there). */
static int vnum(const level_t *l, int64_t f, uint32_t x)
{
    const uint32_t *c = &l->v[3 * (size_t)f];
    return c[0] == x ? 0 : c[1] == x ? 1 : 2;
}

static int64_t next_face(const level_t *l, int64_t f, uint32_t x)
{
    return l->nb[3 * (size_t)f + (size_t)vnum(l, f, x)];
}

static int64_t prev_face(const level_t *l, int64_t f, uint32_t x)
{
    return l->nb[3 * (size_t)f + (size_t)PREV(vnum(l, f, x))];
}

static uint32_t next_vert(const level_t *l, int64_t f, uint32_t x)
{
    return l->v[3 * (size_t)f + (size_t)NEXT(vnum(l, f, x))];
}

static uint32_t prev_vert(const level_t *l, int64_t f, uint32_t x)
{
    return l->v[3 * (size_t)f + (size_t)PREV(vnum(l, f, x))];
}

/* The one ring of x in pbrt-v4's order (SDVertex::oneRing): an interior vertex's neighbours
 * from its start face on around it; a boundary vertex's from one boundary edge to the other.
 * Writes at most cap indices and returns the valence (the ring's length), or -1 if the ring
 * does not close within cap (a mesh that is not a manifold). */
static int one_ring(const level_t *l, uint32_t x, uint32_t *ring, int cap)
{
    int n = 0;
    int64_t f = l->start[x];
    if (!l->boundary[x]) {
        do {
            if (n == cap)
                return -1;
            ring[n++] = next_vert(l, f, x);
            f = next_face(l, f, x);
        } while (f != l->start[x] && f >= 0);
        return f < 0 ? -1 : n;
    }
    int64_t g;
    int guard = 0;
    while ((g = next_face(l, f, x)) >= 0) {
        f = g;
        if (++guard > cap)
            return -1;
    }
    ring[n++] = next_vert(l, f, x);
    do {
        if (n == cap)
            return -1;
        ring[n++] = prev_vert(l, f, x);
        f = prev_face(l, f, x);
    } while (f >= 0);
    return n;
}

static double beta(int valence)
{
    return valence == 3 ? 3.0 / 16.0 : 3.0 / (8.0 * valence);
}

/* (1 - n w) p + w * (sum of the ring), or for a boundary vertex (1 - 2 w) p + w (first +
 * last of the ring). */
static void weigh(const double *pts, uint32_t x, const uint32_t *ring, int n, double w,
                  bool boundary, double *out)
{
    for (int c = 0; c < 3; c++) {
        double s;
        if (boundary)
            s = (1.0 - 2.0 * w) * pts[3 * x + c] + w * (pts[3 * ring[0] + c] + pts[3 * ring[n - 1] + c]);
        else {
            s = (1.0 - n * w) * pts[3 * x + c];
            for (int i = 0; i < n; i++)
                s += w * pts[3 * ring[i] + c];
        }
        out[c] = s;
    }
}

typedef struct edge_slot {
    uint32_t a, b; /* a < b */
    int64_t face;  /* the first face seen with this edge, or -1 for an empty slot */
    int k;         /* its edge number there */
    bool joined;
} edge_slot_t;

static size_t hash_edge(uint32_t a, uint32_t b, size_t mask)
{
    uint64_t h = ((uint64_t)a << 32 | b) * 0x9e3779b97f4a7c15ull;
    return (size_t)(h >> 17) & mask;
}

/* The control mesh as level 0: neighbours from shared edges (each edge in at most two faces,
 * traversed in opposite directions), start faces and boundary flags (pbrt-v4's "finish vertex
 * initialization"). */
static int build_control(level_t *l, const double *P, size_t nv, const uint32_t *idx, size_t nt,
                         err_t *err)
{
    if (level_alloc(l, nv, nt) != 0)
        return err_set(err, "out of memory for a control mesh of %zu triangles", nt);
    memcpy(l->p, P, 3 * nv * sizeof *P);
    memcpy(l->v, idx, 3 * nt * sizeof *idx);
    for (size_t i = 0; i < nv; i++)
        l->start[i] = -1;
    for (size_t f = 0; f < nt; f++) {
        const uint32_t *c = &idx[3 * f];
        if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2])
            return err_set(err, "triangle %zu uses vertex %u twice", f,
                           c[0] == c[1] || c[0] == c[2] ? c[0] : c[1]);
        for (int k = 0; k < 3; k++)
            l->start[c[k]] = (int32_t)f;
    }
    for (size_t i = 0; i < nv; i++)
        if (l->start[i] < 0)
            return err_set(err, "vertex %zu is used by no triangle", i);
    size_t cap = 16;
    while (cap < 6 * nt)
        cap *= 2;
    edge_slot_t *tab = malloc(cap * sizeof *tab);
    if (!tab)
        return err_set(err, "out of memory for a control mesh of %zu triangles", nt);
    for (size_t i = 0; i < cap; i++)
        tab[i].face = -1;
    int rc = 0;
    for (size_t f = 0; f < nt && rc == 0; f++)
        for (int k = 0; k < 3 && rc == 0; k++) {
            uint32_t x = idx[3 * f + (size_t)k], y = idx[3 * f + (size_t)NEXT(k)];
            uint32_t a = x < y ? x : y, b = x < y ? y : x;
            size_t h = hash_edge(a, b, cap - 1);
            while (tab[h].face >= 0 && !(tab[h].a == a && tab[h].b == b))
                h = (h + 1) & (cap - 1);
            edge_slot_t *e = &tab[h];
            l->nb[3 * f + (size_t)k] = -1;
            if (e->face < 0) {
                *e = (edge_slot_t){a, b, (int64_t)f, k, false};
                continue;
            }
            if (e->joined) {
                rc = err_set(err, "the edge from vertex %u to %u belongs to more than two triangles "
                                  "(%lld, %lld and %zu): loopsubdiv needs a manifold mesh",
                             a, b, (long long)e->face, (long long)l->nb[3 * (size_t)e->face + (size_t)e->k], f);
                break;
            }
            if (idx[3 * (size_t)e->face + (size_t)e->k] == x)
                rc = err_set(err, "triangles %lld and %zu run along the edge from vertex %u to %u "
                                  "in the same direction: loopsubdiv needs consistently "
                                  "oriented triangles",
                             (long long)e->face, f, x, y);
            e->joined = true;
            l->nb[3 * (size_t)e->face + (size_t)e->k] = (int64_t)f;
            l->nb[3 * f + (size_t)k] = e->face;
        }
    free(tab);
    if (rc != 0)
        return rc;
    for (size_t i = 0; i < nv; i++) {
        int64_t f = l->start[i];
        size_t guard = 0;
        do {
            f = next_face(l, f, (uint32_t)i);
        } while (f >= 0 && f != l->start[i] && ++guard <= nt);
        if (guard > nt)
            return err_set(err, "the triangles around vertex %zu do not form a fan: loopsubdiv "
                                "needs a manifold mesh", i);
        l->boundary[i] = f < 0;
    }
    return 0;
}

/* One level of Loop subdivision of a into b (pbrt-v4's loop body): each vertex keeps its index
 * and moves by the even rule, each edge gets a new (odd) vertex, numbered in the order the
 * faces reach it, and face f becomes faces 4f..4f+3 (the three corners, then the middle). */
static int subdivide(const level_t *a, level_t *b, uint32_t *ring, int cap, err_t *err)
{
    size_t ne = 0;
    int64_t *ev = malloc(3 * a->nf * sizeof *ev); /* the odd vertex of each face edge */
    if (!ev)
        return err_set(err, "out of memory subdividing %zu triangles", a->nf);
    for (size_t f = 0; f < a->nf; f++)
        for (int k = 0; k < 3; k++) {
            int64_t g = a->nb[3 * f + (size_t)k];
            if (g >= 0 && (size_t)g < f) {
                /* g made it: its edge towards f */
                for (int j = 0; j < 3; j++)
                    if (a->nb[3 * (size_t)g + (size_t)j] == (int64_t)f &&
                        (a->v[3 * (size_t)g + (size_t)j] == a->v[3 * f + (size_t)NEXT(k)]))
                        ev[3 * f + (size_t)k] = ev[3 * (size_t)g + (size_t)j];
            } else {
                ev[3 * f + (size_t)k] = (int64_t)(a->nv + ne++);
            }
        }
    if (level_alloc(b, a->nv + ne, 4 * a->nf) != 0) {
        free(ev);
        return err_set(err, "out of memory subdividing %zu triangles", a->nf);
    }
    for (size_t x = 0; x < a->nv; x++) {
        int n = one_ring(a, (uint32_t)x, ring, cap);
        if (n < 0) {
            free(ev);
            return err_set(err, "vertex %zu has more than %d neighbours or no closed fan", x, cap);
        }
        /* the regular rule (1/16) is beta(6); a boundary vertex takes 3/4 of itself and 1/8 of
         * each boundary neighbour */
        weigh(a->p, (uint32_t)x, ring, n, a->boundary[x] ? 1.0 / 8.0 : beta(n), a->boundary[x],
              &b->p[3 * x]);
        b->boundary[x] = a->boundary[x];
        int c = vnum(a, a->start[x], (uint32_t)x);
        b->start[x] = (int32_t)(4 * (size_t)a->start[x] + (size_t)c);
    }
    for (size_t f = 0; f < a->nf; f++)
        for (int k = 0; k < 3; k++) {
            size_t o = (size_t)ev[3 * f + (size_t)k];
            int64_t g = a->nb[3 * f + (size_t)k];
            if (g >= 0 && (size_t)g < f)
                continue;
            uint32_t v0 = a->v[3 * f + (size_t)k], v1 = a->v[3 * f + (size_t)NEXT(k)];
            uint32_t v2 = a->v[3 * f + (size_t)PREV(k)];
            b->boundary[o] = g < 0;
            b->start[o] = (int32_t)(4 * f + 3);
            for (int c = 0; c < 3; c++) {
                if (g < 0) {
                    b->p[3 * o + (size_t)c] = 0.5 * (a->p[3 * v0 + (size_t)c] + a->p[3 * v1 + (size_t)c]);
                } else {
                    uint32_t v3 = 0;
                    for (int j = 0; j < 3; j++) {
                        uint32_t w = a->v[3 * (size_t)g + (size_t)j];
                        if (w != v0 && w != v1)
                            v3 = w;
                    }
                    b->p[3 * o + (size_t)c] =
                        3.0 / 8.0 * (a->p[3 * v0 + (size_t)c] + a->p[3 * v1 + (size_t)c]) +
                        1.0 / 8.0 * (a->p[3 * v2 + (size_t)c] + a->p[3 * v3 + (size_t)c]);
                }
            }
        }
    for (size_t f = 0; f < a->nf; f++) {
        uint32_t *ch = &b->v[12 * f];
        int64_t *cn = &b->nb[12 * f];
        for (int j = 0; j < 3; j++) {
            uint32_t e = (uint32_t)ev[3 * f + (size_t)j];
            ch[3 * j + j] = a->v[3 * f + (size_t)j];   /* child j, corner j: the even vertex */
            ch[3 * j + NEXT(j)] = e;                    /* child j, next corner: odd of edge j */
            ch[3 * NEXT(j) + j] = e;                    /* child j+1, corner j: the same */
            ch[9 + j] = e;                              /* the middle child */
            cn[9 + j] = (int64_t)(4 * f + (size_t)NEXT(j));
            cn[3 * j + NEXT(j)] = (int64_t)(4 * f + 3);
            int64_t g = a->nb[3 * f + (size_t)j];
            cn[3 * j + j] = g >= 0 ? 4 * g + vnum(a, g, a->v[3 * f + (size_t)j]) : -1;
            g = a->nb[3 * f + (size_t)PREV(j)];
            cn[3 * j + PREV(j)] = g >= 0 ? 4 * g + vnum(a, g, a->v[3 * f + (size_t)j]) : -1;
        }
    }
    free(ev);
    return 0;
}

/* Limit positions (pbrt-v4: the boundary mask 1/5 on the two boundary neighbours; inside,
 * gamma = 1 / (n + 3 / (8 beta)), 1/12 for the regular valence 6) and, from the limit
 * positions, the tangents S and T of Loop's limit masks and the normal S x T. */
static int limit(level_t *l, uint32_t *ring, int cap, double *N, err_t *err)
{
    double *lim = malloc(3 * l->nv * sizeof *lim);
    if (!lim)
        return err_set(err, "out of memory for %zu vertices", l->nv);
    for (size_t x = 0; x < l->nv; x++) {
        int n = one_ring(l, (uint32_t)x, ring, cap);
        if (n < 0) {
            free(lim);
            return err_set(err, "vertex %zu has more than %d neighbours or no closed fan", x, cap);
        }
        double w = l->boundary[x] ? 1.0 / 5.0 : 1.0 / (n + 3.0 / (8.0 * beta(n)));
        weigh(l->p, (uint32_t)x, ring, n, w, l->boundary[x], &lim[3 * x]);
    }
    free(l->p);
    l->p = lim;
    const double PI = 3.14159265358979323846;
    for (size_t x = 0; x < l->nv; x++) {
        int n = one_ring(l, (uint32_t)x, ring, cap);
        double S[3] = {0, 0, 0}, T[3] = {0, 0, 0};
        const double *p = &lim[3 * x];
        if (!l->boundary[x])
            for (int j = 0; j < n; j++) {
                /* once per neighbour, not per coordinate: the same sums in the same order */
                double cj = cos(2 * PI * j / n), sj = sin(2 * PI * j / n);
                for (int c = 0; c < 3; c++) {
                    S[c] += cj * lim[3 * ring[j] + (size_t)c];
                    T[c] += sj * lim[3 * ring[j] + (size_t)c];
                }
            }
        for (int c = 0; c < 3 && l->boundary[x]; c++) {
            const double *q0 = &lim[3 * ring[0]], *ql = &lim[3 * ring[n - 1]];
            S[c] = ql[c] - q0[c];
            if (n == 2)
                T[c] = q0[c] + lim[3 * ring[1] + (size_t)c] - 2 * p[c];
            else if (n == 3)
                T[c] = lim[3 * ring[1] + (size_t)c] - p[c];
            else if (n == 4)
                T[c] = -q0[c] + 2 * lim[3 * ring[1] + (size_t)c] + 2 * lim[3 * ring[2] + (size_t)c] -
                       ql[c] - 2 * p[c];
            else {
                double th = PI / (n - 1);
                double t = sin(th) * (q0[c] + ql[c]);
                for (int k = 1; k < n - 1; k++)
                    t += (2 * cos(th) - 2) * sin(k * th) * lim[3 * ring[k] + (size_t)c];
                T[c] = -t;
            }
        }
        N[3 * x] = S[1] * T[2] - S[2] * T[1];
        N[3 * x + 1] = S[2] * T[0] - S[0] * T[2];
        N[3 * x + 2] = S[0] * T[1] - S[1] * T[0];
    }
    return 0;
}

int loopsubdiv_mesh(const double *P, size_t nv, const uint32_t *indices, size_t nt, int levels,
                    mesh_data_t *out, err_t *err)
{
    memset(out, 0, sizeof *out);
    if (nt == 0)
        return err_set(err, "loopsubdiv needs at least one triangle");
    if (levels < 0)
        return err_set(err, "levels %d is negative", levels);
    size_t total = nt;
    for (int i = 0; i < levels; i++) {
        if (total > LOOPSUBDIV_TRIANGLES_MAX / 4)
            return err_set(err, "%d levels of %zu triangles make more than %zu triangles", levels,
                           nt, LOOPSUBDIV_TRIANGLES_MAX);
        total *= 4;
    }
    level_t a = {0}, b = {0};
    enum { RING_MAX = 1024 };
    uint32_t *ring = malloc(RING_MAX * sizeof *ring);
    int rc = ring ? build_control(&a, P, nv, indices, nt, err)
                  : err_set(err, "out of memory");
    for (int i = 0; rc == 0 && i < levels; i++) {
        rc = subdivide(&a, &b, ring, RING_MAX, err);
        level_free(&a);
        a = b;
        memset(&b, 0, sizeof b);
    }
    double *N = rc == 0 ? malloc(3 * a.nv * sizeof *N) : NULL;
    if (rc == 0 && !N)
        rc = err_set(err, "out of memory for %zu vertices", a.nv);
    if (rc == 0)
        rc = limit(&a, ring, RING_MAX, N, err);
    free(ring);
    if (rc != 0) {
        free(N);
        level_free(&a);
        level_free(&b);
        return -1;
    }
    out->nvertices = a.nv;
    out->P = a.p;
    out->N = N;
    out->ntriangles = a.nf;
    out->indices = a.v;
    a.p = NULL;
    a.v = NULL;
    level_free(&a);
    return 0;
}
