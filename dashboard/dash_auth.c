#include "dash_auth.h"

#include "curve.h"

#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct dash_auth {
    curve_ring_t *any, *clients, *admins;
    bool has_file, has_metrics;
    uint8_t file_hash[CURVE_TOKEN_HASH], metrics_hash[CURVE_TOKEN_HASH];
    char file_name[CURVE_NAME_MAX + 1], metrics_name[CURVE_NAME_MAX + 1];
};

/* A token file's holder is named after the file: "ops.token" acts as "ops". */
static void name_after(const char *path, const char *fallback, char *out, size_t size)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    size_t n = strcspn(base, ".");
    if (n == 0 || n > CURVE_NAME_MAX)
        n = strlen(fallback), base = fallback;
    snprintf(out, size, "%.*s", (int)n, base);
}

static int load_ring(const char *dir, curve_ring_t **out, err_t *err)
{
    if (!dir)
        return 0;
    *out = curve_ring_new(dir, err);
    return *out ? 0 : err_prefix(err, "dashboard tokens: ");
}

dash_auth_t *dash_auth_new(const dash_auth_config_t *cfg, err_t *err)
{
    dash_auth_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "dashboard tokens: out of memory");
        return NULL;
    }
    if (load_ring(cfg->any_dir, &self->any, err) < 0 ||
        load_ring(cfg->clients_dir, &self->clients, err) < 0 ||
        load_ring(cfg->admins_dir, &self->admins, err) < 0) {
        dash_auth_destroy(&self);
        return NULL;
    }
    if (cfg->token_file) {
        if (curve_load_token(cfg->token_file, self->file_hash, err) < 0) {
            err_prefix(err, "--http-token-file: ");
            dash_auth_destroy(&self);
            return NULL;
        }
        self->has_file = true;
        name_after(cfg->token_file, "admin", self->file_name, sizeof self->file_name);
    }
    if (cfg->metrics_token_file) {
        if (curve_load_token(cfg->metrics_token_file, self->metrics_hash, err) < 0) {
            err_prefix(err, "--metrics-token-file: ");
            dash_auth_destroy(&self);
            return NULL;
        }
        self->has_metrics = true;
        name_after(cfg->metrics_token_file, "scraper", self->metrics_name,
                   sizeof self->metrics_name);
    }
    return self;
}

void dash_auth_destroy(dash_auth_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    dash_auth_t *self = *self_p;
    curve_ring_destroy(&self->any);
    curve_ring_destroy(&self->clients);
    curve_ring_destroy(&self->admins);
    sodium_memzero(self, sizeof *self);
    free(self);
    *self_p = NULL;
}

bool dash_auth_any(const dash_auth_t *self)
{
    return self->any || self->clients || self->admins || self->has_file || self->has_metrics;
}

/* A key found in a folder that changed since it was read: read it again (a stat otherwise). A
 * failed reload keeps the keys of before, as the ZAP handler does. */
static const char *ring_lookup(curve_ring_t *ring, const uint8_t hash[CURVE_TOKEN_HASH])
{
    if (!ring)
        return NULL;
    err_t ignore;
    (void)curve_ring_refresh(ring, false, NULL, &ignore);
    return curve_ring_find_token(ring, hash);
}

int dash_auth_identify(dash_auth_t *self, const char *authorization, dash_identity_t *who,
                       err_t *err)
{
    memset(who, 0, sizeof *who);
    if (!authorization || !*authorization)
        return err_set(err, "this action needs a token: send 'Authorization: Bearer TOKEN' "
                            "(the NAME.token of prismfarm keygen)");
    if (strncmp(authorization, "Bearer ", 7) != 0)
        return err_set(err, "the Authorization header must be 'Bearer TOKEN'");
    const char *token = authorization + 7;
    while (*token == ' ')
        token++;
    size_t len = strlen(token);
    while (len > 0 && token[len - 1] == ' ')
        len--;
    if (len != CURVE_TOKEN_CHARS)
        return err_set(err, "a token has %d hex digits, this one %zu characters", CURVE_TOKEN_CHARS,
                       len);
    if (!dash_auth_any(self))
        return err_set(err, "this master accepts no token: actions need its authorised key "
                            "folders or --http-token-file (docs/dashboard.md)");
    uint8_t hash[CURVE_TOKEN_HASH];
    curve_token_hash(token, len, hash);
    /* Every source is looked at whatever matched, so the time does not say which did. */
    const char *admin = ring_lookup(self->admins, hash);
    const char *user = ring_lookup(self->clients, hash);
    const char *any = ring_lookup(self->any, hash);
    bool file = self->has_file && sodium_memcmp(hash, self->file_hash, sizeof hash) == 0;
    bool scraper = self->has_metrics && sodium_memcmp(hash, self->metrics_hash, sizeof hash) == 0;
    sodium_memzero(hash, sizeof hash);
    const char *name = admin     ? admin
                       : file    ? self->file_name
                       : user    ? user
                       : any     ? any
                       : scraper ? self->metrics_name
                                 : NULL;
    if (!name)
        return err_set(err, "unknown token: no authorised key of this master carries it");
    snprintf(who->name, sizeof who->name, "%s", name);
    who->admin = admin || file;
    /* A key's token is a key's, even if it is also the scrapers' file. */
    who->scraper = !admin && !file && !user && !any;
    return 0;
}
