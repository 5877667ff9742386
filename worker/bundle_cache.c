#include "bundle_cache.h"

#include "bundle.h"
#include "files.h"
#include "scene_load.h"

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int make_dirs(const char *path)
{
    char buf[512];
    snprintf(buf, sizeof buf, "%s", path);
    for (char *p = buf + 1;; p++) {
        if (*p == '/' || !*p) {
            char c = *p;
            *p = 0;
            if (mkdir(buf, 0700) && errno != EEXIST)
                return -1;
            if (!c)
                return 0;
            *p = c;
        }
    }
}

int bundle_cache_open(bundle_cache_t *self, const char *dir)
{
    if (dir)
        snprintf(self->dir, sizeof self->dir, "%s", dir);
    else
        snprintf(self->dir, sizeof self->dir, "%s/prismfarm-worker-%ld",
                 getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp", (long)getuid());
    if (make_dirs(self->dir))
        return -1;
    /* Bundles of another boot may have lost what was not yet on the disk (no fsync). */
    char boot[64] = "", mark[64] = "", path[600];
    FILE *f = fopen("/proc/sys/kernel/random/boot_id", "r");
    if (f) {
        if (!fgets(boot, sizeof boot, f))
            boot[0] = 0;
        fclose(f);
    }
    snprintf(path, sizeof path, "%s/.boot_id", self->dir);
    if ((f = fopen(path, "r"))) {
        if (!fgets(mark, sizeof mark, f))
            mark[0] = 0;
        fclose(f);
    }
    if (boot[0] && !strcmp(boot, mark))
        return 0;
    DIR *d = opendir(self->dir);
    if (d) {
        struct dirent *e;
        while ((e = readdir(d))) {
            if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
                continue;
            char sub[800];
            snprintf(sub, sizeof sub, "%s/%s", self->dir, e->d_name);
            (void)files_remove_tree(sub, PROTO_MAX_PATH_DEPTH + 4);
        }
        closedir(d);
    }
    err_t err;
    return boot[0] && files_write_atomic(path, boot, strlen(boot), true, &err) < 0 ? -1 : 0;
}

bool bundle_cache_has(const bundle_cache_t *self, const char *hash)
{
    char path[700];
    snprintf(path, sizeof path, "%s/%s/.complete", self->dir, hash);
    return access(path, F_OK) == 0;
}

/* Into a fresh folder first, then renamed into place, so a half-written bundle never looks
 * complete. */
int bundle_cache_put(const bundle_cache_t *self, const char *hash, const proto_bundle_t *b,
                     err_t *err)
{
    char have[PROTO_HASH_HEX + 1];
    if (proto_bundle_hash(b, have, err))
        return -1;
    if (strcmp(have, hash) != 0)
        return err_set(err, "scene bundle hashes to %s, not %s", have, hash);
    if (bundle_cache_has(self, hash))
        return 0;
    char tmp[700], final[700], path[800];
    snprintf(tmp, sizeof tmp, "%s/tmp-%s-%ld", self->dir, hash, (long)getpid());
    snprintf(final, sizeof final, "%s/%s", self->dir, hash);
    if (proto_bundle_extract(b, tmp, false, err))
        return -1;
    snprintf(path, sizeof path, "%s/.main", tmp);
    FILE *f = fopen(path, "w");
    if (!f || fprintf(f, "%s\n", b->main) < 0 || fclose(f) != 0)
        return err_set(err, "cannot write %s: %s", path, strerror(errno));
    snprintf(path, sizeof path, "%s/.complete", tmp);
    f = fopen(path, "w");
    if (!f || fclose(f) != 0)
        return err_set(err, "cannot write %s: %s", path, strerror(errno));
    if (rename(tmp, final) != 0 && !bundle_cache_has(self, hash))
        return err_set(err, "cannot move %s to %s: %s", tmp, final, strerror(errno));
    return 0;
}

int bundle_cache_main(const bundle_cache_t *self, const char *hash, char *out, size_t size,
                      err_t *err)
{
    char namefile[760];
    snprintf(namefile, sizeof namefile, "%s/%s/.main", self->dir, hash);
    /* The bundle's main file name was written next to it at extraction (before .complete). */
    FILE *f = fopen(namefile, "r");
    int ok = f && fgets(out, (int)size, f);
    if (f)
        fclose(f);
    if (!ok)
        return err_set(err, "scene %s: its bundle in %s/%s is incomplete", hash, self->dir, hash);
    out[strcspn(out, "\n")] = 0;
    return 0;
}

scene_t *bundle_cache_load(const bundle_cache_t *self, const char *hash, const char *main,
                           const scene_overrides_t *ov, err_t *err)
{
    char main_path[PROTO_MAX_STRING + 800], dir[700], mainname[PROTO_MAX_STRING + 1];
    snprintf(dir, sizeof dir, "%s/%s", self->dir, hash);
    if (bundle_cache_main(self, hash, mainname, sizeof mainname, err) < 0)
        return NULL;
    /* TASK's decoder checked that main is a bundle path, and the load is confined to the
     * bundle's folder. */
    snprintf(main_path, sizeof main_path, "%s/%s", dir, main && main[0] ? main : mainname);
    return scene_load_file_confined(main_path, dir, ov, err);
}
