#include "proto_limits.h"

proto_limits_t proto_limits_default(void)
{
    return (proto_limits_t){.max_message_bytes = PROTO_MAX_MESSAGE_BYTES,
                            .max_bundle_files = PROTO_MAX_BUNDLE_FILES,
                            .max_bundle_bytes = PROTO_MAX_BUNDLE_BYTES};
}
