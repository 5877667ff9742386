#include "curve.h"

#include "clock.h"
#include "sha256.h"

#include <sodium.h>
#include <zmq.h>

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* The Z85 alphabet (ZeroMQ RFC 32). */
static const char Z85[] = "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                          ".-:+=^!/*?&<>()[]{}@%$#";

int curve_available(err_t *err)
{
    if (!zmq_has("curve"))
        return err_set(err, "this libzmq was built without CURVE (libsodium): encryption is "
                            "impossible; install a libzmq with CURVE, or run with --insecure");
    return 0;
}

int curve_generate(curve_pair_t *out, err_t *err)
{
    if (curve_available(err) < 0)
        return -1;
    if (zmq_curve_keypair(out->public_key, out->secret_key) != 0)
        return err_set(err, "zmq_curve_keypair: %s", zmq_strerror(zmq_errno()));
    return 0;
}

int curve_name_check(const char *name, err_t *err)
{
    size_t n = name ? strlen(name) : 0;
    if (n == 0 || n > CURVE_NAME_MAX)
        return err_set(err, "a key name has 1..%d characters, got %zu", CURVE_NAME_MAX, n);
    if (name[0] == '.' || name[0] == '-')
        return err_set(err, "key name '%s' starts with '%c': expected a letter, digit or '_'", name,
                       name[0]);
    for (size_t i = 0; i < n; i++) {
        char c = name[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
              c == '.' || c == '_' || c == '-'))
            return err_set(err, "key name '%.*s...' holds a character outside [A-Za-z0-9._-]",
                           (int)i, name);
    }
    return 0;
}

bool curve_endpoint_local(const char *endpoint)
{
    return endpoint &&
           (strncmp(endpoint, "inproc://", 9) == 0 || strncmp(endpoint, "ipc://", 6) == 0);
}

int curve_require(const char *endpoint, bool have_keys, bool insecure, const char *how_keys,
                        err_t *err)
{
    if (have_keys && insecure)
        return err_set(err, "--insecure and CURVE keys exclude each other: choose one");
    if (have_keys || insecure || curve_endpoint_local(endpoint))
        return 0;
    return err_set(err,
                   "%s is a network endpoint: without CURVE keys its traffic is plain text and "
                   "anyone who reaches it can connect. Give %s (docs/security.md), or --insecure "
                   "to accept plain text on a network you trust",
                   endpoint ? endpoint : "(none)", how_keys);
}

/* ---------------------------------------------------------------- reading key files */

/* memset that the compiler may not drop as a dead store (explicit_bzero is not POSIX). */
static void wipe(void *p, size_t n)
{
    volatile unsigned char *v = p;
    while (n--)
        *v++ = 0;
}

typedef struct keyfile {
    char public_key[CURVE_Z85 + 1], secret_key[CURVE_Z85 + 1];
    uint8_t token_hash[CURVE_TOKEN_HASH];
    int public_line, secret_line, token_line; /* 0: absent */
} keyfile_t;

static int hex_digit(char c)
{
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
}

/* A hash's text: exactly 2 * n lower-case hex digits into out. */
static int hex_decode(const char *v, size_t len, uint8_t *out, size_t n)
{
    if (len != 2 * n)
        return -1;
    for (size_t i = 0; i < n; i++) {
        int hi = hex_digit(v[2 * i]), lo = hex_digit(v[2 * i + 1]);
        if (hi < 0 || lo < 0)
            return -1;
        out[i] = (uint8_t)(hi << 4 | lo);
    }
    return 0;
}

/* A key's text: exactly 40 Z85 characters that decode. Values are never quoted in messages: a
 * malformed line may be a secret key. */
static int z85_check(const char *path, int line, const char *what, const char *v, size_t n,
                     err_t *err)
{
    if (n != CURVE_Z85)
        return err_set(err,
                       "%s:%d: %s has %zu characters, expected %d (Z85, as prismfarm keygen "
                       "writes it)",
                       path, line, what, n, CURVE_Z85);
    for (size_t i = 0; i < n; i++)
        if (!strchr(Z85, v[i]) || v[i] == '\0')
            return err_set(err, "%s:%d: %s has a character that is not Z85 at column %zu", path,
                           line, what, i + 1);
    char z[CURVE_Z85 + 1];
    uint8_t bin[CURVE_BINARY];
    memcpy(z, v, n);
    z[n] = 0;
    if (!zmq_z85_decode(bin, z))
        return err_set(err, "%s:%d: %s does not decode as Z85", path, line, what);
    return 0;
}

static int parse_keyfile(const char *path, const char *text, size_t size, keyfile_t *out,
                         err_t *err)
{
    memset(out, 0, sizeof *out);
    int line = 0;
    for (size_t at = 0; at < size;) {
        const char *s = text + at;
        const char *nl = memchr(s, '\n', size - at);
        size_t len = nl ? (size_t)(nl - s) : size - at;
        at += len + (nl ? 1 : 0);
        line++;
        while (len > 0 && (s[len - 1] == '\r' || s[len - 1] == ' ' || s[len - 1] == '\t'))
            len--;
        while (len > 0 && (*s == ' ' || *s == '\t'))
            s++, len--;
        if (len == 0 || *s == '#')
            continue;
        size_t name = 0;
        while (name < len && ((s[name] >= 'a' && s[name] <= 'z') || s[name] == '-' ||
                              (s[name] >= '0' && s[name] <= '9')))
            name++;
        bool is_public = name == 10 && !memcmp(s, "public-key", 10);
        bool is_secret = name == 10 && !memcmp(s, "secret-key", 10);
        bool is_token = name == 17 && !memcmp(s, "http-token-sha256", 17);
        size_t v = name;
        while (v < len && (s[v] == ' ' || s[v] == '\t'))
            v++;
        if ((!is_public && !is_secret && !is_token) || v >= len || s[v] != '=')
            return err_set(err,
                           "%s:%d: expected 'public-key = KEY', 'secret-key = KEY', "
                           "'http-token-sha256 = HASH' or a '#' comment (KEY: 40 Z85 characters, "
                           "HASH: 64 hex digits)",
                           path, line);
        v++;
        while (v < len && (s[v] == ' ' || s[v] == '\t'))
            v++;
        if (is_token) {
            if (out->token_line)
                return err_set(err, "%s:%d: a second http-token-sha256 (the first is on line %d)",
                               path, line, out->token_line);
            if (hex_decode(s + v, len - v, out->token_hash, CURVE_TOKEN_HASH) < 0)
                return err_set(err,
                               "%s:%d: http-token-sha256 is not 64 lower-case hex digits (the "
                               "SHA-256 of NAME.token, as prismfarm keygen writes it)",
                               path, line);
            out->token_line = line;
            continue;
        }
        const char *what = is_public ? "public-key" : "secret-key";
        int *seen = is_public ? &out->public_line : &out->secret_line;
        if (*seen)
            return err_set(err, "%s:%d: a second %s (the first is on line %d)", path, line, what,
                           *seen);
        if (z85_check(path, line, what, s + v, len - v, err) < 0)
            return -1;
        char *dst = is_public ? out->public_key : out->secret_key;
        memcpy(dst, s + v, CURVE_Z85);
        dst[CURVE_Z85] = 0;
        *seen = line;
    }
    return 0;
}

/* Reads the whole key file (at most CURVE_FILE_MAX bytes) and parses it; *mode gets its
 * permission bits. */
static int read_keyfile(const char *path, keyfile_t *out, mode_t *mode, err_t *err)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return err_set(err, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0) {
        int e = errno;
        close(fd);
        return err_set(err, "%s: %s", path, strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        return err_set(err, "%s: not a regular file", path);
    }
    *mode = st.st_mode & 07777;
    char text[CURVE_FILE_MAX + 1];
    size_t size = 0;
    for (;;) {
        ssize_t got = read(fd, text + size, sizeof text - size);
        if (got < 0 && errno == EINTR)
            continue;
        if (got < 0) {
            int e = errno;
            close(fd);
            return err_set(err, "%s: cannot read: %s", path, strerror(e));
        }
        if (got == 0)
            break;
        size += (size_t)got;
        if (size == sizeof text) {
            close(fd);
            return err_set(err, "%s: larger than %d bytes: not a prismfarm key file", path,
                           CURVE_FILE_MAX);
        }
    }
    close(fd);
    if (memchr(text, 0, size)) {
        wipe(text, sizeof text);
        return err_set(err, "%s: holds a NUL byte: not a prismfarm key file", path);
    }
    int rc = parse_keyfile(path, text, size, out, err);
    wipe(text, sizeof text); /* the secret key stays in one place only */
    return rc;
}

int curve_load_pair(const char *path, curve_pair_t *out, err_t *err)
{
    keyfile_t k;
    mode_t mode;
    if (read_keyfile(path, &k, &mode, err) < 0)
        return -1;
    int rc = 0;
    if (!k.secret_line)
        rc = err_set(err,
                     "%s: no 'secret-key = ...' line: expected a NAME.key made by "
                     "prismfarm keygen (NAME.pub holds only the public key)",
                     path);
    else if (!k.public_line)
        rc = err_set(err,
                     "%s: no 'public-key = ...' line: expected a NAME.key made by "
                     "prismfarm keygen",
                     path);
    /* ssh's rule for private keys: a secret others may read is no longer a secret. */
    else if (mode & 077)
        rc = err_set(err,
                     "%s: a secret key readable or writable by group or others (mode %04o): "
                     "chmod 600 %s",
                     path, (unsigned)mode, path);
    char derived[CURVE_Z85 + 1];
    if (rc == 0 && curve_available(err) < 0)
        rc = -1;
    else if (rc == 0 && zmq_curve_public(derived, k.secret_key) != 0)
        rc = err_set(err, "%s:%d: zmq_curve_public: %s", path, k.secret_line,
                     zmq_strerror(zmq_errno()));
    else if (rc == 0 && strcmp(derived, k.public_key) != 0)
        rc = err_set(err, "%s:%d: public-key is not the public half of secret-key (line %d)", path,
                     k.public_line, k.secret_line);
    if (rc == 0) {
        memcpy(out->public_key, k.public_key, sizeof out->public_key);
        memcpy(out->secret_key, k.secret_key, sizeof out->secret_key);
    }
    wipe(&k, sizeof k);
    return rc;
}

int curve_load_public_token(const char *path, char out[CURVE_Z85 + 1],
                            uint8_t token_hash[CURVE_TOKEN_HASH], bool *has_token, err_t *err)
{
    keyfile_t k;
    mode_t mode;
    if (read_keyfile(path, &k, &mode, err) < 0)
        return -1;
    int secret = k.secret_line, has_public = k.public_line;
    if (has_public)
        memcpy(out, k.public_key, CURVE_Z85 + 1);
    if (has_token)
        *has_token = k.token_line > 0;
    if (token_hash)
        memcpy(token_hash, k.token_hash, CURVE_TOKEN_HASH);
    wipe(&k, sizeof k);
    if (secret)
        return err_set(err,
                       "%s:%d: a secret key: a public key file must hold only "
                       "'public-key = ...' (copy NAME.pub, never NAME.key)",
                       path, secret);
    if (!has_public)
        return err_set(err,
                       "%s: no 'public-key = ...' line: expected a NAME.pub made by "
                       "prismfarm keygen",
                       path);
    return 0;
}

int curve_load_public(const char *path, char out[CURVE_Z85 + 1], err_t *err)
{
    return curve_load_public_token(path, out, NULL, NULL, err);
}

/* ---------------------------------------------------------------- HTTP tokens */

int curve_token_generate(char token[CURVE_TOKEN_CHARS + 1])
{
    uint8_t raw[CURVE_TOKEN_CHARS / 2];
    randombytes_buf(raw, sizeof raw);
    static const char hex[] = "0123456789abcdef";
    for (size_t i = 0; i < sizeof raw; i++) {
        token[2 * i] = hex[raw[i] >> 4];
        token[2 * i + 1] = hex[raw[i] & 15];
    }
    token[CURVE_TOKEN_CHARS] = 0;
    wipe(raw, sizeof raw);
    return 0;
}

void curve_token_hash(const char *token, size_t len, uint8_t out[CURVE_TOKEN_HASH])
{
    sha256_t h;
    sha256_init(&h);
    sha256_update(&h, token, len);
    sha256_final(&h, out);
}

int curve_load_token(const char *path, uint8_t out[CURVE_TOKEN_HASH], err_t *err)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return err_set(err, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return err_set(err, "%s: not a regular file", path);
    }
    if (st.st_mode & 077) {
        close(fd);
        return err_set(err,
                       "%s: a token readable or writable by group or others (mode %04o): chmod "
                       "600 %s",
                       path, (unsigned)(st.st_mode & 07777), path);
    }
    char text[CURVE_FILE_MAX + 1];
    size_t size = 0;
    for (;;) {
        ssize_t got = read(fd, text + size, sizeof text - 1 - size);
        if (got < 0 && errno == EINTR)
            continue;
        if (got <= 0 || (size += (size_t)got) == sizeof text - 1)
            break;
    }
    close(fd);
    /* The token is the file's first line that is neither blank nor a '#' comment. */
    int rc = err_set(err, "%s: no token: expected the %d hex digits prismfarm keygen writes",
                     path, CURVE_TOKEN_CHARS);
    for (size_t at = 0; at < size;) {
        const char *s = text + at;
        const char *nl = memchr(s, '\n', size - at);
        size_t len = nl ? (size_t)(nl - s) : size - at;
        at += len + (nl ? 1 : 0);
        while (len > 0 && (s[len - 1] == '\r' || s[len - 1] == ' ' || s[len - 1] == '\t'))
            len--;
        while (len > 0 && (*s == ' ' || *s == '\t'))
            s++, len--;
        if (len == 0 || *s == '#')
            continue;
        uint8_t raw[CURVE_TOKEN_CHARS / 2];
        if (hex_decode(s, len, raw, sizeof raw) < 0)
            rc = err_set(err, "%s: the token is not %d lower-case hex digits", path,
                         CURVE_TOKEN_CHARS);
        else {
            curve_token_hash(s, len, out);
            rc = 0;
        }
        wipe(raw, sizeof raw);
        break;
    }
    wipe(text, sizeof text);
    return rc;
}

/* ---------------------------------------------------------------- writing key files */

/* Writes text to a temporary file in dir with the given mode, syncs it, and links it at final
 * (renames it there with overwrite). */
static int write_file(const char *dir, const char *final, const char *text, mode_t mode,
                      bool overwrite, err_t *err)
{
    char tmp[PATH_MAX];
    if (snprintf(tmp, sizeof tmp, "%s/.keygen-XXXXXX", dir) >= (int)sizeof tmp)
        return err_set(err, "%s: path too long", dir);
    int fd = mkstemp(tmp); /* mode 0600 from the start: the secret is never exposed */
    if (fd < 0)
        return err_set(err, "cannot create a file in %s: %s", dir, strerror(errno));
    size_t n = strlen(text), done = 0;
    int rc = 0;
    while (done < n && rc == 0) {
        ssize_t w = write(fd, text + done, n - done);
        if (w < 0 && errno != EINTR)
            rc = err_set(err, "cannot write %s: %s", tmp, strerror(errno));
        else if (w > 0)
            done += (size_t)w;
    }
    if (rc == 0 && fchmod(fd, mode) != 0)
        rc = err_set(err, "cannot set the mode of %s: %s", tmp, strerror(errno));
    if (rc == 0 && fsync(fd) != 0)
        rc = err_set(err, "cannot sync %s: %s", tmp, strerror(errno));
    if (close(fd) != 0 && rc == 0)
        rc = err_set(err, "cannot close %s: %s", tmp, strerror(errno));
    if (rc == 0 && overwrite && rename(tmp, final) != 0)
        rc = err_set(err, "cannot rename %s to %s: %s", tmp, final, strerror(errno));
    if (rc == 0 && !overwrite && link(tmp, final) != 0)
        rc = errno == EEXIST ? err_set(err, "%s exists: not overwritten", final)
                             : err_set(err, "cannot create %s: %s", final, strerror(errno));
    if (rc < 0 || !overwrite)
        (void)unlink(tmp); /* the link (or nothing) remains */
    return rc;
}

int curve_write(const curve_pair_t *pair, const char *token, const char *dir, const char *name,
                bool overwrite, curve_paths_t *paths, err_t *err)
{
    if (curve_name_check(name, err) < 0)
        return -1;
    char *key_path = paths->key, *pub_path = paths->pub, *token_path = paths->token;
    size_t size = sizeof paths->key;
    token_path[0] = 0;
    if (snprintf(key_path, size, "%s/%s.key", dir, name) >= (int)size ||
        snprintf(pub_path, size, "%s/%s.pub", dir, name) >= (int)size ||
        (token && snprintf(token_path, size, "%s/%s.token", dir, name) >= (int)size))
        return err_set(err, "%s/%s.key: path too long", dir, name);
    struct stat st;
    if (!overwrite) {
        /* All checked first, so that a refusal writes nothing. */
        if (lstat(key_path, &st) == 0)
            return err_set(err,
                           "%s exists: not overwritten (--force replaces the pair, and "
                           "locks out this host until its new .pub is authorised)",
                           key_path);
        if (lstat(pub_path, &st) == 0)
            return err_set(err, "%s exists: not overwritten (--force replaces the pair)", pub_path);
        if (token && lstat(token_path, &st) == 0)
            return err_set(err, "%s exists: not overwritten (--force replaces it)", token_path);
    }
    char text[1024];
    snprintf(text, sizeof text,
             "# prismfarm CURVE key pair '%s' (prismfarm keygen). The secret key never leaves\n"
             "# this host and this file stays mode 0600; hand out %s.pub instead.\n"
             "public-key = %s\n"
             "secret-key = %s\n",
             name, name, pair->public_key, pair->secret_key);
    int rc = write_file(dir, key_path, text, 0600, overwrite, err);
    wipe(text, sizeof text);
    if (rc < 0)
        return -1;
    char token_line[128] = "";
    if (token) {
        /* Only the token's hash goes into the .pub: the master that reads it can tell the token
         * when it is shown but holds nothing that would let it (or a thief) present it. */
        uint8_t hash[CURVE_TOKEN_HASH];
        char hex[SHA256_HEX_CHARS + 1];
        curve_token_hash(token, strlen(token), hash);
        sha256_hex(hash, hex);
        snprintf(token_line, sizeof token_line, "http-token-sha256 = %s\n", hex);
        snprintf(text, sizeof text,
                 "# prismfarm dashboard token of '%s' (prismfarm keygen): send it as\n"
                 "# 'Authorization: Bearer TOKEN' to act on the master's dashboard. Mode 0600.\n"
                 "%s\n",
                 name, token);
        rc = write_file(dir, token_path, text, 0600, overwrite, err);
        wipe(text, sizeof text);
        if (rc < 0) {
            if (!overwrite)
                (void)unlink(key_path);
            return -1;
        }
    }
    snprintf(text, sizeof text,
             "# prismfarm CURVE public key '%s' (prismfarm keygen). Copy it into the master's\n"
             "# --authorized folder, or give it to workers and clients as --master-key when\n"
             "# '%s' is the master.\n"
             "public-key = %s\n%s",
             name, name, pair->public_key, token_line);
    if (write_file(dir, pub_path, text, 0644, overwrite, err) < 0) {
        if (!overwrite) {
            (void)unlink(key_path); /* no half pair left behind */
            if (token)
                (void)unlink(token_path);
        }
        return -1;
    }
    return 0;
}

/* ---------------------------------------------------------------- the authorised folder */

typedef struct ring_key {
    uint8_t key[CURVE_BINARY];
    char name[CURVE_NAME_MAX + 1];
    bool has_token;
    uint8_t token_hash[CURVE_TOKEN_HASH];
} ring_key_t;

struct curve_ring {
    char *dir;
    ring_key_t *keys;
    size_t n;
    dev_t dev;
    ino_t ino;
    struct timespec mtime;
    double loaded_at; /* monotonic seconds of the last attempt */
    bool failed;      /* the last attempt failed: not tried again within a second */
};

/* Reads every *.pub of dir into *keys (allocated) and the folder's identity into st. */
static int ring_load(const char *dir, ring_key_t **keys, size_t *n, struct stat *st, err_t *err)
{
    *keys = NULL;
    *n = 0;
    DIR *d = opendir(dir);
    if (!d)
        return err_set(err, "authorised keys: cannot open the folder %s: %s", dir, strerror(errno));
    if (fstat(dirfd(d), st) != 0) {
        int e = errno;
        closedir(d);
        return err_set(err, "authorised keys: %s: %s", dir, strerror(e));
    }
    size_t cap = 0;
    int rc = 0;
    struct dirent *e;
    errno = 0;
    while (rc == 0 && (e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (e->d_name[0] == '.' || len <= 4 || strcmp(e->d_name + len - 4, ".pub") != 0)
            continue;
        char name[256], path[PATH_MAX];
        snprintf(name, sizeof name, "%.*s", (int)(len - 4), e->d_name);
        if (curve_name_check(name, err) < 0) {
            rc = err_prefix(err, "authorised keys: %s/%s: ", dir, e->d_name);
            break;
        }
        if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) >= (int)sizeof path) {
            rc = err_set(err, "authorised keys: %s/%s: path too long", dir, e->d_name);
            break;
        }
        if (*n == CURVE_RING_MAX) {
            rc = err_set(err, "authorised keys: %s holds more than %d .pub files", dir,
                         CURVE_RING_MAX);
            break;
        }
        char z85[CURVE_Z85 + 1];
        uint8_t token_hash[CURVE_TOKEN_HASH];
        bool has_token;
        if (curve_load_public_token(path, z85, token_hash, &has_token, err) < 0) {
            rc = err_prefix(err, "authorised keys: ");
            break;
        }
        if (*n == cap) {
            cap = cap ? 2 * cap : 16;
            ring_key_t *p = realloc(*keys, cap * sizeof *p);
            if (!p) {
                rc = err_set(err, "authorised keys: out of memory");
                break;
            }
            *keys = p;
        }
        ring_key_t *k = &(*keys)[(*n)++];
        if (!zmq_z85_decode(k->key, z85)) { /* checked by the loader: cannot fail */
            rc = err_set(err, "authorised keys: %s: bad Z85", path);
            break;
        }
        memcpy(k->name, name, strlen(name) + 1); /* name_check: at most CURVE_NAME_MAX */
        k->has_token = has_token;
        memcpy(k->token_hash, token_hash, sizeof token_hash);
        errno = 0;
    }
    if (rc == 0 && errno != 0)
        rc = err_set(err, "authorised keys: reading %s: %s", dir, strerror(errno));
    closedir(d);
    if (rc < 0) {
        free(*keys);
        *keys = NULL;
        *n = 0;
    }
    return rc;
}

curve_ring_t *curve_ring_new(const char *dir, err_t *err)
{
    curve_ring_t *self = calloc(1, sizeof *self);
    size_t n = dir ? strlen(dir) + 1 : 0;
    if (!self || !dir || !(self->dir = malloc(n))) {
        free(self);
        err_set(err, dir ? "authorised keys: out of memory" : "authorised keys: no folder given");
        return NULL;
    }
    memcpy(self->dir, dir, n);
    struct stat st;
    if (ring_load(dir, &self->keys, &self->n, &st, err) < 0) {
        curve_ring_destroy(&self);
        return NULL;
    }
    self->dev = st.st_dev;
    self->ino = st.st_ino;
    self->mtime = st.st_mtim;
    self->loaded_at = clock_now_s();
    return self;
}

void curve_ring_destroy(curve_ring_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    curve_ring_t *self = *self_p;
    free(self->keys);
    free(self->dir);
    free(self);
    *self_p = NULL;
}

int curve_ring_refresh(curve_ring_t *self, bool force, bool *reloaded, err_t *err)
{
    if (reloaded)
        *reloaded = false;
    struct stat st;
    if (stat(self->dir, &st) != 0)
        return err_set(err, "authorised keys: %s: %s (keeping the %zu keys loaded before)",
                       self->dir, strerror(errno), self->n);
    bool changed = st.st_dev != self->dev || st.st_ino != self->ino ||
                   st.st_mtim.tv_sec != self->mtime.tv_sec ||
                   st.st_mtim.tv_nsec != self->mtime.tv_nsec;
    double now = clock_now_s();
    bool due = now - self->loaded_at >= 1.0;
    if (!(changed && (due || !self->failed)) && !(force && due))
        return 0;
    ring_key_t *keys;
    size_t n;
    self->loaded_at = now;
    self->failed = ring_load(self->dir, &keys, &n, &st, err) < 0;
    if (self->failed)
        return err_prefix(err, "(keeping the %zu keys loaded before) ", self->n);
    free(self->keys);
    self->keys = keys;
    self->n = n;
    self->dev = st.st_dev;
    self->ino = st.st_ino;
    self->mtime = st.st_mtim;
    if (reloaded)
        *reloaded = true;
    return 0;
}

const char *curve_ring_find(const curve_ring_t *self,
                                  const uint8_t key[CURVE_BINARY])
{
    for (size_t i = 0; i < self->n; i++)
        if (memcmp(self->keys[i].key, key, CURVE_BINARY) == 0)
            return self->keys[i].name;
    return NULL;
}

const char *curve_ring_find_token(const curve_ring_t *self,
                                  const uint8_t token_hash[CURVE_TOKEN_HASH])
{
    /* Every key compared, in constant time each: how long it takes says nothing about which
     * (or whether one) matched. */
    const char *found = NULL;
    for (size_t i = 0; i < self->n; i++) {
        int same = sodium_memcmp(self->keys[i].token_hash, token_hash, CURVE_TOKEN_HASH) == 0;
        if (same && self->keys[i].has_token && !found)
            found = self->keys[i].name;
    }
    return found;
}

size_t curve_ring_size(const curve_ring_t *self)
{
    return self->n;
}

const char *curve_ring_dir(const curve_ring_t *self)
{
    return self->dir;
}
