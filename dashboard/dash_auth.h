/* dash_auth: who presents a dashboard token (docs/dashboard.md, "Tokens"). A token is the
 * secret of a NAME.token that `prismfarm keygen` wrote beside NAME.key; the NAME.pub files of
 * the master's authorised folders carry its SHA-256, so the master maps a token to the key's
 * name and role without holding any secret: a key of the admins' folder is an administrator,
 * one of the clients' (or the single --authorized) folder a user, a worker's key nothing. A
 * token file given to the master itself (--http-token-file) is one more administrator, named
 * after the file; the scrapers' token file (--metrics-token-file) reads /metrics only. Every
 * comparison is in constant time; the folders are read again when they change, as the ZAP handler
 * does. */
#ifndef PRISMFARM_DASH_AUTH_H
#define PRISMFARM_DASH_AUTH_H

#include "dash_provider.h"
#include "err.h"

#include <stdbool.h>
#include <stddef.h>

typedef struct dash_auth dash_auth_t;

/* The folders whose NAME.pub files carry tokens (NULL: none) and an administrator's token file
 * (NULL: none). */
typedef struct dash_auth_config {
    const char *any_dir;            /* --authorized: its keys are users */
    const char *clients_dir;        /* --authorized-clients: users */
    const char *admins_dir;         /* --authorized-admins: administrators */
    const char *token_file;         /* --http-token-file: an administrator named after the file */
    const char *metrics_token_file; /* --metrics-token-file: a scraper (reads /metrics only) */
} dash_auth_config_t;

/* Loads the folders and the token file; NULL with err naming the file at fault. */
dash_auth_t *dash_auth_new(const dash_auth_config_t *cfg, err_t *err);
void dash_auth_destroy(dash_auth_t **self_p);

/* Whether any token can be accepted at all (a folder or a token file was given). */
bool dash_auth_any(const dash_auth_t *self);

/* The identity of an "Authorization" header's value ("Bearer TOKEN"); 0 with *who filled, or
 * -1 with err (no such token, a malformed header). An admin token found in several folders is
 * an administrator. */
int dash_auth_identify(dash_auth_t *self, const char *authorization, dash_identity_t *who,
                       err_t *err);

#endif
