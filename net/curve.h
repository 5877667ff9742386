/* curve: the CURVE keys of the farm's encrypted, authenticated links (docs/security.md). A key
 * file is text: NAME.key holds a key pair and is refused when group or others may read it;
 * NAME.pub holds only the public half. Every loader names the file and line at fault and what it
 * expected. The authorised folder (a ring) is the set of *.pub files a master lets in. */
#ifndef PRISMFARM_CURVE_H
#define PRISMFARM_CURVE_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define CURVE_Z85 40    /* a 32-byte key in Z85 text (ZeroMQ RFC 32) */
#define CURVE_BINARY 32 /* the key itself */
#define CURVE_NAME_MAX 64
#define CURVE_FILE_MAX 4096  /* bytes in a key file: anything larger is not one */
#define CURVE_RING_MAX 10000 /* keys in an authorised folder */
#define CURVE_TOKEN_CHARS 64 /* a dashboard token: 32 random bytes in lower-case hex */
#define CURVE_TOKEN_HASH 32  /* its SHA-256, as NAME.pub's http-token-sha256 line holds it */

/* A key pair in Z85, NUL-terminated. */
typedef struct curve_pair {
    char public_key[CURVE_Z85 + 1];
    char secret_key[CURVE_Z85 + 1];
} curve_pair_t;

/* 0 when libzmq can do CURVE (zmq_has("curve"): built with libsodium), else -1 naming why. */
int curve_available(err_t *err);

/* A fresh key pair (zmq_curve_keypair). */
int curve_generate(curve_pair_t *out, err_t *err);

/* A key name, as in NAME.key: 1..CURVE_NAME_MAX characters of [A-Za-z0-9._-], not starting
 * with '.' or '-' (no path, no hidden file, no option look-alike). */
int curve_name_check(const char *name, err_t *err);

/* The files curve_write wrote (token: "" without a token). */
typedef struct curve_paths {
    char key[4096], pub[4096], token[4096];
} curve_paths_t;

/* Writes dir/NAME.key (mode 0600: the pair) and dir/NAME.pub (mode 0644: the public key), each
 * opening with '#' comment lines, through a temporary file that is synced and then linked (or,
 * with overwrite, renamed) into place. With a token (curve_token_generate; may be NULL), also
 * dir/NAME.token (mode 0600: the token, for the master's dashboard, docs/dashboard.md), and
 * NAME.pub gains an "http-token-sha256 = HEX" line, the token's SHA-256 -- never the token.
 * Without overwrite an existing file is an error and nothing is written. */
int curve_write(const curve_pair_t *pair, const char *token, const char *dir, const char *name,
                bool overwrite, curve_paths_t *paths, err_t *err);

/* Reads a NAME.key: its "public-key = Z85" and "secret-key = Z85" lines ('#' comments and blank
 * lines aside). Fails when the file is readable or writable by group or others, when a line is
 * anything else, or when the public key is not the secret key's. */
int curve_load_pair(const char *path, curve_pair_t *out, err_t *err);

/* Reads the public key of a NAME.pub. A secret-key line is an error: a .pub travels between
 * hosts and must never carry a secret. An http-token-sha256 line is accepted (and ignored here);
 * a .pub without one (written before tokens existed) is as valid as ever. */
int curve_load_public(const char *path, char out[CURVE_Z85 + 1], err_t *err);
/* The same, with the token hash of the http-token-sha256 line: *has_token says whether there
 * is one (token_hash and has_token may be NULL). */
int curve_load_public_token(const char *path, char out[CURVE_Z85 + 1],
                            uint8_t token_hash[CURVE_TOKEN_HASH], bool *has_token, err_t *err);

/* A fresh dashboard token: CURVE_TOKEN_CHARS hex digits of libsodium's randombytes. */
int curve_token_generate(char token[CURVE_TOKEN_CHARS + 1]);
/* The SHA-256 of a token's len bytes: what a .pub's http-token-sha256 line holds. */
void curve_token_hash(const char *token, size_t len, uint8_t out[CURVE_TOKEN_HASH]);
/* Reads a NAME.token (the first line that is neither blank nor a '#' comment) into its hash.
 * Fails when the file is readable or writable by group or others, or holds no token. */
int curve_load_token(const char *path, uint8_t out[CURVE_TOKEN_HASH], err_t *err);

/* Whether endpoint stays on this host (inproc:// or ipc://), where plain text needs no flag. */
bool curve_endpoint_local(const char *endpoint);

/* The farm's rule for an endpoint: a network one (anything but inproc:// and ipc://) needs CURVE
 * keys (have_keys) or an explicit insecure, and not both. On refusal err says so and ends with
 * how_keys ("--key and --authorized"), the flags that give keys. */
int curve_require(const char *endpoint, bool have_keys, bool insecure, const char *how_keys,
                        err_t *err);

/* The public keys in a folder's *.pub files (hidden files and other names ignored), each named
 * by its file name without ".pub". */
typedef struct curve_ring curve_ring_t;

/* Loads dir; any unreadable or malformed .pub, or more than CURVE_RING_MAX, is an error. */
curve_ring_t *curve_ring_new(const char *dir, err_t *err);
void curve_ring_destroy(curve_ring_t **self_p);

/* Loads the folder again when it may have changed: its modification time or inode differ from
 * the last load, or force is set and the last load is at least a second old (an addition made
 * within the file system's time granularity). On failure the keys loaded before stay, and -1
 * with err says why. *reloaded (may be NULL) says whether the keys were replaced. */
int curve_ring_refresh(curve_ring_t *self, bool force, bool *reloaded, err_t *err);

/* The name of the file that holds key (32 bytes), or NULL when none does. */
const char *curve_ring_find(const curve_ring_t *self,
                                  const uint8_t key[CURVE_BINARY]);
/* The name of the file whose http-token-sha256 is token_hash, or NULL: every key is compared in
 * constant time, so the time taken does not tell which matched. */
const char *curve_ring_find_token(const curve_ring_t *self,
                                  const uint8_t token_hash[CURVE_TOKEN_HASH]);
size_t curve_ring_size(const curve_ring_t *self);
const char *curve_ring_dir(const curve_ring_t *self);

#endif
