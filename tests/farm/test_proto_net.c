/* net: messages over real ZeroMQ sockets made by net/net.h. ROUTER <-> DEALER over inproc://
 * (routing ids, replies, version refusal, malformed frames, ROUTER_MANDATORY reporting an
 * unknown peer) and over tcp://127.0.0.1 (a tile result arrives bit for bit; ZMQ_MAXMSGSIZE
 * from the limits cuts off a peer that sends a larger frame). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers it needs */

#include <errno.h>
#include <string.h>
#include <zmq.h>

#include "net.h"
#include "test_wait.h"

/* How long a message already sent may take to arrive: the deadline of a wait (test_wait.h). */
#define WAIT_MS test_wait_ms()

typedef struct pair {
    void *ctx;
    net_t *router, *dealer;
} pair_t;

static void open_pair(pair_t *p, const char *endpoint, const net_options_t *router_opt,
                      const char *dealer_id)
{
    err_t err = {""};
    p->ctx = zmq_ctx_new();
    assert_non_null(p->ctx);
    p->router = net_new(p->ctx, NET_ROUTER, router_opt, &err);
    if (!p->router)
        fail_msg("%s", err.msg);
    if (net_bind(p->router, endpoint, &err) != 0)
        fail_msg("%s", err.msg);
    char bound[256];
    assert_int_equal(net_endpoint(p->router, bound, sizeof bound, &err), 0);
    net_options_t o = net_options_default();
    o.routing_id = dealer_id;
    o.send_timeout_ms = WAIT_MS;
    p->dealer = net_new(p->ctx, NET_DEALER, &o, &err);
    if (!p->dealer)
        fail_msg("%s", err.msg);
    if (net_connect(p->dealer, bound, &err) != 0)
        fail_msg("%s", err.msg);
}

static void close_pair(pair_t *p)
{
    net_destroy(&p->dealer);
    net_destroy(&p->router);
    assert_null(p->router);
    assert_int_equal(zmq_ctx_term(p->ctx), 0);
}

static void send_ok(net_t *s, const proto_peer_t *to, const proto_msg_t *m)
{
    err_t err = {""};
    int rc = net_send(s, to, m, &err);
    if (rc != 0)
        fail_msg("send %s: %d %s", proto_type_name(m->type), rc, err.msg);
}

static void recv_ok(net_t *s, proto_peer_t *from, proto_msg_t *m)
{
    err_t err = {""};
    int rc = net_recv(s, from, m, WAIT_MS, &err);
    if (rc != 0)
        fail_msg("recv: %d %s", rc, err.msg);
}

static void test_router_dealer_inproc(void **state)
{
    (void)state;
    pair_t p;
    open_pair(&p, "inproc://proto-test", NULL, "worker-7");
    proto_msg_t hello = {.type = PROTO_HELLO,
                         .hello = {.name = "node01", .threads = 8, .software = "0.1.0"}};
    send_ok(p.dealer, NULL, &hello);
    proto_peer_t from;
    proto_msg_t got;
    recv_ok(p.router, &from, &got);
    char who[PROTO_PEER_STR];
    assert_string_equal(proto_peer_str(&from, who), "worker-7");
    assert_int_equal(got.type, PROTO_HELLO);
    assert_string_equal(got.hello.name, "node01");
    assert_int_equal(got.hello.threads, 8);
    proto_msg_free(&got);

    proto_msg_t welcome = {.type = PROTO_WELCOME,
                           .welcome = {.worker_id = 3, .heartbeat_ms = 1000}};
    send_ok(p.router, &from, &welcome);
    recv_ok(p.dealer, NULL, &got);
    assert_int_equal(got.type, PROTO_WELCOME);
    assert_int_equal(got.welcome.worker_id, 3);
    proto_msg_free(&got);

    /* Nothing more is coming: a short wait times out. */
    err_t err = {""};
    assert_int_equal(net_recv(p.dealer, NULL, &got, 20, &err), PROTO_EAGAIN);
    assert_int_equal(net_recv(p.dealer, NULL, &got, 0, &err), PROTO_EAGAIN);

    /* ROUTER_MANDATORY: a message to a peer that never connected is an error, not silence. */
    proto_peer_t nobody = {.len = 6};
    memcpy(nobody.id, "nobody", 6);
    proto_msg_t hb = {.type = PROTO_HEARTBEAT};
    assert_int_equal(net_send(p.router, &nobody, &hb, &err), PROTO_EUNREACHABLE);
    assert_non_null(strstr(err.msg, "HEARTBEAT to nobody"));
    assert_non_null(strstr(err.msg, zmq_strerror(EHOSTUNREACH)));
    /* Misuse is refused too. */
    assert_int_equal(net_send(p.router, NULL, &hb, &err), PROTO_ESOCKET);
    assert_int_equal(net_send(p.dealer, &from, &hb, &err), PROTO_ESOCKET);
    /* A message that does not encode is not sent. */
    proto_msg_t bad = {.type = PROTO_HELLO, .hello = {.name = "", .threads = 1, .software = "x"}};
    assert_int_equal(net_send(p.dealer, NULL, &bad, &err), PROTO_EMALFORMED);
    assert_non_null(strstr(err.msg, "HELLO: field 'name' is empty"));
    close_pair(&p);
}

static void test_refusal_and_malformed_frames(void **state)
{
    (void)state;
    pair_t p;
    open_pair(&p, "inproc://proto-bad", NULL, "w2");
    proto_peer_t from;
    proto_msg_t got;
    err_t err = {""};

    /* A peer speaking version 4 is refused, and can read why. */
    proto_msg_t hello = {.type = PROTO_HELLO,
                         .version = 4,
                         .hello = {.name = "future", .threads = 1, .software = "9.0"}};
    send_ok(p.dealer, NULL, &hello);
    assert_int_equal(net_recv(p.router, &from, &got, WAIT_MS, &err), PROTO_EVERSION);
    char who[PROTO_PEER_STR];
    assert_string_equal(proto_peer_str(&from, who), "w2");
    assert_int_equal(got.version, 4);
    err_t text;
    proto_msg_t refuse = proto_refuse_version(got.version, "master", &text);
    send_ok(p.router, &from, &refuse);
    recv_ok(p.dealer, NULL, &got);
    assert_int_equal(got.type, PROTO_REFUSE);
    assert_string_equal(got.refuse.reason,
                        "protocol version 4 not supported by this master (speaks 3)");
    proto_msg_free(&got);

    /* Garbage bytes: an error naming the sender; the socket stays usable. */
    void *raw = net_socket(p.dealer);
    assert_int_equal(zmq_send(raw, "\xdd\x10\x00\x00\x00", 5, 0), 5);
    assert_int_equal(net_recv(p.router, &from, &got, WAIT_MS, &err), PROTO_EMALFORMED);
    assert_non_null(strstr(err.msg, "from w2: malformed msgpack"));
    /* Two frames (a REQ-style delimiter): refused as framing, and both frames consumed. */
    assert_int_equal(zmq_send(raw, "", 0, ZMQ_SNDMORE), 0);
    assert_int_equal(zmq_send(raw, "\x80", 1, 0), 1);
    assert_int_equal(net_recv(p.router, &from, &got, WAIT_MS, &err), PROTO_EMALFORMED);
    assert_non_null(strstr(err.msg, "1 frames after the message"));
    proto_msg_t hb = {.type = PROTO_HEARTBEAT};
    send_ok(p.dealer, NULL, &hb);
    recv_ok(p.router, &from, &got);
    assert_int_equal(got.type, PROTO_HEARTBEAT);
    close_pair(&p);
}

/* Incomplete CURVE options are refused before any connection (test_curve covers the keys). */
static void test_curve_incomplete(void **state)
{
    (void)state;
    void *ctx = zmq_ctx_new();
    net_options_t o = net_options_default();
    o.curve.server_public = "rq:rM>}U?@Lns47E1%kR.o@n%FcmmsL/@{H8]yf7";
    err_t err = {""};
    assert_null(net_new(ctx, NET_DEALER, &o, &err));
    assert_non_null(strstr(err.msg, "needs the server's public key and its own key pair"));
    o = net_options_default();
    o.sndhwm = -5; /* libzmq refuses it, and the message says which option */
    assert_null(net_new(ctx, NET_ROUTER, &o, &err));
    assert_non_null(strstr(err.msg, "ZMQ_SNDHWM, -5"));
    assert_int_equal(zmq_ctx_term(ctx), 0);
}

static void test_tcp_result_and_maxmsgsize(void **state)
{
    (void)state;
    /* A 16x16 tile with 8 buckets: 2048 sums and 768 XYZ sums, 22 KiB; the router accepts at
     * most 64 KiB. */
    enum { W = 16, H = 16, NB = 8, NPIX = W * H };
    static double sums[NPIX * NB], xyz[NPIX * PROTO_TILE_XYZ], lum[NPIX], lum_sq[NPIX];
    static uint64_t counts[NPIX];
    for (int i = 0; i < NPIX * NB; i++)
        sums[i] = 1.0 / (i + 1) - 0.001 * i;
    for (int i = 0; i < NPIX * PROTO_TILE_XYZ; i++)
        xyz[i] = 0.5 / (i + 1);
    for (int i = 0; i < NPIX; i++) {
        counts[i] = 64;
        lum[i] = 0.1 * i;
        lum_sq[i] = 0.01 * i * i;
    }
    net_options_t ro = net_options_default();
    ro.limits.max_message_bytes = 64 * 1024;
    pair_t p;
    open_pair(&p, "tcp://127.0.0.1:*", &ro, "tcp-worker");
    proto_msg_t res = {.type = PROTO_RESULT,
                       .result = {.job = 1,
                                  .task = 2,
                                  .attempt = 0,
                                  .kind = PROTO_KIND_CAMERA_TILE,
                                  .tile = {.rect = {0, 0, W, H, 0, 64},
                                           .nbuckets = NB,
                                           .sums = sums,
                                           .xyz = xyz,
                                           .counts = counts,
                                           .lum = lum,
                                           .lum_sq = lum_sq},
                                  .stats = {NPIX * 64, 1000, 0, 0.5}}};
    send_ok(p.dealer, NULL, &res);
    proto_peer_t from;
    proto_msg_t got;
    recv_ok(p.router, &from, &got);
    assert_int_equal(got.type, PROTO_RESULT);
    assert_memory_equal(got.result.tile.sums, sums, sizeof sums);
    assert_memory_equal(got.result.tile.counts, counts, sizeof counts);
    assert_memory_equal(got.result.tile.lum_sq, lum_sq, sizeof lum_sq);
    proto_msg_free(&got);

    /* A 100 KB file frame exceeds the router's ZMQ_MAXMSGSIZE: libzmq drops the connection, so
     * the message never arrives. The dealer connects again by itself, and what it sends then
     * does arrive: the first message the router receives after the file is one of the
     * heartbeats sent after it (one every 100 ms, as some may go down with the dropped
     * connection), never the file, however long the drop and the reconnection take. */
    static uint8_t big[100 * 1024];
    proto_msg_t file = {.type = PROTO_FILE,
                        .file = {.name = "big.bin", .data = big, .size = sizeof big}};
    send_ok(p.dealer, NULL, &file);
    err_t err = {""};
    proto_msg_t hb = {.type = PROTO_HEARTBEAT};
    int r = PROTO_EAGAIN;
    for (int sent = 0; r == PROTO_EAGAIN; sent++) {
        if (sent * 100 > WAIT_MS)
            fail_msg("no message from the reconnected dealer within %d ms", WAIT_MS);
        send_ok(p.dealer, NULL, &hb);
        r = net_recv(p.router, &from, &got, 100, &err);
    }
    if (r != 0)
        fail_msg("recv after the oversized frame: %d %s", r, err.msg);
    assert_int_equal(got.type, PROTO_HEARTBEAT);
    proto_msg_free(&got);
    close_pair(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_router_dealer_inproc),
        cmocka_unit_test(test_refusal_and_malformed_frames),
        cmocka_unit_test(test_curve_incomplete),
        cmocka_unit_test(test_tcp_result_and_maxmsgsize),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
