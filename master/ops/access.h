/* access: who may act on a job, and the audit log of what each key did (issue 16, item 11;
 * docs/security.md, "Rights"). One rule, used by every request that touches a job's outputs or
 * its course (fetch, cancel, refine; the dashboard's actions): a job's owner is the name of the
 * key that submitted it (job_t.owner); only that key or an admin key (--authorized-admins)
 * may act on it. Without keys (inproc, --insecure) every client is the same anonymous user,
 * owner "", and may act on every job submitted without keys. Listing jobs and their progress
 * (JOBS, STATUS) is open to every client: the owner is shown, the pixels are not. */
#ifndef PRISMFARM_ACCESS_H
#define PRISMFARM_ACCESS_H

#include "master_state.h"

#include <stdbool.h>
#include <stddef.h>

/* The rule itself: user (a key's name, "" without keys) may act on a job owned by owner. */
bool access_allowed(const char *owner, const char *user, bool admin);

/* Whether the connection's key is an admin's (zap.h's role, from the folder it is in). */
bool access_peer_is_admin(const proto_peer_t *who);

/* access_allowed for a client request on job j. When refused: logs the refusal with the key's
 * name and the action ("fetch", "cancel" ...), writes the reply for the client into why, and
 * returns false. */
bool access_check(master_t *m, const job_t *j, const proto_peer_t *who, const char *action,
                  char *why, size_t size);

/* One line of the audit log: "client KEY (connection): what". Every action on a job and
 * every refusal goes through it, so that the log names the key, not only the connection. */
__attribute__((format(printf, 3, 4))) void access_audit(master_t *m, const proto_peer_t *who,
                                                        const char *fmt, ...);

#endif
