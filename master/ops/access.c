#include "access.h"

#include "zap.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

bool access_allowed(const char *owner, const char *user, bool admin)
{
    /* An empty user is a connection without keys: on a keyed master there is none (the ZAP
     * handler names every key it lets in), so "" meets "" only on a master without keys. */
    return admin || strcmp(owner, user) == 0;
}

bool access_peer_is_admin(const proto_peer_t *who)
{
    return who->user[0] && strcmp(who->role, ZAP_ROLE_ADMIN) == 0;
}

bool access_check(master_t *m, const job_t *j, const proto_peer_t *who, const char *action,
                  char *why, size_t size)
{
    if (access_allowed(j->owner, who->user, access_peer_is_admin(who)))
        return true;
    const char *owner = j->owner[0] ? j->owner : "nobody (it was submitted without keys)";
    snprintf(why, size,
             "job %llu belongs to %s%s%s: only its owner or an admin (--authorized-admins) may "
             "%s it",
             (unsigned long long)j->id, j->owner[0] ? "'" : "", owner, j->owner[0] ? "'" : "",
             action);
    access_audit(m, who, "refused to %s job %llu: it belongs to %s%s%s", action,
                 (unsigned long long)j->id, j->owner[0] ? "'" : "", owner, j->owner[0] ? "'" : "");
    return false;
}

void access_audit(master_t *m, const proto_peer_t *who, const char *fmt, ...)
{
    char what[768], peer[PROTO_PEER_STR];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    proto_peer_str(who, peer);
    master_log(m, "client %s%s: %s", peer, access_peer_is_admin(who) ? " [admin]" : "", what);
}
