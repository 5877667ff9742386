/* proto_limits: the protocol's bounds, which the codec (proto.h) and the bundles (bundle.h)
 * both enforce: the fixed ones, which no message may exceed, and the limits a caller sets in
 * proto_limits_t. It sits below both modules so that neither needs the other's header; it
 * depends on nothing. Every bound is documented in docs/protocol.md, "Decoding untrusted bytes". */
#ifndef PRISMFARM_PROTO_LIMITS_H
#define PRISMFARM_PROTO_LIMITS_H

#include <stddef.h>

/* Fixed bounds of the decoder. */
#define PROTO_MAX_DEPTH 16           /* msgpack nesting depth */
#define PROTO_MAX_MAP_ENTRIES 256    /* entries in any map (messages have ~20 fields) */
#define PROTO_MAX_OBJECTS (1 << 22)  /* msgpack objects in one message (msgpack-c: 24 B each) */
#define PROTO_MAX_STRING 4096        /* bytes in any string (names, paths, error texts) */
#define PROTO_MAX_LIST 100000        /* entries in any list (jobs, workers) */
#define PROTO_MAX_TILE_SIDE 4096     /* tile width and height */
#define PROTO_MAX_BUCKETS 4096       /* buckets of a tile: 4 Stokes planes of 1024 */
#define PROTO_MAX_IMAGE_SIDE 65536   /* image resolution and tile corner coordinates */
#define PROTO_MAX_THREADS 4096       /* worker threads */
#define PROTO_MAX_WAIT_MS 60000      /* longest STATUS long-poll (client timeouts are longer) */
#define PROTO_MAX_PATH_DEPTH 32      /* components of a bundle path */
#define PROTO_MAX_PATH_COMPONENT 200 /* bytes in one component (leaves room under NAME_MAX) */
#define PROTO_HASH_HEX 64            /* a scene hash: lower-case hex SHA-256 */
#define PROTO_MAX_FRAMES 10000      /* frames of a sequence job (SUBMIT's frames) */
#define PROTO_MAX_TIME_LIMIT 31536000.0 /* a job's time limit, seconds (a year) */

/* Defaults of the caller-configurable limits (proto_limits_t). */
#define PROTO_MAX_BUNDLE_FILES 4096
#define PROTO_MAX_BUNDLE_BYTES ((size_t)512 << 20)
#define PROTO_MAX_MESSAGE_BYTES (PROTO_MAX_BUNDLE_BYTES + ((size_t)16 << 20))

typedef struct proto_limits {
    size_t max_message_bytes; /* a whole encoded message; also ZMQ_MAXMSGSIZE in net.h */
    size_t max_bundle_files;  /* files in a scene bundle */
    size_t max_bundle_bytes;  /* sum of the sizes of a bundle's files */
} proto_limits_t;

/* PROTO_MAX_MESSAGE_BYTES, PROTO_MAX_BUNDLE_FILES, PROTO_MAX_BUNDLE_BYTES. */
proto_limits_t proto_limits_default(void);

#endif
