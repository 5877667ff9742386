#include "nanovdb.h"

#include "le_bytes.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#ifdef PRISMFARM_HAVE_BLOSC
#include <blosc.h>
#endif

/* The layout, from OpenVDB's nanovdb/util/IO.h (file) and nanovdb/PNanoVDB.h (grid: the byte
 * offsets it tabulates for float grids, pnanovdb_grid_type_constants[1]). All little-endian.
 * File: segments of a 16-byte header (magic "NanoVDB0", version, grid count, codec), one
 * 176-byte record per grid followed by its name, then each grid's bytes (under the codec). */
#define MAGIC 0x304244566f6e614eULL /* "NanoVDB0" */
#define MAJOR 32u
#define FILE_HEADER 16
#define META_SIZE 176
#define META_GRID_SIZE 0   /* u64: the grid's bytes, decompressed */
#define META_FILE_SIZE 8   /* u64: its bytes in the file */
#define META_GRID_TYPE 32  /* u32 */
#define META_NAME_SIZE 136 /* u32, the NUL included */
#define META_CODEC 168     /* u16 */
#define NAME_MAX_BYTES 4096
#define CODEC_NONE 0
#define CODEC_ZIP 1
#define CODEC_BLOSC 2
#define BLOSC_CHUNK ((uint64_t)1 << 30) /* IO.h: BLOSC compresses 1 GiB at a time */
/* Grid (GridData, 672 bytes), its tree (TreeData, 64 bytes) right after. */
#define GRID_MAGIC 0
#define GRID_VERSION 16
#define GRID_SIZE 32
#define GRID_MAT_D (296 + 88)  /* Map: 3x3 index-to-world matrix, row-major doubles */
#define GRID_VEC_D (296 + 232) /* Map: its translation */
#define GRID_WORLD_BBOX 560    /* 6 doubles: min, max */
#define GRID_TYPE 636
#define GRID_TYPE_FLOAT 1u
#define GRID_BYTES 672
#define TREE_BYTES 64
/* Nodes: root (64 bytes, then 32-byte tiles), upper (32^3 entries), lower (16^3), leaf (8^3). */
#define ROOT_TABLE_SIZE 24
#define ROOT_BACKGROUND 28
#define ROOT_BYTES 64
#define TILE_KEY 0
#define TILE_CHILD 8
#define TILE_VALUE 20
#define TILE_BYTES 32
#define UPPER_CHILD_MASK 4128
#define UPPER_TABLE 8256
#define UPPER_BYTES 270400
#define LOWER_CHILD_MASK 544
#define LOWER_TABLE 1088
#define LOWER_BYTES 33856
#define LEAF_VALUES 96
#define LEAF_BYTES 2144

#define BRICK 512 /* voxels of a leaf, (x << 6) | (y << 3) | z */

struct nanovdb_grid {
    float background;
    int64_t lo[3];  /* the brick table's first brick (index >> 3) */
    int64_t nb[3];  /* its size in bricks */
    int32_t *table; /* >= 0: a leaf; < 0: the constant consts[-1 - entry] */
    float *leaves;  /* BRICK values per leaf */
    float *leaf_max;
    size_t nleaves;
    float min;     /* the least value anywhere */
    float *consts; /* consts[0] is the background */
    size_t nconsts;
    vec3_t bbox_lo, bbox_hi;
    transform_t medium_to_index;
};

/* ---- the tree, walked once ---- */

/* What the walk finds: leaves (their bytes in the grid) and constant tiles (a cube of bricks
 * holding one value), each at its origin in bricks. */
typedef struct item {
    int64_t origin[3]; /* in bricks */
    int64_t size;      /* bricks per side: 1 (leaf or lower tile), 16 (upper tile), 512 (root) */
    uint64_t leaf_at;  /* the leaf's byte offset, or 0 for a tile */
    float value;       /* a tile's */
} item_t;

typedef struct walk {
    const uint8_t *g; /* the grid's bytes */
    uint64_t size;
    uint64_t first[3]; /* first leaf, lower, upper node (byte offsets in the grid) */
    uint64_t count[3];
    uint8_t *seen[3]; /* one byte per node: reached already */
    float background;
    item_t *items;
    size_t nitems, cap;
    /* the bricks a lookup inside the grid's bounds can reach (half-open): the table covers no
     * more, whatever the tree's tiles span (a 4096^3 root tile is 512^3 bricks) */
    int64_t clip_lo[3], clip_hi[3];
    err_t *err;
} walk_t;

/* The bricks of item it inside the clip, per axis [r0, r1); 0 when none. */
static int item_range(const walk_t *w, const item_t *it, int64_t r0[3], int64_t r1[3])
{
    for (int a = 0; a < 3; a++) {
        r0[a] = it->origin[a] > w->clip_lo[a] ? it->origin[a] : w->clip_lo[a];
        r1[a] = it->origin[a] + it->size < w->clip_hi[a] ? it->origin[a] + it->size : w->clip_hi[a];
        if (r0[a] >= r1[a])
            return 0;
    }
    return 1;
}

static int add_item(walk_t *w, const int64_t o[3], int64_t size, uint64_t leaf_at, float value)
{
    if (w->nitems == w->cap) {
        size_t cap = w->cap ? 2 * w->cap : 256;
        item_t *p = realloc(w->items, cap * sizeof *p);
        if (!p)
            return err_set(w->err, "out of memory");
        w->items = p;
        w->cap = cap;
    }
    item_t *it = &w->items[w->nitems++];
    memcpy(it->origin, o, sizeof it->origin);
    it->size = size;
    it->leaf_at = leaf_at;
    it->value = value;
    return 0;
}

/* A child at byte offset `at` (already a sum of a parent's position and its signed offset)
 * must be one of level's nodes, exactly, and not reached before. */
static int claim_node(walk_t *w, int level, int64_t at, uint64_t bytes, const char *what)
{
    static const char *names[] = {"leaf", "lower node", "upper node"};
    if (at < 0 || (uint64_t)at < w->first[level] ||
        (uint64_t)at - w->first[level] >= w->count[level] * bytes ||
        ((uint64_t)at - w->first[level]) % bytes != 0)
        return err_set(w->err, "byte %lld: %s points at no %s (damaged file?)", (long long)at, what,
                       names[level]);
    uint64_t i = ((uint64_t)at - w->first[level]) / bytes;
    if (w->seen[level][i])
        return err_set(w->err, "byte %lld: %s %llu is reached twice (damaged file?)", (long long)at,
                       names[level], (unsigned long long)i);
    w->seen[level][i] = 1;
    return 0;
}

static int tile_value(walk_t *w, const uint8_t *p, uint64_t at, float *v)
{
    *v = le_get_f32(p);
    if (!isfinite(*v))
        return err_set(w->err, "byte %llu: a tile's value is %g (damaged file?)",
                       (unsigned long long)at, *v);
    return 0;
}

static int walk_leaf(walk_t *w, uint64_t at, const int64_t o[3])
{
    const uint8_t *v = w->g + at + LEAF_VALUES;
    for (int i = 0; i < BRICK; i++) {
        float f = le_get_f32(v + 4 * i);
        if (!isfinite(f))
            return err_set(w->err, "byte %llu: voxel value %d of a leaf is %g (damaged file?)",
                           (unsigned long long)(at + LEAF_VALUES + 4 * (uint64_t)i), i, f);
    }
    return add_item(w, o, 1, at, 0.0f);
}

/* An internal node of 2^(3 log2dim) entries over children of `child_bricks` bricks per side:
 * a set bit of the child mask makes the entry a signed byte offset to a child, else it holds
 * a value. */
static int walk_internal(walk_t *w, int level, uint64_t at, const int64_t o[3])
{
    const int log2dim = level == 2 ? 5 : 4;
    const int n = 1 << (3 * log2dim);
    const uint64_t mask_at = at + (level == 2 ? UPPER_CHILD_MASK : LOWER_CHILD_MASK);
    const uint64_t table_at = at + (level == 2 ? UPPER_TABLE : LOWER_TABLE);
    const int64_t child_bricks = level == 2 ? 16 : 1;
    for (int e = 0; e < n; e++) {
        int64_t c[3] = {o[0] + ((e >> (2 * log2dim)) & ((1 << log2dim) - 1)) * child_bricks,
                        o[1] + ((e >> log2dim) & ((1 << log2dim) - 1)) * child_bricks,
                        o[2] + (e & ((1 << log2dim) - 1)) * child_bricks};
        const uint8_t *entry = w->g + table_at + 8 * (uint64_t)e;
        if (w->g[mask_at + (uint64_t)(e >> 3)] >> (e & 7) & 1) {
            int64_t off = (int64_t)le_get_u64(entry);
            if (off == 0 || off < -(int64_t)w->size || off > (int64_t)w->size)
                return err_set(w->err, "byte %llu: a child offset of %lld (damaged file?)",
                               (unsigned long long)(table_at + 8 * (uint64_t)e), (long long)off);
            int64_t child = (int64_t)at + off;
            if (level == 2) {
                if (claim_node(w, 1, child, LOWER_BYTES, "an upper node's child") ||
                    walk_internal(w, 1, (uint64_t)child, c))
                    return -1;
            } else if (claim_node(w, 0, child, LEAF_BYTES, "a lower node's child") ||
                       walk_leaf(w, (uint64_t)child, c)) {
                return -1;
            }
        } else {
            float v;
            if (tile_value(w, entry, table_at + 8 * (uint64_t)e, &v))
                return -1;
            if (v != w->background && add_item(w, c, level == 2 ? 16 : 1, 0, v))
                return -1;
        }
    }
    return 0;
}

/* A root tile's key packs its origin's coordinates >> 12, 21 bits each: x, y, z from the top
 * (PNanoVDB.h pnanovdb_coord_to_key); the origin is in index coordinates, a multiple of 4096. */
static int64_t key_coord(uint64_t key, int shift)
{
    uint32_t u = (uint32_t)((key >> shift) & 0xFFFFFu) << 12;
    return (int64_t)(int32_t)u;
}

static int walk_root(walk_t *w, uint64_t root)
{
    uint32_t ntiles = le_get_u32(w->g + root + ROOT_TABLE_SIZE);
    if ((uint64_t)ntiles * TILE_BYTES > w->size - root - ROOT_BYTES)
        return err_set(
            w->err, "byte %llu: the root's %u tiles run past the grid's %llu bytes (damaged file?)",
            (unsigned long long)(root + ROOT_TABLE_SIZE), ntiles, (unsigned long long)w->size);
    for (uint32_t t = 0; t < ntiles; t++) {
        uint64_t at = root + ROOT_BYTES + (uint64_t)t * TILE_BYTES;
        uint64_t key = le_get_u64(w->g + at + TILE_KEY);
        int64_t o[3] = {key_coord(key, 42) / 8, key_coord(key, 21) / 8, key_coord(key, 0) / 8};
        int64_t child = (int64_t)le_get_u64(w->g + at + TILE_CHILD);
        if (child != 0) {
            if (child < -(int64_t)w->size || child > (int64_t)w->size)
                return err_set(w->err, "byte %llu: a child offset of %lld (damaged file?)",
                               (unsigned long long)(at + TILE_CHILD), (long long)child);
            int64_t up = (int64_t)root + child;
            if (claim_node(w, 2, up, UPPER_BYTES, "a root tile") ||
                walk_internal(w, 2, (uint64_t)up, o))
                return -1;
        } else {
            float v;
            if (tile_value(w, w->g + at + TILE_VALUE, at + TILE_VALUE, &v))
                return -1;
            if (v != w->background && add_item(w, o, 512, 0, v))
                return -1;
        }
    }
    return 0;
}

/* ---- the grid's bytes ---- */

static int charge(uint64_t n, uint64_t *charged, uint64_t left, const char *what, err_t *err)
{
    if (left && (n > left || *charged > left - n))
        return err_set(err,
                       "%s (%llu voxels) takes the scene over its budget of texels and voxels "
                       "(prismfarm master --max-texels)",
                       what, (unsigned long long)n);
    *charged += n;
    return 0;
}

static int decode(const uint8_t *src, uint64_t src_len, uint64_t src_at, unsigned codec,
                  uint8_t *dst, uint64_t dst_len, err_t *err)
{
    if (codec == CODEC_NONE) {
        if (src_len != dst_len)
            return err_set(
                err, "byte %llu: an uncompressed grid of %llu bytes stored in %llu (damaged file?)",
                (unsigned long long)src_at, (unsigned long long)dst_len,
                (unsigned long long)src_len);
        memcpy(dst, src, dst_len);
        return 0;
    }
    if (codec == CODEC_ZIP) {
        if (src_len < 8 || le_get_u64(src) != src_len - 8)
            return err_set(
                err, "byte %llu: the ZIP block's size disagrees with the file (damaged file?)",
                (unsigned long long)src_at);
        uLongf out = (uLongf)dst_len;
        int rc = uncompress(dst, &out, src + 8, (uLong)(src_len - 8));
        if (rc != Z_OK || out != dst_len)
            return err_set(
                err, "byte %llu: the ZIP block does not inflate to the grid's %llu bytes (%s)",
                (unsigned long long)src_at, (unsigned long long)dst_len,
                rc == Z_OK ? "short" : zError(rc));
        return 0;
    }
#ifdef PRISMFARM_HAVE_BLOSC
    uint64_t pos = 0, done = 0;
    while (done < dst_len) {
        uint64_t chunk = dst_len - done < BLOSC_CHUNK ? dst_len - done : BLOSC_CHUNK;
        if (src_len - pos < 8)
            return err_set(err, "byte %llu: a BLOSC block is cut short (damaged file?)",
                           (unsigned long long)(src_at + pos));
        uint64_t n = le_get_u64(src + pos);
        pos += 8;
        size_t nbytes = 0;
        if (n > src_len - pos || blosc_cbuffer_validate(src + pos, (size_t)n, &nbytes) != 0 ||
            nbytes != chunk ||
            blosc_decompress_ctx(src + pos, dst + done, (size_t)chunk, 1) != (int)chunk)
            return err_set(
                err, "byte %llu: a BLOSC block does not decompress to %llu bytes (damaged file?)",
                (unsigned long long)(src_at + pos - 8), (unsigned long long)chunk);
        pos += n;
        done += chunk;
    }
    if (pos != src_len)
        return err_set(err, "byte %llu: the BLOSC blocks end before the grid does (damaged file?)",
                       (unsigned long long)(src_at + pos));
    return 0;
#else
    (void)dst;
    return err_set(
        err,
        "byte %llu: the grid is compressed with BLOSC, which this build cannot read (build "
        "prismfarm with Debian's libblosc-dev, or store the file with the ZIP codec or none: "
        "nanovdb_convert -z)",
        (unsigned long long)src_at);
#endif
}

/* The brick table over every item, the leaves copied into it. */
static int build(nanovdb_grid_t *g, walk_t *w, uint64_t left, uint64_t *charged, err_t *err)
{
    int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX}, hi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
    size_t nleaves = 0, nconsts = 1, inside = 0;
    for (size_t i = 0; i < w->nitems; i++) {
        const item_t *it = &w->items[i];
        int64_t r0[3], r1[3];
        if (!item_range(w, it, r0, r1))
            continue;
        inside++;
        for (int a = 0; a < 3; a++) {
            lo[a] = r0[a] < lo[a] ? r0[a] : lo[a];
            hi[a] = r1[a] > hi[a] ? r1[a] : hi[a];
        }
        if (it->leaf_at)
            nleaves++;
        else
            nconsts++;
    }
    uint64_t entries = 0;
    if (inside) {
        /* at most 2^29 bricks a side (index coordinates are 32-bit): no overflow below */
        entries = 1;
        for (int a = 0; a < 3; a++) {
            uint64_t n = (uint64_t)(hi[a] - lo[a]);
            if (entries > UINT64_MAX / n) {
                entries = UINT64_MAX;
                break;
            }
            entries *= n;
        }
        if (charge(entries > UINT64_MAX / 2 ? UINT64_MAX / 2 : entries, charged, left,
                   "the grid's table of 8^3 bricks", err))
            return -1;
        if (entries > ((uint64_t)1 << 31))
            return err_set(err, "the grid spans %llu bricks of 8^3 voxels, more than 2^31",
                           (unsigned long long)entries);
    }
    if (!(g->leaves = malloc((nleaves ? nleaves : 1) * BRICK * sizeof *g->leaves)) ||
        !(g->leaf_max = malloc((nleaves ? nleaves : 1) * sizeof *g->leaf_max)) ||
        !(g->consts = malloc(nconsts * sizeof *g->consts)) ||
        !(g->table = malloc((entries ? entries : 1) * sizeof *g->table)))
        return err_set(err, "out of memory");
    g->consts[0] = g->background;
    g->nconsts = 1;
    g->min = g->background;
    for (uint64_t e = 0; e < entries; e++)
        g->table[e] = -1;
    for (int a = 0; a < 3; a++) {
        g->lo[a] = inside ? lo[a] : 0;
        g->nb[a] = inside ? hi[a] - lo[a] : 0;
    }
    /* Tiles first, leaves after: a leaf always wins over a tile it overlaps (it cannot, in a
     * sound tree, but a damaged one must still give a defined grid). */
    for (int pass = 0; pass < 2; pass++)
        for (size_t i = 0; i < w->nitems; i++) {
            const item_t *it = &w->items[i];
            int64_t r0[3], r1[3];
            if ((pass == 0) != (it->leaf_at == 0) || !item_range(w, it, r0, r1))
                continue;
            int32_t entry;
            if (it->leaf_at) {
                float *dst = g->leaves + g->nleaves * BRICK, mx = -INFINITY;
                for (int v = 0; v < BRICK; v++) {
                    dst[v] = le_get_f32(w->g + it->leaf_at + LEAF_VALUES + 4 * (uint64_t)v);
                    mx = dst[v] > mx ? dst[v] : mx;
                    g->min = dst[v] < g->min ? dst[v] : g->min;
                }
                g->leaf_max[g->nleaves] = mx;
                entry = (int32_t)g->nleaves++;
            } else {
                g->consts[g->nconsts] = it->value;
                g->min = it->value < g->min ? it->value : g->min;
                entry = -1 - (int32_t)g->nconsts++;
            }
            for (int64_t z = r0[2]; z < r1[2]; z++)
                for (int64_t y = r0[1]; y < r1[1]; y++)
                    for (int64_t x = r0[0]; x < r1[0]; x++)
                        g->table[((z - g->lo[2]) * g->nb[1] + (y - g->lo[1])) * g->nb[0] +
                                 (x - g->lo[0])] = entry;
        }
    return 0;
}

/* The grid's bytes (decoded): its header, map and bounds, then the tree. */
static int read_grid(nanovdb_grid_t *g, const uint8_t *b, uint64_t size, uint64_t left,
                     uint64_t *charged, err_t *err)
{
    if (size < GRID_BYTES + TREE_BYTES || le_get_u64(b + GRID_MAGIC) != MAGIC ||
        le_get_u32(b + GRID_VERSION) >> 21 != MAJOR || le_get_u64(b + GRID_SIZE) > size)
        return err_set(err, "the grid's own header is not NanoVDB 32's (damaged file?)");
    if (le_get_u32(b + GRID_TYPE) != GRID_TYPE_FLOAT)
        return err_set(
            err, "the grid holds values of NanoVDB type %u; only float grids (type 1) are read",
            le_get_u32(b + GRID_TYPE));
    double m[9], v[3], bb[6];
    for (int i = 0; i < 9; i++)
        m[i] = le_get_f64(b + GRID_MAT_D + 8 * i);
    for (int i = 0; i < 3; i++)
        v[i] = le_get_f64(b + GRID_VEC_D + 8 * i);
    for (int i = 0; i < 6; i++)
        bb[i] = le_get_f64(b + GRID_WORLD_BBOX + 8 * i);
    double mm[4][4] = {
        {m[0], m[1], m[2], v[0]}, {m[3], m[4], m[5], v[1]}, {m[6], m[7], m[8], v[2]}, {0, 0, 0, 1}};
    transform_t to_medium = transform_from_matrix(mm);
    transform_t inv = transform_inverse(to_medium);
    if (inv.singular || !transform_is_finite(&to_medium) || !transform_is_finite(&inv))
        return err_set(err, "byte %d: the grid's index-to-world map is not invertible", GRID_MAT_D);
    for (int a = 0; a < 3; a++)
        if (!isfinite(bb[a]) || !isfinite(bb[a + 3]) || !(bb[a + 3] > bb[a]))
            return err_set(err, "byte %d: the grid's world bounding box is empty or not finite",
                           GRID_WORLD_BBOX);
    g->medium_to_index = inv;
    g->bbox_lo = vec3_make(bb[0], bb[1], bb[2]);
    g->bbox_hi = vec3_make(bb[3], bb[4], bb[5]);
    /* The voxels a trilinear lookup inside the bounds reaches: the box's corners in index
     * space, floor(min) to floor(max) + 1, in bricks, one brick of margin each side. */
    double ilo[3] = {INFINITY, INFINITY, INFINITY}, ihi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int c = 0; c < 8; c++) {
        vec3_t q = transform_point(
            &inv, vec3_make(bb[c & 1 ? 3 : 0], bb[c & 2 ? 4 : 1], bb[c & 4 ? 5 : 2]));
        const double qa[3] = {q.x, q.y, q.z};
        for (int a = 0; a < 3; a++) {
            ilo[a] = fmin(ilo[a], qa[a]);
            ihi[a] = fmax(ihi[a], qa[a]);
        }
    }
    int64_t clip_lo[3], clip_hi[3];
    for (int a = 0; a < 3; a++) {
        /* index coordinates are 32-bit: nothing is stored beyond */
        double l = fmax(fmin(floor(ilo[a]), 3e9), -3e9),
               h = fmax(fmin(floor(ihi[a]) + 1.0, 3e9), -3e9);
        clip_lo[a] = ((int64_t)l >> 3) - 1;
        clip_hi[a] = ((int64_t)h >> 3) + 2;
    }

    const uint8_t *tree = b + GRID_BYTES;
    walk_t w = {.g = b, .size = size, .err = err};
    memcpy(w.clip_lo, clip_lo, sizeof clip_lo);
    memcpy(w.clip_hi, clip_hi, sizeof clip_hi);
    uint64_t root = GRID_BYTES + le_get_u64(tree + 24);
    for (int l = 0; l < 3; l++) {
        static const uint64_t bytes[3] = {LEAF_BYTES, LOWER_BYTES, UPPER_BYTES};
        w.first[l] = GRID_BYTES + le_get_u64(tree + 8 * l);
        w.count[l] = le_get_u32(tree + 32 + 4 * l);
        if (w.count[l] && (w.first[l] < GRID_BYTES || w.first[l] > size ||
                           w.count[l] > (size - w.first[l]) / bytes[l]))
            return err_set(
                err,
                "byte %d: the tree's %llu nodes of level %d lie outside the grid's %llu bytes "
                "(damaged file?)",
                GRID_BYTES + 32 + 4 * l, (unsigned long long)w.count[l], l,
                (unsigned long long)size);
    }
    if (root < GRID_BYTES || root > size || size - root < ROOT_BYTES)
        return err_set(err, "byte %d: the tree's root lies outside the grid (damaged file?)",
                       GRID_BYTES + 24);
    w.background = le_get_f32(b + root + ROOT_BACKGROUND);
    if (!isfinite(w.background))
        return err_set(err, "byte %llu: the background value is not finite",
                       (unsigned long long)(root + 28));
    g->background = w.background;
    int rc = 0;
    for (int l = 0; l < 3 && rc == 0; l++)
        if (!(w.seen[l] = calloc(w.count[l] ? w.count[l] : 1, 1)))
            rc = err_set(err, "out of memory");
    if (rc == 0)
        rc = walk_root(&w, root);
    if (rc == 0)
        rc = build(g, &w, left, charged, err);
    for (int l = 0; l < 3; l++)
        free(w.seen[l]);
    free(w.items);
    return rc;
}

int nanovdb_read(const uint8_t *data, size_t len, const char *name, uint64_t voxels_left,
                 nanovdb_grid_t **out, uint64_t *voxels_charged, err_t *err)
{
    *out = NULL;
    *voxels_charged = 0;
    uint64_t at = 0;
    if (len < FILE_HEADER)
        return err_set(err, "%zu bytes: too short for a NanoVDB file", len);
    while (at < len) {
        if (len - at < FILE_HEADER)
            return err_set(err, "byte %llu: a segment header is cut short (damaged file?)",
                           (unsigned long long)at);
        uint64_t magic = le_get_u64(data + at);
        if (magic != MAGIC)
            return err_set(err,
                           "byte %llu: not a NanoVDB file (its magic number is not \"NanoVDB0\")",
                           (unsigned long long)at);
        uint32_t version = le_get_u32(data + at + 8);
        if (version >> 21 != MAJOR)
            return err_set(err,
                           "byte %llu: NanoVDB version %u.%u.%u; this reader knows version %u.x",
                           (unsigned long long)(at + 8), version >> 21, (version >> 10) & 0x7FF,
                           version & 0x3FF, MAJOR);
        unsigned ngrids = le_get_u16(data + at + 12), codec = le_get_u16(data + at + 14);
        if (codec > CODEC_BLOSC)
            return err_set(err, "byte %llu: unknown codec %u (NanoVDB has NONE, ZIP and BLOSC)",
                           (unsigned long long)(at + 14), codec);
        at += FILE_HEADER;
        /* the records, then the grids' bytes in the same order */
        uint64_t rec = at, body = 0;
        for (unsigned i = 0; i < ngrids; i++) {
            if (len - rec < META_SIZE)
                return err_set(err, "byte %llu: grid record %u is cut short (damaged file?)",
                               (unsigned long long)rec, i);
            uint32_t nsize = le_get_u32(data + rec + META_NAME_SIZE);
            if (nsize < 1 || nsize > NAME_MAX_BYTES || len - rec - META_SIZE < nsize ||
                data[rec + META_SIZE + nsize - 1] != 0)
                return err_set(err, "byte %llu: grid record %u has a damaged name",
                               (unsigned long long)(rec + META_NAME_SIZE), i);
            rec += META_SIZE + nsize;
        }
        body = rec;
        /* the grids' bytes must all be there: a cut file is refused whichever grid is read */
        uint64_t need = 0;
        for (unsigned i = 0, r = 0; i < ngrids; i++) {
            uint64_t f = le_get_u64(data + at + r + META_FILE_SIZE);
            if (f > len - body || need > len - body - f)
                return err_set(
                    err, "byte %llu: the grids' bytes run past the file's end (damaged file?)",
                    (unsigned long long)(at + r + META_FILE_SIZE));
            need += f;
            r += META_SIZE + le_get_u32(data + at + r + META_NAME_SIZE);
        }
        rec = at;
        for (unsigned i = 0; i < ngrids; i++) {
            const uint8_t *r = data + rec;
            uint64_t gsize = le_get_u64(r + META_GRID_SIZE), fsize = le_get_u64(r + META_FILE_SIZE);
            uint32_t nsize = le_get_u32(r + META_NAME_SIZE);
            const char *gname = (const char *)r + META_SIZE;
            if (fsize > len - body)
                return err_set(
                    err,
                    "byte %llu: grid \"%s\" claims %llu bytes, past the file's end (damaged file?)",
                    (unsigned long long)(rec + META_FILE_SIZE), gname, (unsigned long long)fsize);
            if (le_get_u16(r + META_CODEC) != codec)
                return err_set(
                    err,
                    "byte %llu: grid \"%s\" names another codec than its segment (damaged file?)",
                    (unsigned long long)(rec + META_CODEC), gname);
            if (!strcmp(gname, name)) {
                if (le_get_u32(r + META_GRID_TYPE) != GRID_TYPE_FLOAT)
                    return err_set(err,
                                   "grid \"%s\" holds values of NanoVDB type %u; only float grids "
                                   "(type 1) are read",
                                   gname, le_get_u32(r + META_GRID_TYPE));
                if (gsize < GRID_BYTES + TREE_BYTES || gsize > NANOVDB_GRID_BYTES_MAX)
                    return err_set(
                        err, "byte %llu: grid \"%s\" claims %llu bytes (at most %llu are read)",
                        (unsigned long long)(rec + META_GRID_SIZE), gname,
                        (unsigned long long)gsize, (unsigned long long)NANOVDB_GRID_BYTES_MAX);
                /* the decoded bytes, a float each, before anything is allocated */
                if (charge(gsize / 4, voxels_charged, voxels_left, "the grid", err))
                    return err_prefix(err, "grid \"%s\": ", gname);
                uint8_t *buf = malloc(gsize);
                if (!buf)
                    return err_set(err, "out of memory");
                nanovdb_grid_t *g = calloc(1, sizeof *g);
                int rc = g ? 0 : err_set(err, "out of memory");
                if (rc == 0)
                    rc = decode(data + body, fsize, body, codec, buf, gsize, err);
                if (rc == 0)
                    rc = read_grid(g, buf, gsize, voxels_left, voxels_charged, err);
                free(buf);
                if (rc) {
                    nanovdb_destroy(&g);
                    return err_prefix(err, "grid \"%s\": ", gname);
                }
                *out = g;
                return 0;
            }
            body += fsize;
            rec += META_SIZE + nsize;
        }
        at = body;
    }
    return 0;
}

void nanovdb_destroy(nanovdb_grid_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    nanovdb_grid_t *g = *self_p;
    free(g->table);
    free(g->leaves);
    free(g->leaf_max);
    free(g->consts);
    free(g);
    *self_p = NULL;
}

void nanovdb_bounds(const nanovdb_grid_t *self, vec3_t *lo, vec3_t *hi)
{
    *lo = self->bbox_lo;
    *hi = self->bbox_hi;
}

transform_t nanovdb_medium_to_index(const nanovdb_grid_t *self)
{
    return self->medium_to_index;
}

size_t nanovdb_leaf_count(const nanovdb_grid_t *self)
{
    return self->nleaves;
}

double nanovdb_min(const nanovdb_grid_t *self)
{
    return self->min;
}

/* The table's entry for the brick holding voxel (i, j, k); -1 (the background) outside. */
static int32_t brick_of(const nanovdb_grid_t *g, int64_t i, int64_t j, int64_t k)
{
    int64_t b0 = (i >> 3) - g->lo[0], b1 = (j >> 3) - g->lo[1], b2 = (k >> 3) - g->lo[2];
    if (b0 < 0 || b1 < 0 || b2 < 0 || b0 >= g->nb[0] || b1 >= g->nb[1] || b2 >= g->nb[2])
        return -1;
    return g->table[(b2 * g->nb[1] + b1) * g->nb[0] + b0];
}

static float voxel(const nanovdb_grid_t *g, int64_t i, int64_t j, int64_t k)
{
    int32_t e = brick_of(g, i, j, k);
    if (e < 0)
        return g->consts[-1 - e];
    return g->leaves[(size_t)e * BRICK + (size_t)(((i & 7) << 6) | ((j & 7) << 3) | (k & 7))];
}

double nanovdb_sample(const nanovdb_grid_t *self, vec3_t p)
{
    vec3_t u = transform_point(&self->medium_to_index, p);
    const double c[3] = {u.x, u.y, u.z};
    int64_t i[3];
    double f[3];
    for (int a = 0; a < 3; a++) {
        /* far outside the 32-bit index space every voxel is the background */
        if (!(c[a] > -4e9 && c[a] < 4e9))
            return self->background;
        double fl = floor(c[a]);
        i[a] = (int64_t)fl;
        f[a] = c[a] - fl;
    }
    double d = 0.0;
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 2; j++)
            for (int h = 0; h < 2; h++) {
                double w =
                    (h ? f[0] : 1.0 - f[0]) * (j ? f[1] : 1.0 - f[1]) * (k ? f[2] : 1.0 - f[2]);
                if (w > 0.0)
                    d += w * voxel(self, i[0] + h, i[1] + j, i[2] + k);
            }
    return d;
}

double nanovdb_max_in(const nanovdb_grid_t *self, const int64_t lo[3], const int64_t hi[3])
{
    double mx = -INFINITY;
    int64_t b0[3], b1[3];
    for (int a = 0; a < 3; a++) {
        b0[a] = (lo[a] >> 3) - self->lo[a];
        b1[a] = (hi[a] >> 3) - self->lo[a];
        if (b0[a] < 0 || b1[a] >= self->nb[a])
            mx = self->background; /* part of the box has no stored voxels */
        b0[a] = b0[a] < 0 ? 0 : b0[a];
        b1[a] = b1[a] >= self->nb[a] ? self->nb[a] - 1 : b1[a];
    }
    for (int64_t z = b0[2]; z <= b1[2]; z++)
        for (int64_t y = b0[1]; y <= b1[1]; y++)
            for (int64_t x = b0[0]; x <= b1[0]; x++) {
                int32_t e = self->table[(z * self->nb[1] + y) * self->nb[0] + x];
                double v = e < 0 ? self->consts[-1 - e] : self->leaf_max[e];
                mx = v > mx ? v : mx;
            }
    return mx == -INFINITY ? self->background : mx;
}
