#include "scene_bundle.h"

#include "files.h"

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

/* One scene file and what it reads, added to the bundle: a path it already holds (a file
 * another frame reads too) is read once. */
static int add_scene(scene_bundle_t *self, const char *scene_path, err_t *err)
{
    scene_desc_t *d = pbrt_parse_file(scene_path, err);
    if (!d)
        return -1;
    int rc = 0;
    if (reserve(self, d->nfiles) < 0) {
        rc = err_set(err, "out of memory");
        goto out;
    }
    const char *main = NULL;
    for (size_t i = 0; i < d->nfiles; i++) {
        const scene_file_t *sf = &d->files[i];
        /* The main file is the bundle's root whatever path named it. */
        const char *rel = sf->relative;
        if (sf->kind == SCENE_FILE_MAIN) {
            const char *slash = strrchr(sf->path, '/');
            rel = slash ? slash + 1 : sf->path;
        } else if (sf->outside) {
            rc = err_set(err,
                         "%s:%d:%d: \"%s\" lies outside the scene's folder, so it cannot "
                         "travel with the job: move it below the folder of %s",
                         sf->loc.file, sf->loc.line, sf->loc.col, sf->relative, scene_path);
            goto out;
        }
        size_t at = find_file(self, rel);
        if (at == self->n) {
            size_t size = 0;
            if (!(self->paths[at] = strdup(rel))) {
                rc = err_set(err, "out of memory");
                goto out;
            }
            self->data[at] = NULL;
            self->n++;
            if (files_read(sf->path, PROTO_MAX_BUNDLE_BYTES, &self->data[at], &size, err) < 0) {
                rc = -1;
                goto out;
            }
            self->files[at] = (proto_bundle_file_t){
                .path = self->paths[at], .data = self->data[at], .size = size};
            self->bytes += size;
        }
        if (sf->kind == SCENE_FILE_MAIN)
            main = self->paths[at];
    }
    if (!main)
        rc = err_set(err, "%s: the parser did not report the main file", scene_path);
    else
        self->mains[self->nmains++] = (char *)main;
out:
    scene_desc_destroy(&d);
    return rc;
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
        if (folder_length(scene_paths[k]) != dir || strncmp(scene_paths[k], scene_paths[0], dir) != 0)
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
    for (size_t k = 0; k < n; k++) {
        const char *p = scene_paths[k];
        /* Bundle paths are relative to the scene's folder: frames of other folders would
         * name their files from other roots. */
        if (folder_length(p) != dir || strncmp(p, scene_paths[0], dir) != 0) {
            err_set(err,
                    "%s: the frames of a sequence must be in one folder (the first, %s, is "
                    "in '%.*s')",
                    p, scene_paths[0], (int)dir, dir ? scene_paths[0] : ".");
            goto fail;
        }
        size_t before = self->nmains;
        if (add_scene(self, p, err) < 0) {
            if (n > 1)
                err_prefix(err, "frame %zu of %zu: ", k + 1, n);
            goto fail;
        }
        for (size_t i = 0; i < before; i++)
            if (!strcmp(self->mains[i], self->mains[before])) {
                err_set(err, "%s is given twice as a frame", p);
                goto fail;
            }
    }
    self->bundle.files = self->files;
    self->bundle.nfiles = self->n;
    self->bundle.main = self->mains[0];
    if (proto_bundle_check(&self->bundle, NULL, err)) {
        err_prefix(err, "%s: ", scene_paths[0]);
        goto fail;
    }
    return self;
fail:
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
