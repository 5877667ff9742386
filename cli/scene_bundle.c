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
    size_t n, bytes;
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
    free(self);
    *self_p = NULL;
}

scene_bundle_t *scene_bundle_new(const char *scene_path, err_t *err)
{
    scene_desc_t *d = pbrt_parse_file(scene_path, err);
    if (!d)
        return NULL;
    scene_bundle_t *self = calloc(1, sizeof *self);
    size_t n = d->nfiles;
    if (self) {
        self->files = calloc(n ? n : 1, sizeof *self->files);
        self->paths = calloc(n ? n : 1, sizeof *self->paths);
        self->data = calloc(n ? n : 1, sizeof *self->data);
    }
    if (!self || !self->files || !self->paths || !self->data) {
        err_set(err, "out of memory");
        goto fail;
    }
    for (size_t i = 0; i < n; i++) {
        const scene_file_t *sf = &d->files[i];
        /* The main file is the bundle's root whatever path named it. */
        const char *rel = sf->relative;
        if (sf->kind == SCENE_FILE_MAIN) {
            const char *slash = strrchr(sf->path, '/');
            rel = slash ? slash + 1 : sf->path;
        } else if (sf->outside) {
            err_set(err, "%s:%d:%d: \"%s\" lies outside the scene's folder, so it cannot travel "
                         "with the job: move it below the folder of %s",
                    sf->loc.file, sf->loc.line, sf->loc.col, sf->relative, scene_path);
            goto fail;
        }
        self->paths[i] = strdup(rel);
        size_t size = 0;
        if (!self->paths[i] || files_read(sf->path, PROTO_MAX_BUNDLE_BYTES, &self->data[i], &size, err))
            goto fail;
        self->n = i + 1;
        self->files[i] = (proto_bundle_file_t){.path = self->paths[i], .data = self->data[i], .size = size};
        self->bytes += size;
        if (sf->kind == SCENE_FILE_MAIN)
            self->bundle.main = self->paths[i];
    }
    self->n = n;
    self->bundle.files = self->files;
    self->bundle.nfiles = n;
    if (!self->bundle.main) {
        err_set(err, "%s: the parser did not report the main file", scene_path);
        goto fail;
    }
    if (proto_bundle_check(&self->bundle, NULL, err)) {
        err_prefix(err, "%s: ", scene_path);
        goto fail;
    }
    scene_desc_destroy(&d);
    return self;
fail:
    scene_desc_destroy(&d);
    scene_bundle_destroy(&self);
    return NULL;
}

const proto_bundle_t *scene_bundle_get(const scene_bundle_t *self) { return &self->bundle; }
size_t scene_bundle_bytes(const scene_bundle_t *self) { return self->bytes; }
