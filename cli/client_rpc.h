/* client_rpc: one request to the master's client endpoint and its reply, for the `prismfarm`
 * commands that talk to a master (submit, status, jobs, workers, fetch, cancel). */
#ifndef PRISMFARM_CLIENT_RPC_H
#define PRISMFARM_CLIENT_RPC_H

#include "curve.h"
#include "err.h"
#include "proto.h"

/* The endpoint used when --master is not given: $PRISMFARM_MASTER, else tcp://127.0.0.1:5556. */
const char *client_default_master(void);

/* How a client (or worker) secures its link to the master (docs/security.md): its own key pair
 * and the master's public key, or plain text by explicit choice (the options --key, --master-key
 * and --insecure: cli_args.h's CLI_SECURITY_OPTS). */
typedef struct client_security {
    const char *key_file;        /* NAME.key: our key pair (prismfarm keygen) */
    const char *master_key_file; /* the master's NAME.pub */
    int insecure;                /* plain text over tcp:// */
    int keys_from_flags;         /* --key or --master-key was given (not only the environment) */
} client_security_t;

/* $PRISMFARM_KEY and $PRISMFARM_MASTER_KEY when set and not empty; not insecure. */
client_security_t client_security_default(void);

/* Loads the keys sec names into *curve (pointing into *pair), after the farm's rule for endpoint
 * (curve.h's curve_require). --insecure discards keys that came from the environment only;
 * with keys from flags it is an error. Also used by `prismfarm worker`. */
int client_security_load(const client_security_t *sec, const char *endpoint,
                         curve_pair_t *pair, char master_public[CURVE_Z85 + 1],
                         int *use_curve, err_t *err);

typedef struct client_rpc client_rpc_t;

/* The one "no master" rule: every command that needs its master now (submit, fetch, refine,
 * jobs, status, workers, cancel and the operations) calls this first. A tcp:// endpoint where
 * nothing listens (the host refuses the connection) is waited for -- a master starting or
 * restarting refuses for a moment -- for up to wait_s seconds (the command's --timeout), never
 * more than CLIENT_RPC_LISTEN_WAIT_S, saying at once on stderr that it waits ("prismfarm CMD:
 * nothing listens at ... yet", when cmd is not NULL); then it is an error with the same message
 * for every command. A bad port or a host that does not resolve is an error at once.
 * `status --wait` skips it: it follows a job through master restarts on its own. */
#define CLIENT_RPC_LISTEN_WAIT_S 10.0
int client_rpc_probe(const char *endpoint, double wait_s, const char *cmd, err_t *err);

/* A connection to the master at endpoint; ctx NULL makes one. sec NULL: no keys (plain text,
 * allowed only on inproc:// and ipc://). */
client_rpc_t *client_rpc_new(const char *endpoint, void *zmq_ctx, const client_security_t *sec,
                             err_t *err);
void client_rpc_destroy(client_rpc_t **self_p);

/* Called with each PROGRESS the master sends while it works on a request (docs/protocol.md):
 * what it is doing and for how long. */
typedef void (*client_rpc_progress_fn)(void *user, const char *message, double elapsed_s);
/* Without a callback a PROGRESS only restarts the wait. */
void client_rpc_on_progress(client_rpc_t *self, client_rpc_progress_fn fn, void *user);

/* Sends req and waits up to timeout_ms for the reply (free it with proto_msg_free). An ERROR or
 * REFUSE reply becomes -1 with its text in err; so does at once a refused handshake ("the
 * master at ENDPOINT refused our key ..."). A PROGRESS restarts the wait (the master answers
 * when its work is done: timeout_ms bounds silence, not work). Silence ("no answer from the master at ENDPOINT
 * within 10 s: is it running?") and a dropped connection (a master restarting) return
 * CLIENT_RPC_UNREACHABLE with the text in err: worth asking again after client_rpc_reconnect. */
#define CLIENT_RPC_UNREACHABLE (-2)
int client_rpc_call(client_rpc_t *self, const proto_msg_t *req, proto_msg_t *reply, int timeout_ms,
                    err_t *err);

/* A fresh connection to the same master, with the same keys: whatever the old one still held
 * (a request sent to a master that died, a late answer) is dropped with it. */
int client_rpc_reconnect(client_rpc_t *self, err_t *err);

#endif
