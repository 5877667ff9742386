#include "scene_bundle.h"

#include "files.h"
#include "paths.h"

#include "bundle.h"
#include "pbrt_parser.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct scene_bundle {
    proto_bundle_t bundle;
    proto_bundle_file_t *files;
    char **paths;
    uint8_t **data;
    size_t n, cap, bytes;
    char **mains; /* each frame's main, pointing into paths */
    size_t nmains;
};

void scene_bundle_destroy(scene_bundle_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    scene_bundle_t *self = *self_p;
    for (size_t i = 0; i < self->n; i++) {
        free(self->paths[i]);
        free(self->data[i]);
    }
    free(self->paths);
    free(self->data);
    free(self->files);
    free(self->mains);
    free(self);
    *self_p = NULL;
}

/* The index of the file with this bundle path, or n. */
static size_t find_file(const scene_bundle_t *self, const char *rel)
{
    size_t i = 0;
    while (i < self->n && strcmp(self->paths[i], rel) != 0)
        i++;
    return i;
}

static int reserve(scene_bundle_t *self, size_t more)
{
    if (self->n + more <= self->cap)
        return 0;
    size_t cap = self->cap ? self->cap : 8;
    while (cap < self->n + more)
        cap *= 2;
    proto_bundle_file_t *f = realloc(self->files, cap * sizeof *f);
    if (f)
        self->files = f;
    char **p = realloc(self->paths, cap * sizeof *p);
    if (p)
        self->paths = p;
    uint8_t **d = realloc(self->data, cap * sizeof *d);
    if (d)
        self->data = d;
    if (!f || !p || !d)
        return -1;
    self->cap = cap;
    return 0;
}

/* A scene parsed as the farm's client reads it: the bundle rule (pbrt_confine.h) applied to
 * every file before it is read, so an absolute path or a symbolic link out of the folder is
 * refused unread. */
static scene_desc_t *parse_for_bundle(const char *scene_path, err_t *err)
{
    return pbrt_parse_file_opts(scene_path, &(pbrt_parse_opts_t){.bundle = true}, err);
}

/* The bundle's root is the main file's folder lifted by the most ".." any file's path (relative
 * to that folder) starts with: the nearest folder that holds everything the scene names. */
static size_t root_ups(const scene_desc_t *d)
{
    size_t ups = 0;
    for (size_t i = 0; i < d->nfiles; i++) {
        size_t u = paths_ups(d->files[i].relative);
        ups = u > ups ? u : ups;
    }
    return ups;
}

/* One parsed scene and what it reads, added to the bundle under their paths below the root
 * (prefix: the main file's folder as seen from the root, "" when they are the same): a path
 * the bundle already holds (a file another frame reads too) is read once. */
static int add_scene(scene_bundle_t *self, const char *scene_path, const scene_desc_t *d,
                     const char *prefix, err_t *err)
{
    if (reserve(self, d->nfiles) < 0)
        return err_set(err, "out of memory");
    const char *main = NULL;
    for (size_t i = 0; i < d->nfiles; i++) {
        const scene_file_t *sf = &d->files[i];
        /* The main file sits in the prefix whatever path named it. */
        const char *rel = sf->relative;
        if (sf->kind == SCENE_FILE_MAIN) {
            const char *slash = strrchr(sf->path, '/');
            rel = slash ? slash + 1 : sf->path;
        } else if (rel[0] == '/') {
            /* The parse refuses it first (bundle rule); kept as the last line of defence. */
            return err_set(err,
                           "%s:%d:%d: \"%s\" is an absolute path, so it cannot travel with the "
                           "job",
                           sf->loc.file, sf->loc.line, sf->loc.col, sf->relative);
        }
        size_t plen = strlen(prefix), rlen = strlen(rel);
        char *joined = malloc(plen + rlen + 2);
        if (!joined)
            return err_set(err, "out of memory");
        snprintf(joined, plen + rlen + 2, "%s%s%s", prefix, plen ? "/" : "", rel);
        char *name = paths_normalise(joined);
        free(joined);
        if (!name)
            return err_set(err, "out of memory");
        size_t at = find_file(self, name);
        if (at == self->n) {
            size_t size = 0;
            self->paths[at] = name;
            self->data[at] = NULL;
            self->n++;
            if (files_read(sf->path, PROTO_MAX_BUNDLE_BYTES, &self->data[at], &size, err) < 0)
                return -1;
            self->files[at] = (proto_bundle_file_t){
                .path = self->paths[at], .data = self->data[at], .size = size};
            self->bytes += size;
        } else {
            free(name);
        }
        if (sf->kind == SCENE_FILE_MAIN)
            main = self->paths[at];
    }
    if (!main)
        return err_set(err, "%s: the parser did not report the main file", scene_path);
    self->mains[self->nmains++] = (char *)main;
    return 0;
}

/* The main file's folder as seen from the bundle's root ups levels above it ("" for ups 0):
 * the last ups components of its absolute, normalised form. */
static char *root_prefix(const char *scene_path, size_t ups)
{
    char *dir = paths_folder(scene_path);
    char *adir = dir ? paths_lexical(dir[0] ? dir : ".") : NULL;
    char *root = adir ? paths_lift(adir, ups) : NULL;
    char *prefix = root ? paths_relative_to(root, adir) : NULL;
    free(dir);
    free(adir);
    free(root);
    return prefix;
}

/* The folder part of a path ("" for none), for the one-folder rule. */
static size_t folder_length(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? (size_t)(slash - path) : 0;
}

bool scene_bundle_one_folder(const char *const *scene_paths, size_t n)
{
    size_t dir = n ? folder_length(scene_paths[0]) : 0;
    for (size_t k = 1; k < n; k++)
        if (folder_length(scene_paths[k]) != dir ||
            strncmp(scene_paths[k], scene_paths[0], dir) != 0)
            return false;
    return true;
}

scene_bundle_t *scene_bundle_new_frames(const char *const *scene_paths, size_t n, err_t *err)
{
    if (n == 0) {
        err_set(err, "no scene file given");
        return NULL;
    }
    scene_bundle_t *self = calloc(1, sizeof *self);
    if (!self || !(self->mains = calloc(n, sizeof *self->mains))) {
        free(self);
        err_set(err, "out of memory");
        return NULL;
    }
    size_t dir = folder_length(scene_paths[0]);
    scene_desc_t **descs = calloc(n, sizeof *descs);
    char *prefix = NULL;
    size_t ups = 0;
    if (!descs) {
        err_set(err, "out of memory");
        goto fail;
    }
    for (size_t k = 0; k < n; k++) {
        const char *p = scene_paths[k];
        /* Bundle paths are relative to one root: frames of other folders would name their
         * files from other roots. */
        if (folder_length(p) != dir || strncmp(p, scene_paths[0], dir) != 0) {
            err_set(err,
                    "%s: the frames of a sequence must be in one folder (the first, %s, is "
                    "in '%.*s')",
                    p, scene_paths[0], (int)dir, dir ? scene_paths[0] : ".");
            goto fail;
        }
        if (!(descs[k] = parse_for_bundle(p, err))) {
            if (n > 1)
                err_prefix(err, "frame %zu of %zu: ", k + 1, n);
            goto fail;
        }
        size_t u = root_ups(descs[k]);
        ups = u > ups ? u : ups;
    }
    if (!(prefix = root_prefix(scene_paths[0], ups))) {
        err_set(err, "out of memory");
        goto fail;
    }
    for (size_t k = 0; k < n; k++) {
        size_t before = self->nmains;
        if (add_scene(self, scene_paths[k], descs[k], prefix, err) < 0) {
            if (n > 1)
                err_prefix(err, "frame %zu of %zu: ", k + 1, n);
            goto fail;
        }
        for (size_t i = 0; i < before; i++)
            if (!strcmp(self->mains[i], self->mains[before])) {
                err_set(err, "%s is given twice as a frame", scene_paths[k]);
                goto fail;
            }
    }
    for (size_t k = 0; k < n; k++)
        scene_desc_destroy(&descs[k]);
    free(descs);
    free(prefix);
    descs = NULL;
    prefix = NULL;
    self->bundle.files = self->files;
    self->bundle.nfiles = self->n;
    self->bundle.main = self->mains[0];
    if (proto_bundle_check(&self->bundle, NULL, err)) {
        err_prefix(err, "%s: ", scene_paths[0]);
        goto fail;
    }
    return self;
fail:
    if (descs)
        for (size_t k = 0; k < n; k++)
            scene_desc_destroy(&descs[k]);
    free(descs);
    free(prefix);
    scene_bundle_destroy(&self);
    return NULL;
}

scene_bundle_t *scene_bundle_new(const char *scene_path, err_t *err)
{
    return scene_bundle_new_frames(&scene_path, 1, err);
}

const proto_bundle_t *scene_bundle_get(const scene_bundle_t *self)
{
    return &self->bundle;
}
size_t scene_bundle_bytes(const scene_bundle_t *self)
{
    return self->bytes;
}
const char *scene_bundle_frame_main(const scene_bundle_t *self, size_t k)
{
    return k < self->nmains ? self->mains[k] : NULL;
}
