/* zap: the master's ZeroMQ authentication handler (ZeroMQ RFC 27, ZAP). A thread answers, for
 * every CURVE server socket of its context, whether a connecting peer's public key is in the
 * authorised folder (curve.h's ring), and logs each decision with the peer's address. Without a
 * handler bound at inproc://zeromq.zap.01, libzmq 4.3 lets in any client that knows the
 * server's public key (docs/security.md, "How it works"); with this one, only listed keys, and
 * the folder is read again when it changes, so adding or removing a .pub needs no restart
 * (connections already made stay). */
#ifndef PRISMFARM_ZAP_H
#define PRISMFARM_ZAP_H

#include "err.h"

#include <stddef.h>
#include <stdint.h>

/* One line of the handler's log (no newline); called from the handler's thread. */
typedef void (*zap_log_fn)(void *user, const char *line);

typedef struct zap zap_t;

/* The authorised folders, by role (docs/security.md, "Roles"). A key is let in on the workers
 * endpoint (ZAP domain "workers") only from any or workers, on the clients endpoint ("clients")
 * only from any, clients or admins; the ZAP user id of the connection is the key's file name.
 * NULL: no such folder. any is the single --authorized folder of before roles. */
/* The role of an accepted key, as the connection's metadata property ZAP_ROLE_PROPERTY
 * (zmq_msg_gets on any message it sends; net_recv copies it into proto_peer_t.role): the
 * folder the key was found in. "any" is the single --authorized folder of before roles. */
#define ZAP_ROLE_PROPERTY "X-Role"
#define ZAP_ROLE_ANY "any"
#define ZAP_ROLE_WORKER "worker"
#define ZAP_ROLE_CLIENT "client"
#define ZAP_ROLE_ADMIN "admin"

typedef struct zap_folders {
    const char *any, *workers, *clients, *admins;
} zap_folders_t;

/* Loads the authorised folders, binds inproc://zeromq.zap.01 on zmq_ctx (one handler per
 * context) and starts the thread. Create it before binding the server sockets, and destroy it
 * after closing them: a CURVE server that finds no handler accepts every client. log may be
 * NULL. */
zap_t *zap_new(void *zmq_ctx, const zap_folders_t *folders, zap_log_fn log, void *user,
               err_t *err);

/* Stops the thread (within 100 ms) and closes its socket. */
void zap_destroy(zap_t **self_p);

typedef struct zap_stats {
    uint64_t accepted, refused; /* decisions since zap_new */
    size_t keys;                /* keys authorised now */
} zap_stats_t;

/* Safe to call from any thread. */
zap_stats_t zap_stats(zap_t *self);

#endif
